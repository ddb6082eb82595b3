//! Two-sided materials (Mitsuba's `twosided`): a surface seen from behind scatters as from the
//! front, its emission stays on the front face. Checked against the same scene with every
//! face turned towards the camera, for the path tracer and the many-light methods.

mod common;

use common::{Job, closed_cube_facing};
use glam::Vec3;
use pir::integrator::{Integrator, Method, MethodConfig, PathTracer};
use pir::material::{Bsdf, Material};
use pir::scene::Scene;

fn material(albedo: f32, emission: f32, two_sided: bool) -> Material {
    Material {
        name: format!("a{albedo}-e{emission}-{two_sided}"),
        bsdf: Bsdf::Diffuse { albedo: Vec3::splat(albedo) },
        emission: Vec3::splat(emission),
        two_sided,
        textures: None,
    }
}

/// The inside of the cube, lit by its top face (+y, facing in, emitting 1); the other five
/// faces are diffuse of albedo 0.6, two-sided or not, facing in or out.
fn lit_cube(two_sided: bool, walls_outward: bool) -> Scene {
    let materials = vec![material(0.5, 1.0, two_sided), material(0.6, 0.0, two_sided)];
    closed_cube_facing(materials, |f| u32::from(f != 3), |f| walls_outward && f != 3)
}

/// The image mean and its standard error over iterations.
fn mean(scene: &Scene, integrator: &mut dyn Integrator) -> ([f64; 3], [f64; 3]) {
    let job = Job { iterations: 48, max_depth: 6, ..Job::default() };
    job.run(scene, integrator).mean_and_stderr()
}

fn integrators() -> Vec<(&'static str, Box<dyn Integrator>)> {
    let mut v: Vec<(&'static str, Box<dyn Integrator>)> = vec![("pt", Box::new(PathTracer))];
    for name in ["pir-clamp", "pir-vsl", "pir-mis", "pir-bdpt"] {
        let config = MethodConfig::new(name.parse::<Method>().unwrap());
        v.push((name, config.integrator(2.0 * 3f32.sqrt())));
    }
    v
}

/// Walls seen from behind but two-sided render the image of walls seen from the front
/// (z-test of the difference of the means at 4.5 standard errors), and one-sided walls seen
/// from behind are black: the image is then the emitter's alone, much darker.
#[test]
fn two_sided_walls_seen_from_behind_scatter_as_from_the_front() {
    let front = lit_cube(true, false);
    let back = lit_cube(true, true);
    let one_sided_back = lit_cube(false, true);
    for ((name, mut a), (_, mut b)) in integrators().into_iter().zip(integrators()) {
        let (ma, sa) = mean(&front, a.as_mut());
        let (mb, sb) = mean(&back, b.as_mut());
        for c in 0..3 {
            let se = (sa[c] * sa[c] + sb[c] * sb[c]).sqrt().max(1e-9);
            let z = (ma[c] - mb[c]) / se;
            assert!(z.abs() < 4.5, "{name}: front {} back {} (z {z:.2})", ma[c], mb[c]);
        }
        assert!(ma[0] > 0.1, "{name}: {ma:?}");
    }
    let (m, _) = mean(&one_sided_back, &mut PathTracer);
    let (lit, _) = mean(&front, &mut PathTracer);
    assert!(m[0] < 0.5 * lit[0], "one-sided walls from behind: {m:?} against {lit:?}");
}

/// The emitter's back face emits nothing, two-sided or not: with the top face turned
/// outwards and no other light, the image is black.
#[test]
fn emission_stays_on_the_front_face() {
    for two_sided in [false, true] {
        let materials = vec![material(0.5, 1.0, two_sided), material(0.6, 0.0, two_sided)];
        let scene = closed_cube_facing(materials, |f| u32::from(f != 3), |f| f == 3);
        let (m, _) = mean(&scene, &mut PathTracer);
        assert!(m.iter().all(|&c| c == 0.0), "two-sided {two_sided}: {m:?}");
    }
}
