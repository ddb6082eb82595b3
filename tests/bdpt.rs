//! The bidirectional weighing of `pir-bdpt` (`src/integrator/many_light/bidirectional.rs`):
//! without a bound every path's techniques (emitter hit, next-event estimation, a connection
//! at each camera vertex) weigh to one, so the estimate is unbiased per iteration for
//! diffuse, glossy and delta surfaces; the progressive bound's bias falls with the
//! iterations; the image does not depend on the thread count.

mod common;

use common::{Job, Rendered, closed_cube, closed_cube_of, diffuse};
use glam::Vec3;
use pir::integrator::many_light::Connect;
use pir::integrator::many_light::Pilot;
use pir::integrator::many_light::bidirectional::light_samples_for;
use pir::integrator::many_light::importance::WORTH_IT;
use pir::integrator::many_light::path_count::{CAUSTIC_RARE, PILOT_PATHS};
use pir::integrator::many_light::subpath::LIGHT_TRACING_COUNT;
use pir::integrator::many_light::view_pilot::{self, VIEW_PILOT_RAYS};
use pir::integrator::methods::{PirBdpt, Pt};
use pir::integrator::{
    BDPT_AUTO_PATHS, BDPT_PATHS, BDPT_VPLS, Clamping, Counters, DEFAULT_LIGHT_SAMPLES, Gather,
    InstantRadiosity, Method, MethodConfig, MethodParams, PathTracer, VirtualLights,
};
use pir::material::{Bsdf, Material};
use pir::sampling::SamplerKind;
use pir::scene::Scene;

const Z: f64 = 4.5;

/// Which camera vertices connect: each changes which techniques the weights count. (The
/// test scenes' glossy material, α 0.15, is glossy for `Connect::Glossy`: in the mixed cube
/// it connects after the glossy walls only.)
const CONNECT: [Connect; 4] = [Connect::First, Connect::FirstTwo, Connect::All, Connect::Glossy];

fn bdpt(clamping: Clamping, paths: usize) -> InstantRadiosity {
    bdpt_connecting(clamping, Connect::default(), paths)
}

/// With as many light samples at the first vertex as the default (`--connect first` and
/// `glossy`), one (`first-two`) or three (`all`), so that every test covers a count other than one, whose
/// weights count the light samples, and the count of one.
fn bdpt_connecting(clamping: Clamping, connect: Connect, paths: usize) -> InstantRadiosity {
    let light_samples = match connect {
        Connect::First | Connect::Glossy => pir::integrator::DEFAULT_LIGHT_SAMPLES,
        Connect::FirstTwo => 1,
        Connect::All => 3,
    };
    InstantRadiosity::new(VirtualLights::Bidirectional(clamping, connect), paths)
        .with_light_samples(light_samples)
}

fn glossy(emission: f32) -> Material {
    Material {
        name: "glossy".into(),
        bsdf: Bsdf::Glossy { albedo: Vec3::splat(0.2), specular: Vec3::splat(0.6), roughness: 0.15 },
        emission: Vec3::splat(emission),
        two_sided: false,
        textures: None,
    }
}

/// z of the difference of two renders' means (independent seeds), red channel.
fn z_between(a: &Rendered, b: &Rendered) -> (f64, f64, f64) {
    let ((ma, sa), (mb, sb)) = (a.mean_and_stderr(), b.mean_and_stderr());
    let z = (ma[0] - mb[0]) / (sa[0] * sa[0] + sb[0] * sb[0]).sqrt().max(1e-12);
    (ma[0], mb[0], z)
}

/// The furnace gives Le · Σ_{k<D} a^k exactly, for every max_depth (z-test over independent
/// iterations): every wall emits and reflects, so every technique makes every path.
#[test]
fn bidirectional_weights_are_unbiased_in_the_furnace_for_every_max_depth() {
    let (a, le) = (0.5f64, 1.0f64);
    let scene = closed_cube(diffuse(a as f32, le as f32));
    for connect in CONNECT {
        for depth in [2u32, 3, 4, 8] {
            let expected: f64 = (0..depth).map(|k| le * a.powi(k as i32)).sum();
            let r = Job { iterations: 48, max_depth: depth, ..Job::default() }
                .run(&scene, &mut bdpt_connecting(Clamping::None, connect, 64));
            let (mean, se) = r.mean_and_stderr();
            let z = (mean[0] - expected) / se[0].max(1e-12);
            eprintln!(
                "ir-bdpt {connect:?}, max_depth {depth}: mean {:.5} expected {expected:.5} (z {z:+.2})",
                mean[0]
            );
            assert!(
                z.abs() < Z || (mean[0] - expected).abs() < 1e-6,
                "{connect:?}, max_depth {depth}: z = {z:.2}"
            );
        }
    }
}

