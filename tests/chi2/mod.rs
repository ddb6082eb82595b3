//! A χ² goodness-of-fit test of a direction sampler against its claimed density, in the
//! manner of pbrt's and Mitsuba 3's BSDF tests (Mitsuba's `mitsuba.chi2`):
//!
//! - the sphere is binned on a grid of (s, φ) about a chosen pole, with cos θ = 1 − 2 s^k
//!   (k = 1 is the usual equal-area (cos θ, φ) grid; k > 1 gives finer bins near the pole,
//!   where a narrow lobe is put);
//! - expected counts are N · ∫bin pdf dω, integrated with nested adaptive Simpson quadrature in
//!   f64; an extra cell counts failed samples, expected N · (1 − ∫sphere pdf);
//! - cells expected to hold fewer than 5 samples are pooled; a sample in a cell whose expected
//!   count is (numerically) zero fails the test outright;
//! - the p-value of the statistic with (cells − 1) degrees of freedom comes from the
//!   regularised upper incomplete gamma function Q(dof/2, χ²/2) (Numerical Recipes §6.2).

use glam::Vec3;
use pir::geometry::Frame;
use std::f64::consts::PI;

/// Where directions are binned.
pub struct Grid {
    pub frame: Frame,
    pub k: f64,
    pub n_s: usize,
    pub n_phi: usize,
}

impl Grid {
    pub fn new(pole: Vec3, k: f64, n_s: usize, n_phi: usize) -> Self {
        Grid { frame: Frame::from_normal(pole.normalize()), k, n_s, n_phi }
    }

    fn direction(&self, s: f64, phi: f64) -> Vec3 {
        let cos_t = (1.0 - 2.0 * s.powf(self.k)).clamp(-1.0, 1.0);
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let l = Vec3::new((sin_t * phi.cos()) as f32, (sin_t * phi.sin()) as f32, cos_t as f32);
        self.frame.to_world(l)
    }

    /// dω / (ds dφ).
    fn jacobian(&self, s: f64) -> f64 {
        2.0 * self.k * s.powf(self.k - 1.0)
    }

    pub fn cell(&self, w: Vec3) -> usize {
        let l = self.frame.to_local(w.normalize());
        let cos_t = (l.z as f64).clamp(-1.0, 1.0);
        let s = ((1.0 - cos_t) / 2.0).max(0.0).powf(1.0 / self.k);
        let mut phi = (l.y as f64).atan2(l.x as f64);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let i = ((s * self.n_s as f64) as usize).min(self.n_s - 1);
        let j = ((phi / (2.0 * PI) * self.n_phi as f64) as usize).min(self.n_phi - 1);
        i * self.n_phi + j
    }

    /// ∫ pdf over every cell, row-major in (s, φ). The quadrature tolerance of a cell is set
    /// from a coarse estimate p of its mass so that the error stays far below the statistical
    /// noise of a test with `samples` samples: 1e-2 · √(p / samples) (at least 1e-10).
    pub fn integrate(&self, pdf: &dyn Fn(Vec3) -> f32, samples: f64) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.n_s * self.n_phi);
        let ds = 1.0 / self.n_s as f64;
        let dphi = 2.0 * PI / self.n_phi as f64;
        for i in 0..self.n_s {
            for j in 0..self.n_phi {
                let (s0, p0) = (i as f64 * ds, j as f64 * dphi);
                let f = |s: f64, phi: f64| self.jacobian(s) * pdf(self.direction(s, phi)) as f64;
                // Coarse estimate: 8×8 midpoint rule.
                let m = 8;
                let mut coarse = 0.0;
                for a in 0..m {
                    for b in 0..m {
                        let s = s0 + (a as f64 + 0.5) / m as f64 * ds;
                        let phi = p0 + (b as f64 + 0.5) / m as f64 * dphi;
                        coarse += f(s, phi);
                    }
                }
                coarse *= ds * dphi / (m * m) as f64;
                let eps = (1e-2 * (coarse.max(0.0) / samples).sqrt()).max(1e-10);
                let eps_inner = eps / (ds * 2.0 * self.k);
                let inner = |s: f64| adaptive_simpson(&|phi| f(s, phi), p0, p0 + dphi, eps_inner, 12);
                out.push(adaptive_simpson(&inner, s0, s0 + ds, eps, 12));
            }
        }
        out
    }
}

