//! Golden images: a tiny render of every method (and of the configurations that take other
//! code paths) is hashed and compared with `tests/golden/hashes.txt`, whose hashes were made
//! at the estimator revision the file names. Any change to an estimator's image changes a
//! hash, and the test fails until `ESTIMATOR_REVISION` (`src/render/state.rs`) is bumped, the
//! bump noted in `CHANGELOG.md`, and the hashes regenerated with
//!
//!     PIR_BLESS=1 cargo test --release --test golden
//!
//! Blessing rewrites the file with this pir's hashes at this pir's revision. It refuses to
//! record a changed hash at the revision the old one was made at: that bump is what makes
//! checkpoints of the old estimators refused instead of resumed with the new ones. Entries
//! may be added or removed at the same revision.
//!
//! A hash is FNV-1a over the film's exact f64 sums and sums of squares (not the f32 image),
//! after 2 iterations at 24 × 20 pixels with seed 7 on 2 threads (the image does not depend
//! on the thread count). The renders use the brute-force backend, every ray against every
//! triangle in the scene's order, which has no version per vector width: the BVH picks an
//! AVX-512, AVX2 or baseline traversal at run time, the same hits by design, but a tie between
//! two triangles is where versions could part. The resampled gather's estimates pick an AVX2
//! or baseline version at run time too; both do the same IEEE operations (Rust contracts
//! nothing into fused multiply-adds). Measured 2026-12-06 on an AVX-512 machine, every entry's
//! hash was the same with the BVH's AVX-512, AVX2 and baseline traversals and the gather's
//! AVX2 and baseline estimates (forced by editing the `multiversion` attributes), and the same
//! with the BVH as with brute force.

mod common;

use clap::Parser;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use pir::accel::Backend;
use pir::integrator::MethodConfig;
use pir::render::state::ESTIMATOR_REVISION;
use pir::render::{Budget, Control, Renderer, SceneOptions};

const HASHES: &str = "tests/golden/hashes.txt";
const GLOSSY: &str = "scenes/cornell-box/glossy.toml";

/// Configurations beyond the methods' defaults, each a code path the defaults leave out: the
/// other gathers of points, spheres, weighed points and `pir-bdpt`, `pir-bdpt`'s connections
/// and light samples, a pilot that chooses more light paths and samples (the slit room),
/// vertex merging and none (the mirror-and-glass caustic), VPLs kept by their share of the
/// image (the near-mirror floor), no connections at near-specular vertices, explicit counts,
/// independent numbers and a short path; next-event estimation among a few emitting
/// triangles by importance, and by power where the default's pilot keeps it (the glowing box);
/// by importance among clusters of 80 emitting triangles, and the pilot's choice there (the
/// bulbs).
const EXTRA: &[&str] = &[
    "pt --sampler independent",
    "pt --max-depth 3",
    "ir --gather resample",
    "pir-clamp --gather tree",
    "pir-clamp --gather resample --gather-samples 3 --gather-candidates 20",
    "pir-clamp --vpls 7 --max-depth 3",
    "vsl --gather tree",
    "pir-vsl --gather resample --radius 0.05",
    "pir-mis --gather all",
    "pir-mis --gather tree",
    "pir-bdpt --gather all",
    "pir-bdpt --gather tree",
    "pir-bdpt --connect all --light-samples 3",
    "pir-bdpt --connect first-two --vpls 16",
    "pir-bdpt --sampler independent",
    "pir-bdpt --scene scenes/stress/slit/scene.toml",
    "pir-bdpt --connect glossy --scene scenes/stress/corner/scene.toml",
    "pir-bdpt --connect glossy --gather tree --scene scenes/stress/corner/scene.toml",
    "pir-bdpt --scene scenes/stress/caustic/scene.toml",
    "pir-bdpt --merge-radius 0 --scene scenes/stress/caustic/scene.toml",
    "pir-bdpt --scene scenes/stress/glossy/scene.toml",
    "pir-bdpt --scene tests/data/near-specular.toml",
    "pt --scene tests/data/glowing-box.toml",
    "pt --emitter-choice importance --scene tests/data/glowing-box.toml",
    "pir-bdpt --emitter-choice importance --scene tests/data/glowing-box.toml",
    "pt --scene tests/data/bulbs.toml",
    "pt --emitter-choice importance --scene tests/data/bulbs.toml",
];

/// What is rendered, as `pir render` flags (and `--scene`): every method at its defaults on
/// the Cornell box and on the glossy Cornell box, then [`EXTRA`].
fn entries() -> Vec<String> {
    let methods = common::methods();
    let defaults = methods.iter().map(|m| m.to_string());
    let glossy = methods.iter().map(|m| format!("{m} --scene {GLOSSY}"));
    defaults.chain(glossy).chain(EXTRA.iter().map(|e| e.to_string())).collect()
}

/// An entry's flags: the method, its parameters and the render options.
#[derive(Parser)]
struct Entry {
    #[command(flatten)]
    config: MethodConfig,
    #[command(flatten)]
    options: SceneOptions,
    #[arg(long, default_value = "scenes/cornell-box/scene.toml")]
    scene: PathBuf,
}

