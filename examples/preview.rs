//! A small PNG preview of a large EXR: the image box-averaged by a whole factor (in linear
//! light, as `pir study` downsamples references), then encoded like pir's own previews. The
//! conference room's `preview.png` (`docs/batch.md`) is made with it.
//!
//! Run: `cargo run --release --example preview -- IMAGE.exr OUT.png FACTOR [EXPOSURE]`,
//! e.g. `… -- merged.exr preview.png 4` for a 480×270 preview of a 1920×1080 render.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use pir::image::{read_exr, write_preview};

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("preview: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if !(3..=4).contains(&args.len()) {
        bail!("usage: preview IMAGE.exr OUT.png FACTOR [EXPOSURE]");
    }
    let factor: usize = args[2].parse().ok().filter(|f| *f >= 1).context("FACTOR: a whole number ≥ 1")?;
    let exposure: f32 = match args.get(3) {
        Some(e) => e.parse().ok().filter(|e: &f32| e.is_finite()).context("EXPOSURE: a number of stops")?,
        None => 0.0,
    };
    let (image, _) = read_exr(Path::new(&args[0]))?;
    let small = image.downsample(factor).with_context(|| {
        format!("{}: {}×{} is not divisible by {factor}", args[0], image.width, image.height)
    })?;
    write_preview(Path::new(&args[1]), &small, exposure)?;
    eprintln!("preview: wrote {} ({}×{})", args[1], small.width, small.height);
    Ok(())
}
