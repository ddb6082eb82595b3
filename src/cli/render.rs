//! `pir render SCENE`: render a scene to EXR (linear RGB) and a PNG preview.

use anyhow::{Result, bail};
use clap::Args;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use pir::accel::{Backend, build_accelerator, embree_status};
use pir::image::{RgbImage, write_exr, write_preview};
use pir::integrator::{MethodConfig, RenderContext};
use pir::render::memory;
use pir::render::state::{Job, Shard, read_state, write_state};
use pir::render::{Budget, Control, Film, RenderSettings, RenderStats, render_from};

use super::setup::{Prepared, SceneOptions, check_writable, interrupt_flag, prepare, scene_stem};

/// Largest accepted image side, and pixel count (refused before anything is allocated).
const MAX_SIDE: u32 = 65_536;
const MAX_PIXELS: u64 = 1 << 28;

/// Render a scene progressively and write an EXR and a PNG preview.
///
/// Each iteration adds one sample per pixel; the image is the mean over iterations. The
/// render stops after --spp iterations or after --time seconds, whichever comes first
/// (default: 64 spp).
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The scene file (TOML, see the README's scene format).
    pub scene: PathBuf,
    #[command(flatten)]
    pub config: MethodConfig,
    /// Samples per pixel (= iterations; one sample per pixel per iteration).
    #[arg(long, visible_alias = "iterations", value_name = "N")]
    pub spp: Option<u64>,
    /// Wall-clock budget in seconds (at least one iteration is always rendered).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Output EXR; the PNG preview is written beside it [default: SCENE-METHOD.exr in the
    /// current directory].
    #[arg(long, short, value_name = "FILE.exr")]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub options: SceneOptions,
    /// Exposure of the PNG preview in stops (the EXR is never scaled).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Do not write the PNG preview.
    #[arg(long)]
    pub no_preview: bool,
    /// Write the image (with the state needed to resume it) every SECONDS, atomically, so that
    /// a killed render loses at most one interval. Makes the output resumable.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub checkpoint: Option<f64>,
    /// Continue a resumable render (written with --checkpoint, --shard or --resume) with the
    /// same random numbers, up to --spp iterations in all or for --time seconds; the scene and
    /// every parameter must be the same. Writes back to FILE.exr unless --out is given.
    #[arg(long, value_name = "FILE.exr")]
    pub resume: Option<PathBuf>,
    /// Render only shard K of N: global iterations K+1, K+1+N, … of --spp in all (merge the
    /// shards with `pir merge`). Makes the output resumable.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
    /// Refuse a render whose estimated memory exceeds this many GiB [default: 80 % of this
    /// machine's memory].
    #[arg(long, value_name = "GIB", allow_negative_numbers = true)]
    pub max_memory: Option<f64>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

pub fn run(a: RenderArgs) -> Result<()> {
    // ---- Check every argument before any work.
    let budget = budget(&a)?;
    a.options.check()?;
    if !a.exposure.is_finite() {
        bail!("--exposure must be a finite number");
    }
    a.config.validate()?;
    let checkpoint = match a.checkpoint {
        None => None,
        Some(t) if t.is_finite() && t > 0.0 && t < 1e9 => Some(Duration::from_secs_f64(t)),
        Some(t) => bail!("--checkpoint {t}: must be a positive number of seconds"),
    };
    let out =
        a.out.clone().or_else(|| a.resume.clone()).unwrap_or_else(|| {
            PathBuf::from(format!("{}-{}.exr", scene_stem(&a.scene), a.config.method.name()))
        });
    if out.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()) != Some("exr".into()) {
        bail!("{}: the output must be an .exr file", out.display());
    }
    check_writable(&out)?;

    let Prepared { scene, emitters, pool } = prepare(&a.scene, &a.options)?;
    let (width, height) = a.options.resolution(&scene);
    check_resolution(width, height)?;
    let max_depth = a.options.max_depth(&scene);
    check_memory(&a, width, height, scene.indices.len(), max_depth)?;
    let seed = a.options.seed(&scene);
    let backend = a.options.backend();
    let accel = build_accelerator(backend, &scene.positions, &scene.indices).map_err(anyhow::Error::msg)?;

    let mut integrator = a.config.integrator(scene.bounds.diagonal());
    let ctx = RenderContext { scene: &scene, accel: accel.as_ref(), emitters: &emitters, max_depth, seed };
    let (w, h) = (width as usize, height as usize);

    // ---- What this render is, and where it starts (a resumed film or an empty one).
    let shard = a.shard.unwrap_or(Shard::ALL);
    let job = Job::new(&scene, &a.config, max_depth, seed, w, h);
    let film = match &a.resume {
        None => Film::new(w, h),
        Some(path) => {
            let saved = read_state(path)?;
            let mut differences = job.differences(&saved.job);
            if saved.shard != shard {
                differences.push(format!("shard: {shard} here, {} in the file", saved.shard));
            }
            if !differences.is_empty() {
                bail!("{}: cannot resume a different render: {}", path.display(), differences.join("; "));
            }
            eprintln!("pir: resuming {} at iteration {}", path.display(), saved.film.iterations());
            saved.film
        }
    };
    let resumable =
        (checkpoint.is_some() || a.resume.is_some() || a.shard.is_some()).then_some((&job, shard));
    let budget = Budget { iterations: budget.iterations.map(|n| shard.iterations_of(n)), ..budget };
    let settings = RenderSettings { width: w, height: h, budget, tile_size: 16, progress: !a.quiet };
    eprintln!(
        "pir: {} ({} triangles, {} emitting), {}×{}, method {}, max_depth {}, seed {}, {} threads",
        a.scene.display(),
        scene.indices.len(),
        emitters.len(),
        width,
        height,
        integrator.name(),
        max_depth,
        seed,
        pool.current_num_threads()
    );
    if scene.degenerate_dropped > 0 {
        eprintln!(
            "pir: warning: {} zero-area triangles were dropped (common in scanned meshes)",
            scene.degenerate_dropped
        );
    }
    eprintln!("pir: accelerator {}", accel.describe());
    if !Backend::Embree.is_available() {
        eprintln!("pir: {}", embree_status());
    }

    // ---- Output, written at checkpoints, on interruption and at the end.
    let preview = (!a.no_preview).then(|| out.with_extension("png"));
    let parameters = integrator.parameters();
    let method_name = integrator.name();
    let describe = accel.describe();
    let threads = pool.current_num_threads();
    let write = |film: &Film, stats: &RenderStats| -> Result<RgbImage> {
        let image = film.image();
        let mut attrs: Vec<(String, String)> = vec![
            ("pir.version".into(), env!("CARGO_PKG_VERSION").into()),
            ("pir.scene".into(), a.scene.display().to_string()),
            ("pir.method".into(), method_name.into()),
            ("pir.max_depth".into(), max_depth.to_string()),
            ("pir.seed".into(), seed.to_string()),
            ("pir.iterations".into(), film.iterations().to_string()),
            ("pir.spp".into(), film.iterations().to_string()),
            ("pir.resolution".into(), format!("{width} {height}")),
            ("pir.render_time_s".into(), format!("{:.3}", stats.elapsed.as_secs_f64())),
            ("pir.accel".into(), describe.clone()),
            ("pir.threads".into(), threads.to_string()),
            ("pir.dropped_samples".into(), stats.dropped.to_string()),
        ];
        for (k, v) in &parameters {
            attrs.push((format!("pir.param.{k}"), v.clone()));
        }
        match resumable {
            Some((job, shard)) => write_state(&out, &image, &attrs, job, shard, film)?,
            None => write_exr(&out, &image, &attrs)?,
        }
        if let Some(p) = &preview {
            write_preview(p, &image, a.exposure)?;
        }
        Ok(image)
    };

    // Ctrl-C or SIGTERM: finish the running iteration, write the image, exit 0.
    let interrupted = interrupt_flag()?;
    let mut last_checkpoint = Instant::now();
    let mut checkpoint_error = None;
    let (film, stats) = pool.install(|| {
        render_from(&ctx, integrator.as_mut(), &settings, film, shard, |film, stats| {
            if interrupted.load(Ordering::SeqCst) {
                return Control::Stop;
            }
            if checkpoint.is_some_and(|c| last_checkpoint.elapsed() >= c) {
                if let Err(e) = write(film, stats) {
                    checkpoint_error = Some(e);
                    return Control::Stop;
                }
                last_checkpoint = Instant::now();
            }
            Control::Continue
        })
    });
    if let Some(e) = checkpoint_error {
        return Err(e.context("writing a checkpoint failed"));
    }
    if interrupted.load(Ordering::SeqCst) {
        eprintln!("pir: interrupted: writing the {} iterations rendered so far", stats.iterations);
    }
    let image = write(&film, &stats)?;

    // ---- Summary.
    let secs = stats.elapsed.as_secs_f64();
    let pixels = (width as u64 * height as u64) as f64;
    eprintln!(
        "pir: {} iterations ({} spp in the image) in {:.2} s ({:.2} s pixels, {:.2} s preparation): {:.2} Msamples/s, {:.2} Mrays/s ({} closest-hit, {} shadow)",
        stats.rendered,
        stats.iterations,
        secs,
        stats.pixel_time.as_secs_f64(),
        stats.prepare_time.as_secs_f64(),
        pixels * stats.rendered as f64 / secs.max(1e-9) / 1e6,
        stats.rays_per_second() / 1e6,
        stats.counters.rays,
        stats.counters.shadow_rays
    );
    let mean = image.mean();
    eprintln!("pir: image mean RGB {:.5} {:.5} {:.5}", mean[0], mean[1], mean[2]);
    if stats.counters.vpls > 0 {
        eprintln!(
            "pir: {:.0} VPLs per iteration; light tracing {:.2} s, gathering {:.2} s at {:.2} M shadow rays/s",
            stats.counters.vpls as f64 / stats.rendered.max(1) as f64,
            stats.prepare_time.as_secs_f64(),
            stats.pixel_time.as_secs_f64(),
            stats.shadow_rays_per_second() / 1e6
        );
    }
    if stats.dropped > 0 {
        let (x, y, it) = stats.first_dropped.unwrap_or_default();
        eprintln!(
            "pir: warning: {} samples were NaN or infinite and were dropped (first at pixel ({x}, {y}), iteration {it})",
            stats.dropped
        );
    }
    match &preview {
        Some(p) => eprintln!("pir: wrote {} and {}", out.display(), p.display()),
        None => eprintln!("pir: wrote {}", out.display()),
    }
    Ok(())
}

