//! `pir reference SCENE --time SECONDS`: a long path-traced render to serve as the reference
//! of studies, for scenes without an external one. The EXR records its sample count
//! (`pir.spp`, `pir.iterations`) and render time. Without `--seed` it renders at a seed of its
//! own, so that it is independent of renders and studies at the scene's seed
//! ([`pir::study::independence`]).

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::Duration;

use pir::integrator::methods::Pt;
use pir::integrator::{Method, MethodConfig};
use pir::render::{Budget, Control, Renderer, SceneOptions};
use pir::study::independence::reference_seed;

use super::progress::{DEFAULT_LINE_INTERVAL, Progress};
use super::setup::{check_exr_output, interrupt_flag, scene_stem, seconds};

/// Render a reference image with the path tracer for a wall-clock budget.
///
/// Ctrl-C or SIGTERM stops after the running iteration and writes what was rendered. Without
/// --seed the reference takes a seed of its own (the scene's offset by a constant), so that a
/// study at the scene's seed does not share its random numbers.
#[derive(Args, Debug)]
pub struct ReferenceArgs {
    /// The scene file: pir's TOML, or a Mitsuba 3 scene (.xml).
    pub scene: PathBuf,
    /// Wall-clock budget in seconds.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub time: f64,
    /// Output EXR (a PNG preview is written beside it) [default: SCENE-reference.exr].
    #[arg(long, short, value_name = "FILE.exr")]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub options: SceneOptions,
}

pub fn run(a: ReferenceArgs) -> Result<()> {
    let budget = Budget { iterations: None, time: Some(seconds("--time", a.time)?) };
    a.options.check()?;
    let out =
        a.out.clone().unwrap_or_else(|| PathBuf::from(format!("{}-reference.exr", scene_stem(&a.scene))));
    check_exr_output(&out)?;

    let scene = a.options.load(&a.scene)?;
    let mut options = a.options.clone();
    options.seed.get_or_insert(reference_seed(scene.defaults().seed));
    let renderer = Renderer::new(&scene, &options)?;
    let (width, height) = renderer.resolution();
    eprintln!(
        "pir reference: {} at {width}×{height}, path tracer for {} s on {} threads",
        a.scene.display(),
        a.time,
        renderer.threads()
    );
    let interrupted = interrupt_flag()?;
    let mut progress = Progress::new(&budget, true, Duration::from_secs_f64(DEFAULT_LINE_INTERVAL));
    let config = MethodConfig::new(Method::new(&Pt));
    let (film, stats) = renderer.render(&config, budget, |_, stats| {
        progress.update(stats);
        if interrupted.load(Ordering::SeqCst) { Control::Stop } else { Control::Continue }
    });
    progress.finish();
    let mut attributes = renderer.attributes(&config, &stats);
    attributes.push(("pir.reference".into(), "true".into()));
    let preview = out.with_extension("png");
    renderer.write(&out, &film, &attributes, None, Some((&preview, 0.0)))?;
    eprintln!(
        "pir reference: {} spp in {:.2} s; wrote {} and {}",
        stats.iterations,
        stats.elapsed.as_secs_f64(),
        out.display(),
        preview.display()
    );
    Ok(())
}