/// Glossy receivers and glossy VPLs, where the weights depend on the lobes in both
/// directions: without a bound `pir-bdpt` agrees with the path tracer (two independent
/// renders, z of their difference), with the exhaustive and the resampled gather (whose 64
/// candidates become 32 after a coated wall with `Connect::Glossy`: `AFTER_COATED` in
/// `config.rs`).
#[test]
fn bidirectional_weights_match_the_path_tracer_on_glossy_walls() {
    let scene = closed_cube(glossy(1.0));
    for depth in [3u32, 6] {
        let job = Job { iterations: 64, max_depth: depth, ..Job::default() };
        let pt = Job { iterations: 256, seed: 7, ..job.clone() }.run(&scene, &mut PathTracer);
        for (name, gather) in
            [("all", Gather::All), ("resample", Gather::Resampled { candidates: 64, samples: 4 })]
        {
            for connect in CONNECT {
                let r =
                    job.run(&scene, &mut bdpt_connecting(Clamping::None, connect, 64).with_gather(gather));
                let (m, p, z) = z_between(&r, &pt);
                eprintln!(
                    "glossy cube, max_depth {depth}, gather {name}, {connect:?}: ir-bdpt {m:.5}, pt {p:.5} (z {z:+.2})"
                );
                assert!(z.abs() < Z, "max_depth {depth}, gather {name}, {connect:?}: z = {z:.2}");
            }
        }
    }
}

/// With `--connect glossy` the vertex after a glossy one over a diffuse base (the test
/// scenes' glossy material) picks one light (`AFTER_COATED` in `config.rs`), and the vertex
/// after a rough metal its own count: the shadow rays that the deeper connections add to
/// those of `--connect first` scale with the count only after the metal. (Both cubes' images are
/// unbiased whatever the count: the coated one's against the path tracer above.)
#[test]
fn the_vertex_after_a_coated_one_picks_fewer_lights() {
    let metal = Material {
        bsdf: Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::splat(0.8), roughness: 0.15 },
        ..glossy(1.0)
    };
    let job = Job { iterations: 4, max_depth: 6, ..Job::default() };
    let rays = |scene: &Scene, connect: Connect, samples: usize| {
        let gather = Gather::Resampled { candidates: 64, samples };
        job.run(scene, &mut bdpt_connecting(Clamping::None, connect, 64).with_gather(gather))
            .stats
            .counters
            .shadow_rays as f64
    };
    // The deeper connections' shadow rays at 4 picks over those at 1.
    let deeper = |scene: &Scene| {
        let at = |k| rays(scene, Connect::Glossy, k) - rays(scene, Connect::First, k);
        let (four, one) = (at(4), at(1));
        assert!(one > 1000.0, "too few deeper connections: {one}");
        four / one
    };
    let (coated, metal) = (deeper(&closed_cube(glossy(1.0))), deeper(&closed_cube(metal)));
    eprintln!("deeper shadow rays at 4 picks over 1: coated {coated:.3}, metal {metal:.3}");
    assert!((coated - 1.0).abs() < 0.1, "after a coated vertex: {coated}");
    assert!(metal > 3.0, "after a metal one: {metal}");
}

/// A material that does not emit, named `name`.
fn material(name: &str, bsdf: Bsdf) -> Material {
    Material { name: name.into(), bsdf, emission: Vec3::ZERO, two_sided: false, textures: None }
}

/// Delta vertices rule out the connections that touch them, on either subpath: a cube with a
/// mirror wall and a glass wall (light leaves through it) among glossy and diffuse emitting
/// walls agrees with the path tracer.
/// A mirror of reflectance 0.9 and glass of index 1.5.
fn mirror_and_glass() -> [Material; 2] {
    [
        material("mirror", Bsdf::Mirror { specular: Vec3::splat(0.9) }),
        material("glass", Bsdf::Glass { ior: 1.5 }),
    ]
}

fn mixed_cube() -> Scene {
    let [mirror, glass] = mirror_and_glass();
    closed_cube_of(vec![diffuse(0.6, 1.0), glossy(0.5), mirror, glass], |face| match face {
        0 => 2,
        3 => 3,
        1 | 4 => 1,
        _ => 0,
    })
}

/// `ir-bdpt` with the resampled gather and every rule of which vertices connect, `job`'s
/// iterations each, agrees with the path tracer (256 iterations at another seed) on
/// `scene`, named `name` in the messages.
fn agrees_with_the_path_tracer_for_every_connect(scene: &Scene, job: &Job, name: &str) {
    let pt = Job { iterations: 256, seed: 7, ..job.clone() }.run(scene, &mut PathTracer);
    for connect in CONNECT {
        let gather = Gather::Resampled { candidates: 32, samples: 4 };
        let r = job.run(scene, &mut bdpt_connecting(Clamping::None, connect, 64).with_gather(gather));
        let (m, p, z) = z_between(&r, &pt);
        eprintln!("{name}, {connect:?}: ir-bdpt {m:.5}, pt {p:.5} (z {z:+.2})");
        assert!(z.abs() < Z, "{name}, {connect:?}: z = {z:.2}");
    }
}

#[test]
fn bidirectional_weights_match_the_path_tracer_with_mirror_and_glass() {
    let job = Job { iterations: 64, max_depth: 6, ..Job::default() };
    agrees_with_the_path_tracer_for_every_connect(&mixed_cube(), &job, "mirror and glass cube");
}

/// A near-specular metal (a glossy lobe without albedo, α 0.01) and a pane of near-specular
/// rough glass (α 0.01): `pir-bdpt` neither connects there nor leaves a VPL there.
fn near_specular() -> [Material; 2] {
    use pir::material::microfacet::{Distribution, Microfacet};
    [
        material("metal", Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::splat(0.9), roughness: 0.01 }),
        material(
            "pane",
            Bsdf::RoughDielectric {
                eta: 1.5,
                reflectance: Vec3::ONE,
                transmittance: Vec3::ONE,
                microfacet: Microfacet::new(Distribution::Ggx, 0.01),
            },
        ),
    ]
}

