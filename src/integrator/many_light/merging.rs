//! Vertex merging for the caustics seen through delta surfaces (`pir-bdpt`): a path
//! camera → S⁺ → x → S⁺ → emitter, with x non-delta and every S a delta vertex (mirror,
//! glass), is one that no connection, no light sample and no light tracing to the camera can
//! make (each needs a non-delta vertex next to its end or two adjacent ones); only the camera
//! path's BSDF sample at x that runs through the delta chain into the emitter finds it, which
//! for a small emitter is rare and bright: the fireflies of a caustic seen in a mirror or
//! through glass. So are the paths with more non-delta vertices, each between two delta
//! chains (camera → S⁺ → x → S⁺ → y → S⁺ → emitter: a caustic of a caustic, seen in a
//! mirror). Vertex merging (Hachisuka and Jensen's progressive photon mapping, as Georgiev et
//! al.'s vertex connection and merging weighs it) makes the same paths from the other side: a
//! light path from the emitter leaves a **photon** at every non-delta vertex that a delta
//! chain reaches while the path is of the class, and the camera's x merges with every photon
//! of the iteration within the radius r of it, as if the photon's point were x.
//!
//! **Which paths.** Merging is limited to this class: paths whose vertices after the camera
//! and before the emitter are delta but for non-delta ones each between two delta vertices,
//! with at least one; the camera merges at its first non-delta vertex x, with the photons that
//! light paths from area emitters left at the vertex a delta vertex led to, whose light
//! subpath was of the class. Every other path keeps the techniques and weights of
//! [`super::bidirectional`]; for the paths of the class those give the emitter hit weight 1
//! (no other technique has a density there), so the balance heuristic between the two is all
//! there is to weigh: w_merge = R / (1 + R), w_hit = 1 / (1 + R), R = p_merge / p_hit. After
//! Georgiev's report (its d_VM sums through delta vertices), with η = π r² N the merging's
//! count of N light paths within the disc,
//!
//!   R = η · p_A · (cos θ_e / π) · cos θ_x · Π_w (cos θ_w^light / cos θ_w^camera)
//!       · Π_y (p_L(y) / p_C(y)) / (cos θ_e · p_σ(x: ω_o → ω)),
//!
//! p_A the light paths' area density of the emitter point (its selection included), cos θ_e / π
//! their direction density there (cosine-distributed), θ_x the angle at x of the direction ω
//! that leaves it towards the light, p_σ the camera BSDF's solid-angle density of ω at x, at
//! each vertex w between x and the emitter the cosine of the segment towards the light over
//! that of the segment towards the camera, and at each non-delta one y among them the light
//! path's BSDF density of the direction towards the camera over the camera path's of the
//! direction towards the light; the distances cancel. So R = r² N p_A cos θ_x Π / p_σ: the
//! emitter hit computes it from the camera path ([`Caustic`]), the merge from the photon,
//! which carries p_A cos θ_y Π ([`Photon::density`], the photon's point standing in for x).
//! Non-delta vertices with a delta lobe among others (plastic) end the class on both sides.
//!
//! **Consistency.** A merge is biased by its kernel (the light of the disc instead of the
//! point's); the radius shrinks with the iterations as progressive photon mapping's does,
//! r_i² = r_1² · i^(α−1) (Knaus and Zwicker 2011; the same schedule as the thesis' spherical
//! lights, [`super::schedule`], with the same `--alpha`), so the bias vanishes while each
//! iteration's merges still count N paths. r_1 is `--merge-radius` pixels' footprint at x: the
//! camera ray's pixel angle times the path's length to x (through the delta chain), so that
//! the blur is about as wide in the image at every resolution (behind curved glass, which
//! magnifies, it is not; the bias vanishes either way). A photon counts when it is within r
//! of x and its surface faces the same way as x's (a photon on the other side of a thin wall
//! does not); both limits vanish with r.
//!
//! What this leaves to the emitter hit alone: paths with two adjacent non-delta vertices that
//! no connection the `--connect` rule allows makes (camera → S → x → S → y → z → S →
//! emitter under `--connect first`), those of lights without area (a point light's caustic
//! seen in a mirror, which `pt` cannot render either), and the emitter seen through delta
//! vertices alone (its image in a mirror), which only the camera can find.

use glam::Vec3;

use super::knn::{KdTree, Located};
use crate::integrator::walker::Vertex;
use crate::material::{Bsdf, BsdfSample, LocalGeometry, PreparedBsdf, TransportMode};

