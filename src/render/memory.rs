//! The memory a render will need, estimated before anything large is allocated, so that an
//! absurd request (a huge resolution, millions of light paths) is refused with a message
//! instead of ending in an out-of-memory kill hours into a batch.
//!
//! The figures are upper estimates per item, from the sizes of pir's own structures: the film
//! (f64 sums and squares), the per-iteration sample buffers and the output encoding (the
//! image, the resumable state channels and the preview), the acceleration structure (pir's BVH
//! and Embree's medium-quality build measure below 128 bytes per triangle) and the VPLs of one
//! iteration (at most one per path segment).

use std::fmt;

/// Bytes per triangle allowed for the acceleration structure.
const ACCEL_PER_TRIANGLE: u64 = 128;
/// Bytes per VPL: the light itself, its prepared BSDF and its lanes (the gather's chunks,
/// and the resampled gather's pairs of chunks, which hold each lane twice: 88 bytes).
const PER_VPL: u64 = 384;

/// Estimated peak memory of a render, in bytes, by item.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Estimate {
    pub film: u64,
    pub buffers: u64,
    pub accel: u64,
    pub vpls: u64,
}

impl Estimate {
    /// `paths` light paths per iteration (0 for the path tracer) of up to `max_depth` vertices.
    pub fn new(width: u64, height: u64, triangles: u64, paths: u64, max_depth: u64) -> Estimate {
        let pixels = width.saturating_mul(height);
        Estimate {
            // Sums and sums of squares: two f64 triples per pixel.
            film: pixels.saturating_mul(48),
            // Tile results (f32 RGB), the mean image, its EXR channels with the state (f32 RGB +
            // twelve u32), the 8-bit preview and its f32 copy: 12 + 12 + 60 + 3 + 12 bytes.
            buffers: pixels.saturating_mul(99),
            accel: triangles.saturating_mul(ACCEL_PER_TRIANGLE),
            vpls: paths.saturating_mul(max_depth).saturating_mul(PER_VPL),
        }
    }

    pub fn total(&self) -> u64 {
        self.film.saturating_add(self.buffers).saturating_add(self.accel).saturating_add(self.vpls)
    }
}

fn gib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 30) as f64
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:.2} GiB (film {:.2}, image buffers {:.2}, acceleration structure {:.2}, VPLs {:.2})",
            gib(self.total()),
            gib(self.film),
            gib(self.buffers),
            gib(self.accel),
            gib(self.vpls)
        )
    }
}

/// This machine's total memory in bytes, from /proc/meminfo (`None` where it cannot be read).
pub fn total_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn estimate_grows_with_every_input_and_never_overflows() {
        let base = Estimate::new(512, 512, 1000, 32, 8);
        assert!(Estimate::new(1024, 512, 1000, 32, 8).total() > base.total());
        assert!(Estimate::new(512, 512, 2_000_000, 32, 8).total() > base.total());
        assert!(Estimate::new(512, 512, 1000, 1 << 20, 8).total() > base.total());
        assert_eq!(Estimate::new(u64::MAX, u64::MAX, u64::MAX, u64::MAX, u64::MAX).total(), u64::MAX);
        assert!(base.to_string().contains("GiB"));
    }
}
