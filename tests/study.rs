//! `pir reference` and `pir study` end to end, on the Cornell box at 32×32 with budgets of a
//! fraction of a second: every output is written, the CSV agrees with the final images, and
//! bad input fails cleanly before any rendering.

use std::path::{Path, PathBuf};

mod common;
use common::binary::{assert_clean_failure, pir, pir_interrupted, stderr};
use common::study_csv::{Row, read_csv};

use pir::image::{metrics, read_exr};

fn scene() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/scene.toml").display().to_string()
}

/// A 32×32 reference in `dir`/ref.exr.
fn make_reference(dir: &Path) -> PathBuf {
    let o =
        pir(&["reference", &scene(), "--time", "0.3", "--resolution", "32", "32", "--out", "ref.exr"], dir);
    assert!(o.status.success(), "{}", stderr(&o));
    dir.join("ref.exr")
}

#[test]
fn reference_then_study_writes_every_output_consistently() {
    let dir = tempfile::tempdir().unwrap();
    let reference = make_reference(dir.path());
    let (ref_img, attrs) = read_exr(&reference).unwrap();
    assert_eq!((ref_img.width, ref_img.height), (32, 32));
    let spp: u64 = attrs.iter().find(|(k, _)| k == "pir.spp").unwrap().1.parse().unwrap();
    assert!(spp >= 1);

    let o = pir(
        &[
            "study",
            &scene(),
            "--reference",
            "ref.exr",
            "--methods",
            "pt,pir-clamp",
            "--time",
            "0.5",
            "--first-snapshot",
            "0.05",
            "--vpls",
            "64",
            "--target-rel-mse",
            "1e3",
            "--out",
            "out",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("out");
    for f in [
        "snapshots.csv",
        "study.json",
        "report.md",
        "sheet.png",
        "rmse.png",
        "rmse.svg",
        "rel_mse.png",
        "rel_mse.svg",
        "hdr_flip.png",
        "hdr_flip.svg",
        "max_rel_se.png",
        "max_rel_se.svg",
        "final-pt.exr",
        "final-pir-clamp.exr",
    ] {
        let len = std::fs::metadata(out.join(f)).unwrap_or_else(|e| panic!("{f}: {e}")).len();
        assert!(len > 100, "{f} is {len} bytes");
    }
    let svg = std::fs::read_to_string(out.join("rel_mse.svg")).unwrap();
    assert!(svg.contains("wall-clock time (s)") && svg.contains("relative MSE") && svg.contains("pir-clamp"));

    let rows = read_csv(&out.join("snapshots.csv"));
    for label in ["pt", "pir-clamp"] {
        let r: Vec<&Row> = rows.iter().filter(|r| r.label == label).collect();
        assert!(r.len() >= 3, "{label}: {} snapshots", r.len());
        assert!(r.windows(2).all(|w| w[0].time < w[1].time && w[0].iterations < w[1].iterations), "{label}");
        let last = r.last().unwrap();
        assert!(last.time >= 0.5 && last.time < 3.0, "{label}: {}", last.time);
        assert!(r.iter().all(|x| x.flip > 0.0 && x.flip < 1.0), "{label}");
        // The final row is the final image's error.
        let (img, _) = read_exr(&out.join(format!("final-{label}.exr"))).unwrap();
        let m = metrics(&img, &ref_img).unwrap();
        assert!((m.rmse - last.rmse).abs() <= 1e-6 * m.rmse, "{label}: {} vs {}", m.rmse, last.rmse);
        assert!((m.rel_mse - last.rel_mse).abs() <= 1e-6 * m.rel_mse, "{label}");
        assert!((m.max_rel_se - last.max_rel_se).abs() <= 1e-6 * m.max_rel_se, "{label}");
        let mean = m.mean_rel_diff().iter().sum::<f64>() / 3.0;
        assert!((mean - last.mean_rel_diff).abs() <= 1e-6 * mean.abs().max(1e-6), "{label}");
    }

    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("study.json")).unwrap()).unwrap();
    assert_eq!(json["snapshots"].as_array().unwrap().len(), rows.len());
    assert_eq!(json["study"]["width"], 32);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    for link in ["(rel_mse.png)", "(hdr_flip.svg)", "(sheet.png)", "(snapshots.csv)", "| pir-clamp |"] {
        assert!(report.contains(link), "report lacks {link}");
    }
    // Every line is below an error of 1,000 at its first snapshot.
    assert!(report.contains("## Time to reach a relative MSE of 1.000e3"), "{report}");
    let first_pt = rows.iter().find(|r| r.label == "pt").unwrap();
    assert!(report.contains(&format!("| pt | {:.2} | {} |", first_pt.time, first_pt.iterations)), "{report}");
}

