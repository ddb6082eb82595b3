//! A study's outputs, all in one folder: `snapshots.csv` and `study.json` (every snapshot),
//! one chart per metric (`<metric>.png` and `.svg`), `sheet.png`, the final images as EXR
//! (`final-<label>.exr`) and `report.md`, which links them with a table of final metrics.

use anyhow::{Context, Result};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::chart::{self, Metric};
use super::sheet::{self, Region};
use super::{Run, RunResult, Snapshot};
use crate::image::{RgbImage, write_atomically, write_exr};

/// What the study was: recorded in the JSON and the report.
#[derive(Clone, Debug, Serialize)]
pub struct StudyInfo {
    pub scene: String,
    pub reference: String,
    /// The reference's sample count, when its metadata records it.
    pub reference_spp: Option<String>,
    pub width: usize,
    pub height: usize,
    /// Each line's budget: seconds of rendering, or iterations.
    pub budget_s: Option<f64>,
    pub budget_iterations: Option<u64>,
    /// The first snapshot (seconds or iterations, as the budget); later ones follow at factors
    /// of √2.
    pub first_snapshot: f64,
    /// The exposures (stops) at which HDR-FLIP compares, from the reference.
    pub hdr_flip_exposures: Vec<f32>,
    /// With `--target-rel-mse`: the relative MSE whose time to reach the report gives.
    pub target_rel_mse: Option<f64>,
    pub seed: u64,
    pub max_depth: u32,
    pub threads: usize,
    pub accel: String,
    pub pir_version: String,
}

#[derive(Serialize)]
struct Json<'a> {
    study: &'a StudyInfo,
    /// Each line's method and parameters, in the order raced.
    lines: Vec<&'a Run>,
    hardest_region: Region,
    metrics: [&'static str; 5],
    hdr_flip: &'static str,
    snapshots: Vec<&'a Snapshot>,
}

const FLIP_NOTE: &str = "mean over pixels of HDR-FLIP (Andersson et al. 2021): per-pixel maximum of NVIDIA's LDR-FLIP (nv-flip crate, 67 pixels/degree) over exposures spanning the reference's luminance range, ACES tone curve, 8-bit sRGB input";

/// A file-name-safe form of a label ("pir-clamp α=0.3" → "pir-clamp_alpha-0.3").
pub fn slug(label: &str) -> String {
    let s = label.replace('α', "alpha").replace('=', "-");
    s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '.' { c } else { '_' }).collect()
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

/// The CSV text of the snapshots (header + one row each).
pub fn csv(snapshots: &[Snapshot]) -> String {
    let mut out = String::from(
        "label,method,parameters,time_s,iterations,rmse,rel_mse,hdr_flip,max_rel_se,mean_rel_diff\n",
    );
    for s in snapshots {
        let _ = writeln!(
            out,
            "{},{},{},{:.6},{},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e}",
            csv_field(&s.label),
            s.method.name(),
            csv_field(&s.parameters),
            s.time_s,
            s.iterations,
            s.rmse,
            s.rel_mse,
            s.hdr_flip,
            s.max_rel_se,
            s.mean_rel_diff
        );
    }
    out
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomically(path, |f| {
        use std::io::Write;
        f.write_all(text.as_bytes())?;
        Ok(())
    })
}

