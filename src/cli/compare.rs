//! `pir compare IMAGE REFERENCE`: error metrics of a render against a reference.

use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;

use pir::image::{error_map, metrics, read_exr, write_png};

/// Compare an EXR image with a reference EXR.
///
/// Prints RMSE, relative MSE (mean over pixels and channels of (x − r)² / (r² + 0.01)), the
/// largest per-pixel relative squared error and the per-channel means of both images with
/// their relative difference.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The image to judge (EXR).
    pub image: PathBuf,
    /// The reference image (EXR), e.g. a long path-traced render.
    pub reference: PathBuf,
    /// Also write a false-colour map of the per-pixel relative squared error (PNG; log scale
    /// from 1e-5, black, to 1, white).
    #[arg(long, value_name = "FILE.png")]
    pub error_map: Option<PathBuf>,
}

pub fn run(a: CompareArgs) -> Result<()> {
    let (img, _) = read_exr(&a.image)?;
    let (reference, _) = read_exr(&a.reference)?;
    // A reference a whole factor larger is box-downsampled to the image's size, as `pir study`
    // takes it.
    let reference = super::setup::at_resolution(reference, (img.width, img.height), &a.reference)
        .with_context(|| format!("cannot compare {} with {}", a.image.display(), a.reference.display()))?;
    let m = metrics(&img, &reference)
        .with_context(|| format!("cannot compare {} with {}", a.image.display(), a.reference.display()))?;
    let d = m.mean_rel_diff();
    println!("image      {}", a.image.display());
    println!("reference  {}", a.reference.display());
    println!("RMSE          {:.6e}", m.rmse);
    println!("relative MSE  {:.6e}", m.rel_mse);
    println!("max pixel relative SE  {:.6e}", m.max_rel_se);
    println!("mean R G B    image {:.6} {:.6} {:.6}", m.mean[0], m.mean[1], m.mean[2]);
    println!(
        "              ref   {:.6} {:.6} {:.6}",
        m.reference_mean[0], m.reference_mean[1], m.reference_mean[2]
    );
    println!("              diff  {:+.3}% {:+.3}% {:+.3}%", 100.0 * d[0], 100.0 * d[1], 100.0 * d[2]);
    if let Some(path) = &a.error_map {
        write_png(path, img.width, img.height, &error_map(&img, &reference, -5.0, 0.0))?;
        println!("error map     {}", path.display());
    }
    Ok(())
}
