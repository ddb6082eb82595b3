//! The scene's lights other than its emitting triangles (Mitsuba 3's `point`, `spot`,
//! `directional`, `constant` and `envmap`), and the one interface next-event estimation and
//! escaping rays use for all of them.
//!
//! Delta lights (point, spot, directional) can only be sampled, never hit: their sample has
//! an infinite density and full weight. Infinite lights (directional, constant, envmap) lie
//! beyond everything: a shadow ray towards them is unbounded, and the environments among them
//! (constant, envmap) are what a ray that escapes the scene sees.

use glam::{Vec2, Vec3};

use super::constant::{ConstantLight, UNIFORM_SPHERE_PDF, uniform_sphere};
use super::directional::DirectionalLight;
use super::envmap::Envmap;
use super::point::PointLight;
use super::spot::SpotLight;
use crate::hash::Fnv1a;

#[derive(Clone, Debug)]
pub enum Light {
    Point(PointLight),
    Spot(SpotLight),
    Directional(DirectionalLight),
    Constant(ConstantLight),
    Envmap(Box<Envmap>),
}

/// A light sampled from a receiver: what connecting to it needs.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the receiver towards the light.
    pub wi: Vec3,
    /// The light's position, for finite lights; `None` at infinity.
    pub position: Option<Vec3>,
    /// Radiance arriving (for delta lights: intensity / distance², or irradiance) divided by
    /// the density of the sample (for delta lights: by one).
    pub weight: Vec3,
    /// Solid-angle density of the sample; infinite for delta lights.
    pub pdf: f32,
}

