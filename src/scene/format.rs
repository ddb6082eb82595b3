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
use toml::Spanned;

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
    pub eye: Spanned<[f32; 3]>,
    pub target: Spanned<[f32; 3]>,
    pub up: Spanned<[f32; 3]>,
    pub fov: Spanned<f32>,
    pub resolution: Spanned<[u32; 2]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderToml {
    pub max_depth: Option<Spanned<u32>>,
    pub seed: Option<u64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshToml {
    pub obj: Spanned<String>,
    pub scale: Option<Spanned<Scale>>,
    pub rotate_y: Option<Spanned<f32>>,
    pub translate: Option<Spanned<[f32; 3]>>,
    pub material: Option<Spanned<String>>,
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
    pub kind: Spanned<String>,
    pub albedo: Option<Spanned<[f32; 3]>>,
    pub specular: Option<Spanned<[f32; 3]>>,
    pub roughness: Option<Spanned<f32>>,
    pub ior: Option<Spanned<f32>>,
    pub emission: Option<Spanned<[f32; 3]>>,
}

/// The scene file's path and text, to turn spans into line numbers for messages.
#[derive(Clone, Copy)]
pub struct Doc<'a> {
    pub path: &'a Path,
    pub text: &'a str,
}

impl Doc<'_> {
    /// The 1-based line where `v` starts.
    pub fn line<T>(&self, v: &Spanned<T>) -> usize {
        let end = v.span().start.min(self.text.len());
        self.text.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() + 1
    }

    fn err<T>(&self, at: &Spanned<T>, key: impl Into<String>, problem: impl Into<String>) -> SceneError {
        SceneError::Value {
            path: self.path.to_path_buf(),
            line: Some(self.line(at)),
            key: key.into(),
            problem: problem.into(),
        }
    }

    /// Parses the TOML text (syntax, types and unknown keys only).
    pub fn parse(&self) -> Result<SceneFile, SceneError> {
        toml::from_str(self.text).map_err(|e| SceneError::Toml {
            path: self.path.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        })
    }

    fn finite3(&self, key: &str, v: &Spanned<[f32; 3]>) -> Result<Vec3, SceneError> {
        let a = *v.get_ref();
        if a.iter().all(|x| x.is_finite()) {
            Ok(Vec3::from_array(a))
        } else {
            Err(self.err(v, format!("{key} = {a:?}"), "must be finite numbers"))
        }
    }

    /// A colour: three finite numbers ≥ 0 (zero when absent).
    fn colour(&self, key: &str, v: Option<&Spanned<[f32; 3]>>) -> Result<Vec3, SceneError> {
        let Some(v) = v else { return Ok(Vec3::ZERO) };
        let a = *v.get_ref();
        if a.iter().all(|x| x.is_finite() && *x >= 0.0) {
            Ok(Vec3::from_array(a))
        } else {
            Err(self.err(v, format!("{key} = {a:?}"), "must be finite numbers ≥ 0"))
        }
    }

    /// The camera, validated: finite vectors, eye ≠ target, up not parallel to the view
    /// direction, vertical fov in (0, 180) degrees, bounded resolution.
    pub fn camera(&self, c: &CameraToml) -> Result<Camera, SceneError> {
        let eye = self.finite3("[camera] eye", &c.eye)?;
        let target = self.finite3("[camera] target", &c.target)?;
        let up = self.finite3("[camera] up", &c.up)?;
        let fov = *c.fov.get_ref();
        if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
            return Err(self.err(
                &c.fov,
                format!("[camera] fov = {fov}"),
                "must be a vertical field of view in degrees, strictly between 0 and 180",
            ));
        }
        let [w, h] = *c.resolution.get_ref();
        let key = format!("[camera] resolution = [{w}, {h}]");
        if w == 0 || h == 0 {
            return Err(self.err(&c.resolution, key, "width and height must be at least 1"));
        }
        if w > MAX_RESOLUTION || h > MAX_RESOLUTION || u64::from(w) * u64::from(h) > MAX_PIXELS {
            return Err(self.err(
                &c.resolution,
                key,
                format!(
                    "too large (at most {MAX_RESOLUTION} per side and {MAX_PIXELS} pixels in \
                     total)"
                ),
            ));
        }
        let forward = (target - eye).normalize_or_zero();
        if forward == Vec3::ZERO || !forward.is_finite() {
            return Err(self.err(
                &c.target,
                format!("[camera] eye = {:?}, target = {:?}", c.eye.get_ref(), c.target.get_ref()),
                "eye and target must be different points",
            ));
        }
        let up_n = up.normalize_or_zero();
        if up_n == Vec3::ZERO || forward.cross(up_n).length() < 1e-6 {
            return Err(self.err(
                &c.up,
                format!("[camera] up = {:?}", c.up.get_ref()),
                "must be non-zero and not parallel to the view direction (target − eye)",
            ));
        }
        Ok(Camera::pinhole(eye, target, up, fov, w, h))
    }

    /// `[render]` with its defaults (max_depth 8, seed 0).
    pub fn render(&self, r: Option<&RenderToml>) -> Result<RenderDefaults, SceneError> {
        let mut out = RenderDefaults::default();
        if let Some(r) = r {
            if let Some(d) = &r.max_depth {
                let v = *d.get_ref();
                if !(1..=MAX_DEPTH).contains(&v) {
                    return Err(self.err(
                        d,
                        format!("[render] max_depth = {v}"),
                        format!("must be between 1 and {MAX_DEPTH}"),
                    ));
                }
                out.max_depth = v;
            }
            if let Some(s) = r.seed {
                out.seed = s;
            }
        }
        Ok(out)
    }

    /// The placement of mesh number `index` (1-based): finite, non-zero scale.
    pub fn mesh_transform(&self, index: usize, m: &MeshToml) -> Result<MeshTransform, SceneError> {
        let key = |k: &str| format!("[[mesh]] #{index} {k}");
        let scale = match m.scale.as_ref() {
            None => Vec3::ONE,
            Some(s) => {
                let v = match s.get_ref() {
                    Scale::Uniform(u) => Vec3::splat(*u),
                    Scale::PerAxis(a) => Vec3::from_array(*a),
                };
                if !v.is_finite() || v.cmpeq(Vec3::ZERO).any() {
                    return Err(self.err(
                        s,
                        key(&format!("scale = {:?}", v.to_array())),
                        "must be finite and non-zero on every axis",
                    ));
                }
                v
            }
        };
        let mut rotate_y = 0.0;
        if let Some(r) = &m.rotate_y {
            rotate_y = *r.get_ref();
            if !rotate_y.is_finite() {
                return Err(self.err(r, key(&format!("rotate_y = {rotate_y}")), "must be finite"));
            }
        }
        let translate = match &m.translate {
            Some(t) => self.finite3(&key("translate"), t)?,
            None => Vec3::ZERO,
        };
        Ok(MeshTransform::new(scale, rotate_y, translate))
    }

    /// A `[materials.NAME]` table as a material (see the module docs for the keys of each
    /// kind).
    pub fn material(&self, name: &str, m: &MaterialToml) -> Result<Material, SceneError> {
        let key = |k: &str| format!("[materials.{name}] {k}");
        let kind = m.kind.get_ref().as_str();
        let (required, optional): (&[&str], &[&str]) = match kind {
            "diffuse" => (&["albedo"], &[]),
            "glossy" => (&["specular", "roughness"], &["albedo"]),
            "mirror" => (&["specular"], &[]),
            "glass" => (&["ior"], &[]),
            other => {
                return Err(self.err(
                    &m.kind,
                    key(&format!("kind = {other:?}")),
                    "must be one of \"diffuse\", \"glossy\", \"mirror\", \"glass\"",
                ));
            }
        };
        let present = [
            ("albedo", m.albedo.as_ref().map(|v| v.span())),
            ("specular", m.specular.as_ref().map(|v| v.span())),
            ("roughness", m.roughness.as_ref().map(|v| v.span())),
            ("ior", m.ior.as_ref().map(|v| v.span())),
        ];
        for (k, span) in present {
            let wanted = required.contains(&k) || optional.contains(&k);
            match span {
                Some(span) if !wanted => {
                    let at = Spanned::new(span, ());
                    return Err(self.err(
                        &at,
                        key(k),
                        format!("not used by kind = {kind:?} (it takes {})", keys_of(required, optional)),
                    ));
                }
                None if required.contains(&k) => {
                    return Err(self.err(
                        &m.kind,
                        key(k),
                        format!("missing: kind = {kind:?} requires {}", required.join(", ")),
                    ));
                }
                _ => {}
            }
        }
        let bsdf = match (kind, &m.roughness, &m.ior) {
            ("diffuse", ..) => Bsdf::Diffuse { albedo: self.colour(&key("albedo"), m.albedo.as_ref())? },
            ("glossy", Some(r), _) => {
                let v = *r.get_ref();
                if !(v.is_finite() && v > 0.0 && v <= MAX_ROUGHNESS) {
                    return Err(self.err(
                        r,
                        key(&format!("roughness = {v}")),
                        format!("must be a GGX alpha in (0, {MAX_ROUGHNESS}]"),
                    ));
                }
                Bsdf::Glossy {
                    albedo: self.colour(&key("albedo"), m.albedo.as_ref())?,
                    specular: self.colour(&key("specular"), m.specular.as_ref())?,
                    roughness: v,
                }
            }
            ("mirror", ..) => Bsdf::Mirror { specular: self.colour(&key("specular"), m.specular.as_ref())? },
            (_, _, Some(ior)) => {
                let v = *ior.get_ref();
                if !(v.is_finite() && v > 0.0) {
                    return Err(self.err(
                        ior,
                        key(&format!("ior = {v}")),
                        "must be a finite positive number",
                    ));
                }
                Bsdf::Glass { ior: v }
            }
            // Unreachable: required keys were checked above.
            _ => return Err(self.err(&m.kind, key("kind"), "internal: incomplete material")),
        };
        if let Some((field, v)) = bsdf.creates_energy() {
            let at = if field == "albedo" { m.albedo.as_ref() } else { m.specular.as_ref() };
            let line = at.map(|a| self.line(a));
            return Err(SceneError::Value {
                path: self.path.to_path_buf(),
                line,
                key: key(&format!("{field} = [{}, {}, {}]", v.x, v.y, v.z)),
                problem: "a reflectance must not exceed 1 (the material would create energy; Mitsuba refuses it too)"
                    .into(),
            });
        }
        let emission = self.colour(&key("emission"), m.emission.as_ref())?;
        Ok(Material { name: name.to_string(), bsdf, emission, two_sided: false, textures: None })
    }
}

fn keys_of(required: &[&str], optional: &[&str]) -> String {
    let mut all: Vec<&str> = required.iter().chain(optional).copied().collect();
    all.push("emission");
    all.join(", ")
}
