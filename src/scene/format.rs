//! The scene TOML of `shared/scene-format.md`: the serde structures (unknown keys are errors
//! everywhere) and their validation into typed values. Every check names the file and the
//! key it is about.
//!
//! Material keys per kind (anything else in a `[materials.NAME]` table is an error):
//!
//! | kind      | required              | optional                         |
//! |-----------|-----------------------|----------------------------------|
//! | `diffuse` | `albedo`              | `emission`                       |
//! | `glossy`  | `specular`, `roughness` | `albedo` (default 0), `emission` |
//! | `mirror`  | `specular`            | `emission`                       |
//! | `glass`   | `ior`                 | `emission`                       |
//!
//! `emission` defaults to 0 (not an emitter). Defaults follow `shared/tools/mitsuba_ref.py`,
//! the independent reader of the same files, so both read a scene the same way.

use std::collections::BTreeMap;
use std::path::Path;

use glam::Vec3;
use serde::Deserialize;

use super::RenderDefaults;
use super::camera::Camera;
use super::error::SceneError;
use super::transform::MeshTransform;
use crate::material::{Bsdf, Material};

/// Largest accepted image side, in pixels.
pub const MAX_RESOLUTION: u32 = 65536;
/// Largest accepted number of pixels (checked before anything is allocated).
pub const MAX_PIXELS: u64 = 1 << 28;
/// Largest accepted `max_depth`.
pub const MAX_DEPTH: u32 = 1024;
/// Largest accepted GGX alpha (MTL `Ns` ≥ 0 always maps to at most 1).
pub const MAX_ROUGHNESS: f32 = 1.0;

