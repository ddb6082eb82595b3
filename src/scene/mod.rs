//! The scene: camera, triangles in world space, materials and emitters, read from the TOML
//! format of `shared/scene-format.md` or from a Mitsuba 3 scene file ([`mitsuba`]); see
//! [`load`].

mod camera;
mod error;
mod filter;
mod fingerprint;
mod format;
mod load;
pub mod mesh_data;
pub mod mitsuba;
mod mtl;
mod obj;
pub mod ply;
mod repeated;
pub mod serialized;
mod spheres;
mod transform;

pub use camera::{Camera, CameraRays, FovAxis, LensConnection, ThinLens};
pub use filter::Filter;
pub use load::{SceneError, load, load_with};
pub use spheres::SphereShape;

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
    /// The camera path's vertex (counted from 1, the camera ray's hit) from whose
    /// continuation on Russian roulette plays (Mitsuba's `rr_depth`; the TOML format's is
    /// always [`DEFAULT_RR_DEPTH`]). Unbiased at any value: it changes the noise only.
    pub rr_depth: u32,
}

/// Where camera paths start Russian roulette unless a Mitsuba scene says otherwise: Mitsuba 3's
/// default `rr_depth` (`docs/integrator-measurements.md`, "Russian roulette").
pub const DEFAULT_RR_DEPTH: u32 = 5;

impl Default for RenderDefaults {
    fn default() -> Self {
        RenderDefaults { max_depth: 8, seed: 0, rr_depth: DEFAULT_RR_DEPTH }
    }
}

/// A loaded scene, all meshes merged into one triangle list in world space.
///
/// Its fields are private so that every scene holds the invariants that shading and the
/// accelerators rely on, checked once by [`Scene::new`]: finite vertices, one (zero or unit)
/// shading normal per vertex, triangles of non-zero area with indices in range, and a valid
/// material for every triangle.
#[derive(Clone, Debug)]
pub struct Scene {
    path: PathBuf,
    camera: Camera,
    render: RenderDefaults,
    positions: VertexBuffer,
    normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, empty when no mesh of the scene has any
    /// ([`Geometry::uvs`]).
    uvs: Vec<Vec2>,
    indices: Vec<[u32; 3]>,
    tri_material: Vec<u32>,
    /// Per triangle, what turning a hit into a surface point needs, in one place.
    shading: Vec<TriangleShading>,
    materials: Vec<Material>,
    bounds: Aabb,
    degenerate_dropped: usize,
    /// The film's reconstruction filter (box unless a Mitsuba file names another).
    filter: Filter,
    /// Lights other than emitting triangles (point, spot, directional, environments).
    lights: Vec<crate::light::Light>,
    /// The emitting spheres whose triangles next-event estimation samples by the cone of
    /// the exact sphere (Mitsuba's `sphere` shapes).
    sphere_lights: Vec<crate::light::SphereLight>,
    /// Analytic spheres, primitives `indices.len()..` ([`Scene::with_spheres`]).
    spheres: Vec<SphereShape>,
}

/// What [`Scene::surface_at`] needs of a triangle, computed once at load: its corners, the
/// shading frame of its unit geometric normal, its material, whether it is smooth-shaded and
/// whether its vertices have texture coordinates.
/// One record per triangle (80 bytes) instead of an index load, three position loads, a cross
/// product, a square root and (for flat triangles, whose shading frame it is) the frame's
/// construction per hit.
#[derive(Clone, Copy, Debug)]
struct TriangleShading {
    corners: [Vec3; 3],
    /// `Frame::from_normal(ng)`, ng = normalize((b − a) × (c − a)) its `n`.
    flat: Frame,
    material: u32,
    /// All three vertices carry a shading normal.
    smooth: bool,
    /// Its material scatters on both sides ([`Material::two_sided`]).
    two_sided: bool,
    /// All three vertices have texture coordinates; otherwise the point's are its
    /// barycentrics (Mitsuba's rule for meshes without them).
    textured: bool,
    /// Its material has a normal or bump map ([`crate::material::shading_map`]).
    mapped: bool,
    /// The primitive is an analytic sphere ([`spheres`]): only `material` and `two_sided`
    /// hold, and every surface function asks [`Scene::sphere_of`].
    sphere: bool,
}

