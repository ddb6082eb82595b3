//! Virtual point lights: light tracing (the first phase of instant radiosity, Keller 1997).
//!
//! Each iteration traces N light paths. A path starts on an emitter triangle chosen by power
//! at a uniform point, leaving in a cosine-distributed direction, or at another light chosen by
//! power ([`crate::light::Light::emit`]: a point light's uniform direction, a spot light's
//! uniform direction in its cone, lights at infinity from the disk covering the scene's
//! bounding sphere, as pbrt does), and at every hit samples the
//! BSDF in importance mode (with the adjoint shading-normal correction), continuing under
//! Russian roulette (the continuation of [`crate::integrator::scatter`], shared with the
//! camera walker). Every non-delta vertex that can reflect the light it receives gets a VPL
//! that stores what its own BSDF needs later (position, normals, incoming direction,
//! material) and the path's throughput Φ divided by N, the number of light PATHS traced (not
//! of VPLs). Delta vertices (mirror, glass) get none, but the path continues through them:
//! that is how caustics reach diffuse surfaces. Nor do vertices where the light arrives from
//! behind the surface or the material is black ([`crate::material::Bsdf::reflects_from`]):
//! such a VPL adds exactly nothing to any receiver as a point light (the spherical lights'
//! density radius, the distance to a light's 4th-nearest VPL, is now taken among the VPLs
//! that reflect: a different bias of `vsl` and `pir-vsl`, vanishing as before), and where
//! light enters through an
//! opening most light paths end on the outside of the wall around it (in the slit room, 85 %
//! of the VPLs of an iteration of 64 paths were such; every one took a candidate's place in
//! the resampled gather's window; the exhaustive gather evaluated them all and traced no
//! shadow ray to them).
//!
//! Path `k` of iteration `i` draws its numbers from sampler k of `Streams::light_paths(sampler,
//! seed, i)` (with Sobol points, point k of the iteration's own scrambled sequence), and paths are traced in parallel but collected in path order, so the VPL set is a function
//! of the seed alone.
//!
//! With light tracing to the camera (`pir-bdpt`, [`super::to_camera`]) every non-delta vertex
//! within `max_depth` − 1 segments of the emitter also splats its light into the film, one
//! segment deeper than the VPLs reach; the splats too are collected in path order.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::config::{After, near_specular};
use super::importance::Acceptance;
use super::merging::{LightChain, Photon};
use super::subpath::{Counts, MisState, Scatter};
use super::to_camera::{LightVertex, ToCamera};
use crate::geometry::{Frame, Ray, offset_origin};
use crate::integrator::scatter::{scatter, survives_roulette};
use crate::integrator::{Counters, FilmSplat, RenderContext};
use crate::light::Choice;
use crate::material::{Bsdf, LocalGeometry, TransportMode};
use crate::sampling::{Sampler, Streams, cosine_hemisphere};

