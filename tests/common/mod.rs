//! Helpers shared by the integration tests: scenes built in code, in-process renders, and
//! what a test needs that may be absent (`../shared`, the Embree backend: see [`require`]).
#![allow(dead_code)]

pub mod binary;
pub mod require;
pub mod study_csv;

#[allow(unused_imports)]
pub use require::{embree_available, shared_dir};

use glam::Vec3;
use std::path::PathBuf;

use pir::accel::{Accelerator, Backend};
use pir::image::RgbImage;
use pir::integrator::{Integrator, RenderContext};
use pir::light::{EmitterChoice, Emitters};
use pir::material::{Bsdf, Material};
use pir::render::{Budget, Control, Film, RenderSettings, RenderStats, render};
use pir::sampling::SamplerKind;
use pir::scene::{Camera, Geometry, RenderDefaults, Scene};

/// Every rendering method, by the name `--method` takes: the one list that the tests of every
/// method (`tests/golden.rs`, `tests/batch.rs`) take them from.
pub fn methods() -> Vec<&'static str> {
    pir::integrator::Method::all().into_iter().map(|m| m.name()).collect()
}

/// The inside of the cube [-1, 1]³, every face facing inwards, all of one material; the
/// camera sits at the centre looking down −z.
pub fn closed_cube(material: Material) -> Scene {
    closed_cube_of(vec![material], |_| 0)
}

/// [`closed_cube`] with several materials: face f (0 to 5: −x, +x, −y, +y, −z, +z) gets
/// material `face_material(f)`.
pub fn closed_cube_of(materials: Vec<Material>, face_material: impl Fn(usize) -> u32) -> Scene {
    closed_cube_facing(materials, face_material, |_| false)
}

/// [`closed_cube_of`] with the faces for which `outward(f)` holds wound the other way: their
/// geometric normals point out of the cube, so the camera inside sees their backs.
pub fn closed_cube_facing(
    materials: Vec<Material>,
    face_material: impl Fn(usize) -> u32,
    outward: impl Fn(usize) -> bool,
) -> Scene {
    let mut tri_material = Vec::new();
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    // For each axis and sign, a face at coordinate `sign` whose normal points to −sign.
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f32, b: f32| {
                let mut p = [0.0f32; 3];
                p[axis] = sign;
                p[u] = a;
                p[v] = b;
                Vec3::from(p)
            };
            let base = positions.len() as u32;
            positions.extend([corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)]);
            let inward = {
                let mut n = [0.0f32; 3];
                n[axis] = -sign;
                Vec3::from(n)
            };
            let (a, b, c) =
                (positions[base as usize], positions[base as usize + 1], positions[base as usize + 2]);
            let face = 2 * axis + usize::from(sign > 0.0);
            tri_material.extend([face_material(face); 2]);
            if ((b - a).cross(c - a).dot(inward) > 0.0) != outward(face) {
                indices.push([base, base + 1, base + 2]);
                indices.push([base, base + 2, base + 3]);
            } else {
                indices.push([base, base + 2, base + 1]);
                indices.push([base, base + 3, base + 2]);
            }
        }
    }
    let camera = Camera::pinhole(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), Vec3::Y, 60.0, 16, 16);
    let geometry = Geometry::flat(positions, indices, tri_material);
    Scene::new(PathBuf::from("closed-cube"), camera, RenderDefaults::default(), geometry, materials)
        .expect("the closed cube is a valid scene")
}

pub fn diffuse(albedo: f32, emission: f32) -> Material {
    Material {
        name: "m".into(),
        bsdf: Bsdf::Diffuse { albedo: Vec3::splat(albedo) },
        emission: Vec3::splat(emission),
        two_sided: false,
        textures: None,
    }
}

/// A finished in-process render.
pub struct Rendered {
    pub film: Film,
    pub stats: RenderStats,
    /// Per-channel image mean of every iteration's samples (iteration i at index i − 1).
    pub iteration_means: Vec<[f64; 3]>,
    /// Images after the iterations asked for in `snapshot_at`.
    pub snapshots: Vec<(u64, RgbImage)>,
}

impl Rendered {
    pub fn image(&self) -> RgbImage {
        self.film.image()
    }

