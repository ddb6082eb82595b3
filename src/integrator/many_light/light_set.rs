//! The light set of one iteration: the VPLs of its light paths as point lights (with this
//! iteration's bound on G) or as spheres (with their radii), prepared once for all the
//! receivers that gather from them, and, for the sampled gather ([`Gather::Tree`]), the light
//! tree over them.

use glam::Vec3;

use super::config::{Clamping, Gather, VirtualLights};
use super::lanes::VplLanes;
use super::light_paths::Vpl;
use super::light_tree::{LightTree, TreeLight};
use super::spheres::SphereLights;
use super::subpath::Counts;
use crate::integrator::RenderContext;
use crate::material::{Bsdf, PreparedBsdf, TransportMode};

/// This iteration's virtual lights, and how receivers gather from them.
pub struct LightSet {
    pub lights: Lights,
    /// Which lights a receiver gathers from.
    pub selection: Selection,
    /// Connections weighed against a BSDF-sampled bounce (`pir-mis`), or plain.
    pub mis: Option<Mis>,
}

/// What the weighed connections of [`super::mis`] need from the iteration.
#[derive(Clone, Copy, Debug)]
pub struct Mis {
    /// Light paths traced this iteration (`pir-mis`: every connection counts them all), or
    /// the bidirectional weights' counts ([`Counts`]).
    pub counts: Counts,
    /// The bound on the weighted connection ([`super::mis::Weighing::apply`]).
    pub bound: f32,
}

/// Which of the iteration's lights a receiver gathers from ([`Gather`]).
pub enum Selection {
    /// Every light.
    All,
    /// `samples` lights drawn from the tree.
    Tree { tree: LightTree, samples: usize },
    /// `samples` lights picked from a window of `candidates` ([`super::resample`]).
    Resampled { candidates: usize, samples: usize },
}

/// This iteration's virtual lights.
pub enum Lights {
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
        let power: Vec<f32> = vpls
            .iter()
            .zip(&emitting)
            .map(|(v, e)| tree_light(v, &ctx.scene.material(v.material).bsdf, e.is_active(), 0.0).intensity)
            .collect();
        let lanes = VplLanes::new(&vpls, &emitting, &power);
        PointLights { vpls, emitting, lanes, bound: clamping.bound(iteration) }
    }
}

impl Default for LightSet {
    /// No lights (before the first iteration).
    fn default() -> Self {
        LightSet {
            lights: Lights::Points(PointLights {
                vpls: Vec::new(),
                emitting: Vec::new(),
                lanes: VplLanes::default(),
                bound: f32::INFINITY,
            }),
            selection: Selection::All,
            mis: None,
        }
    }
}

impl LightSet {
    /// The set of `lights` made from iteration `iteration`'s VPLs, with the light tree when
    /// `gather` samples from one; `counts` are the weights' counts of its light paths (the
    /// ones the VPLs' sums were traced with, for `pir-bdpt`; `pir-mis` counts every path,
    /// [`Counts::paths`]).
    pub fn new(
        ctx: &RenderContext,
        lights: &VirtualLights,
        vpls: Vec<Vpl>,
        counts: Counts,
        iteration: u64,
        gather: Gather,
    ) -> Self {
        let mis = match *lights {
            VirtualLights::WeighedPoints(clamping) => {
                Some(Mis { counts: Counts::uniform(counts.paths), bound: clamping.bound(iteration) })
            }
            VirtualLights::Bidirectional(clamping, _) => {
                Some(Mis { counts, bound: clamping.bound(iteration) })
            }
            _ => None,
        };
        let lights = match *lights {
            VirtualLights::Points(clamping) => {
                Lights::Points(PointLights::new(vpls, clamping, iteration, ctx))
            }
            // The bound applies to the weighted connection ([`super::mis`]), not to G.
            VirtualLights::WeighedPoints(_) | VirtualLights::Bidirectional(..) => {
                Lights::Points(PointLights::new(vpls, Clamping::None, iteration, ctx))
            }
            VirtualLights::Spheres { radius, alpha } => Lights::Spheres(SphereLights::new(
                vpls,
                |v| ctx.scene.material(v.material).bsdf,
                radius,
                alpha,
                iteration,
                ctx.scene.bounds().diagonal(),
            )),
        };
        let selection = match gather {
            Gather::All => Selection::All,
            Gather::Tree { samples } => {
                Selection::Tree { tree: LightTree::new(&lights.tree_lights(ctx)), samples: samples.max(1) }
            }
            Gather::Resampled { candidates, samples } => {
                Selection::Resampled { candidates: candidates.max(1), samples: samples.max(1) }
            }
        };
        LightSet { lights, selection, mis }
    }
}

impl Lights {
    /// The lights as the tree sees them ([`tree_light`]).
    pub fn tree_lights(&self, ctx: &RenderContext) -> Vec<TreeLight> {
        use rayon::prelude::*;
        let (vpls, radii) = match self {
            Lights::Points(p) => (&p.vpls, None),
            Lights::Spheres(s) => (&s.vpls, Some(&s.radii)),
        };
        vpls.par_iter()
            .enumerate()
            .map(|(j, v)| {
                let bsdf = ctx.scene.material(v.material).bsdf;
                let active = match self {
                    Lights::Points(p) => p.emitting[j].is_active(),
                    Lights::Spheres(s) => s.emitting[j].is_active(),
                };
                tree_light(v, &bsdf, active, radii.map_or(0.0, |r| r[j]))
            })
            .collect()
    }
}

/// The largest adjoint correction factor [`tree_light`] counts (a weight only: larger ones are
/// as likely to be drawn as this).
const CORRECTION_CAP: f32 = 1e6;

/// VPL `v` as the tree sees it: position, geometric normal, depth, `radius` (0 for points),
/// and the intensity Σ over RGB of Φ × the reflectance of its BSDF (diffuse albedo, plus the
/// specular colour of a glossy one) × its adjoint shading-normal correction's constant
/// factor |ω_in · n_s| / |ω_in · n_g| (which turns the shading cosine towards a receiver into
/// the geometric one, as the importance and the estimates take it, at most `CORRECTION_CAP`: 1 on flat-shaded
/// surfaces, unbounded where light grazes a face whose shading normal it does not graze), or 0
/// when its BSDF is inactive for its incoming direction (`active`). Either way the intensity
/// is 0 only when every channel of Φ ∘ f_p is 0 in every direction: the light contributes
/// nothing anywhere.
pub fn tree_light(v: &Vpl, bsdf: &Bsdf, active: bool, radius: f32) -> TreeLight {
    // Where |ω_in · n_g| is 0 the correction, and so the light, is 0 everywhere; the cap keeps
    // the estimates finite without making a contributing light's zero.
    let (in_ns, in_ng) = (v.w_in.dot(v.frame.n).abs(), v.w_in.dot(v.ng).abs());
    let correction = if in_ng > 0.0 { (in_ns / in_ng).min(CORRECTION_CAP) } else { 0.0 };
    let intensity =
        if active { (v.flux * bsdf.reflectance()).max(Vec3::ZERO).element_sum() * correction } else { 0.0 };
    // Non-finite (never in practice): the largest intensity, still sampled.
    TreeLight { p: v.p, ng: v.ng, intensity: intensity.min(f32::MAX), depth: v.depth, radius }
}
