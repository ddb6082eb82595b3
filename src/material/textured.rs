//! A material's textured parameters: which field of its [`Bsdf`] each texture sets
//! ([`Slot`]), resolved at a surface point's texture coordinates by
//! [`super::Material::bsdf_at`]. The [`Bsdf`] stays the per-point, `Copy` description every
//! integrator works with.

use glam::{Vec2, Vec3};

use super::Bsdf;
use super::conductor::ComplexIor;
use super::microfacet::Microfacet;
use super::shading_map::ShadingMap;
use crate::texture::Texture;

/// A field of a [`Bsdf`] that a texture can set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Slot {
    /// The diffuse albedo (Mitsuba's `reflectance`) of a diffuse or glossy BSDF.
    Reflectance,
    /// The specular colour (`specular_reflectance`) of a glossy BSDF, a mirror, a conductor,
    /// a plastic or a dielectric (its reflection's weight).
    Specular,
    /// The transmission's weight (`specular_transmittance`) of a dielectric (smooth, thin or
    /// rough).
    Transmittance,
    /// A conductor's (smooth or rough) index of refraction η, per channel.
    Eta,
    /// A conductor's (smooth or rough) absorption coefficient k, per channel.
    K,
    /// A mask's opacity (a number: the texture's [`Texture::eval_1`]), the diffuse one's or a
    /// composite's ([`Bsdf::Composite`]).
    Opacity,
    /// A blend's weight (a number), its second part's share ([`Bsdf::Composite`]).
    Weight,
    /// A rough conductor's α (a number), or the roughness of the glossy lobe pir reads a
    /// GGX conductor of index "none" as.
    Alpha,
    /// The radiance an emitter's front face emits (Mitsuba's area emitter's `radiance`): not a
    /// field of the BSDF, read by [`super::Material::emission_at`].
    Emission,
}

impl Slot {
    pub fn name(self) -> &'static str {
        match self {
            Slot::Reflectance => "reflectance",
            Slot::Specular => "specular",
            Slot::Transmittance => "transmittance",
            Slot::Eta => "eta",
            Slot::K => "k",
            Slot::Opacity => "opacity",
            Slot::Weight => "weight",
            Slot::Alpha => "alpha",
            Slot::Emission => "emission",
        }
    }

    /// Whether it holds a number (set from [`Texture::eval_1`]) rather than a colour.
    fn is_number(self) -> bool {
        matches!(self, Slot::Opacity | Slot::Alpha | Slot::Weight)
    }

    /// The slot's value on average for a texture of mean `mean`: the mean itself, or for a
    /// number slot its luminance (the mean luminance), unless it is grey already.
    pub fn mean_value(self, mean: Vec3) -> Vec3 {
        if self.is_number() && !(mean.x == mean.y && mean.y == mean.z) {
            Vec3::splat(crate::texture::luminance(mean))
        } else {
            mean
        }
    }
}

/// The textures of a material, each with the slot it sets; every value of the material's
/// untextured [`Bsdf`] that no texture sets stays as it is. `map`, if any, perturbs the
/// shading frame ([`crate::scene::Scene::surface_at`] applies it).
#[derive(Clone, Debug, PartialEq)]
pub struct Textured {
    pub slots: Vec<(Slot, Texture)>,
    pub map: Option<ShadingMap>,
}

impl Textured {
    pub fn new(slots: Vec<(Slot, Texture)>) -> Textured {
        Textured { slots, map: None }
    }

    /// The texture of `slot`, if one sets it.
    #[inline]
    pub fn get(&self, slot: Slot) -> Option<&Texture> {
        self.slots.iter().find(|(s, _)| *s == slot).map(|(_, t)| t)
    }

    /// `bsdf` with every slot set to its texture's value at `uv` (a composite's parts are
    /// resolved at `uv` too: [`Bsdf::Composite`]).
    #[inline]
    pub fn apply(&self, mut bsdf: Bsdf, uv: Vec2) -> Bsdf {
        for (slot, texture) in self.slots.iter().filter(|(s, _)| *s != Slot::Emission) {
            let value = if slot.is_number() { Vec3::splat(texture.eval_1(uv)) } else { texture.eval(uv) };
            bsdf = bsdf.with_slot(*slot, value);
        }
        if let Bsdf::Composite { weight, parts, .. } = bsdf {
            bsdf = Bsdf::Composite { weight, parts, uv: Some(uv) };
        }
        bsdf
    }