/// With --iterations every number but the times is the same from run to run, and snapshots
/// fall on the log-spaced iteration counts.
#[test]
fn iteration_budgets_are_reproducible() {
    let dir = tempfile::tempdir().unwrap();
    make_reference(dir.path());
    let study = |out: &str, threads: &str| {
        let args = [
            "study",
            &scene(),
            "--reference",
            "ref.exr",
            "--methods",
            "pt,ir-clamp",
            "--iterations",
            "8",
            "--vpls",
            "8",
            "--threads",
            threads,
            "--out",
            out,
        ];
        let o = pir(&args, dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        read_csv(&dir.path().join(out).join("snapshots.csv"))
    };
    let (a, b) = (study("a", "1"), study("b", "2"));
    let its: Vec<u64> = a.iter().filter(|r| r.label == "pt").map(|r| r.iterations).collect();
    assert_eq!(its, [1, 2, 3, 4, 6, 8]);
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!((&x.label, x.iterations), (&y.label, y.iterations));
        assert_eq!((x.rmse, x.rel_mse, x.flip, x.max_rel_se), (y.rmse, y.rel_mse, y.flip, y.max_rel_se));
    }
    let report = std::fs::read_to_string(dir.path().join("a/report.md")).unwrap();
    assert!(report.contains("8 iterations per line"), "{report}");
    let o =
        pir(&["study", &scene(), "--reference", "ref.exr", "--iterations", "4", "--time", "1"], dir.path());
    assert_clean_failure(&o, &["--iterations", "--time"]);
    let o = pir(&["study", &scene(), "--reference", "ref.exr", "--iterations", "0"], dir.path());
    assert_clean_failure(&o, &["--iterations 0"]);
}

