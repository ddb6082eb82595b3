//! The scene's emitters: every triangle whose material has non-zero emission is a diffuse
//! area light on its front face (the side of its geometric normal); the scene's other lights
//! (point, spot, directional, constant, envmap: [`Light`]) join them.
//!
//! Sampling picks a triangle or light with probability proportional to its power (for a
//! triangle: mean emitted radiance over the channels × area × π; for the others
//! [`Light::power`], infinite lights' from the scene's bounding sphere), in constant time from
//! one alias table, and a uniform point on the triangle or a sample of the light. The same
//! distribution serves next-event estimation, MIS weights of BSDF-sampled hits, and the start
//! of light paths. A scene without other lights builds exactly the table it always did.
//!
//! One file per kind: [`point`], [`spot`], [`directional`], [`constant`], [`envmap`], and
//! their one interface in [`kind`].

pub mod constant;
pub mod directional;
pub mod envmap;
pub mod kind;
pub mod point;
pub mod spot;

pub use kind::{Emission, Light, LightSample};

use glam::{Vec2, Vec3};

use crate::sampling::reuse::{refined, to_unit_f32};
use crate::sampling::{AliasTable, uniform_triangle};
use crate::scene::Scene;

pub struct Emitters {
    /// Emitting triangles, in scene order.
    prims: Vec<u32>,
    dist: AliasTable,
    /// For every triangle of the scene: the area density of sampling a point on it
    /// (selection probability / area); zero for non-emitters.
    pdf_area: Vec<f32>,
    /// The scene's other lights (entries `prims.len()..` of `dist`).
    lights: Vec<Light>,
    /// Their selection probabilities.
    light_pmf: Vec<f32>,
    /// The indices (into `lights`) of the environments, which escaping rays see.
    environments: Vec<usize>,
}

/// What [`Emitters::choose`] picked.
#[derive(Clone, Copy, Debug)]
pub enum Choice {
    /// A point on an emitting triangle, as [`Emitters::sample`] gives it.
    Area(EmitterSample),
    /// Another light, its selection probability, and the two numbers left for its sample.
    Light { index: usize, pmf: f32, u: Vec2 },
}

/// Where a sampled point lies: what connecting to it needs.
#[derive(Clone, Copy, Debug)]
pub struct EmitterPoint {
    pub p: Vec3,
    /// The triangle's unit geometric normal (its front side emits).
    pub ng: Vec3,
    pub prim: u32,
}

/// A point sampled on an emitter.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    pub point: EmitterPoint,
    /// Emitted radiance towards the front side.
    pub radiance: Vec3,
    /// Probability density per unit area of having sampled this point.
    pub pdf_area: f32,
}

impl Emitters {
    /// `None` when the scene has no emitter or light with positive power.
    pub fn new(scene: &Scene) -> Option<Self> {
        let mut prims = Vec::new();
        let mut weights = Vec::new();
        for prim in 0..scene.indices().len() as u32 {
            let m = scene.material_of(prim);
            if m.is_emitter() {
                let area = scene.area(prim);
                let power = m.emission.element_sum() as f64 / 3.0 * area as f64 * std::f64::consts::PI;
                if power > 0.0 {
                    prims.push(prim);
                    weights.push(power);
                }
            }
        }
        let radius = scene.bounding_sphere().1;
        let mut lights = Vec::new();
        for light in scene.lights() {
            let power = light.power(radius);
            if power > 0.0 && power.is_finite() {
                lights.push(light.clone());
                weights.push(power);
            }
        }
        let dist = AliasTable::new(&weights)?;
        let mut pdf_area = vec![0.0f32; scene.indices().len()];
        for (i, &prim) in prims.iter().enumerate() {
            pdf_area[prim as usize] = dist.pmf(i) / scene.area(prim);
        }
        let light_pmf = (0..lights.len()).map(|k| dist.pmf(prims.len() + k)).collect();
        let environments = (0..lights.len()).filter(|&k| lights[k].is_environment()).collect();
        Some(Emitters { prims, dist, pdf_area, lights, light_pmf, environments })
    }

