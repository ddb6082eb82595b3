//! The [`Renderer`]: what `pir render`, `pir reference` and `pir study` drive, and the API of a
//! program that embeds pir.
//!
//! A renderer holds everything a render needs besides the method: the scene (borrowed, since
//! the accelerator borrows its triangles), its emitters, the worker pool, the accelerator, the
//! resolution, seed and path length, and what the EXR metadata records. It renders a
//! [`MethodConfig`] for a [`Budget`], calling back after every iteration (for progress,
//! checkpoints, snapshots, interruption), and writes the EXR with its PNG preview.
//!
//! ```no_run
//! # fn main() -> anyhow::Result<()> {
//! use pir::integrator::{Method, MethodConfig};
//! use pir::render::{Budget, Control, Renderer, SceneOptions};
//!
//! let scene = pir::scene::load("scenes/cornell-box/scene.toml".as_ref())?;
//! let renderer = Renderer::new(&scene, &SceneOptions::default())?;
//! let config = MethodConfig::new("pir-vsl".parse::<Method>().map_err(anyhow::Error::msg)?);
//! let budget = Budget { iterations: Some(16), time: None };
//! let (film, stats) = renderer.render(&config, budget, |_, _| Control::Continue);
//! let attributes = renderer.attributes(&config, &stats);
//! renderer.write("out.exr".as_ref(), &film, &attributes, None, Some(("out.png".as_ref(), 0.0)))?;
//! # Ok(())
//! # }
//! ```

use anyhow::{Context, Result};
use std::path::Path;

use super::options::{SceneOptions, check_resolution};
use super::state::{Job, Shard, write_state};
use super::{Budget, Control, Film, RenderSettings, RenderStats, render_from};
use crate::accel::{Accelerator, set_flush_denormals};
use crate::image::{RgbImage, write_exr, write_preview};
use crate::integrator::emitter_pilot::{self, Verdict};
use crate::integrator::{Counters, Integrator, MethodConfig, RayByRay, RenderContext, Walker};
use crate::light::{EmitterChoice, Emitters};
use crate::sampling::SamplerKind;
use crate::scene::Scene;

/// A scene ready to render: emitters, worker pool, accelerator and render settings.
pub struct Renderer<'s> {
    scene: &'s Scene,
    emitters: Emitters,
    pool: rayon::ThreadPool,
    accel: Box<dyn Accelerator + 's>,
    accel_description: String,
    /// The scene's fingerprint, for every file's attributes (hashing a big scene takes a while).
    fingerprint: String,
    width: u32,
    height: u32,
    seed: u64,
    sampler: SamplerKind,
    max_depth: u32,
    walker: Walker,
    /// The pilots of the methods that run them, once for the render ([`Integrator::prepare`]).
    pilot: crate::integrator::many_light::Pilots,
    /// What the pilot of next-event estimation's choice found, where it ran
    /// (`--emitter-choice auto` and emitters that can be picked by importance).
    emitter_verdict: Option<Verdict>,
}

