//! How many light paths an iteration traces when `--vpls` is not given (`pir-bdpt`): its
//! fewest paths ([`BDPT_PATHS`](crate::integrator::BDPT_PATHS), 256), or more where they
//! leave fewer VPLs than a target ([`BDPT_VPLS`](crate::integrator::BDPT_VPLS), 64), so that
//! an iteration always holds at least that many VPLs (`docs/integrator-measurements.md`,
//! "Light paths of pir-bdpt").
//!
//! **Why the count is the scene's.** Where light spreads freely from the emitters, every
//! light path leaves a VPL or more (the Cornell box: 156 from 64 paths). Where it enters
//! through an opening, most light paths end on the outside of the wall around it and leave
//! none: in the slit room 64 paths left 8 VPLs (one path in about thirty goes through the
//! slit), so an iteration's light that came through the opening was estimated from two or
//! three paths,
//! and that shared error dominated `pir-bdpt`'s. A path that leaves no VPL costs a ray or
//! two; what the VPLs cost is the gather, per receiver, which grows with their number up to
//! the window of candidates ([`super::resample`]). So the count is raised only as far as it
//! takes to leave the VPL target, what 64 paths leave where every path leaves one: in the
//! slit room about 520 paths against 64 (with the connections between Lambertian ends
//! counted N, [`super::subpath::Counts`]) lowered `pir-bdpt`'s relative MSE by 39 %
//! and its relative MSE × time by 28 % (seeds 1–3, fixed iterations); filling the whole window of
//! 128 candidates instead cost the Mori knob (30 VPLs from 64 paths) 19 % more time for 3 %
//! less error (`docs/measurements.md`, "Light paths by the scene's yield").
//!
//! **Caustics ask for more.** Where a delta vertex (a mirror, glass) leads light paths to the
//! surfaces they reach, those vertices are the caustics that light tracing to the camera and
//! vertex merging make ([`super::merging`]), and their noise falls as 1 / N while a light
//! path costs a few pixels' samples: so where at least one path in 64 makes such a vertex
//! ([`CAUSTIC_RARE`]), the count is also raised as far as it takes to leave
//! [`AutoPaths::caustics`] of them. Where light paths make no caustic, more of them only cost
//! time, so the rule asks for none there; where they do, it pays at equal time
//! (`docs/results.md`, "Light paths for caustics", has the measurements). A vertex that a
//! narrow glossy lobe led a path to counts as a caustic too
//! ([`super::light_paths::NARROW_LOBE_DENSITY`]): on the near-mirror floor (a coat of α 0.05)
//! one path in twelve makes one, and 4,096 paths instead of the 880 chosen without them took
//! `pir-bdpt` from 1.18–1.27× `pt`'s relative MSE at equal time to 0.90–0.95×
//! (`docs/results.md`, "Glossy caustics ask for light paths too"); of the other study and
//! Mitsuba scenes none makes one in 64 (the glossy corner 5 in 4,096 paths, the dense
//! scenes 4 and 12, the living room 9, veach-ajar 22), so their counts stay.
//!
//! **How.** Before the first iteration, a pilot traces [`PILOT_PATHS`] light paths from a
//! stream of their own (no iteration draws from it) and counts the VPLs they leave: y per
//! path. The count is ⌈t / y⌉ for a target of t VPLs, within [`AutoPaths::at_least`] and
//! [`AutoPaths::at_most`], or more for caustics (above). The same pilot measures the emitters' visibility from the points
//! they light, which weighs `pir-bdpt`'s connections ([`Pilot::visibility`]). Both are a
//! function of the scene, its path length, the seed, the sampler and (through the rays'
//! rounding) the accelerator alone: the pilot's paths are collected in order whatever the
//! threads, so a resumed or sharded render on the same machine finds the same, and they are
//! fixed for the whole render: every iteration is an unbiased estimate of the same image,
//! as with a count given by `--vpls`.

use super::light_paths::trace_pilot_vpls;
use crate::integrator::direct::{light_occluded, occluded};
use crate::integrator::{Counters, RenderContext};
use crate::light::Choice;
use crate::sampling::{Sampler, Streams};
use glam::Vec3;

/// Light paths of the pilot that measures the yield of VPLs per path (no more than the most
/// an iteration of `pir-bdpt` traces, which the memory estimate counts).
pub const PILOT_PATHS: usize = 4096;

/// Light samples the pilot takes from each VPL lit directly (in the slit room its
/// visibility came out 0.15–0.17 over seeds 1–3, against 0.15–0.20 with one sample).
const PILOT_LIGHT_SAMPLES: usize = 8;

