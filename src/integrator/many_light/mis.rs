//! Multiple importance sampling of the VPL connection against a BSDF-sampled bounce
//! (`pir-mis`): an estimator of our own that needs no clamp where the thesis' methods spike.
//!
//! **The two techniques.** Take a path x → y → z → … whose first vertex x is where a camera
//! path gathers (non-delta) and whose next vertex y is a non-delta surface. pir samples it in
//! two ways:
//! - **A, the connection** (every VPL method): light tracing reaches y from z and leaves a VPL
//!   there; x connects to it. Per unit area at y its density is the light path's,
//!   q_z p_z(ω_zy) cos θ_y / ‖y − z‖², with q_z the light path's survival probability at z and
//!   p_z the density of z's BSDF sampling; N light paths per iteration give N such samples.
//! - **B, the bounce**: x samples its BSDF and the ray hits y, with density
//!   p_x(ω_xy) cos θ_y / ‖y − x‖²; y then connects to z's VPL (the same N light paths) or, if
//!   z lies on an emitter, samples the emitters once (next-event estimation).
//!
//! The prefix up to z is common to both (the same light paths) except where z is on an
//! emitter: light tracing picks that point N times, next-event estimation once, with the same
//! density (both use [`crate::light::Emitters::sample`]; where next-event estimation samples
//! an emitting sphere's cone, [`Vpl::arrival`] holds light tracing's density relative to the
//! cone's). The cosine at y cancels too. So with
//! a = [`Vpl::arrival`] (q_z p_z / ‖y − z‖², or N · (cos θ_e / π) / ‖y − e‖² for a VPL lit
//! directly) and b = p_x / ‖y − x‖², the balance heuristic weighs A by a / (a + b) and B by
//! b / (a + b). The weights of one path sum to 1, so the pair is unbiased for the iteration
//! wherever both are unclamped: every path x → y → … with y non-delta is counted exactly
//! once. A VPL reached through a delta vertex has a = ∞ (B cannot produce it): weight 1.
//!
//! **Why no spike is left where the thesis' methods clamp.** Near a crease (x close to y),
//! b ∝ 1 / ‖y − x‖² grows as fast as G, so a/(a + b) · G stays below π a: the 1/d² spike goes
//! to B, which samples exactly that solid angle. At a glossy receiver, p_x is large exactly
//! where f_x is (the lobe), so the lobe goes to B as well. What neither technique samples is
//! the VPL's own lobe (f_y large towards x, at a glossy y), and the mirror case of it in B
//! (f_z at a glossy z); for those the weighted connection keeps a progressive bound,
//! [`Weighing::apply`]: π² · w · max(c) / max(Φ) ≤ b_i, which for two white Lambertian ends
//! is exactly w · G ≤ b_i, the thesis' clamp applied to what MIS leaves, with the thesis'
//! schedule b_i = b_1 · i^α. Its bias vanishes as b_i → ∞ for the same reason as
//! `pir-clamp`'s, so `pir-mis` is consistent; where nothing is clamped it is unbiased per
//! iteration.
//!
//! **Light that reaches y straight from an emitter** (x → y → e) has a third technique, C:
//! y samples its BSDF and the ray hits the emitter, which is what handles a glossy y that
//! reflects a light (the VPL's own lobe, which neither A nor B samples). Its density
//! relative to B is p_y(ω_ye) / p_light(ω_ye) (y's BSDF against next-event estimation's
//! solid-angle density), and the three weigh by the balance heuristic ([`EmitterPath`]); a
//! VPL lit directly stores the density of next-event estimation for its emitter point
//! ([`Vpl::nee_pdf`]) so that A can weigh against C.
//!
//! **Lights that are not triangles** fit the same scheme, with what light tracing picks
//! beyond next-event estimation's pick of the same light ([`crate::light::Light::emit`]): a
//! point or spot light's direction (a = N p_dir / ‖y − l‖²; C cannot hit a delta light, and
//! next-event estimation picks it with an infinite density, [`Vpl::nee_pdf`]), and for lights
//! at infinity the point on the disk the path starts from (a = N / π r²; for an environment C
//! is y's BSDF sample leaving the scene, against next-event estimation's density of the
//! direction).
//!
//! Costs: B adds, per gathering vertex, one ray (the walker traces it anyway for the
//! emission that MIS-weights direct light) and a second gather and emitter sample at y; C
//! one more ray from y.

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

use super::bidirectional::{CameraEnd, DrawWeights, connection, connection_weight};
use super::config::{Next, glossy_vertex};
use super::light_paths::Vpl;
use super::lobe::Lobe;
use super::points::{PointLights, PointReceiver};
use super::virtual_light::{Weigh, weighed_pick};
use crate::integrator::direct::LightSample;
use crate::integrator::walker::Vertex;
use crate::material::PreparedBsdf;
use crate::sampling::Sampler;

