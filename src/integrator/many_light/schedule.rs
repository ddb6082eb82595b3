//! Progressive schedules: how a bias-controlling parameter changes with the iteration.
//!
//! Clamping (Georgiev et al. 2012's schedule, used by the thesis, section 4.2.1): the bound
//! on the geometry term grows as b_i = b_1 · i^α, so less energy is clamped away each
//! iteration. Virtual spherical lights (section 4.2.2, VCM's merging radius): the radius
//! shrinks as r_i = r_1 · i^((α−1)/2). With 0 < α < 1 the bias vanishes while the variance
//! added per iteration stays finite; the thesis found α = 0.6 best.

/// The thesis' choice of α for both schedules.
pub const DEFAULT_ALPHA: f32 = 0.6;

/// b_i = b_1 · i^α (iterations count from 1).
pub fn clamp_bound(b1: f32, alpha: f32, iteration: u64) -> f32 {
    b1 * (iteration.max(1) as f32).powf(alpha)
}

/// r_i = r_1 · i^((α−1)/2) (iterations count from 1).
pub fn radius(r1: f32, alpha: f32, iteration: u64) -> f32 {
    r1 * (iteration.max(1) as f32).powf((alpha - 1.0) * 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedules_start_at_their_initial_value_and_move_monotonically() {
        assert_eq!(clamp_bound(2.0, 0.6, 1), 2.0);
        assert_eq!(radius(0.5, 0.6, 1), 0.5);
        assert!((clamp_bound(1.0, 0.6, 1024) - 1024f32.powf(0.6)).abs() < 1e-2);
        assert!((radius(1.0, 0.6, 1024) - 1024f32.powf(-0.2)).abs() < 1e-6);
        let mut prev = (0.0, f32::INFINITY);
        for i in 1..100 {
            let (b, r) = (clamp_bound(1.0, 0.6, i), radius(1.0, 0.6, i));
            assert!(b > prev.0 && r < prev.1);
            prev = (b, r);
        }
    }
}
