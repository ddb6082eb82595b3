//! Instant radiosity: virtual point lights, plain, clamped and progressively clamped, and
//! virtual spherical lights of constant or progressively shrinking radius.
//!
//! | `--method` | virtual light | bias | reference |
//! |---|---|---|---|
//! | `ir` | point, G unclamped | none, but spiky near creases and on glossy surfaces | Keller 1997 |
//! | `ir-clamp` | point, G' = min(G, b) | too dark, for ever | Keller; pbrt-v2 `igi` |
//! | `pir-clamp` | point, G' = min(G, b_i), b_i = b_1 · i^α | vanishes: consistent | thesis 4.2.1 |
//! | `vsl` | sphere of radius r | blur, for ever | Hašan et al. 2009 |
//! | `pir-vsl` | sphere, r_i = r_1 · i^((α−1)/2) | vanishes: consistent | thesis 4.2.2 |
//!
//! Parameters (flags of `pir render`):
//! - `--vpls N` light paths per iteration (default [`DEFAULT_PATHS`]). Each leaves a virtual
//!   light at every non-delta vertex.
//! - `--clamp B` the bound b (`ir-clamp`) or b_1 (`pir-clamp`), in 1/length². Default:
//!   100 / diagonal², the G of two facing surfaces a tenth of the scene's diagonal apart, so
//!   the default needs no tuning whatever the scene's units.
//! - `--radius R` the radius r (`vsl`) or r_1 (`pir-vsl`), one for all lights. Default: per
//!   light from the VPL density, the distance to its 4th nearest VPL of the iteration, at most
//!   4 % of the scene's diagonal (see [`super::vsl`]); an iteration with too few VPLs for the
//!   neighbours takes the 4 %.
//! - `--alpha A` the schedule exponent of `pir-clamp` and `pir-vsl` (default 0.6, the
//!   thesis' best).
//!
//! # Path space
//! Every method must render exactly the path space of `pt` for the same `max_depth`. The
//! camera path follows delta bounces to its first non-delta vertex x (depth d segments). Paths
//! through x split into disjoint classes by their next vertex:
//! - an emitter: direct light, by light sampling and BSDF sampling with MIS (the BSDF-sampled
//!   ray's emission is added with its MIS weight);
//! - a non-delta surface point y: a VPL connection x–y, where y is a VPL of s segments from its
//!   emitter, admitted when d + 1 + s ≤ max_depth;
//! - a delta surface (mirror, glass): the BSDF-sampled ray continues through the delta chain
//!   and the next non-delta vertex gathers in turn (plain VPL gathering misses these paths,
//!   e.g. a diffuse floor lit by a wall seen in a mirror).
//!
//! # Gathering
//! L(x) = Σ_j Φ_j f_j(ω_j, y_j→x) cos θ_j · f_x(x→y_j, ω_o) cos θ_x / ‖y_j − x‖² · V(x, y_j),
//! both BSDFs evaluated in full (a glossy VPL emits its lobe), with Φ_j already divided by the
//! number of light paths. Shadow rays are issued in batches through the accelerator.

use glam::Vec3;

use super::direct::{Sampled, emission, sample_emitters, shadow_segment};
use super::knn::KdTree;
use super::schedule::{DEFAULT_ALPHA, clamp_bound, radius};
use super::shadow_batch::ShadowBatch;
use super::vpl::{Vpl, trace_vpls};
use super::vpl_lanes::{DiffuseReceiver, LANES, LaneKind, VplLanes};
use super::vsl::{self, KNN_K, KNN_SCALE, MAX_RADIUS};
use super::{Counters, Integrator, RenderContext};
use crate::geometry::{OffsetPoint, Ray, offset_origin};
use crate::material::{Bsdf, LocalGeometry, PreparedBsdf, TransportMode};
use crate::sampling::Sampler;
use crate::scene::SurfacePoint;

/// Light paths per iteration when `--vpls` is not given. An iteration costs pixels × VPLs
/// shadow rays and the progressive schedules advance once per iteration, so many cheap
/// iterations beat few rich ones: on the 256×256 Cornell box, 20 s of `pir-clamp` on 2 cores
/// reached a relative MSE of 5.0e-4 with 16 paths, 5.1e-4 with 32, 6.3e-4 with 64 and 1.2e-3
/// with 256. 32 keeps a few VPLs per iteration for glossy and spherical lights too.
pub const DEFAULT_PATHS: usize = 32;

/// How the geometry term is bounded.
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
        Clamping::Progressive { b1, alpha: DEFAULT_ALPHA }
    }

    fn bound(&self, iteration: u64) -> f32 {
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
    /// Per light, the distance to its 4th nearest VPL (see [`super::vsl`]).
    Density,
}