/// `--merge-radius` when not given: r_1 of two pixels' footprint.
pub const DEFAULT_MERGE_PIXELS: f32 = 2.0;

/// A non-delta vertex of a light path of the class that a delta vertex led to: where its
/// light can be merged.
#[derive(Clone, Copy, Debug)]
pub struct Photon {
    pub p: Vec3,
    pub ng: Vec3,
    /// Unit direction towards the previous vertex of the light path (the last delta vertex).
    pub w_in: Vec3,
    /// Incident flux Φ / N, as a VPL's ([`super::Vpl::flux`]).
    pub flux: Vec3,
    /// Segments from the emitter.
    pub depth: u32,
    /// p_A · cos θ_y · Π_w (cos θ_w^light / cos θ_w^camera) · Π (p_L / p_C): the light path's
    /// part of the merge's density ratio R (see the module docs).
    pub density: f32,
}

impl Located for Photon {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// A light path's bookkeeping for photons: present while the path is of the class (its first
/// vertex after the area emitter delta, and every non-delta vertex since between two delta
/// ones).
#[derive(Clone, Copy, Debug)]
pub struct LightChain {
    /// The emitter point's area density p_A (with the emitter's selection).
    pdf_area: f32,
    /// Π_w cos θ_w^light / cos θ_w^camera over the vertices passed, times p_L / p_C at the
    /// non-delta ones (see the module docs).
    product: f32,
    /// Whether the vertex passed last was delta.
    last_delta: bool,
}

impl LightChain {
    /// A light path that starts on an area emitter picked with area density `pdf_area`.
    pub fn start(pdf_area: f32) -> Self {
        LightChain { pdf_area, product: 1.0, last_delta: false }
    }

    /// The light path, arrived from `w_in` at a vertex of BSDF `bsdf` and geometry `g`, leaves
    /// it along the sample `s`: the chain through it, or none where the path leaves the class
    /// (a non-delta vertex after another, or one with a delta lobe among others). At a
    /// non-delta vertex p_L is the sample's density and p_C the density with which the camera's
    /// BSDF sampling, arriving along the sample, would pick `w_in`.
    #[inline]
    pub fn scatter(self, bsdf: &Bsdf, g: &LocalGeometry, w_in: Vec3, s: &BsdfSample) -> Option<Self> {
        let cosines = g.ng.dot(w_in).abs() / g.ng.dot(s.wi).abs();
        let densities = || s.pdf / bsdf.pdf(g, s.wi, w_in);
        let (product, last_delta) = extend(self.product, self.last_delta, bsdf, cosines, densities)?;
        Some(LightChain { product, last_delta, ..self })
    }

    /// The photon at the non-delta vertex at `p` (geometric normal `ng`) that the chain
    /// reaches, `depth` segments from the emitter, with the light's throughput `flux` arriving
    /// from `w_in`; none where the vertex before it was not delta or the ratio is not finite.
    pub fn photon(&self, p: Vec3, ng: Vec3, w_in: Vec3, flux: Vec3, depth: u32) -> Option<Photon> {
        let density = self.pdf_area * self.product * ng.dot(w_in).abs();
        (self.last_delta && density.is_finite() && density > 0.0).then_some(Photon {
            p,
            ng,
            w_in,
            flux,
            depth,
            density,
        })
    }
}

/// One vertex more of a path of the class, from either side: the product of cosine ratios
/// `cosines` (towards the light over towards the camera) and, at a non-delta vertex,
/// `densities` (p_L / p_C) times `product`, and whether the vertex was delta; none where the
/// path leaves the class (a non-delta vertex after another, or one with a delta lobe among
/// others) or the ratio is not finite and positive. One rule for both subpaths, so that they
/// classify the same paths and compute the same R.
#[inline]
fn extend(
    product: f32,
    last_delta: bool,
    bsdf: &Bsdf,
    cosines: f32,
    densities: impl FnOnce() -> f32,
) -> Option<(f32, bool)> {
    let next = if bsdf.is_delta() {
        (product * cosines, true)
    } else if last_delta && !bsdf.has_delta() {
        (product * cosines * densities(), false)
    } else {
        return None;
    };
    (next.0.is_finite() && next.0 > 0.0).then_some(next)
}

/// An iteration's photons and radius: what the camera merges with.
pub struct Merging {
    photons: KdTree<Photon>,
    /// N, the iteration's light paths.
    paths: f32,
    /// r_i over the pixel footprint: r_1 in pixels times i^((α−1)/2).
    pixels: f32,
}

impl Merging {
    /// The photons of iteration `iteration` (from 1) of `paths` light paths, merged within
    /// `pixels` pixels' footprint (r_1) shrunk by the schedule of exponent `alpha`.
    pub fn new(photons: Vec<Photon>, paths: f32, pixels: f32, alpha: f32, iteration: u64) -> Self {
        let pixels = super::schedule::radius(pixels, alpha, iteration);
        Merging { photons: KdTree::from_vec(photons), paths, pixels }
    }

