//! What every rendering command (`pir render`, `pir study`, `pir reference`) shares: the
//! scene options each of them takes, loading the scene with its emitters and worker pool, and
//! the checks made before any work.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use pir::accel::{Backend, set_flush_denormals};
use pir::light::Emitters;
use pir::scene::Scene;

/// Options every rendering command takes; each defaults to the scene file's value.
#[derive(Args, Debug)]
pub struct SceneOptions {
    /// Random seed [default: the scene's render.seed]. The same seed gives the same image for
    /// any number of threads.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads [default: all cores].
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
}

impl SceneOptions {
    /// The checks that need no scene.
    pub fn check(&self) -> Result<()> {
        if self.threads == Some(0) {
            bail!("--threads must be at least 1");
        }
        if self.max_depth == Some(0) {
            bail!("--max-depth must be at least 1");
        }
        Ok(())
    }

    pub fn seed(&self, scene: &Scene) -> u64 {
        self.seed.unwrap_or(scene.render.seed)
    }

    pub fn max_depth(&self, scene: &Scene) -> u32 {
        self.max_depth.unwrap_or(scene.render.max_depth)
    }

    /// The image size: --resolution, else the scene camera's.
    pub fn resolution(&self, scene: &Scene) -> (u32, u32) {
        match &self.resolution {
            Some(r) => (r[0], r[1]),
            None => (scene.camera.width, scene.camera.height),
        }
    }

    pub fn backend(&self) -> Backend {
        self.accel.unwrap_or_else(Backend::default_available)
    }
}

/// A loaded scene with its emitters and a worker pool (the accelerator borrows the scene, so
/// the caller builds it with `build_accelerator`).
pub struct Prepared {
    pub scene: Scene,
    pub emitters: Emitters,
    pub pool: rayon::ThreadPool,
}

/// Checks the options, loads the scene and starts the worker pool.
pub fn prepare(scene_path: &Path, options: &SceneOptions) -> Result<Prepared> {
    options.check()?;
    let scene = pir::scene::load(scene_path)?;
    let emitters = Emitters::new(&scene)
        .with_context(|| format!("{}: the scene has no emitter with positive power", scene_path.display()))?;
    // Embree asks for flush-to-zero on every thread that traces rays.
    set_flush_denormals();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads.unwrap_or(0))
        .start_handler(|_| set_flush_denormals())
        .build()
        .context("cannot start the worker threads")?;
    Ok(Prepared { scene, emitters, pool })
}

/// Fails now, not after the render, when the output file's folder is missing or not writable.
pub fn check_writable(out: &Path) -> Result<()> {
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!("{}: the output folder {} does not exist", out.display(), dir.display());
    }
    tempfile::Builder::new()
        .prefix(".pir-check-")
        .tempfile_in(dir)
        .with_context(|| format!("{}: cannot write in {}", out.display(), dir.display()))?;
    Ok(())
}

/// Parses a positive number of seconds.
pub fn seconds(name: &str, t: f64) -> Result<std::time::Duration> {
    if t.is_finite() && t > 0.0 && t < 1e9 {
        Ok(std::time::Duration::from_secs_f64(t))
    } else {
        bail!("{name} {t}: must be a positive number of seconds")
    }
}

/// A flag that Ctrl-C or SIGTERM sets: the commands finish the running iteration, write what
/// they have and exit 0. Installed once per process.
pub fn interrupt_flag() -> Result<Arc<AtomicBool>> {
    let flag = Arc::new(AtomicBool::new(false));
    let f = Arc::clone(&flag);
    ctrlc::set_handler(move || f.store(true, Ordering::SeqCst))
        .context("cannot install the interrupt handler")?;
    Ok(flag)
}

/// "scenes/cornell-box/scene.toml" → "cornell-box"; "foo.toml" → "foo".
pub fn scene_stem(scene: &Path) -> String {
    let stem = scene.file_stem().and_then(|s| s.to_str()).unwrap_or("scene");
    if stem == "scene" {
        scene.parent().and_then(|p| p.file_name()).and_then(|s| s.to_str()).unwrap_or(stem).to_string()
    } else {
        stem.to_string()
    }
}