/// Writes every output into `dir` (which must exist). Returns the files written.
pub fn write_all(
    dir: &Path,
    info: &StudyInfo,
    results: &[RunResult],
    reference: &RgbImage,
) -> Result<Vec<PathBuf>> {
    let snapshots: Vec<Snapshot> = results.iter().flat_map(|r| r.snapshots.iter().cloned()).collect();
    let mut written = Vec::new();

    let p = dir.join("snapshots.csv");
    write_text(&p, &csv(&snapshots))?;
    written.push(p);

    let region = sheet::write_sheet(&dir.join("sheet.png"), results, reference)?;
    written.push(dir.join("sheet.png"));

    let json = Json {
        study: info,
        lines: results.iter().map(|r| &r.run).collect(),
        hardest_region: region,
        metrics: ["rmse", "rel_mse", "hdr_flip", "max_rel_se", "mean_rel_diff"],
        hdr_flip: FLIP_NOTE,
        snapshots: snapshots.iter().collect(),
    };
    let p = dir.join("study.json");
    write_text(&p, &serde_json::to_string_pretty(&json).context("cannot encode the JSON")?)?;
    written.push(p);

    let subtitle = format!("{}, {}×{}", scene_name(&info.scene), info.width, info.height);
    for m in Metric::ALL {
        let stem = dir.join(m.key());
        chart::draw(&stem, &snapshots, m, &subtitle)?;
        written.push(stem.with_extension("png"));
        written.push(stem.with_extension("svg"));
    }

    let sweeps = sweep_lines(results);
    if let Some((key, lines)) = &sweeps {
        for m in Metric::ALL {
            let data: Vec<chart::Series> = lines
                .iter()
                .map(|(method, pts)| {
                    let v = pts.iter().map(|(x, s)| (*x, m.of(s))).filter(|(_, v)| *v > 0.0).collect();
                    (method.clone(), v)
                })
                .collect();
            let stem = dir.join(format!("sweep-{}", m.key()));
            chart::draw_sweep(&stem, &data, key, m, &subtitle)?;
            written.push(stem.with_extension("png"));
            written.push(stem.with_extension("svg"));
        }
    }

    for r in results {
        let p = dir.join(format!("final-{}.exr", slug(&r.run.label)));
        let last = r.snapshots.last();
        let attrs = vec![
            ("pir.method".to_string(), r.run.method().name().to_string()),
            ("pir.study.label".to_string(), r.run.label.replace('α', "alpha")),
            ("pir.iterations".to_string(), last.map_or(0, |s| s.iterations).to_string()),
            ("pir.render_time_s".to_string(), format!("{:.3}", last.map_or(0.0, |s| s.time_s))),
        ];
        write_exr(&p, &r.image, &attrs)?;
        written.push(p);
    }

    let p = dir.join("report.md");
    write_text(&p, &report(info, results, region, sweeps.as_ref().map(|(k, _)| k.as_str())))?;
    written.push(p);
    Ok(written)
}

/// The swept key and, per method, (parameter value, final snapshot) sorted by value; `None`
/// when no line belongs to a sweep.
type SweepLines<'a> = (String, Vec<(String, Vec<(f64, &'a Snapshot)>)>);

fn sweep_lines(results: &[RunResult]) -> Option<SweepLines<'_>> {
    let mut key = None;
    let mut lines: Vec<(String, Vec<(f64, &Snapshot)>)> = Vec::new();
    for r in results {
        let (Some((k, v)), Some(last)) = (&r.run.sweep, r.snapshots.last()) else { continue };
        key.get_or_insert_with(|| k.key().to_string());
        let name = r.run.method().name().to_string();
        match lines.iter_mut().find(|(n, _)| *n == name) {
            Some((_, pts)) => pts.push((*v as f64, last)),
            None => lines.push((name, vec![(*v as f64, last)])),
        }
    }
    for (_, pts) in &mut lines {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    key.map(|k| (k, lines))
}

fn scene_name(scene: &str) -> String {
    let p = Path::new(scene);
    let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or(scene);
    if stem == "scene" {
        p.parent().and_then(|d| d.file_name()).and_then(|s| s.to_str()).unwrap_or(stem).to_string()
    } else {
        stem.to_string()
    }
}

