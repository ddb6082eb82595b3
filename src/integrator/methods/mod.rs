//! The rendering methods, one type per method in a registry that `pir render`, `pir study`,
//! the resume identity of a checkpoint ([`crate::render::state`]) and the tests iterate over.
//!
//! A method ([`MethodSpec`]) owns its name, its one-line description (`--help`, the EXR
//! metadata), the parameters it uses from the shared table ([`params`]: flags, checks,
//! metadata), its defaults ([`Defaults`]) and how its resolved parameters ([`Settings`])
//! become an integrator. [`Method`] is the handle that `--method`, a study's JSON and a
//! checkpoint's identity hold: the method's name, looked up in the registry.
//!
//! Adding a method is one file (a unit type implementing [`MethodSpec`], building its
//! integrator with the public builders of [`crate::integrator`]) and one line in the
//! `methods!` list below; a program that embeds pir adds its own with [`register`]
//! (`tests/methods.rs` does, for `ir-clamp-10`).
//!
//! [`MethodConfig`] is a method with its parameters: a clap argument group (flattened into
//! every command that renders) and a serde value (a study's JSON, a checkpoint's identity).

pub mod params;

use anyhow::{Result, bail};
use clap::Args;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;
use std::sync::RwLock;

use super::many_light::AutoPaths;
use super::many_light::Connect;
use super::many_light::merging::DEFAULT_MERGE_PIXELS;
use super::{Clamping, DEFAULT_PATHS, Gather, InstantRadiosity, Integrator, Radius, VirtualLights};
use params::{
    DEFAULT_GATHER_CANDIDATES, DEFAULT_GATHER_SAMPLES, DEFAULT_LIGHT_SAMPLES, GatherKind, MethodParams,
    Parameter,
};

/// Declares the in-tree methods: each `file::Type` is the module `file.rs` of this folder and
/// its unit type, registered in [`METHODS`] in this order (of `--help` and of a study).
macro_rules! methods {
    ($($file:ident :: $ty:ident),* $(,)?) => {
        $(pub mod $file; pub use $file::$ty;)*
        /// pir's methods, in the order of `--help` and of a study (then the ones added by
        /// [`register`]).
        pub static METHODS: &[&dyn MethodSpec] = &[$(&$ty),*];
    };
}

methods! {
    pt::Pt,
    ir::Ir,
    ir_clamp::IrClamp,
    pir_clamp::PirClamp,
    vsl::Vsl,
    pir_vsl::PirVsl,
    pir_mis::PirMis,
    pir_bdpt::PirBdpt,
}

/// A rendering method: its name, description, parameters, defaults and integrator.
pub trait MethodSpec: Send + Sync + 'static {
    /// The `--method` name, as in the EXR metadata, a study's JSON and a checkpoint's identity:
    /// lowercase letters, digits and dashes.
    fn name(&self) -> &'static str;

    /// One line for `--help` and the EXR metadata (`pir.method.description`).
    fn description(&self) -> &'static str;

    /// The parameters it uses (any order); the flags of the others change nothing.
    fn parameters(&self) -> &'static [Parameter];

    /// Its defaults of the parameters that have per-method ones.
    fn defaults(&self) -> Defaults {
        Defaults::COMMON
    }

    /// Its integrator with the parameters resolved for the scene.
    fn integrator(&self, settings: &Settings) -> Box<dyn Integrator>;

    /// Whether its integrator may choose the resampled gather's picks by the scene when
    /// `--gather-samples` is not given and the light paths are the scene's (`pir-bdpt`,
    /// [`InstantRadiosity::with_auto_acceptance`]): the identity then leaves them unset.
    fn picks_by_scene(&self) -> bool {
        false
    }
}

/// Light paths per iteration when `--vpls` is not given.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Paths {
    Fixed(usize),
    /// Chosen by the scene's yield of VPLs when the integrator is prepared ([`AutoPaths`]);
    /// `at_least` until then and in the metadata of an unprepared integrator.
    ByScene(AutoPaths),
}

impl Paths {
    /// The count before the scene chooses.
    pub fn fewest(self) -> usize {
        match self {
            Paths::Fixed(n) => n,
            Paths::ByScene(a) => a.at_least,
        }
    }
}

/// A method's defaults of the parameters whose defaults differ by method (`--clamp`: 100 /
/// diagonal², [`Clamping::default_bound`]; `--radius`: by density; `--alpha`:
/// [`DEFAULT_ALPHA`](crate::integrator::schedule::DEFAULT_ALPHA) for every method).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Defaults {
    /// `--vpls`.
    pub paths: Paths,
    /// `--gather`, `--gather-samples` (k), `--gather-candidates` (m).
    pub gather: (GatherKind, usize, usize),
    /// `--connect`; none: chosen by the scene ([`crate::integrator::many_light::view_pilot`]).
    pub connect: Option<Connect>,
    /// `--light-samples`: the count where the emitters are in view, more where a pilot finds
    /// them hidden.
    pub light_samples: u32,
}

