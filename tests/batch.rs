//! Unattended batch rendering, end to end through the binary: checkpoints, resume (also after
//! SIGKILL), shards and merge, and the refusals that keep incompatible renders apart.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::binary::pir;
use pir::render::state::read_state;

fn scene() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/cornell-box/scene.toml")
        .to_string_lossy()
        .into_owned()
}

/// A small pir-clamp render (its clamp schedule uses the global iteration number).
fn render(dir: &Path, extra: &[&str]) -> Output {
    let s = scene();
    let mut args =
        vec!["render", &s, "--method", "pir-clamp", "--vpls", "8", "--resolution", "40", "32", "-q"];
    args.extend_from_slice(extra);
    let o = pir(&args, dir);
    assert!(o.status.success(), "{:?}: {}", extra, String::from_utf8_lossy(&o.stderr));
    o
}

fn pixels(path: &Path) -> Vec<glam::Vec3> {
    pir::image::read_exr(path).unwrap().0.pixels
}

fn iterations(path: &Path) -> u64 {
    let (_, attrs) = pir::image::read_exr(path).unwrap();
    attrs.iter().find(|(k, _)| k == "pir.iterations").unwrap().1.parse().unwrap()
}

fn failure(o: &Output) -> String {
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!e.contains("panicked") && !e.contains("backtrace"), "{e}");
    e
}

#[test]
fn resumed_render_equals_uninterrupted_render_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, &["--spp", "7", "--checkpoint", "1000", "--out", "full.exr"]);
    render(d, &["--spp", "3", "--checkpoint", "1000", "--out", "part.exr"]);
    render(d, &["--spp", "7", "--resume", "part.exr"]);
    assert_eq!(iterations(&d.join("part.exr")), 7);
    assert_eq!(pixels(&d.join("part.exr")), pixels(&d.join("full.exr")));
    let (a, b) = (read_state(&d.join("part.exr")).unwrap(), read_state(&d.join("full.exr")).unwrap());
    assert_eq!(a.film.sums(), b.film.sums());
    assert_eq!(a.film.sums_of_squares(), b.film.sums_of_squares());
}

/// Under `--emitter-choice auto` (the default) a resumed render takes the choice its file
/// made, not its pilot's again: a render of the glowing box by importance (where the pilot
/// would pick by power) resumes without the flag, and ends as one uninterrupted render.
#[test]
fn a_resumed_render_keeps_the_emitter_choice_of_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let glowing = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/glowing-box.toml");
    let glowing = glowing.to_string_lossy().into_owned();
    let run = |extra: &[&str]| {
        let args =
            [&["render", glowing.as_str(), "--method", "pt", "--resolution", "24", "20", "-q"][..], extra];
        let o = pir(&args.concat(), d);
        assert!(o.status.success(), "{extra:?}: {}", String::from_utf8_lossy(&o.stderr));
    };
    run(&["--spp", "4", "--emitter-choice", "importance", "--out", "full.exr"]);
    run(&["--spp", "2", "--emitter-choice", "importance", "--checkpoint", "1000", "--out", "part.exr"]);
    run(&["--spp", "4", "--resume", "part.exr"]);
    assert_eq!(
        read_state(&d.join("part.exr")).unwrap().job.emitter_choice,
        pir::light::EmitterChoice::Importance
    );
    assert_eq!(pixels(&d.join("part.exr")), pixels(&d.join("full.exr")));
    // Asked for by power, it is another render.
    let s = glowing.as_str();
    let o = pir(
        &[
            "render",
            s,
            "--method",
            "pt",
            "--resolution",
            "24",
            "20",
            "-q",
            "--spp",
            "6",
            "--resume",
            "part.exr",
            "--emitter-choice",
            "power",
        ],
        d,
    );
    assert!(failure(&o).contains("emitter choice: power here, importance in the file"));
}

