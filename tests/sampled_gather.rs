//! The sampled gathers, through a light tree (`Gather::Tree`) and resampled from a window of
//! candidates (`Gather::Resampled`), in whole renders: each converges to the image of the
//! exhaustive gather (`Gather::All`), and each is a function of the seed alone.

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

/// The sampled gathers under test: k = 4 tree samples, and k = 4 picks among windows of about
/// 16 candidates (runs of 4 of the 32 light paths, about 9 of their 75 VPLs, most runs
/// starting and ending within a chunk of the lanes, so that the window's choice and its edges
/// are tested too).
fn sampled() -> [(&'static str, Gather); 2] {
    [("tree", Gather::Tree { samples: 4 }), ("resample", Gather::Resampled { candidates: 16, samples: 4 })]
}

/// For ir, pir-clamp and pir-vsl on the Cornell box at 32×32, 48 iterations with the same VPLs
/// gathered exhaustively and by each sampled gather: the expected images are equal (a sampled
/// gather is unbiased for the exhaustive sum of every iteration), so the paired
/// difference of the image means is a zero-mean t statistic with 47 degrees of freedom per
/// channel. |t| < 4.5 has a false-alarm probability below 5·10⁻⁵ per channel, so below 5·10⁻⁴
/// for the nine (Šidák) of each gather. No sample may be dropped as non-finite.
#[test]
fn sampled_gathers_converge_to_the_exhaustive_gather() {
    let scene = cornell();
    let job = Job { width: 32, height: 32, iterations: 48, seed: 5, ..Job::default() };
    for (name, lights) in methods() {
        let all = job.run(&scene, &mut InstantRadiosity::new(lights, 32));
        for (how, gather) in sampled() {
            let sampled = job.run(&scene, &mut InstantRadiosity::new(lights, 32).with_gather(gather));
            let z = paired_z(&sampled, &all);
            eprintln!(
                "{name}: all {:?} {how} {:?}, shadow rays all {} {how} {}, paired t {z:.2?}",
                all.image().mean(),
                sampled.image().mean(),
                all.stats.counters.shadow_rays,
                sampled.stats.counters.shadow_rays
            );
            assert!(z.iter().all(|z| z.abs() < 4.5), "{name} {how}: t = {z:?}");
            assert_eq!(all.stats.dropped + sampled.stats.dropped, 0, "{name} {how}");
            assert!(sampled.stats.counters.shadow_rays < all.stats.counters.shadow_rays, "{name} {how}");
        }
    }
}

/// `pir-vsl` on the glossy Cornell box (glossy receivers and glossy spheres, whose cone
/// integrals are sampled, and whose candidates are estimated without their lobes): the
/// resampled gather, which evaluates only the picked spheres' integrals, converges to the
/// exhaustive gather's image, as above (|t| < 4.5 per channel). 160 iterations rather than
/// 48: a glossy receiver's picks have rare large weights, whose skew makes the paired mean
/// of few iterations fall below its expectation more often than above it (seeds 1–7 at 48
/// iterations: t down to −3.4, before this gather's change as after; at 768 iterations
/// within ±0.7).
#[test]
fn resampled_spheres_converge_on_glossy_receivers() {
    let scene = load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/glossy.toml")).unwrap();
    let job = Job { width: 32, height: 32, iterations: 160, seed: 7, ..Job::default() };
    let lights = VirtualLights::Spheres { radius: Radius::Density, alpha: Some(0.6) };
    let all = job.run(&scene, &mut InstantRadiosity::new(lights, 32));
    let gather = Gather::Resampled { candidates: 16, samples: 4 };
    let sampled = job.run(&scene, &mut InstantRadiosity::new(lights, 32).with_gather(gather));
    let z = paired_z(&sampled, &all);
    eprintln!("all {:?} resample {:?}, paired t {z:.2?}", all.image().mean(), sampled.image().mean());
    assert!(z.iter().all(|z| z.abs() < 4.5), "t = {z:?}");
    assert_eq!(all.stats.dropped + sampled.stats.dropped, 0);
}

/// The sampled gathers on glossy receivers, whose draws follow the receiver's GGX lobe (the
/// tree's descents mix it with the geometric importance; the resampled gather's estimate of a
/// point light includes it): `pir-clamp` (tree and resample) and `pir-vsl` (tree) on the glossy
/// Cornell box (GGX floor and boxes, α 0.22–0.24) converge to the exhaustive gather's image,
/// as above (|t| < 4.5 per channel, 160 iterations for the skew of glossy picks' weights).
#[test]
fn sampled_gathers_converge_on_glossy_receivers() {
    let scene = load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/glossy.toml")).unwrap();
    let job = Job { width: 32, height: 32, iterations: 160, seed: 8, ..Job::default() };
    let b1 = Clamping::default_bound(scene.bounds().diagonal());
    let points = VirtualLights::Points(Clamping::progressive(b1));
    let spheres = VirtualLights::Spheres { radius: Radius::Density, alpha: Some(0.6) };
    let tree = Gather::Tree { samples: 4 };
    let resample = Gather::Resampled { candidates: 16, samples: 4 };
    for (name, lights, gathers) in
        [("pir-clamp", points, vec![tree, resample]), ("pir-vsl", spheres, vec![tree])]
    {
        let all = job.run(&scene, &mut InstantRadiosity::new(lights, 32));
        for gather in gathers {
            let sampled = job.run(&scene, &mut InstantRadiosity::new(lights, 32).with_gather(gather));
            let z = paired_z(&sampled, &all);
            eprintln!(
                "{name} {gather:?}: all {:?} sampled {:?}, paired t {z:.2?}",
                all.image().mean(),
                sampled.image().mean()
            );
            assert!(z.iter().all(|z| z.abs() < 4.5), "{name} {gather:?}: t = {z:?}");
            assert_eq!(all.stats.dropped + sampled.stats.dropped, 0, "{name} {gather:?}");
        }
    }
}

/// The same seed gives the same image, bit for bit, on one thread and on two (every random
/// number of a sampled gather comes from the camera vertex's sampler, and the tree does not
/// depend on the thread count).
#[test]
fn sampled_gathers_are_independent_of_the_thread_count() {
    let scene = cornell();
    for (name, lights) in methods() {
        for (how, gather) in [
            ("tree", Gather::Tree { samples: 8 }),
            ("resample", Gather::Resampled { candidates: 64, samples: 8 }),
        ] {
            let run = |threads| {
                let job = Job { width: 16, height: 16, iterations: 3, seed: 9, threads, ..Job::default() };
                job.run(&scene, &mut InstantRadiosity::new(lights, 300).with_gather(gather)).image()
            };
            let (one, two) = (run(1), run(2));
            let bits = |img: &pir::image::RgbImage| -> Vec<[u32; 3]> {
                img.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
            };
            assert_eq!(bits(&one), bits(&two), "{name} {how}");
        }
    }
}
