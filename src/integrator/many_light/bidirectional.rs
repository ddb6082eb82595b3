//! Bidirectional weighing of VPL connections (`pir-bdpt`): every camera path is a full path
//! tracer's (next-event estimation and BSDF-sampled emission at every vertex, Russian
//! roulette), and at every non-delta vertex it also connects to the iteration's VPLs; each
//! path is counted by all the techniques that can make it, weighed by the balance heuristic
//! (the two emitter techniques among themselves by the power heuristic, as `pt` weighs them).
//!
//! **The techniques.** Take a path z_1 … z_k from the camera's first hit z_1 to an emitter
//! point z_k. pir can make it in k + 1 ways, by t = 0 … k camera vertices:
//! - t = k: the camera path hits the emitter (BSDF sampling); one sample per camera path;
//! - t = k − 1: next-event estimation at z_{k−1}; one sample, or n = `--light-samples` at
//!   the camera's first vertex (default 2), counted n times, each sample's estimate divided
//!   by n;
//! - t ≤ k − 2: the camera vertex z_t connects to the VPL that light tracing left at z_{t+1}
//!   (its light path came from the emitter through z_k … z_{t+2}); the iteration's N light
//!   paths give N samples, so this technique's density is N times its path density (a
//!   sampled gather counts fewer: [`Counts`]);
//! - t = 0: light tracing to the camera ([`super::to_camera`]): the light path that came
//!   from the emitter through z_k … z_2 to z_1 connects z_1 to the lens and splats into the
//!   film; each of the N light paths splats, so it counts N (but
//!   [`super::subpath::LIGHT_TRACING_COUNT`] N where z_1 is lit directly, k = 2, whose
//!   splats compete with light samples that the sampler stratifies and they are not),
//!   against the camera's density of z_1 (its direction density with a pixel as the unit
//!   of area, times cos / d²). An
//!   emitter seen directly (k = 1) is the camera's alone: light tracing does not connect the
//!   emitter's own point to the lens.
//!
//! A connection needs z_t and z_{t+1} non-delta (and, in `pir-bdpt`, neither near-specular: its
//! count is zero there, [`Counts::factor`]), next-event estimation z_{k−1}, light tracing
//! z_1; the hit is always possible. Every technique reaches every path length up to `max_depth`, so the set
//! of techniques is the same for every path of a given shape and the balance heuristic's
//! weights p_t n_t / Σ_u p_u n_u (n_u for a connection as [`Counts`] says from its two
//! ends, the light samples for next-event estimation, 1 for the hit, N or a quarter of it
//! for light tracing)
//! sum to one: without
//! a bound the estimate is unbiased per iteration (`ir-bdpt`, the tests). Light tracing
//! makes the paths no other technique can, a caustic seen directly (z_1 diffuse, z_2 … z_{k−1}
//! delta): the camera finds them only by BSDF sampling into the delta chain, which rarely
//! reaches a small light (fireflies).
//!
//! **The emitter techniques: the power heuristic among themselves.** The weights are
//! two-level: next-event estimation and the hit together take their balance-heuristic share
//! against the connections, (p_n + p_h) / (p_n + p_h + Σ_c p_c n_c), and split it between
//! them by the power heuristic (β = 2), p_n² / (p_n² + p_h²), as `pt` does; a connection
//! keeps p_c n_c / Σ_u p_u n_u. The three shares of a path still sum to one, whatever the
//! densities. A path that no connection can make (the direct light of the first non-delta
//! vertex: a connection needs two non-delta vertices before the emitter) is weighed as `pt`
//! weighs it, within the share light tracing leaves it where the camera ray found the vertex
//! directly (after a delta chain light tracing cannot make the path): small over most of the
//! image (the camera's density of a point, thousands of pixels over what it sees, against a
//! quarter of the N light paths), not near a light, where light paths crowd, which is why
//! light tracing counts a quarter on these paths ([`super::subpath::LIGHT_TRACING_COUNT`]);
//! this keeps
//! `pir-bdpt` as good as `pt` where direct light dominates
//! (`docs/integrator-measurements.md`, "Which heuristic"; `docs/results.md`, "Light tracing
//! counts a quarter where it meets light samples").
//!
//! **Computing the weights.** As in Georgiev's vertex connection and merging (the technical
//! report "Implementing vertex connection and merging", 2012, in bidirectional mode), each
//! subpath carries two running sums ([`MisState`]): `dvcm`, the density ratio of the
//! technique that would end the other subpath one vertex earlier, and `dvc`, the sum over
//! the techniques that end it earlier still. They are updated at every hit and scatter from
//! the BSDF's densities in both directions, and a connection, a light sample or an emitter
//! hit finishes the sum with its own end's densities. pir's changes: the camera subpath starts
//! at 1 / the camera's direction density (light tracing's N over N, in sums relative to N;
//! zero without light tracing, which the camera path then leaves out too; the two camera
//! techniques of a path of two segments read its term a quarter, [`MisState::for_light_sample`],
//! [`MisState::for_hit`]), the light subpath
//! carries its sums by which camera vertices `--connect` lets connect ([`MisState::beyond`]:
//! the connection folded in last, and those after a glossy vertex), and the counts n_u:
//! the light subpath's sums
//! start divided by N (the two emitter techniques it carries count once, not N times), and
//! the camera subpath's sums count N when next-event estimation or a hit weighs them. A
//! connection whose count is not N enters either subpath's sums times its count relative to
//! N (`Scatter::count`, [`Vpl::count_out`], [`CameraEnd::count_in`]), and a connection's
//! own weight divides the others by its count, so every technique keeps its own count.
//! Russian roulette is left out of the densities: the weights still sum to one (every
//! technique is weighed with the same densities), only a little less well balanced.
//!
//! **Why it is robust.** Every path that a path tracer samples well (a glossy lobe at any
//! vertex, a camera ray that hits the light) is still sampled as the path tracer samples
//! it, and its VPL connections get the share the balance heuristic gives them: where a
//! connection spikes (a short segment, a receiver's or a VPL's lobe), the path tracer's
//! density is the larger and takes the path. Where light arrives by long diffuse chains or
//! through an opening, the connections dominate. What is left of the connection keeps the
//! progressive bound of `pir-mis` ([`super::mis::Weighing::apply`]), b_i = b_1 · i^α on
//! π² · w · max(c) / max(Φ); its bias vanishes as b_i grows, so `pir-bdpt` is consistent.
//!
//! **Light samples at the first vertex.** The direct light of the camera's first vertex is
//! the one error the connections cannot take over (a connection needs two non-delta vertices
//! before the emitter), and where light comes through an opening it is most of what is left.
//! An iteration's cost is
//! mostly the gather and the path, so a light sample costs `pir-bdpt` a smaller share than
//! it costs `pt`: two are the default where the emitters are in view, more where a pilot
//! finds them mostly hidden ([`light_samples_for`]). The samples' points are one block of
//! consecutive points of one Sobol dimension (`Sampler::next_2d_block`), so that they are
//! stratified among themselves as well as over the iterations (`docs/integrator-measurements.md`,
//! "Light samples at the first vertex").
//!
//! Cost: a path tracer's rays plus a gather at each non-delta vertex of the camera path
//! (the resampled gather: k shadow rays of about m candidates; one of 32 after a coated vertex,
//! [`super::config::AFTER_COATED`]).

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

use super::config::{After, Connect, Next};
use super::light_paths::Vpl;
use super::points::point_value;
use super::subpath::{Counts, MisState, light_tracing_count};
use crate::integrator::direct::LightSample;
use crate::material::{Bsdf, LocalGeometry, PreparedBsdf};

/// Most light samples at the first vertex that [`light_samples_for`] chooses: 8 times the
/// default, where an iteration's camera path with its gather costs about as many rays as
/// the samples do.
pub const MAX_AUTO_LIGHT_SAMPLES: u32 = 16;