#[test]
fn sweep_runs_one_line_per_value() {
    let dir = tempfile::tempdir().unwrap();
    make_reference(dir.path());
    let o = pir(
        &[
            "study",
            &scene(),
            "--reference",
            "ref.exr",
            "--sweep",
            "alpha=0.3,0.7",
            "--methods",
            "pir-clamp",
            "--time",
            "0.1",
            "--vpls",
            "16",
            "--out",
            "sw",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = read_csv(&dir.path().join("sw/snapshots.csv"));
    let mut labels: Vec<&str> = rows.iter().map(|r| r.label.as_str()).collect();
    labels.dedup();
    assert_eq!(labels, ["pir-clamp α=0.3", "pir-clamp α=0.7"]);
    for f in ["sweep-rel_mse.png", "sweep-rel_mse.svg", "sweep-hdr_flip.png", "final-pir-clamp_alpha-0.3.exr"]
    {
        assert!(dir.path().join("sw").join(f).is_file(), "{f} missing");
    }
    let report = std::fs::read_to_string(dir.path().join("sw/report.md")).unwrap();
    assert!(report.contains("## Parameter sweep: alpha"));
}

#[test]
fn bad_input_fails_cleanly_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene();
    let o = pir(&["study", &s, "--reference", "missing.exr", "--time", "0.1"], d);
    assert_clean_failure(&o, &["missing.exr"]);
    let reference = make_reference(d);
    let r = reference.display().to_string();
    let o = pir(&["study", &s, "--reference", &r, "--methods", "pt,bogus", "--time", "0.1"], d);
    assert_clean_failure(&o, &["unknown method", "bogus"]);
    let o = pir(&["study", &s, "--reference", &r, "--sweep", "beta=1,2", "--time", "0.1"], d);
    assert_clean_failure(&o, &["beta"]);
    let o =
        pir(&["study", &s, "--reference", &r, "--methods", "pt", "--sweep", "alpha=0.5", "--time", "0.1"], d);
    assert_clean_failure(&o, &["none of the methods"]);
    let o = pir(&["study", "nope.toml", "--reference", &r, "--time", "0.1"], d);
    assert_clean_failure(&o, &["nope.toml"]);
    let o = pir(&["study", &s, "--reference", &r, "--resolution", "20", "20", "--time", "0.1"], d);
    assert_clean_failure(&o, &["differs from the reference"]);
    std::fs::write(d.join("afile"), "x").unwrap();
    let o = pir(&["study", &s, "--reference", &r, "--out", "afile/sub", "--time", "0.1"], d);
    assert_clean_failure(&o, &["afile/sub"]);
    let o = pir(&["study", &s, "--reference", &r, "--time", "-1"], d);
    assert_clean_failure(&o, &["--time"]);
    let o = pir(&["reference", &s, "--time", "0.1", "--out", "x.png"], d);
    assert_clean_failure(&o, &["x.png"]);
    assert!(!d.join("study-cornell-box").exists());
}

/// A reference that pir rendered from the scene at the study's seed shares its random numbers
/// with the study's lines (`pt`'s first iterations are its own): refused, naming the remedy.
/// `pir reference` renders at a seed of its own, so a study at the scene's seed may use it.
#[test]
fn a_reference_at_the_studys_seed_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene();
    let reference = make_reference(d);
    let (_, attrs) = read_exr(&reference).unwrap();
    let seed = attrs.iter().find(|(k, _)| k == "pir.seed").unwrap().1.clone();
    assert_ne!(seed, "0", "the scene's seed");
    let study = |reference: &str, seed: &str| {
        let args = ["study", &s, "--reference", reference, "--methods", "pt", "--iterations", "1"];
        pir(&[&args[..], &["--seed", seed, "--out", "out"]].concat(), d)
    };
    let o = study("ref.exr", &seed);
    assert_clean_failure(&o, &["ref.exr", "same scene", &format!("seed {seed}"), "--seed"]);
    let o = pir(
        &[
            "render",
            &s,
            "--method",
            "pt",
            "--spp",
            "1",
            "--resolution",
            "32",
            "32",
            "--seed",
            "5",
            "-q",
            "--out",
            "same.exr",
        ],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = study("same.exr", "5");
    assert_clean_failure(&o, &["same.exr", "seed 5"]);
    let o = study("same.exr", "6");
    assert!(o.status.success(), "{}", stderr(&o));
}

/// SIGINT during a study ends the running line after its iteration and writes the study of
/// the lines raced so far, with exit 0: an interrupted study loses nothing already raced.
#[test]
fn interrupted_study_writes_the_lines_raced_so_far() {
    let dir = tempfile::tempdir().unwrap();
    make_reference(dir.path());
    let args = ["study", &scene(), "--reference", "ref.exr", "--methods", "pt,pir-clamp", "--time", "600"];
    let args = [&args[..], &["--first-snapshot", "0.05", "--out", "st"]].concat();
    let o = pir_interrupted(&args, dir.path(), "-INT", std::time::Duration::from_millis(1500));
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("interrupted: writing the 1 of 2 lines"), "{err}");
    let rows = read_csv(&dir.path().join("st/snapshots.csv"));
    assert!(!rows.is_empty() && rows.iter().all(|r| r.label == "pt"), "only pt was raced");
    let last = rows.last().unwrap();
    assert!(last.time < 600.0 && last.iterations >= 1);
    assert!(dir.path().join("st/report.md").is_file() && dir.path().join("st/final-pt.exr").is_file());
}
