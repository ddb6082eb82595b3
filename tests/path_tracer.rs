//! Physics tests of the path tracer that need no reference image.

mod common;

use common::{closed_cube, diffuse, render_scene};
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
        let r = render_scene(&scene, &mut PathTracer, 16, 16, 64, 1, depth, 2);
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
    let r = render_scene(&scene, &mut PathTracer, 8, 8, 4, 3, 1, 1);
    for p in &r.image().pixels {
        assert!((*p - glam::Vec3::splat(2.0)).abs().max_element() < 1e-6, "{p}");
    }
}

/// The same seed gives bit-identical images for 1 and 2 threads; another seed does not.
#[test]
fn same_seed_same_image_for_any_thread_count() {
    let scene = closed_cube(diffuse(0.7, 1.0));
    let a = render_scene(&scene, &mut PathTracer, 24, 20, 3, 9, 5, 1).image();
    let b = render_scene(&scene, &mut PathTracer, 24, 20, 3, 9, 5, 2).image();
    assert_eq!(a, b);
    let c = render_scene(&scene, &mut PathTracer, 24, 20, 3, 10, 5, 2).image();
    assert_ne!(a, c);
}
