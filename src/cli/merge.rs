//! `pir merge A.exr B.exr … -o OUT.exr`: combine the shards of a render.

use anyhow::{Result, bail};
use clap::Args;
use std::path::PathBuf;

use pir::image::{write_exr, write_preview};
use pir::render::state::{Saved, Shard, read_state, write_state};

/// Merge the shards of a render (`pir render … --shard K/N`) into one image.
///
/// Progressive iterations are independent, so shards rendered anywhere (a Slurm job array, GNU
/// parallel, several machines) add up: the merged image is the mean over all their
/// iterations, the same as one run of them all. The inputs must be renders of the same scene
/// with the same method, parameters, seed, path length and resolution, each shard of the same
/// N at most once. When they are all N shards of one run, the result is itself resumable.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The shards (resumable EXRs written with --shard).
    #[arg(required = true, num_args = 1..)]
    pub inputs: Vec<PathBuf>,
    /// The merged EXR; a PNG preview is written beside it.
    #[arg(long, short, value_name = "FILE.exr")]
    pub out: PathBuf,
    /// Exposure of the PNG preview in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Do not write the PNG preview.
    #[arg(long)]
    pub no_preview: bool,
}

pub fn run(a: MergeArgs) -> Result<()> {
    // One shard in memory at a time besides the sum: a merge of many large shards needs the
    // memory of two films, not of all of them.
    let Some((first_path, rest)) = a.inputs.split_first() else { bail!("no shards to merge") };
    let Saved { job, shard: first_shard, mut film } = read_state(first_path)?;
    let n = first_shard.count;
    let mut seen = vec![None::<&PathBuf>; n as usize];
    seen[first_shard.index as usize] = Some(first_path);
    let mut shards = vec![(first_shard, film.iterations())];
    for path in rest {
        let s = read_state(path)?;
        let differences = s.job.differences(&job);
        if !differences.is_empty() {
            bail!(
                "{} and {} are not shards of one render: {}",
                path.display(),
                first_path.display(),
                differences.join("; ").replace(" here,", " in the first,")
            );
        }
        if s.shard.count != n {
            bail!(
                "{}: shard {} is not one of {} shards like {}",
                path.display(),
                s.shard,
                n,
                first_path.display()
            );
        }
        if let Some(other) = seen[s.shard.index as usize].replace(path) {
            bail!(
                "{} and {} are both shard {}: their iterations overlap",
                other.display(),
                path.display(),
                s.shard
            );
        }
        film.merge(&s.film);
        shards.push((s.shard, s.film.iterations()));
    }
    // All N shards, each with its share of the first T global iterations: one run of T.
    let total = film.iterations();
    let complete = shards.len() as u64 == n && shards.iter().all(|(s, i)| *i == s.iterations_of(total));
    let image = film.image();
    let attrs = vec![
        ("pir.version".to_string(), env!("CARGO_PKG_VERSION").to_string()),
        ("pir.method".to_string(), job.config.method.name().to_string()),
        ("pir.seed".to_string(), job.seed.to_string()),
        ("pir.sampler".to_string(), job.sampler.name().to_string()),
        (pir::study::independence::FINGERPRINT_KEY.to_string(), job.scene_fingerprint.clone()),
        ("pir.max_depth".to_string(), job.max_depth.to_string()),
        ("pir.iterations".to_string(), total.to_string()),
        ("pir.spp".to_string(), total.to_string()),
        ("pir.merged_from".to_string(), shards.len().to_string()),
    ];
    if complete {
        write_state(&a.out, &image, &attrs, &job, Shard::ALL, &film)?;
    } else {
        write_exr(&a.out, &image, &attrs)?;
        eprintln!(
            "pir: note: the inputs are not all {n} shards of one run of {total} iterations, so the merged \
             image is correct but not resumable"
        );
    }
    if !a.no_preview {
        write_preview(&a.out.with_extension("png"), &image, a.exposure)?;
    }
    eprintln!("pir: merged {} shards, {total} iterations, into {}", shards.len(), a.out.display());
    Ok(())
}
