//! `vsl`: virtual spherical lights (Hašan et al. 2009) of a constant radius (`--radius`, else
//! per light by the VPLs' density): no spikes, a blur that stays.

use super::{MethodSpec, Parameter, Settings};
use crate::integrator::{Integrator, VirtualLights};

pub struct Vsl;

impl MethodSpec for Vsl {
    fn name(&self) -> &'static str {
        "vsl"
    }
    fn description(&self) -> &'static str {
        "virtual spherical lights of constant --radius (Hašan et al. 2009): biased"
    }
    fn parameters(&self) -> &'static [Parameter] {
        use Parameter::*;
        &[Vpls, Gather, GatherCandidates, GatherSamples, Radius]
    }
    fn integrator(&self, s: &Settings) -> Box<dyn Integrator> {
        s.instant_radiosity(VirtualLights::Spheres { radius: s.radius, alpha: None })
    }
}