/// A virtual point light at a non-delta vertex of a light path.
#[derive(Clone, Copy, Debug)]
pub struct Vpl {
    pub p: Vec3,
    pub ng: Vec3,
    /// Shading frame at the vertex.
    pub frame: Frame,
    /// Unit direction towards the previous vertex of the light path (where light came from).
    pub w_in: Vec3,
    pub material: u32,
    /// Texture coordinates of the point ([`Vpl::bsdf`] resolves its material's textures there).
    pub uv: Vec2,
    /// Incident flux Φ / N (already divided by the number of paths).
    pub flux: Vec3,
    /// Segments from the emitter to this vertex (1 for a vertex lit directly by an emitter).
    pub depth: u32,
    /// The density with which light tracing reached this point, per unit area and without
    /// the cosine at the point: q · p(ω) / d² from the previous vertex (its survival
    /// probability q, its BSDF's solid-angle density p of the direction, the distance d);
    /// for a vertex lit directly, N · (cos θ_e / π) / d² relative to next-event estimation
    /// (where it picks the emitter point exactly as light tracing does, but once, not N
    /// times); infinite after a delta vertex. For a vertex lit directly by a sphere that
    /// next-event estimation from it samples by its cone, or by a triangle that it picks by
    /// its importance here: N p_A / (π pdf), light tracing's density N p_A cos θ_e / (π d²)
    /// relative to next-event estimation's pdf cos θ_e / d² of the same point
    /// ([`crate::light::Emitters::nee_pdf`]). For a vertex lit directly by a light that is not a
    /// triangle: N · [`crate::light::Emission::density`] (divided by d² for a point or spot
    /// light), likewise relative to next-event estimation. What the multiple importance
    /// sampling of [`super::mis`] weighs a connection with.
    pub arrival: f32,
    /// The probability that the light path continues from here (Russian roulette; 0 at the
    /// last vertex traced).
    pub survival: f32,
    /// For a vertex lit directly: the solid-angle density with which next-event estimation
    /// from here picks the emitter point that lit it (a sphere's cone's density, where it
    /// samples that; infinite for a delta light, which it
    /// picks with certainty once chosen; for an environment its selection probability times
    /// its density of the direction back along the path); 0 otherwise.
    pub nee_pdf: f32,
    /// The light subpath's running sums for the bidirectional weights of `pir-bdpt`
    /// ([`super::bidirectional`]), at this vertex.
    pub mis: MisState,
    /// The count of the connection from this vertex, as a camera vertex, to the VPL at the
    /// light path's previous vertex, relative to the paths the weights count
    /// ([`Counts::factor`]); 1 for a vertex lit directly. And the same where that camera
    /// vertex draws fewer ([`Counts::at`]: the camera vertex before it is coated).
    pub count_out: f32,
    pub count_out_fewer: f32,
}

impl Vpl {
    /// A VPL for unit tests: material 0, reached with density 1, continuing with
    /// probability 1, not lit directly, the bidirectional sums zero.
    #[cfg(test)]
    pub(crate) fn for_test(p: Vec3, ng: Vec3, frame: Frame, w_in: Vec3, flux: Vec3, depth: u32) -> Vpl {
        Vpl {
            p,
            ng,
            frame,
            w_in,
            material: 0,
            uv: Vec2::ZERO,
            flux,
            depth,
            arrival: 1.0,
            survival: 1.0,
            nee_pdf: 0.0,
            mis: MisState::default(),
            count_out: 1.0,
            count_out_fewer: 1.0,
        }
    }

    pub fn geometry(&self) -> LocalGeometry {
        LocalGeometry { ng: self.ng, frame: self.frame }
    }

    /// The BSDF at the VPL: its material's, textures evaluated at its texture coordinates
    /// ([`crate::material::Material::bsdf_at`]).
    #[inline(always)]
    pub fn bsdf(&self, scene: &crate::scene::Scene) -> Bsdf {
        scene.material(self.material).bsdf_at(self.uv)
    }
}

/// Number of segments after which light paths use Russian roulette.
const RR_DEPTH: u32 = 3;

/// The largest survival probability of Russian roulette (as [`survives_roulette`] caps it).
const MAX_SURVIVAL: f32 = 0.95;

/// Traces `paths` light paths for `iteration` and returns their VPLs, in path order. Only
/// vertices within `max_vpl_depth` segments of the emitter are traced.
/// `counts` are the bidirectional weights' counts ([`Counts`]).
pub fn trace_vpls(
    ctx: &RenderContext,
    iteration: u64,
    paths: usize,
    counts: Counts,
    max_vpl_depth: u32,
) -> (Vec<Vpl>, u64) {
    let traced = trace_light_paths(ctx, iteration, paths, counts, max_vpl_depth, None, false, None);
    (traced.vpls, traced.rays)
}

