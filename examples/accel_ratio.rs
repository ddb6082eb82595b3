//! Ray-query rates of the BVH against Embree measured in one process, alternating, for
//! before/after comparisons on a busy machine, and fixed workloads for instruction counts.
//!
//!     accel_ratio ratio SCENE WORKLOAD ROUNDS   BVH/Embree rate ratio, median of ROUNDS
//!     accel_ratio bvh SCENE WORKLOAD PASSES     the BVH alone (for valgrind --tool=callgrind)
//!     accel_ratio embree SCENE WORKLOAD PASSES  Embree alone
//!
//! SCENE: cornell, bunny, dragon (from ../shared/scenes), closed1m or conference
//! (`testmesh::conference_room`); WORKLOAD: closest, occluded or gather, the rays of
//! `benches/accel.rs`, occluded-batch or gather-batch, the same rays in one batched call
//! (Embree's 16-wide packets; the BVH traces a batch ray by ray), or
//! `build`: the BVH's build time over Embree's (medium quality), both on every core (rayon's
//! and TBB's threads), timed in wall time, alternating, a build of each per round (the ratio is
//! of times: lower is better; `bvh SCENE build N` builds N times, for profilers). The BVH builds
//! on rayon's global pool, so `RAYON_NUM_THREADS=1` times its one-thread build (Embree's
//! stays on every core; the accel bench instead makes pools of its own). A round
//! traces about 400,000 rays (`RAYS`) on the BVH, then as many on Embree, each timed in CPU
//! time of this thread (`CLOCK_THREAD_CPUTIME_ID`), so time the thread spends preempted does
//! not count and the machine's drift between the two halves of a round is small. (Until
//! 2026-12-05 this read /proc/thread-self/schedstat, which on these machines advances by
//! scheduler ticks of 4 ms: ±1 % on a round of 3 M gather rays on the bunny, ±7 % on 400,000.)
//! Compare two builds by their ratios: `cargo build --release --example accel_ratio`, copy
//! `target/release/examples/accel_ratio` aside, change the code, build again, and run both in
//! turn.
//!
//! Diagnostics, from the environment: `SPLIT=occluded` or `SPLIT=free` keeps only the rays that
//! are (or are not) occluded, by brute force (which rays of the gather pattern cost what), and
//! `REPEAT=K` traces each ray K times in a row, so that all but the first find the tree's nodes
//! and triangles in cache (the work per ray without the memory traffic).
//!
//! Instruction counts of the traversal alone: `valgrind --tool=callgrind
//! --toggle-collect='*hit_dispatch*' target/release/examples/accel_ratio bvh bunny occluded 1`
//! (valgrind runs the AVX2 versions, pir's and Embree's); of the code the CPU really runs, AVX-512
//! included, per ray of either backend: `docs/stepcount.py`, by single-stepping in gdb.

use std::process::ExitCode;

use anyhow::{Context, Result, bail, ensure};
use cpu_time::ThreadTime;
use pir::accel::testmesh::{self, Mesh, Workloads};
use pir::accel::{Accelerator, Backend, BruteForce, Bvh, build_accelerator};
use pir::geometry::{Ray, VertexBuffer};

fn scene(name: &str) -> Result<Mesh> {
    let obj = |path: std::path::PathBuf| Mesh::from_obj(&path).with_context(|| path.display().to_string());
    Ok(match name {
        "cornell" => testmesh::cornell_like(),
        "closed1m" => testmesh::closed_scene(1_000_000),
        "bunny" => obj(testmesh::shared_scenes().join("bunny/bun_zipper.obj"))?,
        "dragon" => obj(testmesh::shared_scenes().join("dragon/dragon_vrip_res2.obj"))?,
        "conference" => obj(testmesh::conference_room())?,
        _ => bail!("unknown scene {name:?}: expected cornell, bunny, dragon, closed1m or conference"),
    })
}

