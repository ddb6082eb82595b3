//! The camera-path walker: the one loop that follows a camera ray through the scene, for every
//! method (after Tungsten's `TraceBase`, whose per-vertex routine serves all its tracers, and
//! pbrt-v4's integrators over one path loop).
//!
//! The walker owns what every camera path does the same way: the closest-hit queries, the
//! depth count against `max_depth`, delta vertices (no light sampling, no gather), BSDF
//! sampling with the throughput update, and Russian roulette. A method is an [`Estimator`]:
//! what it adds where the path arrives ([`Estimator::on_hit`]: the emission found there,
//! weighted as the method weighs it), at every non-delta vertex ([`Estimator::at_vertex`]:
//! next-event estimation and the method's own techniques, e.g. a gather from the virtual
//! lights), and what it keeps of each scatter ([`Estimator::on_scatter`], e.g. the running
//! sums of bidirectional weights). Its per-path bookkeeping is its [`Estimator::State`].
//! `max_depth` counts path segments from the camera to the emitter, as Mitsuba 3 does (1 =
//! emitters seen directly, 2 = direct light, …).
//!
//! An estimator may split the path space at a non-delta vertex x of depth d by the next
//! vertex:
//! - an emitter: direct light, light sampling plus the BSDF-sampled ray's emission (MIS);
//! - a non-delta surface: the estimator's own estimate when [`Estimator::COVERS_SURFACES`]
//!   (a many-light method connects x to its virtual lights; the walk then stops at the next
//!   non-delta vertex after adding its emission, and [`Estimator::at_bounce`] there), else the
//!   walk continues through it (the path tracer, `pir-bdpt`);
//! - a delta surface (mirror, glass): the walk continues through the delta chain and the next
//!   non-delta vertex is handled in turn, which plain VPL gathering would miss (a diffuse floor
//!   lit by a wall seen in a mirror).
//!
//! So every method renders exactly the path space of the path tracer for the same
//! `max_depth`. Russian roulette (after the BSDF sample of the fifth vertex, as Mitsuba 3's
//! default `rr_depth = 5`, or of the scene's `rr_depth`; survival min(0.95, max throughput · η²), survivors reweighted: unbiased)
//! applies to full walks only: a walk whose estimator covers surfaces ends at its next
//! non-delta vertex, so only delta chains, bounded by `max_depth`, continue it.
//!
//! A ray that leaves the scene finds the environments (Mitsuba's `constant` and `envmap`)
//! where there are any ([`Estimator::on_escape`]: by default the path tracer's MIS weight
//! against light sampling, full from the camera or a delta lobe); a covered walk's ray too,
//! as its emission is the BSDF-sampled half of the direct light the estimate at the vertex it
//! left did not cover.
//!
//! Every term is added to the path's radiance as it is found, in the walker's order (emission,
//! then the vertex's terms, vertex by vertex), so that the image is a function of the
//! estimator's terms alone.

use glam::Vec3;

use super::deferred::{Immediate, Terms};
use super::direct::{Sampled, emission, environment};
use super::scatter::{scatter, survives_roulette};
use super::{Counters, RenderContext};
use crate::accel::Hit;
use crate::geometry::{Ray, offset_origin};
use crate::material::{Bsdf, BsdfSample, Material, TransportMode};
use crate::sampling::Sampler;
use crate::scene::SurfacePoint;

/// A vertex of a camera path, as an estimator sees it.
pub struct Vertex<'a> {
    pub sp: &'a SurfacePoint,
    /// Unit direction back along the camera path.
    pub wo: Vec3,
    pub bsdf: &'a Bsdf,
    /// Segments from the camera to this vertex (1 for the camera ray's hit).
    pub depth: u32,
}

/// Where a camera path arrives: the vertex, its material, and how the ray that found it was
/// sampled.
pub struct Arrival<'a> {
    pub sp: &'a SurfacePoint,
    /// Unit direction back along the camera path.
    pub wo: Vec3,
    pub material: &'a Material,
    /// Segments from the camera to this vertex.
    pub depth: u32,
    pub how: &'a Sampled,
}

/// What a method estimates along a camera path that the walker follows.
///
/// Every method adds its terms to `radiance` itself, each times the path throughput `beta`
/// it is given, so that the order of the sums is the walker's.
pub trait Estimator {
    /// Whether [`Estimator::at_vertex`] estimates every path whose vertex after this one is a
    /// non-delta surface: the walker then follows the BSDF-sampled ray only into delta
    /// vertices (and to pick up emission).
    const COVERS_SURFACES: bool;

