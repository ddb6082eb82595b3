//! Textures: values that vary over a surface with its texture coordinates (u, v), as Mitsuba 3
//! defines them: a constant colour, a [`Bitmap`] image and a [`Checkerboard`].
//!
//! [`Texture::eval`] gives a colour (linear RGB), [`Texture::eval_1`] a number for float
//! parameters (Mitsuba's `eval_1`: a one-channel image's value, an RGB image's luminance),
//! [`Texture::eval_1_grad`] its gradient (for bump maps), [`Texture::mean`] the average over
//! the texture (its texels, or its two colours) for estimates. Texture coordinates come from [`crate::scene::SurfacePoint::uv`].

mod bitmap;
mod checkerboard;

pub use bitmap::{Bitmap, Filter, Image, Wrap};
pub use checkerboard::Checkerboard;

use std::sync::Arc;

use glam::{Affine2, Mat4, Vec2, Vec3};

/// A colour or number that varies over a surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Constant(Vec3),
    Bitmap(Arc<Bitmap>),
    Checkerboard(Arc<Checkerboard>),
}

impl Texture {
    /// The colour at texture coordinates `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.eval(uv),
            Texture::Checkerboard(c) => c.eval(uv),
        }
    }

    /// The number at `uv`, for a float parameter: a constant's value (its luminance if its
    /// channels differ), a one-channel image's value or an RGB image's luminance, and Mitsuba's
    /// checkerboard rule ([`Checkerboard::eval_1`]).
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        match self {
            Texture::Constant(c) if c.x == c.y && c.y == c.z => c.x,
            Texture::Constant(c) => luminance(*c),
            Texture::Bitmap(b) => b.eval_1(uv),
            Texture::Checkerboard(c) => c.eval_1(uv),
        }
    }

    /// The gradient (∂/∂u, ∂/∂v) of [`Texture::eval_1`], as Mitsuba's `eval_1_grad` (a bump
    /// map's slope): a bitmap's ([`Bitmap::eval_1_grad`]); zero for a constant. Mitsuba has
    /// none for a checkerboard (its scene loader refuses that under a bump map, as pir's).
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Bitmap(b) => b.eval_1_grad(uv),
            Texture::Constant(_) | Texture::Checkerboard(_) => Vec2::ZERO,
        }
    }

    /// The average colour over the texture: a bitmap's mean texel, a checkerboard's mean of
    /// its two colours' means.
    pub fn mean(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.mean(),
            Texture::Checkerboard(c) => 0.5 * (c.color0.mean() + c.color1.mean()),
        }
    }

    /// The smallest and largest value of any channel anywhere (for the checks that a
    /// reflectance stays in [0, 1]).
    pub fn range(&self) -> (f32, f32) {
        match self {
            Texture::Constant(c) => (c.min_element(), c.max_element()),
            Texture::Bitmap(b) => b.range(),
            Texture::Checkerboard(c) => {
                let ((a0, a1), (b0, b1)) = (c.color0.range(), c.color1.range());
                (a0.min(b0), a1.max(b1))
            }
        }
    }

    /// Feeds everything that determines the texture's values to `put` (the scene fingerprint).
    pub fn hash_into(&self, put: &mut dyn FnMut(&[u8])) {
        match self {
            Texture::Constant(c) => {
                put(b"constant");
                c.to_array().iter().for_each(|v| put(&v.to_le_bytes()));
            }
            Texture::Bitmap(b) => b.hash_into(put),
            Texture::Checkerboard(c) => {
                put(b"checkerboard");
                hash_affine(&c.to_uv, put);
                c.color0.hash_into(put);
                c.color1.hash_into(put);
            }
        }
    }
}

pub use crate::light::envmap::luminance;

/// Mitsuba's `to_uv` of a 4×4 `<transform>`: rows and columns 0, 1 and 3 (the translation in
/// x and y); z and the projective row are ignored.
pub fn uv_transform(m: Mat4) -> Affine2 {
    Affine2::from_cols(
        Vec2::new(m.x_axis.x, m.x_axis.y),
        Vec2::new(m.y_axis.x, m.y_axis.y),
        Vec2::new(m.w_axis.x, m.w_axis.y),
    )
}

fn hash_affine(a: &Affine2, put: &mut dyn FnMut(&[u8])) {
    a.to_cols_array().iter().for_each(|v| put(&v.to_le_bytes()));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn to_uv_keeps_the_translation_and_drops_z() {
        let m =
            Mat4::from_translation(Vec3::new(0.5, 0.25, 7.0)) * Mat4::from_scale(Vec3::new(2.0, 3.0, 4.0));
        let a = uv_transform(m);
        assert_eq!(a.transform_point2(Vec2::new(1.0, 1.0)), Vec2::new(2.5, 3.25));
    }

    #[test]
    fn constants_and_luminance() {
        let t = Texture::Constant(Vec3::new(0.2, 0.4, 0.6));
        assert_eq!(t.eval(Vec2::new(5.0, -3.0)), Vec3::new(0.2, 0.4, 0.6));
        assert!((t.eval_1(Vec2::ZERO) - (0.2 * 0.212671 + 0.4 * 0.715160 + 0.6 * 0.072169)).abs() < 1e-7);
        assert_eq!(Texture::Constant(Vec3::splat(0.3)).eval_1(Vec2::ZERO), 0.3);
        assert_eq!(t.mean(), Vec3::new(0.2, 0.4, 0.6));
        assert_eq!(t.range(), (0.2, 0.6));
    }
}
