//! The many-light gather's cost per receiver as the number of VPLs grows: the exhaustive
//! gather (`Gather::All`, linear in the count), the tree gather (`Gather::Tree`, k = 16
//! lights per receiver, growing with the tree's depth) and the resampled gather
//! (`Gather::Resampled`, k = 8 picks among m = 256 candidates: constant), shadow rays included; the light
//! tree's build time per VPL count; and the tree's descent alone (`descent`: drawing k = 4 and
//! 16 lights per receiver, no contributions, no shadow rays). Before the descent group, the mean
//! probability of a dead end (a descent that ends without a pick) over the receivers is printed
//! per VPL count.
//!
//! VPLs are traced in the Cornell box (`scenes/cornell-box/scene.toml`) with as many light
//! paths as it takes, and cut to the count. Receivers: the camera's first hits through a 32×32
//! grid of pixel centres. Point lights clamped at the default bound (`ir-clamp`'s kernel).
//!
//! Run: `cargo bench --bench gather -- --noplot` (add `--quick` for a fast pass).

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec2;
use pir::accel::Backend;
use pir::integrator::many_light::light_set::LightSet;
use pir::integrator::many_light::light_tree::LightTree;
use pir::integrator::many_light::points::PointLights;
use pir::integrator::many_light::subpath::Counts;
use pir::integrator::many_light::tree_gather::{Kernel, Lobe, Pick, Receiver, stratified};
use pir::integrator::many_light::virtual_light::{Lights, Plain};
use pir::integrator::many_light::{LightPaths, Vpl, trace_vpls};
use pir::integrator::walker::Vertex;
use pir::integrator::{Clamping, Counters, Gather, RenderContext};
use pir::light::Emitters;
use pir::sampling::{Domain, Sampler, SamplerKind};
use pir::scene::{SurfacePoint, load};

const COUNTS: [usize; 3] = [1_000, 10_000, 100_000];
const SAMPLES: usize = 16;

fn bench(c: &mut Criterion) {
    let scene = load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/scene.toml")).unwrap();
    let accel = scene.accelerator(Backend::default_available()).unwrap();
    let emitters = Emitters::new(&scene).unwrap();
    let ctx = RenderContext {
        scene: &scene,
        accel: accel.as_ref(),
        emitters: &emitters,
        max_depth: 8,
        seed: 1,
        sampler: SamplerKind::default(),
        pilot: None,
    };
    let max_vpl_depth = ctx.max_depth - 2;
    let vpls_of = |n: usize| -> Vec<Vpl> {
        let mut paths = n / 2 + 1;
        loop {
            let (mut v, _) = trace_vpls(&ctx, 1, paths, Counts::uniform(paths as f32), max_vpl_depth);
            if v.len() >= n {
                v.truncate(n);
                return v;
            }
            paths *= 2;
        }
    };
    // Receivers: first hits of the camera rays through a 32×32 grid.
    let camera = scene.camera().with_resolution(32, 32);
    let receivers: Vec<(SurfacePoint, glam::Vec3)> = (0..32 * 32)
        .filter_map(|i| {
            let ray = camera.generate_ray(Vec2::new((i % 32) as f32 + 0.5, (i / 32) as f32 + 0.5));
            let hit = ctx.accel.intersect(&ray)?;
            let sp = scene.surface_of_hit(&hit, ray.dir);
            (!scene.material(sp.material).bsdf.is_delta()).then_some((sp, -ray.dir))
        })
        .collect();
    let clamping = Clamping::Constant { b: Clamping::default_bound(scene.bounds().diagonal()) };
    let points = |vpls| PointLights::new(vpls, clamping, 1, &ctx, None);

    let mut build = c.benchmark_group("tree-build");
    build.sample_size(10).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_secs(1));
    for n in COUNTS.into_iter().chain([1_000_000]) {
        let tree_lights = points(vpls_of(n)).tree_lights(&ctx);
        build.throughput(Throughput::Elements(n as u64));
        build.bench_with_input(BenchmarkId::from_parameter(n), &tree_lights, |b, l| {
            b.iter(|| black_box(LightTree::new(l)))
        });
    }
    build.finish();

    let mut group = c.benchmark_group("gather");
    group.sample_size(10).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_secs(1));
    group.throughput(Throughput::Elements(receivers.len() as u64));
    for n in COUNTS {
        let vpls = vpls_of(n);
        let mut cases = vec![
            ("tree-k16", Gather::Tree { samples: SAMPLES }),
            ("resample-m256-k8", Gather::Resampled { candidates: 256, samples: 8 }),
        ];
        if n <= 10_000 {
            cases.push(("all", Gather::All));
        }
        for (name, gather) in cases {
            let set = LightSet::new(&ctx, points(vpls.clone()), gather, LightPaths::one_each(n));
            group.bench_with_input(BenchmarkId::new(name, n), &set, |b, set| {
                b.iter(|| {
                    let mut counters = Counters::default();
                    let mut sum = glam::Vec3::ZERO;
                    for (i, (sp, wo)) in receivers.iter().enumerate() {
                        let bsdf = &scene.material(sp.material).bsdf;
                        let v = Vertex { sp, wo: *wo, bsdf, depth: 1 };
                        let mut sampler = Sampler::new(1, 1, Domain::Camera, i as u64);
                        sum += set.gather(&ctx, &v, max_vpl_depth, &Plain, &mut sampler, &mut counters);
                    }
                    black_box((sum, counters))
                })
            });
        }
    }
    group.finish();

    // The descent alone, receivers as the gather builds them.
    let bound = clamping.bound(1);
    let rxs: Vec<Receiver> = receivers
        .iter()
        .map(|(sp, wo)| Receiver {
            p: sp.p,
            ng: sp.ng,
            ns: sp.frame.n,
            max_depth: max_vpl_depth,
            kernel: Kernel::Point { bound },
            lobe: Lobe::of(&scene.material(sp.material).bsdf, sp.frame.n, *wo),
        })
        .collect();
    let trees: Vec<(usize, LightTree)> =
        COUNTS.iter().map(|&n| (n, LightTree::new(&points(vpls_of(n)).tree_lights(&ctx)))).collect();
    for (n, tree) in &trees {
        let dead: f64 = rxs.iter().map(|rx| tree.leaf_probabilities(rx).1).sum::<f64>() / rxs.len() as f64;
        eprintln!("{n} VPLs: mean probability of a dead end {dead:.4}");
    }
    let mut descent = c.benchmark_group("descent");
    descent.sample_size(10).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_secs(1));
    descent.throughput(Throughput::Elements(rxs.len() as u64));
    for (n, tree) in &trees {
        for k in [4usize, SAMPLES] {
            descent.bench_with_input(BenchmarkId::new(format!("k{k}"), n), tree, |b, tree| {
                b.iter(|| {
                    let mut picks = 0usize;
                    for (i, rx) in rxs.iter().enumerate() {
                        let mut sampler = Sampler::new(1, 1, Domain::Camera, i as u64);
                        let mut us = vec![0.0f64; k];
                        stratified(&mut sampler, &mut us);
                        let mut out: Vec<Pick> = Vec::with_capacity(k);
                        tree.sample(rx, &mut us, &mut out);
                        picks += out.len();
                    }
                    black_box(picks)
                })
            });
        }
    }
    descent.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
