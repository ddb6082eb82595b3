//! Next-event estimation's choice of an emitting triangle by its importance at the receiver
//! (`src/light/spatial.rs`, `--emitter-choice importance`, where the emitters are three
//! triangles or more, among clusters of them beyond 64) against the choice by power: the same
//! image in expectation for `pt` and for `pir-bdpt`, whose weights take next-event
//! estimation's density from the receiver, and less noise where the lights are apart; and
//! the pilot of `--emitter-choice auto` (`src/integrator/emitter_pilot.rs`).

mod common;

use common::{Job, Rendered, closed_cube_of, diffuse};
use glam::Vec3;
use pir::integrator::MethodConfig;
use pir::integrator::{Clamping, InstantRadiosity, PathTracer, VirtualLights};
use pir::light::{EmitterChoice, Emitters};
use pir::render::{Renderer, SceneOptions};
use pir::scene::{Camera, Geometry, RenderDefaults, Scene};

const Z: f64 = 4.5;

/// The cube with three emitting walls of radiance 1, 2 and 4 (−x, +x, +y: six triangles)
/// and grey walls elsewhere; the camera looks at the −z wall, which each light reaches at a
/// grazing angle from its own side.
fn three_lights() -> Scene {
    let materials = vec![diffuse(0.5, 0.0), diffuse(0.5, 1.0), diffuse(0.5, 2.0), diffuse(0.5, 4.0)];
    closed_cube_of(materials, |face| match face {
        0 => 1,
        1 => 2,
        3 => 3,
        _ => 0,
    })
}

/// A grey floor 12 wide under three small square lamps (0.3 wide, radiance 40, 80 and 160)
/// one unit above it, 4 apart, facing down; the camera looks down at the floor from above.
fn three_lamps() -> Scene {
    lamps_at([-4.0, 0.0, 4.0])
}

/// [`three_lamps`] with the lamps' centres at `xs`.
fn lamps_at(xs: [f32; 3]) -> Scene {
    let (mut positions, mut indices, mut tri_material) = (Vec::new(), Vec::new(), Vec::new());
    for (k, x) in xs.into_iter().enumerate() {
        let base = positions.len() as u32;
        let h = 0.15;
        positions.extend([
            Vec3::new(x - h, 1.0, -h),
            Vec3::new(x + h, 1.0, -h),
            Vec3::new(x + h, 1.0, h),
            Vec3::new(x - h, 1.0, h),
        ]);
        // Facing down.
        indices.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        tri_material.extend([k as u32; 2]);
    }
    let emissions = [40.0, 80.0, 160.0];
    over_the_floor("three-lamps", positions, indices, tri_material, &emissions)
}

/// The floor of [`three_lamps`] under twenty bulbs on a 5 × 4 grid, 2.5 apart, one unit
/// above it, each the lower half of an octahedron of half-width 0.1 (4 triangles facing out
/// and down: 80 emitting triangles, more than the choice takes one by one, so it picks among
/// clusters of them), of radiance 20 to 80; the camera looks down at the floor from above
/// (and sees the bulbs' dark backs).
fn bulbs() -> Scene {
    let (mut positions, mut indices, mut tri_material) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..5 {
        for j in 0..4 {
            let c = Vec3::new(2.5 * i as f32 - 5.0, 1.0, 2.5 * j as f32 - 3.75);
            let base = positions.len() as u32;
            let h = 0.1;
            positions.extend([Vec3::X, -Vec3::X, -Vec3::Y, Vec3::Z, -Vec3::Z].map(|d| c + d * h));
            // Around the lowest corner (2), each face's normal points out and down.
            for (x, y, z) in [(0, 3, 2), (3, 1, 2), (1, 4, 2), (4, 0, 2)] {
                indices.push([base + x, base + y, base + z]);
            }
            tri_material.extend([(i + j) as u32 % 4; 4]);
        }
    }
    over_the_floor("bulbs", positions, indices, tri_material, &[20.0, 40.0, 60.0, 80.0])
}