/// The light samples at the camera path's first vertex for a scene whose emitters next-event
/// estimation finds unoccluded with probability `visibility` (the pilot's,
/// [`super::path_count::Pilot`]), `base` where they are in view: `base` times the power of
/// two nearest (in log scale) to 1 / √v, at most [`MAX_AUTO_LIGHT_SAMPLES`].
///
/// Why: a light sample's estimate is the emitter's light times a visibility that is 1 with
/// probability v, so its variance grows about as 1 / v where the emitters are mostly hidden,
/// while its cost (one shadow ray) does not; the sample count that minimises variance × cost
/// grows as the standard deviation, 1 / √v. Powers of two, because then the samples are an
/// aligned block of a Sobol sequence (`Sampler::next_2d_block`), a net of their own. In
/// the slit room (v = 0.15–0.20) 4 is where relative MSE × time flattens; where the emitters
/// are in view (v > 1/2) this is `base` (`docs/integrator-measurements.md`, "Light samples
/// where the emitters hide"). Not measured (NaN): `base`;
/// nothing in view (v ≤ 0): the most.
pub fn light_samples_for(base: u32, visibility: f32) -> u32 {
    let v = visibility;
    if v.is_nan() || v >= 1.0 {
        return base;
    }
    if v <= 0.0 {
        return base.max(MAX_AUTO_LIGHT_SAMPLES);
    }
    // log2(1 / √v) rounded half away from zero: 0 for v > 1/2, 1 for 1/8 < v ≤ 1/2, 2 for
    // 1/32 < v ≤ 1/8, …
    let doublings = (-0.5 * v.log2()).round().min(8.0) as u32;
    base.saturating_mul(1 << doublings).min(MAX_AUTO_LIGHT_SAMPLES.max(base))
}

/// 1 / (1 + others): the balance heuristic's weight of a technique, given the other
/// techniques' densities relative to its own; 0 when they are not finite.
#[inline]
fn weight(others: f32) -> f32 {
    let w = 1.0 / (1.0 + others);
    if w.is_finite() && others >= 0.0 { w } else { 0.0 }
}

/// The weight of one of the two emitter techniques (next-event estimation, the hit), given
/// the other's density relative to its own (`emitter`) and the connections' (`connections`):
/// the two as a group against the connections by the balance heuristic, (1 + e) / (1 + e +
/// c), and within the group by the power heuristic, 1 / (1 + e²) (see the module docs).
#[inline]
fn emitter_weight(emitter: f32, connections: f32) -> f32 {
    let w = (1.0 + emitter) / (1.0 + emitter + connections) / (1.0 + emitter * emitter);
    if w.is_finite() && emitter >= 0.0 && connections >= 0.0 { w } else { 0.0 }
}

/// The weight of an emitter hit by BSDF sampling, at an emitter point whose cosine towards
/// the path is `cos_light`, with the camera subpath's `state` (after [`MisState::arrive`]):
/// next-event estimation at the vertex the ray left is `dvcm`'s technique, with
/// `light_samples` samples there and its density of the point per unit area `pdf_nee`, the
/// connections `dvc`'s, their light paths starting there with area density `pdf_area` (the
/// same as `pdf_nee` but where next-event estimation samples a sphere's cone).
#[inline]
pub fn hit_weight(
    state: &MisState,
    pdf_nee: f32,
    pdf_area: f32,
    cos_light: f32,
    paths: f32,
    light_samples: f32,
) -> f32 {
    let emission_pdf = pdf_area * cos_light * FRAC_1_PI;
    emitter_weight(light_samples * pdf_nee * state.dvcm, paths * emission_pdf * state.dvc)
}

/// The weight of an environment found by a BSDF-sampled ray that leaves the scene, in the
/// direction that next-event estimation picks with density `nee` (the environment's
/// selection probability times its solid-angle density), with the camera subpath's `state`
/// as the last scatter left it (no [`MisState::arrive`]: the environment is at no distance,
/// and a light path leaving it starts from the disk covering the scene, with density
/// `emission` per unit area, [`crate::light::Light::emission_density`]): as [`hit_weight`]
/// with the emitter point's densities replaced by the direction's.
#[inline]
pub fn escape_weight(state: &MisState, nee: f32, emission: f32, paths: f32, light_samples: f32) -> f32 {
    emitter_weight(light_samples * nee * state.dvcm, paths * nee * emission * state.dvc)
}

/// The weight of next-event estimation from a camera vertex: `light` as sampled, `pdf_rev`
/// the density of the vertex's BSDF sampling back along the camera path from the light's
/// direction, `cos_receiver` the cosine at the vertex towards the light; `previous` the
/// count of the connection from the camera vertex before it to this one, relative to
/// `paths` ([`Counts::factor`]), 0 when that vertex does not connect to VPLs;
/// `light_samples` the light samples taken at the vertex (the technique's count: each
/// sample's estimate is divided by it).
#[inline]
pub fn light_weight(
    state: &MisState,
    light: &LightSample,
    pdf_rev: f32,
    cos_receiver: f32,
    paths: f32,
    previous: f32,
    light_samples: f32,
) -> f32 {
    if light.pdf_light.is_nan() || light.pdf_light <= 0.0 {
        return 0.0;
    }
    // The other techniques' densities relative to all the light samples' (exact for one).
    let hit = light.pdf_bsdf / (light_samples * light.pdf_light);
    // Light tracing's density of the receiver, per unit area: an emitter point's cosine-
    // distributed direction, or relative to next-event estimation's own pick where that is not
    // the emitter point by area: a sphere's cone (the light path's density relative to the
    // cone's), a point or spot light's direction, a light at infinity's point on the disk
    // covering the scene.
    let extend = match light.emission {
        None => paths * light.cos_light * cos_receiver * FRAC_1_PI / light.dist2,
        Some(emission) => paths * emission * cos_receiver,
    };
    let dvcm = state.dvcm * previous;
    emitter_weight(hit, extend * (dvcm + state.dvc * pdf_rev) / light_samples)
}

/// What a connection's weight needs of the camera vertex: its BSDF prepared for its `wo`,
/// the BSDF and geometry again for the reverse density, and its subpath's sums.
#[derive(Clone, Copy)]
pub struct CameraEnd<'a> {
    pub fx: &'a PreparedBsdf,
    pub bsdf: &'a Bsdf,
    pub geometry: LocalGeometry,
    pub wo: Vec3,
    pub state: MisState,
    /// Which camera vertices connect, and this one's rank among the camera path's non-delta
    /// vertices ([`Connect::at`]): whether the vertices after it connect (else only the
    /// emitter techniques extend the camera subpath into the light subpath).
    pub connect: Connect,
    pub rank: u32,
    /// What this vertex makes of the camera vertex after it for `connect`
    /// ([`Connect::after`]; found once per vertex, not per connection), and whether it draws
    /// fewer itself ([`super::config::Connecting::fewer_picks`]), which its connections count
    /// ([`Counts::at`]).
    pub after: After,
    pub fewer: bool,
    /// The connections' counts, and the count of the connection from the camera vertex
    /// before this one to this one (relative to [`Counts::paths`]; 0 where that vertex does
    /// not connect; any value where the sums are zero).
    pub counts: Counts,
    pub count_in: f32,
}

/// The weight of the connection from the camera vertex `x` (at `p`) to `vpl`, whose BSDF is
/// `bsdf_y`, prepared for its incoming direction as `emitting`.
#[inline]
pub fn connection_weight(x: &CameraEnd, p: Vec3, vpl: &Vpl, bsdf_y: &Bsdf, emitting: &PreparedBsdf) -> f32 {
    let d = vpl.p - p;
    let dist2 = d.length_squared();
    if dist2.is_nan() || dist2 <= 0.0 {
        return 0.0;
    }
    let w = d / dist2.sqrt();
    // The reverse densities only where their factors are not zero (at the camera's first
    // vertex its sums are, so the light subpath extended to x has no competitor to weigh).
    let more = vpl.mis.beyond(x.connect, x.rank + 1, x.connect.after(bsdf_y));
    let densities = Densities {
        camera: x.fx.pdf(w),
        camera_rev: if x.state.dvc > 0.0 { x.bsdf.pdf(&x.geometry, w, x.wo) } else { 0.0 },
        light: if x.state.dvcm > 0.0 || x.state.dvc > 0.0 { emitting.pdf(-w) } else { 0.0 },
        light_rev: if more > 0.0 { bsdf_y.pdf(&vpl.geometry(), -w, vpl.w_in) } else { 0.0 },
    };
    weight_of(x, vpl, bsdf_y, w, dist2, more, densities)
}

