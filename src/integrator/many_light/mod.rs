//! The many-light methods: instant radiosity with virtual point lights, plain, clamped and
//! progressively clamped, and virtual spherical lights of constant or progressively
//! shrinking radius.
//!
//! | `--method` | virtual light | bias | reference |
//! |---|---|---|---|
//! | `ir` | point, G unclamped | none, but spiky near creases and on glossy surfaces | Keller 1997 |
//! | `ir-clamp` | point, G' = min(G, b) | too dark, for ever | Keller; pbrt-v2 `igi` |
//! | `pir-clamp` | point, G' = min(G, b_i), b_i = b_1 · i^α | vanishes: consistent | thesis 4.2.1 |
//! | `vsl` | sphere of radius r | blur, for ever | Hašan et al. 2009 |
//! | `pir-vsl` | sphere, r_i = r_1 · i^((α−1)/2) | vanishes: consistent | thesis 4.2.2 |
//! | `pir-mis` | point, connection weighed against a BSDF-sampled bounce, weighted connection bounded by b_i | vanishes: consistent (none without the bound) | pir's own ([`mis`]) |
//! | `pir-bdpt` | point, connected from a full path tracer's camera path, every technique weighed against the others, weighted connection bounded by b_i | vanishes: consistent (none without the bound) | pir's own ([`bidirectional`]) |
//!
//! Parameters (flags of `pir render`):
//! - `--vpls N` light paths per iteration (default [`DEFAULT_PATHS`]; `pir-bdpt`
//!   [`BDPT_PATHS`](crate::integrator::BDPT_PATHS), or more where they leave fewer than
//!   [`BDPT_VPLS`](crate::integrator::BDPT_VPLS) VPLs, chosen by the scene: [`path_count`]).
//!   Each leaves a virtual light at every non-delta vertex that reflects the light it
//!   receives.
//! - `--clamp B` the bound b (`ir-clamp`) or b_1 (`pir-clamp`), in 1/length². Default
//!   ([`Clamping::default_bound`]): 100 / diagonal², the G of two facing surfaces a tenth of
//!   the scene's diagonal apart, so the default needs no tuning whatever the scene's units.
//! - `--radius R` the radius r (`vsl`) or r_1 (`pir-vsl`), one for all lights. Default: per
//!   light from the VPL density (see [`spheres`]).
//! - `--alpha A` the schedule exponent of `pir-clamp` and `pir-vsl` (default 0.6, the
//!   thesis' best; see [`schedule`]).
//!
//! An iteration traces the light paths ([`light_paths`]), makes this iteration's light set
//! from their vertices ([`light_set`]: points with their G bound, or spheres with their
//! radii), and every camera path, followed by the walker of [`super::walker`], gathers from
//! the set at its non-delta vertices ([`gather`]). The walker's split of the path space
//! (emitters, virtual lights, delta chains) makes every method render exactly the path
//! space of `pt` for the same `max_depth`: a VPL of s segments from its emitter serves a
//! camera vertex of d segments when d + 1 + s ≤ max_depth.
//!
//! The files: [`light_paths`] (light tracing, the [`Vpl`]), [`light_set`] (the per-iteration
//! set, points or spheres), [`gather`] (one receiver against the set, shadow rays in
//! batches: [`shadow_batch`]), [`lanes`] (the four-wide kernel of diffuse point lights),
//! [`spheres`] (virtual spherical lights: radii and the cone integral, with [`knn`]),
//! [`schedule`] (the progressive schedules), [`path_count`] (light paths chosen by the
//! scene), [`mis`] (the weighed connections of `pir-mis`),
//! [`bidirectional`] (the camera walk and weights of `pir-bdpt`), and for the sampled gather ([`Gather::Tree`]):
//! [`light_tree`] (the per-iteration tree over the lights) and [`tree_gather`] (drawing k
//! lights per receiver from it, unbiased); for the resampled gather ([`Gather::Resampled`]):
//! [`resample`] (k lights picked among a window of m candidates by their estimated light,
//! unbiased). Measurements behind the defaults are in
//! `docs/measurements.md`.

