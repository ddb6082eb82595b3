//! Mitsuba 3's BSDF plugins beyond `diffuse` and the `twosided` wrapper: conductors with their
//! Fresnel term (`eta`/`k`, or a `material` of Mitsuba's table, whose RGB values are those
//! Mitsuba's RGB variants compute from its spectra), rough conductors, smooth and rough
//! plastics, dielectrics (smooth and rough) with their reflectance and transmittance, thin
//! dielectrics and the mask's opacity. Defaults are Mitsuba's.

use glam::Vec3;

use super::xml::Element;
use super::{Params, SceneError, ior, reflectance};
use crate::light::envmap::luminance;
use crate::material::conductor::ComplexIor;
use crate::material::microfacet::{Distribution, Microfacet};
use crate::material::{Bsdf, ggx};

/// A conductor's complex index: `eta` and `k` (defaults 0 and 1, the "none" of a perfect
/// mirror), or a `material` of Mitsuba's table; both at once are refused, as Mitsuba does.
pub(super) fn complex_ior(e: &Element, p: &Params) -> Result<ComplexIor, SceneError> {
    let material = p.string("material")?.unwrap_or("none");
    let (eta, k) = (p.colour("eta")?, p.colour("k")?);
    if material != "none" {
        if eta.is_some() || k.is_some() {
            return Err(e.error("give either eta and k or a material, not both (as Mitsuba)"));
        }
        return METALS.iter().find(|(n, ..)| *n == material).map(|&(_, eta, k)| ComplexIor { eta: Vec3::from(eta), k: Vec3::from(k) }).ok_or_else(
            || e.error(format!("material \"{material}\": not a name of Mitsuba's table of conductors (Au, Ag, Al, Cu, Cr, …, or none)")),
        );
    }
    let ior = ComplexIor { eta: eta.unwrap_or(Vec3::ZERO), k: k.unwrap_or(Vec3::ONE) };
    // Mitsuba reads them unbounded: RGB conversions of measured spectra can dip below zero,
    // and the Fresnel term depends on their squares only.
    if !(ior.eta.is_finite() && ior.k.is_finite()) {
        return Err(e.error(format!("eta {} and k {}: must be finite", ior.eta, ior.k)));
    }
    Ok(ior)
}

/// A microfacet distribution: `distribution` (default beckmann) and an isotropic `alpha`
/// (default 0.1); `sample_visible` changes only the noise.
pub(super) fn microfacet(e: &Element, p: &Params) -> Result<Microfacet, SceneError> {
    let kind = match p.string("distribution")?.unwrap_or("beckmann") {
        "ggx" => Distribution::Ggx,
        "beckmann" => Distribution::Beckmann,
        d => return Err(e.error(format!("distribution \"{d}\": must be beckmann or ggx"))),
    };
    let alpha = match (p.float("alpha")?, p.float("alpha_u")?, p.float("alpha_v")?) {
        (Some(a), None, None) => a,
        (None, Some(u), Some(v)) if u == v => u,
        (None, None, None) => 0.1,
        _ => return Err(e.error("an anisotropic alpha (alpha_u ≠ alpha_v) is not supported: give one alpha")),
    };
    if !(alpha > 0.0 && alpha <= super::super::format::MAX_ROUGHNESS) {
        return Err(
            e.error(format!("alpha {alpha}: must lie in (0, {}]", super::super::format::MAX_ROUGHNESS))
        );
    }
    p.ignore(&["sample_visible"]);
    Ok(Microfacet::new(kind, alpha.max(ggx::MIN_ALPHA)))
}

/// A reflectance parameter with its default, checked to lie in [0, 1].
fn checked(p: &Params, name: &str, default: Vec3) -> Result<Vec3, SceneError> {
    let v = p.colour(name)?.unwrap_or(default);
    reflectance(p.e, name, v)?;
    Ok(v)
}

