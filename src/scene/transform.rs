//! The placement of a mesh in the world: scale, then rotate about +Y (right-handed, degrees),
//! then translate, exactly as `shared/tools/mitsuba_ref.py` applies it:
//! x' = x cosθ + z sinθ, z' = −x sinθ + z cosθ. Normals go through the inverse transpose
//! (divide by the scale, then rotate) and are renormalised.

use glam::{DVec3, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshTransform {
    scale: DVec3,
    cos: f64,
    sin: f64,
    translate: DVec3,
}

impl MeshTransform {
    pub fn new(scale: Vec3, rotate_y_deg: f32, translate: Vec3) -> Self {
        let a = f64::from(rotate_y_deg).to_radians();
        MeshTransform { scale: scale.as_dvec3(), cos: a.cos(), sin: a.sin(), translate: translate.as_dvec3() }
    }

    fn rotate(&self, v: DVec3) -> DVec3 {
        DVec3::new(self.cos * v.x + self.sin * v.z, v.y, -self.sin * v.x + self.cos * v.z)
    }

    /// A position: scale → rotate_y → translate.
    pub fn point(&self, p: Vec3) -> Vec3 {
        (self.rotate(p.as_dvec3() * self.scale) + self.translate).as_vec3()
    }

    /// A normal: inverse transpose (divide by the scale, rotate), normalised; `Vec3::ZERO` if
    /// it has no direction.
    pub fn normal(&self, n: Vec3) -> Vec3 {
        let v = self.rotate(n.as_dvec3() / self.scale).normalize_or_zero().as_vec3();
        if v.is_finite() { v } else { Vec3::ZERO }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_is_scale_rotate_translate() {
        let t = MeshTransform::new(Vec3::new(2.0, 3.0, 1.0), 90.0, Vec3::new(10.0, 0.0, 0.0));
        // (1, 1, 0) → scale (2, 3, 0) → rotate 90° about +Y: x' = z = 0, z' = −x = −2 → (10, 3, −2)
        let p = t.point(Vec3::new(1.0, 1.0, 0.0));
        assert!((p - Vec3::new(10.0, 3.0, -2.0)).length() < 1e-5, "{p}");
    }

    #[test]
    fn normals_use_the_inverse_transpose() {
        // A plane x + y = 0 (normal (1,1,0)/√2) scaled by (2, 1, 1) becomes x/2 + y = 0,
        // whose normal is (1/2, 1, 0) normalised.
        let t = MeshTransform::new(Vec3::new(2.0, 1.0, 1.0), 0.0, Vec3::ZERO);
        let n = t.normal(Vec3::new(1.0, 1.0, 0.0).normalize());
        assert!((n - Vec3::new(0.5, 1.0, 0.0).normalize()).length() < 1e-6, "{n}");
        assert_eq!(t.normal(Vec3::ZERO), Vec3::ZERO);
    }
}