pub mod bidirectional;
pub mod gather;
pub mod knn;
pub mod lanes;
pub mod light_paths;
pub mod light_set;
pub mod light_tree;
pub mod lobe;
pub mod mis;
pub mod path_count;
pub mod resample;
pub mod schedule;
pub mod shadow_batch;
pub mod sphere_lanes;
pub mod spheres;
pub mod tree_gather;

pub use light_paths::{Vpl, trace_vpls};
pub use light_set::LightSet;
pub use path_count::{AutoPaths, Pilot};

use glam::Vec3;

use super::direct::{Sampled, emission_weighted, sample_emitters_weighted};
use super::scatter::scatter;
use super::walker::{Vertex, VertexHook, walk};
use super::{Counters, Integrator, RenderContext};
use crate::geometry::Ray;
use crate::geometry::offset_origin;
use crate::material::{PreparedBsdf, TransportMode};
use crate::sampling::Sampler;
use mis::{EmitterPath, Technique, Weighing};
use schedule::clamp_bound;

/// Light paths per iteration when `--vpls` is not given. An iteration costs pixels × VPLs
/// shadow rays and the progressive schedules advance once per iteration, so many cheap
/// iterations beat few rich ones (measured in `docs/measurements.md`); 32 keeps a few VPLs
/// per iteration for glossy and spherical lights too.
pub const DEFAULT_PATHS: usize = 32;

/// How the geometry term of point lights is bounded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clamping {
    /// `ir`: no bound.
    None,
    /// `ir-clamp`: a constant bound b.
    Constant { b: f32 },
    /// `pir-clamp`: b_i = b_1 · i^α.
    Progressive { b1: f32, alpha: f32 },
}

impl Clamping {
    /// The default b (or b_1) for a scene of the given diagonal: 100 / diagonal².
    pub fn default_bound(scene_diagonal: f32) -> f32 {
        100.0 / (scene_diagonal * scene_diagonal).max(1e-12)
    }

    /// Progressive clamping with the default α.
    pub fn progressive(b1: f32) -> Self {
        Clamping::Progressive { b1, alpha: schedule::DEFAULT_ALPHA }
    }

    /// The bound of iteration `iteration` (from 1).
    pub fn bound(&self, iteration: u64) -> f32 {
        match *self {
            Clamping::None => f32::INFINITY,
            Clamping::Constant { b } => b,
            Clamping::Progressive { b1, alpha } => clamp_bound(b1, alpha, iteration),
        }
    }
}

/// The radius of virtual spherical lights (r, or r_1 for the progressive schedule).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Radius {
    /// One radius for every light.
    Global(f32),
    /// Per light, from the density of the iteration's VPLs (see [`spheres`]).
    Density,
}

/// Which virtual lights, with which bias control: the parameters of a many-light method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VirtualLights {
    Points(Clamping),
    /// Points whose connections are weighed against a BSDF-sampled bounce ([`mis`]), the
    /// clamping applied to the weighted connection instead of to G.
    WeighedPoints(Clamping),
    /// Points connected from every vertex of a full camera path, every technique weighed
    /// against the others ([`bidirectional`]), the clamping applied to the weighted connection.
    Bidirectional(Clamping, bidirectional::Connect),
    /// Spheres; with `alpha` the radius shrinks as r_1 · i^((α−1)/2).
    Spheres {
        radius: Radius,
        alpha: Option<f32>,
    },
}

/// How a receiver gathers from the iteration's virtual lights.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Gather {
    /// From every light, one shadow ray each ([`gather`]).
    #[default]
    All,
    /// From `samples` lights drawn per receiver from a light tree in proportion to a bound on
    /// their contribution, each weighted by its inverse probability: unbiased for the same
    /// sum ([`light_tree`], [`tree_gather`]).
    Tree { samples: usize },
    /// From `samples` lights picked per receiver, in proportion to their unoccluded
    /// contributions, among a random window of `candidates` lights; unbiased for the same sum
    /// ([`resample`]).
    Resampled { candidates: usize, samples: usize },
}

