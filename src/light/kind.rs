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

/// A light path's start at a light ([`Light::emit`]).
#[derive(Clone, Copy, Debug)]
pub struct Emission {
    /// Where the ray starts: the light's position, or a point of the disk that covers the
    /// scene's bounding sphere, outside it, for lights at infinity.
    pub origin: Vec3,
    /// Unit direction of the ray.
    pub dir: Vec3,
    /// What the ray carries: emitted intensity (or radiance times the disk's area) divided by
    /// the densities of the origin and direction (the light's choice excluded).
    pub weight: Vec3,
    /// The density of what the ray's start picks beyond what next-event estimation picks of
    /// the same light (the point of a point or spot light, the direction of a light at
    /// infinity), per unit area of the receiving surface and without its cosine, excluding
    /// 1/distance² for lights at a position (per unit solid angle there): pdf_dir for a point
    /// or spot light, the disk's 1 / π r² for lights at infinity
    /// ([`Light::emission_density`] at the receiver).
    pub density: f32,
    /// Whether `density` is per unit area already (lights at infinity).
    pub at_infinity: bool,
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

    /// A ray leaving the light, from two pairs of numbers: for a point light a uniform
    /// direction (Mitsuba's), for a spot light a uniform direction within its cutoff cone
    /// (Mitsuba's), for lights at infinity a direction (against the directional light's, or
    /// drawn as next-event estimation draws it) and a uniform point on the disk of the
    /// scene's bounding sphere (`center`, `radius`) perpendicular to it, one radius outside
    /// the centre (pbrt's). `None` when nothing is sent.
    pub fn emit(&self, (center, radius): (Vec3, f32), u_a: Vec2, u_b: Vec2) -> Option<Emission> {
        let disk_area = std::f32::consts::PI * radius * radius;
        let on_disk = |dir: Vec3| {
            let d = crate::sampling::concentric_disk(u_a) * radius;
            let f = crate::geometry::Frame::from_normal(dir);
            center - dir * radius + f.s * d.x + f.t * d.y
        };
        let e = match self {
            Light::Point(l) => {
                let dir = uniform_sphere(u_b);
                Emission {
                    origin: l.position,
                    dir,
                    weight: l.intensity_towards(dir) / UNIFORM_SPHERE_PDF,
                    density: UNIFORM_SPHERE_PDF,
                    at_infinity: false,
                }
            }
            Light::Spot(l) => {
                let cos_max = l.cos_cutoff();
                let dir = crate::geometry::Frame::from_normal(l.axis)
                    .to_world(crate::sampling::uniform_cone(u_b, cos_max))
                    .normalize();
                let pdf = crate::sampling::uniform_cone_pdf(cos_max);
                Emission {
                    origin: l.position,
                    dir,
                    weight: l.intensity_towards(dir) / pdf,
                    density: pdf,
                    at_infinity: false,
                }
            }
            Light::Directional(l) => Emission {
                origin: on_disk(l.direction),
                dir: l.direction,
                weight: l.irradiance * disk_area,
                density: 1.0 / disk_area,
                at_infinity: true,
            },
            Light::Constant(_) | Light::Envmap(_) => {
                let s = self.sample(center, u_b)?;
                let dir = -s.wi;
                Emission {
                    origin: on_disk(dir),
                    dir,
                    weight: s.weight * disk_area,
                    density: 1.0 / disk_area,
                    at_infinity: true,
                }
            }
        };
        (e.dir.is_finite() && e.weight.cmpgt(Vec3::ZERO).any()).then_some(e)
    }

    /// [`Emission::density`] at a receiver `dist2` (squared) from the light (ignored at
    /// infinity), for a scene of bounding-sphere `radius`: what a light path adds to next-event
    /// estimation's pick of the light, per unit area at the receiver without its cosine.
    pub fn emission_density(&self, dist2: f32, radius: f32) -> f32 {
        match self {
            Light::Point(_) => UNIFORM_SPHERE_PDF / dist2,
            Light::Spot(l) => crate::sampling::uniform_cone_pdf(l.cos_cutoff()) / dist2,
            Light::Directional(_) | Light::Constant(_) | Light::Envmap(_) => {
                1.0 / (std::f32::consts::PI * radius * radius)
            }
        }
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

    /// A light path's start carries the light's power on average: the mean of
    /// [`Light::emit`]'s weights over its numbers is [`Light::power`] (per channel, here the
    /// same in all), for every kind.
    #[test]
    fn emitted_rays_carry_the_power() {
        use crate::light::envmap::Envmap;
        let px: Vec<Vec3> = (0..8 * 5).map(|i| Vec3::splat(0.1 + (i % 7) as f32 * 0.3)).collect();
        let lights = [
            Light::Point(PointLight { position: Vec3::ONE, intensity: Vec3::splat(2.0) }),
            Light::Spot(SpotLight::new(glam::Mat4::from_rotation_x(0.3), Vec3::splat(3.0), 30.0, 10.0)),
            Light::Directional(DirectionalLight {
                direction: Vec3::new(0.0, -0.6, -0.8),
                irradiance: Vec3::ONE,
            }),
            Light::Constant(ConstantLight { radiance: Vec3::splat(0.5) }),
            Light::Envmap(Box::new(Envmap::new(8, 5, &px, 2.0, glam::Mat4::from_rotation_y(1.0)).unwrap())),
        ];
        let sphere = (Vec3::new(1.0, 2.0, 3.0), 2.5);
        for light in &lights {
            let n = 256;
            let mut sum = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    if let Some(e) = light.emit(sphere, Vec2::splat(0.3), u) {
                        assert!((e.dir.length() - 1.0).abs() < 1e-4);
                        if e.at_infinity {
                            // Outside the sphere, heading into it.
                            assert!((e.origin - sphere.0).length() >= sphere.1 * 0.999);
                            assert!(e.dir.dot(sphere.0 - e.origin) > 0.0);
                        }
                        sum += e.weight.x as f64;
                    }
                }
            }
            let (got, want) = (sum / (n * n) as f64, light.power(sphere.1));
            assert!((got - want).abs() < 1e-2 * want, "{}: {got} against {want}", light.kind());
        }
    }
}
