//! Error metrics of an image against a reference, as used for every comparison in pir:
//! RMSE, relative MSE (mean over pixels and channels of (x − r)² / (r² + 0.01), the
//! definition of `shared/references/README.md`) and per-channel means.

use anyhow::{Result, bail};
use glam::Vec3;

use super::RgbImage;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    pub rmse: f64,
    pub rel_mse: f64,
    pub mean: [f64; 3],
    pub reference_mean: [f64; 3],
    /// Largest per-pixel relative squared error (mean over channels).
    pub max_rel_se: f64,
}

impl Metrics {
    /// Relative difference of the image's channel means to the reference's.
    pub fn mean_rel_diff(&self) -> [f64; 3] {
        std::array::from_fn(|c| (self.mean[c] - self.reference_mean[c]) / self.reference_mean[c])
    }
}

/// Relative squared error of one pixel, averaged over the channels.
pub fn rel_se(x: Vec3, r: Vec3) -> f64 {
    let mut s = 0.0;
    for c in 0..3 {
        let (x, r) = (x[c] as f64, r[c] as f64);
        s += (x - r) * (x - r) / (r * r + 0.01);
    }
    s / 3.0
}

pub fn metrics(img: &RgbImage, reference: &RgbImage) -> Result<Metrics> {
    if (img.width, img.height) != (reference.width, reference.height) {
        bail!(
            "image is {}×{} but the reference is {}×{}",
            img.width,
            img.height,
            reference.width,
            reference.height
        );
    }
    let (mut se, mut rel, mut max_rel) = (0.0f64, 0.0f64, 0.0f64);
    for (x, r) in img.pixels.iter().zip(&reference.pixels) {
        let d = (*x - *r).as_dvec3();
        se += d.length_squared() / 3.0;
        let e = rel_se(*x, *r);
        rel += e;
        max_rel = max_rel.max(e);
    }
    let n = img.pixels.len().max(1) as f64;
    Ok(Metrics {
        rmse: (se / n).sqrt(),
        rel_mse: rel / n,
        mean: img.mean(),
        reference_mean: reference.mean(),
        max_rel_se: max_rel,
    })
}

/// A false-colour map of the per-pixel relative error: log10 of the relative squared error
/// from `lo` to `hi` mapped through a dark-blue → red → yellow → white ramp.
pub fn error_map(img: &RgbImage, reference: &RgbImage, lo: f64, hi: f64) -> Vec<Vec3> {
    img.pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(x, r)| {
            let e = rel_se(*x, *r).max(1e-30).log10();
            heat(((e - lo) / (hi - lo)).clamp(0.0, 1.0) as f32)
        })
        .collect()
}

/// A perceptually ordered heat ramp on [0, 1].
fn heat(t: f32) -> Vec3 {
    const STOPS: [Vec3; 5] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.15, 0.0, 0.45),
        Vec3::new(0.85, 0.1, 0.1),
        Vec3::new(1.0, 0.8, 0.0),
        Vec3::new(1.0, 1.0, 1.0),
    ];
    let x = t * (STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    STOPS[i].lerp(STOPS[i + 1], x - i as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_of_known_images() {
        let mut a = RgbImage::new(2, 1);
        let mut b = RgbImage::new(2, 1);
        a.pixels = vec![Vec3::splat(1.0), Vec3::splat(0.0)];
        b.pixels = vec![Vec3::splat(0.0), Vec3::splat(0.0)];
        let m = metrics(&a, &b).unwrap();
        assert!((m.rmse - (0.5f64).sqrt()).abs() < 1e-12);
        assert!((m.rel_mse - 0.5 / 0.01).abs() < 1e-9);
        assert_eq!(m.mean, [0.5; 3]);
        let m = metrics(&a, &a).unwrap();
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert!(metrics(&a, &RgbImage::new(1, 2)).is_err());
    }
}
