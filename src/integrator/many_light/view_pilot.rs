//! Which camera vertices of `pir-bdpt` connect when `--connect` is not given: the first, or
//! also each one after a glossy vertex ([`Connect::Glossy`]), chosen by how much of what
//! the camera sees the emitters light directly.
//!
//! **Why.** After a glossy bounce the next vertex (the wall seen in a glossy floor) is where
//! connections to the VPLs pay off, if its light comes indirectly; where the emitters light
//! it directly, next-event estimation there already does well and the extra gather is mostly
//! cost. Measured (`docs/results.md`, "Connections after a glossy vertex"): `glossy` against
//! `first` in efficiency, 3.2× in a room lit through a door gap (Bitterli's veach-ajar),
//! 1.45× in the dense scene lit indirectly, 1.04× in the living room; 0.82–0.94× in the
//! corner, the near-mirror floor and the dense scene lit directly, where the camera's points
//! see the emitters.
//!
//! **How.** Before the first iteration, [`VIEW_PILOT_RAYS`] camera rays through points of the
//! film (a stream no iteration draws from) find their first surface; a light sample from each
//! non-delta one, drawn as next-event estimation draws it, tells whether the emitters light
//! it directly ([`super::path_count::emitter_in_view`]). Where fewer than
//! [`LIT_SHARE_FOR_FIRST`] of the samples see the emitters, the camera paths connect after
//! glossy vertices too. The choice is a function of the scene, its camera, the seed, the
//! sampler and the accelerator alone, fixed for the whole render (resumed and sharded renders
//! make the same), so every iteration estimates the same image with the same unbiased
//! weights, as with a rule given by `--connect`.

use std::sync::Arc;

use glam::Vec3;

use super::config::{Connect, glossy_vertex, near_specular};
use super::path_count::emitter_in_view;
use crate::accel::Hit;
use crate::geometry::{Ray, offset_origin};
use crate::integrator::scatter::scatter;
use crate::integrator::{Counters, RenderContext};
use crate::material::{Bsdf, PreparedBsdf, TransportMode};
use crate::sampling::Sampler;
use crate::sampling::Streams;
use crate::scene::{CameraRays, SurfacePoint};

/// Camera rays of the pilot.
pub const VIEW_PILOT_RAYS: usize = 4096;

/// The share of the pilot's light samples from the camera's first vertices that see the
/// emitters, at and above which only the first vertex connects.
pub const LIT_SHARE_FOR_FIRST: f32 = 0.5;

/// The stream of the pilot's rays: an iteration number no render reaches (nor the light
/// paths' pilot, [`super::path_count::Pilot`]).
const VIEW_PILOT_ITERATION: u64 = u64::MAX - 2;

/// The rule for a scene whose camera's first vertices see the emitters with a share
/// `lit_share` of their light samples.
pub fn connect_for(lit_share: f32) -> Connect {
    if lit_share < LIT_SHARE_FOR_FIRST { Connect::Glossy } else { Connect::First }
}

/// What the pilot found of the camera's view.
#[derive(Debug)]
pub struct View {
    /// Of the light samples from the first non-delta surfaces that [`VIEW_PILOT_RAYS`] rays
    /// of the camera find, the share that sees the emitters (a sample on an emitter's back or
    /// behind the surface does not); 1 when there were none (nothing in view, or only
    /// emitters and delta surfaces).
    pub lit_share: f32,
    /// Points the camera sees that can reflect light towards it, in ray order: those first
    /// surfaces, and where a ray's first surface is a mirror, glass or a near-mirror, what it
    /// shows ([`follow_chain`]): where the image's light is received first
    /// ([`super::importance`] estimates a VPL's share of the image from them).
    pub points: Vec<CameraPoint>,
}

/// A point the camera sees, with its BSDF prepared for the direction to the camera.
#[derive(Clone, Copy, Debug)]
pub struct CameraPoint {
    pub p: Vec3,
    /// The geometric normal on the side the camera sees.
    pub ng: Vec3,
    /// The shading normal.
    pub n: Vec3,
    pub fx: PreparedBsdf,
}

/// The share of the pilot's light samples that see the emitters ([`View::lit_share`]).
pub fn lit_share(ctx: &RenderContext, camera: &CameraRays, counters: &mut Counters) -> f32 {
    view(ctx, camera, counters).lit_share
}

/// The pilot's findings: once per render where the context keeps them ([`super::Pilots`];
/// the render has one camera); its queries are added to `counters.pilot_rays` when it runs.
pub fn view(ctx: &RenderContext, camera: &CameraRays, counters: &mut Counters) -> Arc<View> {
    match ctx.pilot {
        Some(pilots) => pilots.view.get_or_init(|| Arc::new(trace(ctx, camera, counters))).clone(),
        None => Arc::new(trace(ctx, camera, counters)),
    }
}

