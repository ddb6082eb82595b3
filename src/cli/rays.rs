//! `pir rays SCENE`: how fast the chosen backend answers a path tracer's queries in this
//! scene, with nothing else done: the physical limit that a render's rays per second
//! (its summary's `Mrays/s`) can be held against.
//!
//! Three workloads of `--rays` rays each, all drawn from the seed: the camera's rays (one per
//! pixel sample, jittered, over the image at `--resolution`), the bounce rays from the points
//! they hit (a cosine-distributed direction about the normal, on the side the camera sees,
//! leaving from the offset point as a render's do), and the same bounce rays as occlusion
//! queries of unbounded length. Each is traced in batches of 256 (Embree's 16-wide packets,
//! as the batched walker traces them) and one ray at a time, on every thread.

use anyhow::{Result, bail};
use clap::Args;
use glam::Vec2;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

use pir::accel::{Accelerator, Hit};
use pir::geometry::{Frame, Ray, offset_origin};
use pir::render::SceneOptions;
use pir::sampling::{Domain, Sampler, cosine_hemisphere};
use pir::scene::Scene;

/// Rays per batch, as the batched walker's tiles trace them.
const BATCH: usize = 256;

/// Most rays per workload: the two workloads' rays and one workload's answers take about
/// 100 bytes a ray, 1.6 GiB at this size.
const MAX_RAYS: usize = 1 << 24;

/// Measure the ray-query rates of the backend (--accel) in a scene: camera rays, bounce rays
/// and occlusion, batched and one at a time, on all threads (--threads).
#[derive(Args, Debug)]
pub struct RaysArgs {
    /// The scene file: pir's TOML, or a Mitsuba 3 scene (.xml).
    pub scene: PathBuf,
    /// Rays per workload.
    #[arg(long, value_name = "N", default_value_t = 1 << 20)]
    pub rays: usize,
    #[command(flatten)]
    pub options: SceneOptions,
}

pub fn run(a: RaysArgs) -> Result<()> {
    if !(BATCH..=MAX_RAYS).contains(&a.rays) {
        bail!("--rays {}: must be from {BATCH} to {MAX_RAYS}", a.rays);
    }
    a.options.check()?;
    let scene = a.options.load(&a.scene)?;
    // The renders' pool, so that the rates are measured as they trace.
    let pool = pir::render::worker_pool(a.options.threads)?;
    let accel = pool.install(|| scene.accelerator(a.options.backend())).map_err(anyhow::Error::msg)?;
    let seed = a.options.seed(&scene);
    let (width, height) = a.options.resolution(&scene);
    let camera = (*scene.camera()).with_resolution(width, height).rays();
    let pixels = width as u64 * height as u64;
    let camera_rays: Vec<Ray> = pool.install(|| {
        (0..a.rays as u64)
            .into_par_iter()
            .map(|i| {
                let mut s = Sampler::new(seed, i / pixels, Domain::Camera, i % pixels);
                let (x, y) = ((i % pixels) % width as u64, (i % pixels) / width as u64);
                let film = Vec2::new(x as f32, y as f32) + s.next_2d();
                camera.generate_ray(film, s.next_2d())
            })
            .collect()
    });
    let first = trace(&pool, accel.as_ref(), &camera_rays, true).hits;
    let bounce_rays: Vec<Ray> = pool.install(|| {
        camera_rays
            .par_iter()
            .zip(&first)
            .enumerate()
            .map(|(i, (ray, hit))| {
                bounce(&scene, ray, hit.as_ref(), Sampler::new(seed, 0, Domain::LightPath, i as u64))
            })
            .collect()
    });
    drop(first);
    let threads = pool.current_num_threads();
    println!(
        "pir rays: {} at {width}×{height}, {} rays per workload, {threads} threads, {}",
        a.scene.display(),
        a.rays,
        accel.describe()
    );
    println!("{:<22} {:>14} {:>14} {:>9}", "workload", "batched Mr/s", "single Mr/s", "hit share");
    for (name, rays, closest) in [
        ("camera, closest hit", &camera_rays, true),
        ("bounce, closest hit", &bounce_rays, true),
        ("bounce, occlusion", &bounce_rays, false),
    ] {
        let batched = trace(&pool, accel.as_ref(), rays, closest);
        let single = trace_single(&pool, accel.as_ref(), rays, closest);
        println!(
            "{name:<22} {:>14.2} {:>14.2} {:>8.1} %",
            rays.len() as f64 / batched.seconds / 1e6,
            rays.len() as f64 / single / 1e6,
            100.0 * batched.hit_share
        );
    }
    Ok(())
}

/// A bounce ray from the camera ray's hit: a cosine-distributed direction about the normal on
/// the camera's side; a ray that missed the scene stays as it was (it misses again).
fn bounce(scene: &Scene, ray: &Ray, hit: Option<&Hit>, mut s: Sampler) -> Ray {
    let Some(hit) = hit else { return *ray };
    let sp = scene.surface_of_hit(hit, ray.dir);
    let n = sp.facing(ray.dir);
    let w = Frame::from_normal(n).to_world(cosine_hemisphere(s.next_2d()));
    Ray::new(offset_origin(sp.p, sp.ng, w), w)
}

struct Traced {
    seconds: f64,
    hits: Vec<Option<Hit>>,
    hit_share: f64,
}

/// Traces `rays` in batches of [`BATCH`] on the pool's threads.
fn trace(pool: &rayon::ThreadPool, accel: &dyn Accelerator, rays: &[Ray], closest: bool) -> Traced {
    // Only the answers this workload gives.
    let (mut hits, mut blocked) =
        if closest { (vec![None; rays.len()], Vec::new()) } else { (Vec::new(), vec![false; rays.len()]) };
    let start = Instant::now();
    pool.install(|| {
        if closest {
            rays.par_chunks(BATCH)
                .zip(hits.par_chunks_mut(BATCH))
                .for_each(|(r, h)| accel.intersect_batch(r, h));
        } else {
            rays.par_chunks(BATCH)
                .zip(blocked.par_chunks_mut(BATCH))
                .for_each(|(r, o)| accel.occluded_batch(r, o));
        }
    });
    let seconds = start.elapsed().as_secs_f64();
    let n = if closest {
        hits.iter().filter(|h| h.is_some()).count()
    } else {
        blocked.iter().filter(|&&b| b).count()
    };
    Traced { seconds, hits, hit_share: n as f64 / rays.len() as f64 }
}

/// Seconds to trace `rays` one at a time on the pool's threads.
fn trace_single(pool: &rayon::ThreadPool, accel: &dyn Accelerator, rays: &[Ray], closest: bool) -> f64 {
    let start = Instant::now();
    let n: usize = pool.install(|| {
        rays.par_chunks(BATCH)
            .map(|r| {
                r.iter()
                    .filter(|ray| if closest { accel.intersect(ray).is_some() } else { accel.occluded(ray) })
                    .count()
            })
            .sum()
    });
    std::hint::black_box(n);
    start.elapsed().as_secs_f64()
}