    /// r² at a camera vertex whose footprint (pixel angle × path length) is `footprint`.
    #[inline]
    fn radius2(&self, footprint: f32) -> f32 {
        let r = self.pixels * footprint;
        r * r
    }

    /// The merges at the camera vertex `v` (the first non-delta one after a delta chain) of
    /// squared radius `r2`, each weighed against the emitter hit, per unit throughput:
    /// Σ f(ω_o, ω_y) |ω_y · n_s| / |ω_y · n_g| Φ_y w_merge / (π r²) over the photons within r
    /// whose surface faces as x's and whose path with the camera's is at most `max_depth`
    /// segments long (Φ_y per unit of geometric area, the shading cosine the BSDF sample's).
    pub fn estimate(&self, v: &Vertex, r2: f32, max_depth: u32) -> Vec3 {
        if self.photons.is_empty() || r2.is_nan() || r2 <= 0.0 {
            return Vec3::ZERO;
        }
        let (sp, bsdf) = (v.sp, v.bsdf);
        let fx = PreparedBsdf::new(*bsdf, sp.geometry(), v.wo, TransportMode::Radiance);
        if !fx.is_active() {
            return Vec3::ZERO;
        }
        let mut sum = Vec3::ZERO;
        self.photons.within(sp.p, r2, |y| {
            if y.depth + v.depth > max_depth || y.ng.dot(sp.ng) <= 0.0 {
                return;
            }
            // f |ω·n_s| over the geometric cosine: a photon's flux is per unit of geometric area,
            // and the emitter hit it stands in for weighs the shading cosine.
            let (f_cos, pdf) = fx.eval_pdf(y.w_in);
            let cos = y.w_in.dot(sp.ng).abs();
            if f_cos == Vec3::ZERO || cos.is_nan() || cos <= 0.0 {
                return;
            }
            let w = merge_weight(r2 * self.paths * y.density, pdf);
            sum += f_cos / cos * y.flux * w;
        });
        let out = sum / (std::f32::consts::PI * r2);
        if out.is_finite() { out } else { Vec3::ZERO }
    }
}

/// R = `numerator` / p_σ: infinite where the camera's BSDF cannot sample the direction (only
/// the merge makes the path), NaN where p_σ or R is not a number.
#[inline]
fn ratio(numerator: f32, pdf: f32) -> f32 {
    if pdf <= 0.0 { f32::INFINITY } else { numerator / pdf }
}

/// The merge's weight against the emitter hit, R / (1 + R) (1 where R is infinite, 0 where it
/// is not a number).
#[inline]
fn merge_weight(numerator: f32, pdf: f32) -> f32 {
    let r = ratio(numerator, pdf);
    if r.is_nan() {
        0.0
    } else if r.is_infinite() {
        1.0
    } else {
        r / (1.0 + r)
    }
}

/// The emitter hit's weight against the merge, 1 / (1 + R): one minus [`merge_weight`],
/// computed so that it keeps its precision where R is large.
#[inline]
fn hit_weight(numerator: f32, pdf: f32) -> f32 {
    let r = ratio(numerator, pdf);
    if r.is_nan() { 1.0 } else { 1.0 / (1.0 + r) }
}

/// The camera path's bookkeeping for merging.
#[derive(Clone, Copy, Debug, Default)]
pub enum Caustic {
    /// No merge on this path (no merging, or a non-delta vertex before any delta one).
    #[default]
    Off,
    /// Every vertex so far was delta: the pixel angle of the camera ray, the path's length
    /// and the delta vertices passed.
    Prefix { pixel: f32, length: f32, deltas: u32 },
    /// The camera merged at x with squared radius `r2`; the BSDF sample there is next.
    Merged { r2: f32 },
    /// After the BSDF sample at x of density `pdf` and cosine `cos_x`, still in the class:
    /// Π_w cos θ_w^light / cos θ_w^camera over the vertices passed since, times p_L / p_C at
    /// the non-delta ones, and whether the vertex passed last was delta.
    Suffix { r2: f32, cos_x: f32, pdf: f32, product: f32, last_delta: bool },
}

impl Caustic {
    /// A camera path whose first ray's pixel subtends `pixel` radians.
    pub fn start(pixel: f32) -> Self {
        if pixel.is_finite() && pixel > 0.0 {
            Caustic::Prefix { pixel, length: 0.0, deltas: 0 }
        } else {
            Caustic::Off
        }
    }

