//! Statistical and physical tests of the materials (`pir::material`): χ² goodness of fit of
//! every non-delta sampler against its pdf (with the pdf's normalisation and the sample-failure
//! rate checked on the same run), reciprocity, white-furnace energy bounds, glass and mirror
//! geometry, the below-surface rules, the transport-mode corrections and NaN safety.
//!
//! Deterministic: every random number comes from `Sampler` with fixed keys.

mod chi2;

use glam::{Vec2, Vec3};
use pir::geometry::Frame;
use pir::material::{Bsdf, LocalGeometry, TransportMode};
use pir::sampling::{Domain, Sampler};

const R: TransportMode = TransportMode::Radiance;
const I: TransportMode = TransportMode::Importance;

/// Number of χ² tests in this file (for the Šidák correction).
const CHI2_TESTS: usize = 3 + 12 + 2 + 6;
const CHI2_SAMPLES: u64 = 1_000_000;

fn normal() -> Vec3 {
    Vec3::new(0.3, -0.5, 0.8).normalize()
}

fn geometry(ns: Vec3, ng: Vec3) -> LocalGeometry {
    LocalGeometry { ng: ng.normalize(), frame: Frame::from_normal(ns.normalize()) }
}

/// A unit direction at `theta_deg` from `n`, azimuth `phi` in n's frame.
fn dir_at(n: Vec3, theta_deg: f32, phi: f32) -> Vec3 {
    let f = Frame::from_normal(n);
    let t = theta_deg.to_radians();
    f.to_world(Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())).normalize()
}

fn sampler(tag: u64) -> Sampler<'static> {
    Sampler::new(0x5eed, tag, Domain::Iteration, 0)
}

fn rel_close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol * a.abs().max(b.abs()).max_element().max(1e-6)
}

/// Samples `bsdf` CHI2_SAMPLES times, checks every sample's weight and pdf against eval / pdf,
/// runs the χ² test and the normalisation check; returns a failure description.
fn chi2_case(name: &str, bsdf: Bsdf, g: &LocalGeometry, wo: Vec3, k: f64, tag: u64) -> Option<String> {
    let sample = |ul: f32, u: Vec2| {
        let s = bsdf.sample(g, wo, ul, u, R)?;
        assert!(!s.delta && s.eta == 1.0, "{name}: non-delta sample flagged delta");
        assert!(s.weight.is_finite() && s.pdf.is_finite() && s.pdf > 0.0);
        let pdf = bsdf.pdf(g, wo, s.wi);
        let eval = bsdf.eval(g, wo, s.wi, R);
        assert!((s.pdf - pdf).abs() <= 1e-5 * pdf, "{name}: pdf {} vs {pdf}", s.pdf);
        assert!(rel_close(s.weight, eval / pdf, 1e-5), "{name}: weight {} vs {}", s.weight, eval / pdf);
        Some(s.wi)
    };
    let pdf = |w: Vec3| bsdf.pdf(g, wo, w);
    let pole = (2.0 * wo.dot(g.frame.n) * g.frame.n - wo).normalize();
    fit(name, &sample, &pdf, pole, k, tag)
}

