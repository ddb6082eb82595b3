//! The batched (wavefront) camera-path walker: a batch of camera paths advanced together,
//! bounce by bounce, so that each bounce's closest-hit queries and each bounce's shadow rays
//! go to the accelerator as one batch
//! ([`Accelerator::intersect_batch`](crate::accel::Accelerator::intersect_batch),
//! [`Accelerator::occluded_batch`](crate::accel::Accelerator::occluded_batch): Embree's
//! 4/8/16-wide packets), for any [`Estimator`]: `pt`'s, `pir-bdpt`'s, and the forward
//! many-light methods' covered walks.
//!
//! One bounce: trace the rays of the live paths (finished paths are compacted away); shade
//! each hit in the batch's order with the loop body of the scalar walker
//! [`super::walker::walk`], which both share (`walker::arrive` and `walker::leave`: the emission found there, the
//! estimator's terms at the vertex, the BSDF sample, Russian roulette), except that the light
//! samples of the estimator's terms stop at their shadow rays, which are collected with the
//! terms that wait for them ([`Deferred`], the [`Terms`](super::deferred::Terms) that
//! [`Estimator::at_vertex`] is given); trace the collected shadow rays; add the kept terms
//! to their paths, each path's in its order. Every path draws the same dimensions of its own
//! sampler in the same order as the scalar walker, and adds the same terms in the same order
//! (emission at depth d, the terms of the vertex at d, emission at d + 1, …), computed by
//! the same functions; so each path's estimate is the scalar walker's, bit for bit,
//! wherever the batch queries answer as the single-ray ones do: the
//! BVH's and brute force's batch queries are their single-ray ones; Embree's packet kernels
//! are other code than its single-ray kernel, but gave the same hits bit for bit wherever
//! measured (Embree 3.13.5, AVX-512: every path of `tests/wavefront.rs`, and 256 × 256 × 16
//! samples of the Cornell and mirror-and-glass boxes). The scalar walker stays the reference
//! (`--walker scalar`).
//!
//! **`pt`'s Lambertian vertices in lanes.** Where the estimator's vertex terms are `pt`'s
//! ([`Estimator::PT_VERTICES`]) and the emitters are plain (triangles), a bounce's Lambertian
//! vertices are not shaded one by one: each draws its numbers and picks its emitter point
//! in the loop, in the scalar order, and [`Lanes`](super::diffuse_lanes::Lanes) computes
//! their light samples and BSDF samples sixteen at a time, structure of arrays, the same
//! numbers bit for bit; then each path takes its results in the loop's order (its light
//! sample's term, the throughput, roulette, the next ray). Between the two halves of the
//! scalar step ([`super::walker::arrive`], [`super::walker::leave`]).
//!
//! A gather from the virtual lights (`pir-bdpt`'s, the forward many-light methods') of at most
//! 64 connections (the sampled gathers at their defaults) gives its connections to
//! [`Deferred`] too ([`Terms::gather`](super::deferred::Terms::gather)): their shadow rays
//! join the bounce's batch, 16-wide packets filled from many receivers instead of a 4-wide
//! one per receiver (the resampled gather's k = 4), and each path's gather is summed from
//! them as the gather's own batches sum it. A larger gather (every VPL of many) is traced
//! where the scalar walker traces it, so that what a bounce keeps does not grow with the
//! VPLs. What an estimator traces otherwise inside its
//! own terms (a sphere light's cone sample, `pir-mis`'s bounce) is traced where the scalar
//! walker traces it.
//!
//! Measured (`docs/speed.md`): packets of 16 and batches of a whole tile (256 paths) were the
//! fastest for `pt` (1.2–1.3× the scalar walker's speed on Embree); `pir-bdpt` is 1.08–1.11×
//! (Cornell box, near-mirror floor, glossy corner; one thread, CPU time), less because the
//! gather, not Embree, is most of its time. Batching the closest hits gave 1.01–1.04×,
//! deferring the shadow rays of next-event estimation into the bounce's batch the rest.
//!
//! **Versions picked at run time.** The default build targets plain x86-64 (SSE2), so
//! [`walk_batch`], with the shading it inlines (`walker::arrive` and `leave`, BSDF sampling, the light sample of
//! [`connect_emitters_at`](super::direct::connect_emitters_at), the BSDFs' common cases), is
//! compiled three times with the `multiversion` crate, as the BVH's traversal is: for AVX2 +
//! FMA, for AVX-512 (CPUs with Ice Lake's set) and the baseline, the CPU's version picked at
//! run time. The wider ISAs buy three-operand instructions and more registers, not wider
//! arithmetic; the images are the same bit for bit, since the operations are the same IEEE
//! ones (Rust never fuses a multiply and an add on its own). What is not inlined (materials
//! other than the common ones, the emitters' rarer kinds, the gather) runs the baseline code.