/// The workload's rays, as `benches/accel.rs` traces them.
fn rays(m: &Mesh, workload: &str) -> Result<Vec<Ray>> {
    let w = Workloads::new(m);
    Ok(match workload {
        "closest" => w.closest,
        "occluded" => w.occluded,
        "gather" | "gather-batch" => w.gather,
        "occluded-batch" => w.occluded,
        _ => bail!(
            "unknown workload {workload:?}: expected closest, occluded, gather, their -batch forms or build"
        ),
    })
}

/// How a workload is traced: closest hits, or occlusion ray by ray or in batches.
#[derive(Clone, Copy, PartialEq)]
enum Query {
    Closest,
    Occluded,
    OccludedBatch,
}

fn trace(acc: &dyn Accelerator, rays: &[Ray], query: Query) -> usize {
    if query == Query::OccludedBatch {
        let mut occ = vec![false; rays.len()];
        acc.occluded_batch(std::hint::black_box(rays), &mut occ);
        return occ.iter().filter(|&&o| o).count();
    }
    if query == Query::Closest {
        rays.iter().filter(|r| acc.intersect(std::hint::black_box(r)).is_some()).count()
    } else {
        rays.iter().filter(|r| acc.occluded(std::hint::black_box(r))).count()
    }
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("accel_ratio: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let [_, mode, scene_name, workload, n] = &args[..] else {
        bail!("usage: accel_ratio ratio|bvh|embree SCENE WORKLOAD N (see the source's docs)");
    };
    ensure!(
        ["ratio", "bvh", "embree"].contains(&mode.as_str()),
        "unknown mode {mode:?}: expected ratio, bvh or embree"
    );
    let n: usize =
        n.parse().ok().filter(|&n| n > 0).with_context(|| format!("N = {n:?}: a positive count"))?;
    let per_round: usize = match std::env::var("RAYS") {
        Ok(v) => v.parse().ok().filter(|&r| r > 0).with_context(|| format!("RAYS={v}: a positive count"))?,
        Err(_) => 400_000,
    };
    let m = scene(scene_name)?;
    if workload == "build" {
        return builds(mode, scene_name, &m, n);
    }
    let mut rs = rays(&m, workload)?;
    if let Ok(split) = std::env::var("SPLIT") {
        let want = match split.as_str() {
            "occluded" => true,
            "free" => false,
            _ => bail!("SPLIT={split}: expected occluded or free"),
        };
        let oracle = BruteForce::new(&m.positions, &m.indices);
        rs.retain(|r| oracle.occluded(r) == want);
        eprintln!("SPLIT={split}: {} rays", rs.len());
    }
    if let Ok(k) = std::env::var("REPEAT") {
        let k: usize =
            k.parse().ok().filter(|&k| k > 0).with_context(|| format!("REPEAT={k}: a positive count"))?;
        rs = rs.iter().flat_map(|r| std::iter::repeat_n(*r, k)).collect();
    }
    ensure!(!rs.is_empty(), "{scene_name} {workload}: no rays left to trace");
    let query = match workload.as_str() {
        "closest" => Query::Closest,
        w if w.ends_with("-batch") => Query::OccludedBatch,
        _ => Query::Occluded,
    };
    let vertices = VertexBuffer::from(m.positions.clone());
    match mode.as_str() {
        "bvh" => {
            let bvh = Bvh::new(&m.positions, &m.indices);
            println!("{} hits", (0..n).map(|_| trace(&bvh, &rs, query)).sum::<usize>());
        }
        "embree" => {
            let e = build_embree(&vertices, &m)?;
            println!("{} hits", (0..n).map(|_| trace(e.as_ref(), &rs, query)).sum::<usize>());
        }
        "ratio" => {
            let bvh = Bvh::new(&m.positions, &m.indices);
            let e = build_embree(&vertices, &m)?;
            // The two backends' triangle tests differ on rays through a shared edge or vertex,
            // which one of them may count as a hit and the other not (the conference room's
            // closest hits: one ray in 65,536). Up to one ray in 10,000 is tolerated (none in a
            // set of fewer rays, as `SPLIT` may leave), more is taken for a bug.
            let (hb, he) = (trace(&bvh, &rs, query), trace(e.as_ref(), &rs, query));
            if hb != he {
                ensure!(hb.abs_diff(he) * 10_000 <= rs.len(), "hit counts differ: BVH {hb}, Embree {he}");
                eprintln!(
                    "note: hit counts differ by {} (BVH {hb}, Embree {he}), probably rays through shared edges",
                    hb.abs_diff(he)
                );
            }
            let passes = (per_round / rs.len()).max(1);
            let rate = |acc: &dyn Accelerator| -> Result<f64> {
                let t0 = ThreadTime::try_now().context("this thread's CPU time")?;
                for _ in 0..passes {
                    trace(acc, &rs, query);
                }
                let ns = t0.try_elapsed().context("this thread's CPU time")?.as_nanos().max(1);
                Ok((passes * rs.len()) as f64 / ns as f64 * 1e3)
            };
            let (mut b, mut em, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
            for _ in 0..n {
                let (rb, re) = (rate(&bvh)?, rate(e.as_ref())?);
                b.push(rb);
                em.push(re);
                ratio.push(rb / re);
            }
            let (lo, hi) = ratio.iter().fold((f64::MAX, 0f64), |(l, h), &r| (l.min(r), h.max(r)));
            println!(
                "{scene_name} {workload}: BVH {:.3}, Embree {:.3} M rays/s (CPU time), BVH/Embree {:.3} \
                 (median of {n}; {lo:.3}-{hi:.3})",
                median(&b),
                median(&em),
                median(&ratio)
            );
        }
        _ => bail!("unknown mode {mode:?}: expected ratio, bvh or embree"),
    }
    Ok(())
}

/// Embree's scene of `m`, or the reason there is none (a build of pir without Embree).
fn build_embree<'a>(vertices: &'a VertexBuffer, m: &'a Mesh) -> Result<Box<dyn Accelerator + 'a>> {
    build_accelerator(Backend::Embree, vertices, &m.indices)
        .map_err(|e| anyhow::anyhow!("a build with Embree: {e}"))
}

/// The `build` workload: wall time of builds on every core.
fn builds(mode: &str, scene_name: &str, m: &Mesh, n: usize) -> Result<()> {
    let vertices = VertexBuffer::from(m.positions.clone());
    let time = |f: &dyn Fn()| {
        let t0 = std::time::Instant::now();
        f();
        t0.elapsed().as_secs_f64() * 1e3
    };
    let bvh = || drop(std::hint::black_box(Bvh::new(&m.positions, &m.indices)));
    if mode != "bvh" {
        // (Fails early, before anything is timed, on a build without Embree; `bvh` mode, for
        // profilers, builds no Embree scene at all.)
        build_embree(&vertices, m)?;
    }
    let embree = || drop(std::hint::black_box(build_embree(&vertices, m).expect("Embree")));
    match mode {
        "bvh" => (0..n).for_each(|_| bvh()),
        "embree" => (0..n).for_each(|_| embree()),
        "ratio" => {
            // One build of each first: page faults of the first allocations, thread pools.
            bvh();
            embree();
            let (mut b, mut e, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
            for _ in 0..n {
                let (tb, te) = (time(&bvh), time(&embree));
                b.push(tb);
                e.push(te);
                ratio.push(tb / te);
            }
            let (lo, hi) = ratio.iter().fold((f64::MAX, 0f64), |(l, h), &r| (l.min(r), h.max(r)));
            println!(
                "{scene_name} build: BVH {:.1} ms, Embree {:.1} ms (wall time), BVH/Embree {:.3} \
                 (median of {n}; {lo:.3}-{hi:.3})",
                median(&b),
                median(&e),
                median(&ratio)
            );
        }
        _ => bail!("unknown mode {mode:?}: expected ratio, bvh or embree"),
    }
    Ok(())
}