/// The triangles of a scene, as [`Scene::new`] takes them.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    /// World-space vertex positions.
    pub positions: Vec<Vec3>,
    /// World-space unit shading normals aligned with `positions`; `Vec3::ZERO` where a vertex
    /// has none. A triangle is smooth-shaded only when all three of its vertices have one.
    pub normals: Vec<Vec3>,
    /// Texture coordinates: empty, or aligned with `positions` with `Vec2::NAN` where a
    /// vertex has none (Mitsuba's convention: v = 0 at the top row of an image).
    pub uvs: Vec<Vec2>,
    /// Triangles as indices into `positions`.
    pub indices: Vec<[u32; 3]>,
    /// Material index (into the scene's materials) of every triangle.
    pub tri_material: Vec<u32>,
    /// Zero-area triangles dropped while loading (reported, not stored).
    pub degenerate_dropped: usize,
}

impl Geometry {
    /// Flat-shaded triangles without texture coordinates (scenes built in code).
    pub fn flat(positions: Vec<Vec3>, indices: Vec<[u32; 3]>, tri_material: Vec<u32>) -> Geometry {
        let normals = vec![Vec3::ZERO; positions.len()];
        Geometry { positions, normals, uvs: Vec::new(), indices, tri_material, degenerate_dropped: 0 }
    }
}

