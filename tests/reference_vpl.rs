//! The many-light methods against the Mitsuba 3 references (skipped, with a message, when
//! `../shared` is absent; a failure on CI, see `common::require`): the progressive methods converge, the constant-parameter ones keep
//! a bias.
//!
//! Renders are 32×32 and compared with the 256×256 reference box-averaged 8×8, which is
//! exactly the 32×32 image (one-pixel box filter), so the image means are the same quantity
//! at a fraction of the cost. Measured on the Cornell box, the variance of one iteration's
//! image mean is about 30/pixels + 0.13/paths (relative): the per-pixel noise dominates, so
//! the tests use many pixels and few light paths per iteration.
//!
//! Bounds: iterations are independent (fresh VPLs each), so the per-iteration image means are
//! i.i.d. and give the standard error of the rendered mean; the reference's own noise is
//! negligible against it (16,384 spp of a path tracer). Consistency: every channel mean must
//! pass a z-test at |z| < 4.5 (Šidák over the channels and cases keeps false alarms below
//! 1e-4). The quick tests run a few hundred iterations, where the standard error is a few
//! tenths of a percent; the `#[ignore]`d long tests (`cargo test --release --test
//! reference_vpl -- --ignored`) run long enough for a standard error near 0.1 % and also
//! require the means within 0.5 % of the reference. Persistent bias: a constant clamp must be
//! darker than the reference by more than 4.5 standard errors. Convergence: the relative MSE
//! after all iterations is below that after a quarter of them.

mod common;

use common::{Job, shared_dir};
use pir::image::{RgbImage, metrics, read_exr};
use pir::integrator::{Clamping, InstantRadiosity, Integrator, Radius, VirtualLights};
use pir::sampling::SamplerKind;
use pir::scene::Scene;

const Z: f64 = 4.5;
const FACTOR: usize = 8;

struct Case {
    scene: Scene,
    reference: RgbImage,
    name: &'static str,
}

fn case(scene_rel: &str, reference_rel: &str, name: &'static str) -> Option<Case> {
    let shared = shared_dir(scene_rel)?;
    let scene = pir::scene::load(&shared.join(scene_rel)).unwrap();
    let (reference, _) = read_exr(&shared.join(reference_rel)).unwrap();
    Some(Case { scene, reference: reference.downsample(FACTOR).unwrap(), name })
}

fn cornell() -> Option<Case> {
    case("scenes/cornell-box/original.toml", "references/cornell-box-original.exr", "cornell")
}

fn spheres() -> Option<Case> {
    case("scenes/cornell-box/sphere.toml", "references/cornell-box-sphere.exr", "mirror-glass")
}

struct Outcome {
    z: [f64; 3],
    rel: [f64; 3],
    rel_mse_quarter: f64,
    rel_mse: f64,
}

fn run(c: &Case, method: &str, integrator: &mut dyn Integrator, iterations: u64) -> Outcome {
    let job = Job {
        width: c.reference.width,
        height: c.reference.height,
        iterations,
        seed: 77,
        max_depth: c.scene.defaults().max_depth,
        threads: std::thread::available_parallelism().map_or(2, |n| n.get()),
        snapshot_at: vec![iterations / 4],
        // Independent iterations: the standard errors below come from their spread.
        sampler: SamplerKind::Independent,
        ..Job::default()
    };
    let r = job.run(&c.scene, integrator);
    assert_eq!(r.stats.dropped, 0, "{}: NaN/Inf samples", c.name);
    let (mean, se) = r.mean_and_stderr();
    let ref_mean = c.reference.mean();
    let z = std::array::from_fn(|k| (mean[k] - ref_mean[k]) / se[k]);
    let rel = std::array::from_fn(|k| (mean[k] - ref_mean[k]) / ref_mean[k]);
    let rel_mse = metrics(&r.image(), &c.reference).unwrap().rel_mse;
    let rel_mse_quarter = metrics(&r.snapshots[0].1, &c.reference).unwrap().rel_mse;
    eprintln!(
        "{} {}: {} it, mean {:+.3} {:+.3} {:+.3} % (z {:+.1} {:+.1} {:+.1}), relMSE {:.3e} at {} it, {:.3e} at {} it",
        c.name,
        method,
        iterations,
        100.0 * rel[0],
        100.0 * rel[1],
        100.0 * rel[2],
        z[0],
        z[1],
        z[2],
        rel_mse_quarter,
        iterations / 4,
        rel_mse,
        iterations
    );
    Outcome { z, rel, rel_mse_quarter, rel_mse }
}

