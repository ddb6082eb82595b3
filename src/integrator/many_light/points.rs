//! Virtual point lights: one iteration's VPLs as points, each with its BSDF prepared for its
//! incoming direction, laid out in lanes for the four-wide kernel of [`super::lanes`], with the
//! iteration's bound on the geometry term (infinite for `ir` and the weighed methods, whose
//! bound applies to the weighted connection instead).

use glam::Vec3;

use super::bidirectional::{DrawWeights, draw_term};
use super::config::{Clamping, Connect};
use super::lanes::{DiffuseReceiver, EstimateReceiver, LaneKind, VplLanes};
use super::light_paths::Vpl;
use super::light_set::tree_light;
use super::light_tree::TreeLight;
use super::lobe::Lobe;
use super::resample::{Candidates, LANES};
use super::tree_gather::Kernel;
use super::virtual_light::Lights;
use super::window::Window;
use crate::geometry::OffsetPoint;
use crate::integrator::RenderContext;
use crate::integrator::walker::Vertex;
use crate::material::{PreparedBsdf, TransportMode};
use crate::sampling::Sampler;

/// Virtual point lights, each with its BSDF prepared for its incoming direction, also laid out
/// in lanes for the four-wide kernel, and the geometry term's bound of the iteration.
pub struct PointLights {
    pub vpls: Vec<Vpl>,
    /// VPL j's BSDF for its incoming direction (importance mode).
    pub emitting: Vec<PreparedBsdf>,
    /// The same lights in lanes, with their shadow-ray ends.
    pub lanes: VplLanes,
    /// The bound on G (infinite for `ir`).
    pub bound: f32,
}

impl PointLights {
    /// With `weighed`, `pir-bdpt`'s rule of which camera vertices connect, the resampled
    /// gather's estimates include the connections' weights
    /// ([`super::bidirectional::DrawWeights`]).
    pub fn new(
        vpls: Vec<Vpl>,
        clamping: Clamping,
        iteration: u64,
        ctx: &RenderContext,
        weighed: Option<Connect>,
    ) -> Self {
        let emitting: Vec<PreparedBsdf> = vpls
            .iter()
            .map(|v| {
                let bsdf = v.bsdf(ctx.scene);
                PreparedBsdf::new(bsdf, v.geometry(), v.w_in, TransportMode::Importance)
            })
            .collect();
        let power: Vec<f32> = vpls
            .iter()
            .zip(&emitting)
            .map(|(v, e)| tree_light(v, &v.bsdf(ctx.scene), e.is_active(), 0.0).intensity)
            .collect();
        let weight_terms: Vec<f32> = match weighed {
            Some(connect) => {
                vpls.iter().zip(&emitting).map(|(v, e)| draw_term(v, e.bsdf(), connect)).collect()
            }
            None => Vec::new(),
        };
        let lanes = VplLanes::new(&vpls, &emitting, &power, &weight_terms);
        PointLights { vpls, emitting, lanes, bound: clamping.bound(iteration) }
    }
}

/// A camera vertex as a receiver of point lights.
pub struct PointReceiver<'a> {
    v: &'a Vertex<'a>,
    /// Its BSDF prepared for its `wo` (radiance mode).
    fx: PreparedBsdf,
    /// The same as a Lambertian receiver of the four-wide kernel, if it is one.
    diffuse: Option<DiffuseReceiver>,
    lobe: Option<Lobe>,
    max_depth: u32,
}

impl Lights for PointLights {
    type Receiver<'a> = PointReceiver<'a>;

