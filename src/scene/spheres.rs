//! Analytic spheres in a scene (Mitsuba's `sphere` shapes): primitives after the triangles,
//! sphere `k` being primitive `triangle_count + k`. Their surface points are exact: a
//! point's two numbers are the octahedral encoding of its direction from the centre
//! ([`crate::geometry::octahedral_encode`]), which hits, sampled emitter points and stored
//! vertices carry where a triangle's would carry barycentrics.
//!
//! As Mitsuba 3's `Sphere`: the geometric and shading normal is the direction from the centre
//! (inwards with `flip_normals`), the tangent `s` is ∂p/∂u, and the texture coordinates are
//! (φ / 2π, θ / π) of the direction in the sphere's own frame (θ from its +z, φ from its +x
//! towards +y), its frame being `to_world`'s rotation.

use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::{PI, TAU};

use super::{Scene, SceneError, SurfacePoint, TriangleShading};
use crate::accel::{Accelerator, Backend, MAX_SPHERES, WithSpheres, build_accelerator};
use crate::geometry::{Frame, Sphere, octahedral_decode, octahedral_encode};

/// A sphere of the scene, as [`Scene::with_spheres`] takes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereShape {
    pub sphere: Sphere,
    /// The sphere's frame: `to_world`'s rotation (orthonormal, determinant +1).
    pub rotation: Mat3,
    /// Normals point inwards (Mitsuba's `flip_normals`): the inside is the front.
    pub flip: bool,
    /// Index into the scene's materials.
    pub material: u32,
}

impl Scene {
    /// The scene with analytic `spheres` after its triangles. Each must have a finite centre,
    /// a positive finite radius, an orthonormal right-handed frame and a material of the
    /// scene without a normal or bump map; at most [`MAX_SPHERES`].
    pub fn with_spheres(mut self, spheres: Vec<SphereShape>) -> Result<Scene, SceneError> {
        let invalid = |problem: String| SceneError::Invalid { path: self.path.clone(), problem };
        if spheres.len() > MAX_SPHERES {
            return Err(invalid(format!("{} analytic spheres: at most {MAX_SPHERES}", spheres.len())));
        }
        for (k, s) in spheres.iter().enumerate() {
            let Sphere { center, radius } = s.sphere;
            let r = s.rotation;
            let orthonormal = (r.transpose() * r).abs_diff_eq(Mat3::IDENTITY, 1e-4) && r.determinant() > 0.0;
            let material = self.materials.get(s.material as usize);
            if !(center.is_finite() && radius > 0.0 && radius.is_finite() && orthonormal) {
                return Err(invalid(format!("sphere {k}: centre {center}, radius {radius}, frame {r}")));
            }
            match material {
                None => {
                    return Err(invalid(format!(
                        "sphere {k}: material {} of {}",
                        s.material,
                        self.materials.len()
                    )));
                }
                Some(m) if m.textures.as_ref().is_some_and(|t| t.map.is_some()) => {
                    return Err(invalid(format!(
                        "sphere {k}: material {:?} has a normal or bump map",
                        m.name
                    )));
                }
                Some(_) => {}
            }
        }
        for s in &spheres {
            let m = &self.materials[s.material as usize];
            self.shading.push(TriangleShading {
                corners: [s.sphere.center; 3],
                flat: Frame { s: s.rotation.x_axis, t: s.rotation.y_axis, n: s.rotation.z_axis },
                material: s.material,
                smooth: false,
                two_sided: m.two_sided,
                textured: false,
                mapped: false,
                sphere: true,
            });
            let r = Vec3::splat(s.sphere.radius);
            self.bounds = self.bounds.grow(s.sphere.center - r).grow(s.sphere.center + r);
        }
        self.spheres = spheres;
        Ok(self)
    }

    /// The analytic spheres, primitives [`Scene::triangle_count`] and on.
    pub fn spheres(&self) -> &[SphereShape] {
        &self.spheres
    }

    /// Every primitive: the triangles, then the spheres.
    pub fn prim_count(&self) -> usize {
        self.indices.len() + self.spheres.len()
    }

