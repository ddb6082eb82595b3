//! `ir-clamp`: virtual point lights with the geometry term clamped at a constant bound b
//! (`--clamp`; Keller, pbrt-v2's `igi`): the spikes go, and with them energy, for ever.

use super::{MethodSpec, Parameter, Settings};
use crate::integrator::{Clamping, Integrator, VirtualLights};

pub struct IrClamp;

impl MethodSpec for IrClamp {
    fn name(&self) -> &'static str {
        "ir-clamp"
    }
    fn description(&self) -> &'static str {
        "VPLs with the geometry term clamped at a constant --clamp b: biased for ever"
    }
    fn parameters(&self) -> &'static [Parameter] {
        use Parameter::*;
        &[Vpls, Gather, GatherCandidates, GatherSamples, Clamp]
    }
    fn integrator(&self, s: &Settings) -> Box<dyn Integrator> {
        s.instant_radiosity(VirtualLights::Points(Clamping::Constant { b: s.clamp }))
    }
}
