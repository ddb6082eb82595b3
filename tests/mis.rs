//! The weighed connections of `pir-mis` (`src/integrator/many_light/mis.rs`): unbiased
//! without a bound, for diffuse and glossy receivers and VPLs, and a progressive bound whose
//! bias falls with the iterations.

mod common;

use common::{Job, Rendered, closed_cube, diffuse};
use glam::Vec3;
use pir::integrator::{Clamping, Gather, InstantRadiosity, PathTracer, VirtualLights};
use pir::material::{Bsdf, Material};
use pir::scene::Scene;

const Z: f64 = 4.5;

fn weighed(clamping: Clamping, paths: usize) -> InstantRadiosity {
    InstantRadiosity::new(VirtualLights::WeighedPoints(clamping), paths)
}

/// A closed cube of emitting glossy walls (a diffuse base and a GGX lobe of roughness 0.15):
/// every receiver and every VPL glossy.
fn glossy_cube() -> Scene {
    closed_cube(Material {
        name: "glossy".into(),
        bsdf: Bsdf::Glossy { albedo: Vec3::splat(0.2), specular: Vec3::splat(0.6), roughness: 0.15 },
        emission: Vec3::ONE,
        two_sided: false,
        textures: None,
    })
}

/// z of the difference of two renders' means (independent seeds), red channel.
fn z_between(a: &Rendered, b: &Rendered) -> (f64, f64, f64) {
    let ((ma, sa), (mb, sb)) = (a.mean_and_stderr(), b.mean_and_stderr());
    let z = (ma[0] - mb[0]) / (sa[0] * sa[0] + sb[0] * sb[0]).sqrt().max(1e-12);
    (ma[0], mb[0], z)
}

/// Without a bound the two techniques' weights sum to one on every path, so the furnace
/// gives Le · Σ_{k<D} a^k exactly, for every max_depth (z-test over independent iterations).
#[test]
fn weighed_vpls_are_unbiased_in_the_furnace_for_every_max_depth() {
    let (a, le) = (0.5f64, 1.0f64);
    let scene = closed_cube(diffuse(a as f32, le as f32));
    for depth in [2u32, 3, 4, 8] {
        let expected: f64 = (0..depth).map(|k| le * a.powi(k as i32)).sum();
        let r = Job { iterations: 48, max_depth: depth, ..Job::default() }
            .run(&scene, &mut weighed(Clamping::None, 64));
        let (mean, se) = r.mean_and_stderr();
        let z = (mean[0] - expected) / se[0].max(1e-12);
        eprintln!("ir-mis, max_depth {depth}: mean {:.5} expected {expected:.5} (z {z:+.2})", mean[0]);
        assert!(z.abs() < Z || (mean[0] - expected).abs() < 1e-6, "max_depth {depth}: z = {z:.2}");
    }
}

/// The same with glossy receivers and glossy VPLs, where the weights depend on the lobes:
/// the weighed gather without a bound agrees with the path tracer (two independent renders,
/// z of their difference), also where Russian roulette plays on the light paths, and also
/// when the gather is resampled (its estimates fold in an approximate weight).
#[test]
fn weighed_vpls_match_the_path_tracer_on_glossy_walls() {
    let scene = glossy_cube();
    for depth in [3u32, 6] {
        let job = Job { iterations: 64, max_depth: depth, ..Job::default() };
        let pt = Job { iterations: 256, seed: 7, ..job.clone() }.run(&scene, &mut PathTracer);
        for (name, gather) in
            [("all", Gather::All), ("resample", Gather::Resampled { candidates: 32, samples: 4 })]
        {
            let mis = job.run(&scene, &mut weighed(Clamping::None, 64).with_gather(gather));
            let (m, p, z) = z_between(&mis, &pt);
            eprintln!("glossy cube, max_depth {depth}, gather {name}: ir-mis {m:.5}, pt {p:.5} (z {z:+.2})");
            assert!(z.abs() < Z, "max_depth {depth}, gather {name}: z = {z:.2}");
        }
    }
}

/// A harsh constant bound on the weighted connection darkens the glossy cube for ever; the
/// progressive bound of `pir-mis` gives most of it back in the late iterations.
#[test]
fn the_progressive_bound_recovers_what_a_constant_bound_removes() {
    let scene = glossy_cube();
    let depth = 4;
    let job = Job { iterations: 64, max_depth: depth, ..Job::default() };
    let truth = Job { iterations: 256, seed: 11, ..job.clone() }.run(&scene, &mut PathTracer);
    let (expected, se_t) = (truth.mean_and_stderr().0[0], truth.mean_and_stderr().1[0]);
    let b = 0.5;
    let constant = job.run(&scene, &mut weighed(Clamping::Constant { b }, 64));
    let (m_c, se_c) = constant.mean_and_stderr();
    let z_c = (m_c[0] - expected) / (se_c[0] * se_c[0] + se_t * se_t).sqrt();
    eprintln!("constant bound {b}: mean {:.5}, pt {expected:.5} (z {z_c:+.1})", m_c[0]);
    assert!(z_c < -Z, "a constant bound must darken: z = {z_c:.2}");

    let progressive = job.run(&scene, &mut weighed(Clamping::Progressive { b1: b, alpha: 0.6 }, 64));
    let late = |r: &Rendered| r.iteration_means[48..].iter().map(|m| m[0]).sum::<f64>() / 16.0;
    let (m_p, m_k) = (late(&progressive), late(&constant));
    eprintln!("late iterations: pir-mis {m_p:.5}, constant {m_k:.5}, pt {expected:.5}");
    assert!(expected - m_p < 0.5 * (expected - m_k), "the progressive bound must remove most of the bias");
}

/// Same seed, same image, whatever the thread count.
#[test]
fn weighed_gather_does_not_depend_on_the_thread_count() {
    let scene = glossy_cube();
    let run = |threads| {
        Job { iterations: 4, threads, ..Job::default() }
            .run(&scene, &mut weighed(Clamping::progressive(1.0), 16))
            .image()
    };
    assert!(run(1).pixels == run(2).pixels, "pir-mis differs between 1 and 2 threads");
}
