//! Analytic spheres beside any triangle backend: [`WithSpheres`] answers the queries of its
//! triangle backend and of a short list of spheres together, so that every backend (Embree,
//! the BVH, brute force) sees the same spheres through the same intersection code
//! ([`Sphere::intersect`]), with no sphere geometry in Embree's scene (whose primitives differ
//! between Embree 3 and 4).
//!
//! The spheres are tested one after another for every ray: a scene holds few of them
//! (Mitsuba's `sphere` shapes: lights, glass and metal balls), and the scene keeps at most
//! [`MAX_SPHERES`] analytic, tessellating the rest. Sphere `k` is primitive `first + k`, after
//! the triangles; its hit's `u, v` are the octahedral encoding of the direction from its
//! centre ([`octahedral_encode`]), which [`crate::scene::Scene::surface_at`] turns back into
//! the point.

use super::{Accelerator, Hit};
use crate::geometry::{Aabb, Ray, Sphere, octahedral_encode};
use glam::Vec3;

/// The most spheres a scene keeps analytic: each costs every ray one test.
pub const MAX_SPHERES: usize = 64;

/// A triangle backend and analytic spheres.
pub struct WithSpheres<'a> {
    triangles: Box<dyn Accelerator + 'a>,
    spheres: Vec<Sphere>,
    /// The box around every sphere, grown by a margin of 10⁻⁴ of its size and of 16 ulps of
    /// its largest coordinate, so that rounding never culls a sphere the exact test hits
    /// (small and far from the origin included): a ray that misses it misses them all.
    bounds: Aabb,
    /// The primitive index of the first sphere (the triangle count).
    first: u32,
}

impl<'a> WithSpheres<'a> {
    pub fn new(triangles: Box<dyn Accelerator + 'a>, spheres: Vec<Sphere>, first: u32) -> Self {
        let exact = spheres.iter().fold(Aabb::EMPTY, |b, s| {
            b.grow(s.center - Vec3::splat(s.radius)).grow(s.center + Vec3::splat(s.radius))
        });
        let far = exact.min.abs().max(exact.max.abs()).max_element();
        let pad = (exact.max - exact.min) * 1e-4 + Vec3::splat(far * 16.0 * f32::EPSILON);
        let bounds = Aabb { min: exact.min - pad, max: exact.max + pad };
        WithSpheres { triangles, spheres, bounds, first }
    }

    /// Whether `ray` passes through the spheres' box within `(tmin, tmax)` (slabs).
    #[inline]
    fn near(&self, ray: &Ray, tmax: f32) -> bool {
        let inv = ray.dir.recip();
        let a = (self.bounds.min - ray.origin) * inv;
        let b = (self.bounds.max - ray.origin) * inv;
        let (lo, hi) = (a.min(b).max_element(), a.max(b).min_element());
        // A zero direction component gives slabs of ±∞, which `min` and `max` order.
        !(lo > hi || hi < ray.tmin || lo > tmax)
    }

    /// The nearest sphere hit of `ray` before `tmax`.
    #[inline]
    fn nearest_sphere(&self, ray: &Ray, tmax: f32) -> Option<Hit> {
        if !self.near(ray, tmax) {
            return None;
        }
        let mut best: Option<(f32, usize)> = None;
        let mut tmax = tmax;
        for (k, s) in self.spheres.iter().enumerate() {
            if let Some(t) = s.intersect(ray.origin, ray.dir, ray.tmin, tmax) {
                tmax = t;
                best = Some((t, k));
            }
        }
        let (t, k) = best?;
        let e = octahedral_encode(self.spheres[k].direction_to(ray.at(t)));
        Some(Hit { t, prim: self.first + k as u32, u: e.x, v: e.y })
    }

    #[inline]
    fn any_sphere(&self, ray: &Ray) -> bool {
        self.near(ray, ray.tmax) && self.spheres.iter().any(|s| s.hit(ray).is_some())
    }
}

