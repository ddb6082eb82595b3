//! The batched (wavefront) camera-path walker of `pt`: a batch of camera paths advanced
//! together, bounce by bounce, so that each bounce's closest-hit queries and each bounce's
//! shadow rays go to the accelerator as one batch
//! ([`Accelerator::intersect_batch`](crate::accel::Accelerator::intersect_batch),
//! [`Accelerator::occluded_batch`](crate::accel::Accelerator::occluded_batch): Embree's
//! 4/8/16-wide packets).
//!
//! One bounce: trace the rays of the live paths (finished paths are compacted away); shade
//! each hit in the batch's order (the emission found there, the light sample up to its
//! shadow ray, which is collected, the BSDF sample and Russian roulette); trace the collected
//! shadow rays; add each unoccluded light sample to its path. Every path draws the same
//! dimensions of its own sampler in the same order as [`super::walker::walk`] with the path
//! tracer's estimator, and adds the same terms in the same order (emission at depth d, the
//! light sample at d, emission at d + 1, …), computed by the same functions; so each path's
//! estimate is the scalar walker's, bit for bit, wherever the batch queries answer as the
//! single-ray ones do: the BVH's and brute force's batch queries are their single-ray ones;
//! Embree's packet kernels are other code than its single-ray kernel, but gave the same hits
//! bit for bit wherever measured (Embree 3.13.5, AVX-512: every path of `tests/wavefront.rs`,
//! and 256 × 256 × 16 samples of the Cornell and mirror-and-glass boxes). The scalar walker
//! stays the reference, and the walker of every other method.
//!
//! Measured (`docs/speed.md`): packets of 16 and batches of a whole tile (256 paths) were the
//! fastest; the shading, still one vertex at a time, is what is left to go wide.
//!
//! **Versions picked at run time.** The default build targets plain x86-64 (SSE2), so
//! [`walk_batch`], with the shading it inlines (`bounce`, [`scatter`], the light sample of
//! [`connect_emitters_at`], the BSDFs' common cases), is compiled three times with the
//! `multiversion` crate, as the BVH's traversal is: for AVX2 + FMA, for AVX-512 (CPUs with
//! Ice Lake's set) and the baseline, the CPU's version picked at run time. The wider ISAs buy
//! three-operand instructions and more registers, not wider arithmetic;
//! the images are the same bit for bit, since the operations are the same IEEE ones (Rust
//! never fuses a multiply and an add on its own). What is not inlined (materials other than
//! the common ones, the emitters' rarer kinds) runs the baseline code.

use glam::Vec3;
use multiversion::multiversion;

use super::direct::{Sampled, connect_emitters_at, emission, environment, power_heuristic};
use super::scatter::{scatter, survives_roulette};
use super::{Counters, FilmSplat, Integrator, RenderContext};
use crate::accel::Hit;
use crate::geometry::{Ray, offset_origin};
use crate::material::TransportMode;
use crate::sampling::Sampler;
use crate::scene::CameraRays;

/// One camera path of a batch between bounces: what the scalar walker keeps in its loop.
struct Path {
    /// The ray to trace next.
    ray: Ray,
    radiance: Vec3,
    beta: Vec3,
    eta_scale: f32,
    /// How `ray` was sampled (the camera or a delta lobe: full emission).
    how: Sampled,
    /// Segments from the camera to the vertex `ray` left.
    depth: u32,
}

/// A light sample waiting for its shadow ray: the path, its throughput at the vertex, and
/// what it adds unless occluded.
struct Pending {
    path: u32,
    beta: Vec3,
    value: Vec3,
}

/// Buffers of one batch, kept across bounces.
#[derive(Default)]
struct Buffers {
    /// Indices of the live paths, in the batch's order.
    live: Vec<u32>,
    rays: Vec<Ray>,
    hits: Vec<Option<Hit>>,
    pending: Vec<Pending>,
    shadows: Vec<Ray>,
    blocked: Vec<bool>,
}

