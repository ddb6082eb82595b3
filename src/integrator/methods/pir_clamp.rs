//! `pir-clamp`: virtual point lights with the geometry term clamped at a bound that grows
//! with the iteration, b_i = b_1 · i^α (thesis 4.2.1): the bias vanishes, consistent.

use super::{MethodSpec, Parameter, Settings};
use crate::integrator::{Integrator, VirtualLights};

pub struct PirClamp;

impl MethodSpec for PirClamp {
    fn name(&self) -> &'static str {
        "pir-clamp"
    }
    fn description(&self) -> &'static str {
        "VPLs with progressive clamping, b_i = b_1 · i^α: consistent"
    }
    fn parameters(&self) -> &'static [Parameter] {
        use Parameter::*;
        &[Vpls, Gather, GatherCandidates, GatherSamples, Clamp, Alpha]
    }
    fn integrator(&self, s: &Settings) -> Box<dyn Integrator> {
        s.instant_radiosity(VirtualLights::Points(s.progressive_clamping()))
    }
}