/// The χ² fit of `sample` against `pdf` (directions binned about `pole`) and the check that
/// 1 − ∫pdf equals the rate at which `sample` fails.
fn fit(
    name: &str,
    sample: &dyn Fn(f32, Vec2) -> Option<Vec3>,
    pdf: &dyn Fn(Vec3) -> f32,
    pole: Vec3,
    k: f64,
    tag: u64,
) -> Option<String> {
    let grid = chi2::Grid::new(pole, k, 20, 20);
    let mut counts = vec![0u64; grid.n_s * grid.n_phi + 1];
    let fail_cell = counts.len() - 1;
    let mut rng = sampler(tag);
    for _ in 0..CHI2_SAMPLES {
        let (ul, u) = (rng.next_f32(), rng.next_2d());
        match sample(ul, u) {
            None => counts[fail_cell] += 1,
            Some(wi) => counts[grid.cell(wi)] += 1,
        }
    }
    let integrals = grid.integrate(pdf, CHI2_SAMPLES as f64);
    let total: f64 = integrals.iter().sum();
    let n = CHI2_SAMPLES as f64;
    let mut expected: Vec<f64> = integrals.iter().map(|p| p * n).collect();
    expected.push((1.0 - total).max(0.0) * n);

    let fail_rate = counts[fail_cell] as f64 / n;
    let sigma = (fail_rate.max(1e-6) * (1.0 - fail_rate) / n).sqrt();
    let mut problems = Vec::new();
    if total > 1.0 + 1e-4 {
        problems.push(format!("∫pdf = {total} > 1"));
    }
    if ((1.0 - total) - fail_rate).abs() > 5.0 * sigma + 2e-4 {
        problems.push(format!("1 − ∫pdf = {} but failure rate {fail_rate}", 1.0 - total));
    }
    let r = chi2::chi2_test(&counts, &expected);
    let level = chi2::sidak(0.01, CHI2_TESTS);
    eprintln!(
        "{name}: χ² = {:.1}, dof = {}, p = {:.4}, ∫pdf = {total:.6}, fail = {fail_rate:.6}",
        r.statistic, r.dof, r.p_value
    );
    if let Some(msg) = r.impossible {
        problems.push(msg);
    }
    if r.p_value < level {
        problems.push(format!("χ² p-value {} < {level}", r.p_value));
    }
    (!problems.is_empty()).then(|| format!("{name}: {}", problems.join("; ")))
}

/// The χ² test has power: small errors in the density (a slightly different roughness, a
/// missing masking term) are rejected.
#[test]
fn chi2_rejects_wrong_densities() {
    let n = normal();
    let g = geometry(n, n);
    let wo = dir_at(n, 45.0, 0.5);
    let pole = 2.0 * wo.dot(n) * n - wo;
    let truth = Bsdf::Glossy { albedo: Vec3::splat(0.3), specular: Vec3::splat(0.3), roughness: 0.15 };
    let sample = |ul: f32, u: Vec2| truth.sample(&g, wo, ul, u, R).map(|s| s.wi);
    let wrong = Bsdf::Glossy { albedo: Vec3::splat(0.3), specular: Vec3::splat(0.3), roughness: 0.16 };
    let pdf = |w: Vec3| wrong.pdf(&g, wo, w);
    assert!(fit("α 0.16 vs 0.15", &sample, &pdf, pole, 4.0, 900).is_some());
    // Cosine sampling checked against a uniform-hemisphere density.
    let diffuse = Bsdf::Diffuse { albedo: Vec3::ONE };
    let sample = |ul: f32, u: Vec2| diffuse.sample(&g, wo, ul, u, R).map(|s| s.wi);
    let uniform = |w: Vec3| if w.dot(n) > 0.0 { 0.5 * std::f32::consts::FRAC_1_PI } else { 0.0 };
    assert!(fit("cosine vs uniform", &sample, &uniform, n, 1.0, 901).is_some());
}