/// Which technique a weighed gather of point lights is, with what its weights need (the
/// thesis' methods take every connection in full: [`super::virtual_light::Plain`]).
#[derive(Clone, Copy)]
pub enum Technique<'a> {
    /// A at the gathering vertex x, whose BSDF for its `wo` is `fx` (a VPL's BSDF is its
    /// `emitting` one's, textures evaluated at its point).
    Connect { fx: &'a PreparedBsdf },
    /// B at y, reached from the gathering vertex with density `bounce` = p_x / ‖y − x‖².
    Bounce { bounce: f32 },
    /// A connection of `pir-bdpt`, weighed against every other technique of the path
    /// ([`super::bidirectional`]).
    Bidirectional { end: CameraEnd<'a> },
}

/// How a gather of point lights weighs its connections: the technique's MIS weight, and the
/// bound on the weighted connection.
#[derive(Clone, Copy)]
pub struct Weighing<'a> {
    pub technique: Technique<'a>,
    pub bound: f32,
}

impl Weighing<'_> {
    /// VPL `vpl`'s contribution `c` at the receiver `x` (its BSDF `emitting` prepared for its
    /// incoming direction), weighted and bounded.
    #[inline]
    pub fn apply(&self, x: Vec3, vpl: &Vpl, emitting: &PreparedBsdf, c: Vec3) -> Vec3 {
        let w = match self.technique {
            Technique::Connect { .. } if vpl.arrival.is_infinite() => 1.0,
            Technique::Connect { fx } => {
                let d = vpl.p - x;
                let dist2 = d.length_squared();
                let to_vpl = d / dist2.sqrt();
                let b = fx.pdf(to_vpl) / dist2;
                if vpl.nee_pdf > 0.0 {
                    // Lit directly: C, BSDF sampling from y towards the emitter, competes too.
                    // `emitting` holds the VPL's BSDF, its textures evaluated.
                    let p_y = emitting.bsdf().pdf(&vpl.geometry(), -to_vpl, vpl.w_in);
                    share(vpl.arrival, vpl.arrival + b + b * p_y / vpl.nee_pdf)
                } else {
                    balance(vpl.arrival, b)
                }
            }
            Technique::Bidirectional { ref end, .. } => {
                connection_weight(end, x, vpl, emitting.bsdf(), emitting)
            }
            Technique::Bounce { bounce } => {
                let d = x - vpl.p;
                let dist2 = d.length_squared();
                balance(bounce, vpl.survival * emitting.pdf(d / dist2.sqrt()) / dist2)
            }
        };
        bounded(c, vpl.flux, w, self.bound)
    }
}

/// The balance heuristic's weight of the technique with density `a` against one with `b`:
/// 1 when `b` is zero (or `a` infinite), 0 when `a` is zero.
#[inline]
pub fn balance(a: f32, b: f32) -> f32 {
    if a.is_infinite() || b <= 0.0 {
        return 1.0;
    }
    let w = a / (a + b);
    if w.is_finite() { w } else { 0.0 }
}

/// The density `t` of one technique over the sum `total` of all of them: 1 when `t` is
/// infinite, 0 when the sum is not positive and finite.
#[inline]
fn share(t: f32, total: f32) -> f32 {
    if t.is_infinite() {
        return 1.0;
    }
    let w = t / total;
    if w.is_finite() { w.clamp(0.0, 1.0) } else { 0.0 }
}

/// A path x → y → e that ends on an emitter: what the bounce's two techniques at y weigh
/// against each other and against the connection of x to the VPL that light tracing leaves
/// at y. Densities per unit area at y and at e, the factors common to all three divided out.
#[derive(Clone, Copy, Debug)]
pub struct EmitterPath {
    /// p_x / ‖y − x‖² of the bounce.
    pub bounce: f32,
    /// Light paths of the iteration.
    pub paths: f32,
    /// The emitter point as seen from y: its cosine and squared distance, and the
    /// solid-angle densities of its direction for next-event estimation and y's BSDF.
    pub light: LightSample,
}

impl EmitterPath {
    /// (A, B, C): the connection (N light paths, each leaving y with density cos θ_e / π, or
    /// for a light that is not a triangle [`LightSample::emission`]), next-event estimation
    /// from y, BSDF sampling from y (zero for a delta light, whose density is infinite).
    fn densities(&self) -> (f32, f32, f32) {
        let l = &self.light;
        let a = match l.emission {
            None => self.paths * l.cos_light * FRAC_1_PI / l.dist2,
            Some(e) => self.paths * e,
        };
        let c = if l.pdf_light > 0.0 { self.bounce * l.pdf_bsdf / l.pdf_light } else { 0.0 };
        (a, self.bounce, c)
    }