fn budget(a: &RenderArgs) -> Result<Budget> {
    if a.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    let time = match a.time {
        None => None,
        Some(t) if t.is_finite() && t > 0.0 && t < 1e9 => Some(Duration::from_secs_f64(t)),
        Some(t) => bail!("--time {t}: must be a positive number of seconds"),
    };
    let iterations = match (a.spp, time) {
        (None, None) => Some(64),
        (n, _) => n,
    };
    Ok(Budget { iterations, time })
}

/// Refuses, before anything large is allocated, a render that would need more memory than
/// --max-memory (default 80 % of the machine's).
fn check_memory(a: &RenderArgs, width: u32, height: u32, triangles: usize, max_depth: u32) -> Result<()> {
    let limit = match a.max_memory {
        Some(g) if g.is_finite() && g > 0.0 => Some((g * (1u64 << 30) as f64) as u64),
        Some(g) => bail!("--max-memory {g}: must be a positive number of GiB"),
        None => memory::total_memory().map(|m| m / 10 * 8),
    };
    let paths = a.config.light_paths() as u64;
    let need = memory::Estimate::new(width as u64, height as u64, triangles as u64, paths, max_depth as u64);
    if let Some(limit) = limit
        && need.total() > limit
    {
        bail!(
            "this render would need about {need}, more than the limit of {:.2} GiB (--max-memory; by \
             default 80 % of this machine's memory)",
            limit as f64 / (1u64 << 30) as f64
        );
    }
    Ok(())
}

fn check_resolution(w: u32, h: u32) -> Result<()> {
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE || w as u64 * h as u64 > MAX_PIXELS {
        bail!(
            "resolution {w}×{h}: each side must be 1 to {MAX_SIDE} and the total at most {MAX_PIXELS} pixels"
        );
    }
    Ok(())
}