impl Light {
    /// Mitsuba's name of the kind, as errors name it.
    pub fn kind(&self) -> &'static str {
        match self {
            Light::Point(_) => "point",
            Light::Spot(_) => "spot",
            Light::Directional(_) => "directional",
            Light::Constant(_) => "constant",
            Light::Envmap(_) => "envmap",
        }
    }

    /// Sampled only: no ray can hit it.
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point(_) | Light::Spot(_) | Light::Directional(_))
    }

    /// Seen by rays that leave the scene.
    pub fn is_environment(&self) -> bool {
        matches!(self, Light::Constant(_) | Light::Envmap(_))
    }

    /// Power (mean over the channels) for choosing among the lights; infinite lights' from the
    /// scene's bounding-sphere `radius`.
    pub fn power(&self, radius: f32) -> f64 {
        match self {
            Light::Point(l) => l.power(),
            Light::Spot(l) => l.power(),
            Light::Directional(l) => l.power(radius),
            Light::Constant(l) => l.power(radius),
            Light::Envmap(l) => l.power(radius),
        }
    }

    /// A sample of the light seen from `p`, from two numbers (the delta lights use none);
    /// `None` when it sends nothing towards `p`.
    #[inline]
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let (wi, position, weight, pdf) = match self {
            Light::Point(l) => {
                let d = l.position - p;
                let dist2 = d.length_squared();
                let wi = d / dist2.sqrt();
                (wi, Some(l.position), l.intensity_towards(-wi) / dist2, f32::INFINITY)
            }
            Light::Spot(l) => {
                let d = l.position - p;
                let dist2 = d.length_squared();
                let wi = d / dist2.sqrt();
                (wi, Some(l.position), l.intensity_towards(-wi) / dist2, f32::INFINITY)
            }
            Light::Directional(l) => (-l.direction, None, l.irradiance, f32::INFINITY),
            Light::Constant(l) => {
                (uniform_sphere(u), None, l.radiance / UNIFORM_SPHERE_PDF, UNIFORM_SPHERE_PDF)
            }
            Light::Envmap(l) => {
                let (wi, pdf) = l.sample(u);
                if pdf <= 0.0 {
                    return None;
                }
                (wi, None, l.radiance(wi) / pdf, pdf)
            }
        };
        if !(wi.is_finite() && weight.cmpgt(Vec3::ZERO).any()) {
            return None;
        }
        Some(LightSample { wi, position, weight, pdf })
    }

    /// Radiance arriving from the environment along the unit direction `w` (pointing away from
    /// the scene); zero for lights that are not environments.
    #[inline]
    pub fn environment(&self, w: Vec3) -> Vec3 {
        match self {
            Light::Constant(l) => l.radiance,
            Light::Envmap(l) => l.radiance(w),
            _ => Vec3::ZERO,
        }
    }

    /// The solid-angle density of [`Light::sample`] drawing the unit direction `w`, for
    /// environments (zero for the others, which no ray finds).
    #[inline]
    pub fn environment_pdf(&self, w: Vec3) -> f32 {
        match self {
            Light::Constant(_) => UNIFORM_SPHERE_PDF,
            Light::Envmap(l) => l.pdf(w),
            _ => 0.0,
        }
    }

    /// Adds the light's contents to a scene fingerprint.
    pub fn fingerprint(&self, h: &mut Fnv1a) {
        h.bytes(self.kind().as_bytes());
        match self {
            Light::Point(l) => h.f32s(&[l.position.to_array(), l.intensity.to_array()].concat()),
            Light::Spot(l) => {
                h.f32s(&[l.position.to_array(), l.axis.to_array(), l.intensity.to_array()].concat());
                h.f32s(&l.from_world.to_cols_array());
                h.f32s(&[l.cutoff_angle, l.beam_width]);
            }
            Light::Directional(l) => h.f32s(&[l.direction.to_array(), l.irradiance.to_array()].concat()),
            Light::Constant(l) => h.f32s(&l.radiance.to_array()),
            Light::Envmap(l) => {
                let (w, hgt) = l.size();
                h.u64s(&[w as u64, hgt as u64]);
                let (texels, to_world) = l.contents();
                for t in texels {
                    h.f32s(&t.to_array());
                }
                h.f32s(&to_world.to_cols_array());
                h.f32s(&[l.scale]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point light's sample: intensity / distance², full weight, towards the light; a
    /// directional light's: the irradiance, against its direction; a constant environment's:
    /// uniform directions of density 1/4π, weight L / pdf.
    #[test]
    fn samples_carry_what_the_lights_send() {
        let p = Light::Point(PointLight { position: Vec3::new(0.0, 2.0, 0.0), intensity: Vec3::splat(8.0) });
        let s = p.sample(Vec3::ZERO, Vec2::ZERO).unwrap();
        assert_eq!(
            (s.wi, s.position, s.weight, s.pdf),
            (Vec3::Y, Some(Vec3::Y * 2.0), Vec3::splat(2.0), f32::INFINITY)
        );
        assert!(p.is_delta() && !p.is_environment());
        assert!((p.power(1.0) - 32.0 * std::f64::consts::PI).abs() < 1e-9);
        let d = Light::Directional(DirectionalLight { direction: -Vec3::Y, irradiance: Vec3::splat(3.0) });
        let s = d.sample(Vec3::ZERO, Vec2::splat(0.3)).unwrap();
        assert_eq!((s.wi, s.position, s.weight), (Vec3::Y, None, Vec3::splat(3.0)));
        assert!((d.power(2.0) - 12.0 * std::f64::consts::PI).abs() < 1e-9);
        let c = Light::Constant(ConstantLight { radiance: Vec3::splat(0.5) });
        let mut mean = Vec3::ZERO;
        for i in 0..64 {
            for j in 0..64 {
                let u = Vec2::new((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 64.0);
                let s = c.sample(Vec3::ZERO, u).unwrap();
                assert!((s.wi.length() - 1.0).abs() < 1e-5);
                assert_eq!((s.pdf, c.environment_pdf(s.wi)), (UNIFORM_SPHERE_PDF, UNIFORM_SPHERE_PDF));
                assert_eq!(c.environment(s.wi), Vec3::splat(0.5));
                mean += s.wi;
            }
        }
        // Uniform over the sphere: the directions average to zero.
        assert!((mean / 4096.0).length() < 1e-3, "{mean}");
    }
}
