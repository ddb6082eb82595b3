//! `--method pt`: a unidirectional path tracer, pir's ground truth.
//!
//! Next-event estimation on the area emitters (triangle by power, uniform point) combined
//! with BSDF sampling by multiple importance sampling (power heuristic); delta bounces (mirror,
//! glass) carry emission found by the BSDF at full weight. `max_depth` counts path segments
//! from the camera to the emitter as Mitsuba 3 does (1 = emitters seen directly, 2 = direct
//! lighting, …). Russian roulette from the third bounce on, with survival probability
//! min(0.95, max throughput · η²) and the survivors reweighted, keeps the estimate unbiased.
//!
//! No parameters besides `max_depth` (`--max-depth`).

use glam::Vec3;

use super::direct::{Sampled, emission, sample_emitters};
use super::{Counters, Integrator, RenderContext};
use crate::geometry::{Ray, offset_origin};
use crate::material::{LocalGeometry, TransportMode};
use crate::sampling::Sampler;

/// Number of segments after which Russian roulette starts.
const RR_DEPTH: u32 = 3;

#[derive(Clone, Copy, Debug, Default)]
pub struct PathTracer;

impl Integrator for PathTracer {
    fn name(&self) -> &'static str {
        "pt"
    }

    fn radiance(
        &self,
        ctx: &RenderContext,
        mut ray: Ray,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        let mut radiance = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut eta_scale = 1.0f32;
        // How the current ray was sampled: delta lobes (and the camera) get full emission.
        let mut how = Sampled::camera(ray.origin);
        let mut depth = 0u32;
        loop {
            counters.rays += 1;
            let Some(hit) = ctx.accel.intersect(&ray) else { break };
            depth += 1;
            let sp = ctx.scene.surface_of_hit(&ray, &hit);
            let wo = -ray.dir.normalize();
            let material = &ctx.scene.materials[sp.material as usize];

            // ---- Emission found by the camera ray or the BSDF sample.
            radiance += beta * emission(ctx, material, &sp, wo, &how);
            if depth >= ctx.max_depth {
                break;
            }

            // ---- Emitter sampling (one more segment, so depth + 1 ≤ max_depth).
            let bsdf = &material.bsdf;
            if !bsdf.is_delta() {
                radiance += beta * sample_emitters(ctx, &sp, bsdf, wo, sampler, counters);
            }

            // ---- BSDF sampling.
            let g = LocalGeometry { ng: sp.ng, frame: sp.frame };
            let u_lobe = sampler.next_f32();
            let u = sampler.next_2d();
            let Some(s) = bsdf.sample(&g, wo, u_lobe, u, TransportMode::Radiance) else { break };
            beta *= s.weight;
            if beta.max_element() <= 0.0 || !beta.is_finite() {
                break;
            }
            eta_scale *= s.eta * s.eta;
            how = Sampled { from: sp.p, pdf: s.pdf, delta: s.delta };

            // ---- Russian roulette (unbiased: survivors are divided by the survival probability).
            if depth >= RR_DEPTH {
                let q = (beta.max_element() * eta_scale).min(0.95);
                if sampler.next_f32() >= q {
                    break;
                }
                beta /= q;
            }
            ray = Ray::new(offset_origin(sp.p, sp.ng, s.wi), s.wi);
        }
        radiance
    }
}
