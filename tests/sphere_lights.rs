//! Emitting spheres of Mitsuba scenes, sampled by the cones of their exact spheres
//! (`src/light/sphere.rs`): next-event estimation by the cone has the expected value of
//! next-event estimation by area at every point, with less variance where the spheres are
//! small, and `pt`, `pir-mis` and `pir-bdpt` on a scene of sphere lights
//! (`tests/data/mitsuba-sphere-lights.xml`) match Mitsuba 3's image means within 1 %.

mod common;

use std::path::PathBuf;

use glam::{DVec3, Vec2, Vec3};
use pir::accel::Backend;
use pir::geometry::Ray;
use pir::integrator::direct::sample_emitters_at;
use pir::integrator::{Counters, RenderContext};
use pir::light::Emitters;
use pir::sampling::SamplerKind;
use pir::scene::Scene;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

fn scene() -> Scene {
    let options = pir::scene::mitsuba::Options::default();
    pir::scene::load_with(&data("mitsuba-sphere-lights.xml"), &options).unwrap().0
}

/// Mean and standard error per channel of next-event estimation (without MIS weights) at the
/// first surface below `above`, viewed from `eye`, over `n` independent samples.
fn nee(ctx: &RenderContext, above: Vec3, eye: Vec3, n: usize) -> (DVec3, DVec3) {
    let hit = ctx.accel.intersect(&Ray::new(above, -Vec3::Y)).expect("a surface below");
    let sp = ctx.scene.surface_of_hit(&hit, -Vec3::Y);
    let bsdf = ctx.scene.bsdf_at(&sp);
    let wo = (eye - sp.p).normalize();
    // A xorshift generator: the samples only need to be independent.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
    let mut counters = Counters::default();
    for _ in 0..n {
        let u = (next(), Vec2::new(next(), next()));
        let c = sample_emitters_at(ctx, &sp, &bsdf, wo, u, &mut counters, |_| 1.0).as_dvec3();
        sum += c;
        sum2 += c * c;
    }
    let mean = sum / n as f64;
    let var = sum2 / n as f64 - mean * mean;
    (mean, (var / n as f64).max(DVec3::ZERO).powf(0.5))
}

/// At points of the floor and the plates (some seeing the spheres whole, some partly
/// hidden), next-event estimation by the cones
/// and by area (the same scene without its spheres' records) agree within four standard
/// errors, and where the smallest spheres light the point the cones' variance is lower.
#[test]
fn cone_and_area_sampling_agree_at_every_point() {
    let with_cones = scene();
    assert_eq!(with_cones.sphere_lights().len(), 3);
    let by_area = with_cones.clone().with_sphere_lights(Vec::new()).unwrap();
    let accel = with_cones.accelerator(Backend::default_available()).unwrap();
    let context = |scene: &Scene, f: &mut dyn FnMut(&RenderContext)| {
        let emitters = Emitters::new(scene).unwrap();
        f(&RenderContext {
            scene,
            accel: accel.as_ref(),
            emitters: &emitters,
            max_depth: 4,
            seed: 0,
            sampler: SamplerKind::Independent,
            pilot: None,
        })
    };
    let eye = Vec3::new(0.0, 2.2, 5.0);
    // Floor in the open, floor under the ball, the glossy and the rough plate, the floor
    // under the largest sphere by the wall.
    let points = [
        Vec3::new(0.0, 1.0, 1.5),
        Vec3::new(1.4, 1.3, -0.6),
        Vec3::new(-1.2, 1.0, 0.6),
        Vec3::new(1.2, 1.0, 0.6),
        Vec3::new(-1.5, 1.0, -1.9),
    ];
    let n = 400_000;
    let mut lower_variance = 0;
    for p in points {
        let (mut cone, mut area) = ((DVec3::ZERO, DVec3::ZERO), (DVec3::ZERO, DVec3::ZERO));
        context(&with_cones, &mut |ctx| cone = nee(ctx, p, eye, n));
        context(&by_area, &mut |ctx| area = nee(ctx, p, eye, n));
        let sigma = (cone.1 * cone.1 + area.1 * area.1).powf(0.5);
        assert!(area.0.min_element() > 0.0, "{p}: no light by area");
        for c in 0..3 {
            assert!(
                (cone.0[c] - area.0[c]).abs() <= 4.0 * sigma[c],
                "{p}, channel {c}: by cones {} ± {}, by area {} ± {}",
                cone.0[c],
                cone.1[c],
                area.0[c],
                area.1[c]
            );
        }
        if cone.1.x < area.1.x {
            lower_variance += 1;
        }
    }
    assert!(lower_variance >= 4, "the cones' variance is lower at only {lower_variance} of 5 points");
}

/// `pt`, `pir-mis` and `pir-bdpt`, whose MIS weights all use the cones' densities, against
/// Mitsuba 3's image of the scene (`tests/data/mitsuba-sphere-lights-64x48.exr`): image
/// means within 1 % per channel.
#[test]
fn methods_match_mitsubas_sphere_lights() {
    let (r, _) = pir::image::read_exr(&data("mitsuba-sphere-lights-64x48.exr")).unwrap();
    let want = DVec3::from(r.mean());
    let dir = tempfile::tempdir().unwrap();
    for (method, spp) in [("pt", "256"), ("pir-mis", "128"), ("pir-bdpt", "128")] {
        let out = dir.path().join(format!("{method}.exr"));
        let args = ["--spp", spp, "--method", method];
        let img = common::binary::render(&data("mitsuba-sphere-lights.xml"), &args, &out, dir.path(), method);
        let got = DVec3::from(img.mean());
        let rel = (got - want) / want;
        assert!(rel.abs().max_element() < 0.01, "{method}: means {got} against Mitsuba's {want} ({rel})");
    }
}
