//! Error-against-time charts (log-log, one line per run, one chart per metric), drawn with
//! `plotters` as PNG and SVG. Text uses the embedded DejaVu Sans (through `ab_glyph`), so
//! charts render identically on machines without system fonts.

use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

use super::Snapshot;
use crate::image::write_png;

/// Chart size in pixels.
const W: u32 = 1000;
const H: u32 = 700;
/// Width of the legend panel.
const LEGEND_W: i32 = 230;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

pub(crate) fn ensure_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is embedded and known to parse; a failure would only lose the text.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// A metric of the snapshots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    Rmse,
    RelMse,
    HdrFlip,
    /// The largest per-pixel relative squared error: where VPL spikes show.
    MaxRelSe,
}

impl Metric {
    pub const ALL: [Metric; 4] = [Metric::RelMse, Metric::Rmse, Metric::HdrFlip, Metric::MaxRelSe];

    /// File-name stem.
    pub fn key(self) -> &'static str {
        match self {
            Metric::Rmse => "rmse",
            Metric::RelMse => "rel_mse",
            Metric::HdrFlip => "hdr_flip",
            Metric::MaxRelSe => "max_rel_se",
        }
    }

    /// Axis label, with the unit.
    pub fn axis_label(self) -> &'static str {
        match self {
            Metric::Rmse => "RMSE (linear radiance units)",
            Metric::RelMse => "relative MSE (dimensionless)",
            Metric::HdrFlip => "mean HDR-FLIP (0 = identical, 1 = worst)",
            Metric::MaxRelSe => "worst pixel's relative squared error (dimensionless)",
        }
    }

    /// Short name, for titles.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Rmse => "RMSE",
            Metric::RelMse => "relative MSE",
            Metric::HdrFlip => "HDR-FLIP",
            Metric::MaxRelSe => "worst-pixel error",
        }
    }

    pub fn title(self) -> &'static str {
        match self {
            Metric::Rmse => "RMSE against time",
            Metric::RelMse => "Relative MSE against time",
            Metric::HdrFlip => "HDR-FLIP against time",
            Metric::MaxRelSe => "Worst-pixel error against time",
        }
    }

    pub fn of(self, s: &Snapshot) -> f64 {
        match self {
            Metric::Rmse => s.rmse,
            Metric::RelMse => s.rel_mse,
            Metric::HdrFlip => s.hdr_flip,
            Metric::MaxRelSe => s.max_rel_se,
        }
    }
}

/// A line: its label and (time, value) points.
pub type Series = (String, Vec<(f64, f64)>);

/// The series of one metric: one per label, in first-appearance order, points with a
/// positive time and value (a log axis cannot show the others).
pub fn series(snapshots: &[Snapshot], metric: Metric) -> Vec<Series> {
    let mut out: Vec<Series> = Vec::new();
    for s in snapshots {
        let (t, v) = (s.time_s, metric.of(s));
        let i = match out.iter().position(|(l, _)| *l == s.label) {
            Some(i) => i,
            None => {
                out.push((s.label.clone(), Vec::new()));
                out.len() - 1
            }
        };
        if t > 0.0 && v > 0.0 && t.is_finite() && v.is_finite() {
            out[i].1.push((t, v));
        }
    }
    out
}

