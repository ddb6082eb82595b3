//! `pir-bdpt`'s camera path: the walker's [`Estimator`] whose every technique is weighed by
//! the bidirectional weights of [`super::bidirectional`], its [`MisState`] the per-path state
//! (weighed against light tracing to the camera, [`super::to_camera`], where the light paths
//! splat).

use glam::Vec3;

use super::bidirectional::{CameraEnd, escape_weight, hit_weight, light_weight};
use super::config::{AFTER_COATED, Connect, Connecting};
use super::light_set::LightSet;
use super::merging::{Caustic, Merging};
use super::mis::{Technique, Weighing};
use super::points::PointLights;
use super::subpath::{Counts, MisState, Scatter};
use crate::geometry::Ray;
use crate::integrator::deferred::Terms;
use crate::integrator::direct::{Sampled, connect_emitters_at};
use crate::integrator::walker::{Arrival, Estimator, Vertex};
use crate::integrator::{Counters, RenderContext};
use crate::material::{Bsdf, BsdfSample, PreparedBsdf, TransportMode};
use crate::sampling::Sampler;
use crate::scene::CameraRays;

/// `pir-bdpt`'s camera path: a full path tracer's walk with next-event estimation, emitter
/// hits and the gather from `set` at the non-delta vertices that `connect` names, all weighed
/// bidirectionally, the weighted connections bounded by `bound`.
pub struct Bidirectional<'a> {
    pub set: &'a LightSet<PointLights>,
    pub connect: Connect,
    /// Light samples at the first non-delta vertex (one at the others).
    pub light_samples: u32,
    pub counts: Counts,
    pub bound: f32,
    /// The camera that the light paths splat into ([`super::to_camera`]), whose density of
    /// the camera ray starts the weights' sums; none: no light tracing to the camera.
    pub camera: Option<&'a CameraRays>,
    /// The iteration's photons, merged with at the first non-delta vertex after a delta chain
    /// ([`super::merging`]); none: no merging.
    pub merging: Option<&'a Merging>,
}

/// The camera subpath's bookkeeping along the walk.
#[derive(Default)]
pub struct CameraPath {
    /// The running sums of its weights.
    mis: MisState,
    /// The vertex the current ray left (the camera's origin at first).
    from: Vec3,
    /// The BSDF of the vertex the current ray left (none at the camera).
    previous: Option<Bsdf>,
    /// The segments from the camera to the vertex the current ray left (0 at the camera).
    depth: u32,
    /// The non-delta vertices the path has passed, and which of them connect (the last
    /// one's rank: 1 for the first non-delta vertex, whatever delta vertices came before it).
    connecting: Connecting,
    /// Where the path is in the class of paths that merging makes.
    caustic: Caustic,
}

