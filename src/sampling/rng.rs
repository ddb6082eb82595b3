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
    /// The acceptance of a light path's VPLs by their estimated contribution to the image
    /// ([`crate::integrator::many_light::importance`]); the index is the path's number.
    Acceptance = 4,
}

use super::sobol;

const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Which numbers the camera and light-path samplers of a render draw (`--sampler`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SamplerKind {
    /// Shuffled, randomly shifted Sobol points (see `sampling/sobol.rs`): each pixel's samples over
    /// the iterations, and each iteration's light paths, are stratified in every pair of
    /// dimensions.
    #[default]
    Sobol,
    /// Independent uniform numbers: every draw a hash of its key and dimension.
    Independent,
}

impl SamplerKind {
    /// The `--sampler` name.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Sobol => "sobol",
            SamplerKind::Independent => "independent",
        }
    }
}

impl std::str::FromStr for SamplerKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "sobol" => Ok(SamplerKind::Sobol),
            "independent" => Ok(SamplerKind::Independent),
            _ => Err(format!("unknown sampler {s:?} (expected sobol or independent)")),
        }
    }
}

/// A stream of numbers in `[0, 1)`, drawn one dimension at a time.
///
/// The `d`-th draw hashes the key and `d`. An independent sampler returns that hash; a Sobol
/// sampler uses it as the seed of the scrambled Sobol sequence whose point number `index` it
/// returns ([`Sampler::next_2d`] takes both coordinates of one point, one dimension).
/// [`Sampler::next_u64`] is always the hash. A camera sampler's first dimensions take their
/// unshifted points from its iteration's table ([`Streams::camera`]) and only shift them.
#[derive(Clone, Debug)]
pub struct Sampler<'a> {
    key: u64,
    dim: u64,
    /// The point's number in the Sobol sequence, bit-reversed, when `sobol`.
    index: u32,
    sobol: bool,
    /// Unshifted points of the first dimensions, shared by the samplers of a [`Streams`].
    table: &'a [[u32; 2]],
}

/// The samplers of one `(seed, iteration, domain)`, with the part of the key they share
/// hashed once: [`Streams::sampler`] of `index` is `Sampler::new(seed, iteration, domain,
/// index)`, for a loop over many indices (the pixels of an iteration).
#[derive(Clone, Debug)]
pub struct Streams {
    prefix: u64,
    sequence: Sequence,
    /// Camera streams with Sobol points: the unshifted points of the first [`TABLE_DIMS`]
    /// dimensions at this iteration's index, the same for every pixel.
    table: Vec<[u32; 2]>,
}

/// Dimensions whose Sobol points a camera [`Streams`] computes once per iteration: more than
/// a path of `max_depth` 8 draws in `pt` (two a vertex, and the camera's). Later dimensions are
/// computed draw by draw.
const TABLE_DIMS: usize = 48;

/// What a [`Streams`]' Sobol sequence runs over.
#[derive(Clone, Copy, Debug)]
enum Sequence {
    /// Independent samplers.
    None,
    /// Over the iterations: every index has its own scrambles, and this is its point number.
    Fixed(u32),
    /// Over the indices: one set of scrambles, the index is the point number.
    Index,
}

impl Streams {
    /// Independent samplers: [`Streams::sampler`] of `index` is `Sampler::new(seed, iteration,
    /// domain, index)`.
    pub fn new(seed: u64, iteration: u64, domain: Domain) -> Self {
        let k = mix64(seed ^ GAMMA);
        let k = mix64(k ^ iteration.wrapping_mul(0xD6E8_FEB8_6659_FD93));
        Streams {
            prefix: mix64(k ^ (domain as u64).wrapping_mul(0xA076_1D64_78BD_642F)),
            sequence: Sequence::None,
            table: Vec::new(),
        }
    }