impl Scene {
    /// A scene read from `path` (the name its errors carry), checking its invariants.
    pub fn new(
        path: PathBuf,
        camera: Camera,
        render: RenderDefaults,
        geometry: Geometry,
        materials: Vec<Material>,
    ) -> Result<Scene, SceneError> {
        let invalid = |problem: String| SceneError::Invalid { path: path.clone(), problem };
        let Geometry { positions, normals, uvs, indices, tri_material, degenerate_dropped } = geometry;
        if let Some(p) = positions.iter().find(|p| !p.is_finite()) {
            return Err(invalid(format!("vertex {p} is not finite")));
        }
        if normals.len() != positions.len() {
            return Err(invalid(format!("{} normals for {} vertices", normals.len(), positions.len())));
        }
        if let Some(n) = normals.iter().find(|n| **n != Vec3::ZERO && !n.is_normalized()) {
            return Err(invalid(format!("shading normal {n} is neither zero nor unit")));
        }
        if !uvs.is_empty() && uvs.len() != positions.len() {
            return Err(invalid(format!(
                "{} texture coordinates for {} vertices",
                uvs.len(),
                positions.len()
            )));
        }
        if let Some(uv) = uvs.iter().find(|uv| !uv.is_finite() && !uv.is_nan()) {
            return Err(invalid(format!("texture coordinates {uv} are not finite")));
        }
        if indices.is_empty() {
            return Err(invalid("no triangles".into()));
        }
        if tri_material.len() != indices.len() {
            return Err(invalid(format!(
                "{} material slots for {} triangles",
                tri_material.len(),
                indices.len()
            )));
        }
        for (t, (tri, &m)) in indices.iter().zip(&tri_material).enumerate() {
            if let Some(i) = tri.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(invalid(format!(
                    "triangle {t}: index {i} is out of range ({} vertices)",
                    positions.len()
                )));
            }
            let [a, b, c] = tri.map(|i| positions[i as usize]);
            if !(b - a).cross(c - a).normalize().is_finite() {
                return Err(invalid(format!("triangle {t} is degenerate")));
            }
            if m as usize >= materials.len() {
                return Err(invalid(format!("triangle {t}: material {m} of {}", materials.len())));
            }
        }
        let bounds = Aabb::from_points(&positions);
        let shading = indices
            .iter()
            .zip(&tri_material)
            .map(|(tri, &material)| {
                let [a, b, c] = tri.map(|i| positions[i as usize]);
                TriangleShading {
                    corners: [a, b, c],
                    flat: Frame::from_normal((b - a).cross(c - a).normalize()),
                    material,
                    smooth: tri.iter().all(|&i| normals[i as usize] != Vec3::ZERO),
                    two_sided: materials[material as usize].two_sided,
                    textured: !uvs.is_empty() && tri.iter().all(|&i| uvs[i as usize].is_finite()),
                    mapped: materials[material as usize].textures.as_ref().is_some_and(|t| t.map.is_some()),
                    sphere: false,
                }
            })
            .collect();
        Ok(Scene {
            path,
            camera,
            render,
            positions: positions.into(),
            normals,
            uvs,
            indices,
            tri_material,
            shading,
            materials,
            bounds,
            degenerate_dropped,
            filter: Filter::Box,
            lights: Vec::new(),
            sphere_lights: Vec::new(),
            spheres: Vec::new(),
        })
    }

    /// The scene with `lights` besides its emitting triangles.
    pub fn with_lights(mut self, lights: Vec<crate::light::Light>) -> Scene {
        self.lights = lights;
        self
    }

    /// Lights other than emitting triangles.
    pub fn lights(&self) -> &[crate::light::Light] {
        &self.lights
    }

    /// The scene with `spheres`: emitting spheres, each an analytic sphere's primitive or the
    /// exact sphere that a consecutive range of its triangles tessellates (inscribed, front
    /// faces outwards). Spheres whose range is out of bounds or not in increasing order are an
    /// error.
    pub fn with_sphere_lights(
        mut self,
        spheres: Vec<crate::light::SphereLight>,
    ) -> Result<Scene, SceneError> {
        let mut end = 0;
        for s in &spheres {
            if s.prims.start < end || s.prims.start >= s.prims.end || s.prims.end as usize > self.prim_count()
            {
                return Err(SceneError::Invalid {
                    path: self.path.clone(),
                    problem: format!("emitting sphere of triangles {:?}: out of range or order", s.prims),
                });
            }
            end = s.prims.end;
        }
        self.sphere_lights = spheres;
        Ok(self)
    }

    /// The emitting spheres ([`Scene::with_sphere_lights`]), in triangle order.
    pub fn sphere_lights(&self) -> &[crate::light::SphereLight] {
        &self.sphere_lights
    }

    /// The sphere around the triangles' bounding box, as Mitsuba computes it: centre and
    /// radius (infinite lights' power and light paths start from it).
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let c = (self.bounds.min + self.bounds.max) * 0.5;
        (c, (self.bounds.max - c).length())
    }

    /// The scene file it was read from.
    pub fn path(&self) -> &std::path::Path {
        &self.path
    }
    pub fn camera(&self) -> &Camera {
        &self.camera
    }
    /// The `[render]` defaults of the scene file.
    pub fn defaults(&self) -> RenderDefaults {
        self.render
    }
    /// World-space vertex positions (padded so that Embree can share them without a copy).
    pub fn positions(&self) -> &VertexBuffer {
        &self.positions
    }
    /// Per-vertex shading normals (`Vec3::ZERO` where a vertex has none).
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }
    /// Per-vertex texture coordinates (empty when no mesh has any; `Vec2::NAN` for vertices
    /// without).
    pub fn uvs(&self) -> &[Vec2] {
        &self.uvs
    }
    /// Triangles as indices into [`Scene::positions`].
    pub fn indices(&self) -> &[[u32; 3]] {
        &self.indices
    }
    /// The material (index into [`Scene::materials`]) of every triangle.
    pub fn triangle_materials(&self) -> &[u32] {
        &self.tri_material
    }
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }
    /// A material by index (a [`SurfacePoint::material`]).
    #[inline]
    pub fn material(&self, index: u32) -> &Material {
        &self.materials[index as usize]
    }
    /// The BSDF at a surface point: its material's, with the textures evaluated at its uv.
    #[inline(always)]
    pub fn bsdf_at(&self, sp: &SurfacePoint) -> crate::material::Bsdf {
        self.materials[sp.material as usize].bsdf_at(sp.uv)
    }
    /// Bounds of all vertices.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }
    /// Zero-area triangles dropped while loading.
    /// The film's reconstruction filter.
    pub fn filter(&self) -> Filter {
        self.filter
    }

    /// Sets the film's reconstruction filter (a Mitsuba file's `rfilter`).
    pub fn set_filter(&mut self, filter: Filter) {
        self.filter = filter;
    }

    pub fn degenerate_dropped(&self) -> usize {
        self.degenerate_dropped
    }
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
    /// Texture coordinates: the vertices' interpolated, or the barycentrics where the mesh has
    /// none.
    pub uv: Vec2,
    /// Seen from behind a two-sided material: `ng` and `frame` are flipped towards the viewer
    /// ([`Scene::surface_of_hit`]), and the point emits nothing.
    pub back: bool,
}