/// Writes `stem.png` and `stem.svg`.
pub fn draw(stem: &Path, snapshots: &[Snapshot], metric: Metric, subtitle: &str) -> Result<()> {
    ensure_font();
    let data = series(snapshots, metric);
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    {
        // Drawn into a buffer (plotters' own PNG encoder would pull in the `image` crate).
        let mut buf = vec![0u8; (W * H * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
            plot(&root, &data, metric, subtitle).map_err(|e| anyhow!("{}: {e}", png.display()))?;
            root.present().map_err(|e| anyhow!("{}: {e}", png.display()))?;
        }
        let px: Vec<glam::Vec3> = buf
            .chunks_exact(3)
            .map(|c| glam::Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 255.0)
            .collect();
        write_png(&png, W as usize, H as usize, &px)?;
    }
    {
        let root = SVGBackend::new(&svg, (W, H)).into_drawing_area();
        plot(&root, &data, metric, subtitle).map_err(|e| anyhow!("{}: {e}", svg.display()))?;
        root.present().map_err(|e| anyhow!("{}: {e}", svg.display()))?;
    }
    Ok(())
}

/// Enough distinct colours for the eight methods and a sweep (Tableau 10).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// A log range that holds `lo..hi`, widened to the nearest n × 10^k (n = 1 … 9) on each side so
/// that both ends carry a tick.
fn log_range(lo: f64, hi: f64) -> (f64, f64) {
    let (lo, hi) = if lo > 0.0 && hi >= lo { (lo, hi) } else { (0.1, 1.0) };
    let down = |v: f64| {
        let p = 10f64.powf(v.log10().floor());
        (v / p * (1.0 + 1e-9)).floor().max(1.0) * p
    };
    let up = |v: f64| {
        let p = 10f64.powf(v.log10().floor());
        (v / p * (1.0 - 1e-9)).ceil() * p
    };
    let (l, h) = (down(lo), up(hi));
    if h > l { (l, h) } else { (l / 2.0, h * 2.0) }
}

fn plot<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    data: &[Series],
    metric: Metric,
    subtitle: &str,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    // The legend gets its own panel on the right, so that it never hides a line.
    let (root, legend) = root.split_horizontally(W as i32 - LEGEND_W);
    let pts = data.iter().flat_map(|(_, p)| p.iter());
    let (mut t0, mut t1, mut v0, mut v1) = (f64::MAX, 0.0f64, f64::MAX, 0.0f64);
    for (t, v) in pts {
        t0 = t0.min(*t);
        t1 = t1.max(*t);
        v0 = v0.min(*v);
        v1 = v1.max(*v);
    }
    let (t0, t1) = log_range(t0, t1);
    let (v0, v1) = log_range(v0, v1);
    let title = format!("{} — {subtitle}", metric.title());
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 26))
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(95)
        .build_cartesian_2d(
            (t0..t1).log_scale().with_key_points(ticks(t0, t1)),
            (v0..v1).log_scale().with_key_points(ticks(v0, v1)),
        )?;
    chart
        .configure_mesh()
        .x_desc("wall-clock time (s), log scale")
        .y_desc(format!("{}, log scale", metric.axis_label()))
        .axis_desc_style(("sans-serif", 20))
        .label_style(("sans-serif", 16))
        .x_label_formatter(&|v| format_tick(*v))
        .y_label_formatter(&|v| format_tick(*v))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(200, 200, 200))
        .draw()?;
    for (i, (_, points)) in data.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let style = ShapeStyle::from(&colour).stroke_width(3);
        chart.draw_series(LineSeries::new(points.iter().copied(), style))?;
        chart.draw_series(points.iter().map(|p| Circle::new(*p, 4, colour.filled())))?;
    }
    draw_legend(&legend, data)
}

/// Tick positions of a log axis over [lo, hi]: 1, 2, 5 × 10^k, or every integer multiple of
/// 10^k when that gives fewer than three ticks; whole decades only over more than 4 decades.
pub fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let in_range = |mults: &[f64]| -> Vec<f64> {
        let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        (k0..=k1)
            .flat_map(|k| mults.iter().map(move |m| m * 10f64.powi(k)))
            .filter(|v| *v >= lo * (1.0 - 1e-9) && *v <= hi * (1.0 + 1e-9))
            .collect()
    };
    if (hi / lo).log10() > 4.0 {
        return in_range(&[1.0]);
    }
    let t = in_range(&[1.0, 2.0, 5.0]);
    if t.len() >= 3 { t } else { in_range(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]) }
}

