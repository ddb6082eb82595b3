//! An environment map (Mitsuba 3's `envmap`): radiance at infinity from a latitude-longitude
//! image, exactly as Mitsuba 3 maps and interpolates it, and sampled by its luminance.
//!
//! Mitsuba's mapping: a world direction d goes to the map's frame by the inverse of
//! `to_world`; there u = atan2(x, −z) / 2π and v = acos(y) / π; the image gets a copy of its
//! first column appended (width W + 1) and is interpolated bilinearly at
//! ((u − ½/W) mod 1) · W, v · (H − 1): pixel centres lie at u = (i + ½)/W and rows at
//! θ = jπ/(H − 1), the first and last rows at the poles. The radiance is that times `scale`.
//!
//! Sampling: the W × (H − 1) cells between neighbouring texels, each chosen with probability
//! proportional to the mean luminance of its four corners times its solid angle (the sin θ
//! factor, integrated: 2π/W · (cos θ_j − cos θ_{j+1})), and a uniform point in (u, v) within
//! it. A cell whose corners are all black has zero radiance inside, so the density covers
//! every direction that emits. Per unit solid angle the density is
//! pmf · W (H − 1) / (2π² sin θ). The cell is found by inverting the rows' marginal and the
//! row's conditional distribution (pbrt's and Mitsuba's two-level inversion), the second
//! number picking the row and the first the column: a stratified pair stays stratified over
//! the map. (An alias table over the cells, tried first, turned a Sobol pair into a cell and
//! an offset within it that were functions of each other: 20× the variance of independent
//! numbers on the shared material-preview scene, for the same mean.)

use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// Mitsuba's luminance of linear RGB (Rec. 709 primaries).
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.212_671, 0.715_160, 0.072_169))
}

#[derive(Clone, Debug)]
pub struct Envmap {
    /// The image's width W and height H.
    width: usize,
    height: usize,
    /// H rows of W + 1 texels, the last column a copy of the first.
    texels: Vec<Vec3>,
    pub scale: f32,
    to_world: Mat3,
    from_world: Mat3,
    /// The rows' cumulative weights (H entries, from 0), and each row's cumulative weights
    /// of its cells (H − 1 rows of W + 1 entries, from 0).
    row_cdf: Vec<f64>,
    cell_cdf: Vec<f64>,
    /// Every cell's probability.
    pmf: Vec<f32>,
    /// ∫ L dω over the sphere (mean over the channels), scale included.
    integral: f64,
}