impl Bidirectional<'_> {
    /// The light samples at the camera vertex of `path` that the walk is at: `light_samples`
    /// at its first non-delta vertex, one at the others (valid after
    /// [`Bidirectional::vertex`] passed it).
    #[inline]
    fn samples_at(&self, path: &CameraPath) -> u32 {
        if path.connecting.rank() == 1 { self.light_samples } else { 1 }
    }

    /// The terms of the non-delta vertex `v`: its light samples summed in `terms`, each
    /// weighed bidirectionally, and the gather from the VPLs where the vertex connects
    /// (`None` where it does not) as `terms` queued it, each per unit throughput.
    #[inline(always)]
    fn vertex<T: Terms>(
        &self,
        path: &mut CameraPath,
        ctx: &RenderContext,
        v: &Vertex,
        sampler: &mut Sampler,
        counters: &mut Counters,
        terms: &mut T,
    ) -> Option<T::Gathered> {
        let (sp, wo, bsdf, depth) = (&v.sp, v.wo, v.bsdf, v.depth);
        let (counts, connect, state) = (self.counts, self.connect, path.mis);
        let connects = path.connecting.pass(connect, bsdf);
        let rank = path.connecting.rank();
        let geometry = sp.geometry();
        // The count of the connection from the previous camera vertex to this one.
        let count_in = counts.between_at(path.previous.as_ref(), bsdf, path.connecting.previous_fewer());
        let n = self.samples_at(path);
        let count = n as f32;
        // The samples' points: one block of the sequence, stratified among themselves.
        let u_select = sampler.next_f32();
        // (0 where the camera vertex before this one does not connect to VPLs.)
        let count_previous = if path.connecting.previous_connects() { count_in } else { 0.0 };
        // (The sums as next-event estimation reads them, once for the vertex's samples.)
        let nee_state = state.for_light_sample(depth);
        for u in sampler.next_2d_block(n) {
            let c = connect_emitters_at(ctx, sp, bsdf, wo, (u_select, u), counters);
            terms.sum(ctx, c, |l| {
                let pdf_rev = if state.dvc > 0.0 { bsdf.pdf(&geometry, l.wi, wo) } else { 0.0 };
                light_weight(
                    &nee_state,
                    &l,
                    pdf_rev,
                    sp.ng.dot(l.wi).abs(),
                    counts.paths,
                    count_previous,
                    count,
                )
            });
        }
        // ---- The connections to the VPLs (none at a near-specular vertex, whose count is zero).
        if !connects || !counts.connects_at(bsdf) {
            return None;
        }
        let fx = PreparedBsdf::new(*bsdf, geometry, wo, TransportMode::Radiance);
        let count_in = count_previous;
        let (after, fewer) = (path.connecting.after(), path.connecting.fewer_picks());
        let end =
            CameraEnd { fx: &fx, bsdf, geometry, wo, state, connect, rank, after, fewer, counts, count_in };
        let weighing = Weighing { technique: Technique::Bidirectional { end }, bound: self.bound };
        let max_vpl_depth = ctx.max_depth - depth - 1;
        let draws = fewer.then_some(AFTER_COATED);
        Some(self.set.gather_with(terms, ctx, v, max_vpl_depth, &weighing, draws, sampler, counters))
    }
}