/// A grey floor 12 wide (facing up) under the emitting triangles given, whose materials are
/// black emitters of the radiances `emissions` (by index); the camera looks down at the floor
/// from 6 above.
fn over_the_floor(
    name: &str,
    positions: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
    tri_material: Vec<u32>,
    emissions: &[f32],
) -> Scene {
    let floor = [
        Vec3::new(-6.0, 0.0, -6.0),
        Vec3::new(6.0, 0.0, -6.0),
        Vec3::new(6.0, 0.0, 6.0),
        Vec3::new(-6.0, 0.0, 6.0),
    ];
    // Wound counter-clockwise seen from above.
    let mut all_indices = vec![[0, 2, 1], [0, 3, 2]];
    all_indices.extend(indices.iter().map(|t| t.map(|i| i + 4)));
    let all_materials = [vec![0, 0], tri_material.iter().map(|m| m + 1).collect()].concat();
    let geometry = Geometry::flat([&floor[..], &positions].concat(), all_indices, all_materials);
    let mut materials = vec![diffuse(0.5, 0.0)];
    materials.extend(emissions.iter().map(|&e| diffuse(0.0, e)));
    let camera = Camera::pinhole(Vec3::new(0.0, 6.0, 0.01), Vec3::ZERO, Vec3::Y, 90.0, 32, 32);
    Scene::new(name.into(), camera, RenderDefaults::default(), geometry, materials).unwrap()
}

/// z of the difference of two renders' means (independent seeds), per channel, the largest.
fn z_between(a: &Rendered, b: &Rendered) -> f64 {
    let ((ma, sa), (mb, sb)) = (a.mean_and_stderr(), b.mean_and_stderr());
    (0..3)
        .map(|c| ((ma[c] - mb[c]) / (sa[c] * sa[c] + sb[c] * sb[c]).sqrt().max(1e-12)).abs())
        .fold(0.0, f64::max)
}

/// The mean squared difference of two images per pixel: twice their per-pixel variance when
/// they are independent renders of the same expectation.
fn spread(a: &Rendered, b: &Rendered) -> f64 {
    let (a, b) = (a.image(), b.image());
    let d: f64 = a.pixels.iter().zip(&b.pixels).map(|(x, y)| (*x - *y).length_squared() as f64).sum();
    d / a.pixels.len() as f64
}

#[test]
fn the_scene_picks_by_importance_or_by_power_on_request() {
    let scene = three_lights();
    assert_eq!(EmitterChoice::default(), EmitterChoice::Auto);
    assert!(Emitters::new(&scene).unwrap().with_choice(EmitterChoice::Importance).is_spatial());
    assert!(!Emitters::new(&scene).unwrap().with_choice(EmitterChoice::Power).is_spatial());
    assert_eq!("power".parse::<EmitterChoice>(), Ok(EmitterChoice::Power));
    assert_eq!("auto".parse::<EmitterChoice>(), Ok(EmitterChoice::Auto));
    assert!("nearest".parse::<EmitterChoice>().is_err());
}

/// `--emitter-choice auto` (the default): the renderer's pilot takes the choice by
/// importance where the lamps are apart and in the conference room (six panels apart: 2.3x
/// less variance at equal time, `docs/results.md`), gains less where the lamps sit side by
/// side, and keeps the power table in the glowing box (whose repeated face light samples
/// count twice); an explicit choice is not second-guessed. The job records the choice made.
#[test]
fn the_pilot_takes_importance_where_it_pays() {
    let options = |choice| SceneOptions { emitter_choice: choice, ..Default::default() };
    let verdict = |scene: &Scene, choice| {
        let r = Renderer::new(scene, &options(choice)).unwrap();
        let job = r.job(&MethodConfig::new("pt".parse().unwrap()));
        (r.emitter_verdict(), r.emitters().is_spatial(), job.emitter_choice)
    };
    let (v, spatial, recorded) = verdict(&three_lamps(), None);
    eprintln!("lamps apart: {v:?}");
    assert!(v.unwrap().gain > 2.0 && spatial && recorded == EmitterChoice::Importance, "{v:?}");
    let (apart, _, _) = verdict(&three_lamps(), None);
    let (v, _, _) = verdict(&lamps_at([-0.3, 0.0, 0.3]), None);
    eprintln!("lamps side by side: {v:?}");
    assert!(v.unwrap().gain < 0.5 * apart.unwrap().gain, "{v:?}");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let conference = pir::scene::load(&root.join("scenes/conference-room/scene.toml")).unwrap();
    let (v, spatial, recorded) = verdict(&conference, None);
    eprintln!("conference room: {v:?}");
    assert!(v.unwrap().importance_pays() && spatial && recorded == EmitterChoice::Importance, "{v:?}");
    let glowing = pir::scene::load(&root.join("tests/data/glowing-box.toml")).unwrap();
    let (v, spatial, recorded) = verdict(&glowing, None);
    eprintln!("glowing box: {v:?}");
    assert!(!v.unwrap().importance_pays() && !spatial && recorded == EmitterChoice::Power, "{v:?}");
    // Asked for, each choice is taken without a pilot.
    for (choice, want) in [(EmitterChoice::Importance, true), (EmitterChoice::Power, false)] {
        let (v, spatial, _) = verdict(&lamps_at([-0.3, 0.0, 0.3]), Some(choice));
        assert!(v.is_none() && spatial == want);
    }
}