/// The whole scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub camera: CameraToml,
    #[serde(default)]
    pub render: Option<RenderToml>,
    #[serde(default)]
    pub mesh: Vec<MeshToml>,
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialToml>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraToml {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub up: [f32; 3],
    pub fov: f32,
    pub resolution: [u32; 2],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderToml {
    pub max_depth: Option<u32>,
    pub seed: Option<u64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshToml {
    pub obj: String,
    pub scale: Option<Scale>,
    pub rotate_y: Option<f32>,
    pub translate: Option<[f32; 3]>,
    pub material: Option<String>,
}

/// `scale = 2.0` or `scale = [sx, sy, sz]`.
#[derive(Debug, Deserialize)]
#[serde(untagged, expecting = "a number or an array of three numbers")]
pub enum Scale {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialToml {
    pub kind: String,
    pub albedo: Option<[f32; 3]>,
    pub specular: Option<[f32; 3]>,
    pub roughness: Option<f32>,
    pub ior: Option<f32>,
    pub emission: Option<[f32; 3]>,
}

/// Parses the TOML text of the scene file `path` (syntax, types and unknown keys only).
pub fn parse(path: &Path, text: &str) -> Result<SceneFile, SceneError> {
    toml::from_str(text).map_err(|e| SceneError::Toml {
        path: path.to_path_buf(),
        message: e.to_string().trim_end().to_string(),
    })
}

fn vec3(v: [f32; 3]) -> Vec3 {
    Vec3::from_array(v)
}

fn finite3(path: &Path, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(vec3(v))
    } else {
        Err(SceneError::value(path, format!("{key} = {v:?}"), "must be finite numbers"))
    }
}

/// A colour: three finite numbers ≥ 0.
pub fn colour(path: &Path, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
    if v.iter().all(|x| x.is_finite() && *x >= 0.0) {
        Ok(vec3(v))
    } else {
        Err(SceneError::value(path, format!("{key} = {v:?}"), "must be finite numbers ≥ 0"))
    }
}

/// The camera, validated: finite vectors, eye ≠ target, up not parallel to the view
/// direction, vertical fov in (0, 180) degrees, bounded resolution.
pub fn camera(path: &Path, c: &CameraToml) -> Result<Camera, SceneError> {
    let eye = finite3(path, "[camera] eye", c.eye)?;
    let target = finite3(path, "[camera] target", c.target)?;
    let up = finite3(path, "[camera] up", c.up)?;
    if !(c.fov.is_finite() && c.fov > 0.0 && c.fov < 180.0) {
        return Err(SceneError::value(
            path,
            format!("[camera] fov = {}", c.fov),
            "must be a vertical field of view in degrees, strictly between 0 and 180",
        ));
    }
    let [w, h] = c.resolution;
    let key = format!("[camera] resolution = [{w}, {h}]");
    if w == 0 || h == 0 {
        return Err(SceneError::value(path, key, "width and height must be at least 1"));
    }
    if w > MAX_RESOLUTION || h > MAX_RESOLUTION || u64::from(w) * u64::from(h) > MAX_PIXELS {
        return Err(SceneError::value(
            path,
            key,
            format!("too large (at most {MAX_RESOLUTION} per side and {MAX_PIXELS} pixels in total)"),
        ));
    }
    let view = target - eye;
    let forward = view.normalize_or_zero();
    if forward == Vec3::ZERO || !forward.is_finite() {
        return Err(SceneError::value(
            path,
            format!("[camera] eye = {:?}, target = {:?}", c.eye, c.target),
            "eye and target must be different points",
        ));
    }
    let up_n = up.normalize_or_zero();
    if up_n == Vec3::ZERO || forward.cross(up_n).length() < 1e-6 {
        return Err(SceneError::value(
            path,
            format!("[camera] up = {:?}", c.up),
            "must be non-zero and not parallel to the view direction (target − eye)",
        ));
    }
    Ok(Camera { eye, target, up, fov_deg: c.fov, width: w, height: h })
}

/// `[render]` with its defaults (max_depth 8, seed 0).
pub fn render(path: &Path, r: Option<&RenderToml>) -> Result<RenderDefaults, SceneError> {
    let mut out = RenderDefaults::default();
    if let Some(r) = r {
        if let Some(d) = r.max_depth {
            if !(1..=MAX_DEPTH).contains(&d) {
                return Err(SceneError::value(
                    path,
                    format!("[render] max_depth = {d}"),
                    format!("must be between 1 and {MAX_DEPTH}"),
                ));
            }
            out.max_depth = d;
        }
        if let Some(s) = r.seed {
            out.seed = s;
        }
    }
    Ok(out)
}

/// The placement of mesh number `index` (1-based): finite, non-zero scale.
pub fn mesh_transform(path: &Path, index: usize, m: &MeshToml) -> Result<MeshTransform, SceneError> {
    let key = |k: &str| format!("[[mesh]] #{index} {k}");
    let scale = match m.scale {
        None => Vec3::ONE,
        Some(Scale::Uniform(s)) => Vec3::splat(s),
        Some(Scale::PerAxis(s)) => vec3(s),
    };
    if !scale.is_finite() || scale.cmpeq(Vec3::ZERO).any() {
        return Err(SceneError::value(
            path,
            key(&format!("scale = {:?}", scale.to_array())),
            "must be finite and non-zero on every axis",
        ));
    }
    let rotate_y = m.rotate_y.unwrap_or(0.0);
    if !rotate_y.is_finite() {
        return Err(SceneError::value(path, key(&format!("rotate_y = {rotate_y}")), "must be finite"));
    }
    let translate = finite3(path, &key("translate"), m.translate.unwrap_or([0.0; 3]))?;
    Ok(MeshTransform::new(scale, rotate_y, translate))
}

/// A `[materials.NAME]` table as a material (see the module docs for the keys of each kind).
pub fn material(path: &Path, name: &str, m: &MaterialToml) -> Result<Material, SceneError> {
    let table = format!("[materials.{name}]");
    let key = |k: &str| format!("{table} {k}");
    let (required, optional): (&[&str], &[&str]) = match m.kind.as_str() {
        "diffuse" => (&["albedo"], &[]),
        "glossy" => (&["specular", "roughness"], &["albedo"]),
        "mirror" => (&["specular"], &[]),
        "glass" => (&["ior"], &[]),
        other => {
            return Err(SceneError::value(
                path,
                key(&format!("kind = {other:?}")),
                "must be one of \"diffuse\", \"glossy\", \"mirror\", \"glass\"",
            ));
        }
    };
    let present = [
        ("albedo", m.albedo.is_some()),
        ("specular", m.specular.is_some()),
        ("roughness", m.roughness.is_some()),
        ("ior", m.ior.is_some()),
    ];
    for (k, is) in present {
        let wanted = required.contains(&k) || optional.contains(&k);
        if is && !wanted {
            return Err(SceneError::value(
                path,
                key(k),
                format!("not used by kind = {:?} (it takes {})", m.kind, keys_of(required, optional)),
            ));
        }
        if !is && required.contains(&k) {
            return Err(SceneError::value(
                path,
                key(k),
                format!("missing: kind = {:?} requires {}", m.kind, required.join(", ")),
            ));
        }
    }
    let col = |k: &str, v: Option<[f32; 3]>| colour(path, &key(k), v.unwrap_or([0.0; 3]));
    let bsdf = match m.kind.as_str() {
        "diffuse" => Bsdf::Diffuse { albedo: col("albedo", m.albedo)? },
        "glossy" => {
            let r = m.roughness.unwrap_or(f32::NAN);
            if !(r.is_finite() && r > 0.0 && r <= MAX_ROUGHNESS) {
                return Err(SceneError::value(
                    path,
                    key(&format!("roughness = {r}")),
                    format!("must be a GGX alpha in (0, {MAX_ROUGHNESS}]"),
                ));
            }
            Bsdf::Glossy {
                albedo: col("albedo", m.albedo)?,
                specular: col("specular", m.specular)?,
                roughness: r,
            }
        }
        "mirror" => Bsdf::Mirror { specular: col("specular", m.specular)? },
        _ => {
            let ior = m.ior.unwrap_or(f32::NAN);
            if !(ior.is_finite() && ior > 0.0) {
                return Err(SceneError::value(
                    path,
                    key(&format!("ior = {ior}")),
                    "must be a finite positive number",
                ));
            }
            Bsdf::Glass { ior }
        }
    };
    let emission = col("emission", m.emission)?;
    Ok(Material { name: name.to_string(), bsdf, emission })
}

fn keys_of(required: &[&str], optional: &[&str]) -> String {
    let mut all: Vec<&str> = required.iter().chain(optional).copied().collect();
    all.push("emission");
    all.join(", ")
}