    /// The camera path arrives at its next vertex, at squared distance `dist2` (its root taken
    /// only while the length counts).
    #[inline]
    pub fn arrive(&mut self, dist2: f32) {
        if let Caustic::Prefix { length, .. } = self {
            *length += dist2.sqrt();
        }
    }

    /// At a non-delta vertex: where it is the first, after a delta chain, the squared radius
    /// to merge with (then the state waits for the BSDF sample); the first without a delta
    /// chain before it ends the class; after x, none (the BSDF sample decides).
    #[inline]
    pub fn merge_at(&mut self, merging: &Merging) -> Option<f32> {
        match *self {
            Caustic::Prefix { pixel, length, deltas } if deltas > 0 => {
                let r2 = merging.radius2(pixel * length);
                *self = Caustic::Merged { r2 };
                Some(r2)
            }
            Caustic::Prefix { .. } => {
                *self = Caustic::Off;
                None
            }
            _ => None,
        }
    }

    /// The BSDF at a vertex of geometry `g` (delta or not: `bsdf`) sampled the direction `wi`
    /// with density `pdf` (`delta`: a delta lobe), the path arriving from `wo`.
    #[inline]
    pub fn scatter(&mut self, bsdf: &Bsdf, g: &LocalGeometry, wo: Vec3, wi: Vec3, pdf: f32, delta: bool) {
        let ng = g.ng;
        *self = match *self {
            Caustic::Prefix { pixel, length, deltas } if bsdf.is_delta() => {
                Caustic::Prefix { pixel, length, deltas: deltas + 1 }
            }
            Caustic::Merged { r2 } if !delta => {
                Caustic::Suffix { r2, cos_x: ng.dot(wi).abs(), pdf, product: 1.0, last_delta: false }
            }
            Caustic::Suffix { r2, cos_x, pdf: pdf_x, product, last_delta } => {
                let cosines = ng.dot(wi).abs() / ng.dot(wo).abs();
                // (p_L / p_C at a non-delta vertex: the light path's density of the way back
                // towards the camera over this sample's.)
                let densities = || bsdf.pdf(g, wi, wo) / pdf;
                match extend(product, last_delta, bsdf, cosines, densities) {
                    Some((product, last_delta)) => {
                        Caustic::Suffix { r2, cos_x, pdf: pdf_x, product, last_delta }
                    }
                    None => Caustic::Off,
                }
            }
            _ => Caustic::Off,
        };
    }

