"""Mitsuba 3's reference of mitsuba-thinlens.xml (64×48, 16,384 spp in 16 chunks of 1,024,
seeds 0–15, averaged in float64), and the relative MSE of Mitsuba's own renders at 64 and 256
spp (seeds 100–107, mean over the seeds) against it, by pir's definition
(mean of (x − r)² / (r² + 0.01) over pixels and channels).

    /work/mitsuba-venv/bin/python tests/data/thinlens_ref.py  # from the repository's root
"""
import mitsuba as mi
import numpy as np

mi.set_variant('llvm_ad_rgb')
scene = mi.load_file('tests/data/mitsuba-thinlens.xml')
ref = sum(np.array(mi.render(scene, spp=1024, seed=k), dtype=np.float64) for k in range(16)) / 16
mi.util.write_bitmap('tests/data/mitsuba-thinlens-64x48.exr', mi.TensorXf(ref.astype(np.float32)))
ref = ref.astype(np.float32).astype(np.float64)
print('mean RGB', ref.mean(axis=(0, 1)))
for spp in (64, 256):
    errs = []
    for seed in range(100, 108):
        img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
        errs.append(np.mean((img - ref) ** 2 / (ref ** 2 + 0.01)))
    print(f'{spp} spp: relative MSE {np.mean(errs):.4e} (seeds 100-107: {min(errs):.4e} to {max(errs):.4e})')
