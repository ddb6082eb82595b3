//! Resumable renders: what a render is (the job) and how far it got (the film), stored in its
//! EXR so that it can be checkpointed, resumed, split into shards and merged.
//!
//! The EXR's R, G, B channels hold the image (the running mean) as always; a resumable EXR
//! adds the film's exact per-pixel sums and sums of squares (f64, each stored as two u32
//! channels of its bits, so nothing is rounded) and three text attributes: `pir.job.layout`
//! ([`LAYOUT`], the version of what the file holds and how), `pir.job.estimator`
//! ([`ESTIMATOR_REVISION`], the revision of the estimators that rendered it) and
//! `pir.job.state`, the JSON of the job (a typed value: the scene's fingerprint, the
//! [`MethodConfig`] as it decides the image, path length, seed, resolution), the shard and the
//! iterations done. A file of another layout or another estimator revision is refused with a
//! message that says which and why (`CHANGELOG.md` lists what changed at each).
//!
//! Iteration i's numbers are a function of the seed, the sampler and i alone (its samplers
//! come from `Streams::camera(sampler, seed, i)` and `Streams::light_paths`), so a render can
//! continue from any iteration with the same random numbers, and the iterations of a render can
//! be split into shards: shard K of N renders the global iterations K+1, K+1+N, K+1+2N, … (the
//! progressive schedules b_i, r_i use the global index). Merging adds sums and iteration counts.

use anyhow::{Context, Result, bail};
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;
use std::str::FromStr;

use super::Film;
use crate::image::{RgbImage, read_exr_with_channels, write_exr_with_channels};
use crate::integrator::MethodConfig;
use crate::light::{EmitterChoice, Emitters};
use crate::sampling::SamplerKind;
use crate::scene::Scene;

/// Which share of a render's iterations this process renders: shard `index` of `count`.
/// Serialized as its text, "K/N", and checked when read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Shard {
    /// The whole render.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// The global iteration number (from 1) of this shard's `m`-th iteration (from 0).
    pub fn global_iteration(&self, m: u64) -> u64 {
        self.index + 1 + m * self.count
    }

    /// How many of the global iterations 1..=total belong to this shard.
    pub fn iterations_of(&self, total: u64) -> u64 {
        if total <= self.index { 0 } else { (total - self.index - 1) / self.count + 1 }
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Shard, String> {
        let err = || format!("{s:?}: a shard is K/N with 0 ≤ K < N, e.g. 0/4");
        let (k, n) = s.split_once('/').ok_or_else(err)?;
        let (index, count) =
            (k.trim().parse::<u64>().map_err(|_| err())?, n.trim().parse::<u64>().map_err(|_| err())?);
        if count == 0 || index >= count || count > 1 << 20 {
            return Err(err());
        }
        Ok(Shard { index, count })
    }
}

impl TryFrom<String> for Shard {
    type Error = String;
    fn try_from(s: String) -> Result<Shard, String> {
        s.parse()
    }
}

impl From<Shard> for String {
    fn from(s: Shard) -> String {
        s.to_string()
    }
}

/// Everything that decides a render's image except how many iterations were done: two
/// renders of equal jobs can be continued and merged.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Job {
    /// [`crate::scene::Scene::fingerprint`] of the scene as loaded.
    pub scene_fingerprint: String,
    /// The method as it decides the image ([`MethodConfig::identity`]).
    pub config: MethodConfig,
    pub max_depth: u32,
    pub seed: u64,
    pub sampler: SamplerKind,
    pub width: usize,
    pub height: usize,
    /// Next-event estimation's choice of an emitting triangle as it rendered: by importance
    /// only where the scene's emitters allow it ([`crate::light::Emitters::is_spatial`]); under
    /// `auto`, the choice its pilot made (never `auto` itself).
    #[serde(default = "by_power")]
    pub emitter_choice: EmitterChoice,
}

/// What a job without the field chose (pir before estimator revision 17).
fn by_power() -> EmitterChoice {
    EmitterChoice::Power
}

const LAYOUT_KEY: &str = "pir.job.layout";
const ESTIMATOR_KEY: &str = "pir.job.estimator";
const STATE_KEY: &str = "pir.job.state";
/// The key under which pirs before 0.2.0 stored one number for both the layout and the
/// estimators. Its last value, [`LAST_FORMAT`], is layout 1 at estimator revision 1; older
/// ones are refused.
const OLD_FORMAT_KEY: &str = "pir.job.format";
/// The last single format number (pir 0.1.0): the file of layout 1 at estimator revision 1.
const LAST_FORMAT: &str = "9";