    /// The camera samplers of a render's iteration (numbered from 1), one per pixel (the
    /// index). With [`SamplerKind::Sobol`] the sequence runs over the iterations, with
    /// shifts of its own for every pixel: a pixel's samples are stratified over the
    /// iterations, and pixels are independent of each other.
    pub fn camera(kind: SamplerKind, seed: u64, iteration: u64) -> Self {
        match kind {
            SamplerKind::Independent => Streams::new(seed, iteration, Domain::Camera),
            SamplerKind::Sobol => {
                // Iteration u64::MAX is never rendered: these keys are not any independent
                // sampler's.
                let prefix = Streams::new(seed, u64::MAX, Domain::Camera).prefix;
                let rindex = (iteration.wrapping_sub(1) as u32).reverse_bits();
                // The first dimensions' shuffles are per dimension, shared by the pixels, so
                // their points are computed here once; each pixel's own shifts keep the pixels
                // independent (a pixel's error is a function of its shifts alone, for any
                // shuffle).
                let table = (1..=TABLE_DIMS as u64)
                    .map(|d| {
                        sobol::shuffled_2d(rindex, sobol::shuffle_seed(mix64(prefix ^ d.wrapping_mul(GAMMA))))
                    })
                    .collect();
                Streams { prefix, sequence: Sequence::Fixed(rindex), table }
            }
        }
    }

    /// The light-path samplers of a render's iteration (numbered from 1), one per path (the
    /// index). With [`SamplerKind::Sobol`] the sequence runs over the iteration's paths, with
    /// scrambles of the iteration: the paths of an iteration are stratified (an aligned block
    /// when their number is a power of two), and iterations are independent of each other.
    ///
    /// Independent iterations are what the consistency argument of the progressive methods
    /// needs: each iteration's VPLs give an unbiased estimate of its own kernel, with a
    /// variance that grows like b_i, and the variance of the mean of independent iterations
    /// falls. One sequence over all the render's paths stratifies several iterations
    /// together and measured lower error still (`docs/sampling.md`), but its iterations are
    /// dependent, and with the unbounded 1/d² kernel in the limit we have no argument that
    /// its error vanishes.
    pub fn light_paths(kind: SamplerKind, seed: u64, iteration: u64) -> Self {
        let streams = Streams::new(seed, iteration, Domain::LightPath);
        match kind {
            SamplerKind::Independent => streams,
            SamplerKind::Sobol => Streams { sequence: Sequence::Index, ..streams },
        }
    }

    /// The key of stream `index`: its own hash of the shared prefix.
    #[inline]
    fn key(&self, index: u64) -> u64 {
        mix64(self.prefix ^ index.wrapping_mul(0xE703_7ED1_A0B4_28DB))
    }

    /// The sampler of stream `index`.
    #[inline]
    pub fn sampler(&self, index: u64) -> Sampler<'_> {
        let key = self.key(index);
        let table = &self.table[..];
        match self.sequence {
            Sequence::None => Sampler { key, dim: 0, index: 0, sobol: false, table },
            Sequence::Fixed(rindex) => Sampler { key, dim: 0, index: rindex, sobol: true, table },
            Sequence::Index => {
                let index = (index as u32).reverse_bits();
                Sampler { key: self.prefix, dim: 0, index, sobol: true, table }
            }
        }
    }
}

impl Sampler<'static> {
    /// An independent sampler.
    pub fn new(seed: u64, iteration: u64, domain: Domain, index: u64) -> Self {
        let key = Streams::new(seed, iteration, domain).key(index);
        Sampler { key, dim: 0, index: 0, sobol: false, table: &[] }
    }
}

