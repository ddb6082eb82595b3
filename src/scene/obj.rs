//! OBJ files: a validating pass of our own, then tobj for triangulation and indexing.
//!
//! tobj alone reports errors without line numbers (index errors even at the end of the
//! object), loses the name of a `usemtl` it cannot resolve, reads `#` comments inside values
//! as data, scales positions by a fourth `w` value and silently ignores a missing MTL when
//! another one loaded. So a first pass here reads the file as `shared/tools/mitsuba_ref.py`
//! does (`v`, `vn`, `f`, `usemtl`, `mtllib`; `#` starts a comment; texture coordinates and
//! everything else are ignored), checks every number and index with its line number, and
//! writes a normalised copy that tobj then triangulates (fans (0, i, i+1), as the spec
//! requires) with `single_index`. Faces are grouped by their `usemtl` name ("slot").

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::error::{SceneError, read_text};
use super::mtl::{self, MtlEntry};

/// The faces of one `usemtl` name (or of none) in an OBJ file.
#[derive(Clone, Debug)]
pub struct Slot {
    /// The `usemtl` name, `None` for faces before any `usemtl`.
    pub name: Option<String>,
    /// Line of the first face that uses it.
    pub first_face_line: usize,
    /// Whether every corner of every face of the slot has a vertex normal.
    pub all_normals: bool,
}

/// A run of triangles of one slot, in the OBJ's own coordinates.
#[derive(Clone, Debug)]
pub struct Part {
    pub slot: usize,
    pub positions: Vec<Vec3>,
    /// Aligned with `positions` when the slot has normals everywhere, else empty.
    pub normals: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
}

/// A loaded OBJ file with the MTL files it names.
#[derive(Clone, Debug)]
pub struct Obj {
    pub slots: Vec<Slot>,
    pub parts: Vec<Part>,
    /// Whether the file names at least one MTL file (`mtllib`).
    pub has_mtl: bool,
    /// Materials of all its MTL files (a later file replaces a name of an earlier one), with
    /// the file each comes from.
    pub mtl: HashMap<String, (PathBuf, MtlEntry)>,
    /// Number of faces with at least three corners.
    pub faces: usize,
}

impl Obj {
    /// Whether every face corner of the whole file has a vertex normal.
    pub fn all_normals(&self) -> bool {
        self.slots.iter().all(|s| s.all_normals)
    }
}

