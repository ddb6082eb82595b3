//! The parameter table every method draws from: the flags (`--vpls`, `--gather`,
//! `--gather-candidates`, `--gather-samples`, `--connect`, `--light-samples`, `--clamp`,
//! `--radius`, `--alpha`, `--merge-radius`) as one clap and serde struct ([`MethodParams`]), and each parameter
//! by name ([`Parameter`]) with its key, its check and how its resolved value reads in the
//! metadata. A method says which of them it uses ([`super::MethodSpec::parameters`]); the
//! flags it does not use are accepted (a study passes one set of flags to several methods)
//! and change nothing.

use anyhow::{Result, bail};
use clap::Args;
use serde::{Deserialize, Serialize};

use super::Settings;
use crate::integrator::many_light::resample::MAX_CANDIDATES;
use crate::integrator::many_light::spheres;
use crate::integrator::schedule::DEFAULT_ALPHA;
use crate::integrator::{Gather, MAX_LIGHT_SAMPLES, Radius};

/// A method's parameters (each flag names the methods that use it); unset ones take the
/// method's defaults ([`super::Defaults`]).
#[derive(Args, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodParams {
    /// VPL methods: light paths traced per iteration (each leaves a VPL at every non-delta
    /// vertex) [default: 32; for pir-bdpt 256, or as many more as leave 64 VPLs where light
    /// paths seldom reach a surface that reflects them, or 1024 caustic vertices where a
    /// mirror, glass or a near-mirror lobe leads them to surfaces, or up to 8 times as many where most VPLs light
    /// what the camera does not see (then kept by their share of the image), chosen by a
    /// pilot, at most 4096].
    #[arg(long, value_name = "N")]
    pub vpls: Option<usize>,
    /// ir-clamp, pir-clamp: the geometry-term bound b (or b_1), in 1/length²; pir-mis, pir-bdpt: b_1 of
    /// the bound on the weighted connection, in the same units [default: 100 / scene
    /// diagonal², the G of facing surfaces a tenth of the scene apart].
    #[arg(long, value_name = "B", allow_negative_numbers = true)]
    pub clamp: Option<f32>,
    /// vsl, pir-vsl: the radius r (or r_1) of every virtual spherical light, in scene units
    /// [default: per light, the distance to its 4th nearest VPL, at most 4 % of the scene
    /// diagonal].
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// pir-clamp, pir-mis, pir-bdpt, pir-vsl: exponent α of the schedules b_i = b_1 · i^α and
    /// r_i = r_1 · i^((α−1)/2), in (0, 1).
    #[arg(long, value_name = "A", default_value_t = DEFAULT_ALPHA, allow_negative_numbers = true)]
    pub alpha: f32,
    /// VPL methods: how a camera vertex gathers from the iteration's VPLs: all (every VPL, one
    /// shadow ray each), tree (--gather-samples VPLs drawn from a light tree in proportion
    /// to a bound on their contribution, weighted by 1/probability) or resample (the
    /// unoccluded light of about --gather-candidates VPLs, a random window of the light paths, is
    /// estimated without rays, and --gather-samples of them, picked in proportion to it, get
    /// shadow rays). The sampled gathers are unbiased for the same sum, so they afford many
    /// more VPLs per iteration [default: resample for pir-mis and pir-bdpt, all for the thesis' methods].
    #[arg(long, value_enum, value_name = "HOW")]
    #[serde(default)]
    pub gather: Option<GatherKind>,
    /// --gather tree or resample: VPLs drawn per camera vertex (k), 1 to 64 [default: 4 for
    /// pir-mis and pir-bdpt (pir-bdpt: 16 where it keeps fewer than one VPL in eight by its
    /// share of the image), 8 otherwise]. pir-bdpt with --connect glossy draws one (among at
    /// most 32 candidates) at a vertex after a glossy one over a diffuse base (a rough
    /// plastic), where the vertex before it already gathers most of that light.
    #[arg(long, value_name = "K")]
    #[serde(default)]
    pub gather_samples: Option<usize>,
    /// --gather resample: candidate VPLs per camera vertex (m), at most, on average: a window
    /// of the iteration's light paths (an aligned run of a power of two of them, drawn at
    /// random), whose unoccluded contributions choose the k that get shadow rays (every VPL
    /// when the iteration has at most two such runs); 1 to 1024 [default: 64 for
    /// pir-mis, 128 otherwise; pir-bdpt: at most 32 where it draws one VPL, see
    /// --gather-samples].
    #[arg(long, value_name = "M")]
    #[serde(default)]
    pub gather_candidates: Option<usize>,
    /// pir-bdpt: which vertices of the camera path connect to the VPLs: first (the first
    /// non-delta vertex), first-two, all (every non-delta vertex) or glossy (the first, and
    /// each one after a glossy vertex, GGX alpha at most 0.15, whose narrow lobe few VPLs
    /// reach; one VPL of at most 32 candidates after a glossy vertex over a diffuse base, see
    /// --gather-samples);
    /// the path tracer's techniques run at every vertex either way [default: glossy
    /// where fewer than half of the points the camera sees are lit directly, else first].
    #[arg(long, value_enum, value_name = "WHICH")]
    #[serde(default)]
    pub connect: Option<crate::integrator::many_light::Connect>,
    /// pir-bdpt: light samples (next-event estimation) at the camera path's first vertex, 1 to
    /// 64, weighed as that many samples of the technique; deeper vertices take one; powers of
    /// two are stratified best [default: 2, or 4 to 16 where a pilot finds the emitters
    /// mostly hidden from the points they light].
    #[arg(long, value_name = "N")]
    #[serde(default)]
    pub light_samples: Option<u32>,
    /// pir-bdpt: the radius r_1 of vertex merging, in pixels (its footprint where the camera
    /// sees the surface through a mirror or glass), which merges the light paths' caustics with
    /// the camera paths that see them through delta surfaces; shrinks as r_i = r_1 ·
    /// i^((α−1)/2); 0: no merging [default: 2].
    /// (Left out of the JSON when not set, so that the identities of the methods without it
    /// read as before; `pir-bdpt`'s always hold it.)
    #[arg(long, value_name = "PIXELS", allow_negative_numbers = true)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub merge_radius: Option<f32>,
}

