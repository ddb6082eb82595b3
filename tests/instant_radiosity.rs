//! Physics tests of the VPL methods that need no reference image.

mod common;

use common::{Job, closed_cube, diffuse};
use pir::integrator::{Clamping, InstantRadiosity};

const Z: f64 = 4.5;

/// Furnace: closed cube of emitting diffuse walls (albedo a, emission Le); every method that
/// renders pt's path space gives Le · Σ_{k<D} a^k for max_depth D. Iterations are independent
/// (fresh VPLs each), so per-iteration means give an honest standard error even though the
/// pixels of one iteration share their VPLs. |z| < 4.5 per case.
#[test]
fn plain_vpls_are_unbiased_in_the_furnace_for_every_max_depth() {
    let (a, le) = (0.5f64, 1.0f64);
    let scene = closed_cube(diffuse(a as f32, le as f32));
    for depth in [2u32, 3, 4, 8] {
        let expected: f64 = (0..depth).map(|k| le * a.powi(k as i32)).sum();
        let mut ir = InstantRadiosity::points(Clamping::None, 64);
        let r = Job { iterations: 48, max_depth: depth, ..Job::default() }.run(&scene, &mut ir);
        let (mean, se) = r.mean_and_stderr();
        let z = (mean[0] - expected) / se[0].max(1e-12);
        eprintln!(
            "ir, max_depth {depth}: mean {:.5} expected {expected:.5} (stderr {:.2e}, z {z:+.2})",
            mean[0], se[0]
        );
        assert!(z.abs() < Z || (mean[0] - expected).abs() < 1e-6, "max_depth {depth}: z = {z:.2}");
    }
}

/// A constant clamp removes energy for ever (the image is too dark), and the progressive clamp
/// gives it back: after many iterations its bias is below the constant clamp's.
#[test]
fn constant_clamp_darkens_and_progressive_clamp_recovers() {
    let (a, le) = (0.7f64, 1.0f64);
    let scene = closed_cube(diffuse(a as f32, le as f32));
    let depth = 6;
    let expected: f64 = (0..depth).map(|k| le * a.powi(k as i32)).sum();
    // A harsh bound, so that the bias is large against the noise.
    let b = 0.5;
    let job = Job { iterations: 64, max_depth: depth, ..Job::default() };
    let clamped = job.run(&scene, &mut InstantRadiosity::points(Clamping::Constant { b }, 64));
    let (m_c, se_c) = clamped.mean_and_stderr();
    let z_c = (m_c[0] - expected) / se_c[0];
    eprintln!("ir-clamp b={b}: mean {:.5} expected {expected:.5} (z {z_c:+.1})", m_c[0]);
    assert!(z_c < -Z, "a constant clamp must darken: z = {z_c:.2}");

    let progressive =
        job.run(&scene, &mut InstantRadiosity::points(Clamping::Progressive { b1: b, alpha: 0.6 }, 64));
    // Bias of the last quarter of the iterations (b_i is largest there).
    let late = &progressive.iteration_means[48..];
    let m_late = late.iter().map(|m| m[0]).sum::<f64>() / late.len() as f64;
    let late_c = &clamped.iteration_means[48..];
    let m_late_c = late_c.iter().map(|m| m[0]).sum::<f64>() / late_c.len() as f64;
    eprintln!("late iterations: pir-clamp {m_late:.5}, ir-clamp {m_late_c:.5}, expected {expected:.5}");
    assert!(
        (expected - m_late) < 0.5 * (expected - m_late_c),
        "progressive clamping must remove most of the constant clamp's bias"
    );
}

/// Virtual spherical lights in the furnace: a constant radius keeps a bias that does not go
/// away (z-test over all iterations, |z| > 4.5), the progressive radius gives most of it back
/// (late iterations, where r_i is smallest), and nothing non-finite appears near the corners.
#[test]
fn spheres_are_biased_and_progressive_spheres_recover() {
    use pir::integrator::{Radius, VirtualLights};
    let (a, le) = (0.7f64, 1.0f64);
    let scene = closed_cube(diffuse(a as f32, le as f32));
    let depth = 6;
    let expected: f64 = (0..depth).map(|k| le * a.powi(k as i32)).sum();
    let job = Job { width: 8, height: 8, iterations: 96, max_depth: depth, ..Job::default() };
    let r = 0.5;
    let spheres =
        |alpha| InstantRadiosity::new(VirtualLights::Spheres { radius: Radius::Global(r), alpha }, 32);
    let constant = job.run(&scene, &mut spheres(None));
    let progressive = job.run(&scene, &mut spheres(Some(0.6)));
    let late = |run: &common::Rendered| {
        let late = &run.iteration_means[64..];
        late.iter().map(|m| m[0]).sum::<f64>() / late.len() as f64
    };
    let (m, se) = constant.mean_and_stderr();
    let z = (m[0] - expected) / se[0];
    eprintln!(
        "vsl r={r}: mean {:.5} (z {z:+.1}); late iterations: vsl {:.5}, pir-vsl {:.5}; expected {expected:.5}",
        m[0],
        late(&constant),
        late(&progressive)
    );
    assert!(z < -4.5, "a constant radius must keep a bias: z = {z:.2}");
    assert!((expected - late(&progressive)) < 0.6 * (expected - late(&constant)));
    assert_eq!(constant.stats.dropped + progressive.stats.dropped, 0);
}