impl<'s> Renderer<'s> {
    /// Checks the options, finds the scene's emitters, starts the worker pool and builds the
    /// accelerator. The resolution, seed and path length are the options', else the scene's.
    pub fn new(scene: &'s Scene, options: &SceneOptions) -> Result<Renderer<'s>> {
        options.check()?;
        let emitters = Emitters::new(scene)
            .with_context(|| {
                format!("{}: the scene has no emitter with positive power", scene.path().display())
            })?
            .with_choice(options.emitter_choice());
        let (width, height) = options.resolution(scene);
        check_resolution(width, height)?;
        let pool = worker_pool(options.threads)?;
        // Built on the worker pool, so that `threads` bounds the BVH's build as it does the
        // render (Embree builds on its own TBB threads, one per core). The pool's threads flush
        // denormals to zero, which the BVH's boxes allow for (padding, `bvh/traverse.rs`).
        let accel = pool.install(|| scene.accelerator(options.backend())).map_err(anyhow::Error::msg)?;
        // `auto`: the choice by importance where the pilot finds that it pays.
        let (emitters, emitter_verdict) =
            if options.emitter_choice() == EmitterChoice::Auto && emitters.is_spatial() {
                let camera = scene.camera().with_resolution(width, height).rays();
                // On the worker pool, whose threads flush denormals as the render's do.
                let verdict = pool.install(|| {
                    emitter_pilot::run(scene, accel.as_ref(), &emitters, &camera, options.max_depth(scene))
                });
                let choice =
                    if verdict.importance_pays() { EmitterChoice::Importance } else { EmitterChoice::Power };
                (emitters.with_choice(choice), Some(verdict))
            } else {
                (emitters, None)
            };
        Ok(Renderer {
            scene,
            emitters,
            pool,
            accel_description: accel.describe(),
            fingerprint: scene.fingerprint(),
            accel,
            width,
            height,
            seed: options.seed(scene),
            sampler: options.sampler(),
            max_depth: options.max_depth(scene),
            walker: options.walker(),
            pilot: Default::default(),
            emitter_verdict,
        })
    }

    pub fn scene(&self) -> &Scene {
        self.scene
    }

    pub fn emitters(&self) -> &Emitters {
        &self.emitters
    }

    /// What the pilot of next-event estimation's choice found, where it ran.
    pub fn emitter_verdict(&self) -> Option<Verdict> {
        self.emitter_verdict
    }

    /// The image size in pixels.
    pub fn resolution(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    pub fn sampler(&self) -> SamplerKind {
        self.sampler
    }

    pub fn max_depth(&self) -> u32 {
        self.max_depth
    }

    /// How the camera paths are traced (the same image either way).
    pub fn walker(&self) -> Walker {
        self.walker
    }

    /// Worker threads.
    pub fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }

    /// The accelerator's description for summaries and metadata.
    pub fn accel_description(&self) -> &str {
        &self.accel_description
    }

    /// Runs `op` on the renderer's worker pool (e.g. work to spread over the same threads).
    pub fn install<R: Send>(&self, op: impl FnOnce() -> R + Send) -> R {
        self.pool.install(op)
    }

    /// The integrator of a method for this scene, given the camera and prepared
    /// ([`Integrator::prepare`]: the render's pilot of light paths, run at the first call only,
    /// for the methods that use it, and what a method chooses by the camera's view).
    pub fn integrator(&self, config: &MethodConfig) -> Box<dyn Integrator> {
        let mut integrator = config.integrator(self.scene.bounds().diagonal());
        // The camera first: a pilot may look through it.
        integrator.set_camera(self.scene.camera().with_resolution(self.width, self.height).rays());
        let ctx = self.context();
        // (What a pilot run here traces is not a render's: its count is dropped.)
        self.pool.install(|| integrator.prepare(&ctx, &mut Counters::default()));
        integrator
    }

    /// What the integrators see of the render.
    fn context(&self) -> RenderContext<'_> {
        RenderContext {
            scene: self.scene,
            accel: self.accel.as_ref(),
            emitters: &self.emitters,
            max_depth: self.max_depth,
            seed: self.seed,
            sampler: self.sampler,
            pilot: Some(&self.pilot),
        }
    }

    /// What a render of `config` is, for resuming and merging it.
    pub fn job(&self, config: &MethodConfig) -> Job {
        let (w, h) = (self.width as usize, self.height as usize);
        Job::new(self.scene, config, self.max_depth, self.seed, self.sampler, w, h)
            .with_emitters(&self.emitters)
    }

    /// Renders `config` from an empty film until the budget is spent or `on_iteration` (called
    /// after every iteration with the film and the statistics so far) says stop.
    pub fn render(
        &self,
        config: &MethodConfig,
        budget: Budget,
        on_iteration: impl FnMut(&Film, &RenderStats) -> Control + Send,
    ) -> (Film, RenderStats) {
        let film = Film::new(self.width as usize, self.height as usize);
        self.resume(config, budget, film, Shard::ALL, on_iteration)
    }

