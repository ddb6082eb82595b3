//! Mitsuba 3's `checkerboard` texture: with (u, v) = to_uv(uv), `color0` where the
//! fractional parts of u and v are both above ½ or both at most ½, `color1` elsewhere; the
//! colours (textures themselves) are evaluated at the untransformed uv. Defaults 0.4 and 0.2.
//!
//! Mitsuba 3's float lookup (`eval_1`, for float parameters) swaps the two colours (its
//! source tests `neq` where `eval` tests `eq`; checked against Mitsuba 3.9.1): replicated.

use glam::{Affine2, Vec2};

use super::Texture;

#[derive(Clone, Debug, PartialEq)]
pub struct Checkerboard {
    pub color0: Texture,
    pub color1: Texture,
    pub to_uv: Affine2,
}

impl Checkerboard {
    /// Whether `uv` falls on a `color0` square.
    #[inline]
    fn first(&self, uv: Vec2) -> bool {
        let t = self.to_uv.transform_point2(uv);
        let f = t - t.floor();
        (f.x > 0.5) == (f.y > 0.5)
    }

    #[inline]
    pub fn eval(&self, uv: Vec2) -> glam::Vec3 {
        if self.first(uv) { self.color0.eval(uv) } else { self.color1.eval(uv) }
    }

    /// Mitsuba 3's float lookup: `color1` where [`Checkerboard::eval`] gives `color0`.
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        if self.first(uv) { self.color1.eval_1(uv) } else { self.color0.eval_1(uv) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Mitsuba 3.9.1's values of the default checkerboard (0.4, 0.2), by its Python bindings.
    #[test]
    fn squares_and_float_lookup_as_mitsuba() {
        let c = Checkerboard {
            color0: Texture::Constant(Vec3::splat(0.4)),
            color1: Texture::Constant(Vec3::splat(0.2)),
            to_uv: Affine2::IDENTITY,
        };
        for (uv, rgb, one) in [
            ([0.25, 0.25], 0.4, 0.2),
            ([0.75, 0.25], 0.2, 0.4),
            ([0.75, 0.75], 0.4, 0.2),
            ([1.25, 0.25], 0.4, 0.2),
            ([0.5, 0.25], 0.4, 0.2),
            ([-0.25, 0.25], 0.2, 0.4),
        ] {
            let uv = Vec2::from(uv);
            assert_eq!((c.eval(uv), c.eval_1(uv)), (Vec3::splat(rgb), one), "{uv}");
        }
        let shifted = Checkerboard { to_uv: Affine2::from_translation(Vec2::new(0.5, 0.0)), ..c.clone() };
        assert_eq!(shifted.eval(Vec2::new(0.25, 0.25)), Vec3::splat(0.2));
        let t = Texture::Checkerboard(std::sync::Arc::new(c));
        assert!((t.mean() - Vec3::splat(0.3)).abs().max_element() < 1e-7);
    }
}