impl Accelerator for WithSpheres<'_> {
    fn name(&self) -> &str {
        self.triangles.name()
    }

    fn describe(&self) -> String {
        format!("{} and {} analytic spheres", self.triangles.describe(), self.spheres.len())
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_valid() {
            return None;
        }
        let tri = self.triangles.intersect(ray);
        self.nearest_sphere(ray, tri.map_or(ray.tmax, |h| h.t)).or(tri)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        ray.is_valid() && (self.any_sphere(ray) || self.triangles.occluded(ray))
    }

    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.triangles.intersect_batch(rays, hits);
        for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
            if ray.is_valid()
                && let Some(s) = self.nearest_sphere(ray, hit.map_or(ray.tmax, |h| h.t))
            {
                *hit = Some(s);
            }
        }
    }

    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.triangles.occluded_batch(rays, occluded);
        for (ray, o) in rays.iter().zip(occluded.iter_mut()) {
            *o = *o || (ray.is_valid() && self.any_sphere(ray));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Backend, build_accelerator};
    use crate::geometry::{VertexBuffer, octahedral_decode};
    use glam::Vec3;

    /// A floor (two triangles, z = 0) with two spheres above it, one inside the other's
    /// shadow along −z: every backend with the spheres gives the same hits, the nearest of
    /// triangles and spheres, with the sphere's point encoded in `u, v`; batches agree with
    /// single queries, and occlusion with the hits.
    #[test]
    fn spheres_join_every_backend_nearest_first() {
        let p = VertexBuffer::from(vec![
            Vec3::new(-5.0, -5.0, 0.0),
            Vec3::new(5.0, -5.0, 0.0),
            Vec3::new(5.0, 5.0, 0.0),
            Vec3::new(-5.0, 5.0, 0.0),
        ]);
        let t = [[0, 1, 2], [0, 2, 3]];
        let spheres = vec![
            Sphere { center: Vec3::new(0.0, 0.0, 2.0), radius: 1.0 },
            Sphere { center: Vec3::new(0.0, 0.0, 4.5), radius: 0.5 },
        ];
        let rays: Vec<Ray> = (0..400)
            .map(|i| {
                let x = (i % 20) as f32 / 5.0 - 2.0;
                let y = (i / 20) as f32 / 5.0 - 2.0;
                Ray::new(Vec3::new(x * 0.3, y * 0.3, 8.0), Vec3::new(x, y, -8.0))
            })
            .chain([Ray::segment(Vec3::new(0.0, 0.0, 8.0), -Vec3::Z, 2.0)])
            .collect();
        for backend in [Backend::Brute, Backend::Bvh, Backend::Embree] {
            let Ok(inner) = build_accelerator(backend, &p, &t) else { continue };
            let inner_hits: Vec<Option<Hit>> = rays.iter().map(|r| inner.intersect(r)).collect();
            let acc = WithSpheres::new(inner, spheres.clone(), 2);
            assert!(acc.describe().ends_with("and 2 analytic spheres"));
            let mut batch = vec![None; rays.len()];
            acc.intersect_batch(&rays, &mut batch);
            let mut blocked = vec![false; rays.len()];
            acc.occluded_batch(&rays, &mut blocked);
            let mut seen = [0; 3];
            for (k, ray) in rays.iter().enumerate() {
                let hit = acc.intersect(ray);
                assert_eq!(hit, batch[k], "{backend}: ray {k}");
                // Every sphere the exact test hits before the triangles is found (the box
                // around the spheres culls none of them).
                let direct = spheres.iter().filter_map(|s| s.hit(ray)).reduce(f32::min);
                let tri = inner_hits[k].map_or(f32::INFINITY, |h: Hit| h.t);
                if let Some(t) = direct.filter(|&t| t < tri) {
                    assert_eq!(hit.map(|h| h.t), Some(t), "{backend}: ray {k}");
                }
                assert_eq!(hit.is_some(), acc.occluded(ray), "{backend}: ray {k}");
                assert_eq!(hit.is_some(), blocked[k], "{backend}: ray {k}");
                let Some(h) = hit else { continue };
                // The nearest of everything: no sphere or triangle is hit before it.
                let before = Ray { tmax: h.t, ..*ray };
                assert!(!acc.occluded(&Ray { tmax: h.t * (1.0 - 1e-5), ..before }), "{backend}: ray {k}");
                seen[(h.prim as usize).min(2)] += 1;
                if h.prim >= 2 {
                    let s = spheres[h.prim as usize - 2];
                    let q = s.point(octahedral_decode(glam::Vec2::new(h.u, h.v)));
                    assert!((q - ray.at(h.t)).length() < 1e-5, "{backend}: ray {k}: {q}");
                    // The top sphere shadows the bottom one straight down the axis.
                    if ray.dir.x == 0.0 && ray.dir.y == 0.0 {
                        assert_eq!(h.prim, 3);
                    }
                }
            }
            assert!(seen.iter().all(|&n| n > 10), "{backend}: {seen:?}");
            // A small sphere far from the origin (radius 1 at 10⁴, where a box margin of 10⁻⁴
            // of its size is below the coordinates' rounding): the box around it culls none of
            // the grazing rays the exact test hits.
            let sun = Sphere { center: Vec3::new(1e4, 0.0, 0.0), radius: 1.0 };
            let far = WithSpheres::new(build_accelerator(backend, &p, &t).unwrap(), vec![sun], 2);
            for k in 0..=2000 {
                let y = k as f32 / 1000.0 - 1.0;
                let ray = Ray::new(Vec3::new(0.0, 0.0, 50.0), Vec3::new(1e4, y, -50.0));
                assert_eq!(far.intersect(&ray).map(|h| h.t), sun.hit(&ray), "{backend}: y {y}");
            }
            // The segment that stops above the top sphere hits nothing.
            assert_eq!(batch[rays.len() - 1], None);
        }
    }
}
