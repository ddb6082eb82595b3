//! A rendering method's configuration, the one source that `pir render`, `pir study`, the
//! resume identity of a checkpoint ([`crate::render::state`]) and the tests share: the methods
//! by name ([`Method`]), their parameters ([`MethodParams`], the `--vpls`, `--clamp`,
//! `--radius`, `--alpha`, `--gather` and `--gather-samples` flags with their defaults), the checks of those parameters
//! ([`MethodConfig::validate`]), and how a method with its parameters becomes an integrator
//! ([`MethodConfig::integrator`]).
//!
//! The types are clap arguments (flattened into every command that renders) and serde values
//! (a study's JSON, a checkpoint's identity).

use anyhow::{Result, bail};
use clap::Args;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

use super::many_light::AutoPaths;
use super::many_light::Connect;
use super::many_light::resample::MAX_CANDIDATES;
use super::schedule::DEFAULT_ALPHA;
use super::{
    Clamping, DEFAULT_PATHS, Gather, InstantRadiosity, Integrator, PathTracer, Radius, VirtualLights,
};

/// A rendering method (`--method`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Path tracer with next-event estimation and MIS: the ground truth.
    Pt,
    /// Instant radiosity, plain VPLs (Keller 1997): unbiased, spiky near creases.
    Ir,
    /// VPLs with the geometry term clamped at a constant b: biased for ever.
    IrClamp,
    /// Progressive clamping, b_i = b_1 · i^α: consistent.
    PirClamp,
    /// Virtual spherical lights of constant radius (Hašan et al. 2009): biased.
    Vsl,
    /// Progressive VSLs, r_i = r_1 · i^((α−1)/2): consistent.
    PirVsl,
    /// VPL connections weighed against a BSDF-sampled bounce by multiple importance
    /// sampling, the weighted connection bounded progressively (b_i = b_1 · i^α): no spikes at
    /// creases or in a receiver's glossy lobe; consistent (pir's own, not the thesis').
    PirMis,
    /// Bidirectional: a full camera path connects to the VPLs at every non-delta vertex, and
    /// every technique (the path tracer's two and each connection) is weighed against the
    /// others by the balance heuristic (the two emitter techniques among themselves by the
    /// power heuristic, as `pt`), the weighted connection bounded progressively: consistent
    /// (pir's own).
    PirBdpt,
}