impl Envmap {
    /// The environment of `pixels` (row-major, `width` × `height`, linear RGB, finite and not
    /// negative) turned by `to_world` (its linear part). `Err` says what is wrong.
    pub fn new(
        width: usize,
        height: usize,
        pixels: &[Vec3],
        scale: f32,
        to_world: glam::Mat4,
    ) -> Result<Envmap, String> {
        if width < 2 || height < 3 {
            return Err(format!("{width}×{height}: an environment map needs at least 2×3 pixels"));
        }
        if pixels.len() != width * height {
            return Err(format!("{} pixels for {width}×{height}", pixels.len()));
        }
        if let Some(p) = pixels.iter().find(|p| !p.is_finite() || p.min_element() < 0.0) {
            return Err(format!("pixel {p}: must be finite and not negative"));
        }
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(format!("scale {scale}: must be finite and not negative"));
        }
        let w1 = width + 1;
        let mut texels = Vec::with_capacity(w1 * height);
        for row in pixels.chunks_exact(width) {
            texels.extend_from_slice(row);
            texels.push(row[0]);
        }
        let linear = Mat3::from_mat4(to_world);
        if linear.determinant().abs() < 1e-12 {
            return Err("to_world is singular".into());
        }
        let rows = height - 1;
        let mut weights = Vec::with_capacity(width * rows);
        let mut integral = 0.0f64;
        for j in 0..rows {
            let band = ((j as f64 * std::f64::consts::PI / rows as f64).cos()
                - ((j + 1) as f64 * std::f64::consts::PI / rows as f64).cos())
                * (2.0 * std::f64::consts::PI / width as f64);
            for i in 0..width {
                let t = |x: usize, y: usize| texels[y * w1 + x];
                let mean = (t(i, j) + t(i + 1, j) + t(i, j + 1) + t(i + 1, j + 1)) * 0.25;
                weights.push(luminance(mean) as f64 * band);
                integral += (mean.element_sum() as f64 / 3.0) * band;
            }
        }
        let mut row_cdf = vec![0.0f64];
        let mut cell_cdf = Vec::with_capacity((width + 1) * rows);
        for row in weights.chunks_exact(width) {
            let mut c = 0.0;
            cell_cdf.push(0.0);
            for w in row {
                c += w;
                cell_cdf.push(c);
            }
            row_cdf.push(row_cdf.last().unwrap() + c);
        }
        let total = *row_cdf.last().unwrap();
        if !(total > 0.0 && total.is_finite()) {
            return Err("the environment map is black".into());
        }
        let pmf = weights.iter().map(|w| (w / total) as f32).collect();
        Ok(Envmap {
            width,
            height,
            texels,
            scale,
            to_world: linear,
            from_world: linear.inverse(),
            row_cdf,
            cell_cdf,
            pmf,
            integral: integral * scale as f64,
        })
    }

    /// The image's size.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The texels (H rows of W + 1) and the linear part of `to_world`, for the fingerprint.
    pub fn contents(&self) -> (&[Vec3], Mat3) {
        (&self.texels, self.to_world)
    }

    /// Mitsuba's (u, v) of a direction in the map's frame.
    #[inline]
    fn direction_to_uv(d: Vec3) -> Vec2 {
        Vec2::new(d.x.atan2(-d.z) * (0.5 / PI), d.y.clamp(-1.0, 1.0).acos() * (1.0 / PI))
    }

    /// The texel coordinates of (u, v): x in [0, W), y in [0, H − 1] (Mitsuba's
    /// `eval_spectrum` before the bilinear lookup).
    #[inline]
    fn texel_coordinates(&self, uv: Vec2) -> Vec2 {
        let mut uv = Vec2::new(uv.x - 0.5 / self.width as f32, uv.y);
        uv -= uv.floor();
        uv * Vec2::new(self.width as f32, (self.height - 1) as f32)
    }

    /// The cell of texel coordinates (clamped as Mitsuba clamps its lookup).
    #[inline]
    fn cell(&self, xy: Vec2) -> (usize, usize) {
        ((xy.x as usize).min(self.width - 1), (xy.y as usize).min(self.height - 2))
    }

    /// Radiance arriving from infinity along the unit world direction `w` (pointing away from
    /// the scene): Mitsuba's bilinear lookup times `scale`.
    pub fn radiance(&self, w: Vec3) -> Vec3 {
        let xy = self.texel_coordinates(Self::direction_to_uv(self.from_world * w));
        let (i, j) = self.cell(xy);
        let w1 = xy - Vec2::new(i as f32, j as f32);
        let w0 = Vec2::ONE - w1;
        let row = self.width + 1;
        let k = j * row + i;
        let (v00, v10, v01, v11) =
            (self.texels[k], self.texels[k + 1], self.texels[k + row], self.texels[k + row + 1]);
        let v0 = w0.x * v00 + w1.x * v10;
        let v1 = w0.x * v01 + w1.x * v11;
        (w0.y * v0 + w1.y * v1) * self.scale
    }

    /// A direction drawn by luminance: the unit world direction towards the environment and
    /// its solid-angle density (zero at the poles, where it is never drawn in practice).
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (j, ty) = invert(&self.row_cdf, u.y);
        let w1 = self.width + 1;
        let (i, tx) = invert(&self.cell_cdf[j * w1..(j + 1) * w1], u.x);
        let cell = j * self.width + i;
        let x = (i as f32 + tx) / self.width as f32;
        let uv = Vec2::new(x + 0.5 / self.width as f32, (j as f32 + ty) / (self.height - 1) as f32);
        let (theta, phi) = (uv.y * PI, uv.x * 2.0 * PI);
        let (sin_t, cos_t) = theta.sin_cos();
        let (sin_p, cos_p) = phi.sin_cos();
        let local = Vec3::new(sin_p * sin_t, cos_t, -cos_p * sin_t);
        let w = (self.to_world * local).normalize();
        (w, self.pdf_of(cell, sin_t))
    }

    /// The solid-angle density of [`Envmap::sample`] drawing the unit world direction `w`.
    pub fn pdf(&self, w: Vec3) -> f32 {
        let d = (self.from_world * w).normalize();
        let (i, j) = self.cell(self.texel_coordinates(Self::direction_to_uv(d)));
        let sin_t = (d.x * d.x + d.z * d.z).sqrt();
        self.pdf_of(j * self.width + i, sin_t)
    }

    #[inline]
    fn pdf_of(&self, cell: usize, sin_theta: f32) -> f32 {
        if sin_theta <= 0.0 {
            return 0.0;
        }
        self.pmf[cell] * (self.width * (self.height - 1)) as f32 / (2.0 * PI * PI * sin_theta)
    }

    /// Emitted power into a scene of bounding-sphere radius `radius` (mean over the channels):
    /// π r² ∫ L dω, pbrt's convention for infinite lights (the integral from the cells' mean
    /// radiance; it only sets how often the map is chosen among the lights).
    pub fn power(&self, radius: f32) -> f64 {
        let r = radius as f64;
        std::f64::consts::PI * r * r * self.integral
    }
}