/// `conductor`: a perfect mirror when its index is "none" (pir's mirror), else the Fresnel
/// conductor.
/// `textured_ior`: η or k is a texture (whose means `ior` holds).
pub(super) fn conductor(e: &Element, p: &Params, textured_ior: bool) -> Result<Bsdf, SceneError> {
    let ior = complex_ior(e, p)?;
    let specular = checked(p, "specular_reflectance", Vec3::ONE)?;
    Ok(if ior == ComplexIor::NONE && !textured_ior {
        Bsdf::Mirror { specular }
    } else {
        Bsdf::Conductor { specular, ior }
    })
}

/// `roughconductor`; of index "none" and GGX it is pir's glossy lobe without albedo.
pub(super) fn rough_conductor(e: &Element, p: &Params, textured_ior: bool) -> Result<Bsdf, SceneError> {
    let ior = complex_ior(e, p)?;
    let microfacet = microfacet(e, p)?;
    let specular = checked(p, "specular_reflectance", Vec3::ONE)?;
    Ok(if ior == ComplexIor::NONE && !textured_ior && microfacet.kind == Distribution::Ggx {
        Bsdf::Glossy { albedo: Vec3::ZERO, specular, roughness: microfacet.alpha }
    } else {
        Bsdf::RoughConductor { specular, ior, microfacet }
    })
}

/// The relative index `int_ior / ext_ior` of a dielectric coating; the same indices are
/// refused (a coating that is no coating).
fn relative_ior(e: &Element, p: &Params, int_default: f32) -> Result<f32, SceneError> {
    let eta = interface_ior(p, int_default)?;
    if eta == 1.0 {
        return Err(e.error("int_ior and ext_ior are the same: they must differ"));
    }
    Ok(eta)
}

/// The relative index `int_ior / ext_ior` of a smooth dielectric interface. The same index on
/// both sides is an interface that light crosses unchanged and never reflects (Mitsuba
/// renders it so, counting it as a vertex of the path), which is what the smooth dielectrics
/// do at η = 1 (Fresnel reflectance 0).
fn interface_ior(p: &Params, int_default: f32) -> Result<f32, SceneError> {
    let int = ior(p, "int_ior", int_default)?;
    let ext = ior(p, "ext_ior", 1.000277)?;
    Ok(int / ext)
}

/// `plastic` and `roughplastic` (Mitsuba's polypropylene, 1.49, inside) of the (checked)
/// `diffuse` reflectance the caller read, which may be a texture's mean.
pub(super) fn plastic(e: &Element, p: &Params, diffuse: Vec3, rough: bool) -> Result<Bsdf, SceneError> {
    let eta = relative_ior(e, p, 1.49)?;
    let specular = p.colour("specular_reflectance")?;
    if let Some(s) = specular {
        reflectance(e, "specular_reflectance", s)?;
    }
    let nonlinear = p.boolean("nonlinear")?.unwrap_or(false);
    Ok(if rough {
        Bsdf::rough_plastic(diffuse, specular, eta, microfacet(e, p)?, nonlinear)
    } else {
        Bsdf::plastic(diffuse, specular, eta, nonlinear)
    })
}

/// `dielectric` (BK7 inside, 1.5046): pir's glass when it reflects and transmits in full.
pub(super) fn dielectric(p: &Params) -> Result<Bsdf, SceneError> {
    let ior = interface_ior(p, 1.5046)?;
    let reflectance = checked(p, "specular_reflectance", Vec3::ONE)?;
    let transmittance = checked(p, "specular_transmittance", Vec3::ONE)?;
    Ok(if reflectance == Vec3::ONE && transmittance == Vec3::ONE {
        Bsdf::Glass { ior }
    } else {
        Bsdf::Dielectric { ior, reflectance, transmittance }
    })
}

/// `thindielectric`.
pub(super) fn thin_dielectric(p: &Params) -> Result<Bsdf, SceneError> {
    let ior = interface_ior(p, 1.5046)?;
    let reflectance = checked(p, "specular_reflectance", Vec3::ONE)?;
    let transmittance = checked(p, "specular_transmittance", Vec3::ONE)?;
    Ok(Bsdf::ThinDielectric { ior, reflectance, transmittance })
}