/// The connections that touch a near-specular vertex count zero (no gather at the camera
/// vertex, no VPL at the light vertex), and the weights leave them out: in a cube whose face
/// in view is a near-specular metal, with a near-specular glass pane (light leaves through
/// it) and glossy and diffuse emitting faces, `ir-bdpt` agrees with the path tracer for
/// every rule of which vertices connect; its light paths leave no VPL on the near-specular
/// faces, where they would leave many without the rule.
#[test]
fn near_specular_vertices_connect_nothing_and_the_image_is_the_path_tracers() {
    use pir::integrator::many_light::config::near_specular as is_near_specular;
    use pir::integrator::many_light::light_paths::trace_light_paths;
    use pir::integrator::many_light::subpath::Counts;
    let [metal, pane] = near_specular();
    // Face 4 is the one in view (z = −1), face 3 the ceiling (+y).
    let scene = closed_cube_of(vec![diffuse(0.6, 1.0), glossy(0.5), metal, pane], |face| match face {
        4 => 2,
        3 => 3,
        1 => 1,
        _ => 0,
    });
    let job = Job { iterations: 64, max_depth: 5, ..Job::default() };
    agrees_with_the_path_tracer_for_every_connect(&scene, &job, "near-specular cube");
    let on_near_specular = |counts: Counts| {
        job.with_context(&scene, |ctx| {
            let traced = trace_light_paths(ctx, 1, 256, counts, 3, None, false, None);
            let near = traced.vpls.iter().filter(|v| is_near_specular(&v.bsdf(&scene))).count();
            (near, traced.vpls.len())
        })
    };
    let (skipped, kept) = on_near_specular(Counts::uniform(256.0).skipping_near_specular());
    let (near, all) = on_near_specular(Counts::uniform(256.0));
    assert!(skipped == 0 && kept > 100, "{skipped} of {kept} VPLs on near-specular faces");
    assert!(near > all / 10, "without the rule only {near} of {all} VPLs on near-specular faces");
    // The light paths' own counts (what they fold into their sums and give their VPLs): a
    // VPL whose previous vertex was near-specular (the depth before it has no VPL; the cube
    // has no delta face) counts its connection to it zero, one after a VPL does not. One
    // light path per trace, so that the VPLs of a path are known.
    let (mut after_near, mut after_vpl) = (0, 0);
    job.with_context(&scene, |ctx| {
        for iteration in 1..=400 {
            let counts = Counts::uniform(1.0).skipping_near_specular();
            let vpls = trace_light_paths(ctx, iteration, 1, counts, 4, None, false, None).vpls;
            for (j, v) in vpls.iter().enumerate() {
                let previous = j.checked_sub(1).map(|i| vpls[i].depth);
                match v.depth {
                    1 => assert_eq!(v.count_out, 1.0, "lit directly"),
                    d if previous == Some(d - 1) => {
                        assert!(v.count_out > 0.0, "after a VPL: {}", v.count_out);
                        after_vpl += 1;
                    }
                    _ => {
                        assert_eq!(v.count_out, 0.0, "after a near-specular vertex, depth {}", v.depth);
                        after_near += 1;
                    }
                }
            }
        }
    });
    assert!(
        after_near > 20 && after_vpl > 20,
        "{after_near} VPLs after near-specular vertices, {after_vpl} after VPLs"
    );
}

/// With vertex merging in a cube whose face in view is a mirror (and two more faces a mirror
/// and glass): the paths camera → mirror → wall → mirror or glass → emitting wall are shared
/// between the merge and the emitter hit, and the image's mean is still `pt`'s (every wall
/// emits, so the light is smooth and the kernel's bias far below the noise); the merge's share
/// is large enough that leaving the merges out would fail.
#[test]
fn merging_matches_the_path_tracer_through_mirrors_and_glass() {
    let [mirror, glass] = mirror_and_glass();
    // Face 4 is the one in view (z = −1), face 5 behind the camera.
    let scene = closed_cube_of(vec![diffuse(0.6, 1.0), mirror, glass], |face| match face {
        4 | 1 => 1,
        0 => 2,
        _ => 0,
    });
    let job = Job { iterations: 64, max_depth: 6, ..Job::default() };
    let pt = Job { iterations: 256, seed: 7, ..job.clone() }.run(&scene, &mut PathTracer);
    let gather = Gather::Resampled { candidates: 32, samples: 4 };
    let r = job.run(&scene, &mut bdpt(Clamping::None, 64).with_gather(gather).with_merging(0.5, 0.6));
    assert!(r.stats.counters.photons > 0, "no photons");
    let (m, p, z) = z_between(&r, &pt);
    eprintln!("mirror in view, merging: ir-bdpt {m:.5}, pt {p:.5} (z {z:+.2})");
    assert!(z.abs() < Z, "merging: z = {z:.2}");
    // The same seed without merging draws the same numbers: the difference is the merges less
    // the emitter hits' share they took, zero in expectation, and large per pixel.
    let alone = job.run(&scene, &mut bdpt(Clamping::None, 64).with_gather(gather));
    let (a, b) = (r.image(), alone.image());
    let moved =
        a.pixels.iter().zip(&b.pixels).filter(|(x, y)| (**x - **y).abs().max_element() > 1e-4).count();
    let diff: f32 = a.pixels.iter().zip(&b.pixels).map(|(x, y)| (*x - *y).abs().x).sum::<f32>() / m as f32;
    eprintln!("merging moved {moved} of {} pixels, by {diff:.2} of the mean in all", a.pixels.len());
    assert!(moved > a.pixels.len() / 2, "merging moved only {moved} pixels");
}