/// The bin of a cumulative distribution (`cdf[0]` = 0, increasing, last entry positive) in
/// which `u` in [0, 1) of the total falls, and where in it (in [0, 1)); never a bin of zero
/// weight.
#[inline]
fn invert(cdf: &[f64], u: f32) -> (usize, f32) {
    let total = cdf[cdf.len() - 1];
    let target = u as f64 * total;
    // The last bin starting at or below the target: its end lies above it.
    let k = (cdf.partition_point(|&c| c <= target) - 1).min(cdf.len() - 2);
    let t = (target - cdf[k]) / (cdf[k + 1] - cdf[k]);
    (k, crate::sampling::reuse::to_unit_f32(t.clamp(0.0, 1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    /// A 12 × 6 map: a gradient, a bright texel, one black row.
    fn map(to_world: Mat4) -> Envmap {
        let (w, h) = (12, 6);
        let mut px = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let v = if y == 4 { 0.0 } else { 0.2 + 0.1 * x as f32 + 0.3 * y as f32 };
                px.push(Vec3::new(v, 0.5 * v, 0.25 + v));
            }
        }
        px[2 * w + 7] = Vec3::new(30.0, 20.0, 10.0);
        Envmap::new(w, h, &px, 1.5, to_world).unwrap()
    }

    fn direction(theta: f64, phi: f64) -> Vec3 {
        Vec3::new((theta.sin() * phi.cos()) as f32, (theta.sin() * phi.sin()) as f32, theta.cos() as f32)
    }

    /// ∫ f(ω) dω over the sphere by the midpoint rule in (cos θ, φ).
    fn integrate(f: impl Fn(Vec3) -> f64) -> f64 {
        let (nz, np) = (600, 1200);
        let mut s = 0.0;
        for i in 0..nz {
            let z = -1.0 + 2.0 * (i as f64 + 0.5) / nz as f64;
            for j in 0..np {
                let phi = std::f64::consts::TAU * (j as f64 + 0.5) / np as f64;
                s += f(direction(z.acos(), phi));
            }
        }
        s * 4.0 * std::f64::consts::PI / (nz * np) as f64
    }

    fn turned() -> Mat4 {
        Mat4::from_rotation_y(0.7) * Mat4::from_rotation_x(-0.3)
    }

    /// Mitsuba's mapping: the texel (i, j) is seen at u = (i + ½)/W, θ = jπ/(H − 1), in the
    /// map's frame (d = (sin φ sin θ, cos θ, −cos φ sin θ)), turned by `to_world`.
    #[test]
    fn texel_centres_map_to_mitsubas_directions() {
        let m = map(turned());
        let (w, h) = (12usize, 6usize);
        for (i, j) in [(0, 1), (7, 2), (11, 3), (5, 4)] {
            let (u, v) = ((i as f32 + 0.5) / w as f32, j as f32 / (h - 1) as f32);
            let (theta, phi) = (v * PI, u * 2.0 * PI);
            let local = Vec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin());
            let got = m.radiance(Mat3::from_mat4(turned()) * local);
            let want = m.texels[j * (w + 1) + i] * 1.5;
            assert!(
                (got - want).abs().max_element() < 1e-3 * want.max_element().max(1.0),
                "{i},{j}: {got} {want}"
            );
        }
    }

    /// The density integrates to one, and what `sample` reports is `pdf` of the direction.
    #[test]
    fn the_density_integrates_to_one_and_matches_the_samples() {
        let m = map(turned());
        let total = integrate(|w| m.pdf(w) as f64);
        assert!((total - 1.0).abs() < 2e-3, "{total}");
        for k in 0..1000 {
            let u = Vec2::new(((k as f32 + 0.5) * 0.618_034).fract(), (k as f32 * 0.754_878 + 0.1).fract());
            let (w, pdf) = m.sample(u);
            assert!((w.length() - 1.0).abs() < 1e-5);
            let again = m.pdf(w);
            // (At the poles sin θ, which both divide by, has too few digits left to compare.)
            let local = Mat3::from_mat4(turned()).inverse() * w;
            if local.y.abs() > 0.9999 {
                continue;
            }
            assert!((pdf - again).abs() <= 1e-3 * pdf, "{u}: {pdf} against {again}");
            // Never a black direction.
            assert!(m.radiance(w).max_element() > 0.0);
        }
    }

    /// The power uses ∫ L dω (the cells' mean radiance times their solid angle, within a
    /// fraction of a percent of the bilinear radiance's integral).
    #[test]
    fn the_power_is_the_radiance_integral() {
        let m = map(turned());
        let want = integrate(|w| m.radiance(w).element_sum() as f64 / 3.0);
        let got = m.power(1.0) / std::f64::consts::PI;
        assert!((got - want).abs() < 1e-2 * want, "{got} {want}");
    }

    /// A chi-square test of the samples against the density, in 8 × 16 bins of (cos θ, φ)
    /// in world space: a wrong density, mapping or Jacobian fails it.
    #[test]
    fn samples_follow_the_density() {
        let m = map(turned());
        let (nz, np) = (8usize, 16usize);
        let bin = |w: Vec3| {
            let z = ((w.z as f64 + 1.0) / 2.0 * nz as f64).min(nz as f64 - 1.0) as usize;
            let phi = (w.y as f64).atan2(w.x as f64).rem_euclid(std::f64::consts::TAU);
            z * np + ((phi / std::f64::consts::TAU * np as f64) as usize).min(np - 1)
        };
        let mut expected = vec![0.0f64; nz * np];
        let (qz, qp) = (40, 40);
        for bz in 0..nz {
            for bp in 0..np {
                let mut s = 0.0;
                for a in 0..qz {
                    let z = -1.0 + 2.0 * (bz as f64 + (a as f64 + 0.5) / qz as f64) / nz as f64;
                    for b in 0..qp {
                        let phi =
                            std::f64::consts::TAU * (bp as f64 + (b as f64 + 0.5) / qp as f64) / np as f64;
                        s += m.pdf(direction(z.acos(), phi)) as f64;
                    }
                }
                expected[bz * np + bp] =
                    s * (2.0 / nz as f64) * (std::f64::consts::TAU / np as f64) / (qz * qp) as f64;
            }
        }
        let n = 200_000usize;
        let mut counts = vec![0usize; nz * np];
        // SplitMix64, 24 bits per number.
        let mut state = 7u64;
        let mut next = || {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u32 << 24) as f32
        };
        for _ in 0..n {
            let (w, _) = m.sample(Vec2::new(next(), next()));
            counts[bin(w)] += 1;
        }
        let mut chi2 = 0.0;
        let mut dof = 0;
        for (c, e) in counts.iter().zip(&expected) {
            let e = e * n as f64;
            if e > 5.0 {
                chi2 += (*c as f64 - e).powi(2) / e;
                dof += 1;
            } else {
                assert!((*c as f64) < 5.0 * e + 10.0, "{c} samples where {e} expected");
            }
        }
        // Far beyond the 99.9 % quantile of χ² with ~128 degrees of freedom (≈ 180).
        assert!(chi2 < 1.6 * dof as f64 + 30.0, "chi² {chi2} for {dof} bins");
    }
}
