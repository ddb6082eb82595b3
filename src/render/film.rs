//! The film: per-pixel sums of the iterations' samples and of their squares (in f64, so that
//! long renders lose no precision) and the number of iterations. The image is the running
//! mean; the squares give each pixel's sample variance, hence error estimates without a
//! reference.

use glam::{DVec3, Vec3};

use crate::image::RgbImage;

#[derive(Clone, Debug)]
pub struct Film {
    pub width: usize,
    pub height: usize,
    sum: Vec<DVec3>,
    sum_sq: Vec<DVec3>,
    iterations: u64,
}

impl Film {
    pub fn new(width: usize, height: usize) -> Self {
        Film {
            width,
            height,
            sum: vec![DVec3::ZERO; width * height],
            sum_sq: vec![DVec3::ZERO; width * height],
            iterations: 0,
        }
    }

    pub fn iterations(&self) -> u64 {
        self.iterations
    }

    /// Adds one sample to pixel `index` (the caller has checked that it is finite).
    #[inline]
    pub fn add(&mut self, index: usize, value: Vec3) {
        let v = value.as_dvec3();
        self.sum[index] += v;
        self.sum_sq[index] += v * v;
    }

    /// Marks one more iteration as complete.
    pub fn end_iteration(&mut self) {
        self.iterations += 1;
    }

    /// The running mean over the completed iterations.
    pub fn image(&self) -> RgbImage {
        let scale = 1.0 / self.iterations.max(1) as f64;
        RgbImage {
            width: self.width,
            height: self.height,
            pixels: self.sum.iter().map(|s| (*s * scale).as_vec3()).collect(),
        }
    }

    /// Per-pixel sums of the samples, row-major.
    pub fn sums(&self) -> &[DVec3] {
        &self.sum
    }

    /// Per-pixel sums of the squared samples, row-major.
    pub fn sums_of_squares(&self) -> &[DVec3] {
        &self.sum_sq
    }

    /// A film from its parts (a resumed or merged render). `None` if the sizes disagree.
    pub fn from_parts(
        width: usize,
        height: usize,
        sum: Vec<DVec3>,
        sum_sq: Vec<DVec3>,
        iterations: u64,
    ) -> Option<Film> {
        let n = width.checked_mul(height)?;
        (sum.len() == n && sum_sq.len() == n).then_some(Film { width, height, sum, sum_sq, iterations })
    }

    /// Adds another film of the same size (other iterations of the same render): sums and
    /// iteration counts add up. `false` (and no change) if the sizes differ.
    pub fn merge(&mut self, other: &Film) -> bool {
        if (self.width, self.height) != (other.width, other.height) {
            return false;
        }
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            *a += *b;
        }
        for (a, b) in self.sum_sq.iter_mut().zip(&other.sum_sq) {
            *a += *b;
        }
        self.iterations += other.iterations;
        true
    }

    /// Per-channel unbiased sample variance of one sample of each pixel (zero before two
    /// iterations). With independent iterations (`--sampler independent`) the variance of
    /// the pixel's mean is this divided by the iterations; the Sobol sampler's samples are
    /// stratified over the iterations, and its mean's variance is lower than that.
    pub fn sample_variance(&self) -> Vec<DVec3> {
        let n = self.iterations as f64;
        if n < 2.0 {
            return vec![DVec3::ZERO; self.sum.len()];
        }
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| ((*q - *s * *s / n) / (n - 1.0)).max(DVec3::ZERO))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_variance_of_known_samples() {
        let mut f = Film::new(1, 1);
        for v in [1.0f32, 2.0, 3.0, 6.0] {
            f.add(0, Vec3::splat(v));
            f.end_iteration();
        }
        assert_eq!(f.image().pixels[0], Vec3::splat(3.0));
        // Sample variance of {1, 2, 3, 6}: (4 + 1 + 0 + 9) / 3.
        assert!((f.sample_variance()[0].x - 14.0 / 3.0).abs() < 1e-12);
    }
}
