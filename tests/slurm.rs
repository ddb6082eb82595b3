//! `docs/render-shards.sh slurm` on a real Slurm: a private one-node cluster (munged,
//! slurmctld, slurmd of Debian's slurm-wlm, started as root by `tests/slurm/cluster.sh` inside
//! a temporary folder, stopped at the end whatever happens) runs the script's job array and its
//! dependent merge, as a user would:
//!
//! - the merged image equals one uninterrupted run of the same iterations, bit for bit;
//! - a shard killed mid-render with SIGKILL (what a node failure does to it) fails its task, and
//!   its failure blocks the merge (`afterok`); `render-shards.sh requeue` (`scontrol requeue`)
//!   reruns it, its log says from which checkpointed iteration it resumed, the merge follows,
//!   and the merged image is still exactly that of one run;
//! - the shards' logs (no terminal there) show progress lines.
//!
//! Where Slurm cannot be started (not installed, not root, its daemons do not come up) the test
//! skips with the reason, and
//! fails with CI=true (`.ci/run` installs Slurm first). It takes about half a minute.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

mod common;
use common::require::skip_or_fail;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The private cluster; dropping it stops its daemons (and cancels its jobs).
struct Cluster {
    dir: PathBuf,
}

impl Cluster {
    /// Starts the cluster in `dir`, or `None` after [`skip_or_fail`] when Slurm cannot run here.
    fn start(dir: &Path) -> Option<Cluster> {
        let o = Command::new(repo().join("tests/slurm/cluster.sh"))
            .arg("start")
            .arg(dir)
            .output()
            .expect("run tests/slurm/cluster.sh");
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        match o.status.code() {
            Some(0) => Some(Cluster { dir: dir.to_path_buf() }),
            Some(3) => {
                // Stop whatever a partial start left running.
                drop(Cluster { dir: dir.to_path_buf() });
                skip_or_fail(&format!("slurm: {}", err.trim()));
                None
            }
            _ => {
                drop(Cluster { dir: dir.to_path_buf() });
                panic!("tests/slurm/cluster.sh start failed: {err}")
            }
        }
    }