/// The version of a resumable EXR's layout: its attribute keys, the channels that hold the
/// sums, and what the JSON of `pir.job.state` holds and how ([`Job`], [`Shard`], the
/// iterations). Bump it when a file written by the new pir could not be read by the old one
/// or the other way round: a key or channel added, renamed or reinterpreted, a field of the
/// job or of a method's parameters renamed, removed or stored another way, or added so that an
/// older pir would misread the file. (A default that changes what an absent parameter
/// renders changes images: that is [`ESTIMATOR_REVISION`]'s.) A file of another layout is
/// refused; add a line to `CHANGELOG.md`.
pub const LAYOUT: u32 = 1;

/// The revision of the estimators: bump it whenever any method's image of a given scene, job
/// and seed changes, by a bit or more (the random numbers a sample draws, the order of a sum,
/// a default, a weight). A checkpoint of another revision would resume, or merge, with
/// another estimator than the one that rendered it, so the result would match neither's
/// uninterrupted render bit for bit; such files are refused. `tests/golden.rs` keeps pixel
/// hashes of every method made at this revision and fails until it is bumped (with a line in
/// `CHANGELOG.md`) and the hashes regenerated (`PIR_BLESS=1 cargo test --release --test
/// golden`).
pub const ESTIMATOR_REVISION: u32 = 18;

/// What `pir.job.state` holds.
#[derive(Serialize, Deserialize)]
struct StoredState {
    job: Job,
    shard: Shard,
    iterations: u64,
}

impl Job {
    /// The job of rendering `scene` with `config`.
    pub fn new(
        scene: &Scene,
        config: &MethodConfig,
        max_depth: u32,
        seed: u64,
        sampler: SamplerKind,
        width: usize,
        height: usize,
    ) -> Job {
        Job {
            scene_fingerprint: scene.fingerprint(),
            config: config.identity(scene.bounds().diagonal()),
            max_depth,
            seed,
            sampler,
            width,
            height,
            emitter_choice: EmitterChoice::Power,
        }
    }

    /// The job with next-event estimation's choice of `emitters`.
    pub fn with_emitters(self, emitters: &Emitters) -> Job {
        let emitter_choice =
            if emitters.is_spatial() { EmitterChoice::Importance } else { EmitterChoice::Power };
        Job { emitter_choice, ..self }
    }

    /// What differs between two jobs, for a message ("method: pt here, ir in the file"). The
    /// parameters are compared when the methods are the same.
    pub fn differences(&self, other: &Job) -> Vec<String> {
        let mut d = Vec::new();
        let mut cmp = |what: &str, a: String, b: String| {
            if a != b {
                d.push(format!("{what}: {a} here, {b} in the file"));
            }
        };
        cmp("scene (contents)", self.scene_fingerprint.clone(), other.scene_fingerprint.clone());
        cmp("method", self.config.method.to_string(), other.config.method.to_string());
        if self.config.method == other.config.method && self.config.params != other.config.params {
            let (a, b) = (parameter_texts(&self.config), parameter_texts(&other.config));
            for ((key, a), (_, b)) in a.into_iter().zip(b) {
                cmp(&key, a, b);
            }
        }
        cmp("max_depth", self.max_depth.to_string(), other.max_depth.to_string());
        cmp("seed", self.seed.to_string(), other.seed.to_string());
        cmp("sampler", self.sampler.name().to_string(), other.sampler.name().to_string());
        cmp("emitter choice", self.emitter_choice.to_string(), other.emitter_choice.to_string());
        cmp(
            "resolution",
            format!("{}×{}", self.width, self.height),
            format!("{}×{}", other.width, other.height),
        );
        d
    }
}

/// The parameters of a configuration as (name, value) texts, by name; an
/// unset one (the method's default) reads "default".
fn parameter_texts(config: &MethodConfig) -> Vec<(String, String)> {
    // Through the JSON text, which writes each f32 in its shortest form ("0.6").
    let text = serde_json::to_string(&config.params).unwrap_or_default();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
    let Some(fields) = value.as_object() else { return Vec::new() };
    fields
        .iter()
        .map(|(k, v)| (k.clone(), if v.is_null() { "default".to_string() } else { v.to_string() }))
        .collect()
}