/// eval against an independent f64 transcription of the contract's formula (θ-based D and
/// G1), with a shading normal equal to the geometric one.
#[test]
fn glossy_eval_matches_the_contract_formula() {
    let n = normal();
    let g = geometry(n, n);
    let frame = Frame::from_normal(n);
    let mut rng = sampler(7);
    let albedo = Vec3::new(0.2, 0.4, 0.6);
    let specular = Vec3::new(0.7, 0.5, 0.3);
    for roughness in [0.045f32, 0.15, 0.5, 1.0] {
        let bsdf = Bsdf::Glossy { albedo, specular, roughness };
        let a = roughness as f64;
        let d = |cos_h: f64| {
            let tan2 = (1.0 - cos_h * cos_h) / (cos_h * cos_h);
            1.0 / (std::f64::consts::PI * a * a * cos_h.powi(4) * (1.0 + tan2 / (a * a)).powi(2))
        };
        let g1 = |cos_v: f64| {
            let tan2 = (1.0 - cos_v * cos_v) / (cos_v * cos_v);
            2.0 / (1.0 + (1.0 + a * a * tan2).sqrt())
        };
        for _ in 0..5000 {
            let wo = dir_at(n, 89.0 * rng.next_f32(), std::f32::consts::TAU * rng.next_f32());
            // Directions near the mirror direction too, where D is large.
            let wi = if rng.next_f32() < 0.5 {
                dir_at(n, 89.0 * rng.next_f32(), std::f32::consts::TAU * rng.next_f32())
            } else {
                let m = frame.to_world(
                    Vec3::new(
                        0.3 * a as f32 * (rng.next_f32() - 0.5),
                        0.3 * a as f32 * (rng.next_f32() - 0.5),
                        1.0,
                    )
                    .normalize(),
                );
                2.0 * wo.dot(m) * m - wo
            };
            let (co, ci) = (wo.dot(n) as f64, wi.dot(n) as f64);
            if co < 1e-2 || ci < 1e-2 {
                continue;
            }
            let h = (wo + wi).normalize();
            let cos_h = h.dot(n) as f64;
            let spec = d(cos_h) * g1(co) * g1(ci) / (4.0 * co * ci);
            let f = albedo.as_dvec3() / std::f64::consts::PI + specular.as_dvec3() * spec;
            let expect = (f * ci).as_vec3();
            let got = bsdf.eval(&g, wo, wi, R);
            assert!(rel_close(got, expect, 2e-3), "α={roughness}: {got} vs {expect}");
        }
    }
}

fn assert_no_failures(failures: Vec<Option<String>>) {
    let failures: Vec<String> = failures.into_iter().flatten().collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn chi2_diffuse() {
    let n = normal();
    let g = geometry(n, n);
    let bsdf = Bsdf::Diffuse { albedo: Vec3::new(0.8, 0.5, 0.2) };
    let results = [0.0, 45.0, 80.0]
        .iter()
        .enumerate()
        .map(|(i, &theta)| {
            let wo = dir_at(n, theta, 0.7);
            chi2_case(&format!("diffuse θo={theta}"), bsdf, &g, wo, 1.0, 100 + i as u64)
        })
        .collect();
    assert_no_failures(results);
}

#[test]
fn chi2_glossy() {
    let n = normal();
    let g = geometry(n, n);
    let mut results = Vec::new();
    let mut tag = 200;
    for roughness in [0.05f32, 0.15, 0.5, 1.0] {
        let k = if roughness < 0.3 { 4.0 } else { 2.0 };
        for theta in [0.0f32, 45.0, 80.0] {
            let bsdf = Bsdf::Glossy {
                albedo: Vec3::new(0.5, 0.3, 0.2),
                specular: Vec3::new(0.2, 0.3, 0.45),
                roughness,
            };
            let wo = dir_at(n, theta, 2.1);
            results.push(chi2_case(&format!("glossy α={roughness} θo={theta}"), bsdf, &g, wo, k, tag));
            tag += 1;
        }
    }
    // Pure specular lobe, and a shading normal tilted from the geometric one (samples below
    // the geometric surface are rejected and the pdf is zero there).
    let spec = Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::ONE, roughness: 0.3 };
    results.push(chi2_case("glossy specular only α=0.3 θo=45", spec, &g, dir_at(n, 45.0, 1.0), 2.0, tag));
    let tilted = geometry(dir_at(n, 25.0, 0.4), n);
    let bsdf = Bsdf::Glossy { albedo: Vec3::splat(0.4), specular: Vec3::splat(0.4), roughness: 0.5 };
    let wo = dir_at(n, 60.0, 0.4 + std::f32::consts::PI);
    results.push(chi2_case("glossy tilted shading normal α=0.5", bsdf, &tilted, wo, 1.0, tag + 1));
    assert_no_failures(results);
}