/// Which virtual lights, with which bias control.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VirtualLights {
    Points(Clamping),
    /// Spheres; with `alpha` the radius shrinks as r_1 · i^((α−1)/2).
    Spheres {
        radius: Radius,
        alpha: Option<f32>,
    },
}

pub struct InstantRadiosity {
    lights: VirtualLights,
    paths: usize,
    /// Fallback radius when the density radius cannot be computed.
    max_radius: f32,
    /// This iteration's VPLs, each VPL's BSDF prepared for its incoming direction, the
    /// geometry-term bound and (for spheres) radii.
    vpls: Vec<Vpl>,
    emitting: Vec<PreparedBsdf>,
    /// The same VPLs in lanes, for the point-light gather, and their shadow-ray ends.
    lanes: VplLanes,
    bound: f32,
    radii: Vec<f32>,
}

impl InstantRadiosity {
    pub fn new(lights: VirtualLights, paths: usize) -> Self {
        InstantRadiosity {
            lights,
            paths,
            max_radius: 0.0,
            vpls: Vec::new(),
            emitting: Vec::new(),
            lanes: VplLanes::default(),
            bound: f32::INFINITY,
            radii: Vec::new(),
        }
    }

    /// Point lights with the given clamping.
    pub fn points(clamping: Clamping, paths: usize) -> Self {
        Self::new(VirtualLights::Points(clamping), paths)
    }

    /// This iteration's radius of every VSL (empty for point lights).
    pub fn radii(&self) -> &[f32] {
        &self.radii
    }

    fn compute_radii(&mut self, iteration: u64) {
        let VirtualLights::Spheres { radius: r, alpha } = self.lights else {
            self.radii.clear();
            return;
        };
        let factor = alpha.map_or(1.0, |a| radius(1.0, a, iteration));
        self.radii = match r {
            Radius::Global(r1) => vec![r1 * factor; self.vpls.len()],
            Radius::Density => {
                let points: Vec<Vec3> = self.vpls.iter().map(|v| v.p).collect();
                let tree = KdTree::new(&points);
                // The light itself is its own nearest point: the k-th neighbour is the (k+1)-th.
                points
                    .iter()
                    .map(|&p| {
                        let r1 = tree
                            .kth_distance(p, KNN_K + 1)
                            .map_or(self.max_radius, |d| (KNN_SCALE * d).min(self.max_radius));
                        r1.max(self.max_radius * 1e-3) * factor
                    })
                    .collect()
            }
        };
    }

    /// This iteration's VPLs.
    pub fn vpls(&self) -> &[Vpl] {
        &self.vpls
    }

    /// Indirect light at x from every VPL of at most `max_vpl_depth` segments: the
    /// contributions of the VPLs, each queued with its shadow ray.
    #[allow(clippy::too_many_arguments)]
    fn gather(
        &self,
        ctx: &RenderContext,
        sp: &SurfacePoint,
        bsdf: &Bsdf,
        wo: Vec3,
        max_vpl_depth: u32,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        let gx = LocalGeometry { ng: sp.ng, frame: sp.frame };
        let x = OffsetPoint::new(sp.p, sp.ng);
        let mut batch = ShadowBatch::new(ctx.accel);
        if matches!(self.lights, VirtualLights::Spheres { .. }) {
            for (j, vpl) in self.vpls.iter().enumerate() {
                if vpl.depth > max_vpl_depth {
                    continue;
                }
                let bsdf_p = &ctx.scene.materials[vpl.material as usize].bsdf;
                let c = vsl::contribution(&gx, sp.p, bsdf, wo, vpl, bsdf_p, self.radii[j], sampler);
                if c != Vec3::ZERO {
                    batch.push(shadow_segment(&x, self.lanes.end(j)), c);
                }
            }
        } else {
            let fx = PreparedBsdf::new(*bsdf, gx, wo, TransportMode::Radiance);
            if !fx.is_active() {
                return Vec3::ZERO;
            }
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
        }
        let (total, traced) = batch.finish();
        counters.shadow_rays += traced;
        total
    }
}

/// Φ f_p cos_p f_x cos_x / d² of one VPL at the receiver x (shading normal `n`), with G
/// clamped at `bound`; zero when either BSDF is. The scalar form of the gather; the four-wide
/// kernel of [`super::vpl_lanes`] computes exactly this, bit for bit.
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

