//! The progressive loop.
//!
//! Iteration i (from 1) lets the integrator prepare (e.g. trace its VPLs), then renders one
//! sample in every pixel, tiles spread over rayon's pool, each tile's camera rays handed to
//! the integrator in batches ([`Integrator::radiance_batch`], [`BATCH`] rays at most). The
//! sample of pixel p in iteration i uses sampler p of `Streams::camera(sampler, seed, i)` (with Sobol points,
//! point i − 1 of the pixel's own scrambled sequence): its first dimension is the position in
//! the pixel, its second the point on a thin lens's aperture (a pinhole draws none), the rest
//! the integrator's. Each pixel's sum is accumulated in iteration order, so the image depends
//! on the seed only, never on the thread count.
//!
//! Light that the integrator traced to the camera in the iteration ([`Integrator::film_splats`],
//! `pir-bdpt`) is added to the iteration's samples through the same reconstruction filter,
//! splat by splat in the integrator's order, so the iteration's value of a pixel is its camera
//! sample's share plus the light tracer's, whatever the threads.
//!
//! Samples that are NaN or infinite never reach the film: they are counted, dropped and
//! reported (with the first pixel) so that a bug shows instead of hiding.
//!
//! [`render_from`] continues a film (a resumed render) and renders a shard's share of the
//! global iterations (see [`super::state`]); [`render`] is the plain case. Progress display
//! belongs to the caller's per-iteration callback.

use glam::Vec2;
use rayon::prelude::*;
use std::time::{Duration, Instant};

use super::Film;
use super::splat::{Splat, light_image};
use super::state::Shard;
use crate::integrator::{Counters, Integrator, RenderContext};
use crate::sampling::Streams;
use crate::scene::Filter;

/// When to stop: after `iterations` (in the film, counting any it started with), after `time`
/// (of this run), or whichever comes first.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Budget {
    pub iterations: Option<u64>,
    pub time: Option<Duration>,
}

/// Square tile edge in pixels: the unit of work spread over the threads.
pub const TILE_SIZE: usize = 16;

/// Most camera rays per [`Integrator::radiance_batch`] call: a tile's pixels go in chunks of
/// this many, in rows (a whole 16 × 16 tile in one).
pub const BATCH: usize = 256;

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: usize,
    pub height: usize,
    pub budget: Budget,
}

/// What a per-iteration callback tells the driver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    Continue,
    Stop,
}

/// Statistics of a finished render.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    /// Iterations in the film (those it started with included).
    pub iterations: u64,
    /// Iterations rendered by this run.
    pub rendered: u64,
    pub elapsed: Duration,
    /// Time in `prepare` (a pilot) and `begin_iteration` (e.g. light tracing).
    pub prepare_time: Duration,
    /// Time rendering pixels.
    pub pixel_time: Duration,
    pub counters: Counters,
    /// Samples dropped for being NaN or infinite.
    pub dropped: u64,
    /// The first dropped sample: (x, y, iteration).
    pub first_dropped: Option<(usize, usize, u64)>,
}

impl RenderStats {
    pub fn rays_per_second(&self) -> f64 {
        let c = &self.counters;
        (c.rays + c.shadow_rays + c.light_rays + c.pilot_rays) as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }

    /// Occlusion queries per second of pixel time (the gather's rate for VPL methods).
    pub fn shadow_rays_per_second(&self) -> f64 {
        self.counters.shadow_rays as f64 / self.pixel_time.as_secs_f64().max(1e-9)
    }
}

struct Tile {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
}

fn tiles(width: usize, height: usize, size: usize) -> Vec<Tile> {
    let size = size.max(1);
    let mut v = Vec::new();
    for y0 in (0..height).step_by(size) {
        for x0 in (0..width).step_by(size) {
            v.push(Tile { x0, y0, x1: (x0 + size).min(width), y1: (y0 + size).min(height) });
        }
    }
    v
}

/// Renders progressively until the budget is spent or `on_iteration` says stop. Runs on the
/// current rayon pool.
pub fn render(
    ctx: &RenderContext,
    integrator: &mut dyn Integrator,
    settings: &RenderSettings,
    on_iteration: impl FnMut(&Film, &RenderStats) -> Control,
) -> (Film, RenderStats) {
    let film = Film::new(settings.width, settings.height);
    render_from(ctx, integrator, settings, film, Shard::ALL, on_iteration)
}

