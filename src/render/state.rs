//! Resumable renders: what a render is (the job) and how far it got (the film), stored in its
//! EXR so that it can be checkpointed, resumed, split into shards and merged.
//!
//! The EXR's R, G, B channels hold the image (the running mean) as always; a resumable EXR
//! adds the film's exact per-pixel sums and sums of squares (f64, each stored as two u32
//! channels of its bits, so nothing is rounded) and two text attributes: `pir.job.format`
//! (the version of this layout) and `pir.job.state`, the JSON of the job (a typed value: the
//! scene's fingerprint, the [`MethodConfig`] as it decides the image, path length, seed,
//! resolution), the shard and the iterations done. Format 1, written by older pirs, stored
//! the method's parameters as formatted text; it is refused with a message that says so.
//! Iteration i's numbers are a function of the seed, the sampler and i alone (its samplers
//! come from `Streams::camera(sampler, seed, i)` and `Streams::light_paths`), so a render can continue from any
//! iteration with the same random numbers, and the iterations of a render can be split into shards: shard K of N
//! renders the global iterations K+1, K+1+N, K+1+2N, … (the progressive schedules b_i, r_i
//! use the global index). Merging adds sums and iteration counts.

use anyhow::{Context, Result, bail};
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;
use std::str::FromStr;

use super::Film;
use crate::image::{RgbImage, read_exr_with_channels, write_exr_with_channels};
use crate::integrator::MethodConfig;
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
}

const FORMAT_KEY: &str = "pir.job.format";
const STATE_KEY: &str = "pir.job.state";
/// The layout this pir writes and reads; format 1 stored the job as formatted text, format 2
/// came before the gather's defaults depended on the method and before light paths decided
/// Russian roulette from the flux arriving at a vertex (which changes the VPLs of a seed),
/// format 3 before the sampler was chosen (its renders drew independent numbers), format 4
/// before light samples picked the emitter's triangle from their point's own number (which
/// changes every method's image of a seed, so a resume would no longer be exact), format 5
/// before light paths left no VPL where they arrive behind a surface and `pir-bdpt` counted
/// its connections by their ends and chose its light paths by the scene (which change the
/// VPL methods' images of a seed; a stored `pir-bdpt` job without `vpls` meant 64), format 6
/// before `pir-bdpt` chose its light samples by the scene (a stored job's 2 meant the
/// default, which is now more where the emitters are hidden) and before light samples of a
/// count other than a power of two tiled the Sobol sequence (which changes their images),
/// format 7 before `pir-bdpt` traced at least 256 light paths (a stored job without `vpls`
/// meant at least 64), format 8 before `pir-bdpt` counted a resampled connection between
/// Lambertian ends 4k rather than 2k (which changes its images of a seed).
const FORMAT: u32 = 9;

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
        }
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
    attrs.push((FORMAT_KEY.to_string(), FORMAT.to_string()));
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

/// Reads a resumable render from `path`; an error says what is missing or malformed.
pub fn read_state(path: &Path) -> Result<Saved> {
    let r = read_exr_with_channels(path)?;
    let get = |k: &str| -> Result<&str> {
        r.attributes.iter().find(|(a, _)| a == k).map(|(_, v)| v.as_str()).with_context(|| {
            format!(
                "{}: not a resumable pir render (no {k}); render with --checkpoint, --shard or --resume to \
                 write one",
                path.display()
            )
        })
    };
    let format = get(FORMAT_KEY)?;
    if format != FORMAT.to_string() {
        if (1..FORMAT).any(|old| old.to_string() == format) {
            bail!(
                "{}: written by an older pir (resumable-state format {format}), which this pir cannot resume \
                 or merge (it reads format {FORMAT}): render it again with this pir",
                path.display()
            );
        }
        bail!("{}: resumable-state format {format} is not the one this pir reads ({FORMAT})", path.display());
    }
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
        // A plain EXR is not resumable, with a message that says so.
        let plain = dir.path().join("p.exr");
        crate::image::write_exr(&plain, &film.image(), &[]).unwrap();
        let e = read_state(&plain).err().unwrap().to_string();
        assert!(e.contains("not a resumable pir render"), "{e}");
        // A checkpoint of format 1 (older pirs): refused, saying so.
        let old = dir.path().join("old.exr");
        let attrs =
            [("pir.job.format".to_string(), "1".to_string()), ("pir.job.seed".to_string(), "3".to_string())];
        write_exr_with_channels(&old, &film.image(), &attrs, Vec::new()).unwrap();
        let e = read_state(&old).err().unwrap().to_string();
        assert!(e.contains("old.exr") && e.contains("written by an older pir"), "{e}");
        // A damaged state is an error, not a panic.
        let bad = dir.path().join("bad.exr");
        let text = format!(
            "{{\"job\":{},\"shard\":\"1/0\",\"iterations\":1}}",
            serde_json::to_string(&job).unwrap()
        );
        let attrs = [(FORMAT_KEY.to_string(), FORMAT.to_string()), (STATE_KEY.to_string(), text)];
        write_exr_with_channels(&bad, &film.image(), &attrs, Vec::new()).unwrap();
        let e = format!("{:#}", read_state(&bad).err().unwrap());
        assert!(e.contains("malformed pir.job.state") && e.contains("K/N"), "{e}");
    }
}
