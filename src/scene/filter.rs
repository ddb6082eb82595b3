//! The film's reconstruction filter, as Mitsuba 3's `rfilter` plugins define it: `box` (each
//! sample counts for its own pixel only: pir's default), `tent` of a `radius` (default 1), f(x) =
//! max(0, 1 − |x| / r), and `gaussian` of a `stddev` σ (default 0.5), cut off at r = 4σ,
//! f(x) = max(0, exp(−x² / 2σ²) − exp(−8)). Both are separable: f(x) f(y) of the offset from
//! the pixel's centre, in pixels.
//!
//! A pixel's value is the filter's weighted mean of the image around its centre,
//! ∫ f L / ∫ f over the image, which Mitsuba estimates by splatting every sample into the pixels
//! within the radius and dividing by the sum of the weights. pir estimates the same integral
//! per iteration with the one sample of every pixel around it, divided by the expected sum of
//! the weights (the integral of f over the image: exactly the sum's mean, since each pixel's
//! sample is uniform over it), so that each iteration is unbiased and the running mean of the
//! film stays a plain mean ([`crate::render`]'s driver does the splatting, in a fixed order).

/// A reconstruction filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    Box,
    Tent { radius: f32 },
    Gaussian { stddev: f32 },
}

impl Filter {
    /// The filter's 1D profile at offset `x` (pixels); 0 beyond the radius.
    #[inline]
    pub fn eval(&self, x: f32) -> f32 {
        match *self {
            Filter::Box => {
                if x.abs() <= 0.5 {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Tent { radius } => (1.0 - x.abs() / radius).max(0.0),
            Filter::Gaussian { stddev } => {
                if x.abs() >= 4.0 * stddev {
                    0.0
                } else {
                    ((-x * x / (2.0 * stddev * stddev)).exp() - (-8.0f32).exp()).max(0.0)
                }
            }
        }
    }

    /// The radius beyond which the filter is zero.
    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Box => 0.5,
            Filter::Tent { radius } => radius,
            Filter::Gaussian { stddev } => 4.0 * stddev,
        }
    }

    /// How many pixels on each side a sample reaches: a pixel gathers the samples of the
    /// pixels within this distance (in whole pixels) of its own (a sample lies within ½ of its
    /// pixel's centre, so pixel j reaches pixel p when |j − p| − ½ < r).
    pub fn reach(&self) -> usize {
        ((self.radius() + 0.5).ceil() as usize).saturating_sub(1)
    }

    /// ∫ f(x − c) dx over [0, n], c the centre of pixel `i` (i + ½): the expected sum of the
    /// weights a pixel gathers along one axis of an image `n` pixels wide.
    pub fn coverage(&self, i: usize, n: usize) -> f64 {
        let c = i as f64 + 0.5;
        let r = self.radius() as f64;
        let (a, b) = ((c - r).max(0.0), (c + r).min(n as f64));
        // Midpoint rule, fine enough that the error is below f32's resolution of the result.
        let steps = 4096;
        let h = (b - a) / steps as f64;
        (0..steps).map(|k| self.eval((a + (k as f64 + 0.5) * h - c) as f32) as f64).sum::<f64>() * h
    }

    /// Mitsuba's name for it.
    pub fn name(&self) -> &'static str {
        match self {
            Filter::Box => "box",
            Filter::Tent { .. } => "tent",
            Filter::Gaussian { .. } => "gaussian",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Away from the image's edges the tent covers r (its integral), the Gaussian σ√(2π) less
    /// its cut-off pedestal; at an edge, the part inside.
    #[test]
    fn coverage() {
        let t = Filter::Tent { radius: 1.0 };
        assert!((t.coverage(10, 100) - 1.0).abs() < 1e-6);
        // Pixel 0's centre is ½ from the edge: ∫_{−½}^{1} of the tent = 1 − 1/8.
        assert!((t.coverage(0, 100) - 0.875).abs() < 1e-6);
        let g = Filter::Gaussian { stddev: 0.5 };
        let full =
            0.5 * (2.0 * std::f64::consts::PI).sqrt() * libm_erf(4.0 / 2f64.sqrt()) - 4.0 * (-8f64).exp();
        assert!((g.coverage(50, 100) - full).abs() < 1e-5, "{} vs {full}", g.coverage(50, 100));
        assert_eq!(t.reach(), 1);
        assert_eq!(Filter::Box.reach(), 0);
        assert_eq!(g.reach(), 2);
    }

    /// erf for the test (Abramowitz & Stegun 7.1.26, 1.5e-7).
    fn libm_erf(x: f64) -> f64 {
        let t = 1.0 / (1.0 + 0.3275911 * x);
        1.0 - (((((1.061405429 * t - 1.453152027) * t) + 1.421413741) * t - 0.284496736) * t + 0.254829592)
            * t
            * (-x * x).exp()
    }
}
