//! The scene's emitters: every triangle whose material has non-zero emission is a diffuse
//! area light on its front face (the side of its geometric normal).
//!
//! Sampling picks a triangle with probability proportional to its power (mean emitted
//! radiance over the channels × area × π), in constant time from an alias table, and a
//! uniform point on it. The same distribution
//! serves next-event estimation, MIS weights of BSDF-sampled hits, and the start of light
//! paths.

use glam::{Vec2, Vec3};

use crate::sampling::{AliasTable, uniform_triangle};
use crate::scene::Scene;

pub struct Emitters {
    /// Emitting triangles, in scene order.
    prims: Vec<u32>,
    dist: AliasTable,
    /// For every triangle of the scene: the area density of sampling a point on it
    /// (selection probability / area); zero for non-emitters.
    pdf_area: Vec<f32>,
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
    /// `None` when the scene has no emitter with positive power.
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
        let dist = AliasTable::new(&weights)?;
        let mut pdf_area = vec![0.0f32; scene.indices().len()];
        for (i, &prim) in prims.iter().enumerate() {
            pdf_area[prim as usize] = dist.pmf(i) / scene.area(prim);
        }
        Some(Emitters { prims, dist, pdf_area })
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

    /// Picks an emitter triangle by power (`u_select`) and a uniform point on it (`u`).
    #[inline]
    pub fn sample(&self, scene: &Scene, u_select: f32, u: Vec2) -> EmitterSample {
        let prim = self.prims[self.dist.sample(u_select)];
        let (p, ng) = scene.point_at(prim, uniform_triangle(u));
        EmitterSample {
            point: EmitterPoint { p, ng, prim },
            radiance: scene.material_of(prim).emission,
            pdf_area: self.pdf_area[prim as usize],
        }
    }
}

/// Radiance leaving an emitter's surface towards `w` (unit, pointing away from the surface):
/// the emission on the front side of the geometric normal, black behind.
#[inline]
pub fn emitted(emission: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    if ng.dot(w) > 0.0 { emission } else { Vec3::ZERO }
}