/// A many-light method: its parameters, and the light set of the current iteration.
pub struct InstantRadiosity {
    lights: VirtualLights,
    paths: usize,
    /// Light paths chosen by the scene's yield of VPLs ([`path_count`]) when
    /// [`Integrator::prepare`] runs, instead of `paths`.
    auto: Option<AutoPaths>,
    /// What the pilot measured ([`Integrator::prepare`]), for methods that need it.
    pilot: Option<Pilot>,
    gather: Gather,
    /// [`VirtualLights::Bidirectional`]: light samples at the camera path's first vertex.
    light_samples: u32,
    /// Whether [`Integrator::prepare`] chooses `light_samples` by the pilot's visibility of
    /// the emitters ([`bidirectional::light_samples_for`], with `light_samples` the base).
    auto_light_samples: bool,
    set: LightSet,
}

impl InstantRadiosity {
    pub fn new(lights: VirtualLights, paths: usize) -> Self {
        InstantRadiosity {
            lights,
            paths,
            auto: None,
            pilot: None,
            gather: Gather::All,
            light_samples: 1,
            auto_light_samples: false,
            set: LightSet::default(),
        }
    }

    /// The same method with its light paths chosen by the scene's yield of VPLs; `paths`
    /// until [`Integrator::prepare`] chooses them.
    pub fn with_auto_paths(self, auto: AutoPaths) -> Self {
        InstantRadiosity { auto: Some(auto), ..self }
    }

    /// The same method gathering as `gather` says.
    pub fn with_gather(self, gather: Gather) -> Self {
        InstantRadiosity { gather, ..self }
    }

    /// The same method taking `n` light samples at the camera path's first vertex (for
    /// [`VirtualLights::Bidirectional`]; the others take one), 1 to
    /// [`MAX_LIGHT_SAMPLES`](crate::integrator::MAX_LIGHT_SAMPLES).
    pub fn with_light_samples(self, n: u32) -> Self {
        let n = n.clamp(1, crate::integrator::MAX_LIGHT_SAMPLES);
        InstantRadiosity { light_samples: n, auto_light_samples: false, ..self }
    }

    /// The same method with its light samples chosen by the scene when [`Integrator::prepare`]
    /// runs: `base` where the emitters are in view, more where they are hidden
    /// ([`bidirectional::light_samples_for`]).
    pub fn with_auto_light_samples(self, base: u32) -> Self {
        InstantRadiosity { auto_light_samples: true, ..self.with_light_samples(base) }
    }

    /// Point lights with the given clamping.
    pub fn points(clamping: Clamping, paths: usize) -> Self {
        Self::new(VirtualLights::Points(clamping), paths)
    }
}

/// The many-light hook of the camera walker: at a non-delta vertex of d segments, the light
/// of every virtual light of at most max_depth − d − 1 segments.
impl VertexHook for LightSet {
    const COVERS_SURFACES: bool = true;

