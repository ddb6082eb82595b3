//! What the rendering commands (`pir render`, `pir study`, `pir reference`; `pir convert` the
//! output check) share besides the
//! [`pir::render::Renderer`] and its options: the checks of their output, the seconds
//! parser, the interrupt flag and the default output names.

use anyhow::{Context, Result, bail};
use pir::image::RgbImage;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Fails now, not after the render, when `out` is not an `.exr` file or cannot be written.
pub fn check_exr_output(out: &Path) -> Result<()> {
    if out.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).as_deref() != Some("exr") {
        bail!("{}: the output must be an .exr file", out.display());
    }
    check_writable(out)
}

/// Fails now, not after the render (or the scene's conversion), when the output file's folder
/// is missing or not writable.
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

/// The reference at the size asked for: itself, or box-downsampled by a whole factor, which is
/// exactly the reference at that size (pixels are one-pixel box filters), so a high-resolution
/// reference serves quick studies too.
pub fn at_resolution(reference: RgbImage, (w, h): (usize, usize), path: &Path) -> Result<RgbImage> {
    if (w, h) == (reference.width, reference.height) {
        return Ok(reference);
    }
    let factor = reference.width / w.max(1);
    if factor >= 1
        && factor * w == reference.width
        && factor * h == reference.height
        && let Some(small) = reference.downsample(factor)
    {
        return Ok(small);
    }
    bail!(
        "{w}×{h} differs from the reference {} ({}×{}) by no whole factor: metrics need equal sizes",
        path.display(),
        reference.width,
        reference.height
    )
}
