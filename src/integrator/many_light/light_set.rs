//! The light set of one iteration: its virtual lights of one kind ([`Lights`]: points with
//! this iteration's bound on G, or spheres with their radii), prepared once for all the
//! receivers that gather from them, and which of them a receiver gathers from
//! ([`Selection`]: all, or k sampled from the light tree, or k resampled from a window of
//! candidates).

use glam::Vec3;

use super::config::Gather;
use super::light_paths::Vpl;
use super::light_tree::{LightTree, TreeLight};
use super::virtual_light::Lights;
use super::window::LightPaths;
use crate::integrator::RenderContext;
use crate::material::Bsdf;

/// This iteration's virtual lights, and how receivers gather from them.
pub struct LightSet<L> {
    pub lights: L,
    /// Which lights a receiver gathers from.
    pub selection: Selection,
}

/// Which of the iteration's lights a receiver gathers from ([`Gather`]).
pub enum Selection {
    /// Every light.
    All,
    /// `samples` lights drawn from the tree.
    Tree { tree: LightTree, samples: usize },
    /// `samples` lights picked from a window of about `candidates` of the lights of `paths`
    /// ([`super::resample`]).
    Resampled { candidates: usize, samples: usize, paths: LightPaths },
}

impl<L: Lights> LightSet<L> {
    /// The set of `lights`, left by the light paths `paths`, with the light tree when
    /// `gather` samples from one.
    pub fn new(ctx: &RenderContext, lights: L, gather: Gather, paths: LightPaths) -> Self {
        assert_eq!(paths.lights(), lights.count(), "the light paths' lights are the set's");
        let selection = match gather {
            Gather::All => Selection::All,
            Gather::Tree { samples } => {
                Selection::Tree { tree: LightTree::new(&lights.tree_lights(ctx)), samples: samples.max(1) }
            }
            Gather::Resampled { candidates, samples } => {
                Selection::Resampled { candidates: candidates.max(1), samples: samples.max(1), paths }
            }
        };
        LightSet { lights, selection }
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
