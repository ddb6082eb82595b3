//! Equal-time comparison of the exhaustive gather and the tree gather at 128×128: relative MSE
//! against a Mitsuba reference, one render per configuration for the same wall-clock budget.
//! By default the Cornell box against `../shared/references/cornell-box-original.exr`
//! (256×256, box-downsampled); or any scene and reference (box-downsampled to 128 wide).
//!
//! Run: `cargo run --release --example tree_equal_time -- [SECONDS] [THREADS] [SCENE REFERENCE]`,
//! e.g. `… -- 20 2 scenes/stress/slit/scene.toml scenes/stress/slit/reference-128.exr`.

use std::path::Path;
use std::time::Duration;

use pir::accel::{Backend, build_accelerator};
use pir::image::{metrics, read_exr};
use pir::integrator::{Clamping, Gather, InstantRadiosity, Integrator, PathTracer, RenderContext};
use pir::light::Emitters;
use pir::render::{Budget, Control, RenderSettings, render};
use pir::sampling::SamplerKind;
use pir::scene::load;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seconds: f64 = args.get(1).map_or(30.0, |s| s.parse().unwrap());
    let threads: usize = args.get(2).map_or(2, |s| s.parse().unwrap());
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (scene_path, reference_path) = match (args.get(3), args.get(4)) {
        (Some(s), Some(r)) => (root.join(s), root.join(r)),
        _ => (
            root.join("scenes/cornell-box/scene.toml"),
            root.join("../shared/references/cornell-box-original.exr"),
        ),
    };
    let scene = load(&scene_path).unwrap();
    let (reference, _) = read_exr(&reference_path).unwrap();
    let reference = reference.downsample(reference.width / 128).unwrap();
    let accel = build_accelerator(Backend::default_available(), scene.positions(), scene.indices()).unwrap();
    let emitters = Emitters::new(&scene).unwrap();
    let ctx = RenderContext {
        scene: &scene,
        accel: accel.as_ref(),
        emitters: &emitters,
        max_depth: scene.defaults().max_depth,
        seed: 3,
        sampler: SamplerKind::default(),
        pilot: None,
    };
    let settings = RenderSettings {
        width: 128,
        height: 128,
        budget: Budget { iterations: None, time: Some(Duration::from_secs_f64(seconds)) },
    };
    let b1 = Clamping::default_bound(scene.bounds().diagonal());
    let pir_clamp = |paths| InstantRadiosity::points(Clamping::progressive(b1), paths);
    let mut configs: Vec<(String, Box<dyn Integrator>)> =
        vec![("pt".into(), Box::new(PathTracer)), ("pir-clamp all 32".into(), Box::new(pir_clamp(32)))];
    for paths in [1024, 8192] {
        for k in [4, 16] {
            let m = pir_clamp(paths).with_gather(Gather::Tree { samples: k });
            configs.push((format!("pir-clamp tree {paths} k={k}"), Box::new(m)));
        }
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    println!("{}: {seconds} s each, {threads} threads, seed 3, 128×128", scene_path.display());
    println!("| configuration | iterations | VPLs/iteration | prepare s | pixel s | shadow rays | rel MSE |");
    println!("|---|---|---|---|---|---|---|");
    for (name, mut integrator) in configs {
        let (film, stats) =
            pool.install(|| render(&ctx, integrator.as_mut(), &settings, |_, _| Control::Continue));
        let m = metrics(&film.image(), &reference).unwrap();
        println!(
            "| {name} | {} | {:.0} | {:.2} | {:.2} | {} | {:.4e} |",
            stats.iterations,
            stats.counters.vpls as f64 / stats.iterations as f64,
            stats.prepare_time.as_secs_f64(),
            stats.pixel_time.as_secs_f64(),
            stats.counters.shadow_rays,
            m.rel_mse
        );
    }
}
