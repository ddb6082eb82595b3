//! The `pir` binary end to end: a render writes its EXR (with metadata) and PNG and nothing
//! else; bad input gives one clear message naming the problem, a non-zero exit, no panic and
//! no backtrace (with RUST_BACKTRACE=1 set, as on the render nodes), and no file left behind.

use std::path::{Path, PathBuf};

mod common;
use common::binary::{assert_clean_failure, pir, pir_interrupted, stderr};

fn scene() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/scene.toml")
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn render_writes_exr_with_metadata_and_png_only() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    let o = pir(
        &[
            "render",
            s.to_str().unwrap(),
            "--spp",
            "2",
            "--resolution",
            "32",
            "24",
            "--seed",
            "7",
            "--out",
            "img.exr",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(files_in(dir.path()), vec!["img.exr", "img.png"]);
    let (img, attrs) = pir::image::read_exr(&dir.path().join("img.exr")).unwrap();
    assert_eq!((img.width, img.height), (32, 24));
    let get = |k: &str| attrs.iter().find(|(a, _)| a == k).map(|(_, v)| v.clone()).unwrap_or_default();
    assert_eq!(get("pir.method"), "pir-bdpt");
    assert_eq!(get("pir.seed"), "7");
    assert_eq!(get("pir.iterations"), "2");
    assert_eq!(get("pir.max_depth"), "8");
    assert!(get("pir.scene").ends_with("scene.toml"));
    assert!(!get("pir.accel").is_empty());
    assert!(get("pir.render_time_s").parse::<f64>().is_ok());
    assert!(img.mean()[0] > 0.0);
    // Standard error is not a terminal here (as in a batch job's log): progress comes as lines.
    assert!(stderr(&o).contains("pir: progress: 1/2 iterations (50 %), "), "{}", stderr(&o));
    assert!(stderr(&o).contains("pir: scene read in "), "{}", stderr(&o));
    assert!(stderr(&o).contains("pir: estimated peak memory 0.01 GiB (film "), "{}", stderr(&o));
}

#[test]
fn every_method_renders() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    // Every registered method, by construction.
    for m in pir::integrator::Method::all() {
        let m = m.name();
        let out = format!("{m}.exr");
        let o = pir(
            &[
                "render",
                s.to_str().unwrap(),
                "--method",
                m,
                "--spp",
                "2",
                "--vpls",
                "8",
                "--resolution",
                "16",
                "16",
            ]
            .into_iter()
            .chain(["--out", &out, "--no-preview"])
            .collect::<Vec<_>>(),
            dir.path(),
        );
        assert!(o.status.success(), "{m}: {}", stderr(&o));
        let (_, attrs) = pir::image::read_exr(&dir.path().join(&out)).unwrap();
        assert!(attrs.contains(&("pir.method".to_string(), m.to_string())), "{m}: {attrs:?}");
    }
    // Every VPL method also gathers through the light tree and by resampling, which the
    // metadata records.
    type Gather<'a> = (&'a str, &'a [&'a str], &'a [(&'a str, &'a str)]);
    let gathers: [Gather; 2] = [
        (
            "tree",
            &["--gather", "tree", "--gather-samples", "3"],
            &[("gather", "tree"), ("gather-samples", "3")],
        ),
        (
            "resample",
            &["--gather", "resample", "--gather-samples", "3", "--gather-candidates", "20"],
            &[("gather", "resample"), ("gather-samples", "3"), ("gather-candidates", "20")],
        ),
    ];
    for m in ["ir", "pir-clamp", "pir-vsl"] {
        for (how, flags, recorded) in gathers {
            let out = format!("{m}-{how}.exr");
            let args = ["render", s.to_str().unwrap(), "--method", m, "--spp", "2", "--vpls", "64"];
            let o = pir(
                &args
                    .into_iter()
                    .chain(flags.iter().copied())
                    .chain(["--resolution", "16", "16", "--out", &out, "--no-preview"])
                    .collect::<Vec<_>>(),
                dir.path(),
            );
            assert!(o.status.success(), "{m} {how}: {}", stderr(&o));
            let (img, attrs) = pir::image::read_exr(&dir.path().join(&out)).unwrap();
            assert!(img.mean()[0] > 0.0, "{m} {how}");
            for &(k, v) in recorded {
                assert!(attrs.iter().any(|(a, b)| a.ends_with(k) && b == v), "{m}: {k}={v} not in {attrs:?}");
            }
        }
    }
}