    /// The share of an emitter hit that the merge leaves it: 1 / (1 + R) on a path of the class
    /// (the emitter reached from x through delta chains and non-delta vertices between them),
    /// at an emitter point that the light paths pick with area density `pdf_area`; 1 on any
    /// other path.
    #[inline]
    pub fn hit_share(&self, merging: &Merging, pdf_area: f32) -> f32 {
        match *self {
            Caustic::Suffix { r2, cos_x, pdf, product, last_delta: true } => {
                hit_weight(r2 * merging.paths * pdf_area * cos_x * product, pdf)
            }
            _ => 1.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Frame;
    use crate::sampling::{Domain, Sampler};
    use crate::scene::SurfacePoint;
    use glam::Vec2;
    use std::f32::consts::PI;

    fn random_point(s: &mut Sampler) -> Vec3 {
        Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 4.0
    }

    /// A unit normal facing both neighbours, tilted at random.
    fn normal(s: &mut Sampler, p: Vec3, a: Vec3, b: Vec3) -> Vec3 {
        let n = (a - p).normalize() + (b - p).normalize();
        let tilt = Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, s.next_f32() - 0.5) * 0.6;
        (n.normalize_or(Vec3::Z) + tilt).normalize()
    }

    fn cos(n: Vec3, from: Vec3, to: Vec3) -> f32 {
        n.dot((to - from).normalize()).abs()
    }

    fn dist2(a: Vec3, b: Vec3) -> f32 {
        (a - b).length_squared()
    }

    /// On paths of the class, camera → S^a → x → (S^b → y)^c → S^d → emitter (a, b, d from 1
    /// to 3, c from 0 to 2; every S declared delta, the cosines at them unequal as at a
    /// refraction; the y Lambertian or glossy), the emitter hit's share and the merge's
    /// weight, each computed from its own subpath, sum to one where the photon lies at x; and
    /// the ratio R is the merge's density over the hit's with the densities written out (the
    /// distances and the delta vertices' Dirac factors cancel), with η = π r² N.
    #[test]
    fn the_merge_and_the_emitter_hit_weigh_to_one() {
        #[derive(Clone, Copy, PartialEq)]
        enum Kind {
            End,
            Delta,
            X,
            Y(usize),
        }
        let mut s = Sampler::new(17, 0, Domain::LightPath, 0);
        let mirror = Bsdf::Mirror { specular: Vec3::splat(0.9) };
        let ys = [
            Bsdf::Diffuse { albedo: Vec3::splat(0.7) },
            Bsdf::Glossy { albedo: Vec3::splat(0.2), specular: Vec3::splat(0.6), roughness: 0.3 },
        ];
        let x_bsdf = ys[0];
        let (paths, p_a, pixel) = (64.0, 3.0, 0.01);
        let merging = Merging::new(Vec::new(), paths, 2.0, 0.6, 5);
        let mut checked = [0; 3];
        for trial in 0..900 {
            let (a, b, c, d) = (1 + trial % 3, 1 + trial / 3 % 3, trial / 9 % 3, 1 + trial / 27 % 3);
            let mut kinds = vec![Kind::End];
            kinds.extend(std::iter::repeat_n(Kind::Delta, a));
            kinds.push(Kind::X);
            for i in 0..c {
                kinds.extend(std::iter::repeat_n(Kind::Delta, b));
                kinds.push(Kind::Y((trial + i) % 2));
            }
            kinds.extend(std::iter::repeat_n(Kind::Delta, d));
            kinds.push(Kind::End);
            let k = kinds.len() - 1;
            let xi = a + 1;
            let z: Vec<Vec3> = (0..=k).map(|_| random_point(&mut s)).collect();
            let n: Vec<Vec3> = (0..=k)
                .map(|j| if j == 0 || j == k { Vec3::ZERO } else { normal(&mut s, z[j], z[j - 1], z[j + 1]) })
                .collect();
            let n_e = (z[k - 1] - z[k]).normalize();
            let g = |j: usize| LocalGeometry { ng: n[j], frame: Frame::from_normal(n[j]) };
            let dir = |j: usize, i: usize| (z[i] - z[j]).normalize();
            // The BSDF densities at a non-delta vertex: the camera's towards the light, the
            // light's back towards the camera.
            let bsdf_of = |j: usize| match kinds[j] {
                Kind::Y(i) => ys[i],
                _ => x_bsdf,
            };
            let p_c = |j: usize| bsdf_of(j).pdf(&g(j), dir(j, j - 1), dir(j, j + 1));
            let p_l = |j: usize| bsdf_of(j).pdf(&g(j), dir(j, j + 1), dir(j, j - 1));
            if (xi..k).any(|j| kinds[j] != Kind::Delta && (p_c(j).is_nan() || p_c(j) < 1e-3 || p_l(j) < 1e-3))
            {
                continue;
            }
            let (x, n_x) = (z[xi], n[xi]);
            let pdf_x = p_c(xi);
            // The camera path.
            let mut cam = Caustic::start(pixel);
            for j in 1..k {
                cam.arrive((z[j] - z[j - 1]).length_squared());
                let (wo, wi) = (dir(j, j - 1), dir(j, j + 1));
                match kinds[j] {
                    Kind::Delta => cam.scatter(&mirror, &g(j), wo, wi, 1.0, true),
                    Kind::X => {
                        assert!(cam.merge_at(&merging).is_some(), "x merges");
                        cam.scatter(&x_bsdf, &g(j), wo, wi, pdf_x, false);
                    }
                    Kind::Y(_) => {
                        assert!(cam.merge_at(&merging).is_none(), "only x merges");
                        cam.scatter(&bsdf_of(j), &g(j), wo, wi, p_c(j), false);
                    }
                    Kind::End => unreachable!(),
                }
            }
            cam.arrive((z[k] - z[k - 1]).length_squared());
            let share = cam.hit_share(&merging, p_a);
            let r2 = merging.radius2(pixel * (1..=xi).map(|j| (z[j] - z[j - 1]).length()).sum::<f32>());
            // The light path, from the emitter to x.
            let mut chain = Some(LightChain::start(p_a));
            // (As light tracing calls it: the sample's density is the light's, and the chain
            // finds the camera's from the BSDF.)
            for j in (xi + 1..k).rev() {
                let (w_in, wi) = (dir(j, j + 1), dir(j, j - 1));
                let (bsdf, delta) = match kinds[j] {
                    Kind::Delta => (mirror, true),
                    _ => (bsdf_of(j), false),
                };
                let pdf = if delta { 1.0 } else { bsdf.pdf(&g(j), w_in, wi) };
                let sample = BsdfSample { wi, weight: Vec3::ONE, pdf, delta, eta: 1.0 };
                chain = chain.and_then(|ch| ch.scatter(&bsdf, &g(j), w_in, &sample));
            }
            let photon = chain.unwrap().photon(x, n_x, dir(xi, xi + 1), Vec3::ONE, (k - xi) as u32).unwrap();
            let w_merge = merge_weight(r2 * paths * photon.density, pdf_x);
            assert!((share + w_merge - 1.0).abs() < 1e-4, "a {a}, b {b}, c {c}, d {d}: {share} + {w_merge}");
            // The densities written out, per unit area of each vertex the subpath samples.
            let mut p_hit = pdf_x;
            let mut p_light = p_a * cos(n_e, z[k], z[k - 1]) / PI;
            for j in xi + 1..=k {
                let n_j = if j == k { n_e } else { n[j] };
                p_hit *= cos(n_j, z[j], z[j - 1]) / dist2(z[j], z[j - 1]);
                if let Kind::Y(_) = kinds[j] {
                    p_hit *= p_c(j);
                    p_light *= p_l(j);
                }
            }
            for j in (xi..k).rev() {
                p_light *= cos(n[j], z[j], z[j + 1]) / dist2(z[j], z[j + 1]);
            }
            let ratio = PI * r2 * paths * p_light / p_hit;
            let expected = 1.0 / (1.0 + ratio);
            assert!(
                (share - expected).abs() < 2e-3 * expected.max(1e-3),
                "a {a}, b {b}, c {c}, d {d}: {share} against {expected}"
            );
            checked[c] += 1;
        }
        assert!(checked.iter().all(|&n| n > 50), "checked by the vertices between the chains: {checked:?}");
    }

    /// Paths outside the class keep the emitter hit whole: no delta vertex before x (light
    /// tracing's), none after it (next-event estimation's), a second non-delta vertex, a delta
    /// lobe sampled at x; and no merging without a camera ray's pixel.
    #[test]
    fn only_the_class_is_shared() {
        let merging = Merging::new(Vec::new(), 64.0, 2.0, 0.6, 1);
        let mirror = Bsdf::Mirror { specular: Vec3::ONE };
        let diffuse = Bsdf::Diffuse { albedo: Vec3::splat(0.5) };
        let (n, w) = (Vec3::Z, Vec3::new(0.0, 0.6, 0.8));
        let g = LocalGeometry { ng: n, frame: Frame::from_normal(n) };
        let walk = |steps: &[(&Bsdf, bool)]| {
            let mut c = Caustic::start(0.01);
            for &(bsdf, delta) in steps {
                c.arrive(1.0);
                if !bsdf.is_delta() {
                    c.merge_at(&merging);
                }
                c.scatter(bsdf, &g, w, w, 0.3, delta);
            }
            c.arrive(1.0);
            c.hit_share(&merging, 50.0)
        };
        assert!(walk(&[(&mirror, true), (&diffuse, false), (&mirror, true)]) < 0.5, "the class");
        let twice = [(&mirror, true), (&diffuse, false), (&mirror, true), (&diffuse, false), (&mirror, true)];
        assert!(walk(&twice) < 0.5, "the class, a non-delta vertex between delta chains");
        assert_eq!(walk(&[(&diffuse, false), (&mirror, true)]), 1.0);
        assert_eq!(walk(&[(&mirror, true), (&diffuse, false)]), 1.0);
        assert_eq!(walk(&[(&mirror, true), (&diffuse, false), (&mirror, true), (&diffuse, false)]), 1.0);
        assert_eq!(walk(&[(&mirror, true), (&diffuse, false), (&diffuse, false), (&mirror, true)]), 1.0);
        assert_eq!(walk(&[(&mirror, true), (&diffuse, true), (&mirror, true)]), 1.0);
        // A vertex with a delta lobe among others (plastic) between the chains ends the class,
        // on either side.
        let plastic = Bsdf::plastic(Vec3::splat(0.5), None, 1.5, false);
        assert!(plastic.has_delta() && !plastic.is_delta());
        assert_eq!(
            walk(&[(&mirror, true), (&diffuse, false), (&mirror, true), (&plastic, false), (&mirror, true)]),
            1.0
        );
        let sample = |delta| BsdfSample { wi: w, weight: Vec3::ONE, pdf: 0.3, delta, eta: 1.0 };
        let through = LightChain::start(1.0).scatter(&mirror, &g, w, &sample(true)).unwrap();
        assert!(through.scatter(&plastic, &g, w, &sample(false)).is_none());
        assert!(through.scatter(&diffuse, &g, w, &sample(false)).is_some());
        assert!(matches!(Caustic::start(f32::INFINITY), Caustic::Off));
        // A light path's photon needs a delta vertex before it.
        let chain = LightChain::start(1.0);
        assert!(chain.photon(Vec3::ZERO, n, w, Vec3::ONE, 1).is_none());
    }

    /// The merge at a Lambertian x with a tilted shading normal: each photon within r, facing
    /// as x, within `max_depth`, adds albedo / π · |ω·n_s| / |ω·n_g| · Φ · w / (π r²); the
    /// others nothing. The radius shrinks as
    /// i^((α−1)/2).
    #[test]
    fn a_merge_adds_the_photons_within_the_radius() {
        let (n, albedo) = (Vec3::Z, Vec3::new(0.5, 0.6, 0.7));
        let diffuse = Bsdf::Diffuse { albedo };
        // A shading normal tilted from the geometric one.
        let ns = Vec3::new(0.3, 0.1, 1.0).normalize();
        let sp = SurfacePoint {
            p: Vec3::ZERO,
            ng: n,
            frame: Frame::from_normal(ns),
            prim: 0,
            material: 0,
            uv: Vec2::ZERO,
            back: false,
        };
        let v = Vertex { sp: &sp, wo: Vec3::new(0.0, 0.6, 0.8), bsdf: &diffuse, depth: 3 };
        let w_in = Vec3::new(0.8, 0.0, 0.6);
        let photon = |p: Vec3, ng: Vec3, depth: u32, flux: f32| Photon {
            p,
            ng,
            w_in,
            flux: Vec3::splat(flux),
            depth,
            density: 2.0,
        };
        let photons = vec![
            photon(Vec3::new(0.05, 0.0, 0.0), n, 2, 1.0),
            photon(Vec3::new(0.0, -0.08, 0.0), n, 3, 2.0),
            photon(Vec3::new(0.2, 0.0, 0.0), n, 2, 100.0), // beyond r
            photon(Vec3::new(0.0, 0.05, 0.0), -n, 2, 100.0), // the other side
            photon(Vec3::new(0.0, 0.0, 0.01), n, 6, 100.0), // too deep
        ];
        let (paths, r2) = (16.0, 0.01);
        let merging = Merging::new(photons, paths, 2.0, 0.6, 1);
        let got = merging.estimate(&v, r2, 8);
        let pdf = w_in.dot(ns) / PI;
        let w = merge_weight(r2 * paths * 2.0, pdf);
        // f |ω·n_s| / |ω·n_g|: the flux per geometric area, the shading cosine the hit's.
        let expected = albedo / PI * w_in.dot(ns) / w_in.z * 3.0 * w / (PI * r2);
        assert!(
            (got - expected).abs().max_element() < 1e-4 * expected.max_element(),
            "{got} against {expected}"
        );
        assert_eq!(merging.estimate(&v, 0.0, 8), Vec3::ZERO);
        // r_i² = r_1² i^(α−1).
        let first = Merging::new(Vec::new(), paths, 2.0, 0.6, 1).radius2(1.0);
        let later = Merging::new(Vec::new(), paths, 2.0, 0.6, 16).radius2(1.0);
        assert!((first - 4.0).abs() < 1e-6 && (later / first - 16f32.powf(-0.4)).abs() < 1e-5);
    }
}