/// A connection's contribution ([`super::points::point_contribution`] with the G bound `bound`) and its
/// weight ([`connection_weight`]), bit for bit those two, from one evaluation of each end's
/// BSDF with both its densities ([`PreparedBsdf::eval_pdfs`]) instead of two values and four
/// densities: a picked connection's cost, where the ends are glossy, is mostly these.
#[inline]
pub fn connection(x: &CameraEnd, p: Vec3, vpl: &Vpl, emitting: &PreparedBsdf, bound: f32) -> (Vec3, f32) {
    let d = vpl.p - p;
    let dist2 = d.length_squared();
    if dist2 <= 0.0 {
        return (Vec3::ZERO, 0.0);
    }
    let w = d / dist2.sqrt();
    let (fx, camera, camera_rev) = x.fx.eval_pdfs(w);
    if fx == Vec3::ZERO {
        return (Vec3::ZERO, 0.0);
    }
    let (fy, light, light_rev) = emitting.eval_pdfs(-w);
    if fy == Vec3::ZERO {
        return (Vec3::ZERO, 0.0);
    }
    let c = point_value(vpl, fx, fy, x.geometry.frame.n, w, dist2, bound);
    // (`dist2` is a positive number here: a NaN one made `fx` zero.)
    let bsdf_y = emitting.bsdf();
    let more = vpl.mis.beyond(x.connect, x.rank + 1, x.connect.after(bsdf_y));
    (c, weight_of(x, vpl, bsdf_y, w, dist2, more, Densities { camera, camera_rev, light, light_rev }))
}

/// The connection's weight as the resampled gather's draw estimates it
/// ([`super::lanes`]): [`connection_weight`] for a Lambertian receiver at the camera path's
/// first vertex and a Lambertian VPL, from one number per VPL ([`draw_term`]) and two per
/// receiver ([`DrawWeights::of`]).
///
/// Why: the draw picks k of the window's VPLs in proportion to p̂, their unoccluded
/// contribution, but what a pick adds is that contribution times its weight. Near a
/// crease (a VPL on the wall next to the floor point that gathers) G grows as 1/d² and so
/// does the camera's BSDF density of the VPL's point, which takes the path: there the
/// weighted contribution levels off while p̂ does not, and the draw spends its picks on
/// VPLs whose weight is nearly zero. With the weight in p̂ it follows the weighted value.
///
/// The balance heuristic's weight is 1 / (1 + (w_light + w_camera) / count)
/// ([`weight_of`]): w_light = p_x(ω) cos θ_y / d² · (one + more · light_rev), the camera
/// subpath extended to the VPL and beyond, and w_camera = p_y(−ω) cos θ_x / d² · (dvcm ·
/// count_in + dvc · camera_rev), the light subpath extended to x (light tracing at the
/// first vertex). For Lambertian ends p_x = cos θ_x / π, p_y = cos θ_y / π, light_rev and
/// camera_rev do not depend on ω, and the weight is 1 / (1 + h) with
/// h = (cos_x^s cos_y^g · T_y · L + cos_y^s cos_x^g · C_x) / d², T_y the VPL's term, L and
/// C_x the receiver's numbers. Elsewhere (a glossy end, a deeper vertex, a glossy receiver
/// whose next vertex connects) the same formula only estimates the weight, at a glossy
/// receiver that draws by its lobe with the lobe's sampling density in place of cos θ_x / π
/// ([`super::lobe::Lobe::sampling`]): any positive p̂ where the contribution is not zero
/// keeps the gather unbiased ([`super::resample`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrawWeights {
    /// L = 1 / (π · count), the factor of the VPL's term.
    pub light: f32,
    /// C_x: the receiver's own term, (dvcm · count_in + dvc · camera_rev) / (π · count).
    pub camera: f32,
}

impl DrawWeights {
    /// The receiver's side at the camera vertex `x`; `None` where the connection's count
    /// is zero (no gather there) or a number is not finite.
    pub fn of(x: &CameraEnd) -> Option<DrawWeights> {
        // The count of a connection to a VPL of the receiver's own kind (a glossy end
        // counts as glossy either way; a Lambertian receiver's connection to a glossy VPL
        // counts fewer, which this leaves out).
        let count = x.counts.at(x.bsdf, x.bsdf, x.fewer);
        let light = FRAC_1_PI / count;
        let camera_rev =
            if x.state.dvc > 0.0 { x.bsdf.pdf(&x.geometry, x.geometry.frame.n, x.wo) } else { 0.0 };
        let camera = (x.state.dvcm * x.count_in + x.state.dvc * camera_rev) * light;
        let w = DrawWeights { light, camera };
        (count > 0.0 && light.is_finite() && camera.is_finite() && camera >= 0.0).then_some(w)
    }
}

/// T_y, a VPL's side of [`DrawWeights`] for `connect`, its BSDF `bsdf_y`: the camera
/// subpath's sums beyond the VPL, one + more · light_rev, as they are at a Lambertian camera
/// vertex of rank 1 (`one` next-event estimation at the VPL where it is lit directly, else
/// the connection from it to the light path's previous VPL where the camera vertex after
/// the first connects). Light_rev, the VPL's BSDF density of the way the light came, is
/// taken from its shading normal (exact for a Lambertian VPL). Zero where not finite.
pub fn draw_term(vpl: &Vpl, bsdf_y: &Bsdf, connect: Connect) -> f32 {
    let more = vpl.mis.beyond(connect, 2, connect.after(bsdf_y));
    let light_rev = if more > 0.0 { bsdf_y.pdf(&vpl.geometry(), vpl.frame.n, vpl.w_in) } else { 0.0 };
    let t = one_beyond(vpl, connect.next(1, After::Plain)) + more * light_rev;
    if t.is_finite() && t > 0.0 { t } else { 0.0 }
}

/// The camera subpath extended one vertex past the VPL, relative to the connection to it:
/// next-event estimation at the VPL where it is lit directly, else the connection from the
/// VPL to the light path's previous VPL, as the camera vertex after the receiver makes it
/// (`next`).
#[inline]
fn one_beyond(vpl: &Vpl, next: Next) -> f32 {
    match (vpl.depth, next) {
        (1, _) => vpl.mis.dvcm,
        (_, Next::Full) => vpl.mis.dvcm * vpl.count_out,
        // (The camera vertex at the VPL draws fewer where this one is coated.)
        (_, Next::Fewer) => vpl.mis.dvcm * vpl.count_out_fewer,
        (_, Next::None) => 0.0,
    }
}

/// The solid-angle densities of a connection's ends that its weight needs: the camera
/// vertex's BSDF sampling towards the VPL and, from there, back along the camera path; the
/// VPL's towards the camera vertex and, from there, back the way the light came.
struct Densities {
    camera: f32,
    camera_rev: f32,
    light: f32,
    light_rev: f32,
}

/// [`connection_weight`] from the unit direction `w` from the camera vertex to the VPL, their
/// squared distance, the light subpath's sum `more` ([`MisState::beyond`]) and the ends'
/// densities (of which only those whose factors are not zero are used).
#[inline]
fn weight_of(x: &CameraEnd, vpl: &Vpl, bsdf_y: &Bsdf, w: Vec3, dist2: f32, more: f32, d: Densities) -> f32 {
    let cos_x = x.geometry.ng.dot(w).abs();
    let cos_y = vpl.ng.dot(w).abs();
    // The camera subpath extended to the VPL, and the light subpath extended to x.
    let camera_pdf = d.camera * cos_y / dist2;
    let light_rev = if more > 0.0 { d.light_rev } else { 0.0 };
    let w_camera = if x.state.dvcm > 0.0 || x.state.dvc > 0.0 {
        let camera_rev = if x.state.dvc > 0.0 { d.camera_rev } else { 0.0 };
        d.light * cos_x / dist2 * (x.state.dvcm * x.count_in + x.state.dvc * camera_rev)
    } else {
        0.0
    };
    // Two or more vertices further: the emitter techniques, and connections if every vertex
    // connects.
    let w_light = camera_pdf * (one_beyond(vpl, x.connect.next(x.rank, x.after)) + more * light_rev);
    // All of them relative to this connection's count.
    weight((w_light + w_camera) / x.counts.at(x.bsdf, bsdf_y, x.fewer))
}

