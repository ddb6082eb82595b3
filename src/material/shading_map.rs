//! Mitsuba 3's `normalmap` and `bumpmap`: a nested BSDF seen through a shading frame that a
//! texture perturbs. The perturbation is a property of the surface point, not of the
//! directions: [`crate::scene::Scene::surface_at`] builds the perturbed frame once per hit, and
//! every integrator (camera paths, next-event estimation, light paths, the VPLs that keep a
//! hit's frame) hands it to the nested [`super::Bsdf`] as any shading frame.
//!
//! The unperturbed frame is Mitsuba's of a mesh: n the interpolated shading normal (or the
//! geometric one), s the texture parametrization's dp/du with its part along n removed
//! (Gram–Schmidt), t = n × s ([`Tangents::frame`]).
//!
//! - `normalmap`: the normal m = normalize(2 · rgb − 1) of an RGB texture in that frame, s the
//!   frame's first axis made orthogonal to m, t = m × s;
//! - `bumpmap`: with g = scale · ∇h(u, v) of a height texture h ([`Texture::eval_1_grad`]),
//!   dp/du' = dp/du + n (g.u − n · dp/du), dp/dv' likewise, the normal normalize(dp/du' × dp/dv')
//!   turned to the geometric normal's side, s dp/du made orthogonal to it.
//!
//! Mitsuba 3 also flips a perturbed normal that faces away from the viewer
//! (`flip_invalid_normals`) and multiplies its BSDF by a shadowing term of the light's
//! direction (`use_shadowing_function`, Estevez et al. 2019), both on by default; both make
//! its BSDF depend on which direction is the viewer's, which pir's BSDFs (evaluated from either
//! end of a path, the VPLs' from the light) do not know. pir renders both as off; the Mitsuba
//! reader warns when a scene leaves them on (see `docs/mitsuba.md` for the measured effect).

use glam::{Vec2, Vec3};

use crate::geometry::Frame;
use crate::texture::Texture;

/// How a texture perturbs the shading frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Perturbation {
    /// `normalmap`: an RGB texture of normals in the unperturbed frame, each channel x ↦ (x + 1)/2.
    Normal(Texture),
    /// `bumpmap`: a height texture, whose gradient times `scale` tilts the normal.
    Bump { height: Texture, scale: f32 },
}

/// What a two-sided material's back sees, by which of Mitsuba's plugins is outside.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackSide {
    /// `twosided` around the map: Mitsuba mirrors the directions in the unperturbed tangent
    /// plane, so the back sees the front's perturbed frame mirrored in that plane.
    Mirrored,
    /// The map around `twosided` (or a one-sided material): the perturbed frame turned over,
    /// as an unmapped two-sided material's.
    TurnedOver,
}

/// A material's normal or bump map.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadingMap {
    pub perturbation: Perturbation,
    pub back: BackSide,
}

/// The differential geometry of a point that a map perturbs: the unperturbed shading normal
/// `n`, the geometric normal `ng` and the derivatives of the position by the texture
/// coordinates.
#[derive(Clone, Copy, Debug)]
pub struct Tangents {
    pub n: Vec3,
    pub ng: Vec3,
    pub dp_du: Vec3,
    pub dp_dv: Vec3,
}

impl Tangents {
    /// Mitsuba's dp/du and dp/dv of the triangle `corners` with texture coordinates `uvs` at
    /// them (a mesh without any has its barycentrics, (0, 0), (1, 0), (0, 1): dp/du = b − a);
    /// for a parametrization of zero area, the axes of [`Frame::from_normal`] of `ng`.
    pub fn of_triangle(corners: [Vec3; 3], uvs: [Vec2; 3], ng: Vec3, n: Vec3) -> Tangents {
        let [a, b, c] = corners;
        let (dp0, dp1) = (b - a, c - a);
        let (duv0, duv1) = (uvs[1] - uvs[0], uvs[2] - uvs[0]);
        let det = duv0.x * duv1.y - duv0.y * duv1.x;
        let (dp_du, dp_dv) = if det != 0.0 {
            let inv = 1.0 / det;
            ((duv1.y * dp0 - duv0.y * dp1) * inv, (duv0.x * dp1 - duv1.x * dp0) * inv)
        } else {
            let f = Frame::from_normal(ng);
            (f.s, f.t)
        };
        Tangents { n, ng, dp_du, dp_dv }
    }

    /// Mitsuba's shading frame: n, s = dp/du without its part along n (normalized; any axis
    /// around n where that is zero), t = n × s.
    pub fn frame(&self) -> Frame {
        frame_along(self.n, self.dp_du)
    }
}

/// The frame of normal `n` whose s is `along` made orthogonal to `n`; around `n` as
/// [`Frame::from_normal`] where that is not defined.
fn frame_along(n: Vec3, along: Vec3) -> Frame {
    match (along - n * n.dot(along)).try_normalize() {
        Some(s) => Frame { s, t: n.cross(s), n },
        None => Frame::from_normal(n),
    }
}

