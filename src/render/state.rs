//! Resumable renders: what a render is (the job) and how far it got (the film), stored in its
//! EXR so that it can be checkpointed, resumed, split into shards and merged.
//!
//! The EXR's R, G, B channels hold the image (the running mean) as always; a resumable EXR
//! adds the film's exact per-pixel sums and sums of squares (f64, each stored as two u32
//! channels of its bits, so nothing is rounded) and `pir.job.*` text attributes describing
//! the job. Progressive iterations are independent given the seed (iteration i draws from
//! `Sampler::new(seed, i, …)`), so a render can continue from any iteration with the same
//! random numbers, and the iterations of a render can be split into shards: shard K of N
//! renders the global iterations K+1, K+1+N, K+1+2N, … (the progressive schedules b_i, r_i
//! use the global index). Merging adds sums and iteration counts.

use anyhow::{Context, Result, bail};
use glam::DVec3;
use std::fmt;
use std::path::Path;
use std::str::FromStr;

use super::Film;
use crate::image::{RgbImage, read_exr_with_channels, write_exr_with_channels};

/// Which share of a render's iterations this process renders: shard `index` of `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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

/// Everything that decides a render's image except how many iterations were done: two
/// renders of equal jobs can be continued and merged.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Job {
    /// [`crate::scene::Scene::fingerprint`] of the scene as loaded.
    pub scene_fingerprint: String,
    pub method: String,
    /// The method's parameters, as the integrator reports them.
    pub parameters: Vec<(String, String)>,
    pub max_depth: u32,
    pub seed: u64,
    pub width: usize,
    pub height: usize,
}

const PREFIX: &str = "pir.job.";
const FORMAT: &str = "1";

impl Job {
    /// The job as EXR text attributes, with the shard and the iterations done.
    fn attributes(&self, shard: Shard, iterations: u64) -> Vec<(String, String)> {
        let mut a = vec![
            (format!("{PREFIX}format"), FORMAT.to_string()),
            (format!("{PREFIX}scene"), self.scene_fingerprint.clone()),
            (format!("{PREFIX}method"), self.method.clone()),
            (format!("{PREFIX}max_depth"), self.max_depth.to_string()),
            (format!("{PREFIX}seed"), self.seed.to_string()),
            (format!("{PREFIX}resolution"), format!("{} {}", self.width, self.height)),
            (format!("{PREFIX}shard"), shard.to_string()),
            (format!("{PREFIX}iterations"), iterations.to_string()),
        ];
        for (k, v) in &self.parameters {
            a.push((format!("{PREFIX}param.{k}"), v.clone()));
        }
        a
    }

    /// What differs between two jobs, for a message ("method: pt here, ir in the file").
    pub fn differences(&self, other: &Job) -> Vec<String> {
        let mut d = Vec::new();
        let mut cmp = |what: &str, a: String, b: String| {
            if a != b {
                d.push(format!("{what}: {a} here, {b} in the file"));
            }
        };
        cmp("scene (contents)", self.scene_fingerprint.clone(), other.scene_fingerprint.clone());
        cmp("method", self.method.clone(), other.method.clone());
        cmp("parameters", fmt_params(&self.parameters), fmt_params(&other.parameters));
        cmp("max_depth", self.max_depth.to_string(), other.max_depth.to_string());
        cmp("seed", self.seed.to_string(), other.seed.to_string());
        cmp(
            "resolution",
            format!("{}×{}", self.width, self.height),
            format!("{}×{}", other.width, other.height),
        );
        d
    }
}

/// The parameters in a canonical (sorted) order: the EXR stores attributes sorted by name.
fn fmt_params(p: &[(String, String)]) -> String {
    if p.is_empty() {
        return "none".into();
    }
    let mut p: Vec<String> = p.iter().map(|(k, v)| format!("{k}={v}")).collect();
    p.sort();
    p.join(" ")
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
    let mut attrs = attributes.to_vec();
    attrs.extend(job.attributes(shard, film.iterations()));
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
        r.attributes.iter().find(|(a, _)| a == &format!("{PREFIX}{k}")).map(|(_, v)| v.as_str()).with_context(
            || {
                format!(
                    "{}: not a resumable pir render (no {PREFIX}{k}); render with --checkpoint, --shard or \
                     --resume to write one",
                    path.display()
                )
            },
        )
    };
    let bad = |k: &str| format!("{}: malformed {PREFIX}{k}", path.display());
    if get("format")? != FORMAT {
        bail!(
            "{}: resumable-state format {} is not the one this pir reads ({FORMAT})",
            path.display(),
            get("format")?
        );
    }
    let (w, h) = get("resolution")?.split_once(' ').with_context(|| bad("resolution"))?;
    let job = Job {
        scene_fingerprint: get("scene")?.to_string(),
        method: get("method")?.to_string(),
        parameters: r
            .attributes
            .iter()
            .filter_map(|(k, v)| {
                k.strip_prefix(&format!("{PREFIX}param.")).map(|k| (k.to_string(), v.clone()))
            })
            .collect(),
        max_depth: get("max_depth")?.parse().with_context(|| bad("max_depth"))?,
        seed: get("seed")?.parse().with_context(|| bad("seed"))?,
        width: w.parse().with_context(|| bad("resolution"))?,
        height: h.parse().with_context(|| bad("resolution"))?,
    };
    let shard: Shard =
        get("shard")?.parse().map_err(|e: String| anyhow::anyhow!("{}: {e}", path.display()))?;
    let iterations: u64 = get("iterations")?.parse().with_context(|| bad("iterations"))?;
    if (job.width, job.height) != (r.image.width, r.image.height) {
        bail!("{}: the image size does not match {PREFIX}resolution", path.display());
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
        let job = Job {
            scene_fingerprint: "abc".into(),
            method: "pir-clamp".into(),
            parameters: vec![("alpha".into(), "0.6".into())],
            max_depth: 8,
            seed: 3,
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
        // Parameter order does not matter.
        let mut reordered = job.clone();
        reordered.parameters = vec![("z".into(), "1".into()), ("alpha".into(), "0.6".into())];
        let mut sorted = job.clone();
        sorted.parameters = vec![("alpha".into(), "0.6".into()), ("z".into(), "1".into())];
        assert!(reordered.differences(&sorted).is_empty());
        let other = Job { seed: 4, method: "pt".into(), ..job.clone() };
        let d = job.differences(&other);
        assert_eq!(d.len(), 2, "{d:?}");
        assert!(d[0].contains("method: pir-clamp here, pt in the file"));
        // A plain EXR is not resumable, with a message that says so.
        let plain = dir.path().join("p.exr");
        crate::image::write_exr(&plain, &film.image(), &[]).unwrap();
        let e = read_state(&plain).err().unwrap().to_string();
        assert!(e.contains("not a resumable pir render"), "{e}");
    }
}