    #[inline]
    fn receiver<'a>(
        &'a self,
        v: &'a Vertex<'a>,
        max_vpl_depth: u32,
        lobe: Option<Lobe>,
    ) -> PointReceiver<'a> {
        let fx = PreparedBsdf::new(*v.bsdf, v.sp.geometry(), v.wo, TransportMode::Radiance);
        let diffuse = DiffuseReceiver::new(v.sp, &fx);
        PointReceiver { v, fx, diffuse, lobe, max_depth: max_vpl_depth }
    }

    #[inline]
    fn is_active(rx: &PointReceiver) -> bool {
        rx.fx.is_active()
    }

    #[inline]
    fn count(&self) -> usize {
        self.vpls.len()
    }

    #[inline]
    fn chunks(&self) -> usize {
        self.lanes.chunks()
    }

    #[inline]
    fn end(&self, j: usize) -> &OffsetPoint {
        self.lanes.end(j)
    }

    /// Lambertian pairs lane by lane, the others one by one.
    #[inline]
    fn chunk_contributions(&self, chunk: usize, rx: &PointReceiver, _: &mut Sampler) -> [Vec3; LANES] {
        let lanes = rx.diffuse.map(|r| self.lanes.diffuse_contributions(chunk, &r, self.bound, rx.max_depth));
        std::array::from_fn(|i| {
            let j = chunk * LANES + i;
            let Some(vpl) = self.vpls.get(j) else { return Vec3::ZERO };
            match (lanes, self.lanes.kind(j)) {
                (Some(c), LaneKind::Diffuse | LaneKind::Empty) => c[i],
                _ if vpl.depth > rx.max_depth => Vec3::ZERO,
                _ => {
                    let sp = &rx.v.sp;
                    point_contribution(sp.p, sp.frame.n, &rx.fx, vpl, &self.emitting[j], self.bound)
                }
            }
        })
    }

    #[inline]
    fn contribution(&self, j: usize, rx: &PointReceiver, _: &mut Sampler) -> Vec3 {
        let sp = &rx.v.sp;
        point_contribution(sp.p, sp.frame.n, &rx.fx, &self.vpls[j], &self.emitting[j], self.bound)
    }

    /// The four-wide estimates; a pick's contribution is then evaluated alone (a pick is
    /// rarely in the chunk of the one before, and one light's scalar evaluation costs less
    /// than the kernel's of its chunk; the same numbers bit for bit: `lanes.rs`'s tests).
    fn push_estimates(
        &self,
        cands: &mut Candidates,
        window: &Window,
        rx: &PointReceiver,
        weights: Option<DrawWeights>,
        _: &mut Sampler,
    ) {
        let sp = &rx.v.sp;
        let r = EstimateReceiver {
            x: sp.p,
            ng: sp.ng,
            ns: sp.frame.n,
            bound: self.bound,
            max_depth: rx.max_depth,
            lobe: rx.lobe.as_ref(),
            transmits: rx.v.bsdf.transmits(),
            weights,
        };
        self.lanes.push_estimates(cands, window, &r);
    }

    fn kernel(&self) -> Kernel {
        Kernel::Point { bound: self.bound }
    }

    fn tree_lights(&self, ctx: &RenderContext) -> Vec<TreeLight> {
        use rayon::prelude::*;
        self.vpls
            .par_iter()
            .zip(&self.emitting)
            .map(|(v, e)| tree_light(v, &v.bsdf(ctx.scene), e.is_active(), 0.0))
            .collect()
    }
}

/// Φ f_p cos_p f_x cos_x / d² of one VPL at the receiver x (shading normal `n`), with G
/// clamped at `bound`; zero when either BSDF is. The scalar form of the gather; the four-wide
/// kernel of [`super::lanes`] computes exactly this, bit for bit.
pub fn point_contribution(
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
    point_value(vpl, fx, fp, n, w, dist2, bound)
}

/// The end of [`point_contribution`], from the two BSDFs' values `fx` (towards the unit
/// direction `w` to the VPL) and `fp` (towards −w) at squared distance `dist2`, for callers
/// that evaluated the BSDFs themselves (with their densities, [`super::bidirectional::connection`]).
#[inline]
pub fn point_value(vpl: &Vpl, fx: Vec3, fp: Vec3, n: Vec3, w: Vec3, dist2: f32, bound: f32) -> Vec3 {
    let c = vpl.flux * fx * fp / dist2;
    if bound.is_finite() {
        let g = n.dot(w).abs() * vpl.frame.n.dot(w).abs() / dist2;
        if g > bound {
            return c * (bound / g);
        }
    }
    c
}