impl Defaults {
    /// The thesis' methods': [`DEFAULT_PATHS`] light paths, every VPL gathered (k = 8, m = 128
    /// for the sampled gathers), the connecting vertices chosen by the scene,
    /// [`DEFAULT_LIGHT_SAMPLES`].
    pub const COMMON: Defaults = Defaults {
        paths: Paths::Fixed(DEFAULT_PATHS),
        gather: (GatherKind::All, DEFAULT_GATHER_SAMPLES, DEFAULT_GATHER_CANDIDATES),
        connect: None,
        light_samples: DEFAULT_LIGHT_SAMPLES,
    };
}

/// Light samples at the camera path's first vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightSamples {
    Given(u32),
    /// Chosen by the pilot's visibility of the emitters, `base` where they are in view.
    ByScene {
        base: u32,
    },
}

impl LightSamples {
    /// The count given, or the base of the scene's choice.
    pub fn first(self) -> u32 {
        match self {
            LightSamples::Given(n) | LightSamples::ByScene { base: n } => n,
        }
    }
}

/// A method's parameters resolved for a scene (the flags, else the method's defaults): what
/// its integrator is built from. Every field is resolved whether the method uses it or not.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Light paths per iteration (until the scene chooses, with `auto_paths`).
    pub paths: usize,
    pub auto_paths: Option<AutoPaths>,
    pub gather: Gather,
    /// Whether the gather's picks per receiver were left to the method (no
    /// `--gather-samples`): `pir-bdpt` may then raise them by the scene
    /// ([`InstantRadiosity::with_auto_acceptance`]).
    pub gather_samples_by_scene: bool,
    /// The connecting camera vertices; none: chosen by the scene.
    pub connect: Option<Connect>,
    pub light_samples: LightSamples,
    /// The bound b, or b_1 of a progressive schedule.
    pub clamp: f32,
    pub radius: Radius,
    pub alpha: f32,
    /// Vertex merging's r_1 in pixels (`pir-bdpt`; 0: none).
    pub merge_radius: f32,
}

impl Settings {
    /// Progressive clamping, b_i = b_1 · i^α, of `clamp` and `alpha`.
    pub fn progressive_clamping(&self) -> Clamping {
        Clamping::Progressive { b1: self.clamp, alpha: self.alpha }
    }

    /// The many-light integrator of `lights` with these light paths, gather and light samples.
    pub fn instant_radiosity(&self, lights: VirtualLights) -> Box<dyn Integrator> {
        Box::new(self.many_light(lights))
    }

    /// [`Settings::instant_radiosity`] unboxed, for a method that sets more of it (vertex
    /// merging, [`InstantRadiosity::with_merging`]).
    pub fn many_light(&self, lights: VirtualLights) -> InstantRadiosity {
        let ir = InstantRadiosity::new(lights, self.paths).with_gather(self.gather);
        let ir = match self.light_samples {
            LightSamples::Given(n) => ir.with_light_samples(n),
            LightSamples::ByScene { base } => ir.with_auto_light_samples(base),
        };
        let ir = if self.connect.is_none() { ir.with_auto_connect() } else { ir };
        match self.auto_paths {
            Some(auto) => ir.with_auto_paths(auto),
            None => ir,
        }
    }
}

/// Methods added with [`register`], after [`METHODS`].
static REGISTERED: RwLock<Vec<&'static dyn MethodSpec>> = RwLock::new(Vec::new());

/// Adds a method to the registry, after pir's own: `--method`, a study and the resume of its
/// checkpoints then know it by its name. Refuses a name that is taken or not made of
/// lowercase letters, digits and dashes.
pub fn register(spec: &'static dyn MethodSpec) -> Result<Method> {
    let name = spec.name();
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-') {
        bail!("method name {name:?}: must be lowercase letters, digits and dashes");
    }
    let mut registered = REGISTERED.write().unwrap_or_else(|e| e.into_inner());
    if METHODS.iter().chain(registered.iter()).any(|m| m.name() == name) {
        bail!("method name {name:?}: already registered");
    }
    registered.push(spec);
    Ok(Method(spec))
}

/// The parameters of every registered method, one line each, for `--help`.
pub fn parameters_help() -> String {
    let methods = Method::all();
    let width = methods.iter().map(|m| m.name().len()).max().unwrap_or(0) + 1;
    let mut text = String::from(
        "Parameters by method (a flag that a method does not use changes nothing; `pir render` warns):",
    );
    for m in methods {
        let flags: Vec<String> =
            Parameter::ALL.into_iter().filter(|&p| m.uses(p)).map(Parameter::flag).collect();
        let flags = if flags.is_empty() { "none".to_string() } else { flags.join(" ") };
        text.push_str(&format!("\n  {:<width$} {flags}", format!("{}:", m.name())));
    }
    text
}