/// The rough dielectric's sampler against its pdf over the whole sphere (reflection and
/// refraction), lit from outside and from inside, GGX and Beckmann, on a shading normal tilted
/// off the geometric one; every sample's weight is eval / pdf and its η the index crossed.
#[test]
fn chi2_rough_dielectric() {
    use pir::material::microfacet::{Distribution, Microfacet};
    let n = normal();
    let g = geometry(dir_at(n, 10.0, 0.4), n);
    let mut results = Vec::new();
    let cases = [
        (Distribution::Ggx, 0.3f32, 1.5f32, 30.0f32, false),
        (Distribution::Ggx, 0.6, 1.5, 75.0, false),
        (Distribution::Ggx, 0.3, 1.5, 20.0, true),
        (Distribution::Ggx, 0.2, 1.33, 50.0, true),
        (Distribution::Beckmann, 0.3, 1.5, 45.0, false),
        (Distribution::Beckmann, 0.4, 2.0, 35.0, true),
    ];
    for (tag, (kind, alpha, eta, theta, inside)) in cases.into_iter().enumerate() {
        let bsdf = Bsdf::RoughDielectric {
            eta,
            reflectance: Vec3::ONE,
            transmittance: Vec3::new(0.9, 0.7, 0.5),
            microfacet: Microfacet::new(kind, alpha),
        };
        let side = if inside { -1.0 } else { 1.0 };
        let wo = side * dir_at(g.frame.n, theta, 2.3);
        let name = format!("roughdielectric {kind:?} α={alpha} η={eta} θo={theta} inside={inside}");
        let sample = |ul: f32, u: Vec2| {
            let s = bsdf.sample(&g, wo, ul, u, R)?;
            let refracted = s.wi.dot(n) * wo.dot(n) < 0.0;
            let crossed = if !refracted {
                1.0
            } else if inside {
                1.0 / eta
            } else {
                eta
            };
            assert!(!s.delta && s.eta == crossed, "{name}: {s:?}");
            let (pdf, eval) = (bsdf.pdf(&g, wo, s.wi), bsdf.eval(&g, wo, s.wi, R));
            assert!((s.pdf - pdf).abs() <= 1e-5 * pdf, "{name}: pdf {} vs {pdf}", s.pdf);
            assert!(rel_close(s.weight, eval / pdf, 1e-5), "{name}: weight {} vs {}", s.weight, eval / pdf);
            Some(s.wi)
        };
        let pdf = |w: Vec3| bsdf.pdf(&g, wo, w);
        results.push(fit(&name, &sample, &pdf, -wo, 1.0, 300 + tag as u64));
    }
    assert_no_failures(results);
}

/// Uniformly distributed directions over the sphere (for pairs of directions).
fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[test]
fn reciprocity_of_diffuse_and_glossy() {
    let n = normal();
    let g = geometry(n, n);
    let mut rng = sampler(1);
    for bsdf in [
        Bsdf::Diffuse { albedo: Vec3::new(0.7, 0.2, 0.4) },
        Bsdf::Glossy {
            albedo: Vec3::new(0.3, 0.2, 0.1),
            specular: Vec3::new(0.5, 0.6, 0.7),
            roughness: 0.05,
        },
        Bsdf::Glossy { albedo: Vec3::new(0.3, 0.2, 0.1), specular: Vec3::new(0.5, 0.6, 0.7), roughness: 0.4 },
        Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::ONE, roughness: 1.0 },
    ] {
        let mut nonzero = 0;
        for _ in 0..20_000 {
            let (wo, wi) = (uniform_sphere(rng.next_2d()), uniform_sphere(rng.next_2d()));
            let (co, ci) = (wo.dot(n), wi.dot(n));
            let a = bsdf.eval(&g, wo, wi, R);
            let b = bsdf.eval(&g, wi, wo, R);
            if co <= 0.0 || ci <= 0.0 {
                assert_eq!(a, Vec3::ZERO);
                assert_eq!(b, Vec3::ZERO);
                continue;
            }
            if co < 1e-3 || ci < 1e-3 {
                continue; // the cosines' relative rounding error dominates
            }
            let (fa, fb) = (a / ci, b / co);
            assert!(rel_close(fa, fb, 1e-4), "{bsdf:?}: f(wo,wi) = {fa}, f(wi,wo) = {fb}");
            // With ns = ng the importance-mode BSDF is the same.
            assert!(rel_close(bsdf.eval(&g, wo, wi, I), a, 1e-5));
            nonzero += 1;
        }
        assert!(nonzero > 3000);
    }
}