/// Reads the OBJ file `path` and the MTL files it names (relative to the OBJ).
pub fn read(path: &Path) -> Result<Obj, SceneError> {
    let text = read_text(path)?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let err = |line: usize, p: String| SceneError::syntax(path, Some(line), p);

    let mut clean = String::with_capacity(text.len());
    let (mut nv, mut nn) = (0usize, 0usize);
    let mut slots: Vec<Slot> = Vec::new();
    let mut slot_of: HashMap<Option<String>, usize> = HashMap::new();
    let mut current: Option<String> = None;
    let mut open_slot: Option<usize> = None;
    let mut mtl: HashMap<String, (PathBuf, MtlEntry)> = HashMap::new();
    let mut has_mtl = false;
    let mut faces = 0usize;

    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let toks: Vec<&str> = raw.split('#').next().unwrap_or("").split_whitespace().collect();
        let Some((&key, args)) = toks.split_first() else { continue };
        match key {
            "v" | "vn" => {
                let v = three_finite(args).ok_or_else(|| {
                    err(line, format!("{key} {}: expected three finite numbers", args.join(" ")))
                })?;
                let _ = writeln!(clean, "{key} {} {} {}", v[0], v[1], v[2]);
                if key == "v" {
                    nv += 1;
                } else {
                    nn += 1;
                }
            }
            "f" => {
                let mut corners = Vec::with_capacity(args.len());
                let mut all_n = true;
                for c in args {
                    let parts: Vec<&str> = c.split('/').collect();
                    if parts.len() > 3 {
                        return Err(err(
                            line,
                            format!("face corner {c:?}: expected v, v/vt, v//vn or v/vt/vn"),
                        ));
                    }
                    let v = index(parts[0], nv)
                        .map_err(|p| err(line, format!("face corner {c:?}: vertex {p}")))?;
                    let n = match parts.get(2) {
                        Some(s) if !s.is_empty() => Some(
                            index(s, nn).map_err(|p| err(line, format!("face corner {c:?}: normal {p}")))?,
                        ),
                        _ => None,
                    };
                    all_n &= n.is_some();
                    corners.push((v, n));
                }
                if corners.len() < 3 {
                    // Not a surface (mitsuba_ref.py makes no triangle of it either).
                    continue;
                }
                faces += 1;
                let slot = match open_slot {
                    Some(s) => s,
                    None => {
                        let s = *slot_of.entry(current.clone()).or_insert_with(|| {
                            slots.push(Slot {
                                name: current.clone(),
                                first_face_line: line,
                                all_normals: true,
                            });
                            slots.len() - 1
                        });
                        let _ = writeln!(clean, "o {s}");
                        open_slot = Some(s);
                        s
                    }
                };
                slots[slot].all_normals &= all_n;
                clean.push('f');
                for (v, n) in corners {
                    match n {
                        Some(n) => {
                            let _ = write!(clean, " {}//{}", v + 1, n + 1);
                        }
                        None => {
                            let _ = write!(clean, " {}", v + 1);
                        }
                    }
                }
                clean.push('\n');
            }
            "usemtl" => {
                let name = args.join(" ");
                if name.is_empty() {
                    return Err(err(line, "usemtl without a material name".into()));
                }
                if current.as_ref() != Some(&name) {
                    current = Some(name);
                    open_slot = None;
                }
            }
            "mtllib" => {
                let name = args.join(" ");
                if name.is_empty() {
                    return Err(err(line, "mtllib without a file name".into()));
                }
                let mtl_path = dir.join(&name);
                let entries = match mtl::read(&mtl_path) {
                    Ok(m) => m,
                    Err(SceneError::Io { path: p, error }) => {
                        return Err(err(
                            line,
                            format!("mtllib {name}: cannot read {}: {error}", p.display()),
                        ));
                    }
                    Err(e) => return Err(e),
                };
                has_mtl = true;
                for (k, e) in entries {
                    mtl.insert(k, (mtl_path.clone(), e));
                }
            }
            _ => {}
        }
    }
    if faces == 0 {
        return Err(SceneError::syntax(
            path,
            None,
            "no faces (no `f` statement with three or more vertices)",
        ));
    }

    let options =
        tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let (models, _) =
        tobj::load_obj_buf(&mut clean.as_bytes(), &options, |_| Ok((Vec::new(), Default::default())))
            .map_err(|e| SceneError::syntax(path, None, format!("tobj: {e}")))?;

    let mut parts = Vec::with_capacity(models.len());
    for m in models {
        let mesh = m.mesh;
        if mesh.indices.is_empty() {
            continue;
        }
        let slot: usize = m.name.parse().ok().filter(|s| *s < slots.len()).ok_or_else(|| {
            SceneError::syntax(path, None, format!("internal: unexpected object {:?}", m.name))
        })?;
        let positions: Vec<Vec3> =
            mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let normals: Vec<Vec3> = if slots[slot].all_normals && mesh.normals.len() == mesh.positions.len() {
            mesh.normals.chunks_exact(3).map(|n| Vec3::new(n[0], n[1], n[2])).collect()
        } else {
            Vec::new()
        };
        let n = positions.len();
        let mut indices = Vec::with_capacity(mesh.indices.len() / 3);
        for t in mesh.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= n) {
                return Err(SceneError::syntax(path, None, "internal: tobj index out of range"));
            }
            indices.push([t[0], t[1], t[2]]);
        }
        parts.push(Part { slot, positions, normals, indices });
    }
    Ok(Obj { slots, parts, has_mtl, mtl, faces })
}

fn three_finite(args: &[&str]) -> Option<[f32; 3]> {
    if args.len() < 3 {
        return None;
    }
    let mut v = [0.0f32; 3];
    for (o, s) in v.iter_mut().zip(args) {
        *o = s.parse().ok().filter(|x: &f32| x.is_finite())?;
    }
    Some(v)
}

/// A 1-based (or negative, relative) OBJ index into `count` elements read so far, as a
/// 0-based index.
fn index(s: &str, count: usize) -> Result<usize, String> {
    let i: i64 = s.parse().map_err(|_| format!("index {s:?} is not an integer"))?;
    let count_i = i64::try_from(count).unwrap_or(i64::MAX);
    let r = if i > 0 && i <= count_i {
        i - 1
    } else if i < 0 && -i <= count_i {
        count_i + i
    } else if i == 0 {
        return Err("index 0 is invalid (OBJ indices start at 1)".into());
    } else {
        return Err(format!("index {i} is out of range ({count} defined so far)"));
    };
    usize::try_from(r).map_err(|_| format!("index {i} is out of range"))
}
