//! The batched walker (`src/integrator/wavefront.rs`) against the scalar walker, the
//! reference, for `pt` and every many-light method (`pir-bdpt`'s camera paths first): the same
//! estimate for every camera path, bit for bit (on the BVH and the brute-force backends,
//! whose batch queries are their single-ray queries, and on Embree, whose packet kernels
//! measured the same as its single-ray kernel), the same draws from every path's sampler and
//! the same ray counts, on scenes that take every branch of the walk (glass and mirrors,
//! glossy surfaces, an environment, a point light, emitting spheres sampled by their cones,
//! textures, a thin lens, a short `max_depth`); and the driver's batches: the same film as ray
//! by ray for image sizes whose edge tiles are not square, on any number of threads.

mod common;

use glam::{Vec2, Vec3};
use std::path::Path;

use pir::accel::Backend;
use pir::geometry::Ray;
use pir::integrator::{Counters, GatherKind, Integrator, MAX_GATHER_SAMPLES, MethodConfig, RayByRay};
use pir::sampling::{Sampler, SamplerKind, Streams};
use pir::scene::Scene;

use common::Job;

/// Scenes covering the walker's branches, each with what it adds.
const SCENES: &[&str] = &[
    // Diffuse, area light sampled by power.
    "scenes/cornell-box/scene.toml",
    // A mirror and a glass sphere: delta chains, refraction's η² in Russian roulette.
    "scenes/cornell-box/sphere.toml",
    // Glossy surfaces.
    "scenes/cornell-box/glossy.toml",
    // An environment map: escaping rays, MIS against its sampling.
    "tests/data/emitters/envmap.xml",
    // A point light: a light that is not a triangle.
    "tests/data/emitters/point.xml",
    // Emitting spheres: cone samples, whose visibility is a closest-hit query.
    "tests/data/mitsuba-sphere-lights.xml",
    // A thin lens: the camera sample's aperture dimension.
    "tests/data/mitsuba-thinlens.xml",
    // Rough dielectrics, conductors, plastics, textures.
    "tests/data/mitsuba-roughdielectric.xml",
    "tests/data/mitsuba-materials.xml",
    "tests/data/textured/scene.xml",
];

