//! The image sheet of a study: one row per run (and one for the reference) with the final
//! image, a nearest-neighbour enlargement of the hardest region, and the false-colour map of
//! the per-pixel relative squared error (`pir::image::error_map`, log10 from −5 to 0).
//!
//! The hardest region is the window (a quarter of the width and height) with the largest
//! relative squared error summed over all runs, searched on a grid of half-window steps.

use anyhow::{Result, anyhow};
use glam::Vec3;
use plotters::prelude::*;
use std::path::Path;

use super::RunResult;
use crate::image::{RgbImage, error_map, write_png};

/// Relative squared error of a pixel, as in `pir::image::metrics` (mean over channels of
/// (x − r)² / (r² + 0.01)).
fn rel_se(x: Vec3, r: Vec3) -> f64 {
    (0..3)
        .map(|c| {
            let (x, r) = (x[c] as f64, r[c] as f64);
            (x - r) * (x - r) / (r * r + 0.01)
        })
        .sum::<f64>()
        / 3.0
}

/// A window of the image, in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Region {
    pub x: usize,
    pub y: usize,
    pub width: usize,
    pub height: usize,
}

/// The window of a quarter of each side with the largest error summed over `images`.
pub fn hardest_region(images: &[&RgbImage], reference: &RgbImage) -> Region {
    let (w, h) = (reference.width, reference.height);
    let (cw, ch) = ((w / 4).max(1), (h / 4).max(1));
    let mut err = vec![0.0f64; w * h];
    for img in images {
        for (e, (x, r)) in err.iter_mut().zip(img.pixels.iter().zip(&reference.pixels)) {
            let v = rel_se(*x, *r);
            if v.is_finite() {
                *e += v;
            }
        }
    }
    // Summed-area table for O(1) window sums.
    let mut sat = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        for x in 0..w {
            sat[(y + 1) * (w + 1) + x + 1] =
                err[y * w + x] + sat[y * (w + 1) + x + 1] + sat[(y + 1) * (w + 1) + x] - sat[y * (w + 1) + x];
        }
    }
    let sum = |x: usize, y: usize| {
        let (x1, y1) = (x + cw, y + ch);
        sat[y1 * (w + 1) + x1] - sat[y * (w + 1) + x1] - sat[y1 * (w + 1) + x] + sat[y * (w + 1) + x]
    };
    let (sx, sy) = ((cw / 2).max(1), (ch / 2).max(1));
    let mut best = (f64::MIN, 0, 0);
    let mut y = 0;
    while y + ch <= h {
        let mut x = 0;
        while x + cw <= w {
            let s = sum(x, y);
            if s > best.0 {
                best = (s, x, y);
            }
            x += sx;
        }
        y += sy;
    }
    Region { x: best.1, y: best.2, width: cw, height: ch }
}

fn srgb(v: f32) -> f32 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

fn preview(img: &RgbImage) -> Vec<Vec3> {
    img.pixels.iter().map(|p| Vec3::new(srgb(p.x), srgb(p.y), srgb(p.z))).collect()
}

const LABEL: usize = 30;
const MIN_PANEL: usize = 256;
const GAP: usize = 8;

/// Writes the sheet as a PNG; returns the region that was enlarged.
pub fn write_sheet(path: &Path, results: &[RunResult], reference: &RgbImage) -> Result<Region> {
    let (w, h) = (reference.width, reference.height);
    let images: Vec<&RgbImage> = results.iter().map(|r| &r.image).collect();
    let region = hardest_region(&images, reference);
    let zoom = (w / region.width).min(h / region.height).max(1);
    // Small images are enlarged (nearest-neighbour, integer factors) towards MIN_PANEL wide.
    let s = (MIN_PANEL / w).max(1);
    let (pw, ph) = (w * s, h * s);
    let rows = results.len() + 1;
    let (sw, sh) = (3 * pw + 4 * GAP, LABEL + rows * (ph + LABEL + GAP));
    let mut px = vec![Vec3::ONE; sw * sh];
    let mut blit = |x0: usize, y0: usize, bw: usize, bh: usize, src: &dyn Fn(usize, usize) -> Vec3| {
        for y in 0..bh {
            for x in 0..bw {
                px[(y0 + y) * sw + x0 + x] = src(x, y);
            }
        }
    };
    let mut labels: Vec<(usize, usize, String)> = vec![
        (GAP, 6, "final image (box: crop)".into()),
        (2 * GAP + pw, 6, format!("hardest region, ×{}", zoom * s)),
        (3 * GAP + 2 * pw, 6, "rel. sq. error 1e-5 … 1".into()),
    ];
    for row in 0..rows {
        let (img, name) = if row == 0 {
            (reference, "reference".to_string())
        } else {
            let r = &results[row - 1];
            let last = r.snapshots.last();
            let detail = last.map_or(String::new(), |s| {
                format!(
                    ": {} it, {:.2} s, relMSE {:.3e}, HDR-FLIP {:.4}",
                    s.iterations, s.time_s, s.rel_mse, s.hdr_flip
                )
            });
            (&r.image, format!("{}{detail}", r.run.label))
        };
        let y0 = LABEL + row * (ph + LABEL + GAP) + LABEL;
        labels.push((GAP, y0 - LABEL + 6, name));
        let pre = preview(img);
        let (x1, y1) = (region.x + region.width - 1, region.y + region.height - 1);
        let outline = |x: usize, y: usize| {
            let in_x = (region.x..=x1).contains(&x);
            let in_y = (region.y..=y1).contains(&y);
            (in_x && (y == region.y || y == y1)) || (in_y && (x == region.x || x == x1))
        };
        blit(GAP, y0, pw, ph, &|x, y| {
            let (x, y) = (x / s, y / s);
            if outline(x, y) { Vec3::new(0.0, 1.0, 0.0) } else { pre[y * w + x] }
        });
        let z = zoom * s;
        blit(2 * GAP + pw, y0, region.width * z, region.height * z, &|x, y| {
            pre[(region.y + y / z) * w + region.x + x / z]
        });
        if row > 0 {
            let map = error_map(img, reference, -5.0, 0.0);
            blit(3 * GAP + 2 * pw, y0, pw, ph, &|x, y| map[(y / s) * w + x / s]);
        }
    }
    // Labels, drawn with plotters on the 8-bit buffer.
    let mut bytes: Vec<u8> =
        px.iter().flat_map(|p| [p.x, p.y, p.z].map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)).collect();
    {
        super::chart::ensure_font();
        let root = BitMapBackend::with_buffer(&mut bytes, (sw as u32, sh as u32)).into_drawing_area();
        for (x, y, text) in &labels {
            root.draw_text(text, &("sans-serif", 18).into_font().color(&BLACK), (*x as i32, *y as i32))
                .map_err(|e| anyhow!("{}: {e}", path.display()))?;
        }
        root.present().map_err(|e| anyhow!("{}: {e}", path.display()))?;
    }
    let px: Vec<Vec3> =
        bytes.chunks_exact(3).map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 255.0).collect();
    write_png(path, sw, sh, &px)?;
    Ok(region)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hardest_region_holds_the_error() {
        let reference = RgbImage::new(64, 64);
        let mut img = reference.clone();
        for y in 40..48 {
            for x in 8..16 {
                img.pixels[y * 64 + x] = Vec3::ONE;
            }
        }
        let r = hardest_region(&[&img], &reference);
        assert_eq!((r.width, r.height), (16, 16));
        assert!(r.x <= 8 && r.x + r.width >= 16 && r.y <= 40 && r.y + r.height >= 48, "{r:?}");
    }
}
