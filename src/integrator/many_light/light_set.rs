//! The light set of one iteration: the VPLs of its light paths as point lights (with this
//! iteration's bound on G) or as spheres (with their radii), prepared once for all the
//! receivers that gather from them.

use super::lanes::VplLanes;
use super::light_paths::Vpl;
use super::spheres::SphereLights;
use super::{Clamping, VirtualLights};
use crate::integrator::RenderContext;
use crate::material::{PreparedBsdf, TransportMode};

/// This iteration's virtual lights.
pub enum LightSet {
    Points(PointLights),
    Spheres(SphereLights),
}

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
    pub fn new(vpls: Vec<Vpl>, clamping: Clamping, iteration: u64, ctx: &RenderContext) -> Self {
        let emitting: Vec<PreparedBsdf> = vpls
            .iter()
            .map(|v| {
                let bsdf = ctx.scene.material(v.material).bsdf;
                PreparedBsdf::new(bsdf, v.geometry(), v.w_in, TransportMode::Importance)
            })
            .collect();
        let lanes = VplLanes::new(&vpls, &emitting);
        PointLights { vpls, emitting, lanes, bound: clamping.bound(iteration) }
    }
}

impl Default for LightSet {
    /// No lights (before the first iteration).
    fn default() -> Self {
        LightSet::Points(PointLights {
            vpls: Vec::new(),
            emitting: Vec::new(),
            lanes: VplLanes::default(),
            bound: f32::INFINITY,
        })
    }
}

impl LightSet {
    /// The set of `lights` made from iteration `iteration`'s VPLs.
    pub fn new(ctx: &RenderContext, lights: &VirtualLights, vpls: Vec<Vpl>, iteration: u64) -> Self {
        match *lights {
            VirtualLights::Points(clamping) => {
                LightSet::Points(PointLights::new(vpls, clamping, iteration, ctx))
            }
            VirtualLights::Spheres { radius, alpha } => LightSet::Spheres(SphereLights::new(
                vpls,
                radius,
                alpha,
                iteration,
                ctx.scene.bounds().diagonal(),
            )),
        }
    }

    /// The VPLs of the set.
    pub fn vpls(&self) -> &[Vpl] {
        match self {
            LightSet::Points(p) => &p.vpls,
            LightSet::Spheres(s) => &s.vpls,
        }
    }
}
