//! The scene loader: a TOML file (`shared/scene-format.md`) plus the OBJ/MTL files it names,
//! merged into one world-space triangle list. Paths are relative to the TOML file.
//!
//! Materials of a mesh: with `material = "X"` every face uses X; otherwise each face uses its
//! `usemtl` name. A name resolves to `[materials.NAME]` of the scene file if present (a whole
//! replacement), else to the OBJ's own MTL through the mapping table (see [`super::mtl`]),
//! else it is an error naming the mesh. Equal materials are stored once in
//! `Scene::materials`; two different materials of the same name (from two OBJ files) are
//! both kept.
//!
//! Vertex normals are used as shading normals for the faces of a material only when every
//! corner of every face of that material (of the whole mesh with `material = "X"`) has one,
//! like `shared/tools/mitsuba_ref.py`; other vertices get `Vec3::ZERO`.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

pub use super::error::SceneError;
use super::error::read_text;
use super::{Geometry, Scene, format, mtl, obj};
use crate::material::Material;

/// Loads the scene file `path` and everything it names: a Mitsuba 3 scene (`.xml`, see
/// [`super::mitsuba`]) or pir's TOML. Warnings (what pir renders differently from the file's
/// own renderer) go to standard error.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let (scene, warnings) = load_with(path, &super::mitsuba::Options::default())?;
    for w in warnings {
        eprintln!("pir: warning: {w}");
    }
    Ok(scene)
}

/// [`load`] with the Mitsuba parameters of `options` (`-D name=value`), returning the
/// warnings.
pub fn load_with(path: &Path, options: &super::mitsuba::Options) -> Result<(Scene, Vec<String>), SceneError> {
    let xml = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml"));
    if !xml && !options.defines.is_empty() {
        return Err(SceneError::Value {
            path: path.to_path_buf(),
            line: None,
            key: "-D".into(),
            problem: "parameters (-D name=value) are for Mitsuba scene files (.xml)".into(),
        });
    }
    let (scene, mut warnings) = if xml {
        super::mitsuba::load(path, options)?
    } else {
        let scene = load_toml(path)?;
        let warnings = energy_warnings(path, &scene);
        (scene, warnings)
    };
    warnings.extend(super::repeated::repeated_emitter_warning(path, &scene));
    Ok((scene, warnings))
}

/// A warning for each glossy material whose Lambertian and specular reflectances add up to
/// more than 1 in some channel (legal in the scene format, whose fields are each at most 1):
/// near the lobe's peak it reflects more light than it receives, and Mitsuba, which takes
/// such a material as a blend of two BSDFs of reflectance at most 1, cannot load it.
fn energy_warnings(path: &Path, scene: &Scene) -> Vec<String> {
    scene
        .materials()
        .iter()
        .filter_map(|m| match m.bsdf {
            crate::material::Bsdf::Glossy { albedo, specular, .. } if (albedo + specular).max_element() > 1.0 => {
                let sum = albedo + specular;
                Some(format!(
                    "{}: material {:?}: albedo + specular = {} {} {} exceeds 1: rendered as written, a material \
                     that reflects more light than it receives near its lobe (Mitsuba cannot load it)",
                    path.display(),
                    m.name,
                    sum.x,
                    sum.y,
                    sum.z
                ))
            }
            _ => None,
        })
        .collect()
}

