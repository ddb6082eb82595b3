//! Integrators: what a camera sample sees.
//!
//! An integrator has three parts (as in Tungsten): settings with documented defaults, a
//! per-iteration preparation ([`Integrator::begin_iteration`], e.g. tracing VPLs) and the
//! per-ray radiance estimate ([`Integrator::radiance`]). The progressive driver in
//! [`crate::render`] owns pixels, iterations and threads.
//!
//! Where each concept lives:
//! - [`walker`]: the camera-path walker, the one loop every method's camera paths run
//!   (intersection, depth, delta bounces, BSDF sampling, Russian roulette), and the
//!   [`walker::Estimator`] a method plugs into it (what it adds where the path arrives and at
//!   each non-delta vertex, and what it keeps of each scatter);
//! - [`scatter`]: how a path continues from a vertex (BSDF sampling, Russian roulette), for
//!   camera and light paths alike;
//! - [`direct`]: direct light from the real emitters (light sampling, MIS weights);
//! - `path.rs`: `pt`, whose estimator is next-event estimation and BSDF sampling under MIS;
//! - [`wavefront`]: the batched walker, many camera paths bounce by bounce with batched
//!   queries, for every method's estimator, the same estimates as the scalar walker's;
//! - [`diffuse_lanes`]: `pt`'s Lambertian vertices in the batched walker, sixteen at a time
//!   in structure-of-arrays lanes ([`crate::wide`]), the scalar code's numbers bit for bit;
//! - [`deferred`]: where an estimator puts its light samples, tested at once (the scalar
//!   walker) or parked until the batched walker traces their shadow rays together;
//! - [`many_light`]: the VPL methods, whose estimators add the gather from the virtual lights;
//! - [`methods`]: the methods by name, one type each in a registry ([`methods::MethodSpec`],
//!   [`Method`]), the parameter table ([`methods::params`]) and a method's one configuration
//!   ([`MethodConfig`]: flags, defaults, `validate()`, serde). It builds integrators with the
//!   public builders of the modules above; none of them imports it.

pub mod deferred;
pub mod diffuse_lanes;
pub mod direct;
pub mod emitter_pilot;
pub mod many_light;
pub mod methods;
mod path;
pub mod scatter;
pub mod walker;
pub mod wavefront;

pub use direct::{Sampled, emission, occluded, power_heuristic, sample_emitters, shadow_ray};
pub use many_light::{Clamping, DEFAULT_PATHS, Gather, InstantRadiosity, Radius, VirtualLights, schedule};
pub use methods::params::{
    DEFAULT_GATHER_CANDIDATES, DEFAULT_GATHER_SAMPLES, DEFAULT_LIGHT_SAMPLES, GatherKind, MAX_GATHER_SAMPLES,
    MAX_VPLS, MethodParams, Parameter,
};
pub use methods::pir_bdpt::{BDPT_AUTO_PATHS, BDPT_GATHER, BDPT_MAX_PATHS, BDPT_PATHS, BDPT_VPLS};
pub use methods::pir_mis::MIS_GATHER;
pub use methods::{Method, MethodConfig, MethodSpec, register};
pub use path::PathTracer;
pub use wavefront::{RayByRay, Walker};

use glam::Vec3;

use crate::accel::Accelerator;
use crate::geometry::Ray;
use crate::light::Emitters;
use crate::sampling::{Sampler, SamplerKind};
use crate::scene::{CameraRays, Scene};

/// Most light samples at the camera path's first vertex (`--light-samples`).
pub const MAX_LIGHT_SAMPLES: u32 = 64;

/// What every integrator reads while rendering.
pub struct RenderContext<'a> {
    pub scene: &'a Scene,
    pub accel: &'a dyn Accelerator,
    pub emitters: &'a Emitters,
    /// Largest number of path segments from the camera to an emitter.
    pub max_depth: u32,
    pub seed: u64,
    /// How camera samples and light paths draw their numbers.
    pub sampler: SamplerKind,
    /// Where the render keeps its pilots ([`many_light::Pilots`]), each a function of the
    /// render alone, so that every integrator made for the render (its own, and the ones that
    /// only report their parameters) runs them once; `None`: each runs its own.
    pub pilot: Option<&'a many_light::Pilots>,
}

