"""Mitsuba 3 references of this folder's emitter scenes (64x36, 16,384 spp in 4 chunks of
4,096, seeds 0-3, llvm_ad_rgb), written as NAME-64x36.exr beside them; prints each mean.

    /work/mitsuba-venv/bin/python tests/data/emitters/refs.py [NAME ...]
"""
import os
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_rgb")
HERE = os.path.dirname(os.path.abspath(__file__))
NAMES = sys.argv[1:] or ["point", "spot", "directional", "constant", "envmap", "envmap-hdr", "textured-area"]
for name in NAMES:
    scene = mi.load_file(os.path.join(HERE, name + ".xml"))
    img = sum(np.array(mi.render(scene, spp=4096, seed=k), dtype=np.float64) for k in range(4)) / 4
    mi.Bitmap(img.astype(np.float32)).write(os.path.join(HERE, name + "-64x36.exr"))
    print(name, " ".join("%.6f" % m for m in img.reshape(-1, 3).mean(axis=0)), flush=True)
