//! A renderer's worker pool is the only rayon pool it uses: `--threads N` bounds the BVH's
//! build and the render, and rayon's global pool (one thread per core) is never started. This
//! test is alone in its binary, so nothing else in the process can have started that pool.

mod common;

use pir::accel::Backend;
use pir::integrator::methods::{PirClamp, Pt};
use pir::integrator::{Method, MethodConfig};
use pir::render::{Budget, Control, Renderer, SceneOptions};

#[test]
fn a_render_on_one_thread_starts_no_other_pool() {
    let scene = common::closed_cube(common::diffuse(0.5, 1.0));
    let options = SceneOptions { threads: Some(1), accel: Some(Backend::Bvh), ..Default::default() };
    let renderer = Renderer::new(&scene, &options).expect("the closed cube renders");
    assert_eq!(renderer.threads(), 1);
    for method in [Method::new(&Pt), Method::new(&PirClamp)] {
        let budget = Budget { iterations: Some(2), time: None };
        let (_, stats) = renderer.render(&MethodConfig::new(method), budget, |_, _| Control::Continue);
        assert_eq!(stats.iterations, 2);
    }
    // Fails if anything above ran outside the renderer's pool (rayon starts its global pool on
    // the first parallel call made outside any pool).
    rayon::ThreadPoolBuilder::new()
        .build_global()
        .expect("the renderer ran rayon work outside its own pool (the global pool was started)");
}