/// A resumable render as stored in its EXR.
pub struct Saved {
    pub job: Job,
    pub shard: Shard,
    pub film: Film,
}

const CHANNELS: [&str; 6] = ["sum.R", "sum.G", "sum.B", "sumsq.R", "sumsq.G", "sumsq.B"];

/// Writes the film's image, `attributes` and the resumable state atomically to `path`.
pub fn write_state(
    path: &Path,
    image: &RgbImage,
    attributes: &[(String, String)],
    job: &Job,
    shard: Shard,
    film: &Film,
) -> Result<()> {
    let state = StoredState { job: job.clone(), shard, iterations: film.iterations() };
    let mut attrs = attributes.to_vec();
    attrs.push((LAYOUT_KEY.to_string(), LAYOUT.to_string()));
    attrs.push((ESTIMATOR_KEY.to_string(), ESTIMATOR_REVISION.to_string()));
    attrs.push((
        STATE_KEY.to_string(),
        serde_json::to_string(&state).context("cannot encode the render's state")?,
    ));
    let mut channels = Vec::with_capacity(12);
    for (k, name) in CHANNELS.iter().enumerate() {
        let source = if k < 3 { film.sums() } else { film.sums_of_squares() };
        let bits: Vec<u64> = source.iter().map(|v| v[k % 3].to_bits()).collect();
        channels.push((format!("pir.{name}.hi"), bits.iter().map(|b| (b >> 32) as u32).collect()));
        channels.push((format!("pir.{name}.lo"), bits.iter().map(|b| *b as u32).collect()));
    }
    write_exr_with_channels(path, image, &attrs, channels)
}

/// Reads a resumable render from `path`; an error says what is missing or malformed, or
/// why this pir cannot continue it (another layout or estimator revision).
pub fn read_state(path: &Path) -> Result<Saved> {
    let r = read_exr_with_channels(path)?;
    let find = |k: &str| r.attributes.iter().find(|(a, _)| a == k).map(|(_, v)| v.as_str());
    check_versions(path, find)?;
    let get = |k: &str| -> Result<&str> {
        find(k).with_context(|| format!("{}: not a resumable pir render (no {k})", path.display()))
    };
    let StoredState { job, shard, iterations } = serde_json::from_str(get(STATE_KEY)?)
        .with_context(|| format!("{}: malformed {STATE_KEY}", path.display()))?;
    job.config.validate().with_context(|| format!("{}: malformed {STATE_KEY}", path.display()))?;
    if (job.width, job.height) != (r.image.width, r.image.height) {
        bail!("{}: the image size does not match the resolution in {STATE_KEY}", path.display());
    }
    let n = job.width * job.height;
    let channel =
        |name: String| -> Result<&Vec<u32>> {
            r.channels.iter().find(|(c, _)| *c == name).map(|(_, v)| v).filter(|v| v.len() == n).with_context(
                || format!("{}: channel {name} is missing or of the wrong size", path.display()),
            )
        };
    let mut parts = [vec![DVec3::ZERO; n], vec![DVec3::ZERO; n]];
    for (k, name) in CHANNELS.iter().enumerate() {
        let (hi, lo) = (channel(format!("pir.{name}.hi"))?, channel(format!("pir.{name}.lo"))?);
        for (i, v) in parts[k / 3].iter_mut().enumerate() {
            v[k % 3] = f64::from_bits((u64::from(hi[i]) << 32) | u64::from(lo[i]));
        }
    }
    let [sum, sum_sq] = parts;
    if sum.iter().chain(&sum_sq).any(|v| !v.is_finite()) {
        bail!("{}: the stored sums are not finite", path.display());
    }
    let film = Film::from_parts(job.width, job.height, sum, sum_sq, iterations)
        .with_context(|| format!("{}: inconsistent film size", path.display()))?;
    Ok(Saved { job, shard, film })
}