/// The stream of the pilot's light paths: an iteration number no render reaches.
const PILOT_ITERATION: u64 = u64::MAX;
/// The stream of the pilot's light samples, another such number.
const PILOT_SAMPLES_ITERATION: u64 = u64::MAX - 1;

/// The light paths of an iteration chosen by the scene's yield of VPLs and of caustics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AutoPaths {
    /// The VPLs an iteration should hold at least.
    pub vpls: usize,
    /// Where light paths make caustics (a vertex that a delta vertex or a narrow lobe led
    /// them to) at least once in [`CAUSTIC_RARE`] paths: the caustic vertices an iteration
    /// should hold at least (0: none asked for).
    pub caustics: usize,
    /// Fewest light paths per iteration.
    pub at_least: usize,
    /// Most light paths per iteration.
    pub at_most: usize,
}

/// Caustic vertices per light path below which [`AutoPaths::caustics`] asks for no more paths:
/// one path in 64 (a small glass object in a room).
pub const CAUSTIC_RARE: f64 = 1.0 / 64.0;

impl AutoPaths {
    /// The count for a yield of `per_path` VPLs and `caustic_per_path` caustic vertices per
    /// light path: the larger of ⌈vpls / per_path⌉ and, where caustics are not rare,
    /// ⌈caustics / caustic_per_path⌉, within the bounds; the fewest when no path leaves a VPL
    /// (nothing to gather or splat, whatever the count).
    pub fn for_yield(&self, per_path: f64, caustic_per_path: f64) -> usize {
        let at_least = self.at_least.max(1);
        let at_most = self.at_most.max(at_least);
        if per_path.is_nan() || per_path <= 0.0 {
            return at_least;
        }
        let mut n = (self.vpls as f64 / per_path).ceil();
        if caustic_per_path >= CAUSTIC_RARE {
            n = n.max((self.caustics as f64 / caustic_per_path).ceil());
        }
        if n >= at_most as f64 { at_most } else { (n as usize).clamp(at_least, at_most) }
    }
}

/// Where a render keeps what its pilots measured, each run at most once: the light paths'
/// ([`Pilot`]), the camera's view ([`super::view_pilot::view`], for the render's camera and
/// resolution) and the VPLs' acceptance ([`super::importance::Acceptance::plan`]).
#[derive(Debug, Default)]
pub struct Pilots {
    pub light: std::sync::OnceLock<Pilot>,
    pub view: std::sync::OnceLock<std::sync::Arc<super::view_pilot::View>>,
    /// [`super::importance::Acceptance::plan`]'s choice.
    pub acceptance: std::sync::OnceLock<Option<(super::importance::Acceptance, f32)>>,
}

/// What the pilot measures of a scene before the first iteration: the VPLs its light paths
/// leave, and how often next-event estimation from where they first arrive finds its emitter
/// point in view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pilot {
    /// VPLs per light path.
    pub per_path: f64,
    /// Of the light samples taken from the VPLs lit directly (`PILOT_LIGHT_SAMPLES` each,
    /// towards a point drawn as
    /// next-event estimation draws it, on the emitter's front side and in front of the
    /// VPL's surface), the fraction that no surface blocks; 1 when there were none.
    /// [`super::subpath::Counts`] weighs the connections by it.
    pub visibility: f32,
    /// VPLs per light path that a delta vertex led the path to (a caustic: light tracing to
    /// the camera and vertex merging make it, [`super::merging`]) or a narrow lobe (a glossy
    /// caustic, [`super::light_paths::NARROW_LOBE_DENSITY`]).
    pub caustic_per_path: f64,
}

impl Pilot {
    /// Traces [`PILOT_PATHS`] light paths (as deep as a VPL serves a camera vertex, max_depth
    /// − 2 segments), and light samples from each VPL lit directly, all from streams no
    /// iteration draws from, in order: the same for any thread count. Once per render where
    /// the context keeps it; its queries are added to `counters.pilot_rays` when it runs (not
    /// when it comes from the cache).
    pub fn run(ctx: &RenderContext, counters: &mut Counters) -> Pilot {
        match ctx.pilot {
            Some(pilots) => *pilots.light.get_or_init(|| Pilot::trace(ctx, counters)),
            None => Pilot::trace(ctx, counters),
        }
    }