impl Sampler<'_> {
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
        let h = self.next_u64();
        if self.sobol {
            match self.table.get(self.dim as usize - 1) {
                Some(&p) => sobol::shifted_1d(p, h),
                None => sobol::point_1d(self.index, h),
            }
        } else {
            (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
        }
    }

    /// A uniform point in `[0, 1)²`: two dimensions of an independent sampler, one of a Sobol
    /// sampler.
    #[inline]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        if self.sobol {
            let h = self.next_u64();
            glam::Vec2::from(match self.table.get(self.dim as usize - 1) {
                Some(&p) => sobol::shifted(p, h),
                None => sobol::point_2d(self.index, h),
            })
        } else {
            glam::Vec2::new(self.next_f32(), self.next_f32())
        }
    }

    /// `n` points of one dimension that are stratified among themselves as well as over the
    /// iterations: with Sobol points, the sample's own block of `n` consecutive points of the
    /// dimension's sequence, point `index · n + j` for the j-th, so that the blocks of the
    /// first iterations together are the sequence's first points (and a block of a power of
    /// two is an aligned one, a net of its own); independent points otherwise. For several
    /// samples taken at one vertex (next-event estimation's light samples), where a dimension
    /// per sample would stratify each over the iterations only. One point is
    /// [`Sampler::next_2d`]'s. The points are computed as the block is read.
    ///
    /// The blocks must tile the sequence: a block of `n` points taken from an aligned block
    /// of the next power of two leaves the same points of every block out, and under a
    /// pixel's fixed scramble those lie in the same part of the square at every iteration,
    /// so that the pixel never converges (measured: `docs/sampling.md`).
    pub fn next_2d_block(&mut self, n: u32) -> Block {
        let (one, h) = if n == 1 { (Some(self.next_2d()), 0) } else { (None, self.next_u64()) };
        let first = self.index.reverse_bits().wrapping_mul(n);
        Block { one, h, first, sobol: self.sobol, next: 0, n }
    }
}

/// The points of [`Sampler::next_2d_block`], in order.
#[derive(Clone, Debug)]
pub struct Block {
    /// A block of one: [`Sampler::next_2d`]'s point.
    one: Option<glam::Vec2>,
    /// The dimension's hash: the Sobol points' shuffle and shifts, or the independent
    /// points' key.
    h: u64,
    /// The number of the block's first point in the sequence.
    first: u32,
    sobol: bool,
    next: u32,
    n: u32,
}

impl Iterator for Block {
    type Item = glam::Vec2;