/// A harsh constant bound on the weighted connection darkens the glossy cube for ever; the
/// progressive bound of `pir-bdpt` gives most of it back in the late iterations.
#[test]
fn the_progressive_bound_recovers_what_a_constant_bound_removes() {
    let scene = closed_cube(glossy(1.0));
    let job = Job { iterations: 64, max_depth: 4, ..Job::default() };
    let truth = Job { iterations: 256, seed: 11, ..job.clone() }.run(&scene, &mut PathTracer);
    let (expected, se_t) = (truth.mean_and_stderr().0[0], truth.mean_and_stderr().1[0]);
    let b = 0.05;
    let constant = job.run(&scene, &mut bdpt(Clamping::Constant { b }, 64));
    let (m_c, se_c) = constant.mean_and_stderr();
    let z_c = (m_c[0] - expected) / (se_c[0] * se_c[0] + se_t * se_t).sqrt();
    eprintln!("constant bound {b}: mean {:.5}, pt {expected:.5} (z {z_c:+.1})", m_c[0]);
    assert!(z_c < -Z, "a constant bound must darken: z = {z_c:.2}");

    let progressive = job.run(&scene, &mut bdpt(Clamping::Progressive { b1: b, alpha: 0.6 }, 64));
    let late = |r: &Rendered| r.iteration_means[48..].iter().map(|m| m[0]).sum::<f64>() / 16.0;
    let (m_p, m_k) = (late(&progressive), late(&constant));
    eprintln!("late iterations: pir-bdpt {m_p:.5}, constant {m_k:.5}, pt {expected:.5}");
    assert!(expected - m_p < 0.5 * (expected - m_k), "the progressive bound must remove most of the bias");
}

/// Same seed, same image, whatever the thread count: in the glossy cube, with a thin lens
/// and a tent filter (`tests/data/mitsuba-thinlens.xml`), where the light traced to the camera
/// draws its lens points from the light paths and splats through the filter, and in the
/// mirror-and-glass caustic, where the camera merges with the light paths' photons.
#[test]
fn bidirectional_gather_does_not_depend_on_the_thread_count() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut lens = pir::scene::load(&root.join("tests/data/mitsuba-thinlens.xml")).unwrap();
    lens.set_filter(pir::scene::Filter::Tent { radius: 1.5 });
    let caustic = pir::scene::load(&root.join("scenes/stress/caustic/scene.toml")).unwrap();
    for scene in [closed_cube(glossy(1.0)), lens, caustic] {
        let run = |threads| {
            Job { iterations: 4, threads, width: 24, height: 18, max_depth: 4, ..Job::default() }
                .run(
                    &scene,
                    &mut bdpt(Clamping::progressive(1.0), 16)
                        .with_gather(Gather::Resampled { candidates: 32, samples: 4 })
                        .with_merging(2.0, 0.6),
                )
                .image()
        };
        assert!(run(1).pixels == run(2).pixels, "pir-bdpt differs between 1 and 2 threads");
    }
}

/// Light tracing to the camera alone, every splat unweighed (a plain light tracer), gives the
/// furnace its exact value Le · Σ_{1≤k<D} a^k (every path but the emitters seen directly,
/// which light tracing leaves to the camera), in the image's mean and in every pixel (z-tests
/// over independent iterations), through a pinhole and a thin lens, for two path lengths.
#[test]
fn light_tracing_alone_gives_the_furnace_its_value() {
    use pir::integrator::many_light::light_paths::trace_light_paths;
    use pir::integrator::many_light::subpath::Counts;
    use pir::integrator::many_light::to_camera::ToCamera;
    use pir::scene::{Camera, ThinLens};
    let (a, le) = (0.5f64, 1.0f64);
    let scene = closed_cube(diffuse(a as f32, le as f32));
    let (w, h, paths, iterations) = (12usize, 10usize, 512usize, 96u64);
    let thin = ThinLens { aperture_radius: 0.3, focus_distance: 0.7 };
    for lens in [None, Some(thin)] {
        for depth in [2u32, 4] {
            let expected: f64 = (1..depth).map(|k| le * a.powi(k as i32)).sum();
            let camera = Camera { lens, ..*scene.camera() }.with_resolution(w as u32, h as u32).rays();
            let to_camera = ToCamera { camera, connect: Connect::First, light_samples: 1, weighed: false };
            let job = Job { max_depth: depth, ..Job::default() };
            // Per iteration, each pixel's light (the box filter: the splat's own pixel).
            let images: Vec<Vec<f64>> = job.with_context(&scene, |ctx| {
                (1..=iterations)
                    .map(|i| {
                        let counts = Counts::uniform(paths as f32);
                        let t = trace_light_paths(
                            ctx,
                            i,
                            paths,
                            counts,
                            depth - 2,
                            Some(&to_camera),
                            false,
                            None,
                        );
                        let mut image = vec![0.0; w * h];
                        for s in &t.splats {
                            image[s.film.y as usize * w + s.film.x as usize] += s.value.x as f64;
                        }
                        image
                    })
                    .collect()
            });
            let n = iterations as f64;
            let z = |values: &[f64]| {
                let m = values.iter().sum::<f64>() / n;
                let var = values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
                (m, (m - expected) / (var / n).sqrt().max(1e-12))
            };
            let means: Vec<f64> = images.iter().map(|im| im.iter().sum::<f64>() / (w * h) as f64).collect();
            let (mean, z_mean) = z(&means);
            eprintln!(
                "light tracing, {lens:?}, max_depth {depth}: mean {mean:.5}, expected {expected:.5} (z {z_mean:+.2})"
            );
            assert!(z_mean.abs() < Z, "{lens:?}, max_depth {depth}: mean {mean} against {expected}");
            let worst = (0..w * h)
                .map(|p| z(&images.iter().map(|im| im[p]).collect::<Vec<_>>()).1.abs())
                .fold(0.0, f64::max);
            assert!(worst < 5.0, "{lens:?}, max_depth {depth}: a pixel's z is {worst:.2}");
        }
    }
}