impl ShadingMap {
    /// The perturbed shading frame (world space) of the front side of a point of texture
    /// coordinates `uv`; the unperturbed frame where the map's normal is not defined (a zero
    /// normal-map texel, a bump map's degenerate derivatives).
    pub fn frame(&self, g: &Tangents, uv: Vec2) -> Frame {
        let base = g.frame();
        match &self.perturbation {
            Perturbation::Normal(texture) => {
                let Some(m) = (2.0 * texture.eval(uv) - Vec3::ONE).try_normalize() else { return base };
                // In the unperturbed frame: s is its x axis made orthogonal to m.
                let s = (Vec3::X - m * m.x).try_normalize().unwrap_or(Vec3::Y);
                let t = m.cross(s);
                Frame { s: base.to_world(s), t: base.to_world(t), n: base.to_world(m) }
            }
            Perturbation::Bump { height, scale } => {
                let grad = *scale * height.eval_1_grad(uv);
                let n = base.n;
                let dp_du = g.dp_du + n * (grad.x - n.dot(g.dp_du));
                let dp_dv = g.dp_dv + n * (grad.y - n.dot(g.dp_dv));
                let Some(m) = dp_du.cross(dp_dv).try_normalize() else { return base };
                let m = if m.dot(g.ng) < 0.0 { -m } else { m };
                frame_along(m, g.dp_du)
            }
        }
    }

    /// The frame the back of a two-sided material sees, of the `front` frame
    /// [`ShadingMap::frame`] gave and the unperturbed normal `n`.
    pub fn back_frame(&self, front: Frame, n: Vec3) -> Frame {
        match self.back {
            BackSide::TurnedOver => Frame { s: front.s, t: -front.t, n: -front.n },
            BackSide::Mirrored => {
                let mirror = |v: Vec3| v - 2.0 * v.dot(n) * n;
                Frame { s: mirror(front.s), t: mirror(front.t), n: mirror(front.n) }
            }
        }
    }

