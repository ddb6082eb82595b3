//! `pir-vsl`: virtual spherical lights whose radius shrinks with the iteration,
//! r_i = r_1 · i^((α−1)/2) (thesis 4.2.2): the blur vanishes, consistent.

use super::{MethodSpec, Parameter, Settings};
use crate::integrator::{Integrator, VirtualLights};

pub struct PirVsl;

impl MethodSpec for PirVsl {
    fn name(&self) -> &'static str {
        "pir-vsl"
    }
    fn description(&self) -> &'static str {
        "virtual spherical lights of progressive radius r_i = r_1 · i^((α−1)/2): consistent"
    }
    fn parameters(&self) -> &'static [Parameter] {
        use Parameter::*;
        &[Vpls, Gather, GatherCandidates, GatherSamples, Radius, Alpha]
    }
    fn integrator(&self, s: &Settings) -> Box<dyn Integrator> {
        s.instant_radiosity(VirtualLights::Spheres { radius: s.radius, alpha: Some(s.alpha) })
    }
}