/// Mean sample weight (the directional albedo) over `n` samples, with its standard error.
fn directional_albedo(bsdf: Bsdf, g: &LocalGeometry, wo: Vec3, n: u32, tag: u64) -> (Vec3, Vec3) {
    let mut rng = sampler(tag);
    let (mut sum, mut sum2) = (Vec3::ZERO, Vec3::ZERO);
    for _ in 0..n {
        if let Some(s) = bsdf.sample(g, wo, rng.next_f32(), rng.next_2d(), R) {
            sum += s.weight;
            sum2 += s.weight * s.weight;
        }
    }
    let mean = sum / n as f32;
    let var = (sum2 / n as f32 - mean * mean).max(Vec3::ZERO);
    (mean, (var / n as f32).powf(0.5))
}

#[test]
fn white_furnace() {
    let n = normal();
    let g = geometry(n, n);
    // Diffuse of albedo 1 reflects everything: every weight is exactly 1.
    for theta in [0.0, 45.0, 89.0] {
        let (e, _) =
            directional_albedo(Bsdf::Diffuse { albedo: Vec3::ONE }, &g, dir_at(n, theta, 0.3), 100_000, 10);
        assert!((e - Vec3::ONE).abs().max_element() < 1e-5, "diffuse θ={theta}: {e}");
    }
    // albedo + specular ≤ 1: E[weight] ≤ 1 (3σ tolerance).
    let mut tag = 20;
    for roughness in [1e-4f32, 0.05, 0.15, 0.5, 1.0] {
        for theta in [0.0, 45.0, 80.0, 89.0] {
            let wo = dir_at(n, theta, 1.3);
            for (albedo, specular) in
                [(Vec3::new(0.5, 0.0, 0.9), Vec3::new(0.5, 1.0, 0.1)), (Vec3::ZERO, Vec3::ONE)]
            {
                let bsdf = Bsdf::Glossy { albedo, specular, roughness };
                let (e, se) = directional_albedo(bsdf, &g, wo, 50_000, tag);
                tag += 1;
                assert!(
                    (e - 3.0 * se).max_element() <= 1.0 + 1e-4,
                    "α={roughness} θ={theta}: E = {e} ± {se}"
                );
                if albedo == Vec3::ZERO && theta == 0.0 && roughness <= 0.05 {
                    assert!(e.min_element() > 0.99, "α={roughness}: E = {e}");
                }
            }
        }
    }
}

