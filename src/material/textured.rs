//! A material's textured parameters: which field of its [`Bsdf`] each texture sets
//! ([`Slot`]), resolved at a surface point's texture coordinates by
//! [`super::Material::bsdf_at`]. The [`Bsdf`] stays the per-point, `Copy` description every
//! integrator works with.

use glam::{Vec2, Vec3};

use super::Bsdf;
use crate::texture::Texture;

/// A field of a [`Bsdf`] that a texture can set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Slot {
    /// The diffuse albedo (Mitsuba's `reflectance`) of a diffuse or glossy BSDF.
    Reflectance,
    /// The specular colour (`specular_reflectance`) of a glossy BSDF or a mirror.
    Specular,
}

impl Slot {
    pub fn name(self) -> &'static str {
        match self {
            Slot::Reflectance => "reflectance",
            Slot::Specular => "specular",
        }
    }
}

/// The textures of a material, each with the slot it sets; every value of the material's
/// untextured [`Bsdf`] that no texture sets stays as it is.
#[derive(Clone, Debug, PartialEq)]
pub struct Textured {
    pub slots: Vec<(Slot, Texture)>,
}

impl Textured {
    pub fn new(slots: Vec<(Slot, Texture)>) -> Textured {
        Textured { slots }
    }

    /// `bsdf` with every slot set to its texture's value at `uv`.
    #[inline]
    pub fn apply(&self, mut bsdf: Bsdf, uv: Vec2) -> Bsdf {
        for (slot, texture) in &self.slots {
            bsdf = bsdf.with_slot(*slot, texture.eval(uv));
        }
        bsdf
    }

    /// `bsdf` with every slot set to its texture's mean.
    pub fn apply_mean(&self, mut bsdf: Bsdf) -> Bsdf {
        for (slot, texture) in &self.slots {
            bsdf = bsdf.with_slot(*slot, texture.mean());
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
}
