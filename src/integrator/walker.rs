//! The camera-path walker: the one loop that follows a camera ray through the scene, shared
//! by the path tracer and every many-light method (after Tungsten's `TraceBase`, whose
//! per-vertex routine serves all its tracers).
//!
//! At each vertex the walker adds the emission found there (MIS-weighted against light
//! sampling unless the ray came from the camera or a delta lobe); at a non-delta vertex it
//! samples the emitters (next-event estimation, MIS against BSDF sampling) and calls the
//! method's [`VertexHook`]; then it samples the BSDF and continues. `max_depth` counts path
//! segments from the camera to the emitter, as Mitsuba 3 does (1 = emitters seen directly,
//! 2 = direct light, …).
//!
//! A hook splits the path space at a non-delta vertex x of depth d by the next vertex:
//! - an emitter: direct light, light sampling plus the BSDF-sampled ray's emission (MIS);
//! - a non-delta surface: the hook's own estimate when [`VertexHook::COVERS_SURFACES`]
//!   (a many-light method connects x to its virtual lights; the walk then stops at the next
//!   non-delta vertex after adding its emission), else the walk continues through it (the
//!   path tracer);
//! - a delta surface (mirror, glass): the walk continues through the delta chain and the next
//!   non-delta vertex is handled in turn, which plain VPL gathering would miss (a diffuse floor
//!   lit by a wall seen in a mirror).
//!
//! So every method renders exactly the path space of the path tracer for the same
//! `max_depth`. Russian roulette (after the BSDF sample of the fifth vertex, as Mitsuba 3's
//! `rr_depth = 5`; survival min(0.95, max throughput · η²), survivors reweighted: unbiased)
//! applies to full walks only: a walk whose hook covers surfaces ends at its next non-delta
//! vertex, so only delta chains, bounded by `max_depth`, continue it.

use glam::Vec3;

use super::direct::{Sampled, emission, sample_emitters};
use super::scatter::{scatter, survives_roulette};
use super::{Counters, RenderContext};
use crate::geometry::{Ray, offset_origin};
use crate::material::{Bsdf, TransportMode};
use crate::sampling::Sampler;
use crate::scene::SurfacePoint;

/// The vertex (counted from 1, the camera ray's hit) from whose continuation on Russian
/// roulette plays: Mitsuba 3's default `rr_depth`. Starting earlier (it was 3) saves rays but
/// costs more variance than it saves time: at equal sample count the Cornell box's relative
/// MSE fell from 8.3e-4 to 6.55e-4 (Mitsuba 6.46e-4) at 256 spp, for 27 % more rays.
pub(crate) const RR_DEPTH: u32 = 5;

/// A non-delta vertex of a camera path, as a hook sees it.
pub struct Vertex<'a> {
    pub sp: SurfacePoint,
    /// Unit direction back along the camera path.
    pub wo: Vec3,
    pub bsdf: &'a Bsdf,
    /// Segments from the camera to this vertex (1 for the camera ray's hit).
    pub depth: u32,
}

/// What a method adds at the non-delta vertices of a camera path.
pub trait VertexHook {
    /// Whether [`VertexHook::at_vertex`] estimates every path whose vertex after this one is a
    /// non-delta surface: the walker then follows the BSDF-sampled ray only into delta
    /// vertices (and to pick up emission).
    const COVERS_SURFACES: bool;

