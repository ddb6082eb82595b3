//! Running the `pir` binary from tests, as a render node would (with RUST_BACKTRACE=1).

use std::path::Path;
use std::process::{Command, Output};

/// Runs `pir ARGS` in `cwd` and waits for it.
pub fn pir(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pir"))
        .args(args)
        .current_dir(cwd)
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("run pir")
}

/// Runs `pir ARGS` in `cwd`, sends it `signal` (e.g. "-INT") after `after`, and waits for it.
pub fn pir_interrupted(args: &[&str], cwd: &Path, signal: &str, after: std::time::Duration) -> Output {
    let child = Command::new(env!("CARGO_BIN_EXE_pir"))
        .args(args)
        .current_dir(cwd)
        .env("RUST_BACKTRACE", "1")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run pir");
    std::thread::sleep(after);
    let kill = Command::new("kill").args([signal, &child.id().to_string()]).status().expect("run kill");
    assert!(kill.success(), "kill {signal} failed");
    child.wait_with_output().expect("wait for pir")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A failed run: non-zero exit, the expected words in the message, no panic or backtrace.
pub fn assert_clean_failure(o: &Output, expected: &[&str]) {
    let err = stderr(o);
    assert!(!o.status.success(), "expected failure, got success: {err}");
    for e in expected {
        assert!(err.contains(e), "message lacks {e:?}: {err}");
    }
    for bad in ["panicked", "stack backtrace", "RUST_BACKTRACE"] {
        assert!(!err.contains(bad), "{bad:?} in: {err}");
    }
}

/// Runs `pir render SCENE ARGS… -q --no-preview --out OUT` in `cwd`, asserts that it
/// succeeded (the failure names `what` and pir's stderr), and reads the image it wrote.
pub fn render(scene: &Path, args: &[&str], out: &Path, cwd: &Path, what: &str) -> pir::image::RgbImage {
    let mut all = vec!["render", scene.to_str().unwrap()];
    all.extend_from_slice(args);
    all.extend_from_slice(&["-q", "--no-preview", "--out", out.to_str().unwrap()]);
    let o = pir(&all, cwd);
    assert!(o.status.success(), "{what}: {}", stderr(&o));
    pir::image::read_exr(out).unwrap().0
}