impl Method {
    pub const ALL: [Method; 8] = [
        Method::Pt,
        Method::Ir,
        Method::IrClamp,
        Method::PirClamp,
        Method::Vsl,
        Method::PirVsl,
        Method::PirMis,
        Method::PirBdpt,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Method::Pt => "pt",
            Method::Ir => "ir",
            Method::IrClamp => "ir-clamp",
            Method::PirClamp => "pir-clamp",
            Method::Vsl => "vsl",
            Method::PirVsl => "pir-vsl",
            Method::PirMis => "pir-mis",
            Method::PirBdpt => "pir-bdpt",
        }
    }

    /// Whether the method traces VPLs.
    pub fn uses_vpls(self) -> bool {
        self != Method::Pt
    }
    /// Whether the method uses α (the progressive schedules).
    pub fn uses_alpha(self) -> bool {
        matches!(self, Method::PirClamp | Method::PirVsl | Method::PirMis | Method::PirBdpt)
    }
    pub fn uses_clamp(self) -> bool {
        matches!(self, Method::IrClamp | Method::PirClamp | Method::PirMis | Method::PirBdpt)
    }
    pub fn uses_radius(self) -> bool {
        matches!(self, Method::Vsl | Method::PirVsl)
    }
    /// Whether the method uses the parameter.
    pub fn uses(self, parameter: Parameter) -> bool {
        match parameter {
            Parameter::Alpha => self.uses_alpha(),
            Parameter::Clamp => self.uses_clamp(),
            Parameter::Radius => self.uses_radius(),
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Method, String> {
        Method::ALL.into_iter().find(|m| m.name() == s.trim()).ok_or_else(|| {
            let names: Vec<_> = Method::ALL.iter().map(|m| m.name()).collect();
            format!("unknown method {s:?}: expected one of {}", names.join(", "))
        })
    }
}

/// A method's parameters (each flag names the methods that use it); unset ones take their
/// documented defaults.
#[derive(Args, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodParams {
    /// VPL methods: light paths traced per iteration (each leaves a VPL at every non-delta
    /// vertex) [default: 32; for pir-bdpt 256, or as many more as leave 64 VPLs where light
    /// paths seldom reach a surface that reflects them, chosen by a pilot, at most 4096].
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
    /// unoccluded light of --gather-candidates VPLs, a random window of the light paths, is
    /// estimated without rays, and --gather-samples of them, picked in proportion to it, get
    /// shadow rays). The sampled gathers are unbiased for the same sum, so they afford many
    /// more VPLs per iteration [default: resample for pir-mis and pir-bdpt, all for the thesis' methods].
    #[arg(long, value_enum, value_name = "HOW")]
    #[serde(default)]
    pub gather: Option<GatherKind>,
    /// --gather tree or resample: VPLs drawn per camera vertex (k), 1 to 64 [default: 4 for
    /// pir-mis and pir-bdpt, 8 otherwise].
    #[arg(long, value_name = "K")]
    #[serde(default)]
    pub gather_samples: Option<usize>,
    /// --gather resample: candidate VPLs per camera vertex (m), a random window of the
    /// iteration's light paths whose unoccluded contributions choose the k that get shadow
    /// rays (every VPL when the iteration has at most 2m); 1 to 1024 [default: 64 for
    /// pir-mis, 128 otherwise].
    #[arg(long, value_name = "M")]
    #[serde(default)]
    pub gather_candidates: Option<usize>,
    /// pir-bdpt: which vertices of the camera path connect to the VPLs: first, first-two or
    /// all (every non-delta vertex); the path tracer's techniques run at every vertex either
    /// way [default: first].
    #[arg(long, value_enum, value_name = "WHICH")]
    #[serde(default)]
    pub connect: Option<Connect>,
    /// pir-bdpt: light samples (next-event estimation) at the camera path's first vertex, 1 to
    /// 64, weighed as that many samples of the technique; deeper vertices take one; powers of
    /// two are stratified best [default: 2, or 4 to 16 where a pilot finds the emitters
    /// mostly hidden from the points they light].
    #[arg(long, value_name = "N")]
    #[serde(default)]
    pub light_samples: Option<u32>,
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

/// VPLs drawn per camera vertex with `--gather tree` when `--gather-samples` is not given.
pub const DEFAULT_GATHER_SAMPLES: usize = 8;
/// Most VPLs drawn per camera vertex (`--gather-samples`).
pub const MAX_GATHER_SAMPLES: usize = 64;

/// The gather of `pir-mis` when `--gather`, `--gather-samples` and `--gather-candidates` are
/// not given: resampled, 4 of 64 candidates. Measured on the Cornell box, the glossy Cornell
/// box, the glossy floor and the glossy corner (`docs/results.md`, "Weighed connections"):
/// the resampled gather is 1.6–3× as efficient as the exhaustive one for `pir-mis` on every
/// one of them, and k = 4 of m = 64 is within the noise of the best (k, m) on each. `pir-bdpt`
/// took it too until 2026-12-04 ([`BDPT_GATHER`]): on the Cornell box (single runs, loaded machine), relative MSE × CPU time with k = 2, 4, 8 was 1.16, 1,
/// 1.17 (m = 64), with m = 32, 64, 128 1.41, 1, 0.98 (k = 4), with 16, 32, 64 light paths
/// 1.02, 1, 0.89: none clearly better (`docs/measurements.md`, "Bidirectional weights").
pub const MIS_GATHER: (GatherKind, usize, usize) = (GatherKind::Resample, 4, 64);

/// The gather of `pir-bdpt` when not given: resampled, 4 of 128 candidates, with
/// [`BDPT_PATHS`] light paths per iteration. Measured with 64 paths (the default then),
/// against [`MIS_GATHER`] with 32 paths
/// (2026-12-04, `docs/measurements.md`, "Light paths and candidates of `pir-bdpt`"):
/// relative MSE × time level on six scenes (0.97–1.06, three seeds), and HDR-FLIP at equal
/// time 9 % lower on the Cornell box (four seeds, 20 s), 4–12 % lower in the slit room and on
/// the glossy Cornell box (two seeds, 10 s): twice the VPLs per iteration, each seen by the
/// receivers whose window holds it, leave less of the error in blotches shared by many
/// pixels.
pub const BDPT_GATHER: (GatherKind, usize, usize) = (GatherKind::Resample, 4, 128);
/// The fewest light paths per iteration of `pir-bdpt` when `--vpls` is not given (see
/// [`BDPT_GATHER`]): more where they leave fewer than [`BDPT_VPLS`] VPLs, up to
/// [`BDPT_MAX_PATHS`] ([`MethodConfig::auto_paths`]). 256 rather than 64 (2026-12-04,
/// `docs/measurements.md`, "At least 256 light paths"): at equal time, HDR-FLIP 8.5 % lower
/// on the Cornell box (six seeds, 20 s) and 4–10 % lower on the glossy Cornell box, the
/// near-mirror floor, the dense scene lit indirectly and the bunny's Cornell box (two seeds
/// each), level on the Mori knob; relative MSE level on the dense scene and the bunny's box,
/// 2 % higher on the Cornell box and 5–9 % higher on the glossy scenes and the knob. An
/// iteration's cost is the pixels', so four times the VPLs cost 1–3 % of its time; each
/// receiver's window of candidates then holds a random quarter of them, so the VPLs'
/// error is spread over more of them and less of it is in blotches shared by many pixels,
/// which HDR-FLIP sees and relative MSE does not.
pub const BDPT_PATHS: usize = 256;
/// The fewest VPLs per iteration `pir-bdpt` aims at when it chooses its light paths: where
/// [`BDPT_PATHS`] leave fewer (light that comes through an opening), it traces as many more
/// paths as leave this many (the slit room: about 525).
pub const BDPT_VPLS: usize = 64;
/// The most light paths per iteration `pir-bdpt` chooses by itself, for scenes where one
/// light path in 64 or fewer reaches what the camera sees (an iteration of 4,096 paths that
/// each leave no VPL costs 4,096 rays, a few hundredths of a 128 × 128 image's camera
/// paths).
pub const BDPT_MAX_PATHS: usize = 4096;
/// `pir-bdpt`'s light paths chosen by the scene: at least [`BDPT_PATHS`], as many as leave
/// [`BDPT_VPLS`] VPLs, at most [`BDPT_MAX_PATHS`].
pub const BDPT_AUTO_PATHS: AutoPaths =
    AutoPaths { vpls: BDPT_VPLS, at_least: BDPT_PATHS, at_most: BDPT_MAX_PATHS };

/// Candidates per camera vertex with `--gather resample` when `--gather-candidates` is not
/// given: of 64, 128 and 256 candidates with 4 or 8 picks and 32 to 256 light paths, 128
/// candidates with 4 picks and 256 paths had the lowest variance × time per iteration on
/// the Cornell box (`docs/results.md`, "The resampled gather").
pub const DEFAULT_GATHER_CANDIDATES: usize = 128;

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
        }
    }
}

