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

/// Moves a surface point off its surface, along the geometric normal `ng` on the side that `w`
/// points to, so that a ray leaving in direction `w` does not hit the surface it starts on.
/// The offset grows with the magnitude of the coordinates, as float spacing does.
pub fn offset_origin(p: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    let scale = p.abs().max_element().max(1.0);
    let eps = 1e-4 * scale;
    if ng.dot(w) >= 0.0 { p + ng * eps } else { p - ng * eps }
}