/// As [`render`], continuing `film` (whose size must be the settings') with the shard's next
/// global iterations: the film's m-th iteration is the shard's global iteration
/// `shard.global_iteration(m)`, so a continued render draws the same random numbers as an
/// uninterrupted one.
pub fn render_from(
    ctx: &RenderContext,
    integrator: &mut dyn Integrator,
    settings: &RenderSettings,
    mut film: Film,
    shard: Shard,
    mut on_iteration: impl FnMut(&Film, &RenderStats) -> Control,
) -> (Film, RenderStats) {
    let (w, h) = (settings.width, settings.height);
    assert_eq!((film.width, film.height), (w, h), "the film must have the render's size");
    let camera = ctx.scene.camera().with_resolution(w as u32, h as u32).rays();
    let tiles = tiles(w, h, TILE_SIZE);
    // A filter wider than the box spreads every sample over the pixels around it.
    let mut splat = (ctx.scene.filter() != Filter::Box).then(|| Splat::new(ctx.scene.filter(), w, h));
    let mut stats = RenderStats { iterations: film.iterations(), ..RenderStats::default() };
    let start = Instant::now();
    integrator.set_camera(camera);
    // (A no-op for an integrator the caller prepared already.)
    integrator.prepare(ctx, &mut stats.counters);
    stats.prepare_time += start.elapsed();

    loop {
        let done = film.iterations();
        if settings.budget.iterations.is_some_and(|n| done >= n) {
            break;
        }
        if settings.budget.time.is_some_and(|t| stats.rendered > 0 && start.elapsed() >= t) {
            break;
        }
        let iteration = shard.global_iteration(done);
        let t0 = Instant::now();
        integrator.begin_iteration(ctx, iteration, &mut stats.counters);
        let t1 = Instant::now();
        let integ: &dyn Integrator = integrator;
        let streams = Streams::camera(ctx.sampler, ctx.seed, iteration);
        let results: Vec<(Vec<glam::Vec3>, Vec<Vec2>, Counters)> = tiles
            .par_iter()
            .map(|t| {
                let mut counters = Counters::default();
                let tw = t.x1 - t.x0;
                let n = tw * (t.y1 - t.y0);
                let mut out = vec![glam::Vec3::ZERO; n];
                let mut offsets = Vec::with_capacity(if splat.is_some() { n } else { 0 });
                let mut rays = Vec::with_capacity(n.min(BATCH));
                let mut samplers = Vec::with_capacity(n.min(BATCH));
                // The tile's pixels in rows, a batch at a time.
                for (c, out) in out.chunks_mut(BATCH).enumerate() {
                    rays.clear();
                    samplers.clear();
                    for k in c * BATCH..c * BATCH + out.len() {
                        let (x, y) = (t.x0 + k % tw, t.y0 + k / tw);
                        let mut sampler = streams.sampler((y * w + x) as u64);
                        let offset = sampler.next_2d();
                        // A thin lens's point on the aperture is the camera sample's second
                        // dimension; a pinhole draws none, so that its images stay as they were.
                        let aperture = if camera.has_lens() { sampler.next_2d() } else { Vec2::ZERO };
                        rays.push(camera.generate_ray(Vec2::new(x as f32, y as f32) + offset, aperture));
                        samplers.push(sampler);
                        if splat.is_some() {
                            offsets.push(offset);
                        }
                    }
                    integ.radiance_batch(ctx, &rays, &mut samplers, &mut counters, out);
                }
                (out, offsets, counters)
            })
            .collect();
        if let Some(splat) = &mut splat {
            splat.clear();
        }
        // The light traced to the camera, through the filter.
        let splats = integrator.film_splats();
        let light = (!splats.is_empty()).then(|| {
            let (image, dropped, first) = light_image(splats, splat.as_ref(), w, h);
            stats.dropped += dropped;
            if let Some((x, y)) = first {
                stats.first_dropped.get_or_insert((x, y, iteration));
            }
            image
        });
        for (tile, (values, offsets, counters)) in tiles.iter().zip(results) {
            stats.counters += counters;
            let mut k = 0;
            for y in tile.y0..tile.y1 {
                for x in tile.x0..tile.x1 {
                    let v = values[k];
                    let lit = light.as_ref().map(|l| l[y * w + x]);
                    if !v.is_finite() {
                        stats.dropped += 1;
                        stats.first_dropped.get_or_insert((x, y, iteration));
                        if let (None, Some(l)) = (&splat, lit) {
                            film.add(y * w + x, l);
                        }
                    } else if let Some(splat) = &mut splat {
                        splat.put(x, y, offsets[k], v);
                    } else {
                        film.add(y * w + x, lit.map_or(v, |l| v + l));
                    }
                    k += 1;
                }
            }
        }
        if let Some(splat) = &splat {
            splat.develop(&mut film, light.as_deref());
        }
        film.end_iteration();
        stats.iterations = film.iterations();
        stats.rendered += 1;
        stats.prepare_time += t1 - t0;
        stats.pixel_time += t1.elapsed();
        stats.elapsed = start.elapsed();
        if on_iteration(&film, &stats) == Control::Stop {
            break;
        }
    }
    stats.elapsed = start.elapsed();
    (film, stats)
}
