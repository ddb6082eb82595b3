//! `pir study SCENE --reference REF.exr`: an error-against-time race of rendering methods,
//! with CSV/JSON of every snapshot, log-log charts, an image sheet and a Markdown report.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

use pir::image::read_exr;
use pir::integrator::{MethodConfig, MethodParams, Parameter};
use pir::render::{Renderer, SceneOptions};
use pir::study::independence::check_reference;
use pir::study::output::{StudyInfo, write_all};
use pir::study::{Method, Run, Schedule, run_one};

use super::setup::{at_resolution, interrupt_flag, scene_stem, seconds};

/// Race rendering methods against a reference for the same wall-clock budget.
///
/// Each method renders alone on all threads for --time seconds (or --iterations) at the
/// reference's size; snapshots at 0.25 s · 2^(k/2) (1 iteration · 2^(k/2)) and at the end are
/// measured against the reference (RMSE, relative MSE, HDR-FLIP, worst-pixel error, mean).
/// The output folder gets snapshots.csv, study.json, one log-log chart per metric (PNG and
/// SVG), sheet.png, the final EXRs and report.md.
///
/// Ctrl-C or SIGTERM ends the running line after its iteration and writes the study of the
/// lines raced so far.
///
/// --sweep KEY=V1,V2,… runs every method that uses KEY once per value; without --methods,
/// only those.
#[derive(Args, Debug)]
#[command(after_long_help = pir::integrator::methods::parameters_help())]
pub struct StudyArgs {
    /// The scene file: pir's TOML, or a Mitsuba 3 scene (.xml).
    pub scene: PathBuf,
    /// The reference image (EXR), e.g. from `pir reference`; renders take its size.
    #[arg(long, value_name = "REF.exr")]
    pub reference: PathBuf,
    #[arg(long, value_delimiter = ',', value_name = "LIST", help = methods_help())]
    pub methods: Option<Vec<String>>,
    /// Wall-clock budget of each line, in seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0, allow_negative_numbers = true)]
    pub time: f64,
    /// Instead of --time: this many iterations per line, so that every number but the times is
    /// reproducible.
    #[arg(long, value_name = "N", conflicts_with = "time")]
    pub iterations: Option<u64>,
    /// Output folder, created if missing [default: study-SCENE].
    #[arg(long, short, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Report each line's time to reach this relative MSE (e.g. that of `pt` at 1,024 spp,
    /// from `pir compare`).
    #[arg(long, value_name = "E")]
    pub target_rel_mse: Option<f64>,
    #[arg(long, value_name = "KEY=V1,V2,…", help = sweep_help())]
    pub sweep: Option<String>,
    /// The first snapshot, in seconds, or iterations with --iterations (later ones follow at
    /// factors of √2) [default: 0.25 s, 1 iteration].
    #[arg(long, value_name = "SECONDS|N", allow_negative_numbers = true)]
    pub first_snapshot: Option<f64>,
    #[command(flatten)]
    pub params: MethodParams,
    #[command(flatten)]
    pub options: SceneOptions,
}

/// `--methods`' help: the registered methods.
fn methods_help() -> String {
    format!("Methods, comma-separated: {} [default: all]", Method::names())
}

/// `--sweep`'s help: the parameters a study can sweep, each with the methods that use it.
fn sweep_help() -> String {
    let keys: Vec<String> = Parameter::ALL
        .into_iter()
        .filter(|p| p.sweepable())
        .map(|p| {
            let users: Vec<&str> =
                Method::all().into_iter().filter(|m| m.uses(p)).map(|m| m.name()).collect();
            format!("{}=… ({})", p.key(), users.join(", "))
        })
        .collect();
    format!("Parameter sweep, values comma-separated: {}", keys.join("; "))
}

fn parse_sweep(s: &str) -> Result<(Parameter, Vec<f32>)> {
    let (k, vs) = s.split_once('=').with_context(|| format!("--sweep {s:?}: expected KEY=V1,V2,…"))?;
    let Some(key) = Parameter::from_key(k.trim()).filter(|p| p.sweepable()) else {
        bail!("--sweep: unknown parameter {:?}: expected alpha, clamp, radius or merge-radius", k.trim());
    };
    let mut values = Vec::new();
    for v in vs.split(',') {
        let x: f32 = v.trim().parse().with_context(|| format!("--sweep: {v:?} is not a number"))?;
        if !key.accepts(x) {
            bail!("--sweep {}: {x} is out of range ({})", k.trim(), key.range());
        }
        values.push(x);
    }
    Ok((key, values))
}

/// The lines of the study, in order.
fn runs(a: &StudyArgs) -> Result<Vec<Run>> {
    let sweep = a.sweep.as_deref().map(parse_sweep).transpose()?;
    let methods: Vec<Method> = match &a.methods {
        Some(list) => {
            let mut v = Vec::new();
            for s in list {
                let m: Method = s.parse().map_err(|e| anyhow::anyhow!("--methods: {e}"))?;
                if !v.contains(&m) {
                    v.push(m);
                }
            }
            v
        }
        None => match &sweep {
            Some((key, _)) => Method::all().into_iter().filter(|m| m.uses(*key)).collect(),
            None => Method::all(),
        },
    };
    if methods.is_empty() {
        bail!("--methods: no method given");
    }
    if let Some((key, _)) = &sweep
        && !methods.iter().any(|m| m.uses(*key))
    {
        let k = a.sweep.as_deref().and_then(|s| s.split_once('=')).map_or("", |(k, _)| k.trim());
        bail!("--sweep {k}: none of the methods uses this parameter");
    }
    let mut out = Vec::new();
    for method in methods {
        let run = Run::new(MethodConfig { method, params: a.params });
        match &sweep {
            Some((key, values)) if method.uses(*key) => {
                out.extend(values.iter().map(|&v| run.swept(*key, v)));
            }
            _ => out.push(run),
        }
    }
    Ok(out)
}

