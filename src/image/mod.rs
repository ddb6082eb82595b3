//! Images in and out: linear RGB float images, EXR files with pir's metadata, Radiance HDR
//! files in, sRGB PNG
//! previews, error metrics against a reference, all written atomically.

mod atomic;
mod exr_io;
mod hdr_io;
mod metrics;
mod png_io;

pub use atomic::write_atomically;
pub use exr_io::{ReadExr, read_exr, read_exr_with_channels, write_exr, write_exr_with_channels};
pub use hdr_io::read_hdr;
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

    /// The image at 1/`factor` of the size, each pixel the mean of a `factor`×`factor` block.
    /// With pir's one-pixel box filter this is exactly the render at the smaller size, so a
    /// reference serves tests at lower resolutions. `None` if the size is not a multiple.
    pub fn downsample(&self, factor: usize) -> Option<RgbImage> {
        if factor == 0 || !self.width.is_multiple_of(factor) || !self.height.is_multiple_of(factor) {
            return None;
        }
        let (w, h) = (self.width / factor, self.height / factor);
        let mut out = RgbImage::new(w, h);
        let scale = 1.0 / (factor * factor) as f64;
        for y in 0..h {
            for x in 0..w {
                let mut s = glam::DVec3::ZERO;
                for dy in 0..factor {
                    for dx in 0..factor {
                        s += self.get(x * factor + dx, y * factor + dy).as_dvec3();
                    }
                }
                out.pixels[y * w + x] = (s * scale).as_vec3();
            }
        }
        Some(out)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsample_averages_blocks_and_keeps_the_mean() {
        let mut img = RgbImage::new(4, 2);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::splat(i as f32);
        }
        let d = img.downsample(2).unwrap();
        assert_eq!((d.width, d.height), (2, 1));
        assert_eq!(d.pixels, vec![Vec3::splat(2.5), Vec3::splat(4.5)]);
        assert_eq!(d.mean(), img.mean());
        assert!(img.downsample(3).is_none());
    }
}
