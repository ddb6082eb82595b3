//! The adjoint shading-normal correction, the one place it is written.
//!
//! With shading normals a BSDF evaluated for importance transport (light paths) is not the
//! radiance BSDF with its arguments swapped: it carries the factor
//!
//! |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|)
//!
//! (Veach 1997, §5.3; pbrt-v3's `CorrectShadingNormal`), where `wo` points to the previous
//! vertex of the light path and `wi` to the next. It is 1 where the shading normal is the
//! geometric one, and taken as 0 where it is undefined (a grazing `wi` on the shading horizon).
//!
//! [`shading_correction`] is written once over [`Lanes`], so that the scalar BSDF code
//! ([`super::Bsdf`], [`super::PreparedBsdf`]) and the gather's four-wide kernel evaluate it
//! with the same operations in the same order: the kernel stays bit-identical to the scalar
//! code because it is the same function.

use glam::Vec4;

/// One number or a lane of numbers, with what the correction needs of it.
pub trait Lanes: Copy + std::ops::Mul<Output = Self> + std::ops::Div<Output = Self> {
    fn abs(self) -> Self;
    /// `f` where `den > 0` and `f` is finite, else 0.
    fn finite_ratio_or_zero(f: Self, den: Self) -> Self;
}

impl Lanes for f32 {
    #[inline]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
    #[inline]
    fn finite_ratio_or_zero(f: f32, den: f32) -> f32 {
        if den > 0.0 && f.is_finite() { f } else { 0.0 }
    }
}

impl Lanes for Vec4 {
    #[inline]
    fn abs(self) -> Vec4 {
        Vec4::abs(self)
    }
    #[inline]
    fn finite_ratio_or_zero(f: Vec4, den: Vec4) -> Vec4 {
        Vec4::select(den.cmpgt(Vec4::ZERO) & f.is_finite_mask(), f, Vec4::ZERO)
    }
}

/// |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|), or 0 where it is undefined; the arguments are the four
/// cosines (signed or not: only their magnitudes count).
#[inline]
pub fn shading_correction<T: Lanes>(wo_ns: T, wo_ng: T, wi_ng: T, wi_ns: T) -> T {
    let num = wo_ns.abs() * wi_ng.abs();
    let den = wo_ng.abs() * wi_ns.abs();
    T::finite_ratio_or_zero(num / den, den)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4Swizzles;

    #[test]
    fn lanes_and_scalars_agree_bit_for_bit() {
        let cases = [
            [0.3f32, 0.5, 0.7, 0.2],
            [-0.3, 0.5, -0.7, 0.2],
            [0.3, 0.0, 0.7, 0.2],
            [0.3, 0.5, 0.7, 0.0],
            [1e-30, 1e-30, 1e30, 1e-30],
            [1.0, 1.0, 1.0, 1.0],
        ];
        for c in cases {
            let s = shading_correction(c[0], c[1], c[2], c[3]);
            let v = shading_correction(
                Vec4::splat(c[0]),
                Vec4::splat(c[1]),
                Vec4::splat(c[2]),
                Vec4::splat(c[3]),
            );
            assert_eq!(v.xyz().to_array().map(f32::to_bits), [s.to_bits(); 3], "{c:?}");
            assert!(s.is_finite() && s >= 0.0);
        }
        assert_eq!(shading_correction(0.3f32, 0.0, 0.7, 0.2), 0.0);
        assert_eq!(shading_correction(0.4f32, 0.4, 0.6, 0.6), 1.0);
    }
}
