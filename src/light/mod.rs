//! The scene's emitters: every triangle whose material has non-zero emission is a diffuse
//! area light on its front face (the side of its geometric normal); the scene's other lights
//! (point, spot, directional, constant, envmap: [`Light`]) join them.
//!
//! Sampling picks a triangle or light with probability proportional to its power (for a
//! triangle: mean emitted radiance over the channels × area × π; for the others
//! [`Light::power`], infinite lights' from the scene's bounding sphere), in constant time from
//! one alias table, and a uniform point on the triangle or a sample of the light. The same
//! distribution serves the start of light paths, and next-event estimation and the MIS
//! weights of BSDF-sampled hits but where the emitters are three triangles or more: there next-event
//! estimation picks a triangle by its importance at the receiver ([`spatial`],
//! [`Emitters::sample_from`], [`Emitters::nee_pdf`]). A scene without other lights builds
//! exactly the table it always did.
//!
//! An emitting sphere of a Mitsuba scene ([`SphereLight`]) is one entry of the table, its
//! power its primitives' (one analytic sphere, or the triangles of a tessellated one, among
//! which a table of its own picks by power, as the scene's table would). Next-event estimation from outside it samples the cone of the exact sphere instead
//! of a point ([`Emitters::choose_from`], [`sphere`]); every MIS weight that uses the density
//! of next-event estimation asks [`Emitters::nee_pdf`] for it. Light paths start on its
//! triangles by area, as from any others. A scene without spheres builds the table it always
//! did.
//!
//! One file per kind: [`point`], [`spot`], [`directional`], [`constant`], [`envmap`],
//! [`sphere`], and their one interface in [`kind`].

pub mod constant;
pub mod directional;
pub mod envmap;
pub mod kind;
pub mod point;
pub mod spatial;
pub mod sphere;
pub mod spot;

pub use kind::{Emission, Light, LightSample};
pub use spatial::{EmitterChoice, Spatial};
pub use sphere::SphereLight;

use glam::{Vec2, Vec3};

use crate::sampling::AliasTable;
use crate::sampling::reuse::{refined, to_unit_f32};
use crate::scene::Scene;

pub struct Emitters {
    /// Emitting triangles outside the spheres, in scene order (the first entries of `dist`).
    prims: Vec<u32>,
    /// The emitting spheres (the entries `prims.len()..` of `dist`), in scene order.
    groups: Vec<Group>,
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
    /// Next-event estimation's choice by importance at the receiver, where the emitters are
    /// three triangles or more ([`spatial`]); `None`: by power, as the light paths start.
    spatial: Option<Spatial>,
}

/// An emitting sphere's entry of the table.
struct Group {
    sphere: SphereLight,
    /// Its triangles, and a table that picks among them by power.
    prims: Vec<u32>,
    dist: AliasTable,
    /// The probability of choosing the sphere.
    pmf: f32,
}

/// A direction towards an emitting sphere, drawn by [`Emitters::choose_from`].
#[derive(Clone, Copy, Debug)]
pub struct ConeSample {
    /// Which sphere: its triangles are those [`Emitters::in_group`] names.
    pub group: usize,
    /// Unit direction from the receiver.
    pub wi: Vec3,
    /// Solid-angle density of the direction: the sphere's probability / the cone's Ω.
    pub pdf: f32,
}

/// What [`Emitters::choose_from`] picked for next-event estimation at a receiver.
#[derive(Clone, Copy, Debug)]
pub enum NeeChoice {
    /// What [`Emitters::choose`] would pick.
    Choice(Choice),
    /// A direction in the cone of an emitting sphere seen from outside.
    Cone(ConeSample),
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
    /// The light paths' density per unit area of the point ([`Emitters::pdf_area`]): the
    /// same as `pdf_area` but where next-event estimation picked it by its importance
    /// ([`Emitters::sample_from`]).
    pub pdf_start: f32,
}