impl Integrator for InstantRadiosity {
    fn name(&self) -> &'static str {
        match self.lights {
            VirtualLights::Points(Clamping::None) => "ir",
            VirtualLights::Points(Clamping::Constant { .. }) => "ir-clamp",
            VirtualLights::Points(Clamping::Progressive { .. }) => "pir-clamp",
            VirtualLights::Spheres { alpha: None, .. } => "vsl",
            VirtualLights::Spheres { alpha: Some(_), .. } => "pir-vsl",
        }
    }

    fn parameters(&self) -> Vec<(String, String)> {
        let mut p = vec![("vpls".to_string(), self.paths.to_string())];
        match self.lights {
            VirtualLights::Points(Clamping::None) => {}
            VirtualLights::Points(Clamping::Constant { b }) => p.push(("clamp".into(), b.to_string())),
            VirtualLights::Points(Clamping::Progressive { b1, alpha }) => {
                p.push(("clamp".into(), b1.to_string()));
                p.push(("alpha".into(), alpha.to_string()));
            }
            VirtualLights::Spheres { radius, alpha } => {
                let r = match radius {
                    Radius::Global(r) => r.to_string(),
                    Radius::Density => {
                        format!("density (k={KNN_K}, x{KNN_SCALE}, max {MAX_RADIUS} diagonal)")
                    }
                };
                p.push(("radius".into(), r));
                if let Some(a) = alpha {
                    p.push(("alpha".into(), a.to_string()));
                }
            }
        }
        p
    }

    fn begin_iteration(&mut self, ctx: &RenderContext, iteration: u64, counters: &mut Counters) {
        // A VPL of s segments serves a camera vertex of d ≥ 1 segments when d + 1 + s ≤ max_depth.
        let max_vpl_depth = ctx.max_depth.saturating_sub(2);
        let (vpls, rays) = trace_vpls(ctx, iteration, self.paths, max_vpl_depth);
        counters.light_rays += rays;
        counters.vpls += vpls.len() as u64;
        self.emitting = vpls
            .iter()
            .map(|v| {
                let bsdf = ctx.scene.materials[v.material as usize].bsdf;
                PreparedBsdf::new(bsdf, v.geometry(), v.w_in, TransportMode::Importance)
            })
            .collect();
        self.lanes = VplLanes::new(&vpls, &self.emitting);
        self.vpls = vpls;
        self.bound = match self.lights {
            VirtualLights::Points(c) => c.bound(iteration),
            VirtualLights::Spheres { .. } => f32::INFINITY,
        };
        self.max_radius = vsl::MAX_RADIUS * ctx.scene.bounds.diagonal();
        self.compute_radii(iteration);
    }

    fn radiance(
        &self,
        ctx: &RenderContext,
        ray: Ray,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        let mut radiance = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut how = Sampled::camera(ray.origin);
        let mut ray = ray;
        let mut depth = 0u32;
        counters.rays += 1;
        let Some(mut hit) = ctx.accel.intersect(&ray) else { return radiance };
        loop {
            depth += 1;
            let sp = ctx.scene.surface_of_hit(&ray, &hit);
            let wo = -ray.dir.normalize();
            let material = &ctx.scene.materials[sp.material as usize];
            radiance += beta * emission(ctx, material, &sp, wo, &how);
            if depth >= ctx.max_depth {
                break;
            }
            let bsdf = &material.bsdf;
            let g = LocalGeometry { ng: sp.ng, frame: sp.frame };
            if !bsdf.is_delta() {
                // ---- Direct light (light sampling half of the MIS pair) and VPLs.
                radiance += beta * sample_emitters(ctx, &sp, bsdf, wo, sampler, counters);
                radiance +=
                    beta * self.gather(ctx, &sp, bsdf, wo, ctx.max_depth - depth - 1, sampler, counters);
            }
            // ---- BSDF sampling: the MIS half of direct light, or a delta bounce.
            let u_lobe = sampler.next_f32();
            let u = sampler.next_2d();
            let Some(s) = bsdf.sample(&g, wo, u_lobe, u, TransportMode::Radiance) else { break };
            beta *= s.weight;
            if beta.max_element() <= 0.0 || !beta.is_finite() {
                break;
            }
            let from_delta = bsdf.is_delta();
            how = Sampled { from: sp.p, pdf: s.pdf, delta: s.delta };
            ray = Ray::new(offset_origin(sp.p, sp.ng, s.wi), s.wi);
            counters.rays += 1;
            let Some(next) = ctx.accel.intersect(&ray) else { break };
            hit = next;
            if !from_delta {
                // From a non-delta vertex only the class "next vertex is delta" continues; a
                // non-delta next vertex contributes its emission (direct light) and stops,
                // since the VPLs carry everything beyond it.
                let next_material = ctx.scene.material_of(hit.prim);
                if !next_material.bsdf.is_delta() {
                    if next_material.is_emitter() {
                        let np = ctx.scene.surface_of_hit(&ray, &hit);
                        radiance += beta * emission(ctx, next_material, &np, -ray.dir.normalize(), &how);
                    }
                    break;
                }
            }
        }
        radiance
    }
}