    /// Mean over iterations of the per-iteration channel means, and its standard error.
    pub fn mean_and_stderr(&self) -> ([f64; 3], [f64; 3]) {
        let k = self.iteration_means.len() as f64;
        let mut mean = [0.0; 3];
        let mut se = [0.0; 3];
        for c in 0..3 {
            mean[c] = self.iteration_means.iter().map(|m| m[c]).sum::<f64>() / k;
            let var = self.iteration_means.iter().map(|m| (m[c] - mean[c]).powi(2)).sum::<f64>() / (k - 1.0);
            se[c] = (var / k).sqrt();
        }
        (mean, se)
    }
}

/// An in-process render: image size, iterations, seed, path length, threads, and the
/// iterations after which to keep a snapshot of the image.
#[derive(Clone, Debug)]
pub struct Job {
    pub width: usize,
    pub height: usize,
    pub iterations: u64,
    pub seed: u64,
    pub max_depth: u32,
    pub threads: usize,
    pub snapshot_at: Vec<u64>,
    /// Independent by default: the z-tests estimate their standard error from the spread of
    /// the iterations, which needs independent iterations (a Sobol sampler's are not; its
    /// tests replicate over seeds instead).
    pub sampler: SamplerKind,
    /// How next-event estimation picks an emitting triangle (`--emitter-choice`): by power
    /// unless a test asks (`auto`, the renderer's default, runs its pilot in
    /// [`pir::render::Renderer`] only; here it picks by importance).
    pub emitter_choice: EmitterChoice,
}

impl Default for Job {
    fn default() -> Self {
        Job {
            width: 16,
            height: 16,
            iterations: 16,
            seed: 1,
            max_depth: 8,
            threads: 2,
            snapshot_at: Vec::new(),
            sampler: SamplerKind::Independent,
            emitter_choice: EmitterChoice::Power,
        }
    }
}

impl Job {
    /// Renders `scene` with the default backend (Embree when built in, else pir's BVH).
    pub fn run(&self, scene: &Scene, integrator: &mut dyn Integrator) -> Rendered {
        let accel = scene.accelerator(Backend::default_available()).unwrap();
        self.run_with(scene, accel.as_ref(), integrator)
    }

    /// Calls `f` with the render context of `scene` on the default backend, with this job's
    /// path length, seed and sampler (and no cached pilot).
    pub fn with_context<R>(&self, scene: &Scene, f: impl FnOnce(&RenderContext) -> R) -> R {
        let accel = scene.accelerator(Backend::default_available()).unwrap();
        self.with_context_on(scene, accel.as_ref(), f)
    }

    /// [`Job::with_context`] on `accel`.
    pub fn with_context_on<R>(
        &self,
        scene: &Scene,
        accel: &dyn Accelerator,
        f: impl FnOnce(&RenderContext) -> R,
    ) -> R {
        let emitters = Emitters::new(scene).expect("scene has emitters").with_choice(self.emitter_choice);
        f(&RenderContext {
            scene,
            accel,
            emitters: &emitters,
            max_depth: self.max_depth,
            seed: self.seed,
            sampler: self.sampler,
            pilot: None,
        })
    }

    pub fn run_with(
        &self,
        scene: &Scene,
        accel: &dyn Accelerator,
        integrator: &mut dyn Integrator,
    ) -> Rendered {
        self.with_context_on(scene, accel, |ctx| self.render_in(ctx, integrator))
    }

    fn render_in(&self, ctx: &RenderContext, integrator: &mut dyn Integrator) -> Rendered {
        let (width, height) = (self.width, self.height);
        let settings = RenderSettings {
            width,
            height,
            budget: Budget { iterations: Some(self.iterations), time: None },
        };
        let pool = rayon::ThreadPoolBuilder::new().num_threads(self.threads).build().unwrap();
        let mut iteration_means = Vec::new();
        let mut snapshots = Vec::new();
        let mut prev = vec![glam::DVec3::ZERO; width * height];
        let npix = (width * height) as f64;
        let (film, stats) = pool.install(|| {
            render(ctx, integrator, &settings, |film, _| {
                let mut m = glam::DVec3::ZERO;
                for (s, p) in film.sums().iter().zip(prev.iter_mut()) {
                    m += *s - *p;
                    *p = *s;
                }
                iteration_means.push([m.x / npix, m.y / npix, m.z / npix]);
                if self.snapshot_at.contains(&film.iterations()) {
                    snapshots.push((film.iterations(), film.image()));
                }
                Control::Continue
            })
        });
        Rendered { film, stats, iteration_means, snapshots }
    }
}