    /// The sphere that primitive `prim` is, if it is one.
    #[inline]
    pub fn sphere_of(&self, prim: u32) -> Option<&SphereShape> {
        self.spheres.get((prim as usize).checked_sub(self.indices.len())?)
    }

    /// The point of sphere `s` at octahedral coordinates `e`, and its geometric normal.
    #[inline]
    pub(super) fn sphere_point(s: &SphereShape, e: Vec2) -> (Vec3, Vec3) {
        let n = octahedral_decode(e);
        (s.sphere.point(n), if s.flip { -n } else { n })
    }

    /// The surface point of sphere `s` (primitive `prim`) at octahedral coordinates `e`.
    #[inline(never)]
    pub(super) fn sphere_surface(s: &SphereShape, prim: u32, e: Vec2) -> SurfacePoint {
        let n = octahedral_decode(e);
        let local = s.rotation.transpose() * n;
        let ng = if s.flip { -n } else { n };
        // ∂p/∂u ∝ the rotation of (−y, x, 0); none at the poles.
        let du = s.rotation * Vec3::new(-local.y, local.x, 0.0);
        let tangent = du - ng * ng.dot(du);
        let frame = if tangent.length_squared() > 1e-12 {
            let t = tangent.normalize();
            Frame { s: t, t: ng.cross(t), n: ng }
        } else {
            Frame::from_normal(ng)
        };
        SurfacePoint {
            p: s.sphere.point(n),
            ng,
            frame,
            prim,
            material: s.material,
            uv: sphere_uv(local),
            back: false,
        }
    }

    /// The texture coordinates of sphere `s` at octahedral coordinates `e`.
    #[inline]
    pub(super) fn sphere_texture_coordinates(s: &SphereShape, e: Vec2) -> Vec2 {
        sphere_uv(s.rotation.transpose() * octahedral_decode(e))
    }

    /// The ray-query backend of this scene: its triangles in `backend`, its analytic spheres
    /// beside them ([`WithSpheres`]).
    pub fn accelerator(&self, backend: Backend) -> Result<Box<dyn Accelerator + '_>, String> {
        let triangles = build_accelerator(backend, &self.positions, &self.indices)?;
        if self.spheres.is_empty() {
            return Ok(triangles);
        }
        let spheres = self.spheres.iter().map(|s| s.sphere).collect();
        Ok(Box::new(WithSpheres::new(triangles, spheres, self.indices.len() as u32)))
    }

    /// The surface coordinates of a point uniform over primitive `prim`'s area, from two
    /// uniform numbers: barycentrics on a triangle, octahedral coordinates on a sphere.
    #[inline]
    pub fn uniform_point(&self, prim: u32, u: Vec2) -> Vec2 {
        match self.sphere_of(prim) {
            None => crate::sampling::uniform_triangle(u),
            Some(_) => octahedral_encode(crate::light::constant::uniform_sphere(u)),
        }
    }
}

