//! The options every rendering command takes (`--seed`, `--threads`, `--max-depth`,
//! `--resolution`, `--accel`, `--sampler`, `--walker`), each defaulting to the scene file's value, and the resolution
//! limit.

use anyhow::{Result, bail};
use clap::Args;

use crate::accel::Backend;
use crate::integrator::Walker;
use crate::light::EmitterChoice;
use crate::sampling::SamplerKind;
use crate::scene::Scene;

/// Largest accepted image side, and pixel count (refused before anything is allocated).
pub const MAX_SIDE: u32 = 65_536;
pub const MAX_PIXELS: u64 = 1 << 28;

/// Options every rendering command takes; each defaults to the scene file's value.
#[derive(Args, Clone, Debug, Default)]
pub struct SceneOptions {
    /// Random seed [default: the scene's render.seed]. The same seed gives the same image for
    /// any number of threads.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads, for the render and for the BVH's build (Embree builds on its own
    /// threads, one per core) [default: all cores].
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Largest number of path segments from the camera to an emitter [default: the scene's
    /// render.max_depth]; 1 = emitters only, 2 = direct light, 3 = one bounce, …
    #[arg(long, value_name = "D")]
    pub max_depth: Option<u32>,
    /// Image size in pixels [default: the scene's camera.resolution; for `pir study`, the
    /// reference's, or the reference's divided by a whole factor, which box-downsamples it].
    #[arg(long, num_args = 2, value_names = ["W", "H"])]
    pub resolution: Option<Vec<u32>>,
    /// Ray-query backend: embree (Intel Embree, when pir was built with it), bvh (pir's own
    /// BVH) or brute (every triangle; tests only) [default: embree if built in, else bvh].
    #[arg(long, value_name = "BACKEND")]
    pub accel: Option<Backend>,
    /// How samples are drawn: sobol (each pixel's samples over the iterations, and each
    /// iteration's light paths, stratified by shuffled, randomly shifted Sobol points) or independent
    /// (independent uniform numbers, as pir drew them before) [default: sobol].
    #[arg(long, value_name = "SAMPLER")]
    pub sampler: Option<SamplerKind>,
    /// A Mitsuba scene's parameter: NAME=VALUE overrides its `<default name="NAME">` (and
    /// every `$NAME`), as Mitsuba's `-D`. Repeatable.
    #[arg(short = 'D', long = "define", value_name = "NAME=VALUE", value_parser = parse_define)]
    pub defines: Vec<(String, String)>,
    /// How camera paths are traced: batched (every method: a tile's paths bounce by bounce
    /// together, each bounce's rays and light samples' shadow rays in Embree packets) or
    /// scalar (one path at a time, the reference); the same image either way [default:
    /// batched].
    #[arg(long, value_name = "WALKER")]
    pub walker: Option<Walker>,
    /// How next-event estimation picks an emitting triangle: importance (by a bound on the
    /// light it can send to the receiver, mixed with its power, where the scene's emitters
    /// are three triangles or more and no other lights), power (by power alone, as the light
    /// paths start), or auto (importance where a pilot before the render finds it more
    /// efficient, else power; see docs/cli.md) [default: auto].
    #[arg(long, value_name = "CHOICE")]
    pub emitter_choice: Option<EmitterChoice>,
}

/// `NAME=VALUE` of `-D`.
fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((name, value))
            if !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') =>
        {
            Ok((name.to_string(), value.to_string()))
        }
        _ => Err(format!("{s:?}: expected NAME=VALUE (NAME of letters, digits and _)")),
    }
}

impl SceneOptions {
    /// Loads the scene file `path` with these options' Mitsuba parameters, printing the
    /// loader's warnings.
    pub fn load(&self, path: &std::path::Path) -> Result<Scene> {
        let options = crate::scene::mitsuba::Options { defines: self.defines.clone() };
        // The meshes of a Mitsuba scene are read in parallel: on --threads threads.
        let load = || crate::scene::load_with(path, &options);
        let (scene, warnings) = match self.threads {
            Some(n) => rayon::ThreadPoolBuilder::new().num_threads(n).build()?.install(load)?,
            None => load()?,
        };
        for w in warnings {
            eprintln!("pir: warning: {w}");
        }
        Ok(scene)
    }

    /// The checks that need no scene.
    pub fn check(&self) -> Result<()> {
        if self.threads == Some(0) {
            bail!("--threads must be at least 1");
        }
        if self.max_depth == Some(0) {
            bail!("--max-depth must be at least 1");
        }
        if let Some(r) = &self.resolution {
            check_resolution(r[0], r[1])?;
        }
        Ok(())
    }

    pub fn seed(&self, scene: &Scene) -> u64 {
        self.seed.unwrap_or(scene.defaults().seed)
    }

    pub fn max_depth(&self, scene: &Scene) -> u32 {
        self.max_depth.unwrap_or(scene.defaults().max_depth)
    }

    /// The image size: --resolution, else the scene camera's.
    pub fn resolution(&self, scene: &Scene) -> (u32, u32) {
        match &self.resolution {
            Some(r) => (r[0], r[1]),
            None => (scene.camera().width, scene.camera().height),
        }
    }

    pub fn sampler(&self) -> SamplerKind {
        self.sampler.unwrap_or_default()
    }

    pub fn walker(&self) -> Walker {
        self.walker.unwrap_or_default()
    }

    pub fn emitter_choice(&self) -> EmitterChoice {
        self.emitter_choice.unwrap_or_default()
    }

    pub fn backend(&self) -> Backend {
        self.accel.unwrap_or_else(Backend::default_available)
    }
}

/// Refuses an image with a side of 0 or above [`MAX_SIDE`], or more than [`MAX_PIXELS`].
pub fn check_resolution(w: u32, h: u32) -> Result<()> {
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE || w as u64 * h as u64 > MAX_PIXELS {
        bail!(
            "resolution {w}×{h}: each side must be 1 to {MAX_SIDE} and the total at most {MAX_PIXELS} pixels"
        );
    }
    Ok(())
}
