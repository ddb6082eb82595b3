//! `ir`: instant radiosity with plain virtual point lights (Keller 1997), the geometry term
//! unbounded: unbiased, but spiky near creases and on glossy surfaces.

use super::{MethodSpec, Parameter, Settings};
use crate::integrator::{Clamping, Integrator, VirtualLights};

pub struct Ir;

impl MethodSpec for Ir {
    fn name(&self) -> &'static str {
        "ir"
    }
    fn description(&self) -> &'static str {
        "instant radiosity, plain VPLs (Keller 1997): unbiased, spiky near creases"
    }
    fn parameters(&self) -> &'static [Parameter] {
        use Parameter::*;
        &[Vpls, Gather, GatherCandidates, GatherSamples]
    }
    fn integrator(&self, s: &Settings) -> Box<dyn Integrator> {
        s.instant_radiosity(VirtualLights::Points(Clamping::None))
    }
}