    /// Whether the method's terms at a vertex are exactly `pt`'s: [`Estimator::at_vertex`]
    /// draws `u_select` (`next_f32`) and `u` (`next_2d`), gives [`Terms::sample`] the light
    /// sample of [`connect_emitters_at`](super::direct::connect_emitters_at) weighed against
    /// BSDF sampling by the power heuristic, and changes neither the state nor anything
    /// else; [`Estimator::on_scatter`] does nothing, and the method does not cover surfaces.
    /// Then the batched walker shades its Lambertian vertices sixteen at a time
    /// ([`super::diffuse_lanes`]) where the emitters are plain ([`Emitters::is_plain`]:
    /// triangles, no other lights, no emitting spheres sampled by their cones).
    ///
    /// [`Emitters::is_plain`]: crate::light::Emitters::is_plain
    const PT_VERTICES: bool = false;

    /// What the method keeps along one camera path.
    type State: Default;

    /// The state of a path that starts along the camera ray `ray`.
    #[inline]
    fn start(&self, _ray: &Ray) -> Self::State {
        Self::State::default()
    }

    /// At every vertex the walk reaches: the emission found there. By default the path
    /// tracer's: weighed against light sampling by the power heuristic, in full from the
    /// camera or a delta lobe.
    #[inline]
    fn on_hit(
        &self,
        _state: &mut Self::State,
        ctx: &RenderContext,
        at: &Arrival,
        beta: Vec3,
        radiance: &mut Vec3,
    ) {
        *radiance += beta * emission(ctx, at.material, at.sp, at.wo, at.how);
    }

    /// Where the ray `ray` leaves the scene (only in scenes with an environment), sampled as
    /// `how` says: the environment's radiance along it. By default the path tracer's: weighed
    /// against light sampling by the power heuristic, in full from the camera or a delta lobe.
    #[inline]
    fn on_escape(
        &self,
        _state: &mut Self::State,
        ctx: &RenderContext,
        ray: &Ray,
        how: &Sampled,
        beta: Vec3,
        radiance: &mut Vec3,
    ) {
        *radiance += beta * environment(ctx, ray.dir.normalize(), how);
    }

    /// At a non-delta vertex below `max_depth`, after [`Estimator::on_hit`] and before BSDF
    /// sampling, with the vertex's sampler: light sampling and the method's own techniques,
    /// each term given to `terms` (with `radiance`), which adds it at once (the scalar
    /// walker's [`Immediate`](super::deferred::Immediate)) or, from the first that waits for
    /// a shadow ray on, once a batch's shadow rays are traced (the batched walker's
    /// [`Deferred`](super::deferred::Deferred)): the same draws, the same terms in the same
    /// order either way.
    #[allow(clippy::too_many_arguments)]
    fn at_vertex(
        &self,
        state: &mut Self::State,
        ctx: &RenderContext,
        v: &Vertex,
        beta: Vec3,
        radiance: &mut Vec3,
        sampler: &mut Sampler,
        counters: &mut Counters,
        terms: &mut impl Terms,
    );

    /// After the BSDF at `v` (delta or not) sampled the direction the path continues in, and
    /// before Russian roulette.
    #[inline]
    fn on_scatter(&self, _state: &mut Self::State, _v: &Vertex, _s: &BsdfSample) {}

    /// Whether [`Estimator::at_bounce`] adds anything (then the walker prepares the vertex
    /// where a covered walk ends).
    #[inline]
    fn uses_bounces(&self) -> bool {
        false
    }

    /// Radiance the method adds at the non-delta vertex `v` where a covered walk ends (only
    /// when [`Estimator::COVERS_SURFACES`]; `v.depth` < `max_depth`): the walk came there by
    /// BSDF sampling as `how` says, from the vertex whose estimate covered it. A method that
    /// weighs its own estimate against this bounce (multiple importance sampling) adds the
    /// bounce's share here.
    #[inline]
    fn at_bounce(
        &self,
        _ctx: &RenderContext,
        _v: &Vertex,
        _how: &Sampled,
        _sampler: &mut Sampler,
        _counters: &mut Counters,
    ) -> Option<Vec3> {
        None
    }
}

/// One camera path between the walker's steps: what the loop keeps.
pub(super) struct Path<S> {
    /// The ray to trace next.
    pub ray: Ray,
    pub radiance: Vec3,
    pub beta: Vec3,
    pub eta_scale: f32,
    /// How `ray` was sampled: delta lobes (and the camera) get full emission.
    pub how: Sampled,
    /// `ray` left a non-delta vertex whose estimate covers the surfaces beyond it.
    pub covered: bool,
    /// Segments from the camera to the vertex `ray` left.
    pub depth: u32,
    /// The estimator's bookkeeping.
    state: S,
}