/// A rendering method (`--method`): a handle into the registry, read and written as the
/// method's name.
#[derive(Clone, Copy)]
pub struct Method(&'static dyn MethodSpec);

impl Method {
    /// The method of a spec (registered or not).
    pub const fn new(spec: &'static dyn MethodSpec) -> Method {
        Method(spec)
    }

    /// Every registered method: pir's ([`METHODS`]), then the ones added by [`register`].
    pub fn all() -> Vec<Method> {
        let registered = REGISTERED.read().unwrap_or_else(|e| e.into_inner());
        METHODS.iter().chain(registered.iter()).map(|&m| Method(m)).collect()
    }

    /// The registered method of this name.
    pub fn named(name: &str) -> Option<Method> {
        Method::all().into_iter().find(|m| m.name() == name)
    }

    pub fn spec(self) -> &'static dyn MethodSpec {
        self.0
    }

    pub fn name(self) -> &'static str {
        self.0.name()
    }

    pub fn description(self) -> &'static str {
        self.0.description()
    }

    /// Whether the method uses the parameter.
    pub fn uses(self, parameter: Parameter) -> bool {
        self.0.parameters().contains(&parameter)
    }

    /// Whether the method traces VPLs (uses `--vpls`).
    pub fn uses_vpls(self) -> bool {
        self.uses(Parameter::Vpls)
    }

    /// `--method`'s parser: the registered names, each with its description in `--help`.
    pub fn value_parser() -> impl TypedValueParser<Value = Method> {
        let values = Method::all().into_iter().map(|m| PossibleValue::new(m.name()).help(m.description()));
        PossibleValuesParser::new(values).try_map(|name| name.parse::<Method>())
    }

    /// The registered names, comma-separated.
    pub fn names() -> String {
        Method::all().iter().map(|m| m.name()).collect::<Vec<_>>().join(", ")
    }
}

impl PartialEq for Method {
    fn eq(&self, other: &Method) -> bool {
        self.name() == other.name()
    }
}

impl Eq for Method {}

impl fmt::Debug for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Method({})", self.name())
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
        Method::named(s.trim())
            .ok_or_else(|| format!("unknown method {s:?}: expected one of {}", Method::names()))
    }
}

impl Serialize for Method {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for Method {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Method, D::Error> {
        let name = String::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

/// A method with its parameters (`--method` and the flags of [`MethodParams`]).
#[derive(Args, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodConfig {
    /// Rendering method: by default `pir-bdpt`, which wins the studies of real interiors
    /// (`docs/results.md`); `pt` is the ground truth.
    #[arg(long, default_value = "pir-bdpt", value_name = "METHOD", value_parser = Method::value_parser())]
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

    /// Whether the method renders `scene` as it should: the light tree's bounds (`--gather
    /// tree`) assume that both ends of a connection face each other, which those of a BSDF
    /// that transmits through a rough surface (Mitsuba's `roughdielectric`) do not, so the
    /// tree refuses such a scene rather than render it wrong. Every method renders it with
    /// the other gathers.
    pub fn check_scene(&self, scene: &crate::scene::Scene) -> Result<()> {
        let Some(m) = scene.materials().iter().find(|m| {
            matches!(m.bsdf, crate::material::Bsdf::RoughDielectric { transmittance, .. }
                if transmittance != glam::Vec3::ZERO)
        }) else {
            return Ok(());
        };
        let path = scene.path().display();
        if self.method.uses(Parameter::Gather) && self.gather_parameters().0 == GatherKind::Tree {
            anyhow::bail!(
                "{path}: --gather tree does not bound rough transmitting materials yet (material \"{}\"); \
                 --gather resample and all do",
                m.name
            );
        }
        Ok(())
    }

    /// The parameters given that the method does not use (which change nothing).
    pub fn unused(&self) -> Vec<Parameter> {
        self.params.given().into_iter().filter(|&p| !self.method.uses(p)).collect()
    }