    /// B's weight: next-event estimation from y.
    pub fn light_weight(&self) -> f32 {
        let (a, b, c) = self.densities();
        share(b, a + b + c)
    }

    /// C's weight: BSDF sampling from y that hits the emitter.
    pub fn bsdf_weight(&self) -> f32 {
        let (a, b, c) = self.densities();
        share(c, a + b + c)
    }
}

/// `w` · `c`, scaled down so that the connection's size π² · w · max(c) / max(Φ) (w · G for
/// two white Lambertian ends) stays below `bound`.
#[inline]
fn bounded(c: Vec3, flux: Vec3, w: f32, bound: f32) -> Vec3 {
    let c = c * w;
    let size = PI * PI * c.max_element() / flux.max_element();
    if size > bound { c * (bound / size) } else { c }
}

/// Weighed connections exist for point lights only.
impl Weigh<PointLights> for Weighing<'_> {
    /// The lobe of a glossy receiver (GGX α ≤ [`super::config::GLOSSY_ALPHA`],
    /// [`glossy_vertex`]), so that the resampled gather draws the lights in its lobe more
    /// often; none at a wider one, nor where `pir-bdpt`'s camera vertex after it connects
    /// with the gather's own counts ([`super::config::Connect::next`]: the
    /// paths through the lobe are then mostly that connection's).
    ///
    /// Why: a weighed connection's value follows the lobe more than the weights take from it.
    /// In the lobe of a near-mirror floor the competing BSDF sample's density per unit area is
    /// of the order of the light paths' own, so the connections there keep much of their
    /// weight, and a draw that leaves the lobe out (p̂ the geometry term alone) finds them
    /// seldom and weighs them high. Measured (`docs/results.md`, "The lobe in the weighed
    /// gather's draw"): at the same samples `pir-bdpt`'s relative MSE 17–20 % lower on the
    /// near-mirror floor (α 0.05) and 15 % in the glossy corner (α 0.1); on the floor an exact
    /// p̂ (each candidate's weighted contribution) gains 22–25 %. At α 0.22–0.24 (the
    /// glossy Cornell box) the lobe changed nothing but the cost. Any positive p̂ where
    /// the contribution is leaves the estimate unbiased ([`super::resample`]). In Bitterli's
    /// veach-ajar, whose metal floor (α 0.1) the vertex after connects from in full, the lobe
    /// there cost 9–12 % in efficiency; with `--connect first` it gains 6 % there.
    #[inline]
    fn lobe(&self, v: &Vertex) -> Option<Lobe> {
        if !glossy_vertex(v.bsdf) {
            return None;
        }
        if let Technique::Bidirectional { ref end } = self.technique
            && end.connect.next(end.rank, end.after) == Next::Full
        {
            return None;
        }
        Lobe::of(v.bsdf, v.sp.frame.n, v.wo)
    }

    /// The weight in the draw's estimates: `pir-bdpt`'s ([`DrawWeights`]). `pir-mis`'s
    /// weights are left out: measured no further than `pir-bdpt`'s.
    #[inline]
    fn draw_weights(&self) -> Option<DrawWeights> {
        match self.technique {
            Technique::Bidirectional { ref end } => DrawWeights::of(end),
            _ => None,
        }
    }

    #[inline]
    fn weigh(&self, lights: &PointLights, j: usize, x: Vec3, c: Vec3) -> Vec3 {
        self.apply(x, &lights.vpls[j], &lights.emitting[j], c)
    }

    /// `pir-bdpt`'s connection with its weight from one evaluation of each end
    /// ([`connection`]); the same numbers as the two steps.
    #[inline]
    fn picked(
        &self,
        lights: &PointLights,
        j: usize,
        rx: &PointReceiver<'_>,
        x: Vec3,
        sampler: &mut Sampler,
    ) -> Option<Vec3> {
        let Technique::Bidirectional { ref end } = self.technique else {
            return weighed_pick(self, lights, j, rx, x, sampler);
        };
        let vpl = &lights.vpls[j];
        let (c, w) = connection(end, x, vpl, &lights.emitting[j], lights.bound);
        (c != Vec3::ZERO).then(|| bounded(c, vpl.flux, w, self.bound))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Frame;
    use crate::material::Bsdf;
    use crate::scene::SurfacePoint;

    /// A receiver at the origin facing +z.
    fn surface_point() -> SurfacePoint {
        SurfacePoint {
            p: Vec3::ZERO,
            ng: Vec3::Z,
            frame: Frame::from_normal(Vec3::Z),
            prim: 0,
            material: 0,
            uv: glam::Vec2::ZERO,
            back: false,
        }
    }

    /// The weighed gathers draw by the lobe of a glossy receiver (α ≤ 0.15) and by the
    /// geometry term alone at a wider or a Lambertian one.
    #[test]
    fn the_weighed_draw_follows_the_lobe_of_a_glossy_receiver_only() {
        let sp = surface_point();
        let weighing = Weighing { technique: Technique::Bounce { bounce: 1.0 }, bound: 1.0 };
        let glossy =
            |roughness| Bsdf::Glossy { albedo: Vec3::splat(0.05), specular: Vec3::splat(0.8), roughness };
        for (bsdf, lobe) in [
            (glossy(0.05), true),
            (glossy(0.15), true),
            (glossy(0.22), false),
            (Bsdf::Diffuse { albedo: Vec3::splat(0.5) }, false),
        ] {
            let v = Vertex { sp: &sp, wo: Vec3::new(0.0, 0.6, 0.8), bsdf: &bsdf, depth: 1 };
            assert_eq!(weighing.lobe(&v).is_some(), lobe, "{bsdf:?}");
        }
    }

    /// `pir-bdpt`'s gather leaves a glossy receiver's lobe out of its draw where the camera
    /// vertex after the receiver connects with the full counts (after a metal under
    /// `--connect glossy`, after any vertex under `all` and `first-two`), whose connections
    /// carry the paths in the lobe, and keeps it where that vertex connects with fewer draws
    /// (after a coated one under `glossy`) or not at all (`first`); a Lambertian receiver has
    /// no lobe either way.
    #[test]
    fn the_bidirectional_draw_leaves_the_lobe_to_a_next_vertex_that_connects_in_full() {
        use super::super::config::{After, Connect};
        use super::super::subpath::{Counts, MisState};
        use crate::material::TransportMode;
        use crate::material::conductor::ComplexIor;
        use crate::material::microfacet::{Distribution, Microfacet};
        let sp = surface_point();
        let wo = Vec3::new(0.0, 0.6, 0.8);
        let metal = Bsdf::RoughConductor {
            specular: Vec3::splat(0.9),
            ior: ComplexIor { eta: Vec3::new(0.2, 0.5, 1.4), k: Vec3::new(3.6, 2.4, 1.9) },
            microfacet: Microfacet::new(Distribution::Ggx, 0.1),
        };
        let coated = Bsdf::Glossy { albedo: Vec3::splat(0.2), specular: Vec3::splat(0.6), roughness: 0.1 };
        let lambertian = Bsdf::Diffuse { albedo: Vec3::splat(0.5) };
        for (bsdf, connect, after, lobe) in [
            (metal, Connect::Glossy, After::Glossy, false),
            (metal, Connect::All, After::Plain, false),
            (metal, Connect::FirstTwo, After::Plain, false),
            (metal, Connect::First, After::Plain, true),
            (coated, Connect::Glossy, After::Coated, true),
            (coated, Connect::All, After::Plain, false),
            (coated, Connect::First, After::Plain, true),
            (lambertian, Connect::Glossy, After::Plain, false),
            (lambertian, Connect::All, After::Plain, false),
        ] {
            assert_eq!(connect.after(&bsdf), after, "{bsdf:?} under {connect:?}");
            let geometry = sp.geometry();
            let fx = PreparedBsdf::new(bsdf, geometry, wo, TransportMode::Radiance);
            let end = CameraEnd {
                fx: &fx,
                bsdf: &bsdf,
                geometry,
                wo,
                state: MisState::CAMERA,
                connect,
                rank: 1,
                after,
                fewer: false,
                counts: Counts::uniform(32.0),
                count_in: 1.0,
            };
            let weighing = Weighing { technique: Technique::Bidirectional { end }, bound: 1.0 };
            let v = Vertex { sp: &sp, wo, bsdf: &bsdf, depth: 1 };
            assert_eq!(weighing.lobe(&v).is_some(), lobe, "{bsdf:?} under {connect:?}");
        }
    }

    #[test]
    fn balance_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (1e-30, 1e30), (3.0, 3.0), (0.5, 1e-8)] {
            let s = balance(a, b) + balance(b, a);
            assert!((s - 1.0).abs() < 1e-6, "{a} {b}: {s}");
        }
        assert_eq!(balance(f32::INFINITY, 1.0), 1.0);
        assert_eq!(balance(1.0, 0.0), 1.0);
        assert_eq!(balance(0.0, 1.0), 0.0);
    }

    #[test]
    fn the_bound_is_the_clamp_for_white_lambertian_ends() {
        // c = Φ (1/π)(1/π) G: size w · G.
        let flux = Vec3::splat(2.0);
        let g = 40.0;
        let c = flux * (g / (PI * PI));
        let out = bounded(c, flux, 0.5, 10.0);
        assert!((out.x - flux.x * 10.0 / (PI * PI)).abs() < 1e-5, "{out}");
        assert_eq!(bounded(c, flux, 0.5, 100.0), c * 0.5);
    }
}