    /// [`Pilot::run`] without the render's cache.
    fn trace(ctx: &RenderContext, counters: &mut Counters) -> Pilot {
        let max_vpl_depth = ctx.max_depth.saturating_sub(2);
        let (vpls, rays, narrow) = trace_pilot_vpls(ctx, PILOT_ITERATION, PILOT_PATHS, max_vpl_depth);
        let streams = Streams::light_paths(ctx.sampler, ctx.seed, PILOT_SAMPLES_ITERATION);
        let mut samples = Counters::default();
        let (mut tried, mut visible) = (0u32, 0u32);
        for (j, vpl) in vpls.iter().enumerate().filter(|(_, v)| v.depth == 1) {
            let mut sampler = streams.sampler(j as u64);
            for _ in 0..PILOT_LIGHT_SAMPLES {
                if let Some(seen) = emitter_in_view(ctx, vpl.p, vpl.ng, &mut sampler, &mut samples) {
                    tried += 1;
                    visible += u32::from(seen);
                }
            }
        }
        counters.pilot_rays += rays + samples.shadow_rays;
        // (A VPL's arrival density is infinite where a delta vertex led the path to it.)
        let caustics = vpls.iter().filter(|v| v.arrival.is_infinite()).count();
        Pilot {
            per_path: vpls.len() as f64 / PILOT_PATHS as f64,
            visibility: if tried == 0 { 1.0 } else { visible as f32 / tried as f32 },
            caustic_per_path: (caustics + narrow) as f64 / PILOT_PATHS as f64,
        }
    }
}

/// One light sample from the point `p` of normal `ng`, drawn as next-event estimation draws
/// it (a sphere's point by area: this measures visibility, not variance): whether no surface
/// blocks it; `None` where the point drawn is behind the emitter's front side or the
/// surface at `p`. Two numbers and a light's own sample from `sampler`.
pub fn emitter_in_view(
    ctx: &RenderContext,
    p: Vec3,
    ng: Vec3,
    sampler: &mut Sampler,
    counters: &mut Counters,
) -> Option<bool> {
    let u_select = sampler.next_f32();
    let u = sampler.next_2d();
    let es = if !ctx.emitters.is_plain() {
        match ctx.emitters.choose(ctx.scene, u_select, u) {
            Choice::Area(es) => es,
            Choice::Light { index, u, .. } => {
                // A light that is not a triangle: its own sample from the point.
                let ls = ctx.emitters.lights()[index].sample(p, u)?;
                if ng.dot(ls.wi) <= 0.0 {
                    return None;
                }
                return Some(!light_occluded(ctx, p, ng, &ls, counters));
            }
        }
    } else {
        ctx.emitters.sample_from(ctx.scene, p, u_select, u)
    };
    let d = es.point.p - p;
    if es.point.ng.dot(d) >= 0.0 || ng.dot(d) <= 0.0 {
        return None;
    }
    Some(!occluded(ctx, p, ng, es.point.p, es.point.ng, counters))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_count_leaves_the_vpls_within_its_bounds() {
        let auto = AutoPaths { vpls: 64, caustics: 0, at_least: 64, at_most: 4096 };
        // 2.4 VPLs per path (a closed box) or one: the fewest paths leave enough.
        assert_eq!(auto.for_yield(2.4, 0.0), 64);
        assert_eq!(auto.for_yield(1.0, 0.0), 64);
        // One path in eight leaves a VPL: 512 paths.
        assert_eq!(auto.for_yield(0.125, 0.0), 512);
        assert_eq!(auto.for_yield(0.3, 0.0), 214);
        // Almost nothing reaches a receiver: the most; nothing at all (or no number): the fewest.
        assert_eq!(auto.for_yield(1e-6, 0.0), 4096);
        assert_eq!(auto.for_yield(1e-300, 0.0), 4096);
        assert_eq!(auto.for_yield(0.0, 0.0), 64);
        assert_eq!(auto.for_yield(f64::NAN, 0.0), 64);
        // Bounds that make no sense still give a positive count.
        assert_eq!(AutoPaths { vpls: 64, caustics: 0, at_least: 0, at_most: 0 }.for_yield(0.5, 0.0), 1);
    }

    /// Caustics ask for as many paths as leave their target, where they are not rare: a
    /// quarter of the paths make one (a glass sphere and a mirror under a small light), one in
    /// eleven (a Cornell box with a glass and a mirror sphere), one in a hundred (a glass
    /// object in a room: no more paths).
    #[test]
    fn caustics_ask_for_more_paths_where_they_are_common() {
        let auto = AutoPaths { vpls: 64, caustics: 1024, at_least: 256, at_most: 4096 };
        assert_eq!(auto.for_yield(2.2, 0.25), 4096);
        assert_eq!(auto.for_yield(2.2, 0.5), 2048);
        assert_eq!(auto.for_yield(2.2, 0.09), 4096);
        assert_eq!(auto.for_yield(2.2, 0.01), 256);
        assert_eq!(auto.for_yield(2.2, 0.0), 256);
        // The VPLs' target still rules where it asks for more.
        assert_eq!(auto.for_yield(0.01, 0.02), 4096);
        assert_eq!(AutoPaths { caustics: 0, ..auto }.for_yield(2.2, 0.25), 256);
    }
}