    /// As [`Renderer::render`], continuing `film` (of this resolution) with the shard's next
    /// global iterations; `budget.iterations` counts the film's own.
    pub fn resume(
        &self,
        config: &MethodConfig,
        budget: Budget,
        film: Film,
        shard: Shard,
        on_iteration: impl FnMut(&Film, &RenderStats) -> Control + Send,
    ) -> (Film, RenderStats) {
        let ctx = self.context();
        let settings = RenderSettings { width: self.width as usize, height: self.height as usize, budget };
        // Prepared by the driver, which counts the pilot's time in the statistics (unless an
        // earlier call already ran the render's pilot).
        let mut integrator = config.integrator(self.scene.bounds().diagonal());
        if self.walker == Walker::Scalar {
            integrator = Box::new(RayByRay(integrator));
        }
        self.pool.install(|| render_from(&ctx, integrator.as_mut(), &settings, film, shard, on_iteration))
    }

    /// The parameters of `config` as a render of this scene uses them, as (key, value): the
    /// resolved ones with what the prepared integrator chose ([`MethodConfig::report`]).
    pub fn parameters(&self, config: &MethodConfig) -> Vec<(String, String)> {
        config.report(self.scene.bounds().diagonal(), self.integrator(config).measured())
    }

    /// The EXR metadata of a render of `config` with these statistics: pir's version, the
    /// scene, method and its parameters, path length, seed, sample count, resolution, time,
    /// accelerator, threads and dropped samples, and the method's description.
    pub fn attributes(&self, config: &MethodConfig, stats: &RenderStats) -> Vec<(String, String)> {
        let mut attrs: Vec<(String, String)> = vec![
            ("pir.version".into(), env!("CARGO_PKG_VERSION").into()),
            ("pir.scene".into(), self.scene.path().display().to_string()),
            (crate::study::independence::FINGERPRINT_KEY.into(), self.fingerprint.clone()),
            ("pir.method".into(), config.method.name().into()),
            ("pir.max_depth".into(), self.max_depth.to_string()),
            ("pir.seed".into(), self.seed.to_string()),
            ("pir.sampler".into(), self.sampler.name().into()),
            ("pir.iterations".into(), stats.iterations.to_string()),
            ("pir.spp".into(), stats.iterations.to_string()),
            ("pir.resolution".into(), format!("{} {}", self.width, self.height)),
            ("pir.render_time_s".into(), format!("{:.3}", stats.elapsed.as_secs_f64())),
            ("pir.accel".into(), self.accel_description.clone()),
            ("pir.threads".into(), self.threads().to_string()),
            ("pir.dropped_samples".into(), stats.dropped.to_string()),
        ];
        for (k, v) in self.parameters(config) {
            attrs.push((format!("pir.param.{k}"), v));
        }
        attrs.push(("pir.method.description".into(), latin1(config.method.description())));
        attrs
    }

    /// Writes the film's image to `out` (atomically) with `attributes`, resumable when `state`
    /// gives its job and shard, and the PNG preview at `preview` (path, exposure in stops).
    /// Returns the image.
    pub fn write(
        &self,
        out: &Path,
        film: &Film,
        attributes: &[(String, String)],
        state: Option<(&Job, Shard)>,
        preview: Option<(&Path, f32)>,
    ) -> Result<RgbImage> {
        let image = film.image();
        match state {
            Some((job, shard)) => write_state(out, &image, attributes, job, shard, film)?,
            None => write_exr(out, &image, attributes)?,
        }
        if let Some((path, exposure)) = preview {
            write_preview(path, &image, exposure)?;
        }
        Ok(image)
    }
}

/// `text` in the characters an EXR text attribute holds (Latin-1): Greek letters by name,
/// others by their nearest Latin-1 letter or '?'.
fn latin1(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            c if (c as u32) < 256 => out.push(c),
            'α' => out.push_str("alpha"),
            '−' | '–' | '—' => out.push('-'),
            'š' => out.push('s'),
            _ => out.push('?'),
        }
    }
    out
}

/// The pool of `threads` worker threads (none given: one per core) that renders trace rays on,
/// each with denormals flushed to zero, as Embree asks of every thread that traces rays (the
/// calling thread's too).
pub fn worker_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    set_flush_denormals();
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .start_handler(|_| set_flush_denormals())
        .build()
        .context("cannot start the worker threads")
}
