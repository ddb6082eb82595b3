//! The Sobol sampler (`--sampler sobol`, the default) through whole renders: unbiased for the
//! path tracer and for VPLs traced from Sobol light paths, a lower error than independent
//! numbers where the integrand is smooth, and the same image for any thread count.
//!
//! A Sobol render's iterations are not independent (a pixel's samples are stratified over
//! them), so the standard error of its mean cannot come from their spread: these tests
//! replicate renders over seeds, which are independent randomisations, and take the spread
//! of the seeds' image means.

mod common;

use common::{Job, closed_cube, diffuse};
use pir::integrator::{Clamping, InstantRadiosity, Integrator, PathTracer, VirtualLights};
use pir::sampling::SamplerKind;
use pir::scene::Scene;

const Z: f64 = 4.5;

/// Makes a fresh integrator (one per render).
type Make = Box<dyn Fn() -> Box<dyn Integrator>>;

/// Image means (red) of `job` rendered with seeds 1..=n, and their mean and standard error.
fn over_seeds(
    scene: &Scene,
    job: &Job,
    seeds: u64,
    mut integrator: impl FnMut() -> Box<dyn Integrator>,
) -> (f64, f64) {
    let means: Vec<f64> = (1..=seeds)
        .map(|seed| {
            let image = Job { seed, ..job.clone() }.run(scene, integrator().as_mut()).image();
            image.pixels.iter().map(|p| p.x as f64).sum::<f64>() / image.pixels.len() as f64
        })
        .collect();
    let n = means.len() as f64;
    let mean = means.iter().sum::<f64>() / n;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

fn sobol(job: Job) -> Job {
    Job { sampler: SamplerKind::Sobol, ..job }
}

/// The furnace (walls of albedo a emitting Le) gives Le · Σ_{k<D} a^k: the path tracer with
/// Sobol camera samples, and `pir-mis` without a bound (unbiased, see tests/mis.rs) with
/// Sobol camera samples and Sobol light paths. z-test over 10 seeds at 4.5 standard errors.
#[test]
fn sobol_renders_are_unbiased_in_the_furnace() {
    let (a, le) = (0.5f64, 1.0f64);
    let scene = closed_cube(diffuse(a as f32, le as f32));
    for depth in [2u32, 3, 8] {
        let expected: f64 = (0..depth).map(|k| le * a.powi(k as i32)).sum();
        let job = sobol(Job { iterations: 16, max_depth: depth, ..Job::default() });
        let cases: [(&str, Make); 2] = [
            ("pt", Box::new(|| Box::new(PathTracer))),
            (
                "ir-mis",
                Box::new(|| {
                    Box::new(InstantRadiosity::new(VirtualLights::WeighedPoints(Clamping::None), 64))
                }),
            ),
        ];
        for (name, make) in cases {
            let (mean, se) = over_seeds(&scene, &job, 10, make);
            let z = (mean - expected) / se.max(1e-12);
            eprintln!(
                "{name}, max_depth {depth}: mean {mean:.5} expected {expected:.5} (se {se:.2e}, z {z:+.2})"
            );
            assert!(z.abs() < Z || (mean - expected).abs() < 1e-6, "{name}, max_depth {depth}: z = {z:.2}");
        }
    }
}

/// Mean squared error per pixel against the closed form, averaged over 4 seeds.
fn pixel_mse(
    scene: &Scene,
    job: &Job,
    expected: f64,
    mut integrator: impl FnMut() -> Box<dyn Integrator>,
) -> f64 {
    let seeds = 4;
    let mut sum = 0.0;
    for seed in 1..=seeds {
        let image = Job { seed, ..job.clone() }.run(scene, integrator().as_mut()).image();
        sum += image.pixels.iter().map(|p| (p.x as f64 - expected).powi(2)).sum::<f64>()
            / image.pixels.len() as f64;
    }
    sum / seeds as f64
}

/// Where the integrand is smooth, stratification pays: in the furnace after 64 iterations
/// the per-pixel error is well below that of independent numbers (at most half), for the path
/// tracer's direct light (max_depth 2) and for one bounce of `pir-mis` without a bound
/// (max_depth 3: the bounce is gathered from the VPLs of 64 light paths, stratified within
/// each iteration, by camera samples stratified over the iterations). Independent numbers,
/// or a Sobol sampler that ignored its index, give a ratio near 1.
#[test]
fn sobol_lowers_the_error_where_the_integrand_is_smooth() {
    let (a, le) = (0.5f64, 1.0f64);
    let scene = closed_cube(diffuse(a as f32, le as f32));
    let cases: [(&str, u32, Make); 2] = [
        ("pt", 2, Box::new(|| Box::new(PathTracer))),
        (
            "ir-mis, 64 paths",
            3,
            Box::new(|| Box::new(InstantRadiosity::new(VirtualLights::WeighedPoints(Clamping::None), 64))),
        ),
    ];
    for (name, depth, make) in cases {
        let expected: f64 = (0..depth).map(|k| le * a.powi(k as i32)).sum();
        let job = Job { iterations: 64, max_depth: depth, ..Job::default() };
        let independent = pixel_mse(&scene, &job, expected, &make);
        let stratified = pixel_mse(&scene, &sobol(job.clone()), expected, &make);
        eprintln!("{name}: per-pixel MSE {stratified:.3e} (sobol) against {independent:.3e} (independent)");
        assert!(stratified < 0.5 * independent, "{name}: {stratified:.3e} against {independent:.3e}");
    }
}

/// Sobol renders are bit-identical for 1 and 2 threads, for the path tracer and for a
/// many-light method; another seed gives another image.
#[test]
fn sobol_renders_do_not_depend_on_the_thread_count() {
    let scene = closed_cube(diffuse(0.7, 1.0));
    let job = sobol(Job {
        width: 24,
        height: 20,
        iterations: 5,
        seed: 9,
        max_depth: 5,
        threads: 1,
        ..Job::default()
    });
    let cases: [Make; 2] = [
        Box::new(|| Box::new(PathTracer)),
        Box::new(|| Box::new(InstantRadiosity::new(VirtualLights::WeighedPoints(Clamping::None), 100))),
    ];
    for make in cases {
        let a = job.run(&scene, make().as_mut()).image();
        let b = Job { threads: 2, ..job.clone() }.run(&scene, make().as_mut()).image();
        assert_eq!(a, b);
        let c = Job { seed: 10, ..job.clone() }.run(&scene, make().as_mut()).image();
        assert_ne!(a, c);
    }
}