fn assert_consistent(c: &Case, o: &Outcome) {
    for k in 0..3 {
        assert!(o.z[k].abs() < Z, "{}: channel {k} z = {:.2}", c.name, o.z[k]);
    }
    assert!(o.rel_mse < o.rel_mse_quarter, "{}: relative MSE must fall with iterations", c.name);
}

/// The long tests' acceptance criterion on top of the z-test.
fn assert_within_half_percent(c: &Case, o: &Outcome) {
    assert_consistent(c, o);
    for k in 0..3 {
        assert!(o.rel[k].abs() < 0.005, "{}: channel {k} mean off by {:.3} %", c.name, 100.0 * o.rel[k]);
    }
}

const PATHS: usize = 64;
const QUICK: u64 = 400;
const LONG: u64 = 8_000;

fn pir_clamp(c: &Case) -> InstantRadiosity {
    InstantRadiosity::points(
        Clamping::progressive(Clamping::default_bound(c.scene.bounds().diagonal())),
        PATHS,
    )
}

fn pir_vsl() -> InstantRadiosity {
    InstantRadiosity::new(VirtualLights::Spheres { radius: Radius::Density, alpha: Some(0.6) }, PATHS)
}

#[test]
fn pir_clamp_converges_on_the_cornell_box() {
    let Some(c) = cornell() else { return };
    assert_consistent(&c, &run(&c, "pir-clamp", &mut pir_clamp(&c), QUICK));
}

#[test]
fn pir_clamp_converges_on_the_mirror_and_glass_box() {
    let Some(c) = spheres() else { return };
    assert_consistent(&c, &run(&c, "pir-clamp", &mut pir_clamp(&c), QUICK));
}

#[test]
fn pir_vsl_converges_on_the_cornell_box() {
    let Some(c) = cornell() else { return };
    assert_consistent(&c, &run(&c, "pir-vsl", &mut pir_vsl(), QUICK));
}

#[test]
fn pir_vsl_converges_on_the_mirror_and_glass_box() {
    let Some(c) = spheres() else { return };
    assert_consistent(&c, &run(&c, "pir-vsl", &mut pir_vsl(), QUICK));
}

/// A constant clamp fifty times below the default darkens the Cornell box for ever.
#[test]
fn constant_clamp_stays_too_dark_on_the_cornell_box() {
    let Some(c) = cornell() else { return };
    let b = 0.02 * Clamping::default_bound(c.scene.bounds().diagonal());
    let o = run(&c, "ir-clamp", &mut InstantRadiosity::points(Clamping::Constant { b }, PATHS), QUICK);
    for k in 0..3 {
        assert!(o.z[k] < -Z, "ir-clamp must stay darker than the reference: channel {k} z = {:.2}", o.z[k]);
    }
}

/// Both progressive methods, after 8,000 iterations, within 0.5 % of both references in
/// every channel (the latest figures are in `docs/measurements.md`).
#[test]
#[ignore = "long: about three minutes"]
fn long_progressive_methods_within_half_a_percent() {
    for c in [cornell(), spheres()].into_iter().flatten() {
        assert_within_half_percent(&c, &run(&c, "pir-clamp", &mut pir_clamp(&c), LONG));
        assert_within_half_percent(&c, &run(&c, "pir-vsl", &mut pir_vsl(), LONG));
    }
}

/// The default constant clamp's bias is small (about −0.6 % on the Cornell box), so it shows
/// best as a floor under the relative MSE: over a 4× longer run a consistent method's error
/// falls about 3–4× (pir-clamp: 2.75× measured), a biased one's hardly at all (ir-clamp: 1.02×
/// measured). Asserted: it falls by less than 2×, and every channel mean is below the
/// reference.
#[test]
#[ignore = "long: about a minute"]
fn long_default_constant_clamp_keeps_its_bias() {
    let Some(c) = cornell() else { return };
    let b = Clamping::default_bound(c.scene.bounds().diagonal());
    let o = run(&c, "ir-clamp", &mut InstantRadiosity::points(Clamping::Constant { b }, PATHS), LONG);
    assert!(o.rel_mse > 0.5 * o.rel_mse_quarter, "ir-clamp's error must stop falling");
    for k in 0..3 {
        assert!(o.rel[k] < 0.0, "ir-clamp must be darker than the reference: channel {k}");
    }
}