/// `pir-bdpt` chooses its light paths by the scene (a pilot before the first iteration):
/// in the slit room, where it traces many more than its fewest, a resumed render still
/// equals the uninterrupted one, and the summary says how many.
#[test]
fn light_paths_chosen_by_the_scene_resume_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let slit = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/stress/slit/scene.toml");
    let slit = slit.to_string_lossy();
    let run = |extra: &[&str]| {
        let args = [&["render", &slit, "--method", "pir-bdpt", "--resolution", "24", "20"], extra].concat();
        let o = pir(&args, d);
        assert!(o.status.success(), "{extra:?}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let summary = run(&["--spp", "5", "--checkpoint", "1000", "--out", "full.exr"]);
    let paths: u64 = summary
        .split(" VPLs per iteration from ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no light paths in the summary: {summary}"));
    assert!(paths > pir::integrator::BDPT_PATHS as u64, "{paths} light paths per iteration");
    // The light samples chosen for the slit's hidden emitters are in the summary too.
    let samples: u32 = summary
        .lines()
        .find(|line| line.contains(" light samples at the first vertex"))
        .and_then(|line| line.trim_start_matches("pir: ").split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no light samples in the summary: {summary}"));
    assert!(samples > pir::integrator::DEFAULT_LIGHT_SAMPLES, "{samples} light samples");
    run(&["--spp", "2", "--checkpoint", "1000", "--out", "part.exr", "-q"]);
    run(&["--spp", "5", "--resume", "part.exr", "-q"]);
    assert_eq!(pixels(&d.join("part.exr")), pixels(&d.join("full.exr")));
}

/// Every method (tests/common's list) renders with checkpoints after each iteration, resumes
/// from one to exactly the film of an uninterrupted render, and records in the EXR its name,
/// each of its integrator's parameters and its job.
#[test]
fn every_method_resumes_and_records_its_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene();
    let loaded = pir::scene::load(s.as_ref()).unwrap();
    // (At the renders' resolution: `pir-bdpt`'s pilot looks through the camera's frame.)
    let options = pir::render::SceneOptions { resolution: Some(vec![20, 16]), ..Default::default() };
    let renderer = pir::render::Renderer::new(&loaded, &options).unwrap();
    for m in common::methods() {
        let run = |extra: &[&str]| {
            let args =
                [&["render", &s, "--method", m, "--resolution", "20", "16", "-q", "--no-preview"], extra];
            let o = pir(&args.concat(), d);
            assert!(o.status.success(), "{m} {extra:?}: {}", String::from_utf8_lossy(&o.stderr));
        };
        let (full, part) = (format!("{m}-full.exr"), format!("{m}-part.exr"));
        run(&["--spp", "4", "--checkpoint", "1000", "--out", &full]);
        // A checkpoint after every iteration (the interval is a nanosecond), then a resume.
        run(&["--spp", "2", "--checkpoint", "1e-9", "--out", &part]);
        assert_eq!(iterations(&d.join(&part)), 2, "{m}");
        run(&["--spp", "4", "--resume", &part]);
        let (a, b) = (read_state(&d.join(&part)).unwrap(), read_state(&d.join(&full)).unwrap());
        assert_eq!(a.film.iterations(), 4, "{m}");
        assert!(
            a.film.sums() == b.film.sums() && a.film.sums_of_squares() == b.film.sums_of_squares(),
            "{m}"
        );
        assert_eq!(pixels(&d.join(&part)), pixels(&d.join(&full)), "{m}");
        assert_eq!(a.job, b.job, "{m}");
        assert_eq!(a.job.config.method.name(), m);
        // The method and every parameter its integrator reports, as the same scene and seed
        // give them in this process.
        let (_, attrs) = pir::image::read_exr(&d.join(&part)).unwrap();
        let get = |k: &str| attrs.iter().find(|(a, _)| a == k).map(|(_, v)| v.as_str());
        assert_eq!(get("pir.method"), Some(m));
        assert_eq!(get("pir.version"), Some(env!("CARGO_PKG_VERSION")));
        let config = pir::integrator::MethodConfig::new(m.parse().unwrap());
        for (k, v) in renderer.parameters(&config) {
            assert_eq!(get(&format!("pir.param.{k}")), Some(v.as_str()), "{m}: pir.param.{k} in {attrs:?}");
        }
    }
}

#[test]
fn killed_render_resumes_from_its_last_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene();
    let mut child = Command::new(env!("CARGO_BIN_EXE_pir"))
        .args(["render", &s, "--method", "pt", "--resolution", "40", "32", "-q", "--spp", "1000000"])
        .args(["--checkpoint", "0.2", "--out", "k.exr", "--no-preview"])
        .current_dir(d)
        .spawn()
        .unwrap();
    // Wait for a checkpoint with some iterations in it, then kill without warning.
    let path = d.join("k.exr");
    let start = std::time::Instant::now();
    while !(path.exists() && iterations(&path) >= 2) {
        assert!(start.elapsed().as_secs() < 60, "no checkpoint written");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let done = iterations(&path);
    let target = (done + 5).to_string();
    let common = ["render", &s, "--method", "pt", "--resolution", "40", "32", "-q", "--no-preview"];
    let o = pir(&[&common[..], &["--spp", &target, "--resume", "k.exr"]].concat(), d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = pir(&[&common[..], &["--spp", &target, "--out", "straight.exr"]].concat(), d);
    assert!(o.status.success());
    assert_eq!(pixels(&path), pixels(&d.join("straight.exr")));
    // Only the final files: no temporary file of the killed run is left behind.
    let mut names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["k.exr", "straight.exr"]);
}

