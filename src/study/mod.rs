//! Studies: error-against-time races of rendering methods against a reference image.
//!
//! Each run renders one method (with one set of parameters) for a wall-clock budget on all
//! threads, and keeps a snapshot of the running image at log-spaced times (`base` · 2^(k/2)
//! seconds, k = 0, 1, …) and at the end. The time of a snapshot is the render's own time:
//! copying the image out is not counted, and metrics are computed after the render, so that
//! measuring never slows the race. A budget of iterations instead of seconds (snapshots at
//! log-spaced iteration counts) makes a study reproducible number for number, as the stress
//! tests need: only the recorded times then vary from run to run. Every snapshot gets RMSE,
//! relative MSE, HDR-FLIP (see [`flip`]), the worst pixel's error and the image mean's
//! relative difference against the reference; [`output`] writes the CSV, JSON, charts, image
//! sheet and report.

pub mod chart;
pub mod flip;
pub mod independence;
pub mod output;
pub mod sheet;

use anyhow::{Result, bail};
use rayon::prelude::*;
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::image::{RgbImage, metrics};
pub use crate::integrator::Method;
use crate::integrator::{MethodConfig, Parameter};
use crate::render::{Budget, Control, Renderer};

/// One line of a study: a method with its parameters.
#[derive(Clone, Debug, Serialize)]
pub struct Run {
    /// The line's name in charts and tables, e.g. "pir-clamp α=0.3".
    pub label: String,
    #[serde(flatten)]
    pub config: MethodConfig,
    /// In a parameter sweep, the swept parameter and its value.
    pub sweep: Option<(Parameter, f32)>,
}

impl Run {
    /// The line of a method with its parameters, labelled by the method's name.
    pub fn new(config: MethodConfig) -> Run {
        Run { label: config.method.name().to_string(), config, sweep: None }
    }

    /// This line with `parameter` set to `value`, labelled by both ("pir-clamp α=0.3").
    pub fn swept(&self, parameter: Parameter, value: f32) -> Run {
        let mut config = self.config;
        config.params.set(parameter, value);
        Run {
            label: format!("{} {}={value}", config.method.name(), parameter.symbol()),
            config,
            sweep: Some((parameter, value)),
        }
    }

    pub fn method(&self) -> Method {
        self.config.method
    }
}

/// The metrics of one snapshot.
#[derive(Clone, Debug, Serialize)]
pub struct Snapshot {
    pub label: String,
    pub method: Method,
    /// The integrator's parameters as it reports them (e.g. clamp bound, α), "k=v" joined by ";".
    pub parameters: String,
    /// Render time in seconds (snapshot copies excluded).
    pub time_s: f64,
    pub iterations: u64,
    pub rmse: f64,
    pub rel_mse: f64,
    pub hdr_flip: f64,
    /// The largest per-pixel relative squared error (channel mean): spikes show here.
    pub max_rel_se: f64,
    /// (image mean − reference mean) / reference mean, averaged over the channels: bias
    /// shows here (a clamped method's stays negative).
    pub mean_rel_diff: f64,
}

/// The outcome of one run: its snapshots (in time order) and final image.
#[derive(Clone, Debug)]
pub struct RunResult {
    pub run: Run,
    pub snapshots: Vec<Snapshot>,
    pub image: RgbImage,
}

/// How long each line runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StudyBudget {
    /// Wall-clock seconds of rendering (the race).
    Time(Duration),
    /// Iterations: the same images whatever the machine.
    Iterations(u64),
}

/// When snapshots are taken.
#[derive(Clone, Copy, Debug)]
pub struct Schedule {
    pub budget: StudyBudget,
    /// The first snapshot, in seconds or iterations as the budget; later ones follow at factors
    /// of √2.
    pub base: f64,
}

impl Schedule {
    /// A time budget with snapshots from `base` seconds.
    pub fn time(budget: Duration, base: f64) -> Self {
        Schedule { budget: StudyBudget::Time(budget), base }
    }

    /// An iteration budget with snapshots from `base` iterations.
    pub fn iterations(budget: u64, base: u64) -> Self {
        Schedule { budget: StudyBudget::Iterations(budget), base: base as f64 }
    }

    fn end(&self) -> f64 {
        match self.budget {
            StudyBudget::Time(d) => d.as_secs_f64(),
            StudyBudget::Iterations(n) => n as f64,
        }
    }

