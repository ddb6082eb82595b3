//! The gather: the light a receiver x gets from every virtual light of the iteration,
//!
//! L(x) = Σ_j Φ_j f_j(ω_j, y_j→x) cos θ_j · f_x(x→y_j, ω_o) cos θ_x / ‖y_j − x‖² · V(x, y_j)
//!
//! for point lights (G clamped at the iteration's bound), or each term integrated over the
//! cone of a sphere ([`super::spheres`]). Both BSDFs are evaluated in full (a glossy VPL emits
//! its lobe), Φ_j is already divided by the number of light paths, and the shadow rays go to
//! the accelerator in batches ([`ShadowBatch`]), in VPL order.

use glam::Vec3;

use super::lanes::{DiffuseReceiver, LANES, LaneKind};
use super::light_paths::Vpl;
use super::light_set::{LightSet, PointLights};
use super::shadow_batch::ShadowBatch;
use super::spheres::SphereLights;
use crate::geometry::OffsetPoint;
use crate::integrator::direct::shadow_segment;
use crate::integrator::walker::Vertex;
use crate::integrator::{Counters, RenderContext};
use crate::material::{PreparedBsdf, TransportMode};
use crate::sampling::Sampler;

impl LightSet {
    /// Indirect light at the camera vertex `v` from every virtual light of at most
    /// `max_vpl_depth` segments, visibility included.
    pub fn gather(
        &self,
        ctx: &RenderContext,
        v: &Vertex,
        max_vpl_depth: u32,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        let mut batch = ShadowBatch::new(ctx.accel);
        let queued = match self {
            LightSet::Points(p) => p.queue(v, max_vpl_depth, &mut batch),
            LightSet::Spheres(s) => s.queue(ctx, v, max_vpl_depth, sampler, &mut batch),
        };
        if !queued {
            return Vec3::ZERO;
        }
        let (total, traced) = batch.finish();
        counters.shadow_rays += traced;
        total
    }
}

impl PointLights {
    /// Queues every light's contribution with its shadow ray; `false` when the receiver
    /// reflects nothing towards `v.wo`.
    fn queue(&self, v: &Vertex, max_vpl_depth: u32, batch: &mut ShadowBatch) -> bool {
        let sp = &v.sp;
        let fx = PreparedBsdf::new(*v.bsdf, sp.geometry(), v.wo, TransportMode::Radiance);
        if !fx.is_active() {
            return false;
        }
        let x = OffsetPoint::new(sp.p, sp.ng);
        // Lambertian pairs lane by lane, the others one by one, queued in VPL order.
        let receiver = DiffuseReceiver::new(sp, &fx);
        for chunk in 0..self.lanes.chunks() {
            let lanes =
                receiver.map(|r| self.lanes.diffuse_contributions(chunk, &r, self.bound, max_vpl_depth));
            for i in 0..LANES {
                let j = chunk * LANES + i;
                let Some(vpl) = self.vpls.get(j) else { break };
                let c = match (lanes, self.lanes.kind(j)) {
                    (Some(c), LaneKind::Diffuse | LaneKind::Empty) => c[i],
                    _ if vpl.depth > max_vpl_depth => continue,
                    _ => point_contribution(sp.p, sp.frame.n, &fx, vpl, &self.emitting[j], self.bound),
                };
                if c != Vec3::ZERO {
                    batch.push(shadow_segment(&x, self.lanes.end(j)), c);
                }
            }
        }
        true
    }
}

impl SphereLights {
    /// Queues every sphere's contribution with its shadow ray to the centre.
    fn queue(
        &self,
        ctx: &RenderContext,
        v: &Vertex,
        max_vpl_depth: u32,
        sampler: &mut Sampler,
        batch: &mut ShadowBatch,
    ) -> bool {
        let sp = &v.sp;
        let gx = sp.geometry();
        let x = OffsetPoint::new(sp.p, sp.ng);
        for (j, vpl) in self.vpls.iter().enumerate() {
            if vpl.depth > max_vpl_depth {
                continue;
            }
            let bsdf_p = &ctx.scene.material(vpl.material).bsdf;
            let c = self.contribution(j, &gx, sp.p, v.bsdf, v.wo, bsdf_p, sampler);
            if c != Vec3::ZERO {
                batch.push(shadow_segment(&x, &self.ends[j]), c);
            }
        }
        true
    }
}

/// Φ f_p cos_p f_x cos_x / d² of one VPL at the receiver x (shading normal `n`), with G
/// clamped at `bound`; zero when either BSDF is. The scalar form of the gather; the four-wide
/// kernel of [`super::lanes`] computes exactly this, bit for bit.
pub(super) fn point_contribution(
    x: Vec3,
    n: Vec3,
    fx: &PreparedBsdf,
    vpl: &Vpl,
    fp: &PreparedBsdf,
    bound: f32,
) -> Vec3 {
    let d = vpl.p - x;
    let dist2 = d.length_squared();
    if dist2 <= 0.0 {
        return Vec3::ZERO;
    }
    let w = d / dist2.sqrt();
    let fx = fx.eval(w);
    if fx == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let fp = fp.eval(-w);
    if fp == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let c = vpl.flux * fx * fp / dist2;
    if bound.is_finite() {
        let g = n.dot(w).abs() * vpl.frame.n.dot(w).abs() / dist2;
        if g > bound {
            return c * (bound / g);
        }
    }
    c
}