/// Light tracing to the camera counts a quarter of its paths in the weights from a vertex
/// lit directly ([`LIGHT_TRACING_COUNT`]), so that the light the camera sees lit directly stays with the
/// light samples, which the Sobol sampler stratifies over a pixel's iterations and light
/// tracing's splats are not: in the diffuse corner, direct light alone (`max_depth` 2), the
/// noise of `pir-bdpt` is within twice `pt`'s (the mean squared difference of two seeds'
/// images over the squared mean plus 0.01, as `pir compare`'s relative MSE). Measured: 0.75
/// times `pt`'s (1.95e-4 against 2.59e-4); with light tracing counted at its N paths, 4.9
/// times (1.26e-3).
#[test]
fn light_tracing_leaves_the_directly_lit_view_to_the_light_samples() {
    const { assert!(LIGHT_TRACING_COUNT > 0.0 && LIGHT_TRACING_COUNT < 1.0) };
    let scene = pir::scene::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/stress/corner/diffuse.toml"
    )))
    .unwrap();
    let noise = |method| {
        let image = |seed| {
            let job = Job {
                width: 32,
                height: 32,
                iterations: 16,
                max_depth: 2,
                seed,
                sampler: SamplerKind::Sobol,
                ..Job::default()
            };
            job.run(&scene, MethodConfig::new(method).integrator(scene.bounds().diagonal()).as_mut()).image()
        };
        let (a, b) = (image(1), image(2));
        let sum: f64 = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .flat_map(|(p, q)| (0..3).map(move |c| (p[c] as f64, q[c] as f64)))
            .map(|(x, y)| (x - y).powi(2) / ((0.5 * (x + y)).powi(2) + 1e-2))
            .sum();
        sum / (2.0 * 3.0 * a.pixels.len() as f64)
    };
    let (pt, bdpt) = (noise(Method::new(&Pt)), noise(Method::new(&PirBdpt)));
    eprintln!("direct light, relative variance: pt {pt:.3e}, pir-bdpt {bdpt:.3e}");
    assert!(bdpt < 2.0 * pt, "pir-bdpt {bdpt:.3e} against pt {pt:.3e}");
}

/// The room lit through a slit (`scenes/stress/slit`), whose emitters are mostly hidden from
/// the points they light.
fn slit_room() -> Scene {
    pir::scene::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/stress/slit/scene.toml"
    )))
    .unwrap()
}

/// The path length and seed of the pilot tests' contexts.
fn pilot_job(sampler: SamplerKind) -> Job {
    Job { max_depth: 6, seed: 3, sampler, ..Job::default() }
}

