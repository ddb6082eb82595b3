# A 48x24 sky: a blue gradient, a dark ground, and a small bright sun.
import numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
W, H = 48, 24
img = np.zeros((H, W, 3), np.float32)
for y in range(H):
    t = (y + 0.5) / H
    for x in range(W):
        if t < 0.5:
            img[y, x] = [0.3 + 0.4 * t, 0.5 + 0.4 * t, 1.0]
        else:
            img[y, x] = [0.15, 0.12, 0.1]
img[6:8, 10:12] = [40.0, 36.0, 30.0]
mi.Bitmap(img).write('__import__("os").path.join(__import__("os").path.dirname(__import__("os").path.abspath(__file__)), "sky.exr")')