#[test]
fn bad_arguments_fail_cleanly_before_any_output() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    let s = s.to_str().unwrap();
    let cases: &[(&[&str], &[&str])] = &[
        (&["render", "missing.toml"], &["missing.toml"]),
        (&["render", s, "--spp", "0"], &["--spp"]),
        (&["render", s, "--time", "-1"], &["--time"]),
        (&["render", s, "--time", "NaN"], &["--time"]),
        (&["render", s, "--resolution", "0", "10"], &["resolution"]),
        (&["render", s, "--resolution", "100000", "100000"], &["resolution"]),
        (&["render", s, "--vpls", "0"], &["--vpls"]),
        (&["render", s, "--alpha", "1.5"], &["--alpha"]),
        (&["render", s, "--clamp", "-2"], &["--clamp"]),
        (&["render", s, "--radius", "0"], &["--radius"]),
        (&["render", s, "--gather", "cut"], &["--gather", "cut"]),
        (&["render", s, "--gather-samples", "0"], &["--gather-samples"]),
        (&["render", s, "--gather-samples", "1000"], &["--gather-samples"]),
        (&["render", s, "--gather-candidates", "0"], &["--gather-candidates"]),
        (&["render", s, "--gather-candidates", "5000"], &["--gather-candidates"]),
        (&["render", s, "--threads", "0"], &["--threads"]),
        (&["render", s, "--max-depth", "0"], &["--max-depth"]),
        (&["render", s, "--out", "no/such/dir/x.exr"], &["no/such/dir", "does not exist"]),
        (&["render", s, "--out", "x.png"], &["x.png", ".exr"]),
        (&["render", s, "--accel", "optix"], &["optix"]),
        (&["render", s, "--walker", "simd"], &["simd", "batched or scalar"]),
        (
            &["render", s, "--resolution", "8192", "8192", "--max-memory", "1"],
            &["would need about", "--max-memory"],
        ),
        (
            &["render", s, "--method", "ir", "--vpls", "16000000", "--max-memory", "1"],
            &["VPLs", "--max-memory"],
        ),
        (&["render", s, "--max-memory", "-1"], &["--max-memory"]),
        (&["render", s, "--progress-every", "0"], &["--progress-every"]),
        (&["render", s, "--progress-every", "-5"], &["--progress-every", "positive"]),
        (&["render", s, "--method", "photon"], &["photon"]),
        (&["compare", "a.exr", "b.exr"], &["a.exr"]),
    ];
    for (args, expected) in cases {
        let o = pir(args, dir.path());
        assert_clean_failure(&o, expected);
    }
    assert!(files_in(dir.path()).is_empty(), "left behind: {:?}", files_in(dir.path()));
}