    /// Radiance the method adds at `v` (before the path throughput is applied), or `None`.
    /// Called after emitter sampling and before BSDF sampling, with the vertex's sampler.
    fn at_vertex(
        &self,
        ctx: &RenderContext,
        v: &Vertex,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Option<Vec3>;

    /// Whether [`VertexHook::at_bounce`] adds anything (then the walker prepares the vertex
    /// where a covered walk ends).
    #[inline]
    fn uses_bounces(&self) -> bool {
        false
    }

    /// Radiance the method adds at the non-delta vertex `v` where a covered walk ends (only
    /// when [`VertexHook::COVERS_SURFACES`]; `v.depth` < `max_depth`): the walk came there by
    /// BSDF sampling as `how` says, from the vertex whose hook covered it. A hook that weighs
    /// its own estimate against this bounce (multiple importance sampling) adds the bounce's
    /// share here.
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

/// The hook of the path tracer: nothing at the vertices, full walks.
pub struct FullPaths;

impl VertexHook for FullPaths {
    const COVERS_SURFACES: bool = false;

    #[inline]
    fn at_vertex(&self, _: &RenderContext, _: &Vertex, _: &mut Sampler, _: &mut Counters) -> Option<Vec3> {
        None
    }
}

/// Radiance arriving along the camera ray `ray` (unit direction), with `hook` at every
/// non-delta vertex.
pub fn walk<H: VertexHook>(
    ctx: &RenderContext,
    mut ray: Ray,
    hook: &H,
    sampler: &mut Sampler,
    counters: &mut Counters,
) -> Vec3 {
    let mut radiance = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut eta_scale = 1.0f32;
    // How the current ray was sampled: delta lobes (and the camera) get full emission.
    let mut how = Sampled::camera(ray.origin);
    // The current ray left a non-delta vertex whose hook covers the surfaces beyond it.
    let mut covered = false;
    let mut depth = 0u32;
    loop {
        counters.rays += 1;
        let Some(hit) = ctx.accel.intersect(&ray) else { break };
        if H::COVERS_SURFACES && covered {
            let material = ctx.scene.material_of(hit.prim);
            if !material.bsdf.is_delta() {
                // The hook carried everything beyond this vertex; only its emission is left
                // (the BSDF-sampled half of direct light), and the bounce's share of what the
                // hook weighs against it.
                let bounce = hook.uses_bounces() && depth + 1 < ctx.max_depth;
                if material.is_emitter() || bounce {
                    let sp = ctx.scene.surface_of_hit(&hit);
                    let wo = -ray.dir.normalize();
                    if material.is_emitter() {
                        radiance += beta * emission(ctx, material, &sp, wo, &how);
                    }
                    if bounce {
                        let v = Vertex { sp, wo, bsdf: &material.bsdf, depth: depth + 1 };
                        if let Some(l) = hook.at_bounce(ctx, &v, &how, sampler, counters) {
                            radiance += beta * l;
                        }
                    }
                }
                break;
            }
        }
        depth += 1;
        let sp = ctx.scene.surface_of_hit(&hit);
        let wo = -ray.dir.normalize();
        let material = ctx.scene.material(sp.material);

        // ---- Emission found by the camera ray or the BSDF sample.
        radiance += beta * emission(ctx, material, &sp, wo, &how);
        if depth >= ctx.max_depth {
            break;
        }

        // ---- Emitter sampling (one more segment, so depth + 1 ≤ max_depth), and the hook.
        let bsdf = &material.bsdf;
        if !bsdf.is_delta() {
            radiance += beta * sample_emitters(ctx, &sp, bsdf, wo, sampler, counters);
            let v = Vertex { sp, wo, bsdf, depth };
            if let Some(l) = hook.at_vertex(ctx, &v, sampler, counters) {
                radiance += beta * l;
            }
        }

        // ---- BSDF sampling: the MIS half of direct light, a delta bounce, or a full bounce.
        let Some(s) = scatter(bsdf, &sp, wo, TransportMode::Radiance, sampler, &mut beta) else { break };
        eta_scale *= s.eta * s.eta;
        how = Sampled { from: sp.p, pdf: s.pdf, delta: s.delta };
        covered = !bsdf.is_delta();
        if !H::COVERS_SURFACES
            && depth >= RR_DEPTH
            && !survives_roulette(beta.max_element() * eta_scale, &mut beta, sampler)
        {
            break;
        }
        ray = Ray::new(offset_origin(sp.p, sp.ng, s.wi), s.wi);
    }
    radiance
}
