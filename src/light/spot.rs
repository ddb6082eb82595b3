//! A spot light (Mitsuba 3's `spot`): at the origin of its `to_world`, pointing along its +z,
//! radiant intensity `intensity` (W/sr) times Mitsuba's falloff: 1 within `beam_width` of
//! the axis, falling linearly in the angle to 0 at `cutoff_angle`, 0 beyond. A delta light.

use glam::{Mat3, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct SpotLight {
    pub position: Vec3,
    /// The inverse of the linear part of `to_world`: world directions into the light's frame.
    pub from_world: Mat3,
    /// The unit axis in world space (`to_world` applied to +z).
    pub axis: Vec3,
    pub intensity: Vec3,
    /// Radians.
    pub cutoff_angle: f32,
    pub beam_width: f32,
    cos_cutoff: f32,
    cos_beam: f32,
    inv_transition: f32,
}

impl SpotLight {
    /// A spot light; the angles in degrees, as Mitsuba takes them (`beam_width` ≤
    /// `cutoff_angle`, checked by the reader).
    pub fn new(to_world: glam::Mat4, intensity: Vec3, cutoff_deg: f32, beam_deg: f32) -> Self {
        let cutoff_angle = cutoff_deg.to_radians();
        let beam_width = beam_deg.to_radians();
        let linear = Mat3::from_mat4(to_world);
        SpotLight {
            position: to_world.w_axis.truncate(),
            from_world: linear.inverse(),
            axis: (linear * Vec3::Z).normalize(),
            intensity,
            cutoff_angle,
            beam_width,
            cos_cutoff: cutoff_angle.cos(),
            cos_beam: beam_width.cos(),
            inv_transition: 1.0 / (cutoff_angle - beam_width),
        }
    }

    /// Mitsuba 3's `falloff_curve` of a direction in the light's frame (any length).
    #[inline]
    pub fn falloff(&self, local: Vec3) -> f32 {
        let cos_theta = local.normalize().z;
        let beam = if cos_theta >= self.cos_beam {
            1.0
        } else {
            (self.cutoff_angle - cos_theta.clamp(-1.0, 1.0).acos()) * self.inv_transition
        };
        if cos_theta > self.cos_cutoff { beam } else { 0.0 }
    }

    /// Radiant intensity towards the unit world direction `w` leaving the light.
    #[inline]
    pub fn intensity_towards(&self, w: Vec3) -> Vec3 {
        self.intensity * self.falloff(self.from_world * w)
    }

    /// The cosine of the cutoff angle: the cone outside which nothing is emitted.
    pub fn cos_cutoff(&self) -> f32 {
        self.cos_cutoff
    }

    /// Emitted power (mean over the channels): I times the falloff's integral over the sphere,
    /// 2π ∫ falloff(θ) sin θ dθ, in closed form (1 to the beam, linear in θ to the cutoff).
    pub fn power(&self) -> f64 {
        let (a, b) = (self.beam_width as f64, self.cutoff_angle as f64);
        // ∫_0^a sin = 1 − cos a; ∫_a^b (b − θ)/(b − a) sin θ dθ = cos a − (sin b − sin a)/(b − a).
        let ramp = if b > a { a.cos() - (b.sin() - a.sin()) / (b - a) } else { 0.0 };
        let integral = 2.0 * std::f64::consts::PI * ((1.0 - a.cos()) + ramp);
        integral * (self.intensity.element_sum() as f64 / 3.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    /// Mitsuba's curve: 1 within the beam, linear in the angle to 0 at the cutoff, 0 beyond;
    /// the axis is `to_world`'s +z.
    #[test]
    fn the_falloff_is_mitsubas() {
        let to_world = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Mat4::from_rotation_x(0.4);
        let s = SpotLight::new(to_world, Vec3::ONE, 40.0, 10.0);
        let at = |deg: f32| {
            let t = deg.to_radians();
            let w = Mat3::from_mat4(to_world) * Vec3::new(t.sin(), 0.0, t.cos());
            s.intensity_towards(w).x
        };
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(9.0), 1.0);
        assert!((at(25.0) - 0.5).abs() < 1e-4, "{}", at(25.0));
        assert!((at(32.5) - 0.25).abs() < 1e-4, "{}", at(32.5));
        assert_eq!(at(41.0), 0.0);
        assert_eq!(at(120.0), 0.0);
        assert_eq!(s.position, Vec3::new(1.0, 2.0, 3.0));
    }

    /// The power is the intensity's integral over the sphere (midpoint rule in θ).
    #[test]
    fn the_power_is_the_integral_of_the_intensity() {
        for (cutoff, beam) in [(20.0, 15.0), (60.0, 0.0), (90.0, 45.0)] {
            let s = SpotLight::new(Mat4::IDENTITY, Vec3::new(1.0, 2.0, 3.0), cutoff, beam);
            let n = 200_000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let t = std::f64::consts::PI * (i as f64 + 0.5) / n as f64;
                let w = Vec3::new(t.sin() as f32, 0.0, t.cos() as f32);
                sum += s.falloff(w) as f64 * t.sin();
            }
            let want = 2.0 * std::f64::consts::PI * sum * std::f64::consts::PI / n as f64 * 2.0;
            assert!((s.power() - want).abs() < 1e-4 * want, "{cutoff} {beam}: {} {want}", s.power());
        }
    }
}