/// `pt` by importance and by power render the same image in expectation: direct light
/// alone, where the MIS weights of the emitter hits decide it, and with bounces.
#[test]
fn pt_by_importance_matches_pt_by_power() {
    for (name, scene) in [("cube", three_lights()), ("lamps", three_lamps()), ("bulbs", bulbs())] {
        for depth in [2u32, 4] {
            let job = Job { iterations: 256, max_depth: depth, width: 32, height: 32, ..Job::default() };
            let by = |choice, seed| {
                Job { emitter_choice: choice, seed, ..job.clone() }.run(&scene, &mut PathTracer)
            };
            let z = z_between(&by(EmitterChoice::Importance, 1), &by(EmitterChoice::Power, 2));
            eprintln!("pt, {name}, max_depth {depth}: z {z:.2} between the choices");
            assert!(z < Z, "{name}, max_depth {depth}: z = {z:.2}");
        }
    }
}

/// Where the lamps are small and apart, the choice by importance leaves a fraction of the
/// noise per pixel that the choice by power leaves.
#[test]
fn pt_by_importance_is_less_noisy_where_the_lamps_are_apart() {
    let scene = three_lamps();
    let job = Job { iterations: 16, max_depth: 3, width: 32, height: 32, ..Job::default() };
    let by = |choice, seed| Job { emitter_choice: choice, seed, ..job.clone() }.run(&scene, &mut PathTracer);
    let si = spread(&by(EmitterChoice::Importance, 1), &by(EmitterChoice::Importance, 2));
    let sp = spread(&by(EmitterChoice::Power, 3), &by(EmitterChoice::Power, 4));
    eprintln!("spread by importance {si:.4e}, by power {sp:.4e}");
    assert!(si < 0.5 * sp, "by importance {si:.4e} against by power {sp:.4e}");
}

/// So does the choice among clusters of the bulbs' triangles.
#[test]
fn pt_by_importance_among_clusters_is_less_noisy_where_the_bulbs_are_apart() {
    let scene = bulbs();
    assert!(Emitters::new(&scene).unwrap().is_spatial());
    let job = Job { iterations: 16, max_depth: 3, width: 32, height: 32, ..Job::default() };
    let by = |choice, seed| Job { emitter_choice: choice, seed, ..job.clone() }.run(&scene, &mut PathTracer);
    let si = spread(&by(EmitterChoice::Importance, 1), &by(EmitterChoice::Importance, 2));
    let sp = spread(&by(EmitterChoice::Power, 3), &by(EmitterChoice::Power, 4));
    eprintln!("bulbs: spread by importance {si:.4e}, by power {sp:.4e}");
    assert!(si < 0.5 * sp, "by importance {si:.4e} against by power {sp:.4e}");
}

/// `pir-bdpt`'s weights (without the bound, so that the estimate is unbiased per iteration)
/// with the choice by importance: the path tracer's image, whose samples pick by power.
#[test]
fn bidirectional_weights_take_the_choice_by_importance() {
    for (name, scene, depth) in [
        ("cube", three_lights(), 2u32),
        ("cube", three_lights(), 5),
        ("lamps", three_lamps(), 2),
        ("lamps", three_lamps(), 4),
        ("bulbs", bulbs(), 3),
    ] {
        let job = Job {
            iterations: 64,
            max_depth: depth,
            emitter_choice: EmitterChoice::Importance,
            ..Job::default()
        };
        let pt = Job { iterations: 256, seed: 7, emitter_choice: EmitterChoice::Power, ..job.clone() }
            .run(&scene, &mut PathTracer);
        let bdpt =
            InstantRadiosity::new(VirtualLights::Bidirectional(Clamping::None, Default::default()), 64);
        let r = job.run(&scene, &mut { bdpt });
        let z = z_between(&r, &pt);
        eprintln!("pir-bdpt, {name}, max_depth {depth}: z {z:.2}");
        assert!(z < Z, "{name}, max_depth {depth}: z = {z:.2}");
    }
}
