//! An emitting sphere (a Mitsuba `sphere` shape with an area emitter): the exact sphere that
//! its tessellated triangles are inscribed in, and the cone of directions under which it is
//! seen from a point outside it.
//!
//! Next-event estimation samples such a sphere as Mitsuba 3 does (`Sphere::sample_direction`,
//! after Akalin's "sampling the visible sphere"): a direction uniform in the cone of the exact
//! sphere seen from the receiver, density 1 / Ω with Ω = 2π (1 − cos θ_max). The scene keeps
//! the triangles for intersection, so a sampled direction counts only where the ray's first
//! hit is one of the sphere's triangles (see [`super::Emitters::choose_from`]); since the
//! triangles lie inside the exact sphere, every direction that reaches them is in the cone,
//! and the estimate stays unbiased (the directions between the polyhedron and the sphere,
//! 0.04 % of the solid angle, are wasted samples). From inside the sphere, or where the cone
//! is too thin to be represented, the triangles are sampled by area as any others.

use std::f32::consts::PI;
use std::ops::Range;

use glam::{Vec2, Vec3};

use crate::geometry::Frame;

/// An emitting sphere and the scene's triangles that tessellate it.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereLight {
    pub center: Vec3,
    /// The exact sphere's radius (at least every tessellation vertex's distance from the
    /// centre, so that the triangles are inside it).
    pub radius: f32,
    /// The sphere's triangles, consecutive in the scene's order; their front faces point away
    /// from the centre.
    pub prims: Range<u32>,
}

/// The cone of directions from a point towards a sphere.
#[derive(Clone, Copy, Debug)]
pub struct Cone {
    /// Its frame, `n` the unit direction towards the centre.
    frame: Frame,
    /// 1 − cos θ_max, computed without cancellation: sin² θ_max / (1 + cos θ_max).
    one_minus_cos: f32,
    /// The density of a uniform direction in it, 1 / (2π (1 − cos θ_max)).
    pub pdf: f32,
}

impl SphereLight {
    /// The cone of the sphere seen from `x`; `None` when `x` is inside the sphere (or on it)
    /// or the cone is too thin for its density to be finite.
    #[inline]
    pub fn cone(&self, x: Vec3) -> Option<Cone> {
        let d = self.center - x;
        let dist2 = d.length_squared();
        let r2 = self.radius * self.radius;
        if dist2.is_nan() || dist2 <= r2 {
            return None;
        }
        let sin2 = r2 / dist2;
        let cos_max = (1.0 - sin2).max(0.0).sqrt();
        let one_minus_cos = sin2 / (1.0 + cos_max);
        let pdf = 1.0 / (2.0 * PI * one_minus_cos);
        if !(one_minus_cos > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(Cone { frame: Frame::from_normal(d / dist2.sqrt()), one_minus_cos, pdf })
    }
}

impl Cone {
    /// A uniform direction in the cone from two numbers: cos θ = 1 − u_x (1 − cos θ_max),
    /// φ = 2π u_y, with sin θ from 1 − cos θ directly so that thin cones keep their precision.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let h = u.x * self.one_minus_cos;
        let sin_t = (h * (2.0 - h)).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let local = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), 1.0 - h);
        self.frame.to_world(local).normalize()
    }

    /// Whether the unit direction `w` lies in the cone (sin² θ ≤ sin² θ_max on the side of
    /// the axis, which keeps its precision in thin cones).
    #[inline]
    pub fn contains(&self, w: Vec3) -> bool {
        let h = self.one_minus_cos;
        w.dot(self.frame.n) > 0.0 && w.cross(self.frame.n).length_squared() <= h * (2.0 - h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere() -> SphereLight {
        SphereLight { center: Vec3::new(0.3, -1.0, 2.0), radius: 0.7, prims: 0..1 }
    }

    /// The cone's density integrates to one over its directions, and the directions it draws
    /// fill exactly the directions that hit the sphere: a uniform grid of directions over the
    /// whole sphere of directions, weighed by the density where they fall in the cone, sums
    /// to 1, and a direction is in the cone exactly when a ray along it hits the sphere.
    #[test]
    fn the_cone_density_integrates_to_one_over_the_sphere_seen() {
        let s = sphere();
        for x in [Vec3::ZERO, Vec3::new(5.0, 2.0, -1.0), Vec3::new(0.3, -1.0, 2.75)] {
            let cone = s.cone(x).unwrap();
            let n = 1024;
            let (mut integral, mut hits) = (0.0f64, 0usize);
            for i in 0..n {
                for j in 0..n {
                    // Uniform directions over the sphere (equal-area cells): density 1 / 4π.
                    let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
                    let phi = 2.0 * PI * (j as f32 + 0.5) / n as f32;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    let w = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    // Does the ray x + t w hit the sphere?
                    let oc = x - s.center;
                    let b = oc.dot(w);
                    let hit = b < 0.0 && b * b - (oc.length_squared() - s.radius * s.radius) > 0.0;
                    if cone.contains(w) {
                        integral += cone.pdf as f64 * 4.0 * PI as f64 / (n * n) as f64;
                        hits += 1;
                    }
                    // Away from the silhouette, the two agree exactly.
                    let margin = (b * b - (oc.length_squared() - s.radius * s.radius)).abs();
                    if margin > 1e-3 {
                        assert_eq!(cone.contains(w), hit, "{x} {w}");
                    }
                }
            }
            assert!(hits > 100, "{x}: {hits}");
            assert!((integral - 1.0).abs() < 0.02, "{x}: {integral}");
        }
        // Inside, or on the sphere: no cone.
        assert!(s.cone(s.center).is_none());
        assert!(s.cone(s.center + Vec3::X * 0.69).is_none());
    }

    /// Sampled directions are unit, inside the cone, and uniform in it: the mean of cos θ
    /// about the axis is 1 − (1 − cos θ_max) / 2, for wide and very thin cones alike.
    #[test]
    fn sampled_directions_are_uniform_in_the_cone() {
        for (x, radius) in [(Vec3::new(0.0, 0.0, 3.0), 2.9), (Vec3::new(1e3, 0.0, 0.0), 0.01)] {
            let s = SphereLight { center: Vec3::ZERO, radius, prims: 0..1 };
            let cone = s.cone(x).unwrap();
            let axis = -x.normalize();
            let n = 256;
            let mut mean_h = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    let w = cone.sample(u);
                    assert!((w.length() - 1.0).abs() < 1e-5);
                    // 1 − cos θ from sin² θ in f64 (θ < 90°), precise in thin cones too.
                    let sin2 = w.as_dvec3().cross(axis.as_dvec3()).length_squared();
                    let h = sin2 / (1.0 + (1.0 - sin2).sqrt());
                    assert!(w.dot(axis) > 0.0 && cone.contains(w));
                    assert!(h <= cone.one_minus_cos as f64 * 1.001, "{h}");
                    mean_h += h / (n * n) as f64;
                }
            }
            let want = cone.one_minus_cos as f64 / 2.0;
            assert!((mean_h - want).abs() < 0.01 * want + 1e-7, "{mean_h} against {want}");
        }
    }
}