/// The Markdown report.
pub fn report(info: &StudyInfo, results: &[RunResult], region: Region, sweep: Option<&str>) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Study: {}\n", scene_name(&info.scene));
    let _ = writeln!(
        s,
        "Scene `{}`, reference `{}`{}, {}×{} pixels, {} per line on {} threads (one line at a \
         time), seed {}, max depth {}, accelerator {}, pir {}.\n",
        info.scene,
        info.reference,
        info.reference_spp.as_ref().map_or(String::new(), |n| format!(" ({n} spp)")),
        info.width,
        info.height,
        budget_text(info),
        info.threads,
        info.seed,
        info.max_depth,
        info.accel,
        info.pir_version
    );
    let _ = writeln!(s, "## Final metrics\n");
    let _ = writeln!(
        s,
        "| line | parameters | time (s) | iterations | RMSE | relative MSE | HDR-FLIP | worst pixel | mean |"
    );
    let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|---:|");
    let mut best: [Option<(f64, &str)>; 4] = [None; 4];
    for r in results {
        if let Some(l) = r.snapshots.last() {
            let _ = writeln!(
                s,
                "| {} | {} | {:.2} | {} | {:.4e} | {:.4e} | {:.4} | {:.3e} | {:+.2} % |",
                r.run.label,
                l.parameters.replace(';', ", "),
                l.time_s,
                l.iterations,
                l.rmse,
                l.rel_mse,
                l.hdr_flip,
                l.max_rel_se,
                100.0 * l.mean_rel_diff
            );
            for (i, v) in [l.rmse, l.rel_mse, l.hdr_flip, l.max_rel_se].into_iter().enumerate() {
                if best[i].is_none_or(|(b, _)| v < b) {
                    best[i] = Some((v, &r.run.label));
                }
            }
        }
    }
    let _ = writeln!(s);
    let names = ["RMSE", "relative MSE", "HDR-FLIP", "worst-pixel error"];
    for (name, b) in names.iter().zip(best) {
        if let Some((v, l)) = b {
            let _ = writeln!(s, "- lowest final {name}: **{l}** ({v:.4e})");
        }
    }
    if let Some(target) = info.target_rel_mse {
        let _ = writeln!(s, "\n## Time to reach a relative MSE of {target:.3e}\n");
        let _ = writeln!(
            s,
            "The render time at which each line's relative MSE first falls to the target, interpolated \
             log-log between the snapshots around the crossing.\n"
        );
        let _ = writeln!(s, "| line | time (s) | iterations by then (interpolated) |");
        let _ = writeln!(s, "|---|---:|---:|");
        for r in results {
            let cell = match time_to_reach(&r.snapshots, target) {
                Some((t, it)) => format!("{t:.2} | {it}"),
                None => format!("not within {:.1} s | –", r.snapshots.last().map_or(0.0, |l| l.time_s)),
            };
            let _ = writeln!(s, "| {} | {cell} |", r.run.label);
        }
    }
    let _ = writeln!(s, "\n## Error against time\n");
    let unit = if info.budget_iterations.is_some() { "iterations" } else { "s" };
    let _ = writeln!(
        s,
        "Log-log; each point is a snapshot (at {} {unit} · 2^(k/2) and at the end of the budget).\n",
        info.first_snapshot
    );
    for m in Metric::ALL {
        let _ = writeln!(s, "![{}]({}.png)\n\n[SVG]({}.svg)\n", m.title(), m.key(), m.key());
    }
    if let Some(key) = sweep {
        let _ = writeln!(s, "## Parameter sweep: {key}\n");
        let _ = writeln!(
            s,
            "The final error of each swept line (after the full budget) against {}.\n",
            chart::parameter_label(key)
        );
        for m in Metric::ALL {
            let _ =
                writeln!(s, "![final {0} against {key}](sweep-{0}.png)\n\n[SVG](sweep-{0}.svg)\n", m.key());
        }
    }
    let _ = writeln!(s, "## Images\n");
    let _ = writeln!(
        s,
        "Final image, the hardest region (x {}, y {}, {}×{} pixels: the largest relative squared \
         error summed over all lines) enlarged, and the relative-error map of each line.\n",
        region.x, region.y, region.width, region.height
    );
    let _ = writeln!(s, "![image sheet](sheet.png)\n");
    let _ = writeln!(s, "Final images: {}.\n", {
        let v: Vec<String> =
            results.iter().map(|r| format!("[`final-{0}.exr`](final-{0}.exr)", slug(&r.run.label))).collect();
        v.join(", ")
    });
    let _ = writeln!(s, "## Data and definitions\n");
    let _ = writeln!(s, "Every snapshot: [`snapshots.csv`](snapshots.csv), [`study.json`](study.json).\n");
    let _ = writeln!(s, "- time: render time of the line, excluding the copies taken for snapshots;");
    let _ = writeln!(s, "- RMSE: root mean over pixels and channels of (x − r)², in linear radiance;");
    let _ = writeln!(s, "- relative MSE: mean over pixels and channels of (x − r)² / (r² + 0.01);");
    let _ = writeln!(s, "- HDR-FLIP: {FLIP_NOTE};");
    let _ = writeln!(s, "- worst pixel: the largest per-pixel relative squared error (mean over channels);");
    let _ = writeln!(
        s,
        "- mean: relative difference of the image's channel means to the reference's, averaged over \
         the channels."
    );
    s
}