#[test]
fn broken_scene_files_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| std::fs::write(dir.path().join(name), text).unwrap();
    let camera =
        "[camera]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\nup = [0, 1, 0]\nfov = 40\nresolution = [8, 8]\n";
    write("syntax.toml", "[camera\n");
    write("typo.toml", &format!("{camera}[render]\nmax_dept = 3\n"));
    write("noobj.toml", &format!("{camera}[[mesh]]\nobj = \"none.obj\"\n"));
    write("nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
    write(
        "nan.toml",
        &format!(
            "{camera}[[mesh]]\nobj = \"nan.obj\"\nmaterial = \"m\"\n[materials.m]\nkind = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\nemission = [1, 1, 1]\n"
        ),
    );
    write("dark.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    write(
        "dark.toml",
        &format!(
            "{camera}[[mesh]]\nobj = \"dark.obj\"\nmaterial = \"m\"\n[materials.m]\nkind = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n"
        ),
    );
    for (file, expected) in [
        ("syntax.toml", vec!["syntax.toml"]),
        ("typo.toml", vec!["typo.toml", "max_dept"]),
        ("noobj.toml", vec!["none.obj"]),
        ("nan.toml", vec!["nan.obj", "line 2"]),
        ("dark.toml", vec!["dark.toml", "emitter"]),
    ] {
        let o = pir(&["render", file, "--spp", "1"], dir.path());
        assert_clean_failure(&o, &expected);
    }
    let left: Vec<String> =
        files_in(dir.path()).into_iter().filter(|f| f.ends_with(".exr") || f.ends_with(".png")).collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn compare_reports_metrics_and_writes_an_error_map() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    for (out, seed) in [("a.exr", "1"), ("b.exr", "2")] {
        let o = pir(
            &[
                "render",
                s.to_str().unwrap(),
                "--spp",
                "1",
                "--resolution",
                "16",
                "16",
                "--seed",
                seed,
                "--out",
                out,
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = pir(&["compare", "a.exr", "a.exr"], dir.path());
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("RMSE          0.000000e0"), "{text}");
    let o = pir(&["compare", "a.exr", "b.exr", "--error-map", "err.png"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("relative MSE"));
    assert!(dir.path().join("err.png").exists());
    // A reference a whole factor larger is box-downsampled to the image's size: a.exr against
    // itself shrunk by 2 is the shrunk image against itself; a factor that is not whole fails.
    let (a, _) = pir::image::read_exr(&dir.path().join("a.exr")).unwrap();
    let half = a.downsample(2).unwrap();
    pir::image::write_exr(&dir.path().join("half.exr"), &half, &[]).unwrap();
    let o = pir(&["compare", "half.exr", "a.exr"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("RMSE          0.000000e0"));
    let o = pir(&["compare", "a.exr", "half.exr"], dir.path());
    assert_clean_failure(&o, &["half.exr", "by no whole factor"]);

    // Piped into a reader that has gone (`pir compare … | head -1`): no panic message, and
    // the status of a process ended by SIGPIPE (or success, had it written first).
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_pir"))
        .args(["compare", "a.exr", "b.exr"])
        .current_dir(dir.path())
        .env("RUST_BACKTRACE", "1")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success() || o.status.code() == Some(141), "{:?}: {}", o.status, stderr(&o));
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
}

#[test]
fn help_documents_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let o = pir(&["render", "--help"], dir.path());
    let text = String::from_utf8_lossy(&o.stdout);
    for flag in [
        "--method",
        "--spp",
        "--time",
        "--out",
        "--seed",
        "--threads",
        "--max-depth",
        "--resolution",
        "--accel",
        "--vpls",
        "--clamp",
        "--radius",
        "--alpha",
        "--gather",
        "--gather-samples",
        "--gather-candidates",
        "pir-vsl",
    ] {
        assert!(text.contains(flag), "render --help lacks {flag}");
    }
    let o = pir(&["compare", "--help"], dir.path());
    assert!(String::from_utf8_lossy(&o.stdout).contains("--error-map"));
}

/// `pir rays` measures every workload on the scene's backend with and without batches, and
/// reports hit shares that fit the scene: the Cornell box's camera sees a wall through nearly
/// every pixel, and half its bounce rays leave through the open front.
#[test]
fn rays_reports_each_workloads_rate() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    let args = ["rays", s.to_str().unwrap(), "--rays", "4096", "--resolution", "32", "32", "--threads", "2"];
    let o = pir(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(text.contains("32×32, 4096 rays per workload, 2 threads"), "{text}");
    let row = |name: &str| -> Vec<f64> {
        let line = text.lines().find(|l| l.starts_with(name)).unwrap_or_else(|| panic!("no {name}: {text}"));
        line[name.len()..].split_whitespace().filter_map(|w| w.parse().ok()).collect()
    };
    for name in ["camera, closest hit", "bounce, closest hit", "bounce, occlusion"] {
        let v = row(name);
        assert!(v.len() == 3 && v[0] > 0.0 && v[1] > 0.0, "{name}: {v:?}");
    }
    let (camera, bounce, occluded) =
        (row("camera")[2], row("bounce, closest")[2], row("bounce, occlusion")[2]);
    assert!(camera > 80.0 && (20.0..95.0).contains(&bounce), "{camera} {bounce}");
    assert_eq!(bounce, occluded);
    let o = pir(&["rays", s.to_str().unwrap(), "--rays", "3"], dir.path());
    assert_clean_failure(&o, &["--rays 3"]);
    let o = pir(&["rays", "missing.toml"], dir.path());
    assert_clean_failure(&o, &["missing.toml"]);
}

#[test]
fn time_budget_stops_the_render() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene();
    let start = std::time::Instant::now();
    let o = pir(
        &[
            "render",
            s.to_str().unwrap(),
            "--time",
            "0.5",
            "--resolution",
            "32",
            "32",
            "--out",
            "t.exr",
            "--no-preview",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // Generous: the budget is checked between iterations of a few milliseconds each.
    assert!(start.elapsed().as_secs_f64() < 30.0);
    let (_, attrs) = pir::image::read_exr(&dir.path().join("t.exr")).unwrap();
    let it: u64 = attrs.iter().find(|(k, _)| k == "pir.iterations").unwrap().1.parse().unwrap();
    assert!(it >= 1);
    assert_eq!(files_in(dir.path()), vec!["t.exr"]);
}

/// SIGINT and SIGTERM finish the running iteration, write a valid image and exit 0.
#[test]
fn interrupt_writes_the_image_and_exits_zero() {
    for signal in ["-INT", "-TERM"] {
        let dir = tempfile::tempdir().unwrap();
        let s = scene();
        let args =
            ["render", s.to_str().unwrap(), "--time", "600", "--resolution", "64", "64", "--out", "i.exr"];
        // Let it start rendering, then interrupt it.
        let o = pir_interrupted(&args, dir.path(), signal, std::time::Duration::from_millis(1500));
        let err = stderr(&o);
        assert!(o.status.success(), "{signal}: {err}");
        assert!(err.contains("interrupted"), "{err}");
        let (img, attrs) = pir::image::read_exr(&dir.path().join("i.exr")).unwrap();
        assert_eq!((img.width, img.height), (64, 64));
        let it: u64 = attrs.iter().find(|(k, _)| k == "pir.iterations").unwrap().1.parse().unwrap();
        assert!(it >= 1);
        assert_eq!(files_in(dir.path()), vec!["i.exr", "i.png"]);
    }
}

/// `pir-bdpt`'s summary names the materials where it connects nothing (near-specular), and
/// only where there are some; other methods print no such line.
#[test]
fn the_summary_names_the_near_specular_materials() {
    let dir = tempfile::tempdir().unwrap();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let near = root.join("tests/data/near-specular.toml");
    let run = |scene: &Path, method: &str| {
        let s = scene.to_string_lossy();
        let args =
            ["render", &s, "--method", method, "--spp", "1", "--resolution", "16", "16", "--no-preview"];
        let o = pir(&args, dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o).lines().find(|l| l.contains("near-specular materials")).map(str::to_string)
    };
    let line = run(&near, "pir-bdpt").expect("pir-bdpt names the near-specular materials");
    assert!(line.contains("sphere") && line.contains("shortBox") && !line.contains("floor"), "{line}");
    assert_eq!(run(&near, "pt"), None);
    assert_eq!(run(&scene(), "pir-bdpt"), None);
}