    /// `bsdf` with every slot set to its texture's mean (a number slot: the mean's luminance,
    /// which is the mean luminance).
    pub fn apply_mean(&self, mut bsdf: Bsdf) -> Bsdf {
        for (slot, texture) in self.slots.iter().filter(|(s, _)| *s != Slot::Emission) {
            bsdf = bsdf.with_slot(*slot, slot.mean_value(texture.mean()));
        }
        bsdf
    }
}

impl Bsdf {
    /// The BSDF with the field `slot` names set to `value`; a BSDF without that field is
    /// returned unchanged.
    #[inline]
    pub fn with_slot(self, slot: Slot, value: Vec3) -> Bsdf {
        match (self, slot) {
            (Bsdf::Diffuse { .. }, Slot::Reflectance) => Bsdf::Diffuse { albedo: value },
            (Bsdf::Glossy { specular, roughness, .. }, Slot::Reflectance) => {
                Bsdf::Glossy { albedo: value, specular, roughness }
            }
            (Bsdf::Glossy { albedo, roughness, .. }, Slot::Specular) => {
                Bsdf::Glossy { albedo, specular: value, roughness }
            }
            (Bsdf::Mirror { .. }, Slot::Specular) => Bsdf::Mirror { specular: value },
            (Bsdf::Mask { opacity, .. }, Slot::Reflectance) => Bsdf::Mask { opacity, albedo: value },
            (Bsdf::Plastic { specular, eta, specular_weight, nonlinear, .. }, Slot::Reflectance) => {
                Bsdf::Plastic { diffuse: value, specular, eta, specular_weight, nonlinear }
            }
            (Bsdf::RoughPlastic { specular, specular_weight, nonlinear, table, .. }, Slot::Reflectance) => {
                Bsdf::RoughPlastic { diffuse: value, specular, specular_weight, nonlinear, table }
            }
            (Bsdf::Conductor { ior, .. }, Slot::Specular) => Bsdf::Conductor { specular: value, ior },
            (Bsdf::RoughConductor { ior, microfacet, .. }, Slot::Specular) => {
                Bsdf::RoughConductor { specular: value, ior, microfacet }
            }
            (Bsdf::RoughConductor { specular, ior, microfacet }, Slot::Alpha) => {
                Bsdf::RoughConductor { specular, ior, microfacet: Microfacet::new(microfacet.kind, value.x) }
            }
            (Bsdf::RoughDielectric { eta, reflectance, transmittance, microfacet }, Slot::Alpha) => {
                Bsdf::RoughDielectric {
                    eta,
                    reflectance,
                    transmittance,
                    microfacet: Microfacet::new(microfacet.kind, value.x),
                }
            }
            (Bsdf::Glossy { albedo, specular, .. }, Slot::Alpha) => {
                Bsdf::Glossy { albedo, specular, roughness: value.x }
            }
            (Bsdf::Plastic { diffuse, eta, specular_weight, nonlinear, .. }, Slot::Specular) => {
                Bsdf::Plastic { diffuse, specular: value, eta, specular_weight, nonlinear }
            }
            (Bsdf::RoughPlastic { diffuse, specular_weight, nonlinear, table, .. }, Slot::Specular) => {
                Bsdf::RoughPlastic { diffuse, specular: value, specular_weight, nonlinear, table }
            }
            (Bsdf::Dielectric { ior, transmittance, .. }, Slot::Specular) => {
                Bsdf::Dielectric { ior, reflectance: value, transmittance }
            }
            (Bsdf::ThinDielectric { ior, transmittance, .. }, Slot::Specular) => {
                Bsdf::ThinDielectric { ior, reflectance: value, transmittance }
            }
            (Bsdf::Mask { albedo, .. }, Slot::Opacity) => Bsdf::Mask { opacity: value.x, albedo },
            (Bsdf::Dielectric { ior, reflectance, .. }, Slot::Transmittance) => {
                Bsdf::Dielectric { ior, reflectance, transmittance: value }
            }
            (Bsdf::ThinDielectric { ior, reflectance, .. }, Slot::Transmittance) => {
                Bsdf::ThinDielectric { ior, reflectance, transmittance: value }
            }
            (Bsdf::RoughDielectric { eta, transmittance, microfacet, .. }, Slot::Specular) => {
                Bsdf::RoughDielectric { eta, reflectance: value, transmittance, microfacet }
            }
            (Bsdf::RoughDielectric { eta, reflectance, microfacet, .. }, Slot::Transmittance) => {
                Bsdf::RoughDielectric { eta, reflectance, transmittance: value, microfacet }
            }
            (Bsdf::Conductor { specular, ior }, Slot::Eta) => {
                Bsdf::Conductor { specular, ior: ComplexIor { eta: value, k: ior.k } }
            }
            (Bsdf::Conductor { specular, ior }, Slot::K) => {
                Bsdf::Conductor { specular, ior: ComplexIor { eta: ior.eta, k: value } }
            }
            (Bsdf::RoughConductor { specular, ior, microfacet }, Slot::Eta) => {
                Bsdf::RoughConductor { specular, ior: ComplexIor { eta: value, k: ior.k }, microfacet }
            }
            (Bsdf::RoughConductor { specular, ior, microfacet }, Slot::K) => {
                Bsdf::RoughConductor { specular, ior: ComplexIor { eta: ior.eta, k: value }, microfacet }
            }
            (Bsdf::Composite { parts, uv, .. }, Slot::Opacity | Slot::Weight) => {
                Bsdf::Composite { weight: value.x, parts, uv }
            }
            (other, _) => other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::Checkerboard;
    use std::sync::Arc;

    #[test]
    fn slots_set_their_fields_only() {
        let v = Vec3::new(0.1, 0.2, 0.3);
        let g = Bsdf::Glossy { albedo: Vec3::ONE, specular: Vec3::ZERO, roughness: 0.3 };
        assert_eq!(
            g.with_slot(Slot::Reflectance, v),
            Bsdf::Glossy { albedo: v, specular: Vec3::ZERO, roughness: 0.3 }
        );
        assert_eq!(
            g.with_slot(Slot::Specular, v),
            Bsdf::Glossy { albedo: Vec3::ONE, specular: v, roughness: 0.3 }
        );
        assert_eq!(
            Bsdf::Diffuse { albedo: Vec3::ONE }.with_slot(Slot::Reflectance, v),
            Bsdf::Diffuse { albedo: v }
        );
        assert_eq!(
            Bsdf::Diffuse { albedo: Vec3::ONE }.with_slot(Slot::Specular, v),
            Bsdf::Diffuse { albedo: Vec3::ONE }
        );
        assert_eq!(
            Bsdf::Mirror { specular: Vec3::ONE }.with_slot(Slot::Specular, v),
            Bsdf::Mirror { specular: v }
        );
        assert_eq!(Bsdf::Glass { ior: 1.5 }.with_slot(Slot::Specular, v), Bsdf::Glass { ior: 1.5 });
        let check = Texture::Checkerboard(Arc::new(Checkerboard {
            color0: Texture::Constant(Vec3::splat(0.4)),
            color1: Texture::Constant(Vec3::splat(0.2)),
            to_uv: glam::Affine2::IDENTITY,
        }));
        let t = Textured::new(vec![(Slot::Reflectance, check)]);
        let d = Bsdf::Diffuse { albedo: Vec3::splat(0.5) };
        assert_eq!(t.apply(d, Vec2::new(0.75, 0.25)), Bsdf::Diffuse { albedo: Vec3::splat(0.2) });
        assert_eq!(t.apply(d, Vec2::new(0.25, 0.25)), Bsdf::Diffuse { albedo: Vec3::splat(0.4) });
    }

    /// The slots added for Mitsuba's other textured parameters: specular reflectances of
    /// conductors, plastics and dielectrics, a mask's opacity and a rough conductor's α (number
    /// slots take [`Texture::eval_1`], a colour's luminance; their means likewise).
    #[test]
    fn specular_opacity_and_alpha_slots() {
        use super::super::conductor::ComplexIor;
        use super::super::microfacet::Distribution;
        let v = Vec3::new(0.1, 0.2, 0.3);
        let ior = ComplexIor { eta: Vec3::ONE, k: Vec3::ONE };
        let mf = Microfacet::new(Distribution::Beckmann, 0.3);
        let cases = [
            (
                Bsdf::Conductor { specular: Vec3::ONE, ior },
                Slot::Specular,
                Bsdf::Conductor { specular: v, ior },
            ),
            (
                Bsdf::RoughConductor { specular: Vec3::ONE, ior, microfacet: mf },
                Slot::Specular,
                Bsdf::RoughConductor { specular: v, ior, microfacet: mf },
            ),
            (
                Bsdf::RoughConductor { specular: Vec3::ONE, ior, microfacet: mf },
                Slot::Alpha,
                Bsdf::RoughConductor {
                    specular: Vec3::ONE,
                    ior,
                    microfacet: Microfacet::new(Distribution::Beckmann, 0.1),
                },
            ),
            (
                Bsdf::RoughDielectric {
                    eta: 1.5,
                    reflectance: Vec3::ONE,
                    transmittance: Vec3::ONE,
                    microfacet: mf,
                },
                Slot::Alpha,
                Bsdf::RoughDielectric {
                    eta: 1.5,
                    reflectance: Vec3::ONE,
                    transmittance: Vec3::ONE,
                    microfacet: Microfacet::new(Distribution::Beckmann, 0.1),
                },
            ),
            (
                Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::ONE, roughness: 0.3 },
                Slot::Alpha,
                Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::ONE, roughness: 0.1 },
            ),
            (
                Bsdf::Dielectric { ior: 1.5, reflectance: Vec3::ONE, transmittance: Vec3::ONE },
                Slot::Specular,
                Bsdf::Dielectric { ior: 1.5, reflectance: v, transmittance: Vec3::ONE },
            ),
            (
                Bsdf::ThinDielectric { ior: 1.5, reflectance: Vec3::ONE, transmittance: Vec3::ONE },
                Slot::Specular,
                Bsdf::ThinDielectric { ior: 1.5, reflectance: v, transmittance: Vec3::ONE },
            ),
            (
                Bsdf::Mask { opacity: 0.5, albedo: Vec3::ONE },
                Slot::Opacity,
                Bsdf::Mask { opacity: 0.1, albedo: Vec3::ONE },
            ),
        ];
        for (bsdf, slot, want) in cases {
            let value = if slot.is_number() { Vec3::splat(0.1) } else { v };
            assert_eq!(bsdf.with_slot(slot, value), want, "{slot:?}");
        }
        let p = Bsdf::plastic(Vec3::splat(0.5), Some(Vec3::ONE), 1.5, false);
        let Bsdf::Plastic { specular, diffuse, .. } = p.with_slot(Slot::Specular, v) else { panic!() };
        assert_eq!((specular, diffuse), (v, Vec3::splat(0.5)));
        let rp = Bsdf::rough_plastic(Vec3::splat(0.5), None, 1.5, mf, false);
        let Bsdf::RoughPlastic { specular, .. } = rp.with_slot(Slot::Specular, v) else { panic!() };
        assert_eq!(specular, v);
        // A mask's opacity from an RGB texture: its luminance, at a point and on average.
        let c = Vec3::new(0.2, 0.6, 0.9);
        let t = Textured::new(vec![(Slot::Opacity, Texture::Constant(c))]);
        let m = Bsdf::Mask { opacity: 0.5, albedo: Vec3::ONE };
        let lum = crate::texture::luminance(c);
        assert_eq!(t.apply(m, Vec2::ZERO), Bsdf::Mask { opacity: lum, albedo: Vec3::ONE });
        assert_eq!(t.apply_mean(m), Bsdf::Mask { opacity: lum, albedo: Vec3::ONE });
    }
}
