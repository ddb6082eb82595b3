//! A counter-based random number generator.
//!
//! A [`Sampler`] is positioned by `(seed, iteration, domain, index)`; its `d`-th draw is a hash
//! of that key and `d` (SplitMix64's output function applied to `key + (d+1)·γ`). Nothing depends
//! on which thread runs a pixel or in which order, so the same seed gives the same image for any
//! thread count, and any sample can be replayed on its own.

/// What a stream of random numbers is for; keeps camera paths and light paths of the same
/// index independent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u64)]
pub enum Domain {
    /// One camera sample; the index is the pixel's `y * width + x`.
    Camera = 1,
    /// One light path (VPL tracing); the index is the path's number in the iteration.
    LightPath = 2,
    /// Per-iteration choices shared by the whole image.
    Iteration = 3,
}

const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[derive(Clone, Debug)]
pub struct Sampler {
    key: u64,
    dim: u64,
}

/// The samplers of one `(seed, iteration, domain)`, with the part of the key they share
/// hashed once: [`Streams::sampler`] of `index` is `Sampler::new(seed, iteration, domain,
/// index)`, for a loop over many indices (the pixels of an iteration).
#[derive(Clone, Copy, Debug)]
pub struct Streams {
    prefix: u64,
}

impl Streams {
    pub fn new(seed: u64, iteration: u64, domain: Domain) -> Self {
        let k = mix64(seed ^ GAMMA);
        let k = mix64(k ^ iteration.wrapping_mul(0xD6E8_FEB8_6659_FD93));
        Streams { prefix: mix64(k ^ (domain as u64).wrapping_mul(0xA076_1D64_78BD_642F)) }
    }

    /// The sampler of stream `index`.
    #[inline]
    pub fn sampler(&self, index: u64) -> Sampler {
        Sampler { key: mix64(self.prefix ^ index.wrapping_mul(0xE703_7ED1_A0B4_28DB)), dim: 0 }
    }
}

impl Sampler {
    pub fn new(seed: u64, iteration: u64, domain: Domain, index: u64) -> Self {
        Streams::new(seed, iteration, domain).sampler(index)
    }

    /// The number of dimensions drawn so far.
    pub fn dimension(&self) -> u64 {
        self.dim
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.dim += 1;
        mix64(self.key.wrapping_add(self.dim.wrapping_mul(GAMMA)))
    }

    /// A uniform number in `[0, 1)` with 24 random bits.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    #[inline]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.next_f32(), self.next_f32())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_key_same_stream_and_keys_are_independent() {
        let a: Vec<u64> = (0..8)
            .map({
                let mut s = Sampler::new(7, 3, Domain::Camera, 42);
                move |_| s.next_u64()
            })
            .collect();
        let mut s = Sampler::new(7, 3, Domain::Camera, 42);
        let b: Vec<u64> = (0..8).map(|_| s.next_u64()).collect();
        assert_eq!(a, b);
        for other in [
            Sampler::new(8, 3, Domain::Camera, 42),
            Sampler::new(7, 4, Domain::Camera, 42),
            Sampler::new(7, 3, Domain::LightPath, 42),
            Sampler::new(7, 3, Domain::Camera, 43),
        ] {
            let mut o = other;
            assert_ne!(o.next_u64(), a[0]);
        }
    }

    #[test]
    fn streams_are_the_samplers_of_their_key() {
        let streams = Streams::new(7, 3, Domain::Camera);
        for index in [0, 1, 42, u64::MAX] {
            let (mut a, mut b) = (streams.sampler(index), Sampler::new(7, 3, Domain::Camera, index));
            assert_eq!([a.next_u64(), a.next_u64()], [b.next_u64(), b.next_u64()]);
        }
    }

    #[test]
    fn uniform_moments() {
        let mut s = Sampler::new(1, 1, Domain::Camera, 0);
        let n = 200_000;
        let (mut m1, mut m2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let x = s.next_f32() as f64;
            assert!((0.0..1.0).contains(&x));
            m1 += x;
            m2 += x * x;
        }
        m1 /= n as f64;
        m2 /= n as f64;
        // Standard errors: 1/sqrt(12 n) ≈ 6.5e-4 for the mean; 5 sigma bounds.
        assert!((m1 - 0.5).abs() < 5.0 * 6.5e-4, "mean {m1}");
        assert!((m2 - 1.0 / 3.0).abs() < 5.0 * 6.7e-4, "second moment {m2}");
    }
}