#[test]
fn glass_fresnel_snell_and_weights() {
    let n = normal();
    let g = geometry(n, n);
    for ior in [1.33f32, 1.5, 2.0] {
        let r0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
        let bsdf = Bsdf::Glass { ior };
        // Normal incidence: reflection exactly for u_lobe < r0.
        let refl = bsdf.sample(&g, n, 0.5 * r0, Vec2::ZERO, R).unwrap();
        let refr = bsdf.sample(&g, n, r0 + 1e-3, Vec2::ZERO, R).unwrap();
        assert!((refl.pdf - r0).abs() < 1e-6 && (refr.pdf - (1.0 - r0)).abs() < 1e-6);
        assert!((refl.wi - n).length() < 1e-5 && (refr.wi + n).length() < 1e-5);
        assert!(refl.delta && refr.delta);
        assert_eq!(refl.weight, Vec3::ONE);
        assert_eq!(refl.eta, 1.0);
        assert!((refr.eta - ior).abs() < 1e-6);

        for theta in [10.0f32, 45.0, 70.0, 89.0] {
            for (outside, mode) in [(true, R), (false, R), (true, I), (false, I)] {
                let wo = if outside { dir_at(n, theta, 0.9) } else { -dir_at(n, theta, 0.9) };
                let cos_o = wo.dot(n);
                let mut probs = 0.0;
                for u_lobe in [0.0f32, 0.999_999] {
                    let s = bsdf.sample(&g, wo, u_lobe, Vec2::splat(0.5), mode).unwrap();
                    assert!(s.delta && s.weight.is_finite());
                    assert!((s.wi.length() - 1.0).abs() < 1e-5);
                    let cos_i = s.wi.dot(n);
                    if cos_i * cos_o > 0.0 {
                        // Reflection: mirror direction, weight 1.
                        assert!((s.wi - (2.0 * cos_o * n - wo)).length() < 1e-5);
                        assert_eq!(s.weight, Vec3::ONE);
                        assert_eq!(s.eta, 1.0);
                    } else {
                        // Snell: η_o sin θo = η_i sin θi, and the plane of incidence is kept.
                        let (eta_o, eta_i) = if outside { (1.0, ior) } else { (ior, 1.0) };
                        let sin_o = (1.0 - cos_o * cos_o).sqrt();
                        let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
                        assert!((eta_o * sin_o - eta_i * sin_i).abs() < 1e-4, "Snell {theta}");
                        assert!(wo.cross(n).normalize().dot(s.wi).abs() < 1e-4);
                        assert!((s.eta - eta_i / eta_o).abs() < 1e-5);
                        let expect = match mode {
                            TransportMode::Radiance => (eta_o / eta_i).powi(2),
                            TransportMode::Importance => 1.0,
                        };
                        assert!((s.weight - Vec3::splat(expect)).abs().max_element() < 1e-5);
                    }
                    probs += s.pdf;
                }
                // The two lobes' probabilities sum to 1 (or TIR gives reflection with prob. 1).
                let sin_c = 1.0 / ior;
                let tir = !outside && (1.0 - cos_o * cos_o).sqrt() > sin_c;
                if tir {
                    assert!((probs - 2.0).abs() < 1e-6, "TIR expected at θ={theta}");
                } else {
                    assert!((probs - 1.0).abs() < 1e-5, "F + (1−F) = {probs}");
                }
            }
        }
        // Glass is delta: no eval, no pdf.
        assert_eq!(bsdf.eval(&g, n, -n, R), Vec3::ZERO);
        assert_eq!(bsdf.pdf(&g, n, -n), 0.0);
        // In the plane: no sample.
        assert!(
            bsdf.sample(&g, dir_at(n, 90.0, 0.0), 0.3, Vec2::ZERO, R)
                .map(|s| s.weight.is_finite())
                .unwrap_or(true)
        );
    }
}

#[test]
fn glass_total_internal_reflection_from_inside() {
    let n = normal();
    let g = geometry(n, n);
    let ior = 1.5f32;
    let critical = (1.0 / ior).asin().to_degrees();
    let bsdf = Bsdf::Glass { ior };
    for theta in [critical + 0.5, 60.0, 85.0] {
        let wo = -dir_at(n, theta, 0.2);
        for u_lobe in [0.0, 0.5, 0.999_999] {
            let s = bsdf.sample(&g, wo, u_lobe, Vec2::ZERO, R).unwrap();
            assert_eq!(s.pdf, 1.0);
            assert_eq!(s.weight, Vec3::ONE);
            assert!(s.wi.dot(n) < 0.0, "TIR stays inside");
        }
    }
    // Just below the critical angle some light escapes.
    let wo = -dir_at(n, critical - 0.5, 0.2);
    let s = bsdf.sample(&g, wo, 0.999_999, Vec2::ZERO, R).unwrap();
    assert!(s.wi.dot(n) > 0.0);
}