impl SurfacePoint {
    /// The geometric normal on the side that a ray along `dir` sees.
    #[inline]
    pub fn facing(&self, dir: Vec3) -> Vec3 {
        if self.ng.dot(dir) > 0.0 { -self.ng } else { self.ng }
    }

    /// The radiance `emission` that the point emits towards `w`: on its front face only.
    #[inline]
    pub fn emitted(&self, emission: Vec3, w: Vec3) -> Vec3 {
        if self.back { Vec3::ZERO } else { crate::light::emitted(emission, self.ng, w) }
    }

    /// What a BSDF needs of the point: its normal and shading frame.
    #[inline]
    pub fn geometry(&self) -> LocalGeometry {
        LocalGeometry { ng: self.ng, frame: self.frame }
    }
}

impl Scene {
    #[inline]
    pub fn triangle(&self, prim: u32) -> [Vec3; 3] {
        self.shading[prim as usize].corners
    }

    #[inline]
    pub fn material_of(&self, prim: u32) -> &Material {
        &self.materials[self.shading[prim as usize].material as usize]
    }

    /// A point of triangle `prim` at barycentrics `(u, v)` with the triangle's unit geometric
    /// normal (of a sphere at its octahedral coordinates, [`spheres`]): the part of
    /// [`Scene::surface_at`] that emitter sampling needs.
    #[inline]
    pub fn point_at(&self, prim: u32, uv: Vec2) -> (Vec3, Vec3) {
        let t = &self.shading[prim as usize];
        if t.sphere
            && let Some(s) = self.sphere_of(prim)
        {
            return Self::sphere_point(s, uv);
        }
        let [a, b, c] = t.corners;
        (a * (1.0 - uv.x - uv.y) + b * uv.x + c * uv.y, t.flat.n)
    }

    /// Area of a primitive.
    pub fn area(&self, prim: u32) -> f32 {
        if let Some(s) = self.sphere_of(prim) {
            return s.sphere.area();
        }
        let [a, b, c] = self.triangle(prim);
        0.5 * (b - a).cross(c - a).length()
    }

    /// The surface point at barycentrics `(u, v)` of triangle `prim` (of a sphere at its
    /// octahedral coordinates, [`spheres`]): the one function that turns any backend's hit (or
    /// a sampled point) into shading data. Its frame is the perturbed one where the material
    /// has a normal or bump map.
    #[inline]
    pub fn surface_at(&self, prim: u32, uv: Vec2) -> SurfacePoint {
        let sp = self.surface_unmapped(prim, uv);
        if self.shading[prim as usize].mapped { self.mapped(sp, false) } else { sp }
    }

    /// [`Scene::surface_at`] with the unperturbed shading frame.
    #[inline(always)]
    fn surface_unmapped(&self, prim: u32, uv: Vec2) -> SurfacePoint {
        let t = &self.shading[prim as usize];
        if t.sphere
            && let Some(s) = self.sphere_of(prim)
        {
            return Self::sphere_surface(s, prim, uv);
        }
        let [a, b, c] = t.corners;
        let w = 1.0 - uv.x - uv.y;
        let p = a * w + b * uv.x + c * uv.y;
        let ng = t.flat.n;
        let mut frame = t.flat;
        let tex = self.texture_coordinates(prim, uv);
        if t.smooth {
            let [ia, ib, ic] = self.indices[prim as usize];
            let (na, nb, nc) =
                (self.normals[ia as usize], self.normals[ib as usize], self.normals[ic as usize]);
            let n = (na * w + nb * uv.x + nc * uv.y).normalize_or_zero();
            if n != Vec3::ZERO {
                frame = Frame::from_normal(n);
            }
        }
        SurfacePoint { p, ng, frame, prim, material: t.material, uv: tex, back: false }
    }