/// The light paths `pir-bdpt` chooses by the scene's yield of VPLs
/// (`src/integrator/many_light/path_count.rs`): where every light path leaves VPLs (a closed
/// cube) the fewest; in the slit room, where about one VPL is left per eight paths (one path
/// in thirty gets through the opening), as many as leave the VPL target: about eight times
/// the target, more than the fewest; the same count in pools of one and two threads, with
/// either sampler.
/// And the pilot's visibility of the emitters from the points they light, which weighs the
/// connections ([`Counts`](pir::integrator::many_light::subpath::Counts)): all of
/// them inside the cube, a sliver through the slit. Neither makes a caustic; the cube with a
/// mirror and a glass face does, and takes more paths for them.
#[test]
fn light_paths_follow_the_scenes_yield_of_vpls() {
    let auto = BDPT_AUTO_PATHS;
    let (slit_scene, cube_scene) = (slit_room(), closed_cube(diffuse(0.5, 1.0)));
    let resolve = |scene: &Scene, sampler: SamplerKind, threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut counters = Counters::default();
        let pilot =
            pilot_job(sampler).with_context(scene, |ctx| pool.install(|| Pilot::run(ctx, &mut counters)));
        // Every light path is at least one query, and only the pilot's are counted.
        assert!(counters.pilot_rays >= PILOT_PATHS as u64, "{counters:?}");
        assert_eq!(Counters { pilot_rays: 0, ..counters }, Counters::default());
        pilot
    };
    for sampler in [SamplerKind::Independent, SamplerKind::Sobol] {
        let (cube, slit) = (resolve(&cube_scene, sampler, 2), resolve(&slit_scene, sampler, 1));
        assert_eq!((cube.caustic_per_path, slit.caustic_per_path), (0.0, 0.0), "{sampler:?}");
        assert_eq!(auto.for_yield(cube.per_path, cube.caustic_per_path), BDPT_PATHS, "{sampler:?}");
        // Inside the closed cube every emitter point is in view.
        assert_eq!(cube.visibility, 1.0, "{sampler:?}");
        let n = auto.for_yield(slit.per_path, slit.caustic_per_path);
        eprintln!("slit room, {sampler:?}: {n} light paths per iteration, {slit:?}");
        assert_eq!(resolve(&slit_scene, sampler, 2), slit, "{sampler:?}");
        assert!((4 * BDPT_VPLS..=16 * BDPT_VPLS).contains(&n), "{sampler:?}: {n} light paths");
        assert!(n > BDPT_PATHS, "{sampler:?}: {n} light paths, no more than the fewest");
        // From the strip under the slit only a sliver of the panel shows through it.
        assert!(slit.visibility > 0.02 && slit.visibility < 0.4, "{sampler:?}: {slit:?}");
        // So the first vertex takes more light samples there than in the cube.
        assert_eq!(light_samples_for(DEFAULT_LIGHT_SAMPLES, cube.visibility), DEFAULT_LIGHT_SAMPLES);
        let more = light_samples_for(DEFAULT_LIGHT_SAMPLES, slit.visibility);
        assert!([4, 8, 16].contains(&more), "{sampler:?}: {more} light samples");
        // A mirror and a glass face: a caustic from a good share of the paths.
        let mixed = resolve(&mixed_cube(), sampler, 2);
        let n = auto.for_yield(mixed.per_path, mixed.caustic_per_path);
        eprintln!("mirror and glass cube, {sampler:?}: {n} light paths per iteration, {mixed:?}");
        assert!(mixed.caustic_per_path > 0.1, "{sampler:?}: {mixed:?}");
        assert!(n > BDPT_PATHS && n <= auto.at_most, "{sampler:?}: {n} light paths");
    }
}

/// A render counts its pilot's queries in its statistics (once, before the first iteration),
/// and a render of a method without a pilot counts none.
#[test]
fn a_render_counts_its_pilots_queries() {
    let scene = closed_cube(diffuse(0.5, 1.0));
    let job = Job { width: 8, height: 8, iterations: 2, ..pilot_job(SamplerKind::Sobol) };
    let stats = |method| {
        job.run(&scene, MethodConfig::new(method).integrator(scene.bounds().diagonal()).as_mut()).stats
    };
    let bdpt = stats(Method::new(&PirBdpt));
    assert!(bdpt.counters.pilot_rays >= PILOT_PATHS as u64, "{:?}", bdpt.counters);
    assert_eq!(stats(Method::new(&Pt)).counters.pilot_rays, 0);
}

/// `pir-bdpt` without `--light-samples` takes the count the pilot's visibility gives (more in
/// the slit room, the default inside the cube) and reports it among its parameters; a
/// count given is kept.
#[test]
fn light_samples_follow_the_emitters_visibility_unless_given() {
    let (slit_scene, cube_scene) = (slit_room(), closed_cube(diffuse(0.5, 1.0)));
    let chosen = |scene: &Scene, given: Option<u32>| {
        let mut config = MethodConfig::new(Method::new(&PirBdpt));
        config.params.light_samples = given;
        let mut integrator = config.integrator(scene.bounds().diagonal());
        pilot_job(SamplerKind::Sobol)
            .with_context(scene, |ctx| integrator.prepare(ctx, &mut Counters::default()));
        let p = config.report(scene.bounds().diagonal(), integrator.measured());
        let value = |key: &str| p.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone());
        let v: f32 = value("emitter-visibility").unwrap().parse().unwrap();
        (value("light-samples").unwrap().parse::<u32>().unwrap(), v)
    };
    let (n, v) = chosen(&slit_scene, None);
    assert_eq!(n, light_samples_for(DEFAULT_LIGHT_SAMPLES, v));
    assert!(n > DEFAULT_LIGHT_SAMPLES, "slit room: {n} light samples at visibility {v}");
    assert_eq!(chosen(&slit_scene, Some(2)).0, 2);
    assert_eq!(chosen(&slit_scene, Some(3)).0, 3);
    assert_eq!(chosen(&cube_scene, None).0, DEFAULT_LIGHT_SAMPLES);
}

/// `pir-bdpt` with the parameters `set` makes, prepared for `scene` (its pilots run) at
/// 32 × 32 pixels: its report's value of a key, as the EXR metadata records it.
fn prepared(scene: &Scene, set: impl FnOnce(&mut MethodParams)) -> impl Fn(&str) -> Option<String> {
    let mut config = MethodConfig::new(Method::new(&PirBdpt));
    set(&mut config.params);
    let mut integrator = config.integrator(scene.bounds().diagonal());
    integrator.set_camera(scene.camera().with_resolution(32, 32).rays());
    pilot_job(SamplerKind::Sobol)
        .with_context(scene, |ctx| integrator.prepare(ctx, &mut Counters::default()));
    let report = config.report(scene.bounds().diagonal(), integrator.measured());
    move |key: &str| report.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone())
}