/// The VPLs of a pilot's `paths` light paths (from the stream of `iteration`, a number no
/// render reaches), left as `pir-bdpt`'s iterations leave them (none at a near-specular
/// vertex, [`Counts::skipping_near_specular`]), their closest-hit queries, and how many of
/// them a narrow lobe led the paths to ([`Traced::narrow`]).
pub fn trace_pilot_vpls(
    ctx: &RenderContext,
    iteration: u64,
    paths: usize,
    max_vpl_depth: u32,
) -> (Vec<Vpl>, u64, usize) {
    let counts = Counts::uniform(paths as f32).skipping_near_specular();
    let traced = trace_light_paths(ctx, iteration, paths, counts, max_vpl_depth, None, false, None);
    (traced.vpls, traced.rays, traced.narrow)
}

/// What an iteration's light paths leave: VPLs and splats on the film, in path order, where
/// each path's VPLs end, and the queries they made.
#[derive(Default)]
pub struct Traced {
    pub vpls: Vec<Vpl>,
    /// The end of each path's VPLs (one past its last; [`super::window::LightPaths`]), path by path.
    pub path_ends: Vec<u32>,
    pub splats: Vec<FilmSplat>,
    /// With `photons`: the non-delta vertices that a delta vertex led a light path of the
    /// class from an area emitter to ([`super::merging`]), within the VPLs' depth.
    pub photons: Vec<Photon>,
    /// Closest-hit queries.
    pub rays: u64,
    /// Occlusion queries (light tracing to the camera, the estimates of VPLs' acceptance).
    pub shadow_rays: u64,
    /// VPLs that a narrow lobe (not a delta one, nor that of a near-specular vertex,
    /// [`super::config::near_specular`]) led the light path to: the previous vertex's density
    /// of the direction at least [`NARROW_LOBE_DENSITY`]. Counted before an acceptance
    /// leaves any VPL out (the pilot has none).
    pub narrow: usize,
}

/// [`trace_vpls`], and with `to_camera` light tracing to the camera from every non-delta
/// vertex within `ctx.max_depth` − 1 segments of the emitter; with `photons` the photons of
/// vertex merging too; with `acceptance` only the VPLs it keeps ([`Acceptance::keep`]).
#[allow(clippy::too_many_arguments)]
pub fn trace_light_paths(
    ctx: &RenderContext,
    iteration: u64,
    paths: usize,
    counts: Counts,
    max_vpl_depth: u32,
    to_camera: Option<&ToCamera>,
    photons: bool,
    acceptance: Option<&Acceptance>,
) -> Traced {
    const CHUNK: usize = 64;
    let streams = Streams::light_paths(ctx.sampler, ctx.seed, iteration);
    let depths = Depths::new(ctx, max_vpl_depth, to_camera, photons);
    let chunks: Vec<Traced> = (0..paths.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut out = Traced::default();
            for k in c * CHUNK..((c + 1) * CHUNK).min(paths) {
                let mut sampler = streams.sampler(k as u64);
                let first = out.vpls.len();
                trace_path(ctx, &mut sampler, paths as f32, counts, depths, &mut out);
                if let Some(acceptance) = acceptance {
                    let mut queries = Counters::default();
                    acceptance.keep(ctx, iteration, k, paths, &mut out.vpls, first, &mut queries);
                    out.shadow_rays += queries.shadow_rays;
                }
                out.path_ends.push(out.vpls.len() as u32);
            }
            out
        })
        .collect();
    let mut traced = Traced::default();
    for c in chunks {
        let base = traced.vpls.len() as u32;
        traced.path_ends.extend(c.path_ends.iter().map(|e| base + e));
        traced.vpls.extend(c.vpls);
        traced.splats.extend(c.splats);
        traced.photons.extend(c.photons);
        traced.rays += c.rays;
        traced.shadow_rays += c.shadow_rays;
        traced.narrow += c.narrow;
    }
    traced
}

/// How deep a light path goes: VPLs (and photons, where `photons` says) within `vpl`
/// segments of the emitter, splats (with `to_camera`) within `camera`; the path is traced to
/// the deeper of the two.
#[derive(Clone, Copy)]
struct Depths<'a> {
    vpl: u32,
    camera: u32,
    to_camera: Option<&'a ToCamera>,
    photons: bool,
}