#[test]
fn mirror_reflects_exactly() {
    let n = normal();
    let g = geometry(n, n);
    let specular = Vec3::new(0.9, 0.5, 0.1);
    let bsdf = Bsdf::Mirror { specular };
    for theta in [0.0, 30.0, 75.0, 89.5] {
        let wo = dir_at(n, theta, 1.7);
        for mode in [R, I] {
            let s = bsdf.sample(&g, wo, 0.42, Vec2::new(0.1, 0.9), mode).unwrap();
            assert!((s.wi - (2.0 * wo.dot(n) * n - wo)).length() < 1e-6);
            assert!((s.wi.dot(n) - wo.dot(n)).abs() < 1e-6);
            assert!(rel_close(s.weight, specular, 1e-6));
            assert!(s.delta && s.pdf == 1.0 && s.eta == 1.0);
        }
        assert_eq!(bsdf.eval(&g, wo, 2.0 * wo.dot(n) * n - wo, R), Vec3::ZERO);
        assert_eq!(bsdf.pdf(&g, wo, 2.0 * wo.dot(n) * n - wo), 0.0);
    }
    assert!(bsdf.is_delta() && Bsdf::Glass { ior: 1.5 }.is_delta());
}

fn reflective() -> [Bsdf; 4] {
    [
        Bsdf::Diffuse { albedo: Vec3::splat(0.8) },
        Bsdf::Glossy { albedo: Vec3::splat(0.3), specular: Vec3::splat(0.6), roughness: 0.2 },
        Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::ONE, roughness: 1e-6 },
        Bsdf::Mirror { specular: Vec3::ONE },
    ]
}

#[test]
fn below_the_geometric_surface_is_black() {
    let n = normal();
    let g = geometry(n, n);
    let mut rng = sampler(3);
    for bsdf in reflective() {
        for _ in 0..2000 {
            let up = dir_at(n, 85.0 * rng.next_f32(), 6.3 * rng.next_f32());
            let down = -dir_at(n, 85.0 * rng.next_f32(), 6.3 * rng.next_f32());
            for mode in [R, I] {
                for (wo, wi) in [(up, down), (down, up), (down, down)] {
                    assert_eq!(bsdf.eval(&g, wo, wi, mode), Vec3::ZERO);
                    assert_eq!(bsdf.pdf(&g, wo, wi), 0.0);
                }
                assert!(bsdf.sample(&g, down, rng.next_f32(), rng.next_2d(), mode).is_none());
                if let Some(s) = bsdf.sample(&g, up, rng.next_f32(), rng.next_2d(), mode) {
                    assert!(s.wi.dot(n) > 0.0);
                }
            }
        }
    }
    // The geometric normal decides even when the shading normal disagrees: wo in front of ns
    // but behind ng.
    let ng = normal();
    let ns = dir_at(ng, 40.0, 0.0);
    let g = geometry(ns, ng);
    let f = Frame::from_normal(ng);
    let wo = f.to_world(Vec3::new(0.9, 0.0, -0.1).normalize());
    assert!(wo.dot(ns) > 0.0 && wo.dot(ng) < 0.0);
    for bsdf in reflective() {
        assert!(bsdf.sample(&g, wo, 0.5, Vec2::splat(0.5), R).is_none());
        assert_eq!(bsdf.eval(&g, wo, ng, R), Vec3::ZERO);
    }
}