/// Adaptive Simpson quadrature on [a, b] started from 4 panels (so that features narrower
/// than the interval are not skipped), absolute tolerance `eps`.
pub fn adaptive_simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, eps: f64, depth: u32) -> f64 {
    let panels = 4;
    let h = (b - a) / panels as f64;
    (0..panels)
        .map(|p| {
            let (x0, x1) = (a + p as f64 * h, a + (p + 1) as f64 * h);
            let xm = 0.5 * (x0 + x1);
            let (f0, fm, f1) = (f(x0), f(xm), f(x1));
            let whole = (x1 - x0) / 6.0 * (f0 + 4.0 * fm + f1);
            simpson_rec(f, x0, x1, f0, fm, f1, whole, eps / panels as f64, depth)
        })
        .sum()
}

#[allow(clippy::too_many_arguments)]
fn simpson_rec(
    f: &dyn Fn(f64) -> f64,
    a: f64,
    b: f64,
    fa: f64,
    fm: f64,
    fb: f64,
    whole: f64,
    eps: f64,
    depth: u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
    let (flm, frm) = (f(lm), f(rm));
    let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    let delta = left + right - whole;
    if depth == 0 || delta.abs() <= 15.0 * eps {
        return left + right + delta / 15.0;
    }
    simpson_rec(f, a, m, fa, flm, fm, left, 0.5 * eps, depth - 1)
        + simpson_rec(f, m, b, fm, frm, fb, right, 0.5 * eps, depth - 1)
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9).
pub fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    assert!(a > 0.0 && x >= 0.0);
    if x == 0.0 {
        return 1.0;
    }
    let ln_pre = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        // Series for P(a, x).
        let (mut ap, mut del) = (a, 1.0 / a);
        let mut sum = del;
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (1.0 - sum * ln_pre.exp()).clamp(0.0, 1.0)
    } else {
        // Continued fraction for Q(a, x) (modified Lentz).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (ln_pre.exp() * h).clamp(0.0, 1.0)
    }
}

/// The result of [`chi2_test`].
#[derive(Debug)]
pub struct Chi2 {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Set when a sample landed where the density is zero.
    pub impossible: Option<String>,
}

/// χ² test of `observed` counts against `expected` counts (same length, totals equal).
pub fn chi2_test(observed: &[u64], expected: &[f64]) -> Chi2 {
    assert_eq!(observed.len(), expected.len());
    let mut cells: Vec<(f64, f64)> = Vec::new();
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    let mut impossible = None;
    for (i, (&o, &e)) in observed.iter().zip(expected).enumerate() {
        if e < 1e-5 && o > 0 {
            impossible = Some(format!("{o} samples in cell {i} whose expected count is {e:e}"));
        }
        if e < 5.0 {
            pool_o += o as f64;
            pool_e += e;
        } else {
            cells.push((o as f64, e));
        }
    }
    if pool_e > 0.0 || pool_o > 0.0 {
        if pool_e < 5.0 && !cells.is_empty() {
            // Merge the pool into the smallest regular cell.
            let k = (0..cells.len()).min_by(|&a, &b| cells[a].1.total_cmp(&cells[b].1)).unwrap();
            cells[k].0 += pool_o;
            cells[k].1 += pool_e;
        } else {
            cells.push((pool_o, pool_e));
        }
    }
    let statistic: f64 = cells.iter().map(|&(o, e)| (o - e) * (o - e) / e).sum();
    let dof = cells.len().saturating_sub(1).max(1);
    let p_value = gamma_q(dof as f64 / 2.0, statistic / 2.0);
    Chi2 { statistic, dof, p_value, impossible }
}

/// Šidák-corrected significance level for `tests` independent tests at overall `alpha`.
pub fn sidak(alpha: f64, tests: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / tests as f64)
}

#[test]
fn incomplete_gamma_matches_closed_forms() {
    // Q(1, x) = e^{-x}; χ² with 2 dof has survival e^{-x/2}.
    for x in [0.1, 1.0, 3.0, 10.0, 40.0] {
        assert!((gamma_q(1.0, x) - (-x).exp()).abs() < 1e-12, "{x}");
    }
    // Q(1/2, x) = erfc(√x): erfc(1) = 0.157299207050285.
    assert!((gamma_q(0.5, 1.0) - 0.157_299_207_050_285).abs() < 1e-10);
    assert!((ln_gamma(10.0) - 362_880f64.ln()).abs() < 1e-10);
    // The median of χ² with many dof is ≈ dof (1 − 2/(9 dof))³.
    let dof = 399.0;
    let median = dof * (1.0f64 - 2.0 / (9.0 * dof)).powi(3);
    assert!((gamma_q(dof / 2.0, median / 2.0) - 0.5).abs() < 1e-3);
}