impl Estimator for Bidirectional<'_> {
    const COVERS_SURFACES: bool = false;
    type State = CameraPath;

    #[inline]
    fn start(&self, ray: &Ray) -> CameraPath {
        let pdf_dir = self.camera.map(|c| c.direction_pdf(ray.dir));
        let mis = pdf_dir.map_or(MisState::CAMERA, MisState::from_camera);
        // The pixel's angle: its solid angle is 1 / the density (a pixel the unit of area).
        let caustic = match (self.merging, pdf_dir) {
            (Some(_), Some(pdf)) => Caustic::start(pdf.recip().sqrt()),
            _ => Caustic::Off,
        };
        CameraPath {
            mis,
            from: ray.origin,
            previous: None,
            depth: 0,
            connecting: Connecting::CAMERA,
            caustic,
        }
    }

    /// The environments found by a ray that leaves the scene, each weighed against
    /// next-event estimation of it at the vertex the ray left and every connection that
    /// makes the path ([`escape_weight`]); seen from the camera, the camera's alone (light
    /// tracing does not connect a light's own point to the lens).
    fn on_escape(
        &self,
        path: &mut CameraPath,
        ctx: &RenderContext,
        ray: &Ray,
        _how: &Sampled,
        beta: Vec3,
        radiance: &mut Vec3,
    ) {
        let dir = ray.dir.normalize();
        let radius = ctx.scene.bounding_sphere().1;
        // (`rank` is the vertex the ray left where that one was not delta; after a delta one
        // next-event estimation there is no technique, and the count is not used.)
        let left_samples = if path.connecting.rank() == 1 { self.light_samples as f32 } else { 1.0 };
        for &k in ctx.emitters.environments() {
            let light = &ctx.emitters.lights()[k];
            let le = light.environment(dir);
            if le == Vec3::ZERO {
                continue;
            }
            let nee = ctx.emitters.light_pmf(k) * light.environment_pdf(dir);
            let emission = light.emission_density(f32::INFINITY, radius);
            let w = match path.depth {
                0 => 1.0,
                d => escape_weight(&path.mis.for_hit(d + 1), nee, emission, self.counts.paths, left_samples),
            };
            *radiance += beta * le * w;
        }
    }

    /// The emission found by the camera ray or a BSDF sample, weighed against next-event
    /// estimation at the vertex the ray left and every connection that makes the path; found
    /// by the camera ray, the camera's alone (light tracing does not connect an emitter's own
    /// point to the lens).
    #[inline(always)]
    fn on_hit(
        &self,
        path: &mut CameraPath,
        ctx: &RenderContext,
        at: &Arrival,
        beta: Vec3,
        radiance: &mut Vec3,
    ) {
        let sp = at.sp;
        let cos_in = sp.ng.dot(at.wo).abs();
        let dist2 = (sp.p - path.from).length_squared();
        path.mis.arrive(dist2, cos_in);
        path.caustic.arrive(dist2);
        let le = sp.emitted(at.material.emission_at(sp.uv), at.wo);
        if le != Vec3::ZERO {
            let pdf_area = ctx.emitters.pdf_area(sp.prim);
            // Next-event estimation's density of the point, per unit area: a sphere's cone's, or
            // its choice by importance at `path.from`.
            let pdf_nee = match ctx.emitters.nee_pdf(sp.prim, path.from, dist2, cos_in) {
                Some(pdf) => pdf * cos_in / dist2,
                None => pdf_area,
            };
            // Light samples at the vertex the ray left: `light_samples` at the first.
            let left_samples = if path.connecting.rank() == 1 { self.light_samples as f32 } else { 1.0 };
            let w = match path.depth {
                0 => 1.0,
                d => hit_weight(
                    &path.mis.for_hit(d + 1),
                    pdf_nee,
                    pdf_area,
                    cos_in,
                    self.counts.paths,
                    left_samples,
                ),
            };
            let share = self.merging.map_or(1.0, |m| path.caustic.hit_share(m, pdf_area));
            *radiance += beta * le * (w * share);
        }
    }

    /// Next-event estimation (`light_samples` samples at the first vertex, their mean) and
    /// the connections to the VPLs.
    #[inline(always)]
    fn at_vertex(
        &self,
        path: &mut CameraPath,
        ctx: &RenderContext,
        v: &Vertex,
        beta: Vec3,
        radiance: &mut Vec3,
        sampler: &mut Sampler,
        counters: &mut Counters,
        terms: &mut impl Terms,
    ) {
        let gathered = self.vertex(path, ctx, v, sampler, counters, terms);
        terms.mean(beta, self.samples_at(path), radiance);
        if let Some(g) = gathered {
            terms.add_gathered(beta, g, radiance);
        }
        if let Some(merging) = self.merging
            && let Some(r2) = path.caustic.merge_at(merging)
        {
            terms.add(beta, merging.estimate(v, r2, ctx.max_depth), radiance);
        }
    }

    /// The camera subpath's sums extended by the sampled direction.
    #[inline(always)]
    fn on_scatter(&self, path: &mut CameraPath, v: &Vertex, s: &BsdfSample) {
        let (sp, wo, bsdf) = (&v.sp, v.wo, v.bsdf);
        let count_in = self.counts.between_at(path.previous.as_ref(), bsdf, path.connecting.previous_fewer());
        // (Only the camera's sums that are not zero need it: none at the first vertex.)
        let pdf_rev = match (s.delta, path.mis.dvc > 0.0) {
            (true, _) => s.pdf,
            (false, true) => bsdf.pdf(&sp.geometry(), s.wi, wo),
            (false, false) => 0.0,
        };
        let cos_out = sp.ng.dot(s.wi).abs();
        // (At a delta vertex nothing is folded in, whatever `fold` says.)
        let fold = path.connecting.previous_connects();
        path.mis.scatter(Scatter::camera(s.pdf, pdf_rev, cos_out, s.delta, fold, count_in));
        path.caustic.scatter(bsdf, &sp.geometry(), wo, s.wi, s.pdf, s.delta);
        path.previous = Some(*bsdf);
        path.from = sp.p;
        path.depth = v.depth;
    }
}