/// The path tracer's radiance along each camera ray of `rays` (unit directions) into `out`,
/// path `i` drawing from `samplers[i]`: for each path, [`super::walker::walk`] with the path
/// tracer's estimator, the paths' queries batched bounce by bounce.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512vl+avx512dq+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt"
))]
pub fn walk_batch(
    ctx: &RenderContext,
    rays: &[Ray],
    samplers: &mut [Sampler],
    counters: &mut Counters,
    out: &mut [Vec3],
) {
    assert!(rays.len() == samplers.len() && rays.len() == out.len());
    let mut paths: Vec<Path> = rays
        .iter()
        .map(|&ray| Path {
            ray,
            radiance: Vec3::ZERO,
            beta: Vec3::ONE,
            eta_scale: 1.0,
            how: Sampled::camera(ray.origin),
            depth: 0,
        })
        .collect();
    let mut b = Buffers { live: (0..rays.len() as u32).collect(), ..Buffers::default() };
    while !b.live.is_empty() {
        b.rays.clear();
        b.rays.extend(b.live.iter().map(|&i| paths[i as usize].ray));
        b.hits.clear();
        b.hits.resize(b.rays.len(), None);
        counters.rays += b.rays.len() as u64;
        ctx.accel.intersect_batch(&b.rays, &mut b.hits);

        b.pending.clear();
        b.shadows.clear();
        let mut kept = 0;
        for k in 0..b.live.len() {
            let i = b.live[k];
            let (path, sampler) = (&mut paths[i as usize], &mut samplers[i as usize]);
            if bounce(ctx, i, path, b.hits[k], sampler, counters, &mut b.pending, &mut b.shadows) {
                b.live[kept] = i;
                kept += 1;
            }
        }
        b.live.truncate(kept);

        if !b.shadows.is_empty() {
            b.blocked.clear();
            b.blocked.resize(b.shadows.len(), false);
            ctx.accel.occluded_batch(&b.shadows, &mut b.blocked);
            for (p, &blocked) in b.pending.iter().zip(&b.blocked) {
                let value = if blocked { Vec3::ZERO } else { p.value };
                paths[p.path as usize].radiance += p.beta * value;
            }
        }
    }
    for (o, p) in out.iter_mut().zip(&paths) {
        *o = p.radiance;
    }
}

/// One vertex of path `index`, where its ray found `hit`: the scalar walker's loop body for
/// the path tracer, with the light sample's shadow ray pushed to `shadows` (and what it adds
/// to `pending`) instead of traced. Whether the path goes on (its next ray in `path.ray`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn bounce(
    ctx: &RenderContext,
    index: u32,
    path: &mut Path,
    hit: Option<Hit>,
    sampler: &mut Sampler,
    counters: &mut Counters,
    pending: &mut Vec<Pending>,
    shadows: &mut Vec<Ray>,
) -> bool {
    let Some(hit) = hit else {
        if !ctx.emitters.environments().is_empty() {
            path.radiance += path.beta * environment(ctx, path.ray.dir.normalize(), &path.how);
        }
        return false;
    };
    path.depth += 1;
    let sp = ctx.scene.surface_of_hit(&hit, path.ray.dir);
    let wo = -path.ray.dir.normalize();
    let material = ctx.scene.material(sp.material);

    // ---- Emission found by the camera ray or the BSDF sample.
    path.radiance += path.beta * emission(ctx, material, &sp, wo, &path.how);
    if path.depth >= ctx.max_depth {
        return false;
    }

    // ---- Light sampling, its shadow ray deferred to the bounce's batch.
    let bsdf = &material.bsdf_at(sp.uv);
    if !bsdf.is_delta() {
        let u_select = sampler.next_f32();
        let u = sampler.next_2d();
        match connect_emitters_at(ctx, &sp, bsdf, wo, (u_select, u), counters) {
            // (Added as the scalar walker adds its zero: β · 0 is NaN where β is not finite.)
            None => path.radiance += path.beta * Vec3::ZERO,
            Some(c) => {
                let value = c.value(|s| power_heuristic(s.pdf_light, s.pdf_bsdf));
                match c.shadow {
                    None => path.radiance += path.beta * value,
                    Some(ray) => {
                        shadows.push(ray);
                        pending.push(Pending { path: index, beta: path.beta, value });
                    }
                }
            }
        }
    }

    // ---- BSDF sampling and Russian roulette.
    let Some(s) = scatter(bsdf, &sp, wo, TransportMode::Radiance, sampler, &mut path.beta) else {
        return false;
    };
    path.eta_scale *= s.eta * s.eta;
    path.how = Sampled { from: sp.p, pdf: s.pdf, delta: s.delta };
    if path.depth >= ctx.scene.defaults().rr_depth
        && !survives_roulette(path.beta.max_element() * path.eta_scale, &mut path.beta, sampler)
    {
        return false;
    }
    path.ray = Ray::new(offset_origin(sp.p, sp.ng, s.wi), s.wi);
    true
}

/// How the driver's batches of camera rays are traced (`--walker`): together, by the
/// integrator's batched walker where it has one (`pt`: [`walk_batch`]), or ray by ray through
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
/// [`Integrator::radiance`]: for `pt`, the scalar walker, the reference its batched walker is
/// tested against (`--walker scalar`).
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