impl<'a> Depths<'a> {
    fn new(ctx: &RenderContext, vpl: u32, to_camera: Option<&'a ToCamera>, photons: bool) -> Self {
        // A vertex of s segments from the emitter and one to the camera: s + 1 ≤ max_depth.
        let camera = if to_camera.is_some() { ctx.max_depth.saturating_sub(1) } else { 0 };
        Depths { vpl, camera, to_camera, photons }
    }

    fn last(&self) -> u32 {
        self.vpl.max(self.camera)
    }
}

/// Traces one light path, appending its VPLs and splats and counting its queries.
fn trace_path(
    ctx: &RenderContext,
    sampler: &mut Sampler,
    n_paths: f32,
    counts: Counts,
    depths: Depths,
    out: &mut Traced,
) {
    if depths.last() == 0 {
        return;
    }
    let u_select = sampler.next_f32();
    let u_point = sampler.next_2d();
    let es = if !ctx.emitters.is_plain() {
        match ctx.emitters.choose(ctx.scene, u_select, u_point) {
            Choice::Area(es) => es,
            Choice::Light { index, pmf, u } => {
                let light = &ctx.emitters.lights()[index];
                let Some(e) = light.emit(ctx.scene.bounding_sphere(), u, sampler.next_2d()) else { return };
                let beta = e.weight / (pmf * n_paths);
                // Next-event estimation's density of what the start picks: none to weigh for
                // a delta light, the direction back to an environment.
                let nee = if light.is_delta() { f32::INFINITY } else { pmf * light.environment_pdf(-e.dir) };
                let start = Start {
                    ray: Ray::new(e.origin, e.dir),
                    beta,
                    from: e.origin,
                    density: n_paths * e.density,
                    at_infinity: e.at_infinity,
                    nee: if light.is_delta() { NeeAt::Delta } else { NeeAt::Environment(index, pmf) },
                    mis: MisState::light_source(nee, e.density, counts.paths),
                    chain: None,
                };
                return follow(ctx, sampler, start, counts, depths, out);
            }
        }
    } else {
        ctx.emitters.sample(ctx.scene, u_select, u_point)
    };
    let u_dir = sampler.next_2d();
    // Cosine-distributed direction about the emitter's front (geometric) normal:
    // throughput Le · cos / (p_A · cos / π) = Le · π / p_A.
    let local = cosine_hemisphere(u_dir);
    if local.z <= 0.0 {
        return;
    }
    let dir = Frame::from_normal(es.point.ng).to_world(local);
    let beta = es.radiance * (std::f32::consts::PI / es.pdf_area) / n_paths;
    let start = Start {
        ray: Ray::new(offset_origin(es.point.p, es.point.ng, dir), dir),
        beta,
        from: es.point.p,
        density: n_paths * local.z * std::f32::consts::FRAC_1_PI,
        at_infinity: false,
        nee: NeeAt::Area { p: es.point.p, prim: es.point.prim, pdf_area: es.pdf_area, cos_e: local.z },
        mis: MisState::light(es.pdf_area, local.z, counts.paths),
        chain: depths.photons.then(|| LightChain::start(es.pdf_area)),
    };
    follow(ctx, sampler, start, counts, depths, out)
}

/// How next-event estimation from a vertex lit directly finds the light that lit it.
#[derive(Clone, Copy, Debug)]
enum NeeAt {
    /// The emitter point on triangle `prim`, with its area density and the cosine of the
    /// path's direction there.
    Area { p: Vec3, prim: u32, pdf_area: f32, cos_e: f32 },
    /// A delta light: the same point or direction, with a delta density.
    Delta,
    /// An environment (its index among the lights, its selection probability): by its own
    /// solid-angle density of the direction back along the path.
    Environment(usize, f32),
}

/// Where a light path starts: its first ray and throughput, and what the VPL at its first
/// hit records of how it got there.
struct Start {
    ray: Ray,
    beta: Vec3,
    /// Where the first segment starts.
    from: Vec3,
    /// The density of the first direction, per unit solid angle, times the paths (for lights
    /// at infinity, per unit area of the receiver: [`crate::light::Emission::density`]).
    density: f32,
    at_infinity: bool,
    nee: NeeAt,
    mis: MisState,
    /// Where photons are wanted and the light has an area: the path's bookkeeping for them
    /// while it is of the class.
    chain: Option<LightChain>,
}