    /// Its texture (for the material's fingerprint and bounds checks).
    pub fn texture(&self) -> &Texture {
        match &self.perturbation {
            Perturbation::Normal(t) | Perturbation::Bump { height: t, .. } => t,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Texels;
    use crate::texture::{Bitmap, Filter, Image, Wrap};
    use glam::Affine2;
    use std::sync::Arc;

    fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
        (a - b).abs().max_element() <= tol
    }

    fn orthonormal(f: &Frame) -> bool {
        [f.s, f.t, f.n].iter().all(|v| (v.length() - 1.0).abs() < 1e-5)
            && f.s.dot(f.t).abs() < 1e-5
            && f.s.dot(f.n).abs() < 1e-5
            && f.t.dot(f.n).abs() < 1e-5
    }

    /// A tilted triangle whose texture coordinates run along two of its edges, and a shading
    /// normal off its geometric one.
    fn tangents() -> Tangents {
        let corners = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.5), Vec3::new(0.0, 3.0, 0.0)];
        let uvs = [Vec2::new(0.1, 0.2), Vec2::new(0.6, 0.2), Vec2::new(0.1, 0.8)];
        let ng = (corners[1] - corners[0]).cross(corners[2] - corners[0]).normalize();
        let n = (ng + Vec3::new(0.1, -0.05, 0.0)).normalize();
        Tangents::of_triangle(corners, uvs, ng, n)
    }

    fn constant_normal(rgb: Vec3) -> ShadingMap {
        ShadingMap { perturbation: Perturbation::Normal(Texture::Constant(rgb)), back: BackSide::Mirrored }
    }

    /// dp/du and dp/dv are the edges divided by their texture-coordinate spans; without a
    /// parametrization (zero area in uv) an axis pair around ng.
    #[test]
    fn derivatives_follow_the_parametrization() {
        let g = tangents();
        assert!(close(g.dp_du, Vec3::new(4.0, 0.0, 1.0), 1e-5), "{}", g.dp_du);
        assert!(close(g.dp_dv, Vec3::new(0.0, 5.0, 0.0), 1e-5), "{}", g.dp_dv);
        let bary = Tangents::of_triangle(
            [Vec3::ZERO, Vec3::X * 2.0, Vec3::Y],
            [Vec2::ZERO, Vec2::X, Vec2::Y],
            Vec3::Z,
            Vec3::Z,
        );
        assert_eq!((bary.dp_du, bary.dp_dv), (Vec3::X * 2.0, Vec3::Y));
        let flat = Tangents::of_triangle([Vec3::ZERO, Vec3::X, Vec3::Y], [Vec2::ONE; 3], Vec3::Z, Vec3::Z);
        assert!(orthonormal(&Frame { s: flat.dp_du, t: flat.dp_dv, n: Vec3::Z }));
        let f = g.frame();
        assert!(orthonormal(&f) && f.n == g.n && f.s.dot(g.dp_du) > 0.0);
        assert!(close(f.s.cross(f.t), f.n, 1e-5));
    }

    /// A flat normal map, (0.5, 0.5, 1), leaves the unperturbed frame as it is.
    #[test]
    fn flat_normal_map_keeps_the_frame() {
        let g = tangents();
        let f = constant_normal(Vec3::new(0.5, 0.5, 1.0)).frame(&g, Vec2::ZERO);
        let base = g.frame();
        for (a, b) in [(f.s, base.s), (f.t, base.t), (f.n, base.n)] {
            assert!(close(a, b, 1e-6), "{f:?} {base:?}");
        }
    }

    /// A known tilt: rgb (0.75, 0.5, 1) is the normal (0.5, 0, 1)/|·| in the unperturbed frame,
    /// tilted towards s; the frame stays orthonormal and right-handed.
    #[test]
    fn tilted_normal_map_gives_the_expected_normal() {
        let g = tangents();
        let base = g.frame();
        let f = constant_normal(Vec3::new(0.75, 0.5, 1.0)).frame(&g, Vec2::ZERO);
        let want = (0.5 * base.s + base.n).normalize();
        assert!(close(f.n, want, 1e-6), "{} {want}", f.n);
        assert!(orthonormal(&f) && close(f.s.cross(f.t), f.n, 1e-5));
        // s stays in the plane of the unperturbed s and the new normal.
        assert!(f.s.dot(base.t).abs() < 1e-6 && f.s.dot(base.s) > 0.0);
        // A zero normal keeps the unperturbed frame.
        let zero = constant_normal(Vec3::splat(0.5)).frame(&g, Vec2::ZERO);
        assert!(close(zero.n, base.n, 0.0));
    }

    /// The bump-mapped normal is that of the displaced surface p + n · scale · h(u, v), to
    /// first order: by finite differences of that surface's position on a flat triangle, for
    /// a bilinear height image.
    #[test]
    fn bump_normal_is_the_displaced_surface_normal() {
        let texels = Texels {
            width: 4,
            height: 3,
            channels: 1,
            data: vec![0.0, 0.3, 0.1, 0.8, 0.5, 0.2, 0.9, 0.4, 0.7, 0.6, 0.0, 0.25],
            srgb: false,
        };
        let bitmap = Bitmap::new(
            Arc::new(Image::new(texels, true)),
            Filter::Bilinear,
            Wrap::Repeat,
            Affine2::IDENTITY,
        );
        let height = Texture::Bitmap(Arc::new(bitmap));
        let scale = 0.05;
        let map = ShadingMap {
            perturbation: Perturbation::Bump { height: height.clone(), scale },
            back: BackSide::Mirrored,
        };
        let corners = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 1.5, 0.0)];
        let uvs = [Vec2::ZERO, Vec2::X, Vec2::Y];
        let g = Tangents::of_triangle(corners, uvs, Vec3::Z, Vec3::Z);
        let surface =
            |uv: Vec2| corners[0] + g.dp_du * uv.x + g.dp_dv * uv.y + g.n * scale * height.eval_1(uv);
        for uv in [Vec2::new(0.3, 0.2), Vec2::new(0.55, 0.4), Vec2::new(0.1, 0.7)] {
            let e = 1e-3;
            let du = (surface(uv + Vec2::X * e) - surface(uv - Vec2::X * e)) / (2.0 * e);
            let dv = (surface(uv + Vec2::Y * e) - surface(uv - Vec2::Y * e)) / (2.0 * e);
            let want = du.cross(dv).normalize();
            let f = map.frame(&g, uv);
            assert!(close(f.n, want, 2e-3), "{uv}: {} {want}", f.n);
            assert!(orthonormal(&f) && f.n != Vec3::Z);
        }
        // Scale 0 keeps the frame.
        let flat =
            ShadingMap { perturbation: Perturbation::Bump { height, scale: 0.0 }, back: BackSide::Mirrored };
        assert!(close(flat.frame(&g, Vec2::splat(0.4)).n, Vec3::Z, 0.0));
    }

    /// The back of a two-sided material: mirrored in the unperturbed tangent plane (twosided
    /// outside), or turned over (the map outside).
    #[test]
    fn back_frames() {
        let g = tangents();
        let mut map = constant_normal(Vec3::new(0.75, 0.5, 1.0));
        let front = map.frame(&g, Vec2::ZERO);
        let back = map.back_frame(front, g.n);
        let m = front.n;
        assert!(close(back.n, m - 2.0 * m.dot(g.n) * g.n, 1e-6) && orthonormal(&back));
        assert!(back.n.dot(g.n) < 0.0 && (back.n.dot(g.n) + m.dot(g.n)).abs() < 1e-6);
        map.back = BackSide::TurnedOver;
        let over = map.back_frame(front, g.n);
        assert!(close(over.n, -front.n, 0.0) && close(over.s.cross(over.t), over.n, 1e-5));
    }
}
