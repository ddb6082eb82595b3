//! The rendering methods by name, and how a method with its parameters becomes an integrator:
//! the one place that `pir render`, `pir study` and the tests share.

use std::fmt;
use std::str::FromStr;

use super::{Clamping, InstantRadiosity, Integrator, PathTracer, Radius, VirtualLights};

/// A rendering method (`--method`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
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
}

impl Method {
    pub const ALL: [Method; 6] =
        [Method::Pt, Method::Ir, Method::IrClamp, Method::PirClamp, Method::Vsl, Method::PirVsl];

    pub fn name(self) -> &'static str {
        match self {
            Method::Pt => "pt",
            Method::Ir => "ir",
            Method::IrClamp => "ir-clamp",
            Method::PirClamp => "pir-clamp",
            Method::Vsl => "vsl",
            Method::PirVsl => "pir-vsl",
        }
    }

    /// Whether the method traces VPLs.
    pub fn uses_vpls(self) -> bool {
        self != Method::Pt
    }
    /// Whether the method uses α (the progressive schedules).
    pub fn uses_alpha(self) -> bool {
        matches!(self, Method::PirClamp | Method::PirVsl)
    }
    pub fn uses_clamp(self) -> bool {
        matches!(self, Method::IrClamp | Method::PirClamp)
    }
    pub fn uses_radius(self) -> bool {
        matches!(self, Method::Vsl | Method::PirVsl)
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

/// A method with its parameters; unset ones take their documented defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MethodConfig {
    pub method: Method,
    /// Light paths per iteration (VPL methods).
    pub vpls: usize,
    /// b (ir-clamp) or b_1 (pir-clamp); `None`: [`Clamping::default_bound`] of the scene.
    pub clamp: Option<f32>,
    /// r (vsl) or r_1 (pir-vsl); `None`: per light, by VPL density.
    pub radius: Option<f32>,
    /// The schedules' exponent (pir-clamp, pir-vsl).
    pub alpha: f32,
}

impl MethodConfig {
    /// The integrator for a scene whose bounding box has this diagonal.
    pub fn integrator(&self, scene_diagonal: f32) -> Box<dyn Integrator> {
        let bound = self.clamp.unwrap_or_else(|| Clamping::default_bound(scene_diagonal));
        let paths = self.vpls;
        match self.method {
            Method::Pt => Box::new(PathTracer),
            Method::Ir => Box::new(InstantRadiosity::points(Clamping::None, paths)),
            Method::IrClamp => Box::new(InstantRadiosity::points(Clamping::Constant { b: bound }, paths)),
            Method::PirClamp => Box::new(InstantRadiosity::points(
                Clamping::Progressive { b1: bound, alpha: self.alpha },
                paths,
            )),
            Method::Vsl | Method::PirVsl => {
                let radius = self.radius.map_or(Radius::Density, Radius::Global);
                let alpha = (self.method == Method::PirVsl).then_some(self.alpha);
                Box::new(InstantRadiosity::new(VirtualLights::Spheres { radius, alpha }, paths))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_integrators_carry_them() {
        for m in Method::ALL {
            assert_eq!(m.name().parse::<Method>(), Ok(m));
            let c = MethodConfig { method: m, vpls: 4, clamp: None, radius: None, alpha: 0.6 };
            assert_eq!(c.integrator(3.0).name(), m.name());
        }
        assert!("photon".parse::<Method>().unwrap_err().contains("pir-vsl"));
    }
}