use glam::Vec3;
use multiversion::multiversion;

use super::deferred::Deferred;
use super::diffuse_lanes::Lanes;
use super::walker::{Arrived, Estimator, Path, arrive, leave, roulette_and_go_on};
use super::{Counters, FilmSplat, Integrator, RenderContext};
use crate::accel::Hit;
use crate::geometry::Ray;
use crate::material::Bsdf;
use crate::sampling::Sampler;
use crate::scene::CameraRays;

/// Buffers of a batch: kept across bounces, and in a thread-local from batch to batch.
#[derive(Default)]
struct Buffers {
    /// Indices of the live paths, in the batch's order.
    live: Vec<u32>,
    /// Whether each live path goes on after this bounce.
    goes_on: Vec<bool>,
    rays: Vec<Ray>,
    hits: Vec<Option<Hit>>,
    deferred: Deferred,
    /// The bounce's Lambertian vertices, where they are shaded in lanes.
    lanes: Lanes,
}

/// The radiance that `estimator` estimates along each camera ray of `rays` (unit directions)
/// into `out`, path `i` drawing from `samplers[i]`: for each path, [`super::walker::walk`]
/// with `estimator`, the paths' queries batched bounce by bounce.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512vl+avx512dq+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt"
))]
pub fn walk_batch<E: Estimator>(
    ctx: &RenderContext,
    estimator: &E,
    rays: &[Ray],
    samplers: &mut [Sampler],
    counters: &mut Counters,
    out: &mut [Vec3],
) {
    assert!(rays.len() == samplers.len() && rays.len() == out.len());
    let mut paths: Vec<Path<E::State>> = rays.iter().map(|&ray| Path::start(estimator, ray)).collect();
    // The thread's buffers, kept from batch to batch: allocated, and their lanes
    // initialised, once per thread.
    BUFFERS.with_borrow_mut(|b| walk_paths(ctx, estimator, &mut paths, samplers, counters, b));
    for (o, p) in out.iter_mut().zip(&paths) {
        *o = p.radiance;
    }
}

thread_local! {
    static BUFFERS: std::cell::RefCell<Buffers> = std::cell::RefCell::default();
}