    /// The texture coordinates at barycentrics `(u, v)` of triangle `prim`: its vertices'
    /// interpolated where the triangle has some, else the barycentrics themselves; a sphere's
    /// are Mitsuba's (φ / 2π, θ / π).
    #[inline(always)]
    fn texture_coordinates(&self, prim: u32, uv: Vec2) -> Vec2 {
        let t = &self.shading[prim as usize];
        if t.sphere
            && let Some(s) = self.sphere_of(prim)
        {
            return Self::sphere_texture_coordinates(s, uv);
        }
        if !t.textured {
            return uv;
        }
        let [ia, ib, ic] = self.indices[prim as usize];
        let (ta, tb, tc) = (self.uvs[ia as usize], self.uvs[ib as usize], self.uvs[ic as usize]);
        ta * (1.0 - uv.x - uv.y) + tb * uv.x + tc * uv.y
    }

    /// The radiance emitted by the front face of triangle `prim` at barycentrics `(u, v)`
    /// ([`Material::emission_at`]).
    #[inline]
    pub fn emission_at(&self, prim: u32, uv: Vec2) -> Vec3 {
        let m = self.material_of(prim);
        match m.textures.as_deref().and_then(|t| t.get(crate::material::Slot::Emission)) {
            None => m.emission,
            Some(texture) => texture.eval(self.texture_coordinates(prim, uv)),
        }
    }

    /// The surface point of the hit of a ray of direction `dir`; the position is recomputed
    /// from the barycentrics. On a two-sided material seen from behind (`dir` along `ng`) the
    /// normals are flipped towards the ray, so that the BSDF scatters on that side as on the
    /// front, and the point is marked [`SurfacePoint::back`].
    #[inline(always)]
    pub fn surface_of_hit(&self, hit: &Hit, dir: Vec3) -> SurfacePoint {
        let mut sp = self.surface_unmapped(hit.prim, Vec2::new(hit.u, hit.v));
        let t = &self.shading[hit.prim as usize];
        if t.mapped {
            return self.mapped(sp, t.two_sided && sp.ng.dot(dir) > 0.0);
        }
        if t.two_sided && sp.ng.dot(dir) > 0.0 {
            sp.ng = -sp.ng;
            sp.frame = Frame { s: sp.frame.s, t: -sp.frame.t, n: -sp.frame.n };
            sp.back = true;
        }
        sp
    }
}