/// `--connect` not given: the scene's view chooses (`view_pilot`): connections after glossy
/// vertices too where the camera sees mostly points the emitters do not light (the slit room,
/// lit through an opening), the first vertex only where it sees them lit (the emitting cube);
/// a given rule is kept; the same seed chooses the same.
#[test]
fn connections_after_glossy_vertices_follow_the_cameras_view_unless_given() {
    let (slit_scene, cube_scene) = (slit_room(), closed_cube(diffuse(0.5, 1.0)));
    let chosen = |scene: &Scene, given: Option<Connect>| {
        let value = prepared(scene, |p| p.connect = given);
        let share = value("lit-share").map(|v| v.parse::<f32>().unwrap());
        (value("connect").unwrap(), share)
    };
    let (slit, share) = chosen(&slit_scene, None);
    assert!(slit == "glossy" && share.is_some_and(|s| s < 0.2), "slit room: {slit} at {share:?}");
    assert_eq!(chosen(&slit_scene, None), (slit, share));
    let (cube, share) = chosen(&cube_scene, None);
    assert!(cube == "first" && share.is_some_and(|s| s > 0.5), "emitting cube: {cube} at {share:?}");
    assert_eq!(chosen(&slit_scene, Some(Connect::All)), ("all".to_string(), None));
    assert_eq!(chosen(&cube_scene, Some(Connect::Glossy)), ("glossy".to_string(), None));
}

/// The near-mirror floor (`scenes/stress/glossy`), where most light paths light the wall
/// behind the camera and the floor's far side.
fn near_mirror_floor() -> Scene {
    pir::scene::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/stress/glossy/scene.toml"
    )))
    .unwrap()
}

/// `pir-bdpt` keeps its VPLs by their share of the image
/// (`src/integrator/many_light/importance.rs`) where most of them light what the camera does
/// not see (the near-mirror floor's room with a floor of α 0.1: at its own α 0.05 the floor's
/// narrow lobe asks for the most light paths, and then none is left out), with more light
/// paths; not where the camera sees all the light paths reach (inside the emitting cube), nor
/// when `--vpls` gives the light paths.
#[test]
fn vpls_are_kept_by_their_share_of_the_image_where_most_miss_the_view() {
    let chosen = |scene: &Scene, vpls: Option<usize>| {
        let value = prepared(scene, |p| p.vpls = vpls);
        let kept = value("vpl-acceptance").map(|v| v.parse::<f32>().unwrap());
        (kept, value("vpls").unwrap().parse::<usize>().unwrap())
    };
    let floor = near_mirror_floor_of_roughness(0.1);
    let (kept, paths) = chosen(&floor, None);
    eprintln!("near-mirror floor: {paths} light paths, the pilot's would keep {kept:?} of their VPLs");
    assert!(kept.is_some_and(|k| k > 0.0 && k < WORTH_IT), "near-mirror floor: {kept:?}");
    assert!(paths > BDPT_PATHS && paths < BDPT_AUTO_PATHS.at_most, "{paths} light paths");
    assert_eq!(chosen(&floor, None), (kept, paths), "the same seed must choose the same");
    assert_eq!(chosen(&floor, Some(256)), (None, 256));
    assert_eq!(chosen(&closed_cube(diffuse(0.5, 1.0)), None), (None, BDPT_PATHS));
}

/// A narrow glossy lobe that leads light paths to surfaces makes caustics that ask for more
/// light paths (`path_count.rs`, `light_paths::NARROW_LOBE_DENSITY`): the near-mirror floor
/// (GGX α 0.05) takes the most, and keeps every VPL; the same floor at α 0.1 makes too few
/// such vertices (fewer than one path in 64) to ask for more than the fewest (its VPLs'
/// share of the image may still ask for some), and the emitting cube none.
#[test]
fn a_narrow_lobe_asks_for_light_paths_as_a_mirror_does() {
    let auto = BDPT_AUTO_PATHS;
    let pilot = |scene: &Scene| {
        let mut counters = Counters::default();
        pilot_job(SamplerKind::Sobol).with_context(scene, |ctx| Pilot::run(ctx, &mut counters))
    };
    let floor = pilot(&near_mirror_floor());
    eprintln!("near-mirror floor: {floor:?}");
    assert!(floor.caustic_per_path >= CAUSTIC_RARE, "{floor:?}");
    assert_eq!(auto.for_yield(floor.per_path, floor.caustic_per_path), auto.at_most);
    let chosen = |scene: &Scene| {
        let value = prepared(scene, |_| {});
        (value("vpl-acceptance"), value("vpls").unwrap().parse::<usize>().unwrap())
    };
    assert_eq!(chosen(&near_mirror_floor()), (None, auto.at_most));
    let wider = near_mirror_floor_of_roughness(0.1);
    let wide = pilot(&wider);
    eprintln!("the floor at α 0.1: {wide:?}");
    assert!(wide.caustic_per_path < CAUSTIC_RARE, "{wide:?}");
    assert_eq!(auto.for_yield(wide.per_path, wide.caustic_per_path), BDPT_PATHS);
    let (_, paths) = chosen(&wider);
    assert!(paths < auto.at_most, "the floor at α 0.1: {paths} light paths");
    assert_eq!(pilot(&closed_cube(diffuse(0.5, 1.0))).caustic_per_path, 0.0);
    // Not after a near-specular vertex (α ≤ 0.02), which neither connects nor leaves a VPL:
    // the cube with a near-specular metal and pane keeps its count.
    let near = pir::scene::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/near-specular.toml"
    )))
    .unwrap();
    let near = pilot(&near);
    assert!(near.caustic_per_path < CAUSTIC_RARE, "near-specular cube: {near:?}");
}