fn load(path: &str) -> Scene {
    pir::scene::load(Path::new(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// What the two walkers gave for one scene: paths compared, paths whose estimates differ in
/// any bit, and the largest difference of a differing path relative to its larger value.
#[derive(Debug, Default)]
struct Agreement {
    paths: usize,
    differing: usize,
    largest: f32,
}

/// The method named `method` with its default parameters.
fn config(method: &str) -> MethodConfig {
    MethodConfig::new(method.parse().unwrap())
}

/// The integrator of the method named `method` for `scene`.
fn integrator(method: &str, scene: &Scene) -> Box<dyn Integrator> {
    config(method).integrator(scene.bounds().diagonal())
}

/// Every camera path of `iterations` iterations at `width` × `height`, traced by `method`'s
/// batched walker (in batches of `batch`) and by its scalar walker from the same samplers;
/// panics unless both draw the same numbers and count the same rays.
#[allow(clippy::too_many_arguments)]
fn compare_paths(
    method: &MethodConfig,
    scene: &Scene,
    backend: Backend,
    (width, height): (usize, usize),
    iterations: u64,
    max_depth: u32,
    sampler: SamplerKind,
    batch: usize,
) -> Agreement {
    let accel = scene.accelerator(backend).unwrap();
    let job = Job { width, height, max_depth, seed: 3, sampler, ..Job::default() };
    let camera = scene.camera().with_resolution(width as u32, height as u32).rays();
    let mut integrator = method.integrator(scene.bounds().diagonal());
    job.with_context_on(scene, accel.as_ref(), |ctx| {
        let mut agreement = Agreement::default();
        integrator.set_camera(camera);
        integrator.prepare(ctx, &mut Counters::default());
        for iteration in 1..=iterations {
            integrator.begin_iteration(ctx, iteration, &mut Counters::default());
            let streams = Streams::camera(sampler, job.seed, iteration);
            let mut rays = Vec::new();
            let mut samplers: Vec<Sampler> = Vec::new();
            for y in 0..height {
                for x in 0..width {
                    let mut s = streams.sampler((y * width + x) as u64);
                    let offset = s.next_2d();
                    let aperture = if camera.has_lens() { s.next_2d() } else { Vec2::ZERO };
                    rays.push(camera.generate_ray(Vec2::new(x as f32, y as f32) + offset, aperture));
                    samplers.push(s);
                }
            }
            let mut scalar_samplers = samplers.clone();
            let (mut batched, mut scalar) = (Counters::default(), Counters::default());
            let mut out = vec![Vec3::NAN; rays.len()];
            for ((rays, samplers), out) in
                rays.chunks(batch).zip(samplers.chunks_mut(batch)).zip(out.chunks_mut(batch))
            {
                integrator.radiance_batch(ctx, rays, samplers, &mut batched, out);
            }
            for (i, (ray, s)) in rays.iter().zip(scalar_samplers.iter_mut()).enumerate() {
                let l = integrator.radiance(ctx, *ray, s, &mut scalar);
                agreement.paths += 1;
                if l.to_array().map(f32::to_bits) != out[i].to_array().map(f32::to_bits) {
                    agreement.differing += 1;
                    let scale = l.abs().max(out[i].abs()).max_element().max(f32::MIN_POSITIVE);
                    agreement.largest = agreement.largest.max((l - out[i]).abs().max_element() / scale);
                }
            }
            if agreement.differing == 0 {
                // Where every estimate agrees, so do the paths: the same rays, the same draws.
                assert_eq!(batched, scalar, "ray counts");
                for (a, b) in samplers.iter_mut().zip(scalar_samplers.iter_mut()) {
                    assert_eq!(a.next_u64(), b.next_u64(), "the next draw of a path's sampler");
                }
            }
        }
        agreement
    })
}

/// On the BVH and brute force, whose batch queries are their single-ray ones, every path of
/// `method` has the scalar walker's estimate bit for bit, for both samplers, in batches of
/// any size (brute force on the Cornell boxes only: it is slow on the tessellated spheres),
/// on `scenes` (indices into [`SCENES`]).
fn same_paths_on_the_bvh(method: &MethodConfig, scenes: &[usize]) {
    let name = method.method.name();
    for &k in scenes {
        let path = SCENES[k];
        let scene = load(path);
        let depth = scene.defaults().max_depth;
        let backends: &[Backend] = if k < 3 { &[Backend::Bvh, Backend::Brute] } else { &[Backend::Bvh] };
        for (sampler, batch) in [(SamplerKind::Sobol, 256), (SamplerKind::Independent, 7)] {
            for &backend in backends {
                let a = compare_paths(method, &scene, backend, (24, 20), 3, depth, sampler, batch);
                assert_eq!(a.differing, 0, "{name}, {path}, {backend}, {sampler:?}: {a:?}");
            }
        }
        // A short path: the walk ends at max_depth after the emission it finds.
        let a = compare_paths(method, &scene, Backend::Bvh, (24, 20), 2, 2, SamplerKind::Sobol, 64);
        assert_eq!(a.differing, 0, "{name}, {path}, max_depth 2: {a:?}");
    }
}

/// Every scene of [`SCENES`].
const ALL: &[usize] = &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9];

#[test]
fn batched_paths_are_the_scalar_paths_on_the_bvh() {
    same_paths_on_the_bvh(&config("pt"), ALL);
}

/// `pir-bdpt`'s camera paths: next-event estimation with as many light samples at the first
/// vertex as the scene asks for, and with four, the gather, the weights' per-path sums.
#[test]
fn bdpt_batched_paths_are_the_scalar_paths_on_the_bvh() {
    same_paths_on_the_bvh(&config("pir-bdpt"), ALL);
    let mut four = config("pir-bdpt");
    four.params.light_samples = Some(4);
    same_paths_on_the_bvh(&four, &[0, 1, 3, 4]);
}

/// The forward many-light methods' covered walks (points, spheres, and `pir-mis`'s bounces
/// weighed against its connections), on the scenes with delta chains, plastics, an
/// environment and a light that is not a triangle.
#[test]
fn many_light_batched_paths_are_the_scalar_paths_on_the_bvh() {
    for method in ["pir-mis", "pir-clamp", "pir-vsl", "ir"] {
        same_paths_on_the_bvh(&config(method), &[1, 3, 4, 8]);
    }
}

/// A gather's connections are kept with the bounce's shadow rays where there are at most 64
/// of them and traced at once otherwise: the sampled gathers (the light tree's too), a full
/// gather of few VPLs (kept) and of the default's (more than 64: traced), all as the scalar
/// walker traces them.
#[test]
fn kept_and_traced_gathers_are_the_scalar_paths_on_the_bvh() {
    let mut tree = config("pir-clamp");
    tree.params.gather = Some(GatherKind::Tree);
    let mut few = config("pir-clamp");
    few.params.vpls = Some(4);
    let mut most = config("pir-bdpt");
    most.params.gather_samples = Some(MAX_GATHER_SAMPLES);
    for method in [tree, few, config("ir"), most] {
        same_paths_on_the_bvh(&method, &[1, 3]);
    }
}

/// On Embree the batches go in packets, whose kernels are other code than the single-ray
/// kernel's; measured (Embree 3.13.5, AVX-512), they find the same hits bit for bit, so every
/// path's estimate is the scalar walker's. Should another Embree or vector width round a hit
/// differently, this test says how many paths differ and by how much; the image tests
/// (`tests/mitsuba.rs`, `tests/golden.rs` on brute force) still judge the estimator.
#[test]
fn batched_paths_are_the_scalar_paths_on_embree() {
    if !Backend::Embree.is_available() {
        eprintln!("built without Embree; skipped");
        return;
    }
    for method in ["pt", "pir-bdpt", "pir-mis"] {
        for path in SCENES {
            let scene = load(path);
            let depth = scene.defaults().max_depth;
            let a = compare_paths(
                &config(method),
                &scene,
                Backend::Embree,
                (24, 20),
                3,
                depth,
                SamplerKind::Sobol,
                256,
            );
            assert_eq!(a.differing, 0, "{method}, {path}: {a:?}");
        }
    }
}

/// The driver hands the integrator its tiles' pixels in batches: the film is the ray-by-ray
/// film for sizes whose edge tiles are narrow, short or single pixels, on 1 and 3 threads,
/// on the BVH and the default backend (Embree where built in), for `pt` and `pir-bdpt` (whose
/// light paths also splat into the film), and `pir-mis` on one size.
#[test]
fn driver_batches_give_the_ray_by_ray_film() {
    let scene = load("scenes/cornell-box/sphere.toml");
    let cases = [
        ("pt", Backend::Bvh, (37, 23)),
        ("pt", Backend::Bvh, (17, 1)),
        ("pt", Backend::Bvh, (1, 33)),
        ("pt", Backend::Bvh, (16, 16)),
        ("pt", Backend::default_available(), (37, 23)),
        ("pir-bdpt", Backend::Bvh, (37, 23)),
        ("pir-bdpt", Backend::Bvh, (1, 33)),
        ("pir-bdpt", Backend::default_available(), (37, 23)),
        ("pir-mis", Backend::default_available(), (37, 23)),
    ];
    for (method, backend, (width, height)) in cases {
        let accel = scene.accelerator(backend).unwrap();
        let mut films = Vec::new();
        for threads in [1, 3] {
            let job = Job { width, height, iterations: 2, threads, ..Job::default() };
            let batched = job.run_with(&scene, accel.as_ref(), integrator(method, &scene).as_mut());
            let scalar = job.run_with(&scene, accel.as_ref(), &mut RayByRay(integrator(method, &scene)));
            let what = format!("{method}, {backend}, {width}×{height}, {threads} threads");
            assert_eq!(batched.film.sums(), scalar.film.sums(), "{what}");
            assert_eq!(batched.stats.counters, scalar.stats.counters, "{what}");
            films.push(batched.film.sums().to_vec());
        }
        assert_eq!(
            films[0], films[1],
            "{method}, {backend}, {width}×{height}: the film depends on the threads"
        );
    }
}

/// A ray the batch holds twice, or that is not valid, is traced as the scalar walker traces
/// it, by `pt` and `pir-bdpt`.
#[test]
fn degenerate_rays_in_a_batch() {
    let scene = load("scenes/cornell-box/scene.toml");
    let accel = scene.accelerator(Backend::Bvh).unwrap();
    for method in ["pt", "pir-bdpt"] {
        let mut integrator = integrator(method, &scene);
        Job::default().with_context_on(&scene, accel.as_ref(), |ctx| {
            integrator.set_camera(scene.camera().with_resolution(16, 16).rays());
            integrator.prepare(ctx, &mut Counters::default());
            integrator.begin_iteration(ctx, 1, &mut Counters::default());
            let good = Ray::new(Vec3::new(0.0, 1.0, 3.0), Vec3::NEG_Z);
            let rays = [good, Ray::new(Vec3::NAN, Vec3::NEG_Z), good, Ray::new(Vec3::ZERO, Vec3::ZERO)];
            let streams = Streams::camera(SamplerKind::Sobol, 1, 1);
            let mut samplers: Vec<Sampler> = (0..rays.len() as u64).map(|i| streams.sampler(i)).collect();
            let mut scalar = samplers.clone();
            let mut out = [Vec3::ONE; 4];
            integrator.radiance_batch(ctx, &rays, &mut samplers, &mut Counters::default(), &mut out);
            for (i, ray) in rays.iter().enumerate() {
                let l = integrator.radiance(ctx, *ray, &mut scalar[i], &mut Counters::default());
                let (a, b) = (out[i].to_array().map(f32::to_bits), l.to_array().map(f32::to_bits));
                assert_eq!(a, b, "{method}, ray {i}");
            }
            integrator.radiance_batch(ctx, &[], &mut [], &mut Counters::default(), &mut []);
        });
    }
}

/// Before the first iteration a many-light method has no lights and sees nothing, batched
/// or not.
#[test]
fn a_batch_before_the_first_iteration_is_black() {
    let scene = load("scenes/cornell-box/scene.toml");
    let integrator = integrator("pir-bdpt", &scene);
    Job::default().with_context(&scene, |ctx| {
        let rays = [Ray::new(Vec3::new(0.0, 1.0, 3.0), Vec3::NEG_Z); 3];
        let streams = Streams::camera(SamplerKind::Sobol, 1, 1);
        let mut samplers: Vec<Sampler> = (0..rays.len() as u64).map(|i| streams.sampler(i)).collect();
        let mut out = [Vec3::ONE; 3];
        integrator.radiance_batch(ctx, &rays, &mut samplers, &mut Counters::default(), &mut out);
        assert_eq!(out, [Vec3::ZERO; 3]);
    });
}

/// `pir render --walker batched` and `--walker scalar` write the same image, on the default
/// backend (Embree where built in).
#[test]
fn the_walker_option_leaves_the_image_as_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cases: &[(&str, &[&str])] = &[
        ("scenes/cornell-box/sphere.toml", &["--method", "pt"]),
        ("tests/data/mitsuba-thinlens.xml", &["--method", "pt", "--sampler", "independent"]),
        ("tests/data/emitters/envmap.xml", &["--method", "pt", "--max-depth", "4"]),
        ("scenes/cornell-box/sphere.toml", &["--method", "pir-bdpt"]),
        ("tests/data/emitters/envmap.xml", &["--method", "pir-bdpt", "--sampler", "independent"]),
        ("scenes/cornell-box/glossy.toml", &["--method", "pir-mis"]),
    ];
    for (scene, args) in cases {
        let images: Vec<_> = ["batched", "scalar"]
            .iter()
            .map(|walker| {
                let mut all = args.to_vec();
                all.extend_from_slice(&["--walker", walker, "--spp", "4", "--resolution", "33", "21"]);
                let out = dir.path().join(format!("{walker}.exr"));
                common::binary::render(&root.join(scene), &all, &out, dir.path(), scene)
            })
            .collect();
        assert_eq!(images[0].pixels, images[1].pixels, "{scene} {args:?}");
    }
}
