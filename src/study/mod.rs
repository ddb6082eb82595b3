//! Studies: error-against-time races of rendering methods against a reference image.
//!
//! Each run renders one method (with one set of parameters) for a wall-clock budget on all
//! threads, and keeps a snapshot of the running image at log-spaced times (`base` · 2^(k/2)
//! seconds, k = 0, 1, …) and at the end. The time of a snapshot is the render's own time:
//! copying the image out is not counted, and metrics are computed after the render, so that
//! measuring never slows the race. Every snapshot gets RMSE, relative MSE and HDR-FLIP (see
//! [`flip`]) against the reference; [`output`] writes the CSV, JSON, charts, image sheet and
//! report.

pub mod chart;
pub mod flip;
pub mod output;
pub mod sheet;

use anyhow::{Result, bail};
use rayon::prelude::*;
use serde::Serialize;
use std::time::{Duration, Instant};

use crate::image::{RgbImage, metrics};
pub use crate::integrator::Method;
use crate::integrator::{Integrator, MethodConfig, RenderContext};
use crate::render::{Budget, Control, RenderSettings, render};

/// One line of a study: a method with its parameters.
#[derive(Clone, Debug, Serialize)]
pub struct Run {
    pub method: Method,
    /// The line's name in charts and tables, e.g. "pir-clamp α=0.3".
    pub label: String,
    pub alpha: f32,
    /// ir-clamp, pir-clamp: the bound b (b_1); `None` = the default for the scene.
    pub clamp: Option<f32>,
    /// vsl, pir-vsl: the radius r (r_1); `None` = per light, by density.
    pub radius: Option<f32>,
    pub vpls: usize,
    /// In a parameter sweep, the swept parameter ("alpha", "clamp" or "radius") and its value.
    pub sweep: Option<(String, f32)>,
}

impl Run {
    pub fn integrator(&self, scene_diagonal: f32) -> Box<dyn Integrator> {
        let config = MethodConfig {
            method: self.method,
            vpls: self.vpls,
            clamp: self.clamp,
            radius: self.radius,
            alpha: self.alpha,
        };
        config.integrator(scene_diagonal)
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
}

/// The outcome of one run: its snapshots (in time order) and final image.
#[derive(Clone, Debug)]
pub struct RunResult {
    pub run: Run,
    pub snapshots: Vec<Snapshot>,
    pub image: RgbImage,
}

/// When snapshots are taken.
#[derive(Clone, Copy, Debug)]
pub struct Schedule {
    pub budget: Duration,
    /// The first snapshot time in seconds; later ones follow at factors of √2.
    pub base: f64,
}

impl Schedule {
    /// The snapshot times strictly before the budget, in seconds.
    pub fn times(&self) -> Vec<f64> {
        let b = self.budget.as_secs_f64();
        (0..).map(|k| self.base * 2f64.powf(k as f64 / 2.0)).take_while(|t| *t < b).collect()
    }
}

/// Renders one run against `reference` (whose size the render takes) and measures it.
/// Runs on the current rayon pool.
pub fn run_one(
    ctx: &RenderContext,
    run: &Run,
    schedule: &Schedule,
    reference: &RgbImage,
) -> Result<RunResult> {
    if schedule.base <= 0.0 {
        bail!("the first snapshot time must be positive");
    }
    let mut integrator = run.integrator(ctx.scene.bounds.diagonal());
    let parameters: Vec<String> =
        integrator.parameters().into_iter().map(|(k, v)| format!("{k}={v}")).collect();
    let parameters = parameters.join(";");
    let settings = RenderSettings {
        width: reference.width,
        height: reference.height,
        budget: Budget { iterations: None, time: None },
        tile_size: 16,
        progress: false,
    };
    let times = schedule.times();
    let budget = schedule.budget.as_secs_f64();
    let mut next = 0usize;
    let mut overhead = Duration::ZERO;
    let mut taken: Vec<(f64, u64, RgbImage)> = Vec::new();
    let (film, _) = render(ctx, integrator.as_mut(), &settings, |film, stats| {
        let t = (stats.elapsed.saturating_sub(overhead)).as_secs_f64();
        let done = t >= budget;
        let due = next < times.len() && t >= times[next];
        if due && !done {
            let c0 = Instant::now();
            taken.push((t, stats.iterations, film.image()));
            while next < times.len() && times[next] <= t {
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
    let exposures = flip::exposures(reference);
    let measured: Vec<Result<Snapshot>> = taken
        .par_iter()
        .map(|(t, it, img)| {
            let m = metrics(img, reference)?;
            Ok(Snapshot {
                label: run.label.clone(),
                method: run.method,
                parameters: parameters.clone(),
                time_s: *t,
                iterations: *it,
                rmse: m.rmse,
                rel_mse: m.rel_mse,
                hdr_flip: flip::hdr_flip(img, reference, &exposures),
            })
        })
        .collect();
    let snapshots = measured.into_iter().collect::<Result<Vec<_>>>()?;
    Ok(RunResult { run: run.clone(), snapshots, image: film.image() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snapshot_times_grow_by_root_two_below_the_budget() {
        let s = Schedule { budget: Duration::from_secs(2), base: 0.25 };
        let t = s.times();
        assert_eq!(t.len(), 6);
        assert!((t[2] - 0.5).abs() < 1e-12 && (t[4] - 1.0).abs() < 1e-12);
        assert!(t.iter().all(|x| *x < 2.0));
    }
}
