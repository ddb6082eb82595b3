//! Sample reuse: a discrete choice made from the integer part of a scaled number, and what is
//! left of that number used again as a continuous one (pbrt-v4's technique). A choice drawn
//! from a dimension of its own gives each outcome a random subset of a stratified set of
//! points; reusing the point's own coordinate keeps the points stratified within every
//! outcome. Since an `f32` has 24 random bits and the choice uses the top ones, a second
//! number supplies the bits below them, so that the rest keeps full precision.

/// The largest `f64` below 1.
pub const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;

/// `x` in `[0, 1)` as an `f32` in `[0, 1)` (rounding could reach 1).
#[inline]
pub fn to_unit_f32(x: f64) -> f32 {
    (x as f32).min(1.0 - f32::EPSILON / 2.0)
}

/// `u` with `low`'s bits appended below its 24: uniform on `[0, 1)` when both are (each a
/// multiple of 2^-24, as the samplers draw them), with `u`'s stratification.
#[inline]
pub fn refined(u: f32, low: f32) -> f64 {
    (u as f64 + low as f64 * (1.0 / (1u32 << 24) as f64)).min(ONE_BELOW)
}

/// A choice between two outcomes, the first with probability `p`, made from `x` (the first
/// when `x < p`), and the rest of `x` in `[0, 1)`: uniform given the choice when `x` is
/// uniform, and increasing in `x` within it.
#[inline]
pub fn choose(x: f64, p: f32) -> (bool, f32) {
    let (first, rest) = split(x, p as f64);
    (first, to_unit_f32(rest))
}

/// [`choose`] in `f64`: whether `x < p`, and the rest of `x` in `[0, 1)` (the alias table's
/// bins use it too).
#[inline]
pub fn split(x: f64, p: f64) -> (bool, f64) {
    let (first, rest) = if x < p {
        (true, x / p)
    } else if p < 1.0 {
        (false, (x - p) / (1.0 - p))
    } else {
        (true, ONE_BELOW)
    };
    (first, rest.clamp(0.0, ONE_BELOW))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each outcome with its probability, and its rest uniform on [0, 1) (every tenth as
    /// often, for stratified x); the ends of [0, 1) and p of 0 and 1 stay in range.
    #[test]
    fn choices_have_their_probability_and_uniform_rests() {
        for p in [0.0f32, 0.13, 0.5, 0.9, 1.0] {
            let n = 100_000;
            let mut counts = [[0usize; 10]; 2];
            for k in 0..n {
                let (first, rest) = choose((k as f64 + 0.5) / n as f64, p);
                assert!((0.0..1.0).contains(&rest), "{p}: {rest}");
                counts[usize::from(!first)][(rest * 10.0) as usize] += 1;
            }
            for (outcome, q) in [(0, p as f64), (1, 1.0 - p as f64)] {
                let expected = q * n as f64 / 10.0;
                for &c in &counts[outcome] {
                    assert!((c as f64 - expected).abs() <= 1.0 + 1e-6 * n as f64, "{p}: {counts:?}");
                }
            }
            for x in [0.0, ONE_BELOW] {
                assert!((0.0..1.0).contains(&choose(x, p).1));
            }
        }
        let top = refined(1.0 - f32::EPSILON / 2.0, 1.0 - f32::EPSILON / 2.0);
        assert!(top < 1.0 && refined(0.25, 0.5) == 0.25 + 0.5 / (1u32 << 24) as f64);
    }
}
