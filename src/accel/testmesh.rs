//! Generated meshes and ray sets for testing and benchmarking the ray-query backends.
//!
//! Everything here is deterministic (driven by [`Sampler`] with `Domain::Iteration`), so the
//! agreement tests and the benchmarks of every backend see exactly the same geometry and rays.

use std::f32::consts::PI;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::geometry::{Aabb, Ray};
use crate::sampling::{Domain, Sampler};

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.positions)
    }

    /// The vertices of triangle `i`.
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        self.indices[i].map(|k| self.positions[k as usize])
    }

    /// The point with barycentrics `(u, v)` (of the second and third vertex) on triangle `i`.
    pub fn point_on(&self, i: usize, u: f32, v: f32) -> Vec3 {
        let [a, b, c] = self.triangle(i);
        a * (1.0 - u - v) + b * u + c * v
    }

    /// Every triangle of the OBJ file at `path` (all its objects, polygons triangulated),
    /// or the loader's error.
    pub fn from_obj(path: &Path) -> Result<Mesh, tobj::LoadError> {
        let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
        let (models, _) = tobj::load_obj(path, &opts)?;
        let mut m = Mesh::default();
        for model in models {
            let part = Mesh {
                positions: model.mesh.positions.chunks_exact(3).map(Vec3::from_slice).collect(),
                indices: model.mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
            };
            m.append(&part);
        }
        Ok(m)
    }

    /// Appends `other`, renumbering its indices.
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.indices.extend(other.indices.iter().map(|t| t.map(|i| i + base)));
    }

    /// Adds the quad `(a, b, c, d)` (in order around its boundary) split into `n × n` cells.
    pub fn add_quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3, n: u32) {
        let base = self.positions.len() as u32;
        for j in 0..=n {
            for i in 0..=n {
                let (s, t) = (i as f32 / n as f32, j as f32 / n as f32);
                let p = a.lerp(b, s).lerp(d.lerp(c, s), t);
                self.positions.push(p);
            }
        }
        let at = |i: u32, j: u32| base + j * (n + 1) + i;
        for j in 0..n {
            for i in 0..n {
                self.indices.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                self.indices.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }

    /// Adds the closed box of half-extents `half` centred at `center`, turned by `angle`
    /// radians about +y, each face split into `n × n` cells.
    pub fn add_box(&mut self, center: Vec3, half: Vec3, angle: f32, n: u32) {
        let (s, c) = angle.sin_cos();
        let p = |x: f32, y: f32, z: f32| {
            let l = Vec3::new(x, y, z) * half;
            center + Vec3::new(c * l.x + s * l.z, l.y, -s * l.x + c * l.z)
        };
        let corners = [
            [p(-1., -1., -1.), p(1., -1., -1.), p(1., -1., 1.), p(-1., -1., 1.)], // bottom
            [p(-1., 1., -1.), p(-1., 1., 1.), p(1., 1., 1.), p(1., 1., -1.)],     // top
            [p(-1., -1., -1.), p(-1., 1., -1.), p(1., 1., -1.), p(1., -1., -1.)], // back
            [p(-1., -1., 1.), p(1., -1., 1.), p(1., 1., 1.), p(-1., 1., 1.)],     // front
            [p(-1., -1., -1.), p(-1., -1., 1.), p(-1., 1., 1.), p(-1., 1., -1.)], // left
            [p(1., -1., -1.), p(1., 1., -1.), p(1., 1., 1.), p(1., -1., 1.)],     // right
        ];
        for [a, b, cc, d] in corners {
            self.add_quad(a, b, cc, d, n);
        }
    }
}

/// A Cornell-box-like closed scene: the unit cube `[0, 1]³` (walls split 4 × 4) holding a short
/// and a tall block turned about +y, plus a small light quad just below the ceiling.
/// 296 triangles.
pub fn cornell_like() -> Mesh {
    let mut m = Mesh::default();
    m.add_box(Vec3::splat(0.5), Vec3::splat(0.5), 0.0, 4);
    m.add_box(Vec3::new(0.68, 0.15, 0.35), Vec3::new(0.15, 0.15, 0.15), -0.29, 2);
    m.add_box(Vec3::new(0.32, 0.3, 0.65), Vec3::new(0.15, 0.3, 0.15), 0.3, 2);
    let y = 0.999;
    m.add_quad(
        Vec3::new(0.4, y, 0.4),
        Vec3::new(0.6, y, 0.4),
        Vec3::new(0.6, y, 0.6),
        Vec3::new(0.4, y, 0.6),
        2,
    );
    m
}

/// A closed, bumpy UV sphere of radius about 1 centred at the origin, with `rings` rings
/// and `segments` segments: `2 · segments · (rings − 1)` triangles (fans at the poles).
pub fn sphere(rings: u32, segments: u32) -> Mesh {
    let rings = rings.max(2);
    let segments = segments.max(3);
    let radius = |theta: f32, phi: f32| 1.0 + 0.05 * (7.0 * theta).sin() * (9.0 * phi).sin();
    let mut m = Mesh::default();
    m.positions.push(Vec3::new(0.0, radius(0.0, 0.0), 0.0));
    for r in 1..rings {
        let theta = PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = 2.0 * PI * s as f32 / segments as f32;
            let d = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            m.positions.push(d * radius(theta, phi));
        }
    }
    let south = m.positions.len() as u32;
    m.positions.push(Vec3::new(0.0, -radius(PI, 0.0), 0.0));
    let at = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    for s in 0..segments {
        m.indices.push([0, at(1, s + 1), at(1, s)]);
        m.indices.push([south, at(rings - 1, s), at(rings - 1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            m.indices.push([at(r, s), at(r, s + 1), at(r + 1, s + 1)]);
            m.indices.push([at(r, s), at(r + 1, s + 1), at(r + 1, s)]);
        }
    }
    m
}

/// A heightfield over `[-1, 1]²` in the xz-plane with `n × n` cells (`2n²` triangles).
pub fn heightfield(n: u32) -> Mesh {
    let mut m = Mesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let x = -1.0 + 2.0 * i as f32 / n as f32;
            let z = -1.0 + 2.0 * j as f32 / n as f32;
            let y = 0.2 * (5.0 * x).sin() * (4.0 * z).cos() + 0.05 * (23.0 * x * z).sin();
            m.positions.push(Vec3::new(x, y, z));
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            m.indices.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            m.indices.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    m
}

/// A closed scene of about `triangles` triangles: a bumpy sphere (almost all of them) inside a
/// box `[-2, 2]³`.
pub fn closed_scene(triangles: u32) -> Mesh {
    let rings = ((triangles as f32 / 4.0).sqrt() as u32).max(2);
    let mut m = sphere(rings, 2 * rings);
    m.add_box(Vec3::ZERO, Vec3::splat(2.0), 0.0, 4);
    m
}

/// A uniformly distributed unit direction.
pub fn uniform_direction(s: &mut Sampler) -> Vec3 {
    let z = 1.0 - 2.0 * s.next_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * s.next_f32();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A uniformly distributed point in `b`.
pub fn point_in(b: &Aabb, s: &mut Sampler) -> Vec3 {
    let t = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32());
    b.min + (b.max - b.min) * t
}

/// `n` incoherent rays: origins uniform in `b` shrunk by 1 % towards its centre, directions
/// uniform, interval `[0, ∞)`.
pub fn random_rays(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let inner = Aabb { min: b.min.lerp(b.center(), 0.01), max: b.max.lerp(b.center(), 0.01) };
    (0..n)
        .map(|k| {
            let mut s = Sampler::new(seed, 0, Domain::Iteration, k as u64);
            Ray::new(point_in(&inner, &mut s), uniform_direction(&mut s))
        })
        .collect()
}

/// A uniformly chosen point on a uniformly chosen triangle of `m`, and the triangle.
pub fn point_on_mesh(m: &Mesh, s: &mut Sampler) -> (Vec3, usize) {
    let i = ((s.next_f32() * m.indices.len() as f32) as usize).min(m.indices.len() - 1);
    let (mut u, mut v) = (s.next_f32(), s.next_f32());
    if u + v > 1.0 {
        (u, v) = (1.0 - u, 1.0 - v);
    }
    (m.point_on(i, u, v), i)
}

/// The gather pattern: `n` shadow segments from `from` to points scattered over `m`'s
/// surface, each ending just short of its target (`tmax = 1 − 1e-4`).
pub fn gather_rays(m: &Mesh, from: Vec3, n: usize, seed: u64) -> Vec<Ray> {
    (0..n)
        .map(|k| {
            let mut s = Sampler::new(seed, 0, Domain::Iteration, k as u64);
            let (target, _) = point_on_mesh(m, &mut s);
            Ray::segment(from, target - from, 1.0 - 1e-4)
        })
        .collect()
}

/// `n` random segments between pairs of points in `b` (occlusion tests between random pairs).
pub fn random_segments(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    (0..n)
        .map(|k| {
            let mut s = Sampler::new(seed, 0, Domain::Iteration, k as u64);
            let p = point_in(b, &mut s);
            let q = point_in(b, &mut s);
            Ray::segment(p, q - p, 1.0)
        })
        .collect()
}

/// The conference room's mesh in the repository (`scenes/conference-room`, 331k triangles, many
/// of them wall- or table-sized): the production scene of `docs/batch.md`.
pub fn conference_room() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/conference-room/conference.obj")
}

/// The project's shared scene folder: `../shared/scenes` beside the checkout, or
/// `../../shared/scenes` from a worktree in `wt/`; the first when neither exists.
pub fn shared_scenes() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    [root.join("../shared/scenes"), root.join("../../shared/scenes")]
        .into_iter()
        .find(|p| p.exists())
        .unwrap_or_else(|| root.join("../shared/scenes"))
}

/// Rays per workload of the accel benchmark ([`Workloads`]), but the gather's.
pub const WORKLOAD_RAYS: usize = 65_536;

/// The ray-query workloads of the accel benchmark over one mesh.
pub struct Workloads {
    /// [`WORKLOAD_RAYS`] incoherent rays (closest hit).
    pub closest: Vec<Ray>,
    /// [`WORKLOAD_RAYS`] random segments in the mesh's box (occlusion).
    pub occluded: Vec<Ray>,
    /// The gather pattern: one point in open space (inside a closed scene's outer box, outside
    /// its contents) to 1,024 points of the surface (occlusion).
    pub gather: Vec<Ray>,
}

impl Workloads {
    pub fn new(m: &Mesh) -> Workloads {
        let b = m.bounds();
        Workloads {
            closest: random_rays(&b, WORKLOAD_RAYS, 11),
            occluded: random_segments(&b, WORKLOAD_RAYS, 12),
            gather: gather_rays(m, b.min.lerp(b.max, 0.85), 1_024, 13),
        }
    }
}
