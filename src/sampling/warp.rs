//! Warps from the unit square to the domains the renderer samples.

use glam::{BVec4A, Vec2, Vec3, Vec4};
use std::f32::consts::PI;

/// Cosine-weighted direction about +z (Malley's method); pdf = cos θ / π.
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Shirley–Chiu concentric map to the unit disk.
///
/// The map's angle is π/4 · (a ratio in [−1, 1]) or π/2 minus that, so its cosine and sine
/// come from [`sin_cos_quarter`] (a polynomial) instead of a libm `sincosf` call per sample.
/// Which of the two wedges a sample falls in is a coin toss, so the two cases share one
/// evaluation and differ only in operands picked by selects: no branch to mispredict half
/// the time. The values are bit for bit those of the two-branch form.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    // |x| > |y|: radius x at angle π/4 · y/x; otherwise radius y at π/2 − π/4 · x/y, whose
    // cosine and sine are the sine and cosine of π/4 · x/y. The pairs are picked by 4-lane
    // selects: LLVM turns scalar ones back into a branch where the target has no masked
    // scalar moves (SSE2, AVX2), even with `select_unpredictable`.
    let x_major = BVec4A::splat(o.x.abs() > o.y.abs());
    let pick = |a: Vec2, b: Vec2| Vec4::select(x_major, a.extend(0.0).extend(0.0), b.extend(0.0).extend(0.0));
    let ro = pick(o, Vec2::new(o.y, o.x));
    let (sin, cos) = sin_cos_quarter((PI / 4.0) * (ro.y / ro.x));
    let d = pick(Vec2::new(cos, sin), Vec2::new(sin, cos));
    ro.x * Vec2::new(d.x, d.y)
}

/// (sin x, cos x) for |x| ≤ π/4 by their Taylor polynomials to x⁹ and x⁸, whose remainders
/// there are below 2e-9 and 3e-8: as close as `f32` rounding.
#[inline]
pub fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let x2 = x * x;
    let sin =
        x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let cos = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0))));
    (sin, cos)
}

/// Uniform barycentrics `(u, v)` on a triangle (the point is `(1-u-v) a + u b + v c`).
#[inline]
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

/// Uniform direction in the cone about +z with `cos θ ≥ cos_max`; pdf = 1 / (2π (1 − cos_max)).
pub fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_t = 1.0 - u.x * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quarter_sin_cos_matches_libm() {
        for k in -1000..=1000 {
            let x = k as f32 / 1000.0 * (PI / 4.0);
            let (s, c) = sin_cos_quarter(x);
            assert!((s - x.sin()).abs() < 2e-7 && (c - x.cos()).abs() < 2e-7, "{x}: {s} {c}");
        }
    }

    /// The concentric map without branches gives the two-branch form's values bit for bit
    /// (random points, the diagonals where the wedges meet, the axes and the corners).
    #[test]
    fn concentric_disk_matches_the_two_branch_form() {
        let reference = |u: Vec2| {
            let o = 2.0 * u - Vec2::ONE;
            if o == Vec2::ZERO {
                return Vec2::ZERO;
            }
            if o.x.abs() > o.y.abs() {
                let (sin, cos) = sin_cos_quarter((PI / 4.0) * (o.y / o.x));
                o.x * Vec2::new(cos, sin)
            } else {
                let (sin, cos) = sin_cos_quarter((PI / 4.0) * (o.x / o.y));
                o.y * Vec2::new(sin, cos)
            }
        };
        let mut rng = crate::sampling::Sampler::new(3, 0, crate::sampling::Domain::Iteration, 0);
        let grid = (0..=64).flat_map(|i| (0..=64).map(move |j| Vec2::new(i as f32 / 64.0, j as f32 / 64.0)));
        let random = (0..100_000).map(|_| rng.next_2d());
        for u in grid.chain(random) {
            let (a, b) = (concentric_disk(u), reference(u));
            assert_eq!((a.x.to_bits(), a.y.to_bits()), (b.x.to_bits(), b.y.to_bits()), "{u}");
        }
    }

    #[test]
    fn warps_stay_in_their_domains() {
        for i in 0..32 {
            for j in 0..32 {
                let u = Vec2::new(i as f32 / 31.0, j as f32 / 31.0);
                let w = cosine_hemisphere(u);
                assert!(w.z >= 0.0 && (w.length() - 1.0).abs() < 1e-5);
                let b = uniform_triangle(u);
                assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
                let c = uniform_cone(u, 0.8);
                assert!(c.z >= 0.8 - 1e-6 && (c.length() - 1.0).abs() < 1e-5);
            }
        }
    }
}