impl Default for MethodParams {
    fn default() -> Self {
        MethodParams {
            vpls: None,
            clamp: None,
            radius: None,
            alpha: DEFAULT_ALPHA,
            gather: None,
            gather_samples: None,
            gather_candidates: None,
            connect: None,
            light_samples: None,
            merge_radius: None,
        }
    }
}

impl MethodParams {
    /// Checks every parameter, used or not ([`Parameter::validate`]); the error names the flag.
    pub fn validate(&self) -> Result<()> {
        Parameter::ALL.iter().try_for_each(|p| p.validate(self))
    }

    /// Sets a number parameter (a study's sweep); the others ([`Parameter::sweepable`]) are
    /// left as they are.
    pub fn set(&mut self, parameter: Parameter, value: f32) {
        match parameter {
            Parameter::Alpha => self.alpha = value,
            Parameter::Clamp => self.clamp = Some(value),
            Parameter::Radius => self.radius = Some(value),
            Parameter::MergeRadius => self.merge_radius = Some(value),
            _ => {}
        }
    }

    /// The parameters given (the flags set; `--alpha` when it differs from its default), in
    /// the table's order.
    pub fn given(&self) -> Vec<Parameter> {
        Parameter::ALL.into_iter().filter(|p| p.is_given(self)).collect()
    }
}

/// How a camera vertex gathers (`--gather`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GatherKind {
    /// Every VPL of the iteration.
    #[default]
    All,
    /// `--gather-samples` VPLs drawn from a light tree.
    Tree,
    /// `--gather-samples` VPLs picked among `--gather-candidates` by their unoccluded light.
    Resample,
}

/// Light paths per iteration, at most (`--vpls`).
pub const MAX_VPLS: usize = 1 << 24;
/// VPLs drawn per camera vertex with `--gather tree` or `resample` when `--gather-samples` is
/// not given (the thesis' methods).
pub const DEFAULT_GATHER_SAMPLES: usize = 8;
/// Most VPLs drawn per camera vertex (`--gather-samples`).
pub const MAX_GATHER_SAMPLES: usize = 64;
/// Candidates per camera vertex with `--gather resample` when `--gather-candidates` is not
/// given (the thesis' methods): the lowest variance × time per iteration on the Cornell box
/// among 64, 128 and 256 (`docs/measurements.md`, "The resampled gather").
pub const DEFAULT_GATHER_CANDIDATES: usize = 128;
/// Light samples at the camera path's first vertex when `--light-samples` is not given, where
/// the emitters are in view; where a pilot finds them mostly hidden from the points they
/// light, more
/// ([`light_samples_for`](crate::integrator::many_light::bidirectional::light_samples_for)).
/// `docs/measurements.md`, "Light samples at the first vertex" and "Stratified light
/// samples".
pub const DEFAULT_LIGHT_SAMPLES: u32 = 2;
/// The largest `--merge-radius`, in pixels.
pub const MAX_MERGE_PIXELS: f32 = 64.0;
const _: () = assert!(MAX_MERGE_PIXELS == 64.0, "Parameter::range's words for --merge-radius");

