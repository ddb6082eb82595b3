//! Images in and out: linear RGB float images, EXR files with pir's metadata, sRGB PNG
//! previews, error metrics against a reference, all written atomically.

mod atomic;
mod exr_io;
mod metrics;
mod png_io;

pub use atomic::write_atomically;
pub use exr_io::{read_exr, write_exr};
pub use metrics::{Metrics, error_map, metrics};
pub use png_io::{write_png, write_preview};

use glam::Vec3;

/// A linear RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Vec3>,
}

impl RgbImage {
    pub fn new(width: usize, height: usize) -> Self {
        RgbImage { width, height, pixels: vec![Vec3::ZERO; width * height] }
    }

    pub fn get(&self, x: usize, y: usize) -> Vec3 {
        self.pixels[y * self.width + x]
    }

    /// Per-channel mean over all pixels (accumulated in f64).
    pub fn mean(&self) -> [f64; 3] {
        let mut s = [0.0f64; 3];
        for p in &self.pixels {
            s[0] += p.x as f64;
            s[1] += p.y as f64;
            s[2] += p.z as f64;
        }
        let n = self.pixels.len().max(1) as f64;
        [s[0] / n, s[1] / n, s[2] / n]
    }
}
