//! Scene, accelerator and thread-pool setup shared by `pir study` and `pir reference` (the
//! same steps as `pir render`).

use anyhow::{Context, Result, bail};
use std::path::Path;

use pir::accel::set_flush_denormals;
use pir::light::Emitters;
use pir::scene::Scene;

/// A loaded scene with its emitters and a worker pool (the accelerator borrows the scene, so
/// the caller builds it with `build_accelerator`).
pub struct Prepared {
    pub scene: Scene,
    pub emitters: Emitters,
    pub pool: rayon::ThreadPool,
}

pub fn prepare(scene_path: &Path, threads: Option<usize>) -> Result<Prepared> {
    if threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let scene = pir::scene::load(scene_path)?;
    let emitters = Emitters::new(&scene)
        .with_context(|| format!("{}: the scene has no emitter with positive power", scene_path.display()))?;
    // Embree asks for flush-to-zero on every thread that traces rays.
    set_flush_denormals();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .start_handler(|_| set_flush_denormals())
        .build()
        .context("cannot start the worker threads")?;
    Ok(Prepared { scene, emitters, pool })
}

/// Parses a positive number of seconds.
pub fn seconds(name: &str, t: f64) -> Result<std::time::Duration> {
    if t.is_finite() && t > 0.0 && t < 1e9 {
        Ok(std::time::Duration::from_secs_f64(t))
    } else {
        bail!("{name} {t}: must be a positive number of seconds")
    }
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