    /// A command that talks to this cluster.
    fn command(&self, program: impl AsRef<std::ffi::OsStr>) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", self.dir.join("slurm.conf")).env("RUST_BACKTRACE", "1");
        c
    }

    /// Runs `program args` against the cluster and returns its standard output; panics on failure.
    fn run(&self, program: &str, args: &[&str]) -> String {
        let o = self.command(program).args(args).output().unwrap_or_else(|e| panic!("{program}: {e}"));
        assert!(o.status.success(), "{program} {args:?}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    }

    /// `docs/render-shards.sh MODE SCENE OUT N ARGS…` with single-CPU tasks.
    fn shards(&self, mode: &str, scene: &Path, out: &Path, n: u64, args: &[&str], checkpoint: &str) {
        let o = self
            .command(repo().join("docs/render-shards.sh"))
            .arg(mode)
            .arg(scene)
            .arg(out)
            .arg(n.to_string())
            .args(args)
            .env("PIR", env!("CARGO_BIN_EXE_pir"))
            .env("CPUS", "1")
            .env("CHECKPOINT", checkpoint)
            .env("PROGRESS", "1")
            .output()
            .expect("run docs/render-shards.sh");
        assert!(o.status.success(), "render-shards.sh {mode}: {}", String::from_utf8_lossy(&o.stderr));
    }

    /// (state, reason) of a job or array task, e.g. ("PENDING", "Dependency").
    fn job(&self, id: &str) -> (String, String) {
        let text = self.run("scontrol", &["-o", "show", "job", id]);
        let field = |k: &str| {
            text.split_whitespace()
                .find_map(|w| w.strip_prefix(k))
                .unwrap_or_else(|| panic!("no {k} in {text}"))
                .to_string()
        };
        (field("JobState="), field("Reason="))
    }

    /// Waits until `done` holds (checked every 200 ms), at most `limit`; else panics, showing the
    /// queue and the controller's log.
    fn wait(&self, what: &str, limit: Duration, mut done: impl FnMut() -> bool) {
        let start = Instant::now();
        while !done() {
            if start.elapsed() > limit {
                let queue = self.run("squeue", &["-a"]);
                let log = std::fs::read_to_string(self.dir.join("slurmctld.log")).unwrap_or_default();
                let tail: Vec<&str> = log.lines().rev().take(30).collect();
                panic!(
                    "waited {limit:?} for {what}; queue:\n{queue}\nslurmctld.log (last lines first):\n{}",
                    tail.join("\n")
                );
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    fn wait_state(&self, id: &str, state: &str) {
        self.wait(&format!("job {id} to be {state}"), Duration::from_secs(300), || self.job(id).0 == state);
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let stopped = Command::new(repo().join("tests/slurm/cluster.sh")).arg("stop").arg(&self.dir).output();
        if let Ok(o) = stopped
            && !o.status.success()
        {
            eprintln!("stopping the cluster: {}", String::from_utf8_lossy(&o.stderr));
        }
    }
}

/// The job ids `render-shards.sh slurm` recorded in OUT/slurm-jobs: (array, merge).
fn job_ids(out: &Path) -> (String, String) {
    let text = std::fs::read_to_string(out.join("slurm-jobs")).unwrap();
    let get = |k: &str| text.lines().find_map(|l| l.strip_prefix(k)).unwrap().trim().to_string();
    (get("array="), get("merge="))
}

/// The Cornell box at 64×48: a few milliseconds per iteration.
fn write_scene(dir: &Path) -> PathBuf {
    let obj = repo().join("scenes/cornell-box/CornellBox-Original.obj");
    let text = format!(
        "[camera]\neye = [0.0, 1.0, 3.9]\ntarget = [0.0, 1.0, 0.0]\nup = [0.0, 1.0, 0.0]\nfov = 40.0\n\
         resolution = [64, 48]\n\n[render]\nmax_depth = 8\nseed = 0\n\n[[mesh]]\nobj = {:?}\n",
        obj.to_str().unwrap()
    );
    let path = dir.join("small.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// One uninterrupted run of `spp` iterations of the method render-shards.sh uses by default.
fn one_run(scene: &Path, spp: u64, out: &Path) -> Vec<[u32; 3]> {
    let o = Command::new(env!("CARGO_BIN_EXE_pir"))
        .arg("render")
        .arg(scene)
        .args(["--method", "pir-clamp", "--spp", &spp.to_string(), "--no-preview", "-q", "--out"])
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    bits(out)
}

fn bits(path: &Path) -> Vec<[u32; 3]> {
    let (image, _) = pir::image::read_exr(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn iterations(path: &Path) -> Option<u64> {
    pir::render::state::read_state(path).ok().map(|s| s.film.iterations())
}

/// The pid of the `pir render` process writing `file` (found in /proc), if it runs.
fn renderer_of(file: &Path) -> Option<u32> {
    let want = file.to_str().unwrap();
    std::fs::read_dir("/proc").ok()?.flatten().find_map(|e| {
        let pid: u32 = e.file_name().to_str()?.parse().ok()?;
        let cmdline = std::fs::read(e.path().join("cmdline")).ok()?;
        let args: Vec<&[u8]> = cmdline.split(|b| *b == 0).collect();
        let is_render = args.iter().any(|a| *a == b"render");
        let writes = args.windows(2).any(|w| w[0] == b"--out" && w[1] == want.as_bytes());
        (is_render && writes).then_some(pid)
    })
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn slurm_job_array_merges_exactly_even_after_a_killed_and_requeued_shard() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let Some(cluster) = Cluster::start(&d.join("cluster")) else { return };
    let scene = write_scene(d);

    // An undisturbed array of 3 shards and its merge.
    let clean = d.join("clean");
    cluster.shards("slurm", &scene, &clean, 3, &["24"], "300");
    let (array, merge) = job_ids(&clean);
    cluster.wait_state(&merge, "COMPLETED");
    for k in 0..3 {
        assert_eq!(cluster.job(&format!("{array}_{k}")).0, "COMPLETED");
        let log = read(&clean.join(format!("slurm-{array}_{k}.log")));
        assert!(log.contains("pir: progress: 1/8 iterations"), "no progress line in the log: {log}");
    }
    assert_eq!(iterations(&clean.join("merged.exr")), Some(24));
    assert!(
        bits(&clean.join("merged.exr")) == one_run(&scene, 24, &d.join("one-24.exr")),
        "the merged image differs from one run of the same iterations"
    );

    // Shard 1 of 3 killed mid-render, after a checkpoint, as a node failure would kill it.
    let killed = d.join("killed");
    cluster.shards("slurm", &scene, &killed, 3, &["450"], "0.3");
    let (array, merge) = job_ids(&killed);
    let shard = killed.join("shard-1-of-3.exr");
    let mut pid = None;
    cluster.wait("a checkpoint of shard 1", Duration::from_secs(300), || {
        pid = renderer_of(&shard).filter(|_| iterations(&shard).is_some_and(|i| i >= 1));
        pid.is_some()
    });
    let pid = pid.unwrap();
    assert!(Command::new("kill").args(["-KILL", &pid.to_string()]).status().unwrap().success());
    let task = format!("{array}_1");
    cluster.wait_state(&task, "FAILED");
    let checkpointed = iterations(&shard).unwrap();
    assert!((1..150).contains(&checkpointed), "killed at iteration {checkpointed} of 150");

    // The failure blocks the merge: once the other shards are done, Slurm says it never can run.
    cluster.wait_state(&format!("{array}_0"), "COMPLETED");
    cluster.wait_state(&format!("{array}_2"), "COMPLETED");
    cluster.wait("the merge to be refused", Duration::from_secs(300), || {
        let (state, reason) = cluster.job(&merge);
        assert_eq!(state, "PENDING", "the merge ran although shard 1 failed");
        reason == "DependencyNeverSatisfied"
    });
    assert!(!killed.join("merged.exr").exists());

    // Rerun it: it resumes from its checkpoint, and the merge follows.
    cluster.shards("requeue", &scene, &killed, 3, &["1"], "0.3");
    cluster.wait_state(&merge, "COMPLETED");
    let log = read(&killed.join(format!("slurm-{task}.log")));
    let resumed = format!("pir: resuming {} at iteration {checkpointed}\n", shard.display());
    assert!(log.contains(&resumed), "the requeued shard did not resume from {checkpointed}: {log}");
    let rest = format!("pir: {} iterations (150 spp in the image)", 150 - checkpointed);
    assert!(log.contains(&rest), "the requeued shard did not render only the rest: {log}");
    assert_eq!(iterations(&killed.join("merged.exr")), Some(450));
    assert!(
        bits(&killed.join("merged.exr")) == one_run(&scene, 450, &d.join("one-450.exr")),
        "after the requeue, the merged image differs from one run of the same iterations"
    );
    drop(cluster);
}