    /// The snapshot marks strictly before the end of the budget, in seconds or iterations
    /// (whole and distinct for iterations).
    pub fn marks(&self) -> Vec<f64> {
        let end = self.end();
        let raw = (0..).map(|k| self.base * 2f64.powf(k as f64 / 2.0)).take_while(|t| *t < end);
        match self.budget {
            StudyBudget::Time(_) => raw.collect(),
            StudyBudget::Iterations(_) => {
                let mut v: Vec<f64> = raw.map(f64::round).filter(|n| *n >= 1.0 && *n < end).collect();
                v.dedup();
                v
            }
        }
    }
}

/// Renders one run against `reference` (of the renderer's size) and measures it, on the
/// renderer's threads. When `stop` is set the run ends after the running iteration, with a
/// final snapshot of what it has (an interrupted study).
pub fn run_one(
    renderer: &Renderer,
    run: &Run,
    schedule: &Schedule,
    reference: &RgbImage,
    stop: &AtomicBool,
) -> Result<RunResult> {
    if schedule.base.is_nan() || schedule.base <= 0.0 {
        bail!("the first snapshot must be positive");
    }
    let (w, h) = renderer.resolution();
    if (w as usize, h as usize) != (reference.width, reference.height) {
        bail!("the renderer's size {w}×{h} is not the reference's");
    }
    let marks = schedule.marks();
    let end = schedule.end();
    let mut next = 0usize;
    let mut overhead = Duration::ZERO;
    let mut taken: Vec<(f64, u64, RgbImage)> = Vec::new();
    let (film, _) = renderer.render(&run.config, Budget::default(), |film, stats| {
        let t = (stats.elapsed.saturating_sub(overhead)).as_secs_f64();
        let progress = match schedule.budget {
            StudyBudget::Time(_) => t,
            StudyBudget::Iterations(_) => stats.iterations as f64,
        };
        let done = progress >= end || stop.load(Ordering::SeqCst);
        let due = next < marks.len() && progress >= marks[next];
        if due && !done {
            let c0 = Instant::now();
            taken.push((t, stats.iterations, film.image()));
            while next < marks.len() && marks[next] <= progress {
                next += 1;
            }
            overhead += c0.elapsed();
        }
        if done {
            taken.push((t, stats.iterations, film.image()));
            Control::Stop
        } else {
            Control::Continue
        }
    });
    // After the render, whose driver runs (and times) the pilot of the methods that have one.
    let parameters: Vec<String> =
        renderer.parameters(&run.config).into_iter().map(|(k, v)| format!("{k}={v}")).collect();
    let parameters = parameters.join(";");
    let exposures = flip::exposures(reference);
    let measured: Vec<Result<Snapshot>> = renderer.install(|| {
        taken
            .par_iter()
            .map(|(t, it, img)| {
                let m = metrics(img, reference)?;
                Ok(Snapshot {
                    label: run.label.clone(),
                    method: run.method(),
                    parameters: parameters.clone(),
                    time_s: *t,
                    iterations: *it,
                    rmse: m.rmse,
                    rel_mse: m.rel_mse,
                    hdr_flip: flip::hdr_flip(img, reference, &exposures),
                    max_rel_se: m.max_rel_se,
                    mean_rel_diff: m.mean_rel_diff().iter().sum::<f64>() / 3.0,
                })
            })
            .collect()
    });
    let snapshots = measured.into_iter().collect::<Result<Vec<_>>>()?;
    Ok(RunResult { run: run.clone(), snapshots, image: film.image() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snapshot_times_grow_by_root_two_below_the_budget() {
        let s = Schedule::time(Duration::from_secs(2), 0.25);
        let t = s.marks();
        assert_eq!(t.len(), 6);
        assert!((t[2] - 0.5).abs() < 1e-12 && (t[4] - 1.0).abs() < 1e-12);
        assert!(t.iter().all(|x| *x < 2.0));
    }

    #[test]
    fn iteration_marks_are_whole_distinct_and_below_the_budget() {
        let m = Schedule::iterations(16, 1).marks();
        // 1, 1.41, 2, 2.83, 4, 5.66, 8, 11.3 rounded, without repeats; 16 is the end.
        assert_eq!(m, vec![1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 11.0]);
        assert!(Schedule::iterations(1, 1).marks().is_empty());
    }
}