    /// The lights other than triangles.
    #[inline]
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Whether there are lights other than triangles (then [`Emitters::choose`] samples, not
    /// [`Emitters::sample`]).
    #[inline]
    pub fn has_lights(&self) -> bool {
        !self.lights.is_empty()
    }

    /// The probability of choosing light `k` of [`Emitters::lights`].
    #[inline]
    pub fn light_pmf(&self, k: usize) -> f32 {
        self.light_pmf[k]
    }

    /// The indices of the environments (constant, envmap) among [`Emitters::lights`].
    #[inline]
    pub fn environments(&self) -> &[usize] {
        &self.environments
    }

    pub fn len(&self) -> usize {
        self.prims.len()
    }

    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// Area density of [`Emitters::sample`] producing a point on triangle `prim`.
    #[inline]
    pub fn pdf_area(&self, prim: u32) -> f32 {
        self.pdf_area[prim as usize]
    }

    /// Picks an emitter triangle by power and a uniform point on it. The first coordinate of
    /// `u` does both: its integer part among the triangles picks one and the rest is the
    /// point's first number (sample reuse), `u_select` supplying the bits below its 24 so
    /// that the rest keeps full precision. Why: a stratified `u` then stays stratified over
    /// every triangle of a light, where a separate number for the choice made each
    /// triangle's points a random subset of the stratified set.
    ///
    /// Triangles only: with other lights ([`Emitters::has_lights`]) use [`Emitters::choose`].
    #[inline(always)]
    pub fn sample(&self, scene: &Scene, u_select: f32, u: Vec2) -> EmitterSample {
        let (i, rest) = self.dist.sample_reuse(refined(u.x, u_select));
        let prim = self.prims[i];
        let (p, ng) = scene.point_at(prim, uniform_triangle(Vec2::new(to_unit_f32(rest), u.y)));
        EmitterSample {
            point: EmitterPoint { p, ng, prim },
            radiance: scene.material_of(prim).emission,
            pdf_area: self.pdf_area[prim as usize],
        }
    }
}

impl Emitters {
    /// [`Emitters::sample`] over the triangles and the other lights: the same numbers pick
    /// the same way, and a light gets what is left of the first number and the second.
    #[inline]
    pub fn choose(&self, scene: &Scene, u_select: f32, u: Vec2) -> Choice {
        let (i, rest) = self.dist.sample_reuse(refined(u.x, u_select));
        let rest = to_unit_f32(rest);
        match self.prims.get(i) {
            Some(&prim) => {
                let (p, ng) = scene.point_at(prim, uniform_triangle(Vec2::new(rest, u.y)));
                Choice::Area(EmitterSample {
                    point: EmitterPoint { p, ng, prim },
                    radiance: scene.material_of(prim).emission,
                    pdf_area: self.pdf_area[prim as usize],
                })
            }
            None => {
                let index = i - self.prims.len();
                Choice::Light { index, pmf: self.light_pmf[index], u: Vec2::new(rest, u.y) }
            }
        }
    }
}

/// Radiance leaving an emitter's surface towards `w` (unit, pointing away from the surface):
/// the emission on the front side of the geometric normal, black behind.
#[inline]
pub fn emitted(emission: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    if ng.dot(w) > 0.0 { emission } else { Vec3::ZERO }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Bsdf, Material};
    use crate::scene::{Camera, Geometry, RenderDefaults};

    /// Two square lights in the plane z = 0, facing +z: the unit square (two triangles) at
    /// radiance 1, and a square of side 2 beside it at radiance 0.5 (twice the power).
    fn two_lights() -> Scene {
        let square = |x0: f32, s: f32| {
            [
                Vec3::new(x0, 0.0, 0.0),
                Vec3::new(x0 + s, 0.0, 0.0),
                Vec3::new(x0 + s, s, 0.0),
                Vec3::new(x0, s, 0.0),
            ]
        };
        let positions = [square(0.0, 1.0), square(2.0, 2.0)].concat();
        let geometry = Geometry {
            normals: vec![Vec3::ZERO; positions.len()],
            uvs: vec![],
            positions,
            indices: vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]],
            tri_material: vec![0, 0, 1, 1],
            degenerate_dropped: 0,
        };
        let light = |e: f32| Material {
            name: "light".into(),
            bsdf: Bsdf::Diffuse { albedo: Vec3::ZERO },
            emission: Vec3::splat(e),
            two_sided: false,
            textures: None,
        };
        let camera =
            Camera { eye: Vec3::Z, target: Vec3::ZERO, up: Vec3::Y, fov_deg: 40.0, width: 4, height: 4 };
        Scene::new("t.toml".into(), camera, RenderDefaults::default(), geometry, vec![light(1.0), light(0.5)])
            .unwrap()
    }

    /// Points are uniform over each light with the lights' powers as weights, and the
    /// triangle is chosen by the point's first number, not by `u_select`: a regular grid of
    /// points puts equal counts into equal cells of the lights whatever `u_select` is.
    #[test]
    fn a_grid_of_numbers_covers_the_lights_evenly() {
        let scene = two_lights();
        let emitters = Emitters::new(&scene).unwrap();
        for u_select in [0.0, 0.37, 0.999_999] {
            let n = 1024;
            // Cells of side 1/4 on both squares: 16 on the first, 64 on the second.
            let mut cells = std::collections::HashMap::<(i32, i32), usize>::new();
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    let s = emitters.sample(&scene, u_select, u);
                    assert_eq!(s.pdf_area, if s.point.p.x < 1.5 { 1.0 / 3.0 } else { 1.0 / 6.0 });
                    assert_eq!(s.point.ng, Vec3::Z);
                    let cell = ((s.point.p.x * 4.0).floor() as i32, (s.point.p.y * 4.0).floor() as i32);
                    *cells.entry(cell).or_default() += 1;
                }
            }
            assert_eq!(cells.len(), 16 + 64);
            // A cell of the first square has 1/48 of the power, of the second 1/96 (up to
            // the grid's discreteness near the triangles' corners).
            for (cell, &c) in &cells {
                let expected = (n * n) as f64 / if cell.0 < 4 { 48.0 } else { 96.0 };
                assert!(
                    (c as f64 - expected).abs() < 0.05 * expected,
                    "{u_select}: cell {cell:?} has {c}, not {expected}"
                );
            }
        }
    }
}