    #[inline]
    fn at_vertex(
        &self,
        ctx: &RenderContext,
        v: &Vertex,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Option<Vec3> {
        let max_vpl_depth = ctx.max_depth - v.depth - 1;
        let Some(mis) = &self.mis else {
            return Some(self.gather(ctx, v, max_vpl_depth, &Weighing::PLAIN, sampler, counters));
        };
        let fx = PreparedBsdf::new(*v.bsdf, v.sp.geometry(), v.wo, TransportMode::Radiance);
        let weighing =
            Weighing { technique: Technique::Connect { fx: &fx, scene: ctx.scene }, bound: mis.bound };
        Some(self.gather(ctx, v, max_vpl_depth, &weighing, sampler, counters))
    }

    #[inline]
    fn uses_bounces(&self) -> bool {
        self.mis.is_some()
    }

    /// The bounce's share ([`mis`]): the emitters sampled from y and the gather at y, each
    /// weighed against the connection of the gathering vertex to the VPLs at y.
    fn at_bounce(
        &self,
        ctx: &RenderContext,
        v: &Vertex,
        how: &Sampled,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Option<Vec3> {
        let mis = self.mis.as_ref()?;
        let bounce = how.pdf / (v.sp.p - how.from).length_squared();
        let path = |light| EmitterPath { bounce, paths: mis.counts.paths, light };
        let direct =
            sample_emitters_weighted(ctx, &v.sp, v.bsdf, v.wo, sampler, counters, |s| path(s).light_weight());
        let weighing = Weighing { technique: Technique::Bounce { bounce }, bound: mis.bound };
        let max_vpl_depth = ctx.max_depth - v.depth - 1;
        let gathered = self.gather(ctx, v, max_vpl_depth, &weighing, sampler, counters);
        // C: y's BSDF sample, where it hits an emitter.
        let mut beta = Vec3::ONE;
        let Some(s) = scatter(v.bsdf, &v.sp, v.wo, TransportMode::Radiance, sampler, &mut beta) else {
            return Some(direct + gathered);
        };
        counters.rays += 1;
        let ray = Ray::new(offset_origin(v.sp.p, v.sp.ng, s.wi), s.wi);
        let mut found = Vec3::ZERO;
        if let Some(hit) = ctx.accel.intersect(&ray)
            && let material = ctx.scene.material_of(hit.prim)
            && material.is_emitter()
        {
            let e = ctx.scene.surface_of_hit(&hit);
            let how = Sampled { from: v.sp.p, pdf: s.pdf, delta: s.delta };
            found = beta * emission_weighted(ctx, material, &e, -s.wi, &how, |l| path(l).bsdf_weight());
        }
        Some(direct + gathered + found)
    }
}

impl Integrator for InstantRadiosity {
    /// The light paths per iteration, and for [`VirtualLights::Bidirectional`] the light
    /// samples at the first vertex and the pilot's visibility of the emitters (what the
    /// weights' counts used, [`Pilot`]).
    fn measured(&self) -> Vec<(String, String)> {
        let mut m = vec![("vpls".to_string(), self.paths.to_string())];
        if matches!(self.lights, VirtualLights::Bidirectional(..)) {
            m.push(("light-samples".into(), self.light_samples.to_string()));
            if let Some(pilot) = self.pilot {
                m.push(("emitter-visibility".into(), format!("{:.3}", pilot.visibility)));
            }
        }
        m
    }

    /// The pilot, once, for counts chosen by the scene or the bidirectional weights.
    fn prepare(&mut self, ctx: &RenderContext, counters: &mut Counters) {
        let bidirectional = matches!(self.lights, VirtualLights::Bidirectional(..));
        if self.pilot.is_some() || !(bidirectional || self.auto.is_some()) {
            return;
        }
        let pilot = Pilot::run(ctx, counters);
        if let Some(auto) = self.auto.take() {
            self.paths = auto.for_yield(pilot.per_path);
        }
        if std::mem::take(&mut self.auto_light_samples) {
            self.light_samples = bidirectional::light_samples_for(self.light_samples, pilot.visibility);
        }
        self.pilot = Some(pilot);
    }

    fn begin_iteration(&mut self, ctx: &RenderContext, iteration: u64, counters: &mut Counters) {
        // A VPL of s segments serves a camera vertex of d ≥ 1 segments when d + 1 + s ≤ max_depth.
        let max_vpl_depth = ctx.max_depth.saturating_sub(2);
        let visibility = self.pilot.map_or(1.0, |p| p.visibility);
        let counts = bidirectional::Counts::new(self.paths, self.gather, visibility);
        let (vpls, rays) = trace_vpls(ctx, iteration, self.paths, counts, max_vpl_depth);
        counters.light_rays += rays;
        counters.light_paths += self.paths as u64;
        counters.vpls += vpls.len() as u64;
        self.set = LightSet::new(ctx, &self.lights, vpls, counts, iteration, self.gather);
    }

    fn radiance(
        &self,
        ctx: &RenderContext,
        ray: Ray,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        match (&self.lights, &self.set.mis) {
            (&VirtualLights::Bidirectional(_, connect), Some(mis)) => {
                let n = self.light_samples;
                bidirectional::walk(ctx, ray, &self.set, connect, n, mis.counts, mis.bound, sampler, counters)
            }
            _ => walk(ctx, ray, &self.set, sampler, counters),
        }
    }
}