/// Most light paths per iteration (`--vpls`).
pub const MAX_VPLS: usize = 1 << 24;

/// `pir-bdpt`'s light samples at the first vertex when `--light-samples` is not given. Its
/// iteration's cost is mostly the gather and the path, so a light sample costs it a smaller
/// share than it costs `pt`, while the direct light of the first vertex is the error that
/// connections cannot reach (a connection needs two non-delta vertices before the
/// emitter): measured 2026-12-03 (`docs/measurements.md`, "Light samples at the first
/// vertex"), 4 samples against 1 gave relative MSE × instructions 0.95× on the Cornell box,
/// about 0.6× in the slit room and on the Mori knob, 1.06× on the glossy Cornell box. Once
/// the samples were stratified (the emitter's triangle from the point's own number, the
/// samples one block of points; 2026-12-04, "Stratified light samples"), 2 samples beat 4 in
/// relative MSE × time by 7 % on the Cornell box and the glossy Cornell box, 11–13 % on the
/// near-mirror floor and the glossy corner, and were level (+1–3 %) in the slit room and on
/// the Mori knob. That is where the emitters are in view; where a pilot finds them mostly
/// hidden from the points they light, `pir-bdpt` takes more
/// ([`light_samples_for`](crate::integrator::many_light::bidirectional::light_samples_for):
/// 4 in the slit room).
pub const DEFAULT_LIGHT_SAMPLES: u32 = 2;
/// Most light samples at the first vertex (`--light-samples`).
pub const MAX_LIGHT_SAMPLES: u32 = 64;