/// Mitsuba's texture coordinates of the unit direction `local` in a sphere's frame.
#[inline]
fn sphere_uv(local: Vec3) -> Vec2 {
    let mut phi = local.y.atan2(local.x);
    if phi < 0.0 {
        phi += TAU;
    }
    Vec2::new(phi / TAU, local.z.clamp(-1.0, 1.0).acos() / PI)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, RenderDefaults};

    fn scene_with(spheres: Vec<SphereShape>) -> Result<Scene, SceneError> {
        let (geometry, materials) = crate::scene::tests::parts();
        let camera = Camera::pinhole(Vec3::Z * 5.0, Vec3::ZERO, Vec3::Y, 40.0, 4, 4);
        Scene::new("s.xml".into(), camera, RenderDefaults::default(), geometry, materials)?
            .with_spheres(spheres)
    }

    fn shape(flip: bool) -> SphereShape {
        // The sphere's +z is the world's +x.
        let rotation = Mat3::from_rotation_y(std::f32::consts::FRAC_PI_2);
        SphereShape {
            sphere: Sphere { center: Vec3::new(1.0, 2.0, 3.0), radius: 0.5 },
            rotation,
            flip,
            material: 0,
        }
    }

    /// A sphere's surface points lie on it with the outward normal (inward when flipped), a
    /// right-handed frame whose `s` follows φ, and Mitsuba's (φ / 2π, θ / π) in its own frame.
    #[test]
    fn sphere_points_are_exact_with_mitsubas_frame_and_uv() {
        let scene = scene_with(vec![shape(false), shape(true)]).unwrap();
        assert_eq!(scene.prim_count(), 3);
        assert!(scene.sphere_of(0).is_none() && scene.sphere_of(2).is_some());
        assert!(scene.bounds().max.z >= 3.5 && scene.bounds().max.x >= 1.5);
        let s = shape(false).sphere;
        // World +x is the sphere's pole (θ = 0); world +y is its φ = π/2 on the equator.
        for (w, uv) in
            [(Vec3::X, None), (Vec3::Y, Some(Vec2::new(0.25, 0.5))), (-Vec3::Z, Some(Vec2::new(0.0, 0.5)))]
        {
            let e = octahedral_encode(w);
            for prim in [1, 2] {
                let sp = scene.surface_at(prim, e);
                assert!((sp.p - (s.center + w * s.radius)).length() < 1e-6, "{w}: {}", sp.p);
                let out = if prim == 1 { w } else { -w };
                assert!((sp.ng - out).length() < 1e-6 && (sp.frame.n - out).length() < 1e-6);
                assert!((sp.frame.s.cross(sp.frame.t) - sp.frame.n).length() < 1e-5);
                assert!(sp.frame.s.dot(sp.frame.n).abs() < 1e-6);
                assert_eq!(scene.point_at(prim, e).0, sp.p);
                if let Some(uv) = uv {
                    assert!((sp.uv - uv).length() < 1e-6, "{w}: {}", sp.uv);
                    // φ grows along s: towards the sphere's +y from its +x.
                    let ahead =
                        scene.surface_at(prim, octahedral_encode((w + sp.frame.s * 1e-2).normalize()));
                    assert!(ahead.uv.x > sp.uv.x || ahead.uv.x < 0.1, "{w}");
                }
            }
            assert!((scene.surface_at(1, e).uv.y - scene.surface_at(2, e).uv.y).abs() < 1e-6);
        }
        assert!((scene.area(1) - 4.0 * PI * 0.25).abs() < 1e-6);
    }

    /// Uniform points cover the sphere evenly: the mean of the direction is the centre, and
    /// every octant gets an eighth.
    #[test]
    fn uniform_points_cover_the_sphere_evenly() {
        let scene = scene_with(vec![shape(false)]).unwrap();
        let n = 128;
        let mut octants = [0usize; 8];
        let mut mean = Vec3::ZERO;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let (p, ng) = scene.point_at(1, scene.uniform_point(1, u));
                let d = (p - shape(false).sphere.center) / 0.5;
                assert!((d - ng).length() < 1e-5);
                mean += d;
                octants[(d.x > 0.0) as usize + 2 * (d.y > 0.0) as usize + 4 * (d.z > 0.0) as usize] += 1;
            }
        }
        assert!((mean / (n * n) as f32).length() < 1e-3, "{mean}");
        for c in octants {
            assert_eq!(c, n * n / 8);
        }
    }

    /// Bad spheres are refused with what is wrong.
    #[test]
    fn invalid_spheres_are_refused() {
        let bad = |f: fn(&mut SphereShape)| {
            let mut s = shape(false);
            f(&mut s);
            scene_with(vec![s]).unwrap_err().to_string()
        };
        assert!(bad(|s| s.sphere.radius = 0.0).contains("radius 0"));
        assert!(bad(|s| s.sphere.center.x = f32::NAN).contains("sphere 0"));
        assert!(bad(|s| s.rotation = Mat3::from_diagonal(Vec3::new(1.0, 1.0, -1.0))).contains("frame"));
        assert!(bad(|s| s.material = 3).contains("material 3"));
        assert!(scene_with(vec![shape(false); MAX_SPHERES + 1]).unwrap_err().to_string().contains("at most"));
    }
}
