use glam::Vec3;

/// A ray-triangle hit: distance along the ray and barycentrics of `b` and `c`
/// (the point is `(1 - u - v) a + u b + v c`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// Möller–Trumbore intersection of the ray `o + t d`, `t` in `(tmin, tmax)`, with the triangle
/// `(a, b, c)`; both faces count. Returns `None` for a miss or a degenerate triangle.
#[inline]
pub fn intersect_triangle(
    o: Vec3,
    d: Vec3,
    tmin: f32,
    tmax: f32,
    a: Vec3,
    b: Vec3,
    c: Vec3,
) -> Option<TriangleHit> {
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    if t > tmin && t < tmax { Some(TriangleHit { t, u, v }) } else { None }
}
