//! Shuffled, randomly shifted 2D Sobol points: the low-discrepancy half of
//! [`Sampler`](super::Sampler).
//!
//! A sampler's dimensions are drawn in pairs (or singly), each pair from its own randomised
//! copy of the first two Sobol dimensions, the point's number in the sequence being the
//! sample's index (the iteration for a pixel, the path within its iteration for a light path):
//! - **A random digital shift** (XOR with a random 32-bit word) of each coordinate makes every
//!   point uniformly distributed on `[0, 1)²`, so every estimate is unbiased sample by sample,
//!   and keeps the sequence's stratification: every aligned block of `2^k` indices is a
//!   (0, k, 2)-net, one point in each elementary interval of area `2^-k`.
//! - **Shuffling** the index by nested uniform scrambling (Laine and Karras' hash with Burley's
//!   constants, "Practical Hash-based Owen Scrambling", JCGT 2020), with its own seed per pair,
//!   decorrelates the pairs from each other (padding, as in Owen's "Latin supercube sampling",
//!   1998). The shuffle maps every aligned block of `2^k` indices onto another such block, so
//!   the nets survive it. (A shift of the index would not do: Sobol points are linear in the
//!   index's bits, so pairs would be shifts of each other.)
//!
//! Why the average still converges to the integral, for any square-integrable integrand: the
//! error of a shifted net is the sum of the integrand's Walsh coefficients over the net's dual
//! lattice, whose non-zero members move to ever higher frequencies as the net grows, so its
//! variance goes to zero (the tail of Parseval's sum); a count that is not a power of two is a
//! union of aligned blocks, each a net. The shift guarantees no factor over independent
//! sampling at a given count, as Owen scrambling of the coordinates would (Owen 1997), but
//! Owen-scrambled coordinates measured no lower error than shifted ones, for more time per
//! sample (two bit reversals and two hashes more per pair; `docs/sampling.md`), so pir
//! shifts. A shift also lets the camera samplers share the shuffled points of their first
//! dimensions (see `Streams::camera`) and draw each with one hash and an XOR.
//!
//! The progressive many-light methods change their kernel with the iteration, and a pixel's
//! camera samples are stratified over the iterations, so their iterations are no longer
//! independent. They stay consistent: write iteration i's sample as X_i = h_i(c_i) + e_i,
//! where c_i is the camera sample, h_i(c) the mean over the iteration's VPLs and e_i the rest.
//! The e_i have mean zero and are independent across iterations (each iteration's light
//! paths have scrambles of their own; see `Streams::light_paths`), so their mean falls as the
//! thesis' argument has it. h_i tends to h, the unbiased contribution, which is bounded
//! (the exact radiance arriving at the camera vertex); the mean of h(c_i) is the stratified
//! estimate above, and that of h_i(c_i) − h(c_i) has a standard deviation at most the average
//! of ‖h_i − h‖₂, which tends to zero with the bias.
//!
//! Seeds are hashed from the sampler's key and the dimension, so the points are a pure
//! function of (seed, domain, index, dimension), as every random number in pir is.

/// Laine and Karras' permutation with Burley's constants: a bijection on `u32` in which each
/// output bit depends only on the same and lower input bits (the multipliers are even).
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Nested uniform (Owen) scrambling of the binary fraction `x / 2^32`: each bit is flipped
/// by a hash of the bits above it. (The points below compute it with one reversal fewer.)
#[cfg(test)]
fn owen(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The second Sobol dimension's direction numbers (`v_k = v_{k-1} ^ (v_{k-1} >> 1)` from
/// `v_0 = 2^31`) summed (XOR) over the bits of one byte of the index, for each of the
/// index's four bytes: `SOBOL1[b][byte]`.
static SOBOL1: [[u32; 256]; 4] = sobol1_tables();

const fn sobol1_tables() -> [[u32; 256]; 4] {
    let mut v = [0u32; 32];
    let mut k = 0;
    let mut d = 1u32 << 31;
    while k < 32 {
        v[k] = d;
        d ^= d >> 1;
        k += 1;
    }
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut byte = 0;
        while byte < 256 {
            let mut x = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if byte >> bit & 1 == 1 {
                    x ^= v[8 * b + bit];
                }
                bit += 1;
            }
            t[b][byte] = x;
            byte += 1;
        }
        b += 1;
    }
    t
}