    #[inline]
    fn next(&mut self) -> Option<glam::Vec2> {
        if self.next >= self.n {
            return None;
        }
        let j = self.next;
        self.next += 1;
        if let Some(p) = self.one {
            return Some(p);
        }
        Some(if self.sobol {
            // Point `first + j`, given reversed. (The shuffle is the sample's own, for any
            // dimension.)
            let rindex = self.first.wrapping_add(j).reverse_bits();
            glam::Vec2::from(sobol::point_2d(rindex, self.h))
        } else {
            let x = mix64(self.h ^ (j as u64 + 1).wrapping_mul(GAMMA));
            let unit = |bits: u64| (bits & 0xFF_FFFF) as f32 * (1.0 / (1u64 << 24) as f32);
            glam::Vec2::new(unit(x >> 40), unit(x >> 8))
        })
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

    /// Whether the 2^k points of `p` fall one in each cell of every 2^a × 2^(k−a) grid.
    fn is_net(p: &[glam::Vec2]) -> bool {
        let k = p.len().trailing_zeros();
        (0..=k).all(|a| {
            let (nx, ny) = (1usize << a, 1usize << (k - a));
            let mut seen = vec![false; p.len()];
            p.iter().all(|q| {
                !std::mem::replace(
                    &mut seen[(q.x * nx as f32) as usize + nx * (q.y * ny as f32) as usize],
                    true,
                )
            })
        })
    }

    #[test]
    fn sobol_streams_stratify_what_they_say() {
        // Camera: one pixel's draws of one dimension over iterations 1..=64 form a net (and
        // 65..=128 another); pixels differ. Light paths: the 64 paths of an iteration do;
        // iterations differ. Independent streams do not stratify.
        for dim in 0..3 {
            let draw = |mut s: Sampler| {
                for _ in 0..dim {
                    s.next_2d();
                }
                s.next_2d()
            };
            for block in [0u64, 1] {
                let camera: Vec<_> = (1..=64)
                    .map(|i| draw(Streams::camera(SamplerKind::Sobol, 5, 64 * block + i).sampler(7)))
                    .collect();
                assert!(is_net(&camera), "camera, dim {dim}, block {block}");
            }
            let paths = |it| -> Vec<_> {
                let s = Streams::light_paths(SamplerKind::Sobol, 5, it);
                (0..64).map(|k| draw(s.sampler(k))).collect()
            };
            assert!(is_net(&paths(3)), "light paths, dim {dim}");
            assert_ne!(paths(3), paths(4));
            let other_pixel = draw(Streams::camera(SamplerKind::Sobol, 5, 1).sampler(8));
            assert_ne!(other_pixel, draw(Streams::camera(SamplerKind::Sobol, 5, 1).sampler(7)));
            let independent: Vec<_> =
                (1..=64).map(|i| draw(Streams::camera(SamplerKind::Independent, 5, i).sampler(7))).collect();
            assert!(!is_net(&independent));
        }
        // Independent streams are the plain samplers.
        let independent = Streams::camera(SamplerKind::Independent, 5, 2);
        let (mut a, mut b) = (independent.sampler(3), Sampler::new(5, 2, Domain::Camera, 3));
        assert_eq!([a.next_u64(), a.next_u64()], [b.next_u64(), b.next_u64()]);
    }

    /// A pixel's blocks of four over its first 16 iterations are the 64 first points of the
    /// dimension's sequence (a net), and each block alone is one too; after other draws, at
    /// the table's last dimension and beyond it; blocks of three tile the sequence as well.
    /// Independent samplers give distinct points.
    #[test]
    fn blocks_of_points_stratify_within_and_across_iterations() {
        for (before, n) in [(0, 4), (3, 4), (TABLE_DIMS - 1, 4), (TABLE_DIMS + 5, 4), (2, 3)] {
            let block = |kind, i| {
                let streams = Streams::camera(kind, 5, i);
                let mut s = streams.sampler(7);
                for _ in 0..before {
                    s.next_f32();
                }
                let out: Vec<_> = s.next_2d_block(n as u32).collect();
                assert_eq!(s.dimension(), before as u64 + 1);
                out
            };
            if n == 4 {
                let first: Vec<_> = (1..=16).flat_map(|i| block(SamplerKind::Sobol, i)).collect();
                assert!(is_net(&first), "{before} draws before");
                assert!((1..=16).all(|i| is_net(&block(SamplerKind::Sobol, i))));
                let next: Vec<_> = (17..=32).flat_map(|i| block(SamplerKind::Sobol, i)).collect();
                assert!(is_net(&next) && next != first);
            } else {
                // Blocks of three tile the sequence too: those of the first 64 iterations are
                // its 192 first points, 128 and then 64 of them nets. (Three points of aligned
                // blocks of four left the fourth point of every block out: no net.)
                let all: Vec<_> = (1..=64).flat_map(|i| block(SamplerKind::Sobol, i)).collect();
                assert_eq!(all.len(), 192);
                assert!(is_net(&all[..128]) && is_net(&all[128..]), "{before} draws before");
                assert!(
                    all.iter().all(|p| p.cmpge(glam::Vec2::ZERO).all() && p.cmplt(glam::Vec2::ONE).all())
                );
            }
            let independent = block(SamplerKind::Independent, 3);
            assert!(
                independent.iter().all(|p| p.cmpge(glam::Vec2::ZERO).all() && p.cmplt(glam::Vec2::ONE).all())
            );
            assert!((1..n).all(|j| independent[j] != independent[j - 1]));
        }
        // One point is `next_2d`'s.
        let streams = Streams::camera(SamplerKind::Sobol, 5, 3);
        let (mut a, mut b) = (streams.sampler(7), streams.sampler(7));
        let one: Vec<_> = a.next_2d_block(1).collect();
        assert_eq!(one, [b.next_2d()]);
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