/// [`view`] without the render's cache.
fn trace(ctx: &RenderContext, camera: &CameraRays, counters: &mut Counters) -> View {
    let streams = Streams::light_paths(ctx.sampler, ctx.seed, VIEW_PILOT_ITERATION);
    let film = camera.film_size();
    let mut queries = Counters::default();
    let (mut tried, mut seen) = (0u32, 0u32);
    let mut points = Vec::new();
    for j in 0..VIEW_PILOT_RAYS {
        let mut sampler = streams.sampler(j as u64);
        let at = sampler.next_2d() * film;
        let aperture = sampler.next_2d();
        let ray = camera.generate_ray(at, aperture);
        queries.rays += 1;
        let Some(hit) = ctx.accel.intersect(&ray) else { continue };
        let material = ctx.scene.material_of(hit.prim);
        if material.is_emitter() {
            continue;
        }
        if material.bsdf.is_delta() {
            // The lit share counts the first surfaces only; the points also take what a
            // mirror or glass shows.
            follow_chain(ctx, ray, hit, &mut sampler, &mut queries, &mut points);
            continue;
        }
        let sp = ctx.scene.surface_of_hit(&hit, ray.dir);
        let ng = sp.facing(ray.dir);
        let bsdf = ctx.scene.bsdf_at(&sp);
        if let Some(point) = camera_point(&sp, bsdf, ray.dir) {
            points.push(point);
        }
        // (A point drawn behind the emitter's front or the surface does not light it.)
        tried += 1;
        seen += u32::from(emitter_in_view(ctx, sp.p, ng, &mut sampler, &mut queries) == Some(true));
        // What a near-mirror shows, after the lit share's numbers (which stay the same).
        if glossy_vertex(&bsdf)
            && let Some((next, hit)) = bounce(ctx, &sp, &bsdf, ray, &mut sampler, &mut queries)
        {
            follow_chain(ctx, next, hit, &mut sampler, &mut queries, &mut points);
        }
    }
    counters.pilot_rays += queries.rays + queries.shadow_rays;
    View { lit_share: if tried == 0 { 1.0 } else { seen as f32 / tried as f32 }, points }
}

/// Mirrors, glass and near-mirrors the view pilot follows from a camera ray.
const MAX_CHAIN: u32 = 8;

/// The points that the ray `ray`, hitting `hit`, shows through mirrors, glass and
/// near-mirrors ([`glossy_vertex`]), at most [`MAX_CHAIN`] surfaces (each direction drawn as the
/// camera path draws it): every non-delta one (a near-mirror's own, and the first rough
/// surface, where the chain ends), each with its BSDF prepared for the direction back along
/// the chain; none on an emitter, where the chain ends too.
///
/// Why a near-mirror's chain is followed: its own point sees few VPLs (a near-specular one,
/// a GGX lobe of α 0.001, is no camera point at all), so a view made mostly of near-mirrors
/// would look as if the VPLs lit nothing in it and start the acceptance where it does not
/// pay (Bitterli's `cornell-box-dielectric`, `docs/results.md`). What the near-mirror shows is where its
/// light comes from, and where `--connect glossy` connects next.
fn follow_chain(
    ctx: &RenderContext,
    mut ray: Ray,
    mut hit: Hit,
    sampler: &mut Sampler,
    queries: &mut Counters,
    points: &mut Vec<CameraPoint>,
) {
    for surfaces in 1..=MAX_CHAIN {
        if ctx.scene.material_of(hit.prim).is_emitter() {
            return;
        }
        let sp = ctx.scene.surface_of_hit(&hit, ray.dir);
        let bsdf = ctx.scene.bsdf_at(&sp);
        if !bsdf.is_delta() {
            points.extend(camera_point(&sp, bsdf, ray.dir));
            if !glossy_vertex(&bsdf) {
                return;
            }
        }
        if surfaces == MAX_CHAIN {
            return;
        }
        let Some(next) = bounce(ctx, &sp, &bsdf, ray, sampler, queries) else { return };
        (ray, hit) = next;
    }
}

/// The point `sp`, seen along `dir`, with its BSDF prepared for the direction back; none
/// where it reflects nothing that way, or where it is near-specular ([`near_specular`]):
/// `pir-bdpt` connects nothing there.
fn camera_point(sp: &SurfacePoint, bsdf: Bsdf, dir: Vec3) -> Option<CameraPoint> {
    if near_specular(&bsdf) {
        return None;
    }
    let ng = sp.facing(dir);
    let fx = PreparedBsdf::new(bsdf, sp.geometry(), -dir.normalize(), TransportMode::Radiance);
    fx.is_active().then_some(CameraPoint { p: sp.p, ng, n: sp.frame.n, fx })
}

/// The ray a BSDF sample at `sp` continues `ray` with, as the camera path draws it, and what
/// it hits.
fn bounce(
    ctx: &RenderContext,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    ray: Ray,
    sampler: &mut Sampler,
    queries: &mut Counters,
) -> Option<(Ray, Hit)> {
    let mut beta = Vec3::ONE;
    let s = scatter(bsdf, sp, -ray.dir.normalize(), TransportMode::Radiance, sampler, &mut beta)?;
    let next = Ray::new(offset_origin(sp.p, sp.ng, s.wi), s.wi);
    queries.rays += 1;
    Some((next, ctx.accel.intersect(&next)?))
}
