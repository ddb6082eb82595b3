use glam::Vec3;

/// A ray segment `origin + t * dir` for `t` in `[tmin, tmax]`.
///
/// `dir` need not be normalised; `t` is measured in units of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    /// A ray from `origin` along `dir` with the interval `[0, ∞)`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray { origin, dir, tmin: 0.0, tmax: f32::INFINITY }
    }

    /// A segment from `origin` along `dir` ending at `tmax`.
    pub fn segment(origin: Vec3, dir: Vec3, tmax: f32) -> Self {
        Ray { origin, dir, tmin: 0.0, tmax }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// True when the ray can be given to a backend: finite origin and direction, a non-zero
    /// direction and a non-empty interval. Embree's Debian build aborts on invalid rays, so
    /// every query path checks this first.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.dir.is_finite()
            && self.dir != Vec3::ZERO
            && !self.tmin.is_nan()
            && !self.tmax.is_nan()
            && self.tmin >= 0.0
            && self.tmin <= self.tmax
    }
}

/// [`offset_epsilon`]'s factor of `1 + max |p_i|`.
pub const OFFSET_SCALE: f32 = 1500.0 * f32::EPSILON / 2.0;

/// How far a surface point is moved off its surface: (1 + max |p|) · 1500 ε_f32, growing with
/// the magnitude of the coordinates as float spacing does. It is Mitsuba 3's
/// (`Interaction::offset_p`, `math::RayEpsilon`): on thin geometry the offset decides which
/// nearby surfaces a ray can hit, and the shared living room's blinds (thin slats behind which
/// its window light is) come out 0.25 % darker with pir's former 1e-4 · max(1, |p|), within
/// 0.01 % with this.
#[inline]
pub fn offset_epsilon(p: Vec3) -> f32 {
    (1.0 + p.abs().max_element()) * OFFSET_SCALE
}

/// Moves a surface point off its surface by [`offset_epsilon`], along the geometric normal
/// `ng` on the side that `w` points to, so that a ray leaving in direction `w` does not hit
/// the surface it starts on.
pub fn offset_origin(p: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    let eps = offset_epsilon(p);
    if ng.dot(w) >= 0.0 { p + ng * eps } else { p - ng * eps }
}

/// A surface point with both of its [`offset_origin`] positions computed once, for a point
/// that starts or ends many segments (a VPL gather connects one receiver to every VPL and
/// every VPL to every receiver). [`OffsetPoint::toward`] is exactly `offset_origin(p, ng, w)`.
#[derive(Clone, Copy, Debug)]
pub struct OffsetPoint {
    pub p: Vec3,
    pub ng: Vec3,
    /// `p` moved along `+ng` and along `-ng`.
    above: Vec3,
    below: Vec3,
}

impl OffsetPoint {
    #[inline]
    pub fn new(p: Vec3, ng: Vec3) -> Self {
        let eps = offset_epsilon(p);
        OffsetPoint { p, ng, above: p + ng * eps, below: p - ng * eps }
    }

    /// The point moved off its surface on the side that `w` points to.
    #[inline]
    pub fn toward(&self, w: Vec3) -> Vec3 {
        if self.ng.dot(w) >= 0.0 { self.above } else { self.below }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_point_is_offset_origin() {
        let ng = Vec3::new(0.3, -0.8, 0.52).normalize();
        for p in [Vec3::new(0.1, 0.2, -0.3), Vec3::new(-250.0, 3.0, 1e3), Vec3::ZERO] {
            let o = OffsetPoint::new(p, ng);
            for w in [ng, -ng, Vec3::X, Vec3::new(-0.3, 0.8, -0.52), Vec3::ZERO] {
                assert_eq!(o.toward(w).to_array(), offset_origin(p, ng, w).to_array());
            }
        }
    }
}