impl<S> Path<S> {
    /// The path that starts along the camera ray `ray` (unit direction).
    #[inline]
    pub(super) fn start<E: Estimator<State = S>>(estimator: &E, ray: Ray) -> Self {
        Path {
            ray,
            radiance: Vec3::ZERO,
            beta: Vec3::ONE,
            eta_scale: 1.0,
            how: Sampled::camera(ray.origin),
            covered: false,
            depth: 0,
            state: estimator.start(&ray),
        }
    }

    /// The BSDF at the vertex `from` sampled the next ray's direction with density `pdf`
    /// (per unit solid angle), from a delta lobe or not.
    #[inline(always)]
    pub(super) fn sampled(&mut self, from: Vec3, pdf: f32, delta: bool) {
        self.how = Sampled { from, pdf, delta };
        self.covered = !delta;
    }
}

/// Radiance arriving along the camera ray `ray` (unit direction), estimated by `estimator`.
pub fn walk<E: Estimator>(
    ctx: &RenderContext,
    ray: Ray,
    estimator: &E,
    sampler: &mut Sampler,
    counters: &mut Counters,
) -> Vec3 {
    let mut path = Path::start(estimator, ray);
    let terms = &mut Immediate::default();
    loop {
        counters.rays += 1;
        let hit = ctx.accel.intersect(&path.ray);
        if !step(ctx, estimator, &mut path, hit, sampler, counters, terms) {
            break;
        }
    }
    path.radiance
}

/// One step of the walk, the scalar walker's loop body ([`walk`]; the batched walker,
/// [`super::wavefront::walk_batch`], calls its two halves, [`arrive`] and [`leave`], itself):
/// the path's ray found `hit` (`None`: it left the scene); the estimator's terms at the vertex
/// go to `terms`. Whether the path goes on (its next ray in `path.ray`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn step<E: Estimator>(
    ctx: &RenderContext,
    estimator: &E,
    path: &mut Path<E::State>,
    hit: Option<Hit>,
    sampler: &mut Sampler,
    counters: &mut Counters,
    terms: &mut impl Terms,
) -> bool {
    match arrive(ctx, estimator, path, hit, sampler, counters) {
        Arrived::Done(goes_on) => goes_on,
        Arrived::At(sp, wo, material) => {
            let bsdf = &material.bsdf_at(sp.uv);
            leave(ctx, estimator, path, &sp, wo, bsdf, sampler, counters, terms)
        }
    }
}

/// What [`arrive`] leaves to the rest of the step.
pub(super) enum Arrived<'a> {
    /// The step is over: whether the path goes on.
    Done(bool),
    /// A vertex below `max_depth` (`path.depth` counts it), its emission added: the surface
    /// point, the unit direction back along the path and the material.
    At(SurfacePoint, Vec3, &'a Material),
}

/// The first part of [`step`]: where the path's ray arrives, its emission (or the
/// environment's), the end of a covered walk, the depth count.
#[inline(always)]
pub(super) fn arrive<'a, E: Estimator>(
    ctx: &RenderContext<'a>,
    estimator: &E,
    path: &mut Path<E::State>,
    hit: Option<Hit>,
    sampler: &mut Sampler,
    counters: &mut Counters,
) -> Arrived<'a> {
    let Some(hit) = hit else {
        if !ctx.emitters.environments().is_empty() {
            estimator.on_escape(&mut path.state, ctx, &path.ray, &path.how, path.beta, &mut path.radiance);
        }
        return Arrived::Done(false);
    };
    if E::COVERS_SURFACES && path.covered && !ctx.scene.material_of(hit.prim).bsdf.is_delta() {
        return Arrived::Done(covered_end(ctx, estimator, path, &hit, sampler, counters));
    }
    path.depth += 1;
    let depth = path.depth;
    let sp = ctx.scene.surface_of_hit(&hit, path.ray.dir);
    let wo = -path.ray.dir.normalize();
    let material = ctx.scene.material(sp.material);

    // ---- Emission found by the camera ray or the BSDF sample.
    let at = Arrival { sp: &sp, wo, material, depth, how: &path.how };
    estimator.on_hit(&mut path.state, ctx, &at, path.beta, &mut path.radiance);
    if depth >= ctx.max_depth {
        return Arrived::Done(false);
    }
    Arrived::At(sp, wo, material)
}

