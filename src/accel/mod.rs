//! Ray-query backends behind one trait.
//!
//! A backend answers two questions about the scene's triangles: the closest hit along a ray
//! (`intersect`) and whether anything blocks a segment (`occluded`), one ray at a time or in
//! batches. It returns a minimal [`Hit`] (distance, primitive, barycentrics); the scene turns
//! that into a shading point once, for every backend (`Scene::surface_at`).
//!
//! Analytic spheres join any backend through [`WithSpheres`].
//!
//! Backends: [`Bvh`] (pure Rust, binned SAH), [`BruteForce`] (the test oracle) and, when built
//! with Embree, `Embree` (see [`embree`]; [`embree_status`] says whether it is built in).
//! [`Backend`] names them and [`build_accelerator`] builds one behind `Box<dyn Accelerator>`.

mod brute;
mod bvh;
mod spheres;
// FTZ/DAZ needs two MXCSR instructions, which only inline assembly can issue.
#[allow(unsafe_code)]
mod denormals;
// The FFI wrapper: the one module built on `unsafe` code.
#[allow(unsafe_code)]
pub mod embree;
// Test support (the BVH's unit tests, tests/, benches/), not shipped: see Cargo.toml's
// `testmesh` feature.
#[cfg(any(test, feature = "testmesh"))]
pub mod testmesh;

pub use brute::BruteForce;
pub use bvh::Bvh;
pub use denormals::{flush_denormals_enabled, set_flush_denormals};
#[cfg(pir_embree)]
pub use embree::Embree;
pub use embree::embree_status;
pub use spheres::{MAX_SPHERES, WithSpheres};

use std::fmt;
use std::str::FromStr;

use crate::geometry::{Ray, VertexBuffer};

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

/// The backend choice of a render (the `--accel` option).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// Intel Embree through FFI; only when pir was built with it (see [`embree_status`]).
    Embree,
    /// The pure-Rust BVH.
    Bvh,
    /// Every ray against every triangle: the test oracle.
    Brute,
}

impl Backend {
    /// The fastest backend this build has: Embree when built in, else the BVH.
    pub fn default_available() -> Backend {
        if embree::AVAILABLE { Backend::Embree } else { Backend::Bvh }
    }

    /// Whether this build can construct the backend.
    pub fn is_available(self) -> bool {
        self != Backend::Embree || embree::AVAILABLE
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Backend::Embree => "embree",
            Backend::Bvh => "bvh",
            Backend::Brute => "brute",
        })
    }
}

impl FromStr for Backend {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "embree" => Ok(Backend::Embree),
            "bvh" => Ok(Backend::Bvh),
            "brute" | "bruteforce" | "brute-force" => Ok(Backend::Brute),
            _ => Err(format!("unknown accelerator {s:?} (expected embree, bvh or brute)")),
        }
    }
}

/// The message when Embree is asked for but pir was built without it.
pub const EMBREE_MISSING: &str =
    "pir was built without Embree; install libembree-dev libclang-dev and rebuild";

/// Builds the chosen backend over the triangles `indices` of `positions` (Embree with its
/// default settings, reading both arrays in place: they stay borrowed as long as the backend).
pub fn build_accelerator<'a>(
    backend: Backend,
    positions: &'a VertexBuffer,
    indices: &'a [[u32; 3]],
) -> Result<Box<dyn Accelerator + 'a>, String> {
    match backend {
        Backend::Brute => Ok(Box::new(BruteForce::new(positions, indices))),
        Backend::Bvh => Ok(Box::new(Bvh::new(positions, indices))),
        #[cfg(pir_embree)]
        Backend::Embree => Ok(Box::new(Embree::shared(positions, indices)?)),
        #[cfg(not(pir_embree))]
        Backend::Embree => Err(format!("{EMBREE_MISSING} ({})", embree_status())),
    }
}

#[cfg(test)]
mod backend_tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn backend_names_round_trip() {
        for b in [Backend::Embree, Backend::Bvh, Backend::Brute] {
            assert_eq!(b.to_string().parse::<Backend>().unwrap(), b);
        }
        assert!("optix".parse::<Backend>().is_err());
        assert!(Backend::default_available().is_available());
    }

    #[test]
    fn build_accelerator_gives_each_backend_or_a_clear_error() {
        let p = VertexBuffer::from(vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
        let t = [[0, 1, 2]];
        for b in [Backend::Bvh, Backend::Brute, Backend::Embree] {
            match build_accelerator(b, &p, &t) {
                Ok(a) => {
                    assert_eq!(a.name(), b.to_string());
                    let ray = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z);
                    assert_eq!(a.intersect(&ray).map(|h| h.prim), Some(0));
                }
                Err(e) => {
                    assert!(b == Backend::Embree && !embree::AVAILABLE, "{b}: {e}");
                    assert!(e.contains("install libembree-dev libclang-dev"), "{e}");
                }
            }
        }
    }
}
