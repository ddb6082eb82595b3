"""Makes the textures of scene.xml and its Mitsuba 3 reference (see ../README.md).

    /work/mitsuba-venv/bin/python make.py textures   # normal.png, height.png, opacity.png, rough.png
    /work/mitsuba-venv/bin/python make.py reference  # ../mitsuba-shading-maps-64x48.exr
"""
import sys

import mitsuba as mi
import numpy as np


def textures():
    # Normals tilted by up to ~30° in bands along u and rings: 2·rgb − 1, 8-bit, raw.
    h, w = 32, 32
    v, u = np.mgrid[0:h, 0:w] + 0.5
    ax = 0.55 * np.sin(2 * np.pi * u / 8)
    ay = 0.35 * np.cos(2 * np.pi * (u + v) / 16)
    n = np.stack([ax, ay, np.ones_like(ax)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    rgb = np.round((n * 0.5 + 0.5) * 255).astype(np.uint8)
    mi.Bitmap(rgb, mi.Bitmap.PixelFormat.RGB).write('normal.png')
    # Heights: bumps, one channel.
    hgt = 0.5 + 0.5 * np.sin(2 * np.pi * u / 6) * np.sin(2 * np.pi * v / 6)
    mi.Bitmap(np.round(hgt * 255).astype(np.uint8)[..., None], mi.Bitmap.PixelFormat.Y).write('height.png')
    # Opacity: a grey ramp and holes, one channel.
    op = np.clip(u / w + 0.4 * ((u // 4 + v // 4) % 2) - 0.2, 0, 1)
    mi.Bitmap(np.round(op * 255).astype(np.uint8)[..., None], mi.Bitmap.PixelFormat.Y).write('opacity.png')
    # An RGB pattern for a conductor's specular reflectance and alpha.
    r = np.stack([0.5 + 0.4 * np.sin(u / 3), 0.6 + 0.3 * np.cos(v / 4), 0.7 + 0.2 * np.sin((u + v) / 5)], -1)
    mi.Bitmap(np.round(r * 255).astype(np.uint8), mi.Bitmap.PixelFormat.RGB).write('rough.png')


def reference():
    mi.set_variant('llvm_ad_rgb')
    s = mi.load_file('scene.xml')
    img = sum(np.array(mi.render(s, spp=1024, seed=k), dtype=np.float64) for k in range(16)) / 16
    mi.util.write_bitmap('../mitsuba-shading-maps-64x48.exr', mi.TensorXf(img.astype(np.float32)))
    print('mean RGB', img.reshape(-1, img.shape[-1])[:, :3].mean(0))


{'textures': textures, 'reference': reference}[sys.argv[1]]()
