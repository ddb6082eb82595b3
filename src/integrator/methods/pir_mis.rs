//! `pir-mis`: virtual point lights whose connections are weighed against a BSDF-sampled
//! bounce by multiple importance sampling, the weighted connection bounded progressively
//! (b_i = b_1 · i^α): no spikes at creases or in a receiver's glossy lobe, consistent (pir's
//! own, [`crate::integrator::many_light::mis`]). It gathers by resampling ([`MIS_GATHER`]).

use super::params::GatherKind;
use super::{Defaults, MethodSpec, Parameter, Settings};
use crate::integrator::{Integrator, VirtualLights};

/// The gather of `pir-mis` when `--gather`, `--gather-samples` and `--gather-candidates` are
/// not given: resampled, k = 4 of m = 64 candidates (`docs/measurements.md`, "The gather of
/// `pir-mis`"; `docs/results.md`, "Weighed connections").
pub const MIS_GATHER: (GatherKind, usize, usize) = (GatherKind::Resample, 4, 64);

pub struct PirMis;

impl MethodSpec for PirMis {
    fn name(&self) -> &'static str {
        "pir-mis"
    }
    fn description(&self) -> &'static str {
        "VPL connections weighed against a BSDF-sampled bounce, the weighted connection bounded \
         progressively: consistent, no spikes at creases or on glossy receivers"
    }
    fn parameters(&self) -> &'static [Parameter] {
        use Parameter::*;
        &[Vpls, Gather, GatherCandidates, GatherSamples, Clamp, Alpha]
    }
    fn defaults(&self) -> Defaults {
        Defaults { gather: MIS_GATHER, ..Defaults::COMMON }
    }
    fn integrator(&self, s: &Settings) -> Box<dyn Integrator> {
        s.instant_radiosity(VirtualLights::WeighedPoints(s.progressive_clamping()))
    }
}
