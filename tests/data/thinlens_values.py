# Reference values of Mitsuba 3.9.1's thinlens and perspective sensors for pir's unit tests.
import mitsuba as mi
mi.set_variant('scalar_rgb')
T = mi.ScalarTransform4f
def sensor(kind, w, h, **kw):
    d = {'type': kind, 'film': {'type': 'hdrfilm', 'width': w, 'height': h},
         'to_world': T().look_at(origin=[1, 2, 3], target=[0.5, 1.5, -2], up=[0.1, 1, 0])}
    d.update(kw)
    return mi.load_dict(d)
s = sensor('thinlens', 64, 48, fov=40, aperture_radius=0.25, focus_distance=4.0, near_clip=0.1, far_clip=50.0)
for pos, ap in [((0.3, 0.7), (0.2, 0.9)), ((0.95, 0.05), (0.5, 0.5)), ((0.5, 0.5), (0.8, 0.1)), ((0.1, 0.4), (0.05, 0.6)), ((0.0, 1.0), (0.99, 0.3))]:
    ray, _ = s.sample_ray(0.0, 0.5, mi.Point2f(pos), mi.Point2f(ap))
    print('thin', pos, ap, list(ray.o), list(ray.d), ray.maxt)
p = sensor('perspective', 64, 48, fov=40, near_clip=0.1, far_clip=50.0)
for pos in [(0.3, 0.7), (0.95, 0.05)]:
    ray, _ = p.sample_ray(0.0, 0.5, mi.Point2f(pos), mi.Point2f(0.5, 0.5))
    print('persp', pos, list(ray.o), list(ray.d), ray.maxt)
for (w, h) in [(64, 48), (48, 64), (50, 50)]:
    for kw in [dict(fov=40), dict(fov=40, fov_axis='y'), dict(fov=40, fov_axis='diagonal'), dict(fov=40, fov_axis='smaller'), dict(fov=40, fov_axis='larger'), dict(focal_length='35mm'), dict()]:
        x = mi.traverse(sensor('perspective', w, h, **kw))['x_fov']
        print('xfov', w, h, kw, repr(float(x[0] if hasattr(x, '__len__') else x)))
p = sensor('perspective', 64, 48, fov=40, principal_point_offset_x=0.1, principal_point_offset_y=-0.05)
for pos in [(0.3, 0.7), (0.95, 0.05)]:
    ray, _ = p.sample_ray(0.0, 0.5, mi.Point2f(pos), mi.Point2f(0.5, 0.5))
    print('ppo', pos, list(ray.o), list(ray.d), ray.maxt)