/// The near-mirror floor with its floor's GGX α at `roughness` (written to a temporary scene
/// file beside the test's others).
fn near_mirror_floor_of_roughness(roughness: f32) -> Scene {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/stress/glossy");
    let text = std::fs::read_to_string(format!("{dir}/scene.toml")).unwrap();
    assert!(text.contains("roughness = 0.05") && text.contains("obj = \"glossy.obj\""));
    let text = text
        .replace("roughness = 0.05", &format!("roughness = {roughness}"))
        .replace("obj = \"glossy.obj\"", &format!("obj = {:?}", format!("{dir}/glossy.obj")));
    let path = std::env::temp_dir().join(format!("pir-floor-{roughness}-{}.toml", std::process::id()));
    std::fs::write(&path, text).unwrap();
    let scene = pir::scene::load(&path).unwrap();
    std::fs::remove_file(&path).ok();
    scene
}

/// With VPLs kept by their share of the image, the image's mean is still `pt`'s (each kept
/// VPL's flux divided by its probability), and it does not depend on the thread count.
#[test]
fn kept_vpls_leave_the_image_unbiased_and_independent_of_the_threads() {
    // (A floor of α 0.1: at α 0.05 its narrow lobe asks for the most light paths, which
    // keep every VPL.)
    let scene = near_mirror_floor_of_roughness(0.1);
    let job = Job { iterations: 48, width: 24, height: 24, max_depth: 4, ..Job::default() };
    let pt = Job { iterations: 192, seed: 7, ..job.clone() }.run(&scene, &mut PathTracer);
    let integrator = || {
        bdpt(Clamping::None, 64)
            .with_gather(Gather::Resampled { candidates: 32, samples: 4 })
            .with_auto_paths(BDPT_AUTO_PATHS)
            .with_auto_acceptance(true)
    };
    let r = job.run(&scene, &mut integrator());
    assert!(
        r.stats.counters.light_paths > 48 * BDPT_PATHS as u64
            && r.stats.counters.light_paths < 48 * BDPT_AUTO_PATHS.at_most as u64,
        "kept VPLs should come with more light paths, fewer than the most: {:?}",
        r.stats.counters
    );
    let (m, p, z) = z_between(&r, &pt);
    eprintln!("near-mirror floor, kept VPLs: ir-bdpt {m:.5}, pt {p:.5} (z {z:+.2})");
    assert!(z.abs() < Z, "z = {z:.2}");
    let run = |threads| Job { iterations: 3, threads, ..job.clone() }.run(&scene, &mut integrator()).image();
    assert!(run(1).pixels == run(2).pixels, "differs between 1 and 2 threads");
}

/// The points the view pilot gives the VPLs' acceptance include what mirrors and near-mirrors
/// show: in a cube whose face in view is a mirror, the camera's first surfaces are all delta,
/// yet most rays give a point (the walls the mirror shows), and the emitting face none; a
/// near-mirror floor gives its own points and those of the wall it shows.
#[test]
fn the_view_pilot_finds_points_through_mirrors() {
    let [mirror, _] = mirror_and_glass();
    // Face 4 is the one in view (z = −1), face 5 behind the camera.
    let scene = closed_cube_of(vec![diffuse(0.6, 0.0), mirror, diffuse(0.5, 1.0)], |face| match face {
        4 => 1,
        2 => 2,
        _ => 0,
    });
    let camera = scene.camera().with_resolution(32, 32).rays();
    let view = pilot_job(SamplerKind::Sobol)
        .with_context(&scene, |ctx| view_pilot::view(ctx, &camera, &mut Counters::default()));
    eprintln!(
        "mirror in view: {} points of {VIEW_PILOT_RAYS} rays, lit share {}",
        view.points.len(),
        view.lit_share
    );
    assert_eq!(view.lit_share, 1.0, "no first surface is non-delta: the share is 1 by definition");
    assert!(view.points.len() > VIEW_PILOT_RAYS / 2, "{} points", view.points.len());
    assert!(view.points.iter().all(|p| p.ng.y < 0.99), "a point on the emitting face (y = −1)");
    // A near-mirror floor (α 0.05) gives its own points and those of the wall it shows, while
    // the lit share counts its own only.
    let floor = near_mirror_floor();
    let camera = floor.camera().with_resolution(32, 32).rays();
    let view = pilot_job(SamplerKind::Sobol)
        .with_context(&floor, |ctx| view_pilot::view(ctx, &camera, &mut Counters::default()));
    let on_floor = view.points.iter().filter(|p| p.ng.y > 0.99).count();
    eprintln!(
        "near-mirror floor: {} points of {VIEW_PILOT_RAYS} rays, {on_floor} on the floor",
        view.points.len()
    );
    assert!(on_floor > VIEW_PILOT_RAYS / 8, "{on_floor} points on the floor");
    // One point per ray at most without what the floor shows (some rays find the open sky).
    assert!(view.points.len() > VIEW_PILOT_RAYS, "{} points", view.points.len());
}