impl MethodParams {
    /// Checks every parameter; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        if let Some(n) = self.vpls
            && !(1..=MAX_VPLS).contains(&n)
        {
            bail!("--vpls {n}: must be 1 to {MAX_VPLS}");
        }
        if let Some(n) = self.light_samples
            && !(1..=MAX_LIGHT_SAMPLES).contains(&n)
        {
            bail!("--light-samples {n}: must be 1 to {MAX_LIGHT_SAMPLES}");
        }
        for (parameter, value) in [(Parameter::Clamp, self.clamp), (Parameter::Radius, self.radius)] {
            if let Some(v) = value
                && !parameter.accepts(v)
            {
                bail!("--{} {v}: must be a positive number", parameter.key());
            }
        }
        if !Parameter::Alpha.accepts(self.alpha) {
            bail!("--alpha {}: must lie strictly between 0 and 1", self.alpha);
        }
        if let Some(k) = self.gather_samples
            && (k == 0 || k > MAX_GATHER_SAMPLES)
        {
            bail!("--gather-samples {k}: must be 1 to {MAX_GATHER_SAMPLES}");
        }
        if let Some(m) = self.gather_candidates
            && (m == 0 || m > MAX_CANDIDATES)
        {
            bail!("--gather-candidates {m}: must be 1 to {MAX_CANDIDATES}");
        }
        Ok(())
    }

    /// Sets a parameter (a study's sweep).
    pub fn set(&mut self, parameter: Parameter, value: f32) {
        match parameter {
            Parameter::Alpha => self.alpha = value,
            Parameter::Clamp => self.clamp = Some(value),
            Parameter::Radius => self.radius = Some(value),
        }
    }
}

/// A parameter given by a number that a study can sweep (`--sweep KEY=V1,V2,…`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Parameter {
    Alpha,
    Clamp,
    Radius,
}

impl Parameter {
    /// The flag's name without dashes, as in `--sweep alpha=…`.
    pub fn key(self) -> &'static str {
        match self {
            Parameter::Alpha => "alpha",
            Parameter::Clamp => "clamp",
            Parameter::Radius => "radius",
        }
    }

    /// The symbol in labels ("pir-clamp α=0.3").
    pub fn symbol(self) -> &'static str {
        match self {
            Parameter::Alpha => "α",
            Parameter::Clamp => "b",
            Parameter::Radius => "r",
        }
    }

    /// The parameter of a key (`alpha` or `α`, `clamp`, `radius`).
    pub fn from_key(key: &str) -> Option<Parameter> {
        match key {
            "alpha" | "α" => Some(Parameter::Alpha),
            "clamp" => Some(Parameter::Clamp),
            "radius" => Some(Parameter::Radius),
            _ => None,
        }
    }

    /// Whether `value` is in the parameter's range ([`Parameter::range`]).
    pub fn accepts(self, value: f32) -> bool {
        match self {
            Parameter::Alpha => value > 0.0 && value < 1.0,
            Parameter::Clamp | Parameter::Radius => value.is_finite() && value > 0.0,
        }
    }

    /// The range in words.
    pub fn range(self) -> &'static str {
        match self {
            Parameter::Alpha => "0 < α < 1",
            Parameter::Clamp | Parameter::Radius => "must be positive",
        }
    }
}