impl Emitters {
    /// `None` when the scene has no emitter or light with positive power.
    pub fn new(scene: &Scene) -> Option<Self> {
        let power = |prim: u32| {
            let m = scene.material_of(prim);
            if !m.is_emitter() {
                return 0.0;
            }
            let area = scene.area(prim);
            m.emission.element_sum() as f64 / 3.0 * area as f64 * std::f64::consts::PI
        };
        // The spheres whose every triangle emits; their triangles leave the scene's list.
        let spheres: Vec<&SphereLight> =
            scene.sphere_lights().iter().filter(|s| s.prims.clone().all(|p| power(p) > 0.0)).collect();
        let mut in_sphere = vec![false; if spheres.is_empty() { 0 } else { scene.prim_count() }];
        for s in &spheres {
            for p in s.prims.clone() {
                in_sphere[p as usize] = true;
            }
        }
        let mut prims = Vec::new();
        let mut weights = Vec::new();
        for prim in 0..scene.prim_count() as u32 {
            if in_sphere.get(prim as usize) == Some(&true) {
                continue;
            }
            let power = power(prim);
            if power > 0.0 {
                prims.push(prim);
                weights.push(power);
            }
        }
        let mut groups = Vec::new();
        for s in spheres {
            let tris: Vec<u32> = s.prims.clone().collect();
            let w: Vec<f64> = tris.iter().map(|&p| power(p)).collect();
            weights.push(w.iter().sum());
            let dist = AliasTable::new(&w)?;
            groups.push(Group { sphere: s.clone(), prims: tris, dist, pmf: 0.0 });
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
        let mut pdf_area = vec![0.0f32; scene.prim_count()];
        for (i, &prim) in prims.iter().enumerate() {
            pdf_area[prim as usize] = dist.pmf(i) / scene.area(prim);
        }
        for (g, group) in groups.iter_mut().enumerate() {
            group.pmf = dist.pmf(prims.len() + g);
            for (k, &prim) in group.prims.iter().enumerate() {
                pdf_area[prim as usize] = group.pmf * group.dist.pmf(k) / scene.area(prim);
            }
        }
        let first_light = prims.len() + groups.len();
        let light_pmf = (0..lights.len()).map(|k| dist.pmf(first_light + k)).collect();
        let environments = (0..lights.len()).filter(|&k| lights[k].is_environment()).collect();
        // (Triangles only: an analytic sphere that is not a sphere light, seen from inside,
        // has no corners to bound.)
        let spatial = if lights.is_empty()
            && groups.is_empty()
            && prims.iter().all(|&p| scene.sphere_of(p).is_none())
        {
            Spatial::new(prims.iter().enumerate().map(|(i, &prim)| {
                let ng = scene.point_at(prim, Vec2::ZERO).1;
                (scene.triangle(prim), ng, dist.pmf(i), scene.area(prim))
            }))
        } else {
            None
        };
        Some(Emitters { prims, groups, dist, pdf_area, lights, light_pmf, environments, spatial })
    }

    /// The lights other than triangles.
    #[inline]
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Whether the emitters are triangles outside spheres only: then [`Emitters::sample`]
    /// (and [`Emitters::sample_from`]) serve, else [`Emitters::choose`] (and
    /// [`Emitters::choose_from`]) sample.
    #[inline]
    pub fn is_plain(&self) -> bool {
        self.lights.is_empty() && self.groups.is_empty()
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

    /// The emitting triangles, the spheres' included.
    pub fn len(&self) -> usize {
        self.prims.len() + self.groups.iter().map(|g| g.prims.len()).sum::<usize>()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether triangle `prim` is one of sphere `group`'s ([`ConeSample::group`]).
    #[inline]
    pub fn in_group(&self, group: usize, prim: u32) -> bool {
        self.groups[group].sphere.prims.contains(&prim)
    }

    /// Whether next-event estimation picks among the triangles by their importance at the
    /// receiver ([`spatial`], [`Emitters::sample_from`]).
    #[inline]
    pub fn is_spatial(&self) -> bool {
        self.spatial.is_some()
    }

    /// How many entries the choice by importance picks among ([`Spatial::entries`]): the
    /// triangles, or clusters of them; `None` where it picks by power.
    #[inline]
    pub fn spatial_entries(&self) -> Option<usize> {
        self.spatial.as_ref().map(Spatial::entries)
    }

    /// The emitters with next-event estimation's choice as `choice` says: by power alone
    /// ([`EmitterChoice::Power`]) drops the choice by importance; [`EmitterChoice::Auto`]
    /// keeps it for its pilot to decide ([`crate::integrator::emitter_pilot`]).
    pub fn with_choice(mut self, choice: EmitterChoice) -> Self {
        if choice == EmitterChoice::Power {
            self.spatial = None;
        }
        self
    }

    /// The solid-angle density with which next-event estimation from `from` draws the
    /// direction towards a point of triangle `prim` at squared distance `dist2` whose cosine
    /// towards `from` is `cos_e`, where it differs from the light paths' area density
    /// ([`Emitters::pdf_area`], times `dist2 / cos_e`): where it samples a sphere's cone (the
    /// triangle is a sphere's and `from` is outside it), or picks the triangle by its
    /// importance at `from` ([`spatial`]); `None` where it picks points as the light paths
    /// do. Every MIS weight that needs the density of next-event estimation asks here first.
    #[inline]
    pub fn nee_pdf(&self, prim: u32, from: Vec3, dist2: f32, cos_e: f32) -> Option<f32> {
        if let Some(s) = &self.spatial {
            let i = self.prims.binary_search(&prim).ok()?;
            return Some(s.pdf_area(i, s.pmf(from, i)) * dist2 / cos_e);
        }
        if self.groups.is_empty() {
            return None;
        }
        let g = self.groups.partition_point(|g| g.sphere.prims.end <= prim);
        let group = self.groups.get(g).filter(|g| g.sphere.prims.contains(&prim))?;
        Some(group.pmf * group.sphere.cone(from)?.pdf)
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
    /// Plain emitters only ([`Emitters::is_plain`]): otherwise use [`Emitters::choose`].
    #[inline(always)]
    pub fn sample(&self, scene: &Scene, u_select: f32, u: Vec2) -> EmitterSample {
        let (i, rest) = self.dist.sample_reuse(refined(u.x, u_select));
        self.area_sample(scene, self.prims[i], rest, u.y)
    }

    /// [`Emitters::sample`] for next-event estimation at `x`: where the emitters are a few
    /// triangles, the triangle is picked by its importance at `x` ([`spatial`]) from the same
    /// numbers, reused the same way, and `pdf_area` is that choice's.
    ///
    /// Plain emitters only ([`Emitters::is_plain`]): otherwise use [`Emitters::choose_from`].
    #[inline(always)]
    pub fn sample_from(&self, scene: &Scene, x: Vec3, u_select: f32, u: Vec2) -> EmitterSample {
        let Some(s) = &self.spatial else { return self.sample(scene, u_select, u) };
        let (i, pmf, rest) = s.pick(x, refined(u.x, u_select));
        let mut es = self.area_sample(scene, self.prims[i], rest, u.y);
        es.pdf_area = s.pdf_area(i, pmf);
        es
    }

    /// A uniform point on emitter `prim` (a triangle or an analytic sphere,
    /// [`Scene::uniform_point`]) from what is left of the first number,
    /// `rest`, and the second, `v`.
    #[inline(always)]
    fn area_sample(&self, scene: &Scene, prim: u32, rest: f64, v: f32) -> EmitterSample {
        let b = scene.uniform_point(prim, Vec2::new(to_unit_f32(rest), v));
        let (p, ng) = scene.point_at(prim, b);
        let pdf_area = self.pdf_area[prim as usize];
        EmitterSample {
            point: EmitterPoint { p, ng, prim },
            radiance: scene.emission_at(prim, b),
            pdf_area,
            pdf_start: pdf_area,
        }
    }
}

impl Emitters {
    /// [`Emitters::sample`] over the triangles, the spheres and the other lights: the same
    /// numbers pick the same way, a sphere's triangle by a second pick from what is left of the
    /// first number, and a light gets what is left of the first number and the second.
    #[inline]
    pub fn choose(&self, scene: &Scene, u_select: f32, u: Vec2) -> Choice {
        let (i, rest) = self.dist.sample_reuse(refined(u.x, u_select));
        self.choice(scene, i, rest, u)
    }

    /// [`Emitters::choose`] for next-event estimation at `x`: where it picks a sphere that
    /// `x` is outside of, a direction uniform in the sphere's cone from what is left of the
    /// first number and the second, instead of a point on its triangles.
    #[inline]
    pub fn choose_from(&self, scene: &Scene, x: Vec3, u_select: f32, u: Vec2) -> NeeChoice {
        let (i, rest) = self.dist.sample_reuse(refined(u.x, u_select));
        if let Some(group) = i.checked_sub(self.prims.len()).filter(|&g| g < self.groups.len())
            && let Some(cone) = self.groups[group].sphere.cone(x)
        {
            let wi = cone.sample(Vec2::new(to_unit_f32(rest), u.y));
            return NeeChoice::Cone(ConeSample { group, wi, pdf: self.groups[group].pmf * cone.pdf });
        }
        NeeChoice::Choice(self.choice(scene, i, rest, u))
    }

    /// Entry `i` of the table, with what is left of the first number, `rest`.
    #[inline]
    fn choice(&self, scene: &Scene, i: usize, rest: f64, u: Vec2) -> Choice {
        let area = |prim: u32, rest: f64| Choice::Area(self.area_sample(scene, prim, rest, u.y));
        if let Some(&prim) = self.prims.get(i) {
            return area(prim, rest);
        }
        let i = i - self.prims.len();
        match self.groups.get(i) {
            Some(group) => {
                let (k, rest) = group.dist.sample_reuse(rest);
                area(group.prims[k], rest)
            }
            None => {
                let index = i - self.groups.len();
                Choice::Light { index, pmf: self.light_pmf[index], u: Vec2::new(to_unit_f32(rest), u.y) }
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
        lights(false)
    }

    /// [`two_lights`], and with `third` a unit square at x = 10 of radiance 1.
    fn lights(third: bool) -> Scene {
        let square = |x0: f32, s: f32| {
            [
                Vec3::new(x0, 0.0, 0.0),
                Vec3::new(x0 + s, 0.0, 0.0),
                Vec3::new(x0 + s, s, 0.0),
                Vec3::new(x0, s, 0.0),
            ]
        };
        let mut positions = [square(0.0, 1.0), square(2.0, 2.0)].concat();
        let mut indices = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        let mut tri_material = vec![0, 0, 1, 1];
        if third {
            positions.extend(square(10.0, 1.0));
            indices.extend([[8, 9, 10], [8, 10, 11]]);
            tri_material.extend([0, 0]);
        }
        let geometry = Geometry::flat(positions, indices, tri_material);
        let light = |e: f32| Material {
            name: "light".into(),
            bsdf: Bsdf::Diffuse { albedo: Vec3::ZERO },
            emission: Vec3::splat(e),
            two_sided: false,
            textures: None,
        };
        let camera = Camera::pinhole(Vec3::Z, Vec3::ZERO, Vec3::Y, 40.0, 4, 4);
        Scene::new("t.toml".into(), camera, RenderDefaults::default(), geometry, vec![light(1.0), light(0.5)])
            .unwrap()
    }

    /// Next-event estimation's choice by importance: the density that a sample reports is
    /// the one that every MIS weight asks [`Emitters::nee_pdf`] for, and points of the same
    /// light are picked more often from near it; by power it is the light paths' density.
    #[test]
    fn the_choice_by_importance_reports_the_density_that_the_weights_use() {
        let scene = lights(true);
        let emitters = Emitters::new(&scene).unwrap();
        assert!(emitters.is_spatial());
        // A Weyl sequence for the numbers.
        let mut k = 0u32;
        let mut next = || {
            k += 1;
            (k as f32 * 0.618_034).fract()
        };
        for x in [Vec3::new(0.5, 0.5, 0.3), Vec3::new(3.0, 1.0, 2.0), Vec3::new(-20.0, 4.0, 1.0)] {
            for _ in 0..200 {
                let u = Vec2::new(next(), next());
                let s = emitters.sample_from(&scene, x, next(), u);
                let d = s.point.p - x;
                let (dist2, cos_e) = (d.length_squared(), s.point.ng.dot(-d.normalize()).abs());
                let nee = emitters.nee_pdf(s.point.prim, x, dist2, cos_e).unwrap() * cos_e / dist2;
                assert!((nee - s.pdf_area).abs() <= 1e-5 * s.pdf_area, "{x}: {nee} against {}", s.pdf_area);
                assert_eq!(s.pdf_start, emitters.pdf_area(s.point.prim));
            }
        }
        // Unbiased from every receiver: over stratified numbers, the mean of 1 / pdf_area over
        // the points of a light is the light's area (1, 4, 1).
        for x in [Vec3::new(0.5, 0.5, 0.3), Vec3::new(11.0, 0.2, 0.5)] {
            // (Fine in the number that picks the light, where a far light has a small share.)
            let (n, m) = (16384, 16);
            let mut area = [0.0f64; 3];
            for i in 0..n {
                for j in 0..m {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / m as f32);
                    let s = emitters.sample_from(&scene, x, 0.5, u);
                    let light = if s.point.p.x < 1.5 {
                        0
                    } else if s.point.p.x < 5.0 {
                        1
                    } else {
                        2
                    };
                    area[light] += 1.0 / s.pdf_area as f64;
                }
            }
            for (k, want) in [1.0, 4.0, 1.0].into_iter().enumerate() {
                let got = area[k] / (n * m) as f64;
                assert!((got - want).abs() < 0.01 * want, "{x}, light {k}: {got} against {want}");
            }
        }
        // Above the unit square, its points are denser than the light paths'.
        let s = emitters.sample_from(&scene, Vec3::new(0.5, 0.5, 0.2), 0.0, Vec2::new(0.1, 0.5));
        assert!(s.point.p.x < 1.0 && s.pdf_area > 2.0 * s.pdf_start, "{s:?}");
        let by_power = Emitters::new(&scene).unwrap().with_choice(EmitterChoice::Power);
        assert!(by_power.nee_pdf(0, Vec3::Z, 1.0, 1.0).is_none());
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