impl Scene {
    /// `sp` (of [`Scene::surface_unmapped`], on a triangle whose material has a normal or bump
    /// map) with the map's perturbed frame, seen from the `back` of its two-sided material or
    /// from the front.
    #[inline(never)]
    fn mapped(&self, mut sp: SurfacePoint, back: bool) -> SurfacePoint {
        let t = &self.shading[sp.prim as usize];
        let Some(map) = self.materials[t.material as usize].textures.as_ref().and_then(|t| t.map.as_ref())
        else {
            return sp;
        };
        let uvs = if t.textured {
            self.indices[sp.prim as usize].map(|i| self.uvs[i as usize])
        } else {
            [Vec2::ZERO, Vec2::X, Vec2::Y]
        };
        let g = crate::material::shading_map::Tangents::of_triangle(t.corners, uvs, sp.ng, sp.frame.n);
        sp.frame = map.frame(&g, sp.uv);
        if back {
            sp.frame = map.back_frame(sp.frame, g.n);
            sp.ng = -sp.ng;
            sp.back = true;
        }
        sp
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Bsdf;

    /// One triangle of an emitting white material.
    pub(super) fn parts() -> (Geometry, Vec<Material>) {
        let geometry = Geometry::flat(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]], vec![0]);
        let m = Material {
            name: "m".into(),
            bsdf: Bsdf::Diffuse { albedo: Vec3::ONE },
            emission: Vec3::ONE,
            two_sided: false,
            textures: None,
        };
        (geometry, vec![m])
    }

    fn build(geometry: Geometry, materials: Vec<Material>) -> Result<Scene, String> {
        let camera = Camera::pinhole(Vec3::Z, Vec3::ZERO, Vec3::Y, 40.0, 4, 4);
        Scene::new("t.toml".into(), camera, RenderDefaults::default(), geometry, materials)
            .map_err(|e| e.to_string())
    }

    /// A hit from behind a two-sided material flips the normals towards the ray (a
    /// right-handed frame) and marks the point as a back, which emits nothing; a one-sided
    /// material is left as it is.
    #[test]
    fn two_sided_hits_from_behind_face_the_ray() {
        for two_sided in [false, true] {
            let (g, mut m) = parts();
            m[0].two_sided = two_sided;
            let s = build(g, m).unwrap();
            let hit = Hit { t: 1.0, prim: 0, u: 0.25, v: 0.25 };
            let front = s.surface_of_hit(&hit, -Vec3::Z);
            assert!(!front.back && front.ng == Vec3::Z);
            assert_eq!(front.emitted(Vec3::ONE, Vec3::Z), Vec3::ONE);
            let back = s.surface_of_hit(&hit, Vec3::Z);
            assert_eq!(back.back, two_sided);
            let ng = if two_sided { -Vec3::Z } else { Vec3::Z };
            assert_eq!((back.ng, back.frame.n), (ng, ng));
            let f = back.frame;
            assert!((f.s.cross(f.t) - f.n).length() < 1e-6, "{f:?}");
            assert_eq!(back.emitted(Vec3::ONE, -Vec3::Z), Vec3::ZERO);
        }
    }

    /// A point's texture coordinates interpolate its triangle's vertices' and are its
    /// barycentrics where a vertex has none.
    #[test]
    fn texture_coordinates_interpolate_or_are_the_barycentrics() {
        let (mut g, m) = parts();
        let at = Vec2::new(0.25, 0.5);
        assert_eq!(build(g.clone(), m.clone()).unwrap().surface_at(0, at).uv, at);
        g.uvs = vec![Vec2::new(0.5, 1.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 0.0)];
        let s = build(g.clone(), m.clone()).unwrap();
        assert_eq!(s.surface_at(0, at).uv, Vec2::new(0.375, 0.5));
        assert_eq!(s.surface_at(0, Vec2::new(1.0, 0.0)).uv, Vec2::new(1.0, 1.0));
        g.uvs[2] = Vec2::NAN;
        assert_eq!(build(g, m).unwrap().surface_at(0, at).uv, at);
    }

    #[test]
    fn new_checks_every_invariant_and_names_the_scene() {
        let (g, m) = parts();
        let s = build(g.clone(), m.clone()).unwrap();
        assert_eq!((s.triangle_count(), s.bounds().max), (1, Vec3::new(1.0, 1.0, 0.0)));
        type Break = fn(&mut Geometry);
        let broken: [(&str, Break); 8] = [
            ("2 texture coordinates for 3 vertices", |g| g.uvs = vec![Vec2::ZERO; 2]),
            ("texture coordinates [inf, 0] are not finite", |g| {
                g.uvs = vec![Vec2::new(f32::INFINITY, 0.0); 3]
            }),
            ("not finite", |g| g.positions[1].x = f32::NAN),
            ("2 normals for 3 vertices", |g| g.normals.truncate(2)),
            ("neither zero nor unit", |g| g.normals[0] = Vec3::splat(2.0)),
            ("index 3 is out of range", |g| g.indices[0][2] = 3),
            ("degenerate", |g| g.positions[2] = Vec3::X * 2.0),
            ("material 1 of 1", |g| g.tri_material[0] = 1),
        ];
        for (want, breaks) in broken {
            let mut g = g.clone();
            breaks(&mut g);
            let e = build(g, m.clone()).unwrap_err();
            assert!(e.starts_with("t.toml: ") && e.contains(want), "{e:?} lacks {want:?}");
        }
        let e = build(Geometry { indices: vec![], tri_material: vec![], ..g }, m).unwrap_err();
        assert!(e.contains("no triangles"), "{e}");
    }
}