/// The weight of light tracing to the camera from the light subpath's vertex `y`: `mis` its
/// sums on arriving there, `depth` its segments from the emitter, `after` what it makes of
/// the camera vertex after it for `connect` ([`Connect::after`]), `count_out` the count of the
/// connection from it (as the camera's first vertex) to the light subpath's previous vertex
/// ([`Vpl::count_out`]); `pdf_camera` the camera's density of `y` per unit area (its direction
/// density, [`crate::scene::CameraRays::direction_pdf`], times cos θ_y / d²), `light_rev` the
/// density of `y`'s BSDF sampling, from the camera's direction, the way the light came; the
/// first camera vertex takes `light_samples` light samples.
///
/// The others, relative to light tracing (which counts N, each light path splatting once,
/// or [`super::subpath::LIGHT_TRACING_COUNT`] N from a vertex lit directly,
/// [`light_tracing_count`]):
/// the camera path ending at `y` (next-event estimation there if it is lit directly, else
/// the connection to the previous vertex's VPL; `dvcm`) and further on (`dvc`, only the
/// emitter techniques where the camera connects at its first vertex only, and the connections
/// that `connect` allows at the vertices after the first, [`MisState::beyond`]), all behind
/// the camera's density of `y`.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn camera_weight(
    mis: &MisState,
    depth: u32,
    after: After,
    count_out: f32,
    pdf_camera: f32,
    light_rev: f32,
    connect: Connect,
    light_samples: f32,
) -> f32 {
    let one = if depth == 1 { mis.dvcm * light_samples } else { mis.dvcm * count_out };
    let more = mis.beyond(connect, 1, after);
    // All of them relative to light tracing's own count.
    weight(pdf_camera * (one + more * light_rev) / light_tracing_count(depth))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Frame;
    use crate::integrator::many_light::config::Connecting;
    use crate::integrator::many_light::config::Gather;
    use crate::integrator::many_light::points::point_contribution;
    use crate::integrator::many_light::subpath::{LIGHT_TRACING_COUNT, Scatter};
    use crate::material::TransportMode;
    use crate::sampling::{Domain, Sampler};
    use std::f32::consts::PI;

    /// A vertex of a test path: position, normal, BSDF (`None`: a delta vertex).
    struct Node {
        p: Vec3,
        g: LocalGeometry,
        bsdf: Option<Bsdf>,
    }

    impl Node {
        fn dir(&self, to: &Node) -> Vec3 {
            (to.p - self.p).normalize()
        }
        fn cos(&self, to: &Node) -> f32 {
            self.g.ng.dot(self.dir(to)).abs()
        }
        /// The BSDF's density of sampling towards `to` given `from` (1 for a delta vertex).
        fn pdf(&self, from: &Node, to: &Node) -> f32 {
            self.bsdf.map_or(1.0, |b| b.pdf(&self.g, self.dir(from), self.dir(to)))
        }
    }

    fn dist2(a: &Node, b: &Node) -> f32 {
        (a.p - b.p).length_squared()
    }

    /// Counts of 32 light paths: `lambertian` and `glossy` relative to them, and a quarter of
    /// each where the camera vertex draws fewer ([`Counts::at`]).
    fn counts_of(lambertian: f32, glossy: f32) -> Counts {
        Counts {
            paths: 32.0,
            lambertian,
            glossy,
            fewer_lambertian: lambertian / 4.0,
            fewer_glossy: glossy / 4.0,
            skip_near_specular: false,
        }
    }

    /// The count of the connection between `b` and the vertex `a` before it on its subpath
    /// (none at the camera or the emitter), as the renderer folds it in
    /// ([`Counts::between`]; a delta vertex is a mirror).
    fn factor(counts: Counts, a: Option<&Node>, b: &Node) -> f32 {
        factor_at(counts, a, b, false)
    }

    /// [`factor`] where the camera end draws fewer or not ([`Counts::between_at`]).
    fn factor_at(counts: Counts, a: Option<&Node>, b: &Node, fewer: bool) -> f32 {
        let bsdf = |n: &Node| n.bsdf.unwrap_or(Bsdf::Mirror { specular: Vec3::ONE });
        counts.between_at(a.map(bsdf).as_ref(), &bsdf(b), fewer)
    }

    /// Whether the camera vertex z[t] draws fewer ([`Connecting::fewer_picks`]; none at the
    /// camera, t = 0).
    fn fewer(z: &[Node], t: usize, connect: Connect) -> bool {
        t > 0 && walk(z, t, connect).fewer_picks()
    }

    /// Where a test path's light comes from: its last vertex z[k].
    #[derive(Clone, Copy, Debug)]
    enum Source {
        /// A point of an emitting triangle, where light paths start with area density
        /// `pdf_area` and next-event estimation from z[k − 1] picks it with `pdf_nee` (per unit
        /// area; another where it samples a sphere's cone).
        Area { pdf_area: f32, pdf_nee: f32 },
        /// A point light at z[k], emitting in a direction of this density.
        Point(f32),
        /// An environment in the direction from z[k − 1] to z[k]: next-event estimation picks
        /// it with density `nee`, light tracing starts from a disk of density `disk`.
        Environment { nee: f32, disk: f32 },
    }

    /// The test camera's density of the direction from z[0] to `to`, as
    /// [`crate::scene::CameraRays::direction_pdf`] has it: W H / (A cos³ θ) about the view
    /// axis +z (every test path lies in front of it), W H / A chosen so that light tracing
    /// and the camera's techniques weigh alike on the test paths.
    fn camera_pdf_dir(z: &[Node], to: &Node) -> f32 {
        let cos = z[0].dir(to).z;
        100.0 / (cos * cos * cos)
    }

    /// The camera's density of z[1] per unit area.
    fn camera_pdf_area(z: &[Node]) -> f32 {
        camera_pdf_dir(z, &z[1]) * z[1].cos(&z[0]) / dist2(&z[0], &z[1])
    }

    /// Which camera vertices connect, the walk having passed the non-delta ones of z[1..=t]
    /// (z[0] is the camera).
    fn walk(z: &[Node], t: usize, connect: Connect) -> Connecting {
        let mut c = Connecting::CAMERA;
        for n in &z[1..=t] {
            if let Some(b) = &n.bsdf {
                c.pass(connect, b);
            }
        }
        c
    }

    /// The rank of the camera vertex z[t] among the path's non-delta vertices z[1..=t]
    /// ([`Connect::at`]).
    fn rank(z: &[Node], t: usize) -> u32 {
        walk(z, t, Connect::First).rank()
    }

    /// The camera subpath's sums on arriving at z[t] (z[0] is the camera).
    fn camera_state(z: &[Node], t: usize, connect: Connect, counts: Counts) -> MisState {
        camera_state_to(z, t, connect, counts, true)
    }

    /// [`camera_state`], or, with `arrive` false, the sums as the scatter at z[t − 1]
    /// towards z[t] leaves them (an environment's: no distance to arrive over).
    fn camera_state_to(z: &[Node], t: usize, connect: Connect, counts: Counts, arrive: bool) -> MisState {
        let mut s = MisState::from_camera(camera_pdf_dir(z, &z[1]));
        for j in 1..=t {
            if j == t && !arrive {
                break;
            }
            s.arrive(dist2(&z[j - 1], &z[j]), z[j].cos(&z[j - 1]));
            if j < t {
                let (pdf, rev) = (z[j].pdf(&z[j - 1], &z[j + 1]), z[j].pdf(&z[j + 1], &z[j - 1]));
                let delta = z[j].bsdf.is_none();
                let count = factor_at(counts, (j > 1).then(|| &z[j - 1]), &z[j], fewer(z, j - 1, connect));
                let fold = walk(z, j, connect).previous_connects();
                let scatter = Scatter::camera(pdf, rev, z[j].cos(&z[j + 1]), delta, fold, count);
                s.scatter(scatter);
            }
        }
        s
    }

    /// The light subpath's sums on arriving at z[t] from the emitter z[k].
    fn light_state(z: &[Node], t: usize, source: Source, counts: Counts) -> MisState {
        let k = z.len() - 1;
        let mut s = match source {
            Source::Area { pdf_area, .. } => MisState::light(pdf_area, z[k].cos(&z[k - 1]), counts.paths),
            Source::Point(p_dir) => MisState::light_source(f32::INFINITY, p_dir, counts.paths),
            Source::Environment { nee, disk } => MisState::light_source(nee, disk, counts.paths),
        };
        for j in (t..k).rev() {
            let d2 = match source {
                Source::Environment { .. } if j + 1 == k => 1.0,
                _ => dist2(&z[j + 1], &z[j]),
            };
            s.arrive(d2, z[j].cos(&z[j + 1]));
            // As light tracing rescales it where next-event estimation samples a cone.
            if let Source::Area { pdf_area, pdf_nee } = source
                && j == k - 1
                && pdf_nee != pdf_area
            {
                s.dvcm *= pdf_nee / pdf_area;
            }
            if j > t {
                let (pdf, rev) = (z[j].pdf(&z[j + 1], &z[j - 1]), z[j].pdf(&z[j - 1], &z[j + 1]));
                let delta = z[j].bsdf.is_none();
                let count = factor(counts, (j + 1 < k).then(|| &z[j + 1]), &z[j]);
                let count_fewer = factor_at(counts, (j + 1 < k).then(|| &z[j + 1]), &z[j], true);
                let after = z[j].bsdf.map_or(After::Plain, |b| After::of(&b));
                let depth = (k - j) as u32;
                let cos = z[j].cos(&z[j - 1]);
                s.scatter(Scatter::light(pdf, rev, cos, delta, depth, count, count_fewer, after));
            }
        }
        s
    }

    /// Every technique's weight for the path z[1..=k] (z[k] on the emitter), in order of t
    /// from t = 0, light tracing to the camera; `None` for a technique that cannot make the
    /// path. The first vertex takes
    /// `light_samples` light samples.
    fn weights(
        z: &[Node],
        pdf_area: f32,
        counts: Counts,
        connect: Connect,
        light_samples: u32,
    ) -> Vec<Option<f32>> {
        weights_from(z, Source::Area { pdf_area, pdf_nee: pdf_area }, counts, connect, light_samples)
    }

    thread_local! {
        /// Connections whose weight [`draw_weight_agrees`] compared with the draw's, on this
        /// test's thread.
        static DRAW_WEIGHTS_CHECKED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
        /// At glossy receivers of the camera's first vertex and Lambertian VPLs: the
        /// connections compared, and the sums of |ln(estimate / weight)| of the draw's
        /// estimate with the lobe's sampling density and with a Lambertian receiver's.
        static LOBE_DRAWS: std::cell::Cell<(usize, f64, f64)> = const { std::cell::Cell::new((0, 0.0, 0.0)) };
    }

    /// Where the draw's estimate of the weight is exact (two Lambertian ends, the camera's
    /// first vertex, [`DrawWeights`]), the resampled gather's estimate with the weight is the
    /// one without it times `weight`: [`VplLanes`]' kernel with [`draw_term`] and
    /// [`DrawWeights::of`] against [`connection_weight`], to a relative 10⁻⁴ down to the
    /// smallest weight the draw takes ([`MIN_DRAW_WEIGHT`], below which it is that). Elsewhere
    /// it is a weight in [`MIN_DRAW_WEIGHT`], 1]; at a glossy receiver of the first vertex with
    /// its lobe ([`Lobe`]), its error is recorded in `LOBE_DRAWS`, with that of the same
    /// estimate without the lobe's density.
    fn draw_weight_agrees(
        end: &CameraEnd,
        x: Vec3,
        vpl: &Vpl,
        by: &Bsdf,
        emitting: &PreparedBsdf,
        connect: Connect,
        weight: f32,
    ) {
        use super::super::lanes::{EstimateReceiver, MIN_DRAW_WEIGHT, VplLanes};
        use super::super::lobe::Lobe;
        let lanes = VplLanes::new(
            std::slice::from_ref(vpl),
            std::slice::from_ref(emitting),
            &[1.0],
            &[draw_term(vpl, by, connect)],
        );
        let Some(weights) = DrawWeights::of(end) else { return };
        let (g, n) = (end.geometry, vpl.depth);
        let r = |weights| EstimateReceiver {
            x,
            ng: g.ng,
            ns: g.frame.n,
            bound: f32::INFINITY,
            max_depth: n,
            lobe: None,
            transmits: false,
            weights,
        };
        let (with, without) =
            (lanes.estimates_for(0, &r(Some(weights)))[0], lanes.estimates_for(0, &r(None))[0]);
        if without <= 0.0 {
            return;
        }
        let estimated = with / without;
        let lambertian = |b: &Bsdf| matches!(b, Bsdf::Diffuse { .. });
        if lambertian(end.bsdf) && lambertian(by) && end.rank == 1 && !end.fewer {
            let want = weight.max(MIN_DRAW_WEIGHT);
            assert!((estimated - want).abs() <= 1e-4 * want, "draw {estimated}, weight {weight}");
            DRAW_WEIGHTS_CHECKED.with(|c| c.set(c.get() + 1));
        } else {
            let (lo, hi) = (MIN_DRAW_WEIGHT * (1.0 - 1e-4), 1.0 + 1e-6);
            assert!((lo..=hi).contains(&estimated), "draw {estimated}, weight {weight}");
        }
        // A glossy receiver's draw with its lobe: the weight's estimate is the ratio of the
        // estimates with and without the weights, both with the lobe.
        let Some(lobe) = Lobe::of(end.bsdf, g.frame.n, end.wo) else { return };
        if !(lambertian(by) && end.rank == 1 && !end.fewer && weight > MIN_DRAW_WEIGHT) {
            return;
        }
        let lobed = |weights| EstimateReceiver { lobe: Some(&lobe), ..r(weights) };
        let (with, without) =
            (lanes.estimates_for(0, &lobed(Some(weights)))[0], lanes.estimates_for(0, &lobed(None))[0]);
        if without <= 0.0 {
            return;
        }
        let error = |e: f32| (e as f64 / weight as f64).ln().abs();
        LOBE_DRAWS.with(|c| {
            let (n, lobe, plain) = c.get();
            c.set((n + 1, lobe + error(with / without), plain + error(estimated)))
        });
    }

    /// [`weights`] for light from `source`.
    fn weights_from(
        z: &[Node],
        source: Source,
        counts: Counts,
        connect: Connect,
        light_samples: u32,
    ) -> Vec<Option<f32>> {
        let k = z.len() - 1;
        let paths = counts.paths;
        let samples_at = |t: usize| if rank(z, t) == 1 { light_samples as f32 } else { 1.0 };
        // Light tracing: the light subpath's vertex z[1] connected to the camera, as
        // `to_camera` weighs it.
        let mut w = vec![z[1].bsdf.map(|_| {
            let mis = light_state(z, 1, source, counts);
            let count_out = factor(counts, (2 < k).then(|| &z[2]), &z[1]);
            let light_rev = z[1].pdf(&z[0], &z[2]);
            let pdf_camera = camera_pdf_area(z);
            let after = z[1].bsdf.map_or(After::Plain, |b| connect.after(&b));
            let depth = (k - 1) as u32;
            camera_weight(&mis, depth, after, count_out, pdf_camera, light_rev, connect, samples_at(1))
        })];
        for t in 1..=k {
            let x = &z[t];
            let count_in = factor_at(counts, (t > 1).then(|| &z[t - 1]), x, fewer(z, t - 1, connect));
            if t == k {
                w.push(match source {
                    Source::Area { pdf_area, pdf_nee } => {
                        let cam = camera_state(z, t, connect, counts);
                        let cam = cam.for_hit(t as u32);
                        Some(hit_weight(&cam, pdf_nee, pdf_area, x.cos(&z[k - 1]), paths, samples_at(t - 1)))
                    }
                    Source::Point(_) => None,
                    Source::Environment { nee, disk } => {
                        let cam = camera_state_to(z, t, connect, counts, false);
                        Some(escape_weight(&cam.for_hit(t as u32), nee, disk, paths, samples_at(t - 1)))
                    }
                });
                continue;
            }
            let cam = camera_state(z, t, connect, counts);
            // A connection needs both ends non-delta and connecting ([`Counts::connects_at`]).
            let ends = |y: &Node| y.bsdf.is_some_and(|b| counts.connects_at(&b));
            let possible = t + 1 == k || (ends(x) && ends(&z[t + 1]) && walk(z, t, connect).connects());
            let Some(bx) = x.bsdf.filter(|_| possible) else {
                w.push(None);
                continue;
            };
            w.push(if t == k - 1 {
                let e = &z[k];
                let d2 = dist2(x, e);
                let pdf_bsdf = x.pdf(&z[t - 1], e);
                let (wi, cos_light) = (x.dir(e), e.cos(x));
                let light = match source {
                    Source::Area { pdf_area, pdf_nee } => {
                        let pdf_light = pdf_nee * d2 / cos_light;
                        LightSample {
                            pdf_light,
                            pdf_bsdf,
                            cos_light,
                            dist2: d2,
                            wi,
                            // As next-event estimation by a cone sets it (`direct::cone_emission`).
                            emission: (pdf_nee != pdf_area).then(|| pdf_area * FRAC_1_PI / pdf_light),
                        }
                    }
                    Source::Point(p_dir) => LightSample {
                        pdf_light: f32::INFINITY,
                        pdf_bsdf,
                        cos_light: 1.0,
                        dist2: d2,
                        wi,
                        emission: Some(p_dir / d2),
                    },
                    Source::Environment { nee, disk } => LightSample {
                        pdf_light: nee,
                        pdf_bsdf,
                        cos_light: 1.0,
                        dist2: f32::INFINITY,
                        wi,
                        emission: Some(disk),
                    },
                };
                let previous = if walk(z, t, connect).previous_connects() { count_in } else { 0.0 };
                let n = samples_at(t);
                let cam = cam.for_light_sample(t as u32);
                Some(light_weight(&cam, &light, x.pdf(e, &z[t - 1]), x.cos(e), paths, previous, n))
            } else {
                let y = &z[t + 1];
                let by = y.bsdf.unwrap();
                let w_in = y.dir(&z[t + 2]);
                let vpl = Vpl {
                    arrival: 0.0,
                    mis: light_state(z, t + 1, source, counts),
                    count_out: factor(counts, (t + 2 < k).then(|| &z[t + 2]), y),
                    count_out_fewer: factor_at(counts, (t + 2 < k).then(|| &z[t + 2]), y, true),
                    ..Vpl::for_test(y.p, y.g.ng, y.g.frame, w_in, Vec3::ONE, (k - t - 1) as u32)
                };
                let wo = x.dir(&z[t - 1]);
                let fx = PreparedBsdf::new(bx, x.g, wo, TransportMode::Radiance);
                let emitting = PreparedBsdf::new(by, y.g, w_in, TransportMode::Importance);
                let end = CameraEnd {
                    fx: &fx,
                    bsdf: &bx,
                    geometry: x.g,
                    wo,
                    state: cam,
                    connect,
                    rank: rank(z, t),
                    after: walk(z, t, connect).after(),
                    fewer: fewer(z, t, connect),
                    counts,
                    count_in: if walk(z, t, connect).previous_connects() { count_in } else { 0.0 },
                };
                let weight = connection_weight(&end, x.p, &vpl, &by, &emitting);
                draw_weight_agrees(&end, x.p, &vpl, &by, &emitting, connect, weight);
                // The pick's evaluation of both at once gives the same numbers bit for bit.
                for bound in [f32::INFINITY, 0.5] {
                    let (c, fused) = connection(&end, x.p, &vpl, &emitting, bound);
                    let alone = point_contribution(x.p, x.g.frame.n, &fx, &vpl, &emitting, bound);
                    assert_eq!(c.to_array().map(f32::to_bits), alone.to_array().map(f32::to_bits));
                    if c != Vec3::ZERO {
                        assert_eq!(fused.to_bits(), weight.to_bits(), "{c} {fused} {weight}");
                    }
                }
                Some(weight)
            });
        }
        w
    }

    /// The sum of a path's weights where every one is finite (`None` where a density
    /// overflowed, which the weights' callers never see: such paths are not checked).
    fn finite_sum(w: &[Option<f32>]) -> Option<f32> {
        w.iter().flatten().all(|w| w.is_finite()).then(|| w.iter().flatten().sum())
    }

    fn random_path(s: &mut Sampler, k: usize, delta_at: Option<usize>) -> Vec<Node> {
        let mut pts: Vec<Vec3> =
            (0..=k).map(|_| Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 4.0).collect();
        pts[0] = Vec3::new(2.0, 2.0, -6.0);
        (0..=k)
            .map(|j| {
                // A normal facing both neighbours, tilted at random.
                let mut n = Vec3::ZERO;
                if j > 0 {
                    n += (pts[j - 1] - pts[j]).normalize();
                }
                if j < k {
                    n += (pts[j + 1] - pts[j]).normalize();
                }
                let tilt = Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, s.next_f32() - 0.5) * 0.3;
                let n = (n.normalize_or(Vec3::Z) + tilt).normalize();
                // Diffuse, or glossy over a diffuse base (coated where α ≤ 0.15), or a rough
                // metal (glossy without a base, [`After::Glossy`] where α ≤ 0.15).
                let bsdf = if delta_at == Some(j) {
                    None
                } else if s.next_f32() < 0.5 {
                    Some(Bsdf::Diffuse { albedo: Vec3::splat(0.7) })
                } else {
                    let albedo = if s.next_f32() < 0.5 { Vec3::splat(0.2) } else { Vec3::ZERO };
                    Some(Bsdf::Glossy {
                        albedo,
                        specular: Vec3::splat(0.6),
                        roughness: 0.1 + 0.4 * s.next_f32(),
                    })
                };
                Node { p: pts[j], g: LocalGeometry { ng: n, frame: Frame::from_normal(n) }, bsdf }
            })
            .collect()
    }

    /// On a path camera → z_1 → z_2 → emitter z_3, the connection at z_1 weighs exactly
    /// n_c P_c / (n_c P_c + P_nee + P_hit + P_lt) with the densities written out (the camera
    /// ray's common to the first three left out, light tracing's divided by it) and n_c its
    /// count by its two ends: Lambertian and glossy
    /// vertices, counts below one of either kind.
    #[test]
    fn the_connection_weighs_its_count_against_the_emitter_techniques() {
        let mut s = Sampler::new(11, 0, Domain::LightPath, 0);
        let counts = counts_of(0.5, 0.125);
        let pdf_area = 0.6;
        let mut checked = [0; 2];
        for _ in 0..400 {
            let z = random_path(&mut s, 3, None);
            let front = |j: usize, i: usize| z[j].g.ng.dot(z[j].dir(&z[i])) > 0.05;
            if !(front(1, 0) && front(1, 2) && front(2, 1) && front(2, 3) && front(3, 2)) {
                continue;
            }
            let (b1, b2) = (z[1].bsdf.unwrap(), z[2].bsdf.unwrap());
            let n_c = counts.paths * counts.factor(&b1, &b2);
            let p_c = pdf_area * z[3].cos(&z[2]) / PI * z[2].cos(&z[3]) / dist2(&z[2], &z[3]);
            let camera_z2 = z[1].pdf(&z[0], &z[2]) * z[2].cos(&z[1]) / dist2(&z[1], &z[2]);
            let p_nee = camera_z2 * pdf_area;
            let p_hit = camera_z2 * z[2].pdf(&z[1], &z[3]) * z[3].cos(&z[2]) / dist2(&z[2], &z[3]);
            // Light tracing: the light path to z_1, over the camera's density of z_1 (z_1 is
            // not lit directly: counted N).
            let p_lt = counts.paths * p_c * z[2].pdf(&z[3], &z[1]) * z[1].cos(&z[2])
                / dist2(&z[1], &z[2])
                / camera_pdf_area(&z);
            let expected = n_c * p_c / (n_c * p_c + p_nee + p_hit + p_lt);
            let w = weights(&z, pdf_area, counts, Connect::First, 1);
            let got = w[1].unwrap();
            assert!(
                (got - expected).abs() < 1e-3 * expected.max(1e-3),
                "{b1:?} {b2:?}: {got} against {expected}"
            );
            checked[usize::from(counts.factor(&b1, &b2) == counts.lambertian)] += 1;
        }
        assert!(checked.iter().all(|&n| n > 20), "checked (glossy, Lambertian): {checked:?}");
    }

    /// The counts' rule: the exhaustive gather N; the light tree and a glossy end 2k; two
    /// Lambertian ends with the resampled gather 4k / v, at most N (N where nothing was in
    /// view, 4k where nothing was measured).
    #[test]
    fn counts_follow_the_gather_the_ends_and_the_visibility() {
        let lambert = Bsdf::Diffuse { albedo: Vec3::splat(0.5) };
        let glossy = Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::splat(0.5), roughness: 0.2 };
        let resample = Gather::Resampled { candidates: 128, samples: 4 };
        let count = |c: Counts, a: &Bsdf, b: &Bsdf| c.paths * c.factor(a, b);
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-3 * b;
        for v in [1.0, 0.97, 0.5, 0.16, 0.01, 0.0, f32::NAN] {
            let all = Counts::new(512, Gather::All, v);
            assert!(
                close(count(all, &lambert, &glossy), 512.0) && close(count(all, &lambert, &lambert), 512.0)
            );
            let tree = Counts::new(512, Gather::Tree { samples: 4 }, v);
            assert!(
                close(count(tree, &lambert, &lambert), 8.0) && close(count(tree, &glossy, &lambert), 8.0)
            );
            let c = Counts::new(512, resample, v);
            assert!(
                close(count(c, &glossy, &lambert), 8.0) && close(count(c, &lambert, &glossy), 8.0),
                "{v}"
            );
            let expected = match v {
                v if v.is_nan() => 16.0,
                v if v <= 0.0 => 512.0,
                v => (16.0 / v).min(512.0),
            };
            assert!(close(count(c, &lambert, &lambert), expected), "{v}: {c:?}");
            assert_eq!(c.between(None, &glossy), 1.0);
            // A camera vertex that draws one (`AFTER_COATED`) counts one pick: 2 for a glossy
            // end, 4 / v between Lambertian ends; the exhaustive gather counts every path.
            let fewer = |c: Counts, a: &Bsdf, b: &Bsdf| c.paths * c.at(a, b, true);
            assert!(close(fewer(c, &glossy, &lambert), 2.0) && close(fewer(tree, &lambert, &lambert), 2.0));
            let one_pick = match v {
                v if v.is_nan() => 4.0,
                v if v <= 0.0 => 512.0,
                v => (4.0 / v).min(512.0),
            };
            assert!(close(fewer(c, &lambert, &lambert), one_pick), "{v}: {c:?}");
            assert!(close(fewer(all, &lambert, &glossy), 512.0));
        }
        // Fewer paths than 2k: every connection counts them all.
        let few = Counts::new(5, resample, 0.5);
        assert!(close(count(few, &lambert, &lambert), 5.0) && close(count(few, &glossy, &glossy), 5.0));
    }

    /// The light samples' rule: the default where the emitters are in view, doubled for
    /// every factor of four by which their visibility falls (1 / √v to the nearest power of
    /// two in log scale), at most 16, and always a power of two times the base.
    #[test]
    fn light_samples_grow_as_the_emitters_hide() {
        for (v, expected) in [
            (1.0, 2),
            (0.97, 2),
            (0.51, 2),
            (0.49, 4),
            (0.17, 4),
            (0.15, 4),
            (0.13, 4),
            (0.12, 8),
            (0.032, 8),
            (0.03, 16),
            (1e-6, 16),
            (0.0, 16),
            (-1.0, 16),
            (f32::NAN, 2),
            (f32::INFINITY, 2),
        ] {
            assert_eq!(light_samples_for(2, v), expected, "v = {v}");
        }
        for base in [1, 2, 4, 8, 16, 64] {
            for v in [1.0, 0.3, 0.1, 0.01, 0.0] {
                let n = light_samples_for(base, v);
                assert!(
                    n >= base && n.is_power_of_two() && n <= MAX_AUTO_LIGHT_SAMPLES.max(base),
                    "{base}, {v}: {n}"
                );
            }
        }
    }
    /// The direct light of the first non-delta vertex (a path of two segments) is weighed as
    /// `pt` weighs it, the power heuristic of next-event estimation against BSDF sampling,
    /// within the share that light tracing to the camera leaves them, which is light
    /// tracing's density c N p_L(z_1) (c its count, [`LIGHT_TRACING_COUNT`]) against theirs,
    /// balanced, with the densities written out.
    #[test]
    fn direct_light_is_weighed_as_the_path_tracer_weighs_it() {
        let mut s = Sampler::new(5, 0, Domain::LightPath, 0);
        let mut checked = 0;
        for trial in 0..200 {
            let z = random_path(&mut s, 2, None);
            let (x, e) = (&z[1], &z[2]);
            if x.g.ng.dot(x.dir(&z[0])) <= 0.05
                || x.g.ng.dot(x.dir(e)) <= 0.05
                || e.g.ng.dot(e.dir(x)) <= 0.05
            {
                continue;
            }
            let pdf_area = 0.1 + trial as f32 * 0.01;
            let pdf_light = pdf_area * dist2(x, e) / e.cos(x);
            let pdf_bsdf = x.pdf(&z[0], e);
            // With n light samples, the power heuristic with counts: (n p_l)² / ((n p_l)² + p_b²).
            for n in [1, 3] {
                let w = weights(&z, pdf_area, counts_of(1.0, 0.25), Connect::First, n);
                let nee = crate::integrator::direct::power_heuristic(n as f32 * pdf_light, pdf_bsdf);
                // Per unit area of the emitter point, each over the camera's density of z_1.
                let to_area = e.cos(x) / dist2(x, e);
                let p_lt = LIGHT_TRACING_COUNT * 32.0 * pdf_area * e.cos(x) / PI * x.cos(e)
                    / dist2(x, e)
                    / camera_pdf_area(&z);
                let lt = p_lt / (p_lt + n as f32 * pdf_area + pdf_bsdf * to_area);
                let rest = 1.0 - lt;
                assert!((w[0].unwrap() - lt).abs() < 1e-4 * lt.max(1e-2), "n {n}: {w:?} against {lt}");
                assert!((w[1].unwrap() - rest * nee).abs() < 1e-4, "n {n}: {w:?} against {}", rest * nee);
                assert!(
                    (w[2].unwrap() - rest * (1.0 - nee)).abs() < 1e-4,
                    "n {n}: {w:?} against {}",
                    rest * (1.0 - nee)
                );
            }
            checked += 1;
        }
        assert!(checked > 50, "only {checked} paths checked");
    }

    /// The techniques' weights of a path sum to one, for paths of 2 to 7 vertices with diffuse
    /// and glossy vertices, and with a delta vertex (which rules out the connections that
    /// touch it), whichever camera vertices connect; light tracing to the camera among them,
    /// with a share large enough on many paths that the sum fails without it.
    #[test]
    fn weights_of_every_path_sum_to_one() {
        let mut s = Sampler::new(3, 0, Domain::LightPath, 0);
        let mut checked = 0;
        let mut light_tracing = 0;
        for trial in 0..400 {
            let k = 2 + trial % 6;
            let delta_at = (trial % 3 == 0 && k > 2).then(|| 1 + trial / 3 % (k - 1));
            let z = random_path(&mut s, k, delta_at);
            // Only paths that carry light: every neighbour in front of every vertex.
            let front = |j: usize, i: usize| z[j].g.ng.dot(z[j].dir(&z[i])) > 0.05;
            if !(1..=k).all(|j| front(j, j - 1) && (j == k || front(j, j + 1))) {
                continue;
            }
            for (connect, light_samples) in [
                (Connect::First, 1),
                (Connect::FirstTwo, 1),
                (Connect::All, 1),
                (Connect::Glossy, 1),
                (Connect::First, 4),
                (Connect::All, 3),
                (Connect::Glossy, 2),
            ] {
                // Every connection counted alike, and a glossy end counted a quarter.
                for counts in [Counts::uniform(32.0), counts_of(1.0, 0.25), counts_of(0.5, 0.125)] {
                    // Next-event estimation by area, and by a cone denser or sparser there.
                    for pdf_nee in [0.37, 0.05, 4.0] {
                        let source = Source::Area { pdf_area: 0.37, pdf_nee };
                        let w = weights_from(&z, source, counts, connect, light_samples);
                        if let Some(sum) = finite_sum(&w) {
                            assert!(
                                (sum - 1.0).abs() < 2e-3,
                                "k {k}, delta at {delta_at:?}, {connect:?}, {light_samples} light samples, {counts:?}, next-event density {pdf_nee}: weights {w:?} sum to {sum}"
                            );
                            checked += 1;
                            light_tracing += usize::from(w[0].is_some_and(|w| w > 0.05));
                        }
                    }
                }
            }
        }
        assert!(checked > 3 * 4500, "only {checked} paths checked");
        assert!(
            light_tracing > checked / 10,
            "light tracing weighs over 5 % on {light_tracing} of {checked}"
        );
        let draws = DRAW_WEIGHTS_CHECKED.with(|c| c.get());
        assert!(draws > 1000, "the draw's weight checked against {draws} connections only");
        // At glossy receivers the lobe's sampling density brings the draw's weight closer to
        // the connection's: BSDF sampling takes the paths in the lobe, and a Lambertian
        // receiver's density misses that by the lobe's peak.
        let (n, lobe, plain) = LOBE_DRAWS.with(|c| c.get());
        let (lobe, plain) = (lobe / n as f64, plain / n as f64);
        eprintln!(
            "glossy receivers: {n} draws, mean |ln(estimate / weight)| {lobe:.3} with the lobe, {plain:.3} without"
        );
        assert!(n > 200, "only {n} glossy receivers' draws compared");
        assert!(lobe < 0.5 * plain, "mean |ln(estimate / weight)| {lobe} with the lobe, {plain} without");
    }

    /// Makes z[j] a near-specular vertex ([`super::super::config::near_specular`]) that
    /// reflects the path exactly: its normal halfway between its neighbours, a rough metal or
    /// a glossy lobe without albedo of α below the threshold.
    fn make_near_specular(z: &mut [Node], j: usize, glossy: bool) {
        let n = (z[j].dir(&z[j - 1]) + z[j].dir(&z[j + 1])).normalize();
        z[j].g = LocalGeometry { ng: n, frame: Frame::from_normal(n) };
        z[j].bsdf = Some(if glossy {
            Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::splat(0.8), roughness: 0.008 }
        } else {
            Bsdf::RoughConductor {
                specular: Vec3::ONE,
                ior: crate::material::conductor::ComplexIor::NONE,
                microfacet: crate::material::microfacet::Microfacet::new(
                    crate::material::microfacet::Distribution::Ggx,
                    0.005,
                ),
            }
        });
    }

    /// With near-specular vertices, whose connections count zero where the counts skip them
    /// (`pir-bdpt`: no gather there, no VPL there), the weights of every path still sum to
    /// one, whichever camera vertices connect; and the connections that touch them are
    /// left out, while the path tracer's techniques and light tracing take the path.
    #[test]
    fn weights_sum_to_one_where_near_specular_vertices_connect_nothing() {
        let mut s = Sampler::new(13, 0, Domain::LightPath, 0);
        let (mut checked, mut without) = (0, 0);
        for trial in 0..600 {
            let k = 3 + trial % 5;
            let mut z = random_path(&mut s, k, None);
            // One or two near-specular vertices among z[1..k].
            let first = 1 + trial / 5 % (k - 1);
            make_near_specular(&mut z, first, trial % 2 == 0);
            if trial % 3 == 0 && k > 3 {
                let second = 1 + (first + 1 + trial / 7 % (k - 2)) % (k - 1);
                make_near_specular(&mut z, second, trial % 4 == 1);
            }
            let front = |j: usize, i: usize| z[j].g.ng.dot(z[j].dir(&z[i])) > 0.05;
            if !(1..=k).all(|j| front(j, j - 1) && (j == k || front(j, j + 1))) {
                continue;
            }
            for (connect, light_samples) in
                [(Connect::First, 1), (Connect::FirstTwo, 2), (Connect::All, 1), (Connect::Glossy, 1)]
            {
                for counts in [
                    Counts::uniform(32.0).skipping_near_specular(),
                    counts_of(0.5, 0.125).skipping_near_specular(),
                ] {
                    for pdf_nee in [0.37, 4.0] {
                        let source = Source::Area { pdf_area: 0.37, pdf_nee };
                        let w = weights_from(&z, source, counts, connect, light_samples);
                        let Some(sum) = finite_sum(&w) else { continue };
                        assert!(
                            (sum - 1.0).abs() < 2e-3,
                            "k {k}, near-specular at {first}, {connect:?}, {counts:?}: weights {w:?} sum to {sum}"
                        );
                        // The connection at the near-specular vertex (unless it is next-event
                        // estimation's) and the one to it (unless it is light tracing's): no
                        // technique.
                        assert!(first + 1 == k || w[first].is_none(), "{w:?}");
                        assert!(first == 1 || w[first - 1].is_none(), "{w:?}");
                        checked += 1;
                    }
                    // Without the skip, the same path's weights sum to one with those
                    // connections among them.
                    let all = Counts { skip_near_specular: false, ..counts };
                    let w = weights_from(&z, Source::Area { pdf_area: 0.37, pdf_nee: 0.37 }, all, connect, 1);
                    if let Some(sum) = finite_sum(&w) {
                        assert!((sum - 1.0).abs() < 2e-3, "without the skip: {w:?} sum to {sum}");
                        without += 1;
                    }
                }
            }
        }
        assert!(checked > 1500 && without > 500, "only {checked} and {without} paths checked");
    }

    /// The same with light from a point light (which no BSDF sample hits) and from an
    /// environment (whose light paths start on a disk, and which the camera subpath finds by
    /// leaving the scene): the weights of every path still sum to one.
    #[test]
    fn weights_sum_to_one_with_delta_and_infinite_lights() {
        let mut s = Sampler::new(7, 0, Domain::LightPath, 0);
        let mut checked = [0; 2];
        for trial in 0..400 {
            let k = 2 + trial % 6;
            let delta_at = (trial % 3 == 0 && k > 2).then(|| 1 + trial / 3 % (k - 1));
            let z = random_path(&mut s, k, delta_at);
            let front = |j: usize, i: usize| z[j].g.ng.dot(z[j].dir(&z[i])) > 0.05;
            if !(1..k).all(|j| front(j, j - 1) && front(j, j + 1)) {
                continue;
            }
            let sources = [
                Source::Point(0.2 + 0.1 * (trial % 5) as f32),
                Source::Environment { nee: 0.05 + 0.3 * (trial % 4) as f32, disk: 0.02 },
            ];
            for (i, source) in sources.into_iter().enumerate() {
                for (connect, light_samples) in
                    [(Connect::First, 1), (Connect::All, 1), (Connect::FirstTwo, 4), (Connect::Glossy, 1)]
                {
                    for counts in [Counts::uniform(32.0), counts_of(0.5, 0.125)] {
                        let w = weights_from(&z, source, counts, connect, light_samples);
                        let Some(sum) = finite_sum(&w) else { continue };
                        assert!(
                            (sum - 1.0).abs() < 2e-3,
                            "{source:?}, k {k}, delta at {delta_at:?}, {connect:?}, {light_samples} light samples, {counts:?}: weights {w:?} sum to {sum}"
                        );
                        checked[i] += 1;
                    }
                }
            }
        }
        assert!(checked.iter().all(|&n| n > 800), "checked (point, environment): {checked:?}");
    }
}