/// [`walk_batch`]'s paths, bounce by bounce, until all have ended.
#[inline(always)]
fn walk_paths<E: Estimator>(
    ctx: &RenderContext,
    estimator: &E,
    paths: &mut [Path<E::State>],
    samplers: &mut [Sampler],
    counters: &mut Counters,
    b: &mut Buffers,
) {
    const { assert!(!E::PT_VERTICES || !E::COVERS_SURFACES) };
    // (Nothing of an earlier batch is left, even where it ended in a panic.)
    b.deferred.clear();
    b.live.clear();
    b.live.extend(0..paths.len() as u32);
    // `pt`'s Lambertian vertices in lanes ([`Lanes`]).
    let in_lanes = E::PT_VERTICES && ctx.emitters.is_plain();
    while !b.live.is_empty() {
        b.rays.clear();
        b.rays.extend(b.live.iter().map(|&i| paths[i as usize].ray));
        b.hits.clear();
        b.hits.resize(b.rays.len(), None);
        counters.rays += b.rays.len() as u64;
        ctx.accel.intersect_batch(&b.rays, &mut b.hits);

        b.goes_on.clear();
        b.goes_on.resize(b.live.len(), false);
        b.lanes.clear();
        for k in 0..b.live.len() {
            let i = b.live[k] as usize;
            let (path, sampler) = (&mut paths[i], &mut samplers[i]);
            // (The light samples of the vertex's terms are kept in `deferred`, not tested.)
            b.deferred.at(i as u32);
            b.goes_on[k] = match arrive(ctx, estimator, path, b.hits[k], sampler, counters) {
                Arrived::Done(goes_on) => goes_on,
                Arrived::At(sp, wo, material) => match material.bsdf_at(sp.uv) {
                    Bsdf::Diffuse { albedo } if in_lanes => {
                        b.lanes.draw(ctx, k as u32, &sp, wo, albedo, path.beta, sampler);
                        false // (decided below)
                    }
                    bsdf => leave(ctx, estimator, path, &sp, wo, &bsdf, sampler, counters, &mut b.deferred),
                },
            };
        }
        if !b.lanes.is_empty() {
            b.lanes.shade();
            for j in 0..b.lanes.len() {
                let k = b.lanes.slot(j) as usize;
                let i = b.live[k] as usize;
                let (path, sampler) = (&mut paths[i], &mut samplers[i]);
                // What `leave` does after `pt`'s terms at the vertex: its light sample, then
                // the BSDF sample (η = 1: `eta_scale` stays), roulette, the next ray.
                b.deferred.at(i as u32);
                let light = b.lanes.light_sample(j);
                counters.shadow_rays += u64::from(light.shadow.is_some());
                b.deferred.sample_connected(b.lanes.beta(j), light.shadow, light.value, &mut path.radiance);
                b.goes_on[k] = b.lanes.scattered(j).is_some_and(|s| {
                    path.beta = s.beta;
                    path.sampled(b.lanes.point(j), s.pdf, false);
                    roulette_and_go_on::<E>(ctx, path, s.origin, s.wi, sampler)
                });
            }
        }
        let mut goes_on = b.goes_on.iter();
        b.live.retain(|_| *goes_on.next().expect("one flag per live path"));

        b.deferred.finish(ctx.accel, |i, term| paths[i as usize].radiance += term);
    }
}

/// How the driver's batches of camera rays are traced (`--walker`): together, by the
/// integrator's batched walker where it has one (every method's camera paths: [`walk_batch`]),
/// or ray by ray through
/// [`Integrator::radiance`] ([`RayByRay`]), the reference. Both give the same image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Walker {
    #[default]
    Batched,
    Scalar,
}

impl std::fmt::Display for Walker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Walker::Batched => "batched",
            Walker::Scalar => "scalar",
        })
    }
}

impl std::str::FromStr for Walker {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "batched" => Ok(Walker::Batched),
            "scalar" => Ok(Walker::Scalar),
            _ => Err(format!("unknown walker {s:?} (expected batched or scalar)")),
        }
    }
}

/// An integrator with its batch entry point the default, ray by ray through
/// [`Integrator::radiance`]: for every method, the scalar walker, the reference its batched
/// walker is tested against (`--walker scalar`).
pub struct RayByRay(pub Box<dyn Integrator>);

impl Integrator for RayByRay {
    fn measured(&self) -> Vec<(String, String)> {
        self.0.measured()
    }
    fn prepare(&mut self, ctx: &RenderContext, counters: &mut Counters) {
        self.0.prepare(ctx, counters);
    }
    fn set_camera(&mut self, camera: CameraRays) {
        self.0.set_camera(camera);
    }
    fn begin_iteration(&mut self, ctx: &RenderContext, iteration: u64, counters: &mut Counters) {
        self.0.begin_iteration(ctx, iteration, counters);
    }
    fn film_splats(&self) -> &[FilmSplat] {
        self.0.film_splats()
    }
    fn radiance(
        &self,
        ctx: &RenderContext,
        ray: Ray,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        self.0.radiance(ctx, ray, sampler, counters)
    }
}