/// Refuses a file this pir cannot continue: one of another [`LAYOUT`] or
/// [`ESTIMATOR_REVISION`], or of a single format number older than [`LAST_FORMAT`] (pirs
/// before 0.2.0 wrote one).
/// `find` reads the file's attributes.
fn check_versions<'a>(path: &Path, find: impl Fn(&str) -> Option<&'a str>) -> Result<()> {
    let file = path.display();
    let by = find("pir.version").map_or("pir".to_string(), |v| format!("pir {v}"));
    let (layout, estimator) = match (find(LAYOUT_KEY), find(OLD_FORMAT_KEY)) {
        (Some(layout), _) => (layout, find(ESTIMATOR_KEY)),
        (None, Some(LAST_FORMAT)) => ("1", Some("1")),
        (None, Some(format)) => bail!(
            "{file}: written by an older {by} (format {format}), which this pir cannot resume or \
             merge (it reads checkpoint layout {LAYOUT} at estimator revision {ESTIMATOR_REVISION}): \
             render it again with this pir"
        ),
        (None, None) => bail!(
            "{file}: not a resumable pir render (no {LAYOUT_KEY}); render with --checkpoint, --shard or \
             --resume to write one"
        ),
    };
    if layout != LAYOUT.to_string() {
        let age = match layout.parse::<u32>() {
            Ok(n) if n < LAYOUT => "an older",
            Ok(_) => "a newer",
            Err(_) => "another",
        };
        bail!(
            "{file}: checkpoint layout {layout}, written by {age} {by}; this pir reads layout {LAYOUT} \
             only: render it again with this pir, or continue it with the pir that wrote it"
        );
    }
    let estimator = estimator
        .with_context(|| format!("{file}: malformed checkpoint: layout {LAYOUT} without {ESTIMATOR_KEY}"))?;
    if estimator != ESTIMATOR_REVISION.to_string() {
        bail!(
            "{file}: rendered at estimator revision {estimator} (by {by}), this pir's is \
             {ESTIMATOR_REVISION}: the two render other images of the same seed, so resuming or merging \
             it here would mix two estimators and match neither's uninterrupted render bit for bit; \
             render it again with this pir, or continue it with the pir that wrote it"
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::integrator::{Clamping, Method};

    fn method(name: &str) -> Method {
        name.parse().unwrap()
    }

    #[test]
    fn shards_partition_the_iterations() {
        let total = 10;
        let mut seen = vec![0; total as usize + 1];
        for k in 0..3 {
            let s = Shard { index: k, count: 3 };
            for m in 0..s.iterations_of(total) {
                seen[s.global_iteration(m) as usize] += 1;
            }
        }
        assert_eq!(seen[0], 0);
        assert!(seen[1..].iter().all(|&c| c == 1), "{seen:?}");
        assert_eq!(Shard::ALL.iterations_of(7), 7);
        assert_eq!("2/5".parse::<Shard>(), Ok(Shard { index: 2, count: 5 }));
        for bad in ["5/5", "1", "a/2", "0/0", "-1/2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    #[test]
    fn state_roundtrips_bit_exactly_and_jobs_report_differences() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.exr");
        let mut film = Film::new(3, 2);
        for (i, v) in [0.1f32, 1e-7, 3.5, 7.25, 0.3, 1e3].iter().enumerate() {
            film.add(i, glam::Vec3::new(*v, v * 2.0, v / 3.0));
        }
        film.end_iteration();
        let config = MethodConfig::new(method("pir-clamp"));
        let job = Job {
            scene_fingerprint: "abc".into(),
            config: config.identity(2.0),
            max_depth: 8,
            seed: 3,
            sampler: SamplerKind::Sobol,
            width: 3,
            height: 2,
            emitter_choice: EmitterChoice::Importance,
        };
        let shard = Shard { index: 1, count: 4 };
        write_state(&path, &film.image(), &[], &job, shard, &film).unwrap();
        let saved = read_state(&path).unwrap();
        assert_eq!(saved.job, job);
        assert_eq!(saved.shard, shard);
        assert_eq!(saved.film.iterations(), 1);
        assert_eq!(saved.film.sums(), film.sums());
        assert_eq!(saved.film.sums_of_squares(), film.sums_of_squares());
        // An explicit default is the same job; another method or parameter is not.
        let mut explicit = config;
        explicit.params.clamp = Some(Clamping::default_bound(2.0));
        assert!(Job { config: explicit.identity(2.0), ..job.clone() }.differences(&job).is_empty());
        let other = Job { seed: 4, config: MethodConfig::new(method("pt")).identity(2.0), ..job.clone() };
        let d = job.differences(&other);
        assert_eq!(d.len(), 2, "{d:?}");
        assert!(d[0].contains("method: pir-clamp here, pt in the file"));
        let mut alpha = config;
        alpha.params.alpha = 0.25;
        let d = Job { config: alpha.identity(2.0), ..job.clone() }.differences(&job);
        assert_eq!(d, ["alpha: 0.25 here, 0.6 in the file"]);
        let d = Job { sampler: SamplerKind::Independent, ..job.clone() }.differences(&job);
        assert_eq!(d, ["sampler: independent here, sobol in the file"]);
        let d = Job { emitter_choice: EmitterChoice::Power, ..job.clone() }.differences(&job);
        assert_eq!(d, ["emitter choice: power here, importance in the file"]);
        // A plain EXR is not resumable, with a message that says so.
        let plain = dir.path().join("p.exr");
        crate::image::write_exr(&plain, &film.image(), &[]).unwrap();
        let e = read_state(&plain).err().unwrap().to_string();
        assert!(e.contains("not a resumable pir render"), "{e}");
        // A checkpoint of a single format number before the last: refused, saying so.
        let old = dir.path().join("old.exr");
        let attrs = [
            ("pir.version".to_string(), "0.1.0".to_string()),
            (OLD_FORMAT_KEY.to_string(), "8".to_string()),
            (STATE_KEY.to_string(), serde_json::to_string(&job).unwrap()),
        ];
        write_exr_with_channels(&old, &film.image(), &attrs, Vec::new()).unwrap();
        let e = read_state(&old).err().unwrap().to_string();
        assert!(
            e.contains("old.exr")
                && e.contains("written by an older pir 0.1.0 (format 8)")
                && e.contains("render it again"),
            "{e}"
        );
        // Another layout, another estimator revision: refused, naming the file and both numbers.
        let stored = read_exr_with_channels(&path).unwrap();
        let write_with = |key: &str, value: u32, to: &Path| {
            let mut attrs = stored.attributes.clone();
            attrs.iter_mut().find(|(k, _)| k == key).unwrap().1 = value.to_string();
            write_exr_with_channels(to, &film.image(), &attrs, stored.channels.clone()).unwrap();
        };
        // The last format number (pir 0.1.0) is layout 1 at estimator revision 1: read as such.
        let last = dir.path().join("last.exr");
        let mut attrs: Vec<_> = stored
            .attributes
            .iter()
            .filter(|(k, _)| k != LAYOUT_KEY && k != ESTIMATOR_KEY)
            .cloned()
            .collect();
        attrs.push((OLD_FORMAT_KEY.to_string(), LAST_FORMAT.to_string()));
        write_exr_with_channels(&last, &film.image(), &attrs, stored.channels.clone()).unwrap();
        let read = read_state(&last);
        assert_eq!(read.is_ok(), LAYOUT == 1 && ESTIMATOR_REVISION == 1, "{:?}", read.err());
        let other = dir.path().join("other.exr");
        write_with(LAYOUT_KEY, LAYOUT + 1, &other);
        let e = read_state(&other).err().unwrap().to_string();
        let layouts = format!("checkpoint layout {}, written by a newer pir", LAYOUT + 1);
        assert!(
            e.contains("other.exr") && e.contains(&layouts) && e.contains(&format!("layout {LAYOUT} only")),
            "{e}"
        );
        write_with(ESTIMATOR_KEY, ESTIMATOR_REVISION + 1, &other);
        let e = read_state(&other).err().unwrap().to_string();
        let revisions = format!("estimator revision {}", ESTIMATOR_REVISION + 1);
        assert!(
            e.contains("other.exr")
                && e.contains(&revisions)
                && e.contains(&format!("this pir's is {ESTIMATOR_REVISION}"))
                && e.contains("bit for bit"),
            "{e}"
        );
        // A damaged state is an error, not a panic.
        let bad = dir.path().join("bad.exr");
        let text = format!(
            "{{\"job\":{},\"shard\":\"1/0\",\"iterations\":1}}",
            serde_json::to_string(&job).unwrap()
        );
        let attrs = [
            (LAYOUT_KEY.to_string(), LAYOUT.to_string()),
            (ESTIMATOR_KEY.to_string(), ESTIMATOR_REVISION.to_string()),
            (STATE_KEY.to_string(), text),
        ];
        write_exr_with_channels(&bad, &film.image(), &attrs, Vec::new()).unwrap();
        let e = format!("{:#}", read_state(&bad).err().unwrap());
        assert!(e.contains("malformed pir.job.state") && e.contains("K/N"), "{e}");
    }
}