#[test]
fn merged_shards_equal_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, &["--spp", "7", "--out", "one.exr", "--checkpoint", "1000"]);
    for k in 0..3 {
        render(d, &["--spp", "7", "--shard", &format!("{k}/3"), "--out", &format!("s{k}.exr")]);
    }
    assert_eq!([0, 1, 2].map(|k| iterations(&d.join(format!("s{k}.exr")))), [3, 2, 2]);
    let o = pir(&["merge", "s2.exr", "s0.exr", "s1.exr", "-o", "merged.exr"], d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(iterations(&d.join("merged.exr")), 7);
    // Sums of the same samples in another order: equal to float rounding.
    for (a, b) in pixels(&d.join("merged.exr")).iter().zip(pixels(&d.join("one.exr"))) {
        assert!((*a - b).abs().max_element() <= 1e-6 * b.abs().max_element().max(1.0), "{a} vs {b}");
    }
    // A complete set of shards merges into a resumable render of all iterations.
    render(d, &["--spp", "9", "--resume", "merged.exr"]);
    assert_eq!(iterations(&d.join("merged.exr")), 9);
}

#[test]
fn incompatible_renders_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, &["--spp", "2", "--shard", "0/2", "--out", "a.exr"]);
    render(d, &["--spp", "2", "--shard", "1/2", "--seed", "5", "--out", "b.exr"]);
    render(d, &["--spp", "2", "--out", "plain.exr"]);
    let s = scene();
    // Resume with another seed, method or shard.
    let e = failure(&pir(
        &[
            "render",
            &s,
            "--method",
            "pir-clamp",
            "--vpls",
            "8",
            "--resolution",
            "40",
            "32",
            "--seed",
            "3",
            "--shard",
            "0/2",
            "--resume",
            "a.exr",
        ],
        d,
    ));
    assert!(e.contains("a.exr") && e.contains("seed: 3 here, 0 in the file"), "{e}");
    let e =
        failure(&pir(&["render", &s, "--resolution", "40", "32", "--shard", "0/2", "--resume", "a.exr"], d));
    assert!(e.contains("method: pir-bdpt here, pir-clamp in the file"), "{e}");
    let e = failure(&pir(
        &[
            "render",
            &s,
            "--method",
            "pir-clamp",
            "--vpls",
            "8",
            "--resolution",
            "40",
            "32",
            "--resume",
            "a.exr",
        ],
        d,
    ));
    assert!(e.contains("shard: 0/1 here, 0/2 in the file"), "{e}");
    // A plain EXR cannot be resumed.
    let e = failure(&pir(
        &[
            "render",
            &s,
            "--method",
            "pir-clamp",
            "--vpls",
            "8",
            "--resolution",
            "40",
            "32",
            "--resume",
            "plain.exr",
        ],
        d,
    ));
    assert!(e.contains("plain.exr") && e.contains("not a resumable pir render"), "{e}");
    // Merge: other seed, the same shard twice.
    let e = failure(&pir(&["merge", "a.exr", "b.exr", "-o", "m.exr"], d));
    assert!(e.contains("b.exr") && e.contains("seed"), "{e}");
    let e = failure(&pir(&["merge", "a.exr", "a.exr", "-o", "m.exr"], d));
    assert!(e.contains("overlap"), "{e}");
    assert!(!d.join("m.exr").exists());
    let e = failure(&pir(&["render", &s, "--shard", "2/2"], d));
    assert!(e.contains("K/N"), "{e}");
    // A shard of another estimator revision or another layout: neither resumed nor merged.
    let stored = pir::image::read_exr_with_channels(&d.join("a.exr")).unwrap();
    let rewrite = |key: &str, value: String, to: &str| {
        let mut attrs = stored.attributes.clone();
        attrs.iter_mut().find(|(k, _)| k == key).unwrap().1 = value;
        pir::image::write_exr_with_channels(&d.join(to), &stored.image, &attrs, stored.channels.clone())
            .unwrap();
    };
    let revision = pir::render::state::ESTIMATOR_REVISION;
    rewrite("pir.job.estimator", (revision + 1).to_string(), "other-estimator.exr");
    rewrite("pir.job.layout", (pir::render::state::LAYOUT + 1).to_string(), "other-layout.exr");
    let args =
        ["render", &s, "--method", "pir-clamp", "--vpls", "8", "--resolution", "40", "32", "--shard", "0/2"];
    let e = failure(&pir(&[&args[..], &["--resume", "other-estimator.exr"]].concat(), d));
    let expected = format!(
        "estimator revision {} (by pir {}), this pir's is {revision}",
        revision + 1,
        env!("CARGO_PKG_VERSION")
    );
    assert!(e.contains("other-estimator.exr") && e.contains(&expected) && e.contains("bit for bit"), "{e}");
    let e = failure(&pir(&["merge", "other-estimator.exr", "b.exr", "-o", "m.exr"], d));
    assert!(e.contains("other-estimator.exr") && e.contains("mix two estimators"), "{e}");
    let e = failure(&pir(&["merge", "b.exr", "other-layout.exr", "-o", "m.exr"], d));
    assert!(e.contains("other-layout.exr") && e.contains("written by a newer pir"), "{e}");
    assert!(!d.join("m.exr").exists());
}
