//! `pir reference SCENE --time SECONDS`: a long path-traced render to serve as the reference
//! of studies, for scenes without an external one. The EXR records its sample count
//! (`pir.spp`, `pir.iterations`) and render time.

use anyhow::{Result, bail};
use clap::Args;
use std::path::PathBuf;
use std::sync::atomic::Ordering;

use pir::accel::build_accelerator;
use pir::image::{write_exr, write_preview};
use pir::integrator::{Integrator, PathTracer, RenderContext};
use pir::render::{Budget, Control, RenderSettings, render};

use super::setup::{SceneOptions, check_writable, interrupt_flag, prepare, scene_stem, seconds};

/// Render a reference image with the path tracer for a wall-clock budget.
///
/// Ctrl-C or SIGTERM stops after the running iteration and writes what was rendered.
#[derive(Args, Debug)]
pub struct ReferenceArgs {
    /// The scene file (TOML).
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
    let budget = seconds("--time", a.time)?;
    a.options.check()?;
    if let Some(r) = &a.options.resolution
        && (r[0] == 0 || r[1] == 0 || r[0] > 65_536 || r[1] > 65_536)
    {
        bail!("--resolution {}×{}: each side must be 1 to 65536", r[0], r[1]);
    }
    let out =
        a.out.clone().unwrap_or_else(|| PathBuf::from(format!("{}-reference.exr", scene_stem(&a.scene))));
    if out.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).as_deref() != Some("exr") {
        bail!("{}: the output must be an .exr file", out.display());
    }
    check_writable(&out)?;

    let p = prepare(&a.scene, &a.options)?;
    let accel = build_accelerator(a.options.backend(), &p.scene.positions, &p.scene.indices)
        .map_err(anyhow::Error::msg)?;
    let (width, height) = a.options.resolution(&p.scene);
    let max_depth = a.options.max_depth(&p.scene);
    let seed = a.options.seed(&p.scene);
    let ctx =
        RenderContext { scene: &p.scene, accel: accel.as_ref(), emitters: &p.emitters, max_depth, seed };
    let settings = RenderSettings {
        width: width as usize,
        height: height as usize,
        budget: Budget { iterations: None, time: Some(budget) },
        tile_size: 16,
        progress: true,
    };
    eprintln!(
        "pir reference: {} at {width}×{height}, path tracer for {} s on {} threads",
        a.scene.display(),
        a.time,
        p.pool.current_num_threads()
    );
    let interrupted = interrupt_flag()?;
    let mut pt = PathTracer;
    let (film, stats) = p.pool.install(|| {
        render(&ctx, &mut pt, &settings, |_, _| {
            if interrupted.load(Ordering::SeqCst) { Control::Stop } else { Control::Continue }
        })
    });
    let image = film.image();
    let attrs: Vec<(String, String)> = vec![
        ("pir.version".into(), env!("CARGO_PKG_VERSION").into()),
        ("pir.scene".into(), a.scene.display().to_string()),
        ("pir.method".into(), pt.name().into()),
        ("pir.reference".into(), "true".into()),
        ("pir.max_depth".into(), max_depth.to_string()),
        ("pir.seed".into(), seed.to_string()),
        ("pir.iterations".into(), stats.iterations.to_string()),
        ("pir.spp".into(), stats.iterations.to_string()),
        ("pir.resolution".into(), format!("{width} {height}")),
        ("pir.render_time_s".into(), format!("{:.3}", stats.elapsed.as_secs_f64())),
        ("pir.accel".into(), accel.describe()),
        ("pir.threads".into(), p.pool.current_num_threads().to_string()),
        ("pir.dropped_samples".into(), stats.dropped.to_string()),
    ];
    write_exr(&out, &image, &attrs)?;
    write_preview(&out.with_extension("png"), &image, 0.0)?;
    eprintln!(
        "pir reference: {} spp in {:.2} s; wrote {} and {}",
        stats.iterations,
        stats.elapsed.as_secs_f64(),
        out.display(),
        out.with_extension("png").display()
    );
    Ok(())
}
