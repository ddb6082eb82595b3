//! The progress of a render, driven by the render's per-iteration callback: a bar on a
//! terminal; where standard error is not a terminal (a batch job's log, e.g. Slurm's
//! `slurm-*.log`), a line now and then with the iterations, the elapsed time and an estimate of
//! the time left, so that the log tells where the render is.

use std::io::IsTerminal;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

use pir::render::{Budget, RenderStats};

/// Seconds between two progress lines in a log unless a command says otherwise.
pub const DEFAULT_LINE_INTERVAL: f64 = 60.0;

/// How progress is shown.
enum Display {
    /// A bar counting iterations (with an iteration budget) or milliseconds (with a time budget).
    Bar(ProgressBar),
    /// A line after the first iteration this run renders, then one every `every`.
    Lines {
        every: Duration,
        next: Duration,
    },
    Hidden,
}

pub struct Progress {
    display: Display,
    budget: Budget,
}

impl Progress {
    /// Progress of a render of `budget`: a bar on a terminal, else a line every `line_every`;
    /// nothing when not `show`.
    pub fn new(budget: &Budget, show: bool, line_every: Duration) -> Progress {
        let display = if !show {
            Display::Hidden
        } else if std::io::stderr().is_terminal() {
            Display::Bar(bar(budget))
        } else {
            Display::Lines { every: line_every, next: Duration::ZERO }
        };
        Progress { display, budget: *budget }
    }

    /// Shows the statistics after an iteration.
    pub fn update(&mut self, stats: &RenderStats) {
        match &mut self.display {
            Display::Bar(bar) => {
                let secs = stats.elapsed.as_secs_f64().max(1e-9);
                if self.budget.iterations.is_some() {
                    bar.set_position(stats.iterations);
                } else {
                    bar.set_position(stats.elapsed.as_millis() as u64);
                }
                bar.set_message(format!(
                    "{} it, {:.2} it/s, {:.1} Mrays/s",
                    stats.iterations,
                    stats.rendered as f64 / secs,
                    stats.rays_per_second() / 1e6
                ));
            }
            Display::Lines { every, next } => {
                if stats.elapsed >= *next {
                    eprintln!("pir: progress: {}", line(&self.budget, stats));
                    // The next line at the next multiple of the interval.
                    while *next <= stats.elapsed {
                        *next += *every;
                    }
                }
            }
            Display::Hidden => {}
        }
    }

    /// Removes the bar from the terminal.
    pub fn finish(&self) {
        if let Display::Bar(bar) = &self.display {
            bar.finish_and_clear();
        }
    }
}

fn bar(budget: &Budget) -> ProgressBar {
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
    bar
}

/// "120/512 iterations (23 %), 0:01:23 elapsed, about 0:04:30 left, 1.45 it/s": the iterations
/// in the film (a resumed render's included) against the budget, this run's elapsed time and
/// rate, and the time left at that rate (with a time budget, the budget's remainder if sooner).
fn line(budget: &Budget, stats: &RenderStats) -> String {
    let secs = stats.elapsed.as_secs_f64();
    let rate = stats.rendered as f64 / secs.max(1e-9);
    let mut left: Option<f64> = budget.time.map(|t| (t.as_secs_f64() - secs).max(0.0));
    let done = match budget.iterations {
        Some(n) => {
            let by_rate = n.saturating_sub(stats.iterations) as f64 / rate.max(1e-9);
            left = Some(left.map_or(by_rate, |l| l.min(by_rate)));
            format!(
                "{}/{} iterations ({:.0} %)",
                stats.iterations,
                n,
                100.0 * stats.iterations as f64 / n.max(1) as f64
            )
        }
        None => format!("{} iterations", stats.iterations),
    };
    let left = left.map(|l| format!(", about {} left", clock(l))).unwrap_or_default();
    format!("{done}, {} elapsed{left}, {rate:.2} it/s", clock(secs))
}

/// Seconds as h:mm:ss.
fn clock(secs: f64) -> String {
    let s = secs.round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(iterations: u64, rendered: u64, secs: u64) -> RenderStats {
        RenderStats { iterations, rendered, elapsed: Duration::from_secs(secs), ..RenderStats::default() }
    }

    #[test]
    fn a_log_line_says_where_the_render_is_and_how_long_it_has_left() {
        let budget = Budget { iterations: Some(512), time: None };
        // Resumed at 100, 20 more in 10 s: 392 left at 2 it/s.
        assert_eq!(
            line(&budget, &stats(120, 20, 10)),
            "120/512 iterations (23 %), 0:00:10 elapsed, about 0:03:16 left, 2.00 it/s"
        );
        let budget = Budget { iterations: None, time: Some(Duration::from_secs(3600)) };
        assert_eq!(
            line(&budget, &stats(7, 7, 70)),
            "7 iterations, 0:01:10 elapsed, about 0:58:50 left, 0.10 it/s"
        );
    }
}
