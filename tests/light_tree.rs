//! The sampled gather through a light tree (`Gather::Tree`) in whole renders: it converges to
//! the image of the exhaustive gather (`Gather::All`), and it is a function of the seed alone.

mod common;

use std::path::Path;

use common::{Job, Rendered};
use pir::integrator::{Clamping, Gather, InstantRadiosity, Radius, VirtualLights};
use pir::scene::{Scene, load};

fn cornell() -> Scene {
    load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/scene.toml")).unwrap()
}

fn methods() -> Vec<(&'static str, VirtualLights)> {
    let b1 = Clamping::default_bound(cornell().bounds().diagonal());
    vec![
        ("ir", VirtualLights::Points(Clamping::None)),
        ("pir-clamp", VirtualLights::Points(Clamping::progressive(b1))),
        ("pir-vsl", VirtualLights::Spheres { radius: Radius::Density, alpha: Some(0.6) }),
    ]
}

/// Paired z of the per-iteration image means of two renders with the same seed (the same VPLs
/// each iteration), per channel: iterations are independent, so the mean difference over n
/// iterations has the standard error of the n differences.
fn paired_z(a: &Rendered, b: &Rendered) -> [f64; 3] {
    let n = a.iteration_means.len() as f64;
    std::array::from_fn(|c| {
        let d: Vec<f64> =
            a.iteration_means.iter().zip(&b.iteration_means).map(|(x, y)| x[c] - y[c]).collect();
        let mean = d.iter().sum::<f64>() / n;
        let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        mean / (var / n).sqrt().max(1e-300)
    })
}

/// For ir, pir-clamp and pir-vsl on the Cornell box at 32×32, 48 iterations with the same VPLs
/// gathered exhaustively and with k = 4 tree samples: the expected images are equal (the
/// sampled gather is unbiased for the exhaustive sum of every iteration), so the paired
/// difference of the image means is a zero-mean t statistic with 47 degrees of freedom per
/// channel. |t| < 4.5 has a false-alarm probability below 5·10⁻⁵ per channel, so below 5·10⁻⁴
/// for the nine (Šidák). No sample may be dropped as non-finite.
#[test]
fn tree_gather_converges_to_the_exhaustive_gather() {
    let scene = cornell();
    let job = Job { width: 32, height: 32, iterations: 48, seed: 5, ..Job::default() };
    for (name, lights) in methods() {
        let all = job.run(&scene, &mut InstantRadiosity::new(lights, 32));
        let tree =
            job.run(&scene, &mut InstantRadiosity::new(lights, 32).with_gather(Gather::Tree { samples: 4 }));
        let z = paired_z(&tree, &all);
        eprintln!(
            "{name}: all {:?} tree {:?}, shadow rays all {} tree {}, paired t {z:.2?}",
            all.image().mean(),
            tree.image().mean(),
            all.stats.counters.shadow_rays,
            tree.stats.counters.shadow_rays
        );
        assert!(z.iter().all(|z| z.abs() < 4.5), "{name}: t = {z:?}");
        assert_eq!(all.stats.dropped + tree.stats.dropped, 0, "{name}");
        assert!(tree.stats.counters.shadow_rays < all.stats.counters.shadow_rays, "{name}");
    }
}

/// The same seed gives the same image, bit for bit, on one thread and on two (every random
/// number of the tree gather comes from the camera vertex's sampler, and the tree does not
/// depend on the thread count).
#[test]
fn tree_gather_is_independent_of_the_thread_count() {
    let scene = cornell();
    for (name, lights) in methods() {
        let run = |threads| {
            let job = Job { width: 16, height: 16, iterations: 3, seed: 9, threads, ..Job::default() };
            job.run(&scene, &mut InstantRadiosity::new(lights, 300).with_gather(Gather::Tree { samples: 8 }))
                .image()
        };
        let (one, two) = (run(1), run(2));
        let bits = |img: &pir::image::RgbImage| -> Vec<[u32; 3]> {
            img.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
        };
        assert_eq!(bits(&one), bits(&two), "{name}");
    }
}
