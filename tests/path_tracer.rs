//! Physics tests of the path tracer that need no reference image.

mod common;

use common::{Job, closed_cube, diffuse};
use pir::integrator::PathTracer;

/// Furnace test: inside a closed cube whose walls all emit Le and reflect diffusely with
/// albedo a, the radiance everywhere is Le · Σ_{k=0}^{D−1} a^k for `max_depth` D (a path of
/// D segments reaches an emitter after at most D − 1 bounces). This checks the path-length
/// convention of the scene format, the MIS weights between light and BSDF sampling and the
/// unbiasedness of Russian roulette at once.
///
/// Bound: z-test of the image mean over iterations (iterations are independent) at 4.5
/// standard errors, a family-wise false-alarm rate below 1e-4 over the 4 cases (Šidák).
#[test]
fn furnace_matches_the_closed_form_for_every_max_depth() {
    let (a, le) = (0.5f64, 1.0f64);
    let scene = closed_cube(diffuse(a as f32, le as f32));
    for depth in [1u32, 2, 3, 8] {
        let expected: f64 = (0..depth).map(|k| le * a.powi(k as i32)).sum();
        let r = Job { iterations: 64, max_depth: depth, ..Job::default() }.run(&scene, &mut PathTracer);
        assert_eq!(r.stats.dropped, 0);
        let (mean, se) = r.mean_and_stderr();
        for c in 0..3 {
            let z = (mean[c] - expected) / se[c].max(1e-12);
            assert!(
                z.abs() < 4.5 || (mean[c] - expected).abs() < 1e-6,
                "max_depth {depth}: mean {} expected {expected} (stderr {}, z {z:.2})",
                mean[c],
                se[c]
            );
        }
    }
}

/// max_depth = 1: only emitters are seen, with no noise at all.
#[test]
fn max_depth_one_sees_emission_only() {
    let scene = closed_cube(diffuse(0.9, 2.0));
    let r = Job { width: 8, height: 8, iterations: 4, max_depth: 1, threads: 1, ..Job::default() }
        .run(&scene, &mut PathTracer);
    for p in &r.image().pixels {
        assert!((*p - glam::Vec3::splat(2.0)).abs().max_element() < 1e-6, "{p}");
    }
}

/// The same seed gives bit-identical images for 1 and 2 threads; another seed does not.
#[test]
fn same_seed_same_image_for_any_thread_count() {
    let scene = closed_cube(diffuse(0.7, 1.0));
    let job =
        Job { width: 24, height: 20, iterations: 3, seed: 9, max_depth: 5, threads: 1, ..Job::default() };
    let a = job.run(&scene, &mut PathTracer).image();
    let b = Job { threads: 2, ..job.clone() }.run(&scene, &mut PathTracer).image();
    assert_eq!(a, b);
    let c = Job { seed: 10, ..job }.run(&scene, &mut PathTracer).image();
    assert_ne!(a, c);
}
