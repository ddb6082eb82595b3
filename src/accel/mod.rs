//! Ray-query backends behind one trait.
//!
//! A backend answers two questions about the scene's triangles: the closest hit along a ray
//! (`intersect`) and whether anything blocks a segment (`occluded`), one ray at a time or in
//! batches. It returns a minimal [`Hit`] (distance, primitive, barycentrics); the scene turns
//! that into a shading point once, for every backend (`Scene::surface_at`).
//!
//! Backends: [`Bvh`] (pure Rust, binned SAH), [`BruteForce`] (the test oracle) and, when built
//! with Embree, `Embree`.

mod brute;
mod bvh;
#[doc(hidden)]
pub mod testmesh;

pub use brute::BruteForce;
pub use bvh::Bvh;

use crate::geometry::Ray;

/// The closest intersection of a ray: distance `t` along the ray (in units of its direction),
/// primitive (triangle) index and barycentrics of the triangle's second and third vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

/// A ray-query backend over a fixed set of triangles.
///
/// Rays are tested on the open interval `(tmin, tmax)`. Rays that fail [`Ray::is_valid`] miss
/// and are never occluded. Implementations are shared across rendering threads.
pub trait Accelerator: Send + Sync {
    /// A short name for summaries and metadata ("bvh", "brute", "embree").
    fn name(&self) -> &str;

    /// A description of the backend for the render summary (version, ISA, node counts).
    fn describe(&self) -> String {
        self.name().to_string()
    }

    /// The closest hit in `(ray.tmin, ray.tmax)`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;

    /// Whether any triangle is hit in `(ray.tmin, ray.tmax)`.
    fn occluded(&self, ray: &Ray) -> bool;

    /// Closest hits for a batch of rays; `hits.len()` must equal `rays.len()`.
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len());
        for (r, h) in rays.iter().zip(hits.iter_mut()) {
            *h = self.intersect(r);
        }
    }

    /// Occlusion for a batch of rays; `occluded.len()` must equal `rays.len()`.
    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len());
        for (r, o) in rays.iter().zip(occluded.iter_mut()) {
            *o = self.occluded(r);
        }
    }
}