/// The hash of one entry's render.
fn render_hash(entry: &str) -> u64 {
    let args = ["golden", "--method"].into_iter().chain(entry.split_whitespace());
    let Entry { config, mut options, scene } =
        Entry::try_parse_from(args).unwrap_or_else(|e| panic!("{entry}: {e}"));
    config.validate().unwrap();
    options.accel = options.accel.or(Some(Backend::Brute));
    options.resolution = options.resolution.or(Some(vec![24, 20]));
    options.seed = options.seed.or(Some(7));
    options.threads = options.threads.or(Some(2));
    let scene = pir::scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(scene)).unwrap();
    let renderer = Renderer::new(&scene, &options).unwrap();
    let budget = Budget { iterations: Some(2), time: None };
    let (film, _) = renderer.render(&config, budget, |_, _| Control::Continue);
    let mut h = pir::hash::Fnv1a::default();
    let (w, hgt) = renderer.resolution();
    h.u64s(&[u64::from(w), u64::from(hgt), film.iterations()]);
    for v in film.sums().iter().chain(film.sums_of_squares()) {
        h.f64s(&v.to_array());
    }
    h.finish()
}

/// The stored file: the revision its hashes were made at, and the hash of each entry.
struct Golden {
    revision: u32,
    hashes: BTreeMap<String, u64>,
}

fn read_golden(path: &Path) -> Option<Golden> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty() && !l.starts_with('#'));
    let revision = lines.next()?.strip_prefix("estimator-revision ")?.trim().parse().ok()?;
    let mut hashes = BTreeMap::new();
    for line in lines {
        let (entry, hash) = line.trim().rsplit_once(' ').unwrap_or_else(|| panic!("{HASHES}: {line:?}"));
        let hash = u64::from_str_radix(hash, 16).unwrap_or_else(|_| panic!("{HASHES}: {line:?}"));
        hashes.insert(entry.trim().to_string(), hash);
    }
    Some(Golden { revision, hashes })
}

fn write_golden(path: &Path, entries: &[String], hashes: &BTreeMap<String, u64>) {
    let mut text = String::from(
        "# Pixel hashes of tests/golden.rs's renders, made at the estimator revision below (see that\n\
         # file). Regenerate with `PIR_BLESS=1 cargo test --release --test golden` after bumping\n\
         # ESTIMATOR_REVISION in src/render/state.rs; do not edit by hand.\n",
    );
    writeln!(text, "estimator-revision {ESTIMATOR_REVISION}").unwrap();
    let width = entries.iter().map(|e| e.len()).max().unwrap_or(0);
    for e in entries {
        writeln!(text, "{e:width$} {:016x}", hashes[e]).unwrap();
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn every_estimator_renders_its_golden_image() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(HASHES);
    let entries = entries();
    let start = std::time::Instant::now();
    let hashes: BTreeMap<String, u64> = entries.iter().map(|e| (e.clone(), render_hash(e))).collect();
    eprintln!("{} golden renders in {:.2} s", entries.len(), start.elapsed().as_secs_f64());
    let golden = read_golden(&path);
    let stored_revision = golden.as_ref().map(|g| g.revision);
    let stored = golden.map(|g| g.hashes).unwrap_or_default();
    let changed: Vec<&String> =
        entries.iter().filter(|e| stored.get(*e).is_some_and(|h| *h != hashes[*e])).collect();
    let bump = "bump ESTIMATOR_REVISION in src/render/state.rs, note it in CHANGELOG.md and regenerate \
                the hashes with `PIR_BLESS=1 cargo test --release --test golden`";
    if std::env::var_os("PIR_BLESS").is_some_and(|v| v == "1") {
        if stored_revision == Some(ESTIMATOR_REVISION) && !changed.is_empty() {
            let names: Vec<&str> = changed.iter().map(|e| e.as_str()).collect();
            panic!(
                "not blessed: the images of {} changed at estimator revision {ESTIMATOR_REVISION}, the \
                 revision their stored hashes were made at: bump ESTIMATOR_REVISION in src/render/state.rs \
                 and note it in CHANGELOG.md first",
                names.join(", ")
            );
        }
        write_golden(&path, &entries, &hashes);
        eprintln!("wrote {} at estimator revision {ESTIMATOR_REVISION}", path.display());
        return;
    }
    let mut problems = Vec::new();
    match stored_revision {
        None => problems.push(format!("{HASHES} is missing or malformed: regenerate it with `PIR_BLESS=1 cargo test --release --test golden`")),
        Some(r) if r != ESTIMATOR_REVISION => problems.push(format!(
            "the hashes in {HASHES} were made at estimator revision {r}, this pir's is {ESTIMATOR_REVISION}: \
             regenerate them with `PIR_BLESS=1 cargo test --release --test golden`"
        )),
        Some(_) => {
            for e in &changed {
                problems.push(format!("the image of {e} changed: {bump}"));
            }
            for e in entries.iter().filter(|e| !stored.contains_key(*e)) {
                problems.push(format!("no golden hash for {e}: add it with `PIR_BLESS=1 cargo test --release --test golden`"));
            }
            for e in stored.keys().filter(|e| !hashes.contains_key(*e)) {
                problems.push(format!("{e} is in {HASHES} but not rendered: remove it with `PIR_BLESS=1 cargo test --release --test golden`"));
            }
        }
    }
    assert!(problems.is_empty(), "\n{}", problems.join("\n"));
}