/// Creates `dir` if needed and checks that files can be written in it.
fn check_out_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!("{}: exists and is not a folder", dir.display());
    }
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the output folder", dir.display()))?;
    tempfile::Builder::new()
        .prefix(".pir-check-")
        .tempfile_in(dir)
        .with_context(|| format!("{}: cannot write in the output folder", dir.display()))?;
    Ok(())
}

pub fn run(a: StudyArgs) -> Result<()> {
    // ---- Check every argument before any work.
    let schedule = match a.iterations {
        Some(0) => bail!("--iterations 0: must be at least 1"),
        Some(n) => {
            let first = a.first_snapshot.unwrap_or(1.0);
            if !(first.is_finite() && first >= 1.0 && first.fract() == 0.0) {
                bail!(
                    "--first-snapshot {first}: with --iterations, must be a whole number of iterations ≥ 1"
                );
            }
            Schedule::iterations(n, first as u64)
        }
        None => {
            let first = a.first_snapshot.unwrap_or(0.25);
            if !(first.is_finite() && first > 0.0) {
                bail!("--first-snapshot {first}: must be a positive number of seconds");
            }
            Schedule::time(seconds("--time", a.time)?, first)
        }
    };
    let budget_text = match a.iterations {
        Some(n) => format!("{n} iterations"),
        None => format!("{} s", a.time),
    };
    a.params.validate()?;
    if let Some(e) = a.target_rel_mse
        && !(e.is_finite() && e > 0.0)
    {
        bail!("--target-rel-mse {e}: must be a positive number");
    }
    a.options.check()?;
    let runs = runs(&a)?;
    let (reference, ref_attrs) = read_exr(&a.reference).context("cannot read the reference")?;
    let reference = match &a.options.resolution {
        Some(r) => {
            at_resolution(reference, (r[0] as usize, r[1] as usize), &a.reference).context("--resolution")?
        }
        None => reference,
    };
    if reference.pixels.iter().any(|p| !p.is_finite()) {
        bail!("{}: the reference has NaN or infinite pixels", a.reference.display());
    }
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from(format!("study-{}", scene_stem(&a.scene))));
    let scene = a.options.load(&a.scene)?;
    let (seed, sampler) = (a.options.seed(&scene), a.options.sampler());
    check_reference(&a.reference, &ref_attrs, &scene.fingerprint(), seed, sampler.name())?;
    for run in &runs {
        run.config.check_scene(&scene)?;
    }
    // Every line renders at the reference's size.
    let options = SceneOptions {
        resolution: Some(vec![reference.width as u32, reference.height as u32]),
        ..a.options.clone()
    };
    let renderer = Renderer::new(&scene, &options)?;
    check_out_dir(&out)?;
    let threads = renderer.threads();
    eprintln!(
        "pir study: {} at {}×{}, {} lines × {budget_text} on {} threads, output in {}",
        a.scene.display(),
        reference.width,
        reference.height,
        runs.len(),
        threads,
        out.display()
    );

    // Ctrl-C or SIGTERM: end the running line after its iteration and write the study of the
    // lines raced so far (the last one cut short), then exit 0.
    let interrupted = interrupt_flag()?;
    let mut results = Vec::new();
    for run in &runs {
        if interrupted.load(Ordering::SeqCst) {
            break;
        }
        eprintln!("pir study: racing {} for {budget_text} …", run.label);
        let r = run_one(&renderer, run, &schedule, &reference, &interrupted)?;
        if let Some(l) = r.snapshots.last() {
            eprintln!(
                "pir study: {:<22} {:>6} it in {:6.2} s: RMSE {:.4e}, relative MSE {:.4e}, HDR-FLIP {:.4}, \
                 worst pixel {:.3e}, mean {:+.2} %",
                run.label,
                l.iterations,
                l.time_s,
                l.rmse,
                l.rel_mse,
                l.hdr_flip,
                l.max_rel_se,
                100.0 * l.mean_rel_diff
            );
        }
        results.push(r);
    }

    if results.is_empty() {
        eprintln!("pir study: interrupted before the first line: nothing to write");
        return Ok(());
    }
    if interrupted.load(Ordering::SeqCst) {
        eprintln!(
            "pir study: interrupted: writing the {} of {} lines raced so far (the last one cut short)",
            results.len(),
            runs.len()
        );
    }
    let attr = |k: &str| ref_attrs.iter().find(|(key, _)| key == k).map(|(_, v)| v.clone());
    let info = StudyInfo {
        scene: a.scene.display().to_string(),
        reference: a.reference.display().to_string(),
        reference_spp: attr("pir.spp").or_else(|| attr("pir.iterations")),
        width: reference.width,
        height: reference.height,
        budget_s: a.iterations.is_none().then_some(a.time),
        budget_iterations: a.iterations,
        first_snapshot: schedule.base,
        hdr_flip_exposures: pir::study::flip::exposures(&reference),
        target_rel_mse: a.target_rel_mse,
        seed: renderer.seed(),
        max_depth: renderer.max_depth(),
        threads,
        accel: renderer.accel_description().to_string(),
        pir_version: env!("CARGO_PKG_VERSION").into(),
    };
    let files = write_all(&out, &info, &results, &reference)?;
    eprintln!("pir study: wrote {} files; see {}", files.len(), out.join("report.md").display());
    Ok(())
}