/// The solid-angle density (per steradian) of the scattered direction at or above which a
/// light path's vertex was led to the next one by a narrow lobe ([`Traced::narrow`]): 10,
/// some 30 times a Lambertian lobe's largest (1/π). A GGX lobe's density near its peak is
/// about its sampling probability over 4πα² cos θ_o, so at normal incidence it reaches 10 for
/// α up to about 0.09 (more at grazing incidence): the near-mirror floor's coat (α 0.05, 94 %
/// of its reflectance) does often and the glossy corner's floor (α 0.1, 67 %) rarely.
///
/// Why: the light such a lobe sends on is a glossy caustic, which light tracing to the camera
/// and the connections from the vertex it lands on make, and whose noise falls with the light
/// paths, as a mirror's does ([`super::path_count`]). Not after a near-specular vertex
/// (α ≤ 0.02, which neither connects nor leaves a VPL): in Bitterli's Cornell box seen
/// through a rough pane of α 0.001, counting the vertices behind the pane raised its light
/// paths from 256 to 4,096 for the same error at 1.4 times the time.
pub const NARROW_LOBE_DENSITY: f32 = 10.0;

/// Follows a light path from its start, appending its VPLs and splats.
fn follow(
    ctx: &RenderContext,
    sampler: &mut Sampler,
    start: Start,
    counts: Counts,
    depths: Depths,
    out: &mut Traced,
) {
    let Start { mut ray, mut beta, mut from, mut density, at_infinity, nee, mut mis, mut chain } = start;
    // Whether a narrow lobe led the path here ([`Traced::narrow`]): the previous vertex, not
    // near-specular, sampled the direction with a density (without its survival probability)
    // of at least NARROW_LOBE_DENSITY; never at the first vertex.
    let mut led_by_narrow_lobe = false;
    let beta0 = beta.max_element();
    // The BSDF of the light path's previous vertex (none at the emitter).
    let mut previous: Option<Bsdf> = None;
    let max_depth = depths.last();
    for depth in 1..=max_depth {
        out.rays += 1;
        let Some(hit) = ctx.accel.intersect(&ray) else { break };
        let sp = ctx.scene.surface_of_hit(&hit, ray.dir);
        let w_in = -ray.dir.normalize();
        let bsdf = &ctx.scene.bsdf_at(&sp);
        let dist2 = (sp.p - from).length_squared();
        // (The first segment from a light at infinity: its density is per unit area already.)
        mis.arrive(if depth == 1 && at_infinity { 1.0 } else { dist2 }, sp.ng.dot(w_in).abs());
        // Lit directly by a sphere that next-event estimation from here samples by its cone,
        // or by a triangle that it picks by its importance here: next-event estimation's
        // density of the emitter point is its own (per unit area, pdf cos θ_e / d² of its
        // solid-angle density), not the area density the light path started with, in what
        // the VPL and the running sums weigh against it.
        let cone = match nee {
            NeeAt::Area { prim, pdf_area, cos_e, .. } if depth == 1 => {
                ctx.emitters.nee_pdf(prim, sp.p, dist2, cos_e).map(|pdf| (pdf, pdf_area, cos_e))
            }
            _ => None,
        };
        if let Some((pdf, pdf_area, cos_e)) = cone {
            mis.dvcm *= pdf * cos_e / (dist2 * pdf_area);
        }
        // Survival by the flux arriving here relative to the path's start (importance
        // transport has no 1/η² radiance scaling to compensate), decided before the
        // direction is sampled so that a connection can be weighed against this
        // continuation ([`Vpl::survival`]).
        let survival = match depth {
            d if d == max_depth => 0.0,
            d if d >= RR_DEPTH => (beta.max_element() / beta0).min(MAX_SURVIVAL),
            _ => 1.0,
        };
        // The count of the connection from here to the previous vertex's VPL, without and
        // with fewer draws at the camera end.
        let (count, count_fewer) = counts.between_both(previous.as_ref(), bsdf);
        // Only where light can be reflected: a vertex on the back of a surface (light paths
        // that miss an opening and strike the wall around it from outside) or on a black
        // material would add nothing to any receiver, yet take a place in every gather's
        // window. The path ends there all the same ([`scatter`] finds no direction).
        // Nor where no connection reaches it (a near-specular vertex, [`Counts::connects_at`]).
        let reflects = depth <= depths.vpl && bsdf.reflects_from(&sp.geometry(), w_in);
        if reflects && counts.connects_at(bsdf) {
            out.narrow += usize::from(led_by_narrow_lobe);
            out.vpls.push(Vpl {
                p: sp.p,
                ng: sp.ng,
                frame: sp.frame,
                w_in,
                material: sp.material,
                uv: sp.uv,
                flux: beta,
                depth,
                arrival: match cone {
                    // N p_A cos θ_e / (π d²) over next-event estimation's pdf_cone cos θ_e / d².
                    Some((pdf, pdf_area, cos_e)) => density * pdf_area / (pdf * cos_e),
                    None if depth == 1 && at_infinity => density,
                    None => density / dist2,
                },
                // (None beyond the VPLs' depth: a path traced deeper only splats.)
                survival: if depth == depths.vpl { 0.0 } else { survival },
                nee_pdf: if depth == 1 {
                    match (nee, cone) {
                        (_, Some((pdf, ..))) => pdf,
                        (NeeAt::Area { p: e, pdf_area, cos_e, .. }, None) => {
                            pdf_area * (sp.p - e).length_squared() / cos_e
                        }
                        (NeeAt::Delta, None) => f32::INFINITY,
                        (NeeAt::Environment(k, pmf), None) => {
                            pmf * ctx.emitters.lights()[k].environment_pdf(-ray.dir)
                        }
                    }
                } else {
                    0.0
                },
                mis,
                count_out: count,
                count_out_fewer: count_fewer,
            });
        }
        // Where a delta chain of the class reached the vertex, a photon.
        if reflects
            && let Some(c) = chain
            && !bsdf.is_delta()
            && let Some(photon) = c.photon(sp.p, sp.ng, w_in, beta, depth)
        {
            out.photons.push(photon);
        }
        if let Some(to_camera) = depths.to_camera
            && depth <= depths.camera
            && !bsdf.is_delta()
        {
            let aperture = if to_camera.draws_aperture() { sampler.next_2d() } else { Vec2::ZERO };
            let v = LightVertex { sp: &sp, bsdf, w_in, beta, mis: &mis, depth, count_out: count };
            if let Some(splat) = to_camera.splat(ctx, &v, aperture, &mut out.shadow_rays) {
                out.splats.push(splat);
            }
        }
        if depth == max_depth {
            break;
        }
        let Some(s) = scatter(bsdf, &sp, w_in, TransportMode::Importance, sampler, &mut beta) else { break };
        let pdf_rev = if s.delta { s.pdf } else { bsdf.pdf(&sp.geometry(), s.wi, w_in) };
        let after = After::of(bsdf);
        chain = chain.and_then(|c| c.scatter(bsdf, &sp.geometry(), w_in, &s));
        let cos_out = sp.ng.dot(s.wi).abs();
        mis.scatter(Scatter::light(s.pdf, pdf_rev, cos_out, s.delta, depth, count, count_fewer, after));
        previous = Some(*bsdf);
        if depth >= RR_DEPTH && !survives_roulette(survival, &mut beta, sampler) {
            break;
        }
        from = sp.p;
        density = if s.delta { f32::INFINITY } else { survival * s.pdf };
        led_by_narrow_lobe = !s.delta && s.pdf >= NARROW_LOBE_DENSITY && !near_specular(bsdf);
        ray = Ray::new(offset_origin(sp.p, sp.ng, s.wi), s.wi);
    }
}
