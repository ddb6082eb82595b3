//! The scene: camera, triangles in world space, materials and emitters, read from the TOML
//! format of `shared/scene-format.md` (see [`load`]).

mod camera;
mod error;
mod fingerprint;
mod format;
mod load;
mod mtl;
mod obj;
mod transform;

pub use camera::Camera;
pub use load::{SceneError, load};

use glam::{Vec2, Vec3};
use std::path::PathBuf;

use crate::accel::Hit;
use crate::geometry::{Aabb, Frame, VertexBuffer};
use crate::material::{LocalGeometry, Material};

/// Rendering defaults from the scene's `[render]` table (command-line flags override them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderDefaults {
    /// Largest number of path segments from the camera to an emitter (Mitsuba's convention).
    pub max_depth: u32,
    pub seed: u64,
}

impl Default for RenderDefaults {
    fn default() -> Self {
        RenderDefaults { max_depth: 8, seed: 0 }
    }
}

/// A loaded scene, all meshes merged into one triangle list in world space.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file it was read from.
    pub path: PathBuf,
    pub camera: Camera,
    pub render: RenderDefaults,
    /// World-space vertex positions (padded so that Embree can share them without a copy).
    pub positions: VertexBuffer,
    /// World-space unit shading normals aligned with `positions`; `Vec3::ZERO` where a vertex
    /// has none. A triangle is smooth-shaded only when all three of its vertices have one.
    pub normals: Vec<Vec3>,
    /// Triangles as indices into `positions`.
    pub indices: Vec<[u32; 3]>,
    /// Material index (into `materials`) of every triangle.
    pub tri_material: Vec<u32>,
    pub materials: Vec<Material>,
    /// Bounds of all vertices.
    pub bounds: Aabb,
    /// Zero-area triangles dropped while loading.
    pub degenerate_dropped: usize,
}

/// A point on a surface with everything shading needs.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Unit geometric normal, normalize((b − a) × (c − a)).
    pub ng: Vec3,
    /// Shading frame; its `n` is the interpolated vertex normal (or `ng`).
    pub frame: Frame,
    pub prim: u32,
    pub material: u32,
}

impl SurfacePoint {
    /// What a BSDF needs of the point: its normal and shading frame.
    #[inline]
    pub fn geometry(&self) -> LocalGeometry {
        LocalGeometry { ng: self.ng, frame: self.frame }
    }
}

impl Scene {
    pub fn triangle(&self, prim: u32) -> [Vec3; 3] {
        let [a, b, c] = self.indices[prim as usize];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    pub fn material_of(&self, prim: u32) -> &Material {
        &self.materials[self.tri_material[prim as usize] as usize]
    }

    /// Area of a triangle.
    pub fn area(&self, prim: u32) -> f32 {
        let [a, b, c] = self.triangle(prim);
        0.5 * (b - a).cross(c - a).length()
    }

    /// The surface point at barycentrics `(u, v)` of triangle `prim`: the one function that
    /// turns any backend's hit (or a sampled point) into shading data.
    pub fn surface_at(&self, prim: u32, uv: Vec2) -> SurfacePoint {
        let [ia, ib, ic] = self.indices[prim as usize];
        let [a, b, c] = self.triangle(prim);
        let w = 1.0 - uv.x - uv.y;
        let p = a * w + b * uv.x + c * uv.y;
        let ng = (b - a).cross(c - a).normalize();
        let (na, nb, nc) = (self.normals[ia as usize], self.normals[ib as usize], self.normals[ic as usize]);
        let mut ns = ng;
        if na != Vec3::ZERO && nb != Vec3::ZERO && nc != Vec3::ZERO {
            let n = (na * w + nb * uv.x + nc * uv.y).normalize_or_zero();
            if n != Vec3::ZERO {
                ns = n;
            }
        }
        SurfacePoint {
            p,
            ng,
            frame: Frame::from_normal(ns),
            prim,
            material: self.tri_material[prim as usize],
        }
    }

    /// The surface point of a ray's hit; the position is recomputed from the barycentrics.
    pub fn surface_of_hit(&self, hit: &Hit) -> SurfacePoint {
        self.surface_at(hit.prim, Vec2::new(hit.u, hit.v))
    }
}
