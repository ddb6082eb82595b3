//! Mitsuba's shapes as world-space triangles.
//!
//! - `rectangle`: the square [−1, 1]² of the plane z = 0, normal +z;
//! - `cube`: the cube [−1, 1]³, normals outwards, flat;
//! - `disk`: the unit disk of the plane z = 0, normal +z, as a fan of [`DISK_SEGMENTS`]
//!   triangles inscribed in the circle;
//! - `sphere` (`center`, `radius`): an analytic sphere ([`crate::scene::SphereShape`],
//!   [`analytic_sphere`]) where `to_world` is a similarity that does not mirror, its material
//!   has no normal or bump map and the scene has fewer than [`crate::accel::MAX_SPHERES`]
//!   before it; otherwise an icosphere subdivided [`SPHERE_SUBDIVISIONS`] times, its vertices
//!   on the sphere and its shading normals the sphere's own, normals outwards;
//! - `obj` ([`obj`]), `ply` and `serialized` ([`from_data`]): meshes read from files.
//!
//! Texture coordinates are Mitsuba 3's (checked against its ray intersections): the rectangle's
//! ((x + 1) / 2, (y + 1) / 2), the cube's per face as Mitsuba's cube mesh has them, the disk's
//! (r, φ / 2π), the sphere's (φ / 2π, θ / π) with θ from +z, interpolated over the triangles
//! (vertices are split at the seam φ = 0 and at the poles, where each triangle's pole vertex
//! takes the φ of its other two); an OBJ file's `vt` with v flipped (1 − v, as Mitsuba's OBJ
//! reader), a PLY or `.serialized` file's as stored (checked: Mitsuba flips neither). A
//! textured mesh without any gets Mitsuba's rule, a point's barycentrics in the file's corner
//! order, whatever `flip_normals` does to the winding ([`barycentric_uvs`]).
//!
//! Each is moved by its `to_world`; `flip_normals` turns it inside out. Mitsuba's analytic
//! shapes (rectangle, disk, sphere) take their normal from `to_world` applied to the normal
//! (its inverse transpose), even where `to_world` mirrors; their triangles are wound to agree.
//! A mesh without vertex normals gets Mitsuba's (the angle-weighted mean of its faces'
//! normals, Thürmer and Wüthrich 1998) unless `face_normals` asks for flat shading.
//!
//! The tessellated disk and sphere (where it is not analytic) are inscribed: their areas are those of the exact shapes
//! times 0.99990 (disk) and 0.9996 (sphere), and so is an emitter's power.

use std::f32::consts::PI;
use std::path::Path;

use glam::{Mat3, Mat4, Vec2, Vec3};

use super::transform::parse_number;
use super::xml::Element;
use crate::geometry::Sphere;
use crate::scene::error::read_text;
use crate::scene::{SceneError, SphereShape};

/// Triangles of the tessellated disk.
pub const DISK_SEGMENTS: u32 = 512;
/// Subdivisions of the icosahedron of a sphere (20 · 4^n triangles).
pub const SPHERE_SUBDIVISIONS: u32 = 5;

/// A triangle mesh in object space.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Empty, or one per position.
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Empty, or one per position (`Vec2::NAN` for a vertex without).
    pub uvs: Vec<Vec2>,
    /// Flat shading asked for.
    pub face_normals: bool,
}

/// A shape's mesh in world space, ready for the scene: unit shading normals per vertex
/// (`Vec3::ZERO` where there are none).
pub struct WorldMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Empty, or one per position.
    pub uvs: Vec<Vec2>,
}

/// Whether the shape's normal comes from its `to_world` (Mitsuba's analytic shapes) rather
/// than from the winding of its triangles.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Normals {
    Analytic,
    Winding,
}

/// The rectangle [−1, 1]² at z = 0, facing +z.
pub fn rectangle() -> Mesh {
    Mesh {
        positions: vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        normals: vec![Vec3::Z; 4],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        face_normals: false,
    }
}