/// The rest of [`step`] at the vertex `sp` of BSDF `bsdf` that [`arrive`] found: the
/// estimator's terms, BSDF sampling, Russian roulette. Whether the path goes on.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn leave<E: Estimator>(
    ctx: &RenderContext,
    estimator: &E,
    path: &mut Path<E::State>,
    sp: &SurfacePoint,
    wo: Vec3,
    bsdf: &Bsdf,
    sampler: &mut Sampler,
    counters: &mut Counters,
    terms: &mut impl Terms,
) -> bool {
    // ---- Light sampling and the method's techniques (one more segment at least, so
    // depth + 1 ≤ max_depth).
    let depth = path.depth;
    let v = Vertex { sp, wo, bsdf, depth };
    if !bsdf.is_delta() {
        let (state, radiance) = (&mut path.state, &mut path.radiance);
        estimator.at_vertex(state, ctx, &v, path.beta, radiance, sampler, counters, terms);
    }

    // ---- BSDF sampling: the MIS half of direct light, a delta bounce, or a full bounce.
    let Some(s) = scatter(bsdf, sp, wo, TransportMode::Radiance, sampler, &mut path.beta) else {
        return false;
    };
    path.eta_scale *= s.eta * s.eta;
    estimator.on_scatter(&mut path.state, &v, &s);
    path.sampled(sp.p, s.pdf, s.delta);
    roulette_and_go_on::<E>(ctx, path, offset_origin(sp.p, sp.ng, s.wi), s.wi, sampler)
}

/// The end of [`leave`] once the BSDF sample `wi` was taken and the throughput updated:
/// Russian roulette (not on covered walks), then the next ray, from `origin` (the vertex
/// moved off its surface on `wi`'s side). Whether the path goes on.
#[inline(always)]
pub(super) fn roulette_and_go_on<E: Estimator>(
    ctx: &RenderContext,
    path: &mut Path<E::State>,
    origin: Vec3,
    wi: Vec3,
    sampler: &mut Sampler,
) -> bool {
    if !E::COVERS_SURFACES
        && path.depth >= ctx.scene.defaults().rr_depth
        && !survives_roulette(path.beta.max_element() * path.eta_scale, &mut path.beta, sampler)
    {
        return false;
    }
    path.ray = Ray::new(origin, wi);
    true
}

/// The non-delta vertex where a covered walk arrives (only when
/// [`Estimator::COVERS_SURFACES`]): the estimate carried everything beyond the vertex before
/// it; what is left is its emission (the BSDF-sampled half of direct light), the bounce's
/// share of what the estimate weighs against it, and the delta lobe of a plastic or a mask,
/// through which the path goes on. Whether it does (its next ray in `path.ray`).
#[inline(never)]
fn covered_end<E: Estimator>(
    ctx: &RenderContext,
    estimator: &E,
    path: &mut Path<E::State>,
    hit: &Hit,
    sampler: &mut Sampler,
    counters: &mut Counters,
) -> bool {
    let material = ctx.scene.material_of(hit.prim);
    let depth = path.depth;
    let bounce = estimator.uses_bounces() && depth + 1 < ctx.max_depth;
    // A plastic or a mask: the estimate covered its non-delta lobe only; the paths through
    // its delta lobe go on ([`Bsdf::has_delta`]).
    let through = material.bsdf.has_delta() && depth + 1 < ctx.max_depth;
    if !(material.is_emitter() || bounce || through) {
        return false;
    }
    let sp = ctx.scene.surface_of_hit(hit, path.ray.dir);
    let wo = -path.ray.dir.normalize();
    if material.is_emitter() {
        let at = Arrival { sp: &sp, wo, material, depth: depth + 1, how: &path.how };
        estimator.on_hit(&mut path.state, ctx, &at, path.beta, &mut path.radiance);
    }
    if !(bounce || through) {
        return false;
    }
    let bsdf = material.bsdf_at(sp.uv);
    let v = Vertex { sp: &sp, wo, bsdf: &bsdf, depth: depth + 1 };
    if bounce && let Some(l) = estimator.at_bounce(ctx, &v, &path.how, sampler, counters) {
        path.radiance += path.beta * l;
    }
    if !through {
        return false;
    }
    // Sampled in full, kept only when the delta lobe was drawn: its weight f / p of the
    // lobe's probability p is the delta paths' share, unbiased.
    let Some(s) = scatter(&bsdf, &sp, wo, TransportMode::Radiance, sampler, &mut path.beta) else {
        return false;
    };
    if !s.delta {
        return false;
    }
    path.depth += 1;
    path.eta_scale *= s.eta * s.eta;
    estimator.on_scatter(&mut path.state, &v, &s);
    path.how = Sampled { from: sp.p, pdf: s.pdf, delta: true };
    path.covered = false;
    path.ray = Ray::new(offset_origin(sp.p, sp.ng, s.wi), s.wi);
    true
}
