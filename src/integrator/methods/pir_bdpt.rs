//! `pir-bdpt`: bidirectional. A full path tracer's camera path connects to the VPLs at its
//! first non-delta vertex (`--connect first-two`, `all`, `glossy`: at more of them), the light paths
//! splat into the film through the lens (light tracing to the camera), and every
//! technique (the path tracer's two, each connection, light tracing) is weighed against the others by
//! the balance heuristic (the two emitter techniques among themselves by the power
//! heuristic, as `pt`), the weighted connection bounded progressively: consistent (pir's
//! own, [`crate::integrator::many_light::bidirectional`]). Its light paths and its light
//! samples at the first vertex are chosen by the scene (a pilot) unless given.

use super::params::GatherKind;
use super::{Defaults, MethodSpec, Parameter, Paths, Settings};
use crate::integrator::many_light::AutoPaths;
use crate::integrator::{Integrator, VirtualLights};

/// The gather of `pir-bdpt` when not given: resampled, k = 4 of m = 128 candidates, with at
/// least [`BDPT_PATHS`] light paths (`docs/measurements.md`, "Light paths and candidates of
/// `pir-bdpt`").
pub const BDPT_GATHER: (GatherKind, usize, usize) = (GatherKind::Resample, 4, 128);
/// The fewest light paths per iteration of `pir-bdpt` when `--vpls` is not given: more where
/// they leave fewer than [`BDPT_VPLS`] VPLs, up to [`BDPT_MAX_PATHS`]. An iteration's cost is
/// the pixels', so many VPLs cost little, and each receiver's window of candidates holds a
/// random share of them, which spreads their error over more pixels (`docs/measurements.md`,
/// "At least 256 light paths for `pir-bdpt`").
pub const BDPT_PATHS: usize = 256;
/// The fewest VPLs per iteration `pir-bdpt` aims at when it chooses its light paths: where
/// [`BDPT_PATHS`] leave fewer (light that comes through an opening), it traces as many more
/// paths as leave this many.
pub const BDPT_VPLS: usize = 64;
/// The most light paths per iteration `pir-bdpt` chooses by itself, for scenes where one
/// light path in 64 or fewer reaches what the camera sees (an iteration of 4,096 paths that
/// each leave no VPL costs 4,096 rays, a few hundredths of a 128 × 128 image's camera paths).
pub const BDPT_MAX_PATHS: usize = 4096;
/// `pir-bdpt`'s light paths chosen by the scene: at least [`BDPT_PATHS`], as many as leave
/// [`BDPT_VPLS`] VPLs, at most [`BDPT_MAX_PATHS`].
pub const BDPT_AUTO_PATHS: AutoPaths =
    AutoPaths { vpls: BDPT_VPLS, caustics: BDPT_CAUSTICS, at_least: BDPT_PATHS, at_most: BDPT_MAX_PATHS };
/// The caustic vertices per iteration `pir-bdpt` aims at where its light paths make caustics
/// (at least one path in 64, [`crate::integrator::many_light::path_count::CAUSTIC_RARE`]): as
/// many more paths as leave this many, so that light tracing to the camera and vertex
/// merging, which make the caustics, have as many samples as they pay for.
pub const BDPT_CAUSTICS: usize = 1024;

pub struct PirBdpt;

impl MethodSpec for PirBdpt {
    fn name(&self) -> &'static str {
        "pir-bdpt"
    }
    fn description(&self) -> &'static str {
        "bidirectional: a full camera path connecting to the VPLs at its first non-delta vertex \
         (--connect: more) and the light paths traced to the camera, every technique weighed \
         against the others, the weighted connection bounded progressively: consistent"
    }
    fn parameters(&self) -> &'static [Parameter] {
        use Parameter::*;
        &[Vpls, Gather, GatherCandidates, GatherSamples, Connect, LightSamples, Clamp, Alpha, MergeRadius]
    }
    fn defaults(&self) -> Defaults {
        Defaults { paths: Paths::ByScene(BDPT_AUTO_PATHS), gather: BDPT_GATHER, ..Defaults::COMMON }
    }
    fn picks_by_scene(&self) -> bool {
        true
    }
    fn integrator(&self, s: &Settings) -> Box<dyn Integrator> {
        // (A rule chosen by the scene replaces this one before the first iteration.)
        let connect = s.connect.unwrap_or_default();
        let lights = VirtualLights::Bidirectional(s.progressive_clamping(), connect);
        Box::new(s.many_light(lights).with_merging(s.merge_radius, s.alpha).with_auto_acceptance(self.picks_by_scene() && s.gather_samples_by_scene))
    }
}
