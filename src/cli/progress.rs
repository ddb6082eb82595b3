//! The progress bar of a render on a terminal, driven by the render's per-iteration callback.

use indicatif::{ProgressBar, ProgressStyle};

use pir::render::{Budget, RenderStats};

/// A progress bar counting iterations (with an iteration budget) or milliseconds (with a
/// time budget); hidden when not shown.
pub struct Progress {
    bar: ProgressBar,
    by_iterations: bool,
}

impl Progress {
    pub fn new(budget: &Budget, show: bool) -> Progress {
        let by_iterations = budget.iterations.is_some();
        if !show {
            return Progress { bar: ProgressBar::hidden(), by_iterations };
        }
        let (len, unit) = match (budget.iterations, budget.time) {
            (Some(n), _) => (n, "it"),
            (None, Some(t)) => (t.as_millis() as u64, "ms"),
            (None, None) => (0, "it"),
        };
        let bar = ProgressBar::new(len);
        let template = format!("{{elapsed_precise}} [{{bar:40.cyan/blue}}] {{pos}}/{{len}} {unit}  {{msg}}");
        if let Ok(style) = ProgressStyle::with_template(&template) {
            bar.set_style(style.progress_chars("=> "));
        }
        Progress { bar, by_iterations }
    }

    /// Shows the statistics after an iteration.
    pub fn update(&self, stats: &RenderStats) {
        let secs = stats.elapsed.as_secs_f64().max(1e-9);
        if self.by_iterations {
            self.bar.set_position(stats.iterations);
        } else {
            self.bar.set_position(stats.elapsed.as_millis() as u64);
        }
        self.bar.set_message(format!(
            "{} it, {:.2} it/s, {:.1} Mrays/s",
            stats.iterations,
            stats.rendered as f64 / secs,
            stats.rays_per_second() / 1e6
        ));
    }

    /// Removes the bar from the terminal.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