/// The cube [−1, 1]³ as Mitsuba 3's cube mesh: each face with its own four vertices, texture
/// coordinates and flat normal, facing out, in Mitsuba's order.
pub fn cube() -> Mesh {
    // Per face: its normal and its four corners with their texture coordinates.
    const FACES: [([f32; 3], [[f32; 3]; 4]); 6] = [
        ([0.0, -1.0, 0.0], [[1.0, -1.0, -1.0], [1.0, -1.0, 1.0], [-1.0, -1.0, 1.0], [-1.0, -1.0, -1.0]]),
        ([0.0, 1.0, 0.0], [[1.0, 1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]),
        ([1.0, 0.0, 0.0], [[1.0, -1.0, -1.0], [1.0, 1.0, -1.0], [1.0, 1.0, 1.0], [1.0, -1.0, 1.0]]),
        ([0.0, 0.0, 1.0], [[1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, -1.0, 1.0]]),
        ([-1.0, 0.0, 0.0], [[-1.0, -1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, -1.0]]),
        ([0.0, 0.0, -1.0], [[1.0, 1.0, -1.0], [1.0, -1.0, -1.0], [-1.0, -1.0, -1.0], [-1.0, 1.0, -1.0]]),
    ];
    const UV: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let mut m = Mesh::default();
    for (n, corners) in FACES {
        let base = m.positions.len() as u32;
        for (p, uv) in corners.iter().zip(UV) {
            m.positions.push(Vec3::from(*p));
            m.normals.push(Vec3::from(n));
            m.uvs.push(Vec2::from(uv));
        }
        m.triangles.push([base, base + 1, base + 2]);
        m.triangles.push([base + 3, base, base + 2]);
    }
    m.face_normals = true;
    m
}

/// The unit disk at z = 0, facing +z.
/// Its rim vertices are numbered 0 to [`DISK_SEGMENTS`] (the last at φ = 2π, v = 1, where the
/// first is at v = 0), each triangle with its own centre vertex (r = 0, v of its middle).
pub fn disk() -> Mesh {
    let mut m = Mesh::default();
    let n = DISK_SEGMENTS;
    for i in 0..=n {
        let phi = 2.0 * PI * (i % n) as f32 / n as f32;
        m.positions.push(Vec3::new(phi.cos(), phi.sin(), 0.0));
        m.normals.push(Vec3::Z);
        m.uvs.push(Vec2::new(1.0, i as f32 / n as f32));
    }
    for i in 0..n {
        let centre = m.positions.len() as u32;
        m.positions.push(Vec3::ZERO);
        m.normals.push(Vec3::Z);
        m.uvs.push(Vec2::new(0.0, (i as f32 + 0.5) / n as f32));
        m.triangles.push([centre, i, i + 1]);
    }
    m
}

/// The unit sphere about the origin, normals outwards.
pub fn sphere() -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..SPHERE_SUBDIVISIONS {
        let mut midpoint = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push(((positions[a as usize] + positions[b as usize]) * 0.5).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let (ab, bc, ca) =
                (mid(a, b, &mut positions), mid(b, c, &mut positions), mid(c, a, &mut positions));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    // Texture coordinates (φ / 2π, θ / π) per corner: a triangle across the seam φ = 0 takes
    // its small u one turn up, a pole vertex the mean u of the triangle's other two; a vertex
    // is split wherever its corners' coordinates differ.
    let sphere_uv = |p: Vec3| {
        let phi = p.y.atan2(p.x);
        let phi = if phi < 0.0 { phi + 2.0 * PI } else { phi };
        Vec2::new(phi / (2.0 * PI), p.z.clamp(-1.0, 1.0).acos() / PI)
    };
    let mut out = Mesh::default();
    let mut split: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
    for t in &triangles {
        let mut uv = t.map(|i| sphere_uv(positions[i as usize]));
        let pole = t.map(|i| positions[i as usize].truncate().length() < 1e-6);
        let others: Vec<usize> = (0..3).filter(|&k| !pole[k]).collect();
        let (lo, hi) = others.iter().fold((1f32, 0f32), |(lo, hi), &k| (lo.min(uv[k].x), hi.max(uv[k].x)));
        if hi - lo > 0.5 {
            for &k in &others {
                if uv[k].x < 0.5 {
                    uv[k].x += 1.0;
                }
            }
        }
        for k in 0..3 {
            if pole[k] {
                uv[k].x = others.iter().map(|&j| uv[j].x).sum::<f32>() / others.len().max(1) as f32;
            }
        }
        let mut tri = [0u32; 3];
        for k in 0..3 {
            let i = t[k];
            tri[k] = *split.entry((i, uv[k].x.to_bits())).or_insert_with(|| {
                out.positions.push(positions[i as usize]);
                out.uvs.push(uv[k]);
                out.positions.len() as u32 - 1
            });
        }
        out.triangles.push(tri);
    }
    out.normals = out.positions.clone();
    out
}

/// A Wavefront OBJ file as Mitsuba reads it: `v`, `vt`, `vn` and `f` (polygons as fans, a
/// vertex per distinct position/texture/normal triple, negative indices from the end);
/// everything else (materials, groups) is ignored.
pub fn obj(path: &Path) -> Result<Mesh, SceneError> {
    let text = read_text(path)?;
    let err = |line: usize, p: String| SceneError::syntax(path, Some(line), p);
    let (mut v, mut vt, mut vn) = (Vec::new(), Vec::new(), Vec::new());
    let mut map: std::collections::HashMap<(usize, usize, usize), u32> = std::collections::HashMap::new();
    let mut m = Mesh::default();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let mut toks = raw.split('#').next().unwrap_or("").split_whitespace();
        let Some(key) = toks.next() else { continue };
        match key {
            "v" | "vn" => {
                let xyz: Vec<f32> = toks.by_ref().take(3).map_while(parse_number).collect();
                if xyz.len() != 3 {
                    return Err(err(line, format!("{key}: expected three finite numbers")));
                }
                let p = Vec3::new(xyz[0], xyz[1], xyz[2]);
                if key == "v" { v.push(p) } else { vn.push(p) }
            }
            "vt" => {
                let uv: Vec<f32> = toks.by_ref().take(2).map_while(parse_number).collect();
                match uv.as_slice() {
                    // Mitsuba's OBJ reader flips v (an image's first row is at v = 0).
                    [u, v] => vt.push(Vec2::new(*u, 1.0 - *v)),
                    [u] => vt.push(Vec2::new(*u, 1.0)),
                    _ => return Err(err(line, "vt: expected one or two finite numbers".into())),
                }
            }
            "f" => {
                let mut corners = Vec::new();
                for c in toks {
                    let mut parts = c.split('/');
                    let idx = |s: Option<&str>, n: usize, what: &str| -> Result<usize, SceneError> {
                        match s {
                            None | Some("") => Ok(0),
                            Some(s) => {
                                let k: i64 = s.parse().map_err(|_| {
                                    err(
                                        line,
                                        format!("face corner {c:?}: {what} index {s:?} is not a number"),
                                    )
                                })?;
                                let k = if k < 0 { n as i64 + k + 1 } else { k };
                                if k < 1 || k > n as i64 {
                                    return Err(err(
                                        line,
                                        format!(
                                            "face corner {c:?}: {what} index {s} is out of range (the file has {n} so far)"
                                        ),
                                    ));
                                }
                                Ok(k as usize)
                            }
                        }
                    };
                    let p = idx(parts.next(), v.len(), "vertex")?;
                    if p == 0 {
                        return Err(err(line, format!("face corner {c:?}: no vertex index")));
                    }
                    let t = idx(parts.next(), vt.len(), "texture")?;
                    let n = idx(parts.next(), vn.len(), "normal")?;
                    let next = m.positions.len() as u32;
                    let id = *map.entry((p, t, n)).or_insert_with(|| {
                        m.positions.push(v[p - 1]);
                        m.normals.push(if n > 0 { vn[n - 1] } else { Vec3::ZERO });
                        m.uvs.push(if t > 0 { vt[t - 1] } else { Vec2::NAN });
                        next
                    });
                    corners.push(id);
                }
                if corners.len() < 3 {
                    return Err(err(line, format!("a face of {} corners", corners.len())));
                }
                for k in 1..corners.len() - 1 {
                    m.triangles.push([corners[0], corners[k], corners[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if m.triangles.is_empty() {
        return Err(SceneError::syntax(path, None, "no faces"));
    }
    // Mitsuba computes every vertex's normal when the file has none; in a file with some, a
    // corner without one has none (a zero normal: its faces are flat-shaded here).
    if vn.is_empty() {
        m.normals.clear();
    }
    if vt.is_empty() {
        m.uvs.clear();
    }
    Ok(m)
}

/// A mesh read from a PLY or `.serialized` file: its faces, normals and texture coordinates
/// as the file stores them.
pub fn from_data(data: crate::scene::mesh_data::MeshData, path: &Path) -> Result<Mesh, SceneError> {
    if data.triangles.is_empty() {
        return Err(SceneError::syntax(path, None, "no faces"));
    }
    Ok(Mesh {
        positions: data.positions,
        normals: data.normals,
        triangles: data.triangles,
        uvs: data.uvs,
        face_normals: data.face_normals,
    })
}

/// `mesh` moved by `to_world`, turned inside out by `flip`, with shading normals.
pub fn to_world(mesh: Mesh, to_world: Mat4, flip: bool, normals: Normals) -> WorldMesh {
    let linear = Mat3::from_mat4(to_world);
    let normal_matrix = linear.inverse().transpose();
    let positions: Vec<Vec3> = mesh.positions.iter().map(|&p| to_world.transform_point3(p)).collect();
    let mut triangles = mesh.triangles;
    let mut world_normals: Vec<Vec3> = if mesh.face_normals {
        vec![Vec3::ZERO; positions.len()]
    } else if mesh.normals.is_empty() {
        vertex_normals(&positions, &triangles)
    } else {
        mesh.normals.iter().map(|&n| (normal_matrix * n).normalize_or_zero()).collect()
    };
    if flip {
        for n in &mut world_normals {
            *n = -*n;
        }
    }
    // Analytic shapes keep the normal that to_world gives them; their winding follows it.
    let mirrored = linear.determinant() < 0.0;
    if flip ^ (normals == Normals::Analytic && mirrored) {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    WorldMesh { positions, normals: world_normals, triangles, uvs: mesh.uvs }
}

/// Texture coordinates for a textured mesh without any: Mitsuba's rule, each point's
/// barycentrics (b1, b2) in the file's corner order, as per-corner coordinates (0, 0), (1, 0),
/// (0, 1) of vertices of its own (so that the rule holds where `to_world` swapped the winding,
/// `swapped`, which the scene's own barycentric rule would not see).
pub fn barycentric_uvs(mesh: WorldMesh, swapped: bool) -> WorldMesh {
    let mut corners = [Vec2::ZERO, Vec2::X, Vec2::Y];
    if swapped {
        corners.swap(1, 2);
    }
    let mut out =
        WorldMesh { positions: Vec::new(), normals: Vec::new(), triangles: Vec::new(), uvs: Vec::new() };
    for t in &mesh.triangles {
        let base = out.positions.len() as u32;
        for (k, &i) in t.iter().enumerate() {
            out.positions.push(mesh.positions[i as usize]);
            out.normals.push(mesh.normals[i as usize]);
            out.uvs.push(corners[k]);
        }
        out.triangles.push([base, base + 1, base + 2]);
    }
    out
}

/// Mitsuba's vertex normals: each face's unit normal weighted by its angle at the vertex.
fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let v = t.map(|i| positions[i as usize]);
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        if n.length_squared().is_nan() || n.length_squared() <= 0.0 {
            continue;
        }
        let n = n.normalize();
        for j in 0..3 {
            let (a, b) =
                ((v[(j + 1) % 3] - v[j]).normalize_or_zero(), (v[(j + 2) % 3] - v[j]).normalize_or_zero());
            let angle = a.dot(b).clamp(-1.0, 1.0).acos();
            normals[t[j] as usize] += n * angle;
        }
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}

/// The sphere's `center` and `radius` as a transform of the unit sphere.
pub fn sphere_placement(shape: &Element, center: Vec3, radius: f32) -> Result<Mat4, SceneError> {
    if !(radius > 0.0 && radius.is_finite()) {
        return Err(shape.error(format!("radius {radius}: must be a positive number")));
    }
    Ok(Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius)))
}

/// The analytic sphere of a `sphere` shape placed by `to_world` (with its centre and radius),
/// with `flip_normals`: `None` where `to_world` is not a similarity of positive determinant
/// (Mitsuba would draw a sphere there too, but pir keeps tessellating what `to_world` makes
/// of it). Its material is set by the caller.
pub fn analytic_sphere(to_world: Mat4, flip: bool) -> Option<SphereShape> {
    let m = Mat3::from_mat4(to_world);
    let center = to_world.transform_point3(Vec3::ZERO);
    let radius = m.x_axis.length();
    let rotation = m * (1.0 / radius);
    let similar = (rotation.transpose() * rotation).abs_diff_eq(Mat3::IDENTITY, 1e-5);
    let valid =
        similar && rotation.determinant() > 0.0 && radius > 0.0 && radius.is_finite() && center.is_finite();
    valid.then_some(SphereShape { sphere: Sphere { center, radius }, rotation, flip, material: 0 })
}

/// The exact sphere that a `sphere` shape's world-space triangles `mesh` are inscribed in, for
/// next-event estimation by its cone ([`crate::light::SphereLight`]): centre and radius (the
/// largest distance of a vertex from the centre, so that every triangle is inside). `None`
/// where the shape is not a sphere with its front faces outwards: `to_world` (with the
/// placement) not a similarity (an ellipsoid), or `flip_normals` (its light goes inwards,
/// where area sampling serves).
pub fn exact_sphere(mesh: &WorldMesh, to_world: Mat4) -> Option<(Vec3, f32)> {
    let m = Mat3::from_mat4(to_world);
    let center = to_world.transform_point3(Vec3::ZERO);
    let radius = m.x_axis.length();
    let similar = [m.y_axis, m.z_axis].iter().all(|a| (a.length() - radius).abs() <= 1e-5 * radius)
        && [m.x_axis.dot(m.y_axis), m.y_axis.dot(m.z_axis), m.z_axis.dot(m.x_axis)]
            .iter()
            .all(|d| d.abs() <= 1e-5 * radius * radius);
    if !(similar && radius > 0.0 && radius.is_finite() && center.is_finite()) {
        return None;
    }
    let mut max_dist = radius;
    for p in &mesh.positions {
        let d = (*p - center).length();
        if (d - radius).abs() > 1e-4 * radius {
            return None;
        }
        max_dist = max_dist.max(d);
    }
    let outwards = mesh.triangles.iter().all(|t| {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        (b - a).cross(c - a).dot((a + b + c) / 3.0 - center) > 0.0
    });
    outwards.then_some((center, max_dist))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact sphere of a placed sphere: its centre and radius (up to the vertices'
    /// rounding, never less); none for an ellipsoid or a sphere turned inside out.
    #[test]
    fn an_emitting_sphere_knows_its_exact_sphere() {
        let placement =
            Mat4::from_translation(Vec3::new(1.0, 2.0, -3.0)) * Mat4::from_scale(Vec3::splat(0.5));
        let rotation = Mat4::from_rotation_y(0.7);
        let mesh = to_world(sphere(), rotation * placement, false, Normals::Analytic);
        let (c, r) = exact_sphere(&mesh, rotation * placement).unwrap();
        assert!((c - rotation.transform_point3(Vec3::new(1.0, 2.0, -3.0))).length() < 1e-6, "{c}");
        assert!((0.5..0.5 * (1.0 + 1e-6)).contains(&r), "{r}");
        let flipped = to_world(sphere(), placement, true, Normals::Analytic);
        assert!(exact_sphere(&flipped, placement).is_none());
        let ellipsoid = Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0));
        assert!(exact_sphere(&to_world(sphere(), ellipsoid, false, Normals::Analytic), ellipsoid).is_none());
    }

    fn area(m: &WorldMesh) -> f32 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    /// The tessellations' areas against the exact shapes' (what an emitter's power follows),
    /// and their winding: outwards for the sphere and the cube, +z for the rectangle and disk.
    #[test]
    fn tessellations_are_close_and_face_outwards() {
        let sphere = to_world(sphere(), Mat4::IDENTITY, false, Normals::Analytic);
        let ratio = area(&sphere) / (4.0 * PI);
        assert!((0.9994..1.0).contains(&ratio), "sphere {ratio}");
        let disk = to_world(disk(), Mat4::IDENTITY, false, Normals::Analytic);
        let ratio = area(&disk) / PI;
        assert!((0.9999..1.0).contains(&ratio), "disk {ratio}");
        for m in [&sphere, &to_world(cube(), Mat4::IDENTITY, false, Normals::Winding)] {
            for t in &m.triangles {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
            }
        }
        // A mirroring to_world keeps an analytic shape's normal where to_world sends it.
        let mirror = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        let r = to_world(rectangle(), mirror, false, Normals::Analytic);
        let [a, b, c] = r.triangles[0].map(|i| r.positions[i as usize]);
        assert!((b - a).cross(c - a).z > 0.0 && r.normals[0] == Vec3::Z);
        let r = to_world(rectangle(), Mat4::IDENTITY, true, Normals::Analytic);
        let [a, b, c] = r.triangles[0].map(|i| r.positions[i as usize]);
        assert!((b - a).cross(c - a).z < 0.0 && r.normals[0] == -Vec3::Z);
    }
}