/// A method with its parameters (`--method` and the flags of [`MethodParams`]).
#[derive(Args, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodConfig {
    /// Rendering method: pt (path tracer, the ground truth), ir (plain VPLs: unbiased, spiky),
    /// ir-clamp (geometry term clamped at a constant --clamp: biased), pir-clamp (progressive
    /// clamp b_i = b_1 · i^α: consistent), vsl (virtual spherical lights of constant --radius:
    /// biased), pir-vsl (progressive radius r_i = r_1 · i^((α−1)/2): consistent), pir-mis
    /// (VPL connections weighed against a BSDF-sampled bounce, the weighted connection bounded
    /// progressively: consistent, no spikes at creases or on glossy receivers), pir-bdpt (a full
    /// camera path connecting to the VPLs at every vertex, every technique weighed against the
    /// others, the weighted connection bounded progressively: consistent).
    #[arg(long, default_value_t = Method::Pt, value_name = "METHOD")]
    pub method: Method,
    #[command(flatten)]
    #[serde(flatten)]
    pub params: MethodParams,
}

impl MethodConfig {
    /// The method with the default parameters.
    pub fn new(method: Method) -> MethodConfig {
        MethodConfig { method, params: MethodParams::default() }
    }

    /// Checks every parameter; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        self.params.validate()
    }

    /// How the method gathers, k and m: the flags, else the method's defaults ([`MIS_GATHER`]
    /// for `pir-mis`, [`BDPT_GATHER`] for `pir-bdpt`; every VPL, k = 8, m = 128 for the
    /// thesis' methods).
    pub fn gather_parameters(&self) -> (GatherKind, usize, usize) {
        let p = &self.params;
        let (kind, k, m) = match self.method {
            Method::PirMis => MIS_GATHER,
            Method::PirBdpt => BDPT_GATHER,
            _ => (GatherKind::All, DEFAULT_GATHER_SAMPLES, DEFAULT_GATHER_CANDIDATES),
        };
        (p.gather.unwrap_or(kind), p.gather_samples.unwrap_or(k), p.gather_candidates.unwrap_or(m))
    }

    /// The gather of the VPL methods.
    pub fn gather(&self) -> Gather {
        match self.gather_parameters() {
            (GatherKind::All, _, _) => Gather::All,
            (GatherKind::Tree, k, _) => Gather::Tree { samples: k },
            (GatherKind::Resample, k, m) => Gather::Resampled { candidates: m, samples: k },
        }
    }

    /// Light paths traced per iteration, at most: `--vpls` for the VPL methods (or the most
    /// [`MethodConfig::auto_paths`] may choose), 0 for the path tracer.
    pub fn light_paths(&self) -> usize {
        match self.auto_paths() {
            Some(auto) => auto.at_most,
            None if self.method.uses_vpls() => self.paths(),
            None => 0,
        }
    }

    /// Light paths chosen by the scene when `--vpls` is not given: `pir-bdpt` traces
    /// [`BDPT_PATHS`] per iteration, or more where they leave fewer than [`BDPT_VPLS`] VPLs
    /// (up to [`BDPT_MAX_PATHS`], [`AutoPaths`]). `None` for a fixed count.
    pub fn auto_paths(&self) -> Option<AutoPaths> {
        (self.method == Method::PirBdpt && self.params.vpls.is_none()).then_some(BDPT_AUTO_PATHS)
    }

    /// `--vpls`, or the method's default ([`BDPT_PATHS`] for `pir-bdpt`, [`DEFAULT_PATHS`]
    /// for the others).
    fn paths(&self) -> usize {
        let default = if self.method == Method::PirBdpt { BDPT_PATHS } else { DEFAULT_PATHS };
        self.params.vpls.unwrap_or(default)
    }

    /// The configuration as it decides the image, for a scene whose bounding box has this
    /// diagonal: the clamp bound's default made explicit and the parameters the method does not
    /// use set to their defaults. Two configurations whose identities are equal render the same
    /// image (the resume identity of [`crate::render::state`]). The converse holds but for
    /// what the scene chooses: `pir-bdpt`'s light paths and light samples stay unset when not
    /// given, so a given value that equals the scene's choice still makes another identity.
    pub fn identity(&self, scene_diagonal: f32) -> MethodConfig {
        let m = self.method;
        let p = &self.params;
        let default = MethodParams::default();
        let (kind, k, cands) = self.gather_parameters();
        MethodConfig {
            method: m,
            params: MethodParams {
                // A count chosen by the scene is the scene's: the same for the same scene and seed.
                vpls: (m.uses_vpls() && self.auto_paths().is_none()).then(|| self.paths()),
                clamp: m
                    .uses_clamp()
                    .then(|| p.clamp.unwrap_or_else(|| Clamping::default_bound(scene_diagonal))),
                radius: if m.uses_radius() { p.radius } else { None },
                alpha: if m.uses_alpha() { p.alpha } else { default.alpha },
                gather: m.uses_vpls().then_some(kind),
                gather_samples: (m.uses_vpls() && kind != GatherKind::All).then_some(k),
                gather_candidates: (m.uses_vpls() && kind == GatherKind::Resample).then_some(cands),
                connect: (m == Method::PirBdpt).then(|| p.connect.unwrap_or_default()),
                // Chosen by the scene when not given, like the light paths.
                light_samples: if m == Method::PirBdpt { p.light_samples } else { None },
            },
        }
    }

    /// The integrator for a scene whose bounding box has this diagonal.
    pub fn integrator(&self, scene_diagonal: f32) -> Box<dyn Integrator> {
        let p = &self.params;
        let bound = p.clamp.unwrap_or_else(|| Clamping::default_bound(scene_diagonal));
        let paths = self.paths();
        let lights = match self.method {
            Method::Pt => return Box::new(PathTracer),
            Method::Ir => VirtualLights::Points(Clamping::None),
            Method::IrClamp => VirtualLights::Points(Clamping::Constant { b: bound }),
            Method::PirClamp => VirtualLights::Points(Clamping::Progressive { b1: bound, alpha: p.alpha }),
            Method::PirMis => {
                VirtualLights::WeighedPoints(Clamping::Progressive { b1: bound, alpha: p.alpha })
            }
            Method::PirBdpt => {
                let clamping = Clamping::Progressive { b1: bound, alpha: p.alpha };
                VirtualLights::Bidirectional(clamping, p.connect.unwrap_or_default())
            }
            Method::Vsl | Method::PirVsl => {
                let radius = p.radius.map_or(Radius::Density, Radius::Global);
                let alpha = (self.method == Method::PirVsl).then_some(p.alpha);
                VirtualLights::Spheres { radius, alpha }
            }
        };
        let ir = InstantRadiosity::new(lights, paths).with_gather(self.gather());
        let ir = match p.light_samples {
            Some(n) => ir.with_light_samples(n),
            None => ir.with_auto_light_samples(DEFAULT_LIGHT_SAMPLES),
        };
        Box::new(match self.auto_paths() {
            Some(auto) => ir.with_auto_paths(auto),
            None => ir,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_integrators_carry_them() {
        for m in Method::ALL {
            assert_eq!(m.name().parse::<Method>(), Ok(m));
            let c =
                MethodConfig { method: m, params: MethodParams { vpls: Some(4), ..MethodParams::default() } };
            assert_eq!(c.integrator(3.0).name(), m.name());
        }
        assert!("photon".parse::<Method>().unwrap_err().contains("pir-vsl"));
    }

    #[test]
    fn validate_names_the_flag() {
        let ok = MethodParams::default();
        assert!(ok.validate().is_ok());
        for (bad, flag) in [
            (MethodParams { vpls: Some(0), ..ok }, "--vpls 0"),
            (MethodParams { clamp: Some(-2.0), ..ok }, "--clamp -2"),
            (MethodParams { radius: Some(f32::NAN), ..ok }, "--radius NaN"),
            (MethodParams { alpha: 1.0, ..ok }, "--alpha 1"),
            (MethodParams { gather_samples: Some(0), ..ok }, "--gather-samples 0"),
            (MethodParams { gather_samples: Some(65), ..ok }, "--gather-samples 65"),
            (MethodParams { light_samples: Some(0), ..ok }, "--light-samples 0"),
            (MethodParams { light_samples: Some(65), ..ok }, "--light-samples 65"),
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.starts_with(flag), "{e}");
        }
    }

    #[test]
    fn identity_keeps_what_decides_the_image() {
        let mut a = MethodConfig::new(Method::Pt);
        let mut b = a;
        b.params.alpha = 0.3;
        b.params.vpls = Some(9);
        assert_eq!(a.identity(2.0), b.identity(2.0));
        a.method = Method::PirClamp;
        let c = a.identity(2.0);
        assert_eq!(c.params.clamp, Some(Clamping::default_bound(2.0)));
        assert_eq!(c.integrator(2.0).parameters(), a.integrator(2.0).parameters());
        b.method = Method::PirClamp;
        assert_ne!(a.identity(2.0), b.identity(2.0));
    }

    /// Light paths and gather by method when the flags are not given: `pir-bdpt` its own
    /// ([`BDPT_PATHS`] or more, chosen by the scene, [`BDPT_GATHER`]), the others the common
    /// ones; the identity holds the resolved count, so giving the default explicitly is the
    /// same job, except for `pir-bdpt`, whose count chosen by the scene is not a given one;
    /// and a job stored with a plain count (as before `--vpls` became optional) reads back
    /// as that count.
    #[test]
    fn light_paths_and_gathers_default_by_method() {
        for m in Method::ALL {
            let c = MethodConfig::new(m);
            let (paths, gather) = match m {
                Method::Pt => (0, None),
                Method::PirBdpt => (BDPT_MAX_PATHS, Some(BDPT_GATHER)),
                Method::PirMis => (DEFAULT_PATHS, Some(MIS_GATHER)),
                _ => (DEFAULT_PATHS, None),
            };
            assert_eq!(c.light_paths(), paths, "{m:?}");
            assert_eq!(c.auto_paths().is_some(), m == Method::PirBdpt, "{m:?}");
            if let Some(g) = gather {
                assert_eq!(c.gather_parameters(), g, "{m:?}");
            }
            let mut explicit = c;
            explicit.params.vpls = Some(if m == Method::PirBdpt { BDPT_PATHS } else { DEFAULT_PATHS });
            assert_eq!(m != Method::PirBdpt, c.identity(2.0) == explicit.identity(2.0), "{m:?}");
            assert_eq!(explicit.auto_paths(), None, "{m:?}");
            let mut other = c;
            other.params.vpls = Some(5);
            assert_eq!(m == Method::Pt, c.identity(2.0) == other.identity(2.0), "{m:?}");
        }
        let mut stored = serde_json::to_value(MethodParams::default()).unwrap();
        stored["vpls"] = serde_json::json!(32);
        let back: MethodParams = serde_json::from_value(stored).unwrap();
        assert_eq!(back.vpls, Some(32));
    }

    #[test]
    fn configs_round_trip_through_json_exactly() {
        // Every f32 survives serde_json: the identity of a checkpoint compares them exactly.
        let mut x: u32 = 0x9E37_79B9;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let v = f32::from_bits(x);
            if !v.is_finite() {
                continue;
            }
            let c = MethodConfig {
                method: Method::PirVsl,
                params: MethodParams {
                    clamp: Some(v),
                    radius: Some(v.abs()),
                    alpha: v,
                    vpls: Some(7),
                    gather: Some(GatherKind::Resample),
                    gather_samples: Some(5),
                    gather_candidates: Some(77),
                    connect: Some(Connect::All),
                    light_samples: Some(3),
                },
            };
            let back: MethodConfig = serde_json::from_str(&serde_json::to_string(&c).unwrap()).unwrap();
            assert_eq!(back, c, "{v:e}");
        }
    }
}