/// When a line's relative MSE first reaches `target`: the time, interpolated log-log between
/// the last snapshot above it and the first at or below it, and the iterations by then
/// (interpolated linearly in time between the two snapshots' counts).
pub fn time_to_reach(snapshots: &[Snapshot], target: f64) -> Option<(f64, u64)> {
    let i = snapshots.iter().position(|s| s.rel_mse <= target)?;
    let b = &snapshots[i];
    let Some(a) = i.checked_sub(1).map(|k| &snapshots[k]) else { return Some((b.time_s, b.iterations)) };
    let (la, lb, lt) = (a.rel_mse.ln(), b.rel_mse.ln(), target.ln());
    let f = if la > lb { ((la - lt) / (la - lb)).clamp(0.0, 1.0) } else { 1.0 };
    if !(a.time_s > 0.0 && b.time_s > a.time_s) {
        return Some((b.time_s, b.iterations));
    }
    let t = (a.time_s.ln() + f * (b.time_s.ln() - a.time_s.ln())).exp();
    let g = (t - a.time_s) / (b.time_s - a.time_s);
    let it = a.iterations as f64 + g * (b.iterations as f64 - a.iterations as f64);
    Some((t, it.round() as u64))
}

fn budget_text(info: &StudyInfo) -> String {
    match (info.budget_iterations, info.budget_s) {
        (Some(n), _) => format!("{n} iterations"),
        (None, Some(t)) => format!("{t} s of wall-clock time"),
        (None, None) => "an unrecorded budget".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snap(time_s: f64, rel_mse: f64) -> Snapshot {
        Snapshot {
            label: "x".into(),
            method: "pt".parse().unwrap(),
            parameters: String::new(),
            time_s,
            iterations: (time_s * 10.0) as u64,
            rmse: 0.0,
            rel_mse,
            hdr_flip: 0.0,
            max_rel_se: 0.0,
            mean_rel_diff: 0.0,
        }
    }

    #[test]
    fn time_to_reach_interpolates_log_log_at_the_first_crossing() {
        let s = [snap(1.0, 1e-2), snap(4.0, 1e-4), snap(8.0, 1e-5)];
        // Halfway down in log error between 1 s and 4 s: 2 s, in log time.
        // Iterations: 10 at 1 s, 40 at 4 s, so 20 at 2 s.
        let (t, it) = time_to_reach(&s, 1e-3).unwrap();
        assert!((t - 2.0).abs() < 1e-9 && it == 20, "{t} {it}");
        assert_eq!(time_to_reach(&s, 1e-2), Some((1.0, 10)));
        assert_eq!(time_to_reach(&s, 1e-6), None);
        // A line that dips below the target, rises again and falls later counts its first dip.
        let s = [snap(1.0, 1e-2), snap(2.0, 1e-4), snap(4.0, 1e-2), snap(8.0, 1e-4)];
        assert_eq!(time_to_reach(&s, 1e-4).map(|x| x.0), Some(2.0));
    }

    #[test]
    fn slugs_are_file_name_safe_and_csv_quotes_commas() {
        assert_eq!(slug("pir-clamp α=0.3"), "pir-clamp_alpha-0.3");
        assert_eq!(slug("a/b c"), "a_b_c");
        let s = Snapshot {
            label: "x".into(),
            method: "pt".parse().unwrap(),
            parameters: "a=1,b=2".into(),
            time_s: 0.5,
            iterations: 3,
            rmse: 0.25,
            rel_mse: 0.125,
            hdr_flip: 0.0625,
            max_rel_se: 1.5,
            mean_rel_diff: -0.25,
        };
        let text = csv(&[s]);
        let row = text.lines().nth(1).unwrap();
        assert_eq!(
            row,
            "x,pt,\"a=1,b=2\",0.500000,3,2.500000000e-1,1.250000000e-1,6.250000000e-2,1.500000000e0,-2.500000000e-1"
        );
    }
}
