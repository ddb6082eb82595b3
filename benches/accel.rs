//! Ray-query throughput of the backends (rays per second, one thread) and BVH build time.
//!
//! Cases, per scene and backend: `closest` (incoherent random rays, closest hit), `occluded`
//! (random segments between points of the scene's box) and `gather` (one point to 1,024
//! scattered surface points, occlusion: the VPL gathering pattern), each with single-ray calls
//! and with the batched calls (`*-batch`: Embree's 16-wide packets; the BVH's batch is a loop
//! of single rays). Backends: Embree when pir is built with it, the BVH, and brute force on
//! small meshes. Workloads run one after another, each on every backend in turn, so that the
//! rates of one ratio are measured close together in time. Build times for the BVH and
//! Embree. Scenes: a generated Cornell-like box, a generated ~1M-triangle closed scene, the
//! conference room ([`testmesh::conference_room`], in the repository: a missing or broken
//! file fails the run) and, when present, the Stanford bunny and dragon from
//! `../shared/scenes` (or `../../shared/scenes` from a worktree). Backends come from one list
//! of `Box<dyn Accelerator>`; brute force only runs on small meshes.
//!
//! Run: `RAYON_NUM_THREADS=1 cargo bench --bench accel -- --noplot` (add `--quick` for a fast
//! pass). The queries run on the calling thread; the builds on pools of their own (see
//! [`bench_build`]): the BVH on one thread per core, as Embree's TBB, and once more on one
//! thread, whatever `RAYON_NUM_THREADS` says.

use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use pir::accel::testmesh::{self, Mesh, Workloads};
use pir::accel::{Accelerator, Backend, BruteForce, Bvh, build_accelerator};
use pir::geometry::{Ray, VertexBuffer};

/// Brute force only below this many triangles.
const BRUTE_MAX: usize = 2_000;

fn backends<'a>(m: &'a Mesh, vertices: &'a VertexBuffer) -> Vec<Box<dyn Accelerator + 'a>> {
    let mut v: Vec<Box<dyn Accelerator + 'a>> = Vec::new();
    if Backend::Embree.is_available() {
        v.push(build_accelerator(Backend::Embree, vertices, &m.indices).expect("Embree builds"));
    }
    v.push(Box::new(Bvh::new(&m.positions, &m.indices)));
    if m.indices.len() <= BRUTE_MAX {
        v.push(Box::new(BruteForce::new(&m.positions, &m.indices)));
    }
    v
}

fn load_obj(path: &Path) -> Option<Mesh> {
    if !path.exists() {
        println!("skipping {}: not found", path.display());
        return None;
    }
    Mesh::from_obj(path).map_err(|e| println!("skipping {}: {e}", path.display())).ok()
}

fn scenes() -> Vec<(&'static str, Mesh)> {
    let mut v = vec![("cornell", testmesh::cornell_like()), ("closed1m", testmesh::closed_scene(1_000_000))];
    // The production scene of `docs/batch.md`, in the repository: never skipped.
    let path = testmesh::conference_room();
    let room = Mesh::from_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    v.push(("conference", room));
    let shared = testmesh::shared_scenes();
    for (name, file) in [("bunny", "bunny/bun_zipper.obj"), ("dragon", "dragon/dragon_vrip_res2.obj")] {
        if let Some(m) = load_obj(&shared.join(file)) {
            v.push((name, m));
        }
    }
    v
}

fn bench_queries(c: &mut Criterion) {
    for (scene, m) in scenes() {
        let Workloads { closest: rays, occluded: segs, gather } = Workloads::new(&m);
        let vertices = VertexBuffer::from(m.positions.clone());
        let accs = backends(&m, &vertices);
        for acc in &accs {
            println!("{scene}: {}", acc.describe());
        }
        // Workload by workload, every backend in turn: the rates compared in a ratio are taken
        // seconds apart, not a whole scene apart, so a machine whose load drifts skews them less.
        let mut hits = vec![None; rays.len()];
        let mut occ = vec![false; rays.len()];
        let mut gather_occ = vec![false; gather.len()];
        for case in ["closest", "occluded", "closest-batch", "occluded-batch", "gather", "gather-batch"] {
            for acc in &accs {
                let acc = acc.as_ref();
                let mut g = c.benchmark_group(format!("{scene}/{}", acc.name()));
                let n = if case.starts_with("gather") { gather.len() } else { rays.len() };
                g.throughput(Throughput::Elements(n as u64));
                match case {
                    "closest" => g.bench_function(case, |bch| {
                        bch.iter(|| rays.iter().filter(|r| acc.intersect(black_box(r)).is_some()).count())
                    }),
                    "occluded" => g.bench_function(case, |bch| bch.iter(|| count_occluded(acc, &segs))),
                    "closest-batch" => g.bench_function(case, |bch| {
                        bch.iter(|| {
                            acc.intersect_batch(black_box(&rays), &mut hits);
                            hits.iter().filter(|h| h.is_some()).count()
                        })
                    }),
                    "occluded-batch" => {
                        g.bench_function(case, |bch| bch.iter(|| count_occluded_batch(acc, &segs, &mut occ)))
                    }
                    "gather" => g.bench_function(case, |bch| bch.iter(|| count_occluded(acc, &gather))),
                    _ => g.bench_function(case, |bch| {
                        bch.iter(|| count_occluded_batch(acc, &gather, &mut gather_occ))
                    }),
                };
                g.finish();
            }
        }
    }
}

fn count_occluded(acc: &dyn Accelerator, rays: &[Ray]) -> usize {
    rays.iter().filter(|r| acc.occluded(black_box(r))).count()
}

fn count_occluded_batch(acc: &dyn Accelerator, rays: &[Ray], occ: &mut [bool]) -> usize {
    acc.occluded_batch(black_box(rays), occ);
    occ.iter().filter(|&&o| o).count()
}

/// Build times: `build/bvh` on a rayon pool of one thread per core, as Embree's TBB builds
/// (`build/embree`), whatever `RAYON_NUM_THREADS` says, so that the command in `docs/speed.md` (which
/// sets it to 1 for the queries) compares the two builds on the same cores; `build/bvh-1thread`
/// on one thread.
fn bench_build(c: &mut Criterion) {
    let scenes = scenes();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let pool = |threads: usize| {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a rayon pool for the builds")
    };
    let mut cases = vec![("bvh", Backend::Bvh, pool(cores)), ("bvh-1thread", Backend::Bvh, pool(1))];
    if Backend::Embree.is_available() {
        // (Embree's builds run on its own TBB threads; the pool only calls it.)
        cases.push(("embree", Backend::Embree, pool(1)));
    }
    for (name, backend, pool) in &cases {
        let mut g = c.benchmark_group(format!("build/{name}"));
        g.sample_size(10);
        for (scene, m) in &scenes {
            let vertices = VertexBuffer::from(m.positions.clone());
            g.throughput(Throughput::Elements(m.indices.len() as u64));
            // Each sample's builds run on the pool, timed there: no build pays for entering it
            // (a few microseconds, which the Cornell-like box's builds would feel).
            g.bench_function(BenchmarkId::from_parameter(scene), |bch| {
                bch.iter_custom(|iters| {
                    pool.install(|| {
                        let start = Instant::now();
                        for _ in 0..iters {
                            black_box(
                                build_accelerator(*backend, black_box(&vertices), black_box(&m.indices))
                                    .unwrap(),
                            );
                        }
                        start.elapsed()
                    })
                })
            });
        }
        g.finish();
    }
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(20)
}

criterion_group! { name = benches; config = config(); targets = bench_queries, bench_build }
criterion_main!(benches);