/// The second Sobol dimension of point `i` (the first is `i.reverse_bits()`).
#[inline]
fn sobol1(i: u32) -> u32 {
    let b = i.to_le_bytes();
    let t = &SOBOL1;
    t[0][b[0] as usize] ^ t[1][b[1] as usize] ^ t[2][b[2] as usize] ^ t[3][b[3] as usize]
}

/// A 32-bit integer hash (Wellons' lowbias32).
#[inline]
fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// `x / 2^32` rounded down to a float in `[0, 1)` (24 bits).
#[inline]
fn unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// The seed of a pair's shuffle, hashed from its seed (all 64 bits, so that no simple
/// relation between two pairs' seeds gives them the same shuffle).
#[inline]
pub(super) fn shuffle_seed(seed: u64) -> u32 {
    hash32((seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as u32)
}

/// Point `index` of the pair's shuffled, shifted sequence, given as `rindex =
/// index.reverse_bits()` (fixed per sampler, so reversed once): `seed`'s two halves are the
/// two coordinates' digital shifts, and the shuffle's seed is hashed from all of it. The first
/// Sobol dimension of the shuffled index `i` is `rev(i) = laine_karras(rindex)`, so only the
/// second needs `i` itself.
#[inline]
pub(super) fn point_2d(rindex: u32, seed: u64) -> [f32; 2] {
    shifted(shuffled_2d(rindex, shuffle_seed(seed)), seed)
}

/// The unshifted point `index` (given as `rindex`) of a pair whose shuffle seed is `shuffle`:
/// both Sobol coordinates of the shuffled index, as fractions of 2^32.
#[inline]
pub(super) fn shuffled_2d(rindex: u32, shuffle: u32) -> [u32; 2] {
    let j = laine_karras(rindex, shuffle);
    [j, sobol1(j.reverse_bits())]
}

/// An unshifted point shifted by `seed`'s two halves, in `[0, 1)²`.
#[inline]
pub(super) fn shifted(point: [u32; 2], seed: u64) -> [f32; 2] {
    [unit(point[0] ^ seed as u32), unit(point[1] ^ (seed >> 32) as u32)]
}

/// The first coordinate of [`shifted`].
#[inline]
pub(super) fn shifted_1d(point: [u32; 2], seed: u64) -> f32 {
    unit(point[0] ^ seed as u32)
}

/// The first coordinate of [`point_2d`]: a shuffled, shifted van der Corput sequence.
#[inline]
pub(super) fn point_1d(rindex: u32, seed: u64) -> f32 {
    unit(laine_karras(rindex, shuffle_seed(seed)) ^ seed as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `points` (2^k of them) hold one point in every elementary interval of area 2^-k
    /// (all 2^a × 2^(k−a) grids): a (0, k, 2)-net.
    fn is_net(points: &[[f32; 2]]) -> bool {
        let k = points.len().trailing_zeros();
        assert_eq!(points.len(), 1 << k);
        (0..=k).all(|a| {
            let (nx, ny) = (1usize << a, 1usize << (k - a));
            let mut seen = vec![false; points.len()];
            points.iter().all(|p| {
                let cell = (p[0] * nx as f32) as usize + nx * (p[1] * ny as f32) as usize;
                !std::mem::replace(&mut seen[cell], true)
            })
        })
    }

    /// The second Sobol dimension, one direction number per bit of `i`.
    fn sobol1_by_bits(i: u32) -> u32 {
        let (mut v, mut y) = (1u32 << 31, 0);
        for bit in 0..32 {
            if i >> bit & 1 == 1 {
                y ^= v;
            }
            v ^= v >> 1;
        }
        y
    }

    #[test]
    fn sobol_tables_give_the_known_sequence() {
        // The second Sobol dimension in index order: 0, 1/2, 3/4, 1/4, 5/8, 1/8, 3/8, 7/8.
        let y: Vec<f64> = (0..8).map(|i| sobol1(i) as f64 / 2f64.powi(32)).collect();
        assert_eq!(y, [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875]);
        for i in [0u32, 1, 2, 255, 256, 0x1234_5678, u32::MAX] {
            assert_eq!(sobol1(i), sobol1_by_bits(i), "{i}");
        }
    }

    #[test]
    fn points_are_the_shuffled_shifted_sobol_points() {
        // point_2d as defined: shuffle the index (nested uniform scrambling), take both
        // Sobol dimensions, shift each by its half of the seed.
        for seed in [0u64, 7, 0xdead_beef_0bad_cafe] {
            for index in [0u32, 1, 2, 3, 77, 1 << 20, u32::MAX] {
                let i = owen(index, shuffle_seed(seed));
                let x = i.reverse_bits() ^ seed as u32;
                let y = sobol1_by_bits(i) ^ (seed >> 32) as u32;
                assert_eq!(point_2d(index.reverse_bits(), seed), [unit(x), unit(y)]);
                assert_eq!(point_1d(index.reverse_bits(), seed), unit(x));
            }
        }
    }

    #[test]
    fn laine_karras_is_a_bijection_driven_by_lower_bits() {
        // Flipping bit b of the input changes no output bit below b.
        for (x, seed) in [(0u32, 1u32), (0xdead_beef, 7), (12345, 0xffff_ffff)] {
            for b in 0..32 {
                let d = laine_karras(x, seed) ^ laine_karras(x ^ (1 << b), seed);
                assert_eq!(d & ((1u32 << b) - 1), 0, "bit {b}");
                assert_ne!(d, 0);
            }
        }
    }

    #[test]
    fn aligned_blocks_are_nets_for_any_seed() {
        for seed in [0u64, 1, 0x1234_5678_9abc_def0, u64::MAX] {
            for k in [0, 1, 4, 8] {
                for block in [0u32, 1, 5] {
                    let pts: Vec<_> =
                        (0..1u32 << k).map(|j| point_2d(((block << k) + j).reverse_bits(), seed)).collect();
                    assert!(is_net(&pts), "seed {seed} k {k} block {block}");
                    let mut xs: Vec<f32> =
                        (0..1u32 << k).map(|j| point_1d(((block << k) + j).reverse_bits(), seed)).collect();
                    xs.sort_by(f32::total_cmp);
                    let n = xs.len() as f32;
                    assert!(
                        xs.iter().enumerate().all(|(j, &x)| (x * n) as usize == j),
                        "1d seed {seed} k {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn points_are_uniform_over_seeds() {
        // Point 5 (any index) over many seeds: mean 1/2 and second moment 1/3 per coordinate,
        // and the coordinates uncorrelated (E[xy] = 1/4).
        let n = 100_000;
        let (mut mx, mut my, mut mxx, mut mxy) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for s in 0..n {
            let seed = (s as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5555;
            let [x, y] = point_2d(5u32.reverse_bits(), seed);
            let (x, y) = (x as f64, y as f64);
            (mx, my, mxx, mxy) = (mx + x, my + y, mxx + x * x, mxy + x * y);
        }
        let n = n as f64;
        let tol = 5.0 * (1.0 / 12.0f64).sqrt() / n.sqrt();
        assert!((mx / n - 0.5).abs() < tol, "{}", mx / n);
        assert!((my / n - 0.5).abs() < tol, "{}", my / n);
        assert!((mxx / n - 1.0 / 3.0).abs() < tol, "{}", mxx / n);
        assert!((mxy / n - 0.25).abs() < tol, "{}", mxy / n);
    }

    #[test]
    fn seeds_decorrelate_pairs() {
        // Two pairs of the same sample (different seeds, here each other's complement):
        // over 4,096 indices their first coordinates are uncorrelated (|r| within 4 standard
        // errors of zero).
        let n = 4096u32;
        let (a, b) = (0x0123_4567_89ab_cdefu64, !0x0123_4567_89ab_cdefu64);
        let xs: Vec<(f64, f64)> = (0..n)
            .map(|i| (point_1d(i.reverse_bits(), a) as f64 - 0.5, point_1d(i.reverse_bits(), b) as f64 - 0.5))
            .collect();
        let cov: f64 = xs.iter().map(|(x, y)| x * y).sum::<f64>() / n as f64;
        let r = cov * 12.0;
        assert!(r.abs() < 4.0 / (n as f64).sqrt(), "r = {r}");
    }
}