/// Loads pir's TOML scene file `path` and everything it names.
fn load_toml(path: &Path) -> Result<Scene, SceneError> {
    let text = read_text(path)?;
    let doc = format::Doc { path, text: &text };
    let file = doc.parse()?;
    let camera = doc.camera(&file.camera)?;
    let render = doc.render(file.render.as_ref())?;
    let mut overrides: HashMap<&str, Material> = HashMap::new();
    for (name, m) in &file.materials {
        overrides.insert(name.as_str(), doc.material(name, m)?);
    }
    if file.mesh.is_empty() {
        return Err(SceneError::Value {
            path: path.to_path_buf(),
            line: None,
            key: "[[mesh]]".into(),
            problem: "the scene has no mesh".into(),
        });
    }
    let base = path.parent().unwrap_or(Path::new(""));

    let mut b = Builder::default();
    for (k, m) in file.mesh.iter().enumerate() {
        let index = k + 1;
        let transform = doc.mesh_transform(index, m)?;
        let mesh_err = |problem: String| SceneError::Mesh {
            path: path.to_path_buf(),
            line: Some(doc.line(&m.obj)),
            mesh: index,
            obj: m.obj.get_ref().clone(),
            problem,
        };
        let material = m.material.as_ref().map(|s| s.get_ref().as_str());
        let obj_path = base.join(m.obj.get_ref());
        let obj = obj::read(&obj_path).map_err(|e| match e {
            SceneError::Io { path: p, error } => mesh_err(format!("cannot read {}: {error}", p.display())),
            other => other,
        })?;
        if material.is_none() && !obj.has_mtl {
            return Err(mesh_err(
                "the OBJ names no MTL file (mtllib) and the mesh sets no `material`".into(),
            ));
        }
        let mut slot_material = Vec::with_capacity(obj.slots.len());
        for slot in &obj.slots {
            let name = match (material, &slot.name) {
                (Some(n), _) => n,
                (None, Some(n)) => n.as_str(),
                (None, None) => {
                    return Err(mesh_err(format!(
                        "the face on line {} of {} has no material (no usemtl before it) and \
                         the mesh sets no `material`",
                        slot.first_face_line,
                        obj_path.display()
                    )));
                }
            };
            let mat = if let Some(o) = overrides.get(name) {
                o.clone()
            } else if let Some((mtl_path, entry)) = obj.mtl.get(name) {
                mtl::to_material(mtl_path, name, entry)?
            } else if material.is_some() {
                return Err(mesh_err(format!(
                    "material = {name:?} is defined neither in [materials] nor in the OBJ's MTL"
                )));
            } else {
                return Err(mesh_err(format!(
                    "material {name:?} (usemtl, first used on line {} of {}) is defined \
                     neither in the OBJ's MTL nor in [materials]",
                    slot.first_face_line,
                    obj_path.display()
                )));
            };
            slot_material.push(b.intern(mat));
        }
        let mesh_has_normals = material.is_none() || obj.all_normals();
        let before = b.indices.len();
        for part in &obj.parts {
            let offset = u32::try_from(b.positions.len())
                .ok()
                .filter(|o| o.checked_add(part.positions.len() as u32).is_some())
                .ok_or_else(|| mesh_err("too many vertices in the scene".into()))?;
            for &p in &part.positions {
                let w = transform.point(p);
                if !w.is_finite() {
                    return Err(mesh_err(format!(
                        "vertex {p} is not finite after scale, rotate_y and translate"
                    )));
                }
                b.positions.push(w);
            }
            if mesh_has_normals && part.normals.len() == part.positions.len() {
                b.normals.extend(part.normals.iter().map(|&n| transform.normal(n)));
            } else {
                b.normals.extend(std::iter::repeat_n(Vec3::ZERO, part.positions.len()));
            }
            let material = slot_material[part.slot];
            for t in &part.indices {
                let [a, bb, c] = t.map(|i| b.positions[(offset + i) as usize]);
                if !(bb - a).cross(c - a).normalize().is_finite() {
                    b.degenerate_dropped += 1;
                    continue;
                }
                b.indices.push(t.map(|i| offset + i));
                b.tri_material.push(material);
            }
        }
        if b.indices.len() == before {
            return Err(mesh_err(format!(
                "all {} faces are degenerate (zero area, or coordinates too large for their area in single precision)",
                obj.faces
            )));
        }
    }

    if !b.tri_material.iter().any(|&m| b.materials[m as usize].is_emitter()) {
        return Err(SceneError::NoEmitter { path: path.to_path_buf() });
    }
    let geometry = Geometry {
        positions: b.positions,
        normals: b.normals,
        uvs: Vec::new(),
        indices: b.indices,
        tri_material: b.tri_material,
        degenerate_dropped: b.degenerate_dropped,
    };
    Scene::new(path.to_path_buf(), camera, render, geometry, b.materials)
}

#[derive(Default)]
struct Builder {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
    tri_material: Vec<u32>,
    materials: Vec<Material>,
    degenerate_dropped: usize,
}

impl Builder {
    /// The index of `m` in `materials`, adding it if no equal material is there yet.
    fn intern(&mut self, m: Material) -> u32 {
        if let Some(i) = self.materials.iter().position(|x| *x == m) {
            return i as u32;
        }
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }
}