/// Tick labels: plain numbers from 0.01 to 10⁴, otherwise scientific.
fn format_tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if (0.01..1e4).contains(&a) {
        let s = format!("{v:.2}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// The x-axis label of a swept parameter.
pub fn parameter_label(key: &str) -> String {
    match key {
        "alpha" => "α, exponent of the progressive schedule (dimensionless)".into(),
        "clamp" => "b (b₁), geometry-term clamp bound (1/length², log scale)".into(),
        "radius" => "r (r₁), virtual spherical light radius (scene units, log scale)".into(),
        other => other.to_string(),
    }
}

/// Writes `stem.png` and `stem.svg`: the final error of each swept line against the parameter
/// value, one line per method (`lines`: method name and (value, error) points). α is drawn on a
/// linear axis, clamp bounds and radii on a log axis; the error axis is always logarithmic.
pub fn draw_sweep(stem: &Path, lines: &[Series], key: &str, metric: Metric, subtitle: &str) -> Result<()> {
    ensure_font();
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    let mut buf = vec![0u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        plot_sweep(&root, lines, key, metric, subtitle).map_err(|e| anyhow!("{}: {e}", png.display()))?;
        root.present().map_err(|e| anyhow!("{}: {e}", png.display()))?;
    }
    let px: Vec<glam::Vec3> =
        buf.chunks_exact(3).map(|c| glam::Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 255.0).collect();
    write_png(&png, W as usize, H as usize, &px)?;
    let root = SVGBackend::new(&svg, (W, H)).into_drawing_area();
    plot_sweep(&root, lines, key, metric, subtitle).map_err(|e| anyhow!("{}: {e}", svg.display()))?;
    root.present().map_err(|e| anyhow!("{}: {e}", svg.display()))?;
    Ok(())
}

fn plot_sweep<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lines: &[Series],
    key: &str,
    metric: Metric,
    subtitle: &str,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let (area, legend) = root.split_horizontally(W as i32 - LEGEND_W);
    let (mut x0, mut x1, mut v0, mut v1) = (f64::MAX, f64::MIN, f64::MAX, 0.0f64);
    for (x, v) in lines.iter().flat_map(|(_, p)| p.iter()) {
        x0 = x0.min(*x);
        x1 = x1.max(*x);
        v0 = v0.min(*v);
        v1 = v1.max(*v);
    }
    let (v0, v1) = log_range(v0, v1);
    let title =
        format!("Final {} against {} — {subtitle}", metric.name(), if key == "alpha" { "α" } else { key });
    let mut builder = ChartBuilder::on(&area);
    builder.caption(title, ("sans-serif", 24)).margin(20).x_label_area_size(55).y_label_area_size(95);
    let y_desc = format!("final {}, log scale", metric.axis_label());
    let x_desc = parameter_label(key);
    macro_rules! finish {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .max_light_lines(4)
                .x_desc(x_desc.as_str())
                .y_desc(y_desc.as_str())
                .axis_desc_style(("sans-serif", 20))
                .label_style(("sans-serif", 16))
                .x_label_formatter(&|v| format_tick(*v))
                .y_label_formatter(&|v| format_tick(*v))
                .light_line_style(RGBColor(235, 235, 235))
                .bold_line_style(RGBColor(200, 200, 200))
                .draw()?;
            for (i, (_, points)) in lines.iter().enumerate() {
                let colour = PALETTE[i % PALETTE.len()];
                chart.draw_series(LineSeries::new(points.iter().copied(), colour.stroke_width(3)))?;
                chart.draw_series(points.iter().map(|p| Circle::new(*p, 5, colour.filled())))?;
            }
        }};
    }
    if key == "alpha" {
        let (a, b) = if x1 > x0 { (x0, x1) } else { (x0 - 0.1, x1 + 0.1) };
        let pad = 0.05 * (b - a);
        finish!(
            builder.build_cartesian_2d(
                (a - pad)..(b + pad),
                (v0..v1).log_scale().with_key_points(ticks(v0, v1))
            )?
        );
    } else {
        let (a, b) = log_range(x0, x1);
        finish!(builder.build_cartesian_2d(
            (a..b).log_scale().with_key_points(ticks(a, b)),
            (v0..v1).log_scale().with_key_points(ticks(v0, v1))
        )?);
    }
    draw_legend(&legend, lines)
}

fn draw_legend<DB: DrawingBackend>(
    legend: &DrawingArea<DB, Shift>,
    lines: &[Series],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    if lines.is_empty() {
        return Ok(());
    }
    legend.draw(&Text::new("lines", (8, 50), ("sans-serif", 19).into_font()))?;
    for (i, (label, _)) in lines.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let y = 90 + 30 * i as i32;
        legend.draw(&PathElement::new(vec![(8, y), (40, y)], colour.stroke_width(3)))?;
        legend.draw(&Circle::new((24, y), 4, colour.filled()))?;
        legend.draw(&Text::new(label.clone(), (48, y - 9), ("sans-serif", 17).into_font()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ranges_end_on_ticks_and_ticks_stay_inside() {
        let (lo, hi) = log_range(0.27, 1.3);
        assert!((lo - 0.2).abs() < 1e-12 && (hi - 2.0).abs() < 1e-12, "{lo} {hi}");
        let t = ticks(lo, hi);
        assert_eq!(t.first().copied(), Some(0.2));
        assert!(t.iter().all(|v| *v >= lo * 0.999 && *v <= hi * 1.001));
        assert!(t.len() >= 3);
        // Wide ranges: decades only.
        assert_eq!(ticks(1e-6, 1.0).len(), 7);
        assert_eq!(format_tick(0.5), "0.5");
        assert_eq!(format_tick(1e-3), "1e-3");
    }
}