/// Light that an iteration traced to the camera ([`Integrator::film_splats`]): a film
/// position (in pixels, as a camera sample's: x to the right, y down, inside the image) and
/// the value it adds there, per unit area of a pixel; the driver spreads it over the pixels
/// by the film's reconstruction filter, as it spreads a camera sample at that position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmSplat {
    pub film: glam::Vec2,
    pub value: Vec3,
}

/// Ray counts, kept per task and summed for the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Closest-hit queries (camera rays and bounces).
    pub rays: u64,
    /// Occlusion queries.
    pub shadow_rays: u64,
    /// Closest-hit queries of light paths (VPL tracing).
    pub light_rays: u64,
    /// Light paths traced (VPL tracing).
    pub light_paths: u64,
    /// Virtual lights created.
    pub vpls: u64,
    /// Photons left for vertex merging (`pir-bdpt`).
    pub photons: u64,
    /// Queries of a pilot before the first iteration (its light paths' closest hits and its
    /// light samples' occlusion tests), counted by the render that runs it.
    pub pilot_rays: u64,
}

impl std::ops::AddAssign for Counters {
    fn add_assign(&mut self, o: Counters) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.light_rays += o.light_rays;
        self.light_paths += o.light_paths;
        self.vpls += o.vpls;
        self.photons += o.photons;
        self.pilot_rays += o.pilot_rays;
    }
}

/// A rendering method.
pub trait Integrator: Send + Sync {
    /// What the integrator chose for itself when prepared ([`Integrator::prepare`]: a count
    /// chosen by the scene, what a pilot measured), as (key, value) for the summary and the
    /// EXR metadata, where a key of the method's parameters takes this value
    /// ([`MethodConfig::report`]).
    fn measured(&self) -> Vec<(String, String)> {
        Vec::new()
    }

    /// Work done once before the first iteration, with the scene (a count chosen by a
    /// pilot): a function of the scene, the seed and the sampler alone, so that a resumed or
    /// sharded render prepares the same. What it traces is counted in `counters`.
    fn prepare(&mut self, _ctx: &RenderContext, _counters: &mut Counters) {}

    /// The camera at the film's resolution, given by the driver before the first iteration
    /// (for methods that trace light to the camera).
    fn set_camera(&mut self, _camera: CameraRays) {}

    /// Work done once per iteration before any pixel (iterations count from 1), counting
    /// what it traces in `counters`.
    fn begin_iteration(&mut self, _ctx: &RenderContext, _iteration: u64, _counters: &mut Counters) {}

    /// The light the current iteration traced to the camera, added to the iteration's
    /// samples in this order (a function of the seed and the iteration alone, so that the
    /// image does not depend on the threads); none by default.
    fn film_splats(&self) -> &[FilmSplat] {
        &[]
    }

    /// Radiance arriving along the camera ray `ray` (unit direction).
    fn radiance(&self, ctx: &RenderContext, ray: Ray, sampler: &mut Sampler, counters: &mut Counters)
    -> Vec3;

    /// Radiance arriving along each camera ray of `rays` (unit directions) into `out`, ray `i`
    /// drawing from `samplers[i]` (all three of one length): what the driver calls, once per
    /// chunk of a tile's pixels. Each `out[i]` must be what [`Integrator::radiance`] gives for
    /// `rays[i]` and `samplers[i]` (up to the last bits where an accelerator's batch queries
    /// differ from its single-ray ones), so that an integrator may trace the batch's paths
    /// together. By default ray by ray.
    fn radiance_batch(
        &self,
        ctx: &RenderContext,
        rays: &[Ray],
        samplers: &mut [Sampler],
        counters: &mut Counters,
        out: &mut [Vec3],
    ) {
        assert!(rays.len() == samplers.len() && rays.len() == out.len());
        for ((ray, sampler), o) in rays.iter().zip(samplers.iter_mut()).zip(out.iter_mut()) {
            *o = self.radiance(ctx, *ray, sampler, counters);
        }
    }
}