    /// How the method gathers, k and m: the flags, else the method's defaults.
    pub fn gather_parameters(&self) -> (GatherKind, usize, usize) {
        let p = &self.params;
        let (kind, k, m) = self.method.spec().defaults().gather;
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
    /// [`MethodConfig::auto_paths`] may choose), 0 for the others.
    pub fn light_paths(&self) -> usize {
        match self.auto_paths() {
            Some(auto) => auto.at_most,
            None if self.method.uses_vpls() => self.paths(),
            None => 0,
        }
    }

    /// Light paths chosen by the scene when `--vpls` is not given and the method's default
    /// says so ([`Paths::ByScene`]). `None` for a fixed count.
    pub fn auto_paths(&self) -> Option<AutoPaths> {
        match (self.params.vpls, self.method.spec().defaults().paths) {
            (None, Paths::ByScene(auto)) => Some(auto),
            _ => None,
        }
    }

    /// `--vpls`, or the method's default.
    fn paths(&self) -> usize {
        self.params.vpls.unwrap_or_else(|| self.method.spec().defaults().paths.fewest())
    }

    /// The parameters resolved for a scene whose bounding box has this diagonal.
    pub fn settings(&self, scene_diagonal: f32) -> Settings {
        let p = &self.params;
        let defaults = self.method.spec().defaults();
        Settings {
            paths: self.paths(),
            auto_paths: self.auto_paths(),
            gather: self.gather(),
            gather_samples_by_scene: p.gather_samples.is_none(),
            connect: p.connect.or(defaults.connect),
            light_samples: match p.light_samples {
                Some(n) => LightSamples::Given(n),
                None => LightSamples::ByScene { base: defaults.light_samples },
            },
            clamp: p.clamp.unwrap_or_else(|| Clamping::default_bound(scene_diagonal)),
            radius: p.radius.map_or(Radius::Density, Radius::Global),
            alpha: p.alpha,
            merge_radius: p.merge_radius.unwrap_or(DEFAULT_MERGE_PIXELS),
        }
    }

    /// The configuration as it decides the image, for a scene whose bounding box has this
    /// diagonal: the defaults of the parameters the method uses made explicit and the others
    /// set to their defaults. Two configurations whose identities are equal render the same
    /// image (the resume identity of [`crate::render::state`]). The converse holds but for
    /// what the scene chooses: light paths, light samples and `pir-bdpt`'s picks chosen by the scene stay unset,
    /// so a given value that equals the scene's choice still makes another identity.
    pub fn identity(&self, scene_diagonal: f32) -> MethodConfig {
        let m = self.method;
        let p = &self.params;
        let s = self.settings(scene_diagonal);
        let (kind, k, cands) = self.gather_parameters();
        let uses = |parameter| m.uses(parameter);
        MethodConfig {
            method: m,
            params: MethodParams {
                // A count chosen by the scene is the scene's: the same for the same scene and seed.
                vpls: (uses(Parameter::Vpls) && s.auto_paths.is_none()).then_some(s.paths),
                clamp: uses(Parameter::Clamp).then_some(s.clamp),
                radius: if uses(Parameter::Radius) { p.radius } else { None },
                alpha: if uses(Parameter::Alpha) { p.alpha } else { MethodParams::default().alpha },
                gather: uses(Parameter::Gather).then_some(kind),
                // Chosen by the scene when not given, where the method does ([`MethodSpec::picks_by_scene`]).
                gather_samples: (uses(Parameter::GatherSamples)
                    && kind != GatherKind::All
                    && !(m.spec().picks_by_scene()
                        && kind == GatherKind::Resample
                        && s.auto_paths.is_some()
                        && p.gather_samples.is_none()))
                .then_some(k),
                gather_candidates: (uses(Parameter::GatherCandidates) && kind == GatherKind::Resample)
                    .then_some(cands),
                // Chosen by the scene when not given, like the light samples.
                connect: if uses(Parameter::Connect) { s.connect } else { None },
                // Chosen by the scene when not given, like the light paths.
                light_samples: if uses(Parameter::LightSamples) { p.light_samples } else { None },
                merge_radius: uses(Parameter::MergeRadius).then_some(s.merge_radius),
            },
        }
    }

    /// The integrator for a scene whose bounding box has this diagonal.
    pub fn integrator(&self, scene_diagonal: f32) -> Box<dyn Integrator> {
        self.method.spec().integrator(&self.settings(scene_diagonal))
    }

    /// The parameters the method uses as the summary and the EXR metadata (`pir.param.*`)
    /// record them, as (key, value) in the order of [`Parameter::ALL`]: resolved for a scene
    /// of this diagonal, with what its prepared integrator chose ([`Integrator::measured`]) in
    /// place of the same key, and a key of its own after the one before it.
    pub fn report(&self, scene_diagonal: f32, measured: Vec<(String, String)>) -> Vec<(String, String)> {
        let settings = self.settings(scene_diagonal);
        let mut report: Vec<(String, String)> = Parameter::ALL
            .into_iter()
            .filter(|&p| self.method.uses(p))
            .filter_map(|p| Some((p.key().to_string(), p.report(&settings)?)))
            .collect();
        let mut at = 0;
        for (key, value) in measured {
            match report.iter().position(|(k, _)| *k == key) {
                Some(i) => {
                    report[i].1 = value;
                    at = i + 1;
                }
                None => {
                    report.insert(at, (key, value));
                    at += 1;
                }
            }
        }
        report
    }
}

#[cfg(test)]
mod tests;
