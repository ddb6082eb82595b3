//! `pir render SCENE`: render a scene to EXR (linear RGB) and a PNG preview.

use anyhow::{Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use pir::accel::{Backend, embree_status};
use pir::image::RgbImage;
use pir::integrator::MethodConfig;
use pir::integrator::many_light::config::{NEAR_SPECULAR_ALPHA, near_specular};
use pir::light::EmitterChoice;
use pir::render::memory;
use pir::render::state::{Job, Saved, Shard, read_state};
use pir::render::{Budget, Control, Film, RenderStats, Renderer, SceneOptions, check_resolution};
use pir::scene::Scene;

use super::progress::{DEFAULT_LINE_INTERVAL, Progress};
use super::setup::{check_exr_output, interrupt_flag, scene_stem, seconds};

/// Render a scene progressively and write an EXR and a PNG preview.
///
/// Each iteration adds one sample per pixel; the image is the mean over iterations. The
/// render stops after --spp iterations or after --time seconds, whichever comes first
/// (default: 64 spp).
#[derive(Args, Debug)]
#[command(after_long_help = pir::integrator::methods::parameters_help())]
pub struct RenderArgs {
    /// The scene file: pir's TOML (docs/scene-format.md) or a Mitsuba 3 scene (.xml, docs/mitsuba.md).
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
    /// When standard error is not a terminal (a batch job's log): print a progress line after
    /// the first iteration and then every SECONDS (iterations, elapsed, estimated time left)
    /// instead of the bar.
    #[arg(long, value_name = "SECONDS", default_value_t = DEFAULT_LINE_INTERVAL, allow_negative_numbers = true)]
    pub progress_every: f64,
    /// No progress bar or progress lines.
    #[arg(long, short)]
    pub quiet: bool,
}

/// What the arguments ask for, checked before any work.
struct Plan {
    budget: Budget,
    checkpoint: Option<Duration>,
    progress_every: Duration,
    out: PathBuf,
    preview: Option<PathBuf>,
    shard: Shard,
    /// Whether the output carries the state to resume it.
    resumable: bool,
}

pub fn run(a: RenderArgs) -> Result<()> {
    let plan = check_arguments(&a)?;
    let start = Instant::now();
    let scene = a.options.load(&a.scene)?;
    a.config.check_scene(&scene)?;
    let loaded = start.elapsed();
    let memory = check_memory(&a, &scene)?;
    let saved = a.resume.as_ref().map(|path| read_state(path)).transpose()?;
    // Resumed under `auto`: the choice the file made, not the pilot's again (which could
    // differ with another build of the accelerator).
    let mut options = a.options.clone();
    if let Some(saved) = &saved
        && matches!(options.emitter_choice, None | Some(EmitterChoice::Auto))
    {
        options.emitter_choice = Some(saved.job.emitter_choice);
    }
    let renderer = Renderer::new(&scene, &options)?;
    let job = renderer.job(&a.config);
    let film = starting_film(&a, saved, &renderer, &job, plan.shard)?;
    print_header(&a, &renderer, loaded, &memory);
    let (film, stats) = render(&a, &plan, &renderer, &job, film)?;
    let (image, attributes) = write_output(&a, &plan, &renderer, &job, &film, &stats)?;
    print_summary(&plan, &renderer, &stats, &image, &attributes);
    Ok(())
}

/// Checks every argument that needs no scene.
fn check_arguments(a: &RenderArgs) -> Result<Plan> {
    let budget = budget(a)?;
    a.options.check()?;
    if !a.exposure.is_finite() {
        bail!("--exposure must be a finite number");
    }
    a.config.validate()?;
    // Accepted, as `pir study` passes one set of flags to several methods, but said.
    for p in a.config.unused() {
        eprintln!("pir: warning: {} is not used by {}", p.flag(), a.config.method);
    }
    let checkpoint = a.checkpoint.map(|t| seconds("--checkpoint", t)).transpose()?;
    let progress_every = seconds("--progress-every", a.progress_every)?;
    let out =
        a.out.clone().or_else(|| a.resume.clone()).unwrap_or_else(|| {
            PathBuf::from(format!("{}-{}.exr", scene_stem(&a.scene), a.config.method.name()))
        });
    check_exr_output(&out)?;
    let shard = a.shard.unwrap_or(Shard::ALL);
    Ok(Plan {
        budget: Budget { iterations: budget.iterations.map(|n| shard.iterations_of(n)), ..budget },
        checkpoint,
        progress_every,
        preview: (!a.no_preview).then(|| out.with_extension("png")),
        out,
        shard,
        resumable: a.checkpoint.is_some() || a.resume.is_some() || a.shard.is_some(),
    })
}

fn budget(a: &RenderArgs) -> Result<Budget> {
    if a.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    let time = a.time.map(|t| seconds("--time", t)).transpose()?;
    let iterations = match (a.spp, time) {
        (None, None) => Some(64),
        (n, _) => n,
    };
    Ok(Budget { iterations, time })
}

/// Refuses, before anything large is allocated, a render that would need more memory than
/// --max-memory (default 80 % of the machine's); returns the estimate.
fn check_memory(a: &RenderArgs, scene: &Scene) -> Result<memory::Estimate> {
    let (width, height) = a.options.resolution(scene);
    check_resolution(width, height)?;
    let limit = match a.max_memory {
        Some(g) if g.is_finite() && g > 0.0 => Some((g * (1u64 << 30) as f64) as u64),
        Some(g) => bail!("--max-memory {g}: must be a positive number of GiB"),
        None => memory::total_memory().map(|m| m / 10 * 8),
    };
    let need = memory::Estimate::new(
        width as u64,
        height as u64,
        scene.indices().len() as u64,
        a.config.light_paths() as u64,
        a.options.max_depth(scene) as u64,
    );
    if let Some(limit) = limit
        && need.total() > limit
    {
        bail!(
            "this render would need about {need}, more than the limit of {:.2} GiB (--max-memory; by \
             default 80 % of this machine's memory)",
            limit as f64 / (1u64 << 30) as f64
        );
    }
    Ok(need)
}

/// The film the render starts from: a resumed one (of the same job and shard) or an empty one.
fn starting_film(
    a: &RenderArgs,
    saved: Option<Saved>,
    renderer: &Renderer,
    job: &Job,
    shard: Shard,
) -> Result<Film> {
    let (Some(path), Some(saved)) = (&a.resume, saved) else {
        let (w, h) = renderer.resolution();
        return Ok(Film::new(w as usize, h as usize));
    };
    let mut differences = job.differences(&saved.job);
    if saved.shard != shard {
        differences.push(format!("shard: {shard} here, {} in the file", saved.shard));
    }
    if !differences.is_empty() {
        bail!("{}: cannot resume a different render: {}", path.display(), differences.join("; "));
    }
    eprintln!("pir: resuming {} at iteration {}", path.display(), saved.film.iterations());
    Ok(saved.film)
}

fn print_header(a: &RenderArgs, renderer: &Renderer, loaded: Duration, memory: &memory::Estimate) {
    let scene = renderer.scene();
    let (width, height) = renderer.resolution();
    eprintln!(
        "pir: {} ({} triangles, {} emitting), {}×{}, method {}, max_depth {}, seed {}, {} threads",
        a.scene.display(),
        scene.indices().len(),
        renderer.emitters().len(),
        width,
        height,
        a.config.method.name(),
        renderer.max_depth(),
        renderer.seed(),
        renderer.threads()
    );
    if scene.degenerate_dropped() > 0 {
        eprintln!(
            "pir: warning: {} zero-area triangles were dropped (common in scanned meshes)",
            scene.degenerate_dropped()
        );
    }
    eprintln!("pir: scene read in {:.2} s", loaded.as_secs_f64());
    let pilot = renderer.emitter_verdict().map(|v| {
        format!("; the pilot found importance {:.2}x as efficient as power at {} points", v.gain, v.points)
    });
    if let Some(entries) = renderer.emitters().spatial_entries() {
        let triangles = renderer.emitters().len();
        let clusters = if entries < triangles { format!(" (in {entries} clusters)") } else { String::new() };
        eprintln!(
            "pir: next-event estimation picks among the {triangles} emitting triangles{clusters} by their importance at the receiver{} (--emitter-choice, docs/cli.md)",
            pilot.unwrap_or_default()
        );
    } else if let Some(pilot) = pilot {
        eprintln!(
            "pir: next-event estimation picks the emitting triangles by power{pilot} (--emitter-choice, docs/cli.md)"
        );
    }
    eprintln!("pir: accelerator {}, {} walker", renderer.accel_description(), renderer.walker());
    eprintln!("pir: estimated peak memory {memory} (see --max-memory)");
    if !Backend::Embree.is_available() {
        eprintln!("pir: {}", embree_status());
    }
}

/// Writes the EXR (resumable when asked) and the preview; at checkpoints, on interruption and
/// at the end. Returns the image and the EXR's attributes.
fn write_output(
    a: &RenderArgs,
    plan: &Plan,
    renderer: &Renderer,
    job: &Job,
    film: &Film,
    stats: &RenderStats,
) -> Result<(RgbImage, Vec<(String, String)>)> {
    let attributes = renderer.attributes(&a.config, stats);
    let state = plan.resumable.then_some((job, plan.shard));
    let preview = plan.preview.as_deref().map(|p: &Path| (p, a.exposure));
    let image = renderer.write(&plan.out, film, &attributes, state, preview)?;
    Ok((image, attributes))
}

/// Renders with a progress bar and checkpoints. Ctrl-C or SIGTERM finishes the running
/// iteration and returns what was rendered (the caller writes it and exits 0).
fn render(
    a: &RenderArgs,
    plan: &Plan,
    renderer: &Renderer,
    job: &Job,
    film: Film,
) -> Result<(Film, RenderStats)> {
    let interrupted = interrupt_flag()?;
    let mut progress = Progress::new(&plan.budget, !a.quiet, plan.progress_every);
    let mut last_checkpoint = Instant::now();
    let mut checkpoint_error = None;
    let (film, stats) = renderer.resume(&a.config, plan.budget, film, plan.shard, |film, stats| {
        progress.update(stats);
        if interrupted.load(Ordering::SeqCst) {
            return Control::Stop;
        }
        if plan.checkpoint.is_some_and(|c| last_checkpoint.elapsed() >= c) {
            if let Err(e) = write_output(a, plan, renderer, job, film, stats) {
                checkpoint_error = Some(e);
                return Control::Stop;
            }
            last_checkpoint = Instant::now();
        }
        Control::Continue
    });
    progress.finish();
    if let Some(e) = checkpoint_error {
        return Err(e.context("writing a checkpoint failed"));
    }
    if interrupted.load(Ordering::SeqCst) {
        eprintln!("pir: interrupted: writing the {} iterations rendered so far", stats.iterations);
    }
    Ok((film, stats))
}

fn print_summary(
    plan: &Plan,
    renderer: &Renderer,
    stats: &RenderStats,
    image: &RgbImage,
    attributes: &[(String, String)],
) {
    let secs = stats.elapsed.as_secs_f64();
    let (width, height) = renderer.resolution();
    let pixels = (width as u64 * height as u64) as f64;
    let c = &stats.counters;
    let pilot = if c.pilot_rays > 0 { format!(", {} pilot", c.pilot_rays) } else { String::new() };
    eprintln!(
        "pir: {} iterations ({} spp in the image) in {:.2} s ({:.2} s pixels, {:.2} s preparation): {:.2} Msamples/s, {:.2} Mrays/s ({} closest-hit, {} shadow{pilot})",
        stats.rendered,
        stats.iterations,
        secs,
        stats.pixel_time.as_secs_f64(),
        stats.prepare_time.as_secs_f64(),
        pixels * stats.rendered as f64 / secs.max(1e-9) / 1e6,
        stats.rays_per_second() / 1e6,
        c.rays,
        c.shadow_rays
    );
    let mean = image.mean();
    eprintln!("pir: image mean RGB {:.5} {:.5} {:.5}", mean[0], mean[1], mean[2]);
    if stats.counters.light_paths > 0 {
        let per_iteration = |n: u64| n as f64 / stats.rendered.max(1) as f64;
        eprintln!(
            "pir: {:.0} VPLs per iteration from {:.0} light paths; light tracing {:.2} s, gathering {:.2} s at {:.2} M shadow rays/s",
            per_iteration(stats.counters.vpls),
            per_iteration(stats.counters.light_paths),
            stats.prepare_time.as_secs_f64(),
            stats.pixel_time.as_secs_f64(),
            stats.shadow_rays_per_second() / 1e6
        );
        if stats.counters.photons > 0 {
            eprintln!(
                "pir: {:.1} photons per iteration (caustics, merged where the camera sees them through a mirror or glass)",
                per_iteration(stats.counters.photons)
            );
        }
    }
    // What a method chose by the scene's pilot (`pir-bdpt`'s light samples), read from the
    // EXR's attributes, so that a user sees it without opening them.
    let param = |key: &str| {
        attributes.iter().find(|(k, _)| k.strip_prefix("pir.param.") == Some(key)).map(|(_, v)| v.clone())
    };
    if let (Some(n), Some(v)) = (param("light-samples"), param("emitter-visibility")) {
        let percent = v.parse::<f64>().map_or(v.clone(), |v| format!("{:.0} %", 100.0 * v));
        eprintln!(
            "pir: {n} light samples at the first vertex; the emitters are in view of {percent} of the light samples from the points they light"
        );
    }
    if let (Some(c), Some(v)) = (param("connect"), param("lit-share")) {
        let percent = v.parse::<f64>().map_or(v.clone(), |v| format!("{:.0} %", 100.0 * v));
        eprintln!(
            "pir: --connect {c}: the emitters light {percent} of the points the camera sees (glossy below 50 %)"
        );
    }
    // (`pir-bdpt` reports its rule of connections; the materials it connects nowhere.)
    if param("connect").is_some() {
        let near: Vec<&str> = renderer
            .scene()
            .materials()
            .iter()
            .filter(|m| near_specular(&m.mean_bsdf()))
            .map(|m| m.name.as_str())
            .collect();
        if !near.is_empty() {
            eprintln!(
                "pir: near-specular materials (every lobe a microfacet of α ≤ {NEAR_SPECULAR_ALPHA}), where no connection is made and no VPL left: {}",
                near.join(", ")
            );
        }
    }
    if let Some(v) = param("vpl-acceptance") {
        let percent = v.parse::<f64>().map_or(v.clone(), |v| format!("{:.0} %", 100.0 * v));
        let below = 100.0 * pir::integrator::many_light::importance::WORTH_IT;
        eprintln!(
            "pir: VPLs kept by their share of the image: the pilot's light paths would keep {percent} of theirs (more light paths below {below:.0} %)"
        );
    }
    if stats.dropped > 0 {
        let (x, y, it) = stats.first_dropped.unwrap_or_default();
        eprintln!(
            "pir: warning: {} samples were NaN or infinite and were dropped (first at pixel ({x}, {y}), iteration {it})",
            stats.dropped
        );
    }
    match &plan.preview {
        Some(p) => eprintln!("pir: wrote {} and {}", plan.out.display(), p.display()),
        None => eprintln!("pir: wrote {}", plan.out.display()),
    }
}