#[test]
fn shading_normals_stay_finite_and_importance_mode_is_corrected() {
    let ng = normal();
    let mut rng = sampler(4);
    let mut checked = 0;
    for tilt in [5.0f32, 30.0, 60.0] {
        let ns = dir_at(ng, tilt, 1.1);
        let g = geometry(ns, ng);
        for bsdf in reflective().into_iter().chain([Bsdf::Glass { ior: 1.5 }]) {
            for _ in 0..5000 {
                let wo = uniform_sphere(rng.next_2d());
                let (ul, u) = (rng.next_f32(), rng.next_2d());
                let r = bsdf.sample(&g, wo, ul, u, R);
                let i = bsdf.sample(&g, wo, ul, u, I);
                assert_eq!(r.is_some(), i.is_some());
                let (Some(r), Some(i)) = (r, i) else { continue };
                assert!(r.weight.is_finite() && i.weight.is_finite() && r.pdf.is_finite());
                assert!(r.weight.min_element() >= 0.0 && r.pdf > 0.0);
                assert_eq!(r.wi, i.wi);
                let wi = r.wi;
                let corr = wo.dot(ns).abs() * wi.dot(ng).abs() / (wo.dot(ng).abs() * wi.dot(ns).abs());
                // Glass refraction: the importance weight has no (η_i/η_t)² factor.
                let radiance_scale =
                    if let Bsdf::Glass { .. } = bsdf { r.weight.x * i.weight.x.signum() } else { 1.0 };
                let _ = radiance_scale;
                let expect = if let Bsdf::Glass { .. } = bsdf {
                    let s = if wi.dot(ns) * wo.dot(ns) < 0.0 { 1.0 / r.weight.x } else { 1.0 };
                    r.weight * s * corr
                } else {
                    r.weight * corr
                };
                let well_conditioned = wo.dot(ns).abs().min(wi.dot(ns).abs()) > 1e-3;
                if well_conditioned && corr.is_finite() && corr < 1e4 {
                    assert!(
                        rel_close(i.weight, expect, 1e-3),
                        "{bsdf:?}: {} vs {expect}; r {:?} corr {corr} wo.ns {} wi.ns {} wo.ng {} wi.ng {}",
                        i.weight,
                        r,
                        wo.dot(ns),
                        wi.dot(ns),
                        wo.dot(ng),
                        wi.dot(ng)
                    );
                    checked += 1;
                }
                let e = bsdf.eval(&g, wo, wi, R);
                let ei = bsdf.eval(&g, wo, wi, I);
                assert!(e.is_finite() && ei.is_finite());
                assert!(!well_conditioned || rel_close(ei, e * corr, 1e-3) || corr >= 1e4);
            }
        }
    }
    assert!(checked > 10_000);
}

#[test]
fn degenerate_inputs_give_no_nan() {
    let n = normal();
    let g = geometry(n, n);
    let in_plane = Frame::from_normal(n).s;
    let mut all = reflective().to_vec();
    all.push(Bsdf::Glass { ior: 1.5 });
    all.push(Bsdf::Glass { ior: 1.0 });
    all.push(Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::ZERO, roughness: 0.3 });
    all.push(Bsdf::Glossy { albedo: Vec3::splat(0.5), specular: Vec3::splat(0.5), roughness: 0.0 });
    all.push(Bsdf::Diffuse { albedo: Vec3::ZERO });
    for bsdf in all {
        for wo in [in_plane, n, -n, dir_at(n, 89.999, 0.0)] {
            for wi in [in_plane, n, -n, -in_plane, dir_at(n, 89.999, 3.0)] {
                for mode in [R, I] {
                    let e = bsdf.eval(&g, wo, wi, mode);
                    let p = bsdf.pdf(&g, wo, wi);
                    assert!(e.is_finite() && p.is_finite() && e.min_element() >= 0.0 && p >= 0.0, "{bsdf:?}");
                }
            }
            // (u.x picks the glossy lobe: 0.25 and 0.499_999 reach the specular one of the
            // half-and-half material above the bottom of its range, 0.5 the diffuse one.)
            for u in [
                Vec2::ZERO,
                Vec2::splat(0.999_999),
                Vec2::new(0.0, 0.999_999),
                Vec2::new(0.5, 0.25),
                Vec2::new(0.25, 0.5),
                Vec2::new(0.499_999, 0.75),
            ] {
                for ul in [0.0, 0.5, 0.999_999] {
                    for mode in [R, I] {
                        if let Some(s) = bsdf.sample(&g, wo, ul, u, mode) {
                            assert!(
                                s.weight.is_finite() && s.pdf.is_finite() && s.pdf > 0.0,
                                "{bsdf:?} {s:?}"
                            );
                            assert!(s.wi.is_finite() && (s.wi.length() - 1.0).abs() < 1e-4);
                        }
                    }
                }
            }
        }
        // wo exactly in the plane gives no sample.
        let axis = geometry(Vec3::Z, Vec3::Z);
        for ul in [0.0, 0.5, 0.999] {
            assert!(bsdf.sample(&axis, Vec3::X, ul, Vec2::splat(0.5), R).is_none(), "{bsdf:?}");
        }
    }
}