/// `roughdielectric` (BK7 inside, 1.5046): a rough interface that reflects and refracts,
/// from either side ([`crate::material::rough_dielectric`]).
pub(super) fn rough_dielectric(e: &Element, p: &Params) -> Result<Bsdf, SceneError> {
    let eta = relative_ior(e, p, 1.5046)?;
    let microfacet = microfacet(e, p)?;
    let reflectance = checked(p, "specular_reflectance", Vec3::ONE)?;
    let transmittance = checked(p, "specular_transmittance", Vec3::ONE)?;
    Ok(Bsdf::RoughDielectric { eta, reflectance, transmittance, microfacet })
}

/// A `mask`'s opacity (default 0.5): a number, or the luminance of a colour (a texture's mean
/// where the caller took it as a texture).
pub(super) fn opacity(e: &Element, p: &Params) -> Result<f32, SceneError> {
    let opacity = p.colour("opacity")?.map_or(0.5, luminance);
    if !(0.0..=1.0).contains(&opacity) {
        return Err(e.error(format!("opacity {opacity}: must lie between 0 and 1")));
    }
    Ok(opacity)
}

/// Mitsuba's conductors as its RGB variants see them: (name, η, k), from its spectra
/// (`data/ior/*.spd`) converted by Mitsuba 3.9.1 itself (`mi.traverse` of a `conductor` of
/// that material in `scalar_rgb`).
const METALS: &[(&str, [f32; 3], [f32; 3])] = &[
    ("Ag", [0.155276, 0.116728, 0.138388], [4.82835, 3.12222, 2.1469]),
    ("Al", [1.6575, 0.880405, 0.521244], [9.22381, 6.2695, 4.837]),
    ("Au", [0.143036, 0.375307, 1.44205], [3.983, 2.38556, 1.60336]),
    ("Be", [4.18501, 3.18503, 2.78406], [3.83547, 3.01012, 2.86899]),
    ("Be_palik", [4.18501, 3.18503, 2.78406], [3.83547, 3.01012, 2.86899]),
    ("Cr", [4.36967, 2.91651, 1.6549], [5.20655, 4.23131, 3.7547]),
    ("CsI", [2.1449, 1.70232, 1.66243], [0.0, 0.0, 0.0]),
    ("CsI_palik", [2.1449, 1.70232, 1.66243], [0.0, 0.0, 0.0]),
    ("Cu", [0.201005, 0.92375, 1.10222], [3.91326, 2.45305, 2.14209]),
    ("Cu2O", [3.55177, 2.94987, 2.75188], [0.114207, 0.193897, 0.606134]),
    ("Cu2O_palik", [3.55177, 2.94987, 2.75188], [0.114207, 0.193897, 0.606134]),
    ("CuO", [3.24754, 2.44781, 2.21022], [0.52109, 0.570031, 0.722179]),
    ("CuO_palik", [3.24754, 2.44781, 2.21022], [0.52109, 0.570031, 0.722179]),
    ("Cu_palik", [0.213229, 0.919715, 1.10241], [3.92187, 2.45733, 2.13658]),
    ("Hg", [2.39894, 1.44003, 0.90957], [6.32759, 4.37192, 3.42176]),
    ("HgTe", [4.77904, 3.2312, 2.6599], [1.63161, 1.58081, 1.72929]),
    ("HgTe_palik", [4.77904, 3.2312, 2.6599], [1.63161, 1.58081, 1.72929]),
    ("Hg_palik", [2.39894, 1.44003, 0.90957], [6.32759, 4.37192, 3.42176]),
    ("Ir", [3.0863, 2.08219, 1.61791], [5.59215, 4.06709, 3.26731]),
    ("Ir_palik", [3.0863, 2.08219, 1.61791], [5.59215, 4.06709, 3.26731]),
    ("K", [0.0640432, 0.0464098, 0.0381849], [2.1042, 1.34894, 0.913126]),
    ("K_palik", [0.0640432, 0.0464098, 0.0381849], [2.1042, 1.34894, 0.913126]),
    ("Li", [0.265791, 0.195618, 0.220949], [3.54015, 2.31112, 1.66861]),
    ("Li_palik", [0.265791, 0.195618, 0.220949], [3.54015, 2.31112, 1.66861]),
    ("Mo", [4.48397, 3.52513, 2.77631], [4.11144, 3.42083, 3.15061]),
    ("Mo_palik", [4.48397, 3.52513, 2.77631], [4.11144, 3.42083, 3.15061]),
    ("Na_palik", [0.0602694, 0.0561409, 0.0619884], [3.17927, 2.11249, 1.57904]),
    ("Nb", [3.42007, 2.79009, 2.39563], [3.44139, 2.73767, 2.57975]),
    ("Nb_palik", [3.42007, 2.79009, 2.39563], [3.44139, 2.73767, 2.57975]),
    ("Ni_palik", [2.3673, 1.66337, 1.46708], [4.49881, 3.05015, 2.34544]),
    ("Rh", [2.58579, 1.86022, 1.55426], [6.78226, 4.70299, 3.97607]),
    ("Rh_palik", [2.58579, 1.86022, 1.55426], [6.78226, 4.70299, 3.97607]),
    ("Se", [4.05831, 2.84294, 2.82085], [0.75405, 0.638444, 0.521808]),
    ("Se-e", [5.72285, 4.16574, 4.08134], [0.871136, 1.10516, 1.56532]),
    ("Se-e_palik", [5.72285, 4.16574, 4.08134], [0.871136, 1.10516, 1.56532]),
    ("Se_palik", [4.05831, 2.84294, 2.82085], [0.75405, 0.638444, 0.521808]),
    ("SnTe", [4.52425, 1.98164, 1.28159], [0.0, 0.0, 0.0]),
    ("SnTe_palik", [4.52425, 1.98164, 1.28159], [0.0, 0.0, 0.0]),
    ("Ta", [2.06272, 2.39294, 2.62793], [2.40836, 1.74149, 1.94703]),
    ("Ta_palik", [2.06272, 2.39294, 2.62793], [2.40836, 1.74149, 1.94703]),
    ("Te", [7.39023, 4.4821, 2.63711], [3.25602, 3.52706, 3.29205]),
    ("Te-e", [7.50891, 4.29643, 2.36999], [5.58393, 4.94721, 3.99759]),
    ("Te-e_palik", [7.50891, 4.29643, 2.36999], [5.58393, 4.94721, 3.99759]),
    ("Te_palik", [7.39023, 4.4821, 2.63711], [3.25602, 3.52706, 3.29205]),
    ("ThF4", [1.83071, 1.44223, 1.38765], [0.0, 0.0, 0.0]),
    ("ThF4_palik", [1.83071, 1.44223, 1.38765], [0.0, 0.0, 0.0]),
    ("TiC", [3.70053, 2.83742, 2.58229], [3.26564, 2.35159, 2.17279]),
    ("TiC_palik", [3.70053, 2.83742, 2.58229], [3.26564, 2.35159, 2.17279]),
    ("TiN", [1.64845, 1.15052, 1.37982], [3.36833, 1.9435, 1.10207]),
    ("TiN_palik", [1.64845, 1.15052, 1.37982], [3.36833, 1.9435, 1.10207]),
    ("VC", [3.65757, 2.75274, 2.53267], [3.0683, 2.19869, 1.96319]),
    ("VC_palik", [3.65757, 2.75274, 2.53267], [3.0683, 2.19869, 1.96319]),
    ("VN", [2.8656, 2.11919, 1.94009], [3.03224, 2.05612, 1.61631]),
    ("VN_palik", [2.8656, 2.11919, 1.94009], [3.03224, 2.05612, 1.61631]),
    ("V_palik", [4.27758, 3.51295, 2.76107], [3.4913, 2.88945, 3.11152]),
    ("W", [4.37082, 3.30025, 2.99841], [3.50064, 2.60487, 2.27323]),
    ("a-C", [2.94405, 2.22714, 1.96816], [0.887465, 0.799299, 0.81529]),
    ("d-C", [2.70872, 2.31883, 2.2289], [0.0, 0.0, 0.0]),
    ("d-C_palik", [2.70872, 2.31883, 2.2289], [0.0, 0.0, 0.0]),
];