/// One parameter of the table: its flag, its check, and its value in the metadata.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Parameter {
    Vpls,
    Gather,
    GatherCandidates,
    GatherSamples,
    Connect,
    LightSamples,
    Clamp,
    Radius,
    Alpha,
    MergeRadius,
}

impl Parameter {
    /// Every parameter, in the order of the metadata (`pir.param.*`).
    pub const ALL: [Parameter; 10] = [
        Parameter::Vpls,
        Parameter::Gather,
        Parameter::GatherCandidates,
        Parameter::GatherSamples,
        Parameter::Connect,
        Parameter::LightSamples,
        Parameter::Clamp,
        Parameter::Radius,
        Parameter::Alpha,
        Parameter::MergeRadius,
    ];

    /// The flag's name without dashes: `--sweep KEY=…` and the metadata's `pir.param.KEY`.
    pub fn key(self) -> &'static str {
        match self {
            Parameter::Vpls => "vpls",
            Parameter::Gather => "gather",
            Parameter::GatherCandidates => "gather-candidates",
            Parameter::GatherSamples => "gather-samples",
            Parameter::Connect => "connect",
            Parameter::LightSamples => "light-samples",
            Parameter::Clamp => "clamp",
            Parameter::Radius => "radius",
            Parameter::Alpha => "alpha",
            Parameter::MergeRadius => "merge-radius",
        }
    }

    /// The flag, `--KEY`.
    pub fn flag(self) -> String {
        format!("--{}", self.key())
    }

    /// What the parameter is, in a few words.
    pub fn doc(self) -> &'static str {
        match self {
            Parameter::Vpls => "light paths per iteration",
            Parameter::Gather => "how a camera vertex gathers from the VPLs",
            Parameter::GatherCandidates => "candidate VPLs per camera vertex of the resampled gather",
            Parameter::GatherSamples => "VPLs drawn per camera vertex of a sampled gather",
            Parameter::Connect => "which camera vertices connect to the VPLs",
            Parameter::LightSamples => "light samples at the camera path's first vertex",
            Parameter::Clamp => "the bound b (or b_1), in 1/length²",
            Parameter::Radius => "the radius r (or r_1) of the virtual spherical lights",
            Parameter::Alpha => "the exponent α of the progressive schedules",
            Parameter::MergeRadius => "the radius r_1 of vertex merging, in pixels (0: none)",
        }
    }

    /// The symbol in a sweep's labels ("pir-clamp α=0.3").
    pub fn symbol(self) -> &'static str {
        match self {
            Parameter::Alpha => "α",
            Parameter::Clamp => "b",
            Parameter::Radius => "r",
            _ => self.key(),
        }
    }

    /// The parameter of a key (`alpha` or `α`, `clamp`, `gather-samples`, …).
    pub fn from_key(key: &str) -> Option<Parameter> {
        if key == "α" {
            return Some(Parameter::Alpha);
        }
        Parameter::ALL.into_iter().find(|p| p.key() == key)
    }

    /// Whether a study can sweep it (a number: `--sweep alpha=…`, `clamp=…`, `radius=…`,
    /// `merge-radius=…`).
    pub fn sweepable(self) -> bool {
        matches!(self, Parameter::Alpha | Parameter::Clamp | Parameter::Radius | Parameter::MergeRadius)
    }

    /// Whether the number `value` is in a sweepable parameter's range ([`Parameter::range`]).
    pub fn accepts(self, value: f32) -> bool {
        match self {
            Parameter::Alpha => value > 0.0 && value < 1.0,
            Parameter::Clamp | Parameter::Radius => value.is_finite() && value > 0.0,
            Parameter::MergeRadius => value.is_finite() && (0.0..=MAX_MERGE_PIXELS).contains(&value),
            _ => false,
        }
    }

    /// A sweepable parameter's range in words.
    pub fn range(self) -> &'static str {
        match self {
            Parameter::Alpha => "0 < α < 1",
            // (The words hold MAX_MERGE_PIXELS: checked at compile time below.)
            Parameter::MergeRadius => "0 (none) to 64 pixels",
            _ => "must be positive",
        }
    }

    /// Checks the parameter's value in `p`; the error names the flag and the value.
    pub fn validate(self, p: &MethodParams) -> Result<()> {
        let count = |value: Option<usize>, most: usize| match value {
            Some(n) if !(1..=most).contains(&n) => bail!("{} {n}: must be 1 to {most}", self.flag()),
            _ => Ok(()),
        };
        match self {
            Parameter::Vpls => count(p.vpls, MAX_VPLS),
            Parameter::GatherCandidates => count(p.gather_candidates, MAX_CANDIDATES),
            Parameter::GatherSamples => count(p.gather_samples, MAX_GATHER_SAMPLES),
            Parameter::LightSamples => count(p.light_samples.map(|n| n as usize), MAX_LIGHT_SAMPLES as usize),
            Parameter::Gather | Parameter::Connect => Ok(()),
            Parameter::Clamp | Parameter::Radius => {
                match if self == Parameter::Clamp { p.clamp } else { p.radius } {
                    Some(v) if !self.accepts(v) => bail!("{} {v}: must be a positive number", self.flag()),
                    _ => Ok(()),
                }
            }
            Parameter::Alpha if !self.accepts(p.alpha) => {
                bail!("--alpha {}: must lie strictly between 0 and 1", p.alpha)
            }
            Parameter::Alpha => Ok(()),
            Parameter::MergeRadius => match p.merge_radius {
                Some(v) if !self.accepts(v) => {
                    bail!("--merge-radius {v}: must be 0 (no merging) to {MAX_MERGE_PIXELS} pixels")
                }
                _ => Ok(()),
            },
        }
    }

    /// Whether `p` gives the parameter (`--alpha`: when it differs from its default, which is
    /// what an unset `--alpha` holds).
    pub fn is_given(self, p: &MethodParams) -> bool {
        match self {
            Parameter::Vpls => p.vpls.is_some(),
            Parameter::Gather => p.gather.is_some(),
            Parameter::GatherCandidates => p.gather_candidates.is_some(),
            Parameter::GatherSamples => p.gather_samples.is_some(),
            Parameter::Connect => p.connect.is_some(),
            Parameter::LightSamples => p.light_samples.is_some(),
            Parameter::Clamp => p.clamp.is_some(),
            Parameter::Radius => p.radius.is_some(),
            Parameter::Alpha => p.alpha != DEFAULT_ALPHA,
            Parameter::MergeRadius => p.merge_radius.is_some(),
        }
    }

    /// The resolved value as the metadata records it (`pir.param.KEY`), or `None` where the
    /// settings leave the parameter out (the gather's samples and candidates of a gather
    /// that draws none).
    pub fn report(self, s: &Settings) -> Option<String> {
        Some(match self {
            Parameter::Vpls => s.paths.to_string(),
            Parameter::Gather => match s.gather {
                Gather::All => return None,
                Gather::Tree { .. } => "tree".into(),
                Gather::Resampled { .. } => "resample".into(),
            },
            Parameter::GatherCandidates => match s.gather {
                Gather::Resampled { candidates, .. } => candidates.to_string(),
                _ => return None,
            },
            Parameter::GatherSamples => match s.gather {
                Gather::All => return None,
                Gather::Tree { samples } | Gather::Resampled { samples, .. } => samples.to_string(),
            },
            // The name `--connect` takes (clap's, from the enum).
            Parameter::Connect => match s.connect {
                Some(c) => c.name(),
                None => "by the scene".into(),
            },
            Parameter::LightSamples => s.light_samples.first().to_string(),
            Parameter::Clamp => s.clamp.to_string(),
            Parameter::Radius => match s.radius {
                Radius::Global(r) => r.to_string(),
                Radius::Density => spheres::density_radius_name(),
            },
            Parameter::Alpha => s.alpha.to_string(),
            Parameter::MergeRadius => s.merge_radius.to_string(),
        })
    }
}
