//! A study's reference must be independent of the images it judges.
//!
//! pir's random numbers are a function of (seed, iteration, pixel or path, dimension), so a
//! reference that pir rendered from the same scene with the same seed shares its samples with
//! the study's lines: the path tracer's first n iterations are exactly the reference's first
//! n, and the other methods draw their pixels' camera samples from the same numbers. The
//! reference is then closer to those images than to the truth, and the study understates their
//! error (by about half for `pt` at a fifth of the reference's samples), favouring whichever
//! method shares the most. Such a reference is refused, with the remedy: another `--seed`.
//! `pir reference` renders at a seed of its own ([`reference_seed`]) so that its references
//! are independent of studies at the scene's seed.
//!
//! A reference of another sampler (`pir.sampler`) draws other numbers from the same seed and
//! is independent.
//!
//! The reference's scene is known by the fingerprint pir writes (`pir.scene.fingerprint`, or
//! the one in a resumable file's job); a pir file without one (written before it was recorded)
//! counts as the same scene, so at the same seed it is refused too. References that pir did not
//! render (Mitsuba's) have no `pir.seed` and are always independent.

use anyhow::{Result, bail};
use std::path::Path;

/// The EXR attribute that holds the scene's fingerprint ([`crate::scene::Scene::fingerprint`]).
pub const FINGERPRINT_KEY: &str = "pir.scene.fingerprint";

/// The seed `pir reference` renders at when none is given: the scene's `seed` offset by a
/// constant, so that its reference never shares the numbers of a study or render at the
/// scene's own seed, or at any seed near it.
pub fn reference_seed(scene_seed: u64) -> u64 {
    // "REFERENC" in ASCII: far from any seed a person types.
    scene_seed.wrapping_add(0x5245_4645_5245_4e43)
}

/// Refuses a reference (read from `path`, with EXR `attributes`) that pir rendered from the
/// scene of fingerprint `fingerprint` at `seed`, the study's seed, with `sampler`, the study's
/// sampler (`--sampler`'s name: Sobol points and independent numbers of one seed are
/// different numbers).
pub fn check_reference(
    path: &Path,
    attributes: &[(String, String)],
    fingerprint: &str,
    seed: u64,
    sampler: &str,
) -> Result<()> {
    let attr = |k: &str| attributes.iter().find(|(key, _)| key == k).map(|(_, v)| v.as_str());
    let Some(ref_seed) = attr("pir.seed").and_then(|s| s.trim().parse::<u64>().ok()) else { return Ok(()) };
    if ref_seed != seed || attr("pir.sampler").is_some_and(|s| s != sampler) {
        return Ok(());
    }
    let ref_fingerprint =
        attr(FINGERPRINT_KEY).map(str::to_string).or_else(|| job_fingerprint(attr("pir.job.state")?));
    if ref_fingerprint.is_some_and(|f| f != fingerprint) {
        return Ok(());
    }
    bail!(
        "{}: pir rendered this reference from the same scene with seed {seed}, the study's seed, so every \
         line would share its random numbers (pt's first iterations are the reference's own) and its \
         error would be understated; run the study with another --seed, or render the reference with \
         another (`pir reference` picks its own by default)",
        path.display()
    )
}

/// The scene fingerprint in a resumable file's `pir.job.state`.
fn job_fingerprint(state: &str) -> Option<String> {
    let v: serde_json::Value = serde_json::from_str(state).ok()?;
    Some(v.get("job")?.get("scene_fingerprint")?.as_str()?.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attrs(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
        pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
    }

    #[test]
    fn a_reference_of_the_same_scene_and_seed_is_refused() {
        let p = Path::new("ref.exr");
        let same = attrs(&[("pir.seed", "0"), (FINGERPRINT_KEY, "abc")]);
        let e = check_reference(p, &same, "abc", 0, "sobol").unwrap_err().to_string();
        assert!(e.contains("ref.exr") && e.contains("seed 0") && e.contains("--seed"), "{e}");
        // Another seed, another scene, or a reference pir did not render: independent.
        check_reference(p, &same, "abc", 1, "sobol").unwrap();
        check_reference(p, &same, "other", 0, "sobol").unwrap();
        check_reference(p, &attrs(&[("mitsuba.spp", "1024")]), "abc", 0, "sobol").unwrap();
        // Another sampler draws other numbers from the same seed.
        let independent =
            attrs(&[("pir.seed", "0"), (FINGERPRINT_KEY, "abc"), ("pir.sampler", "independent")]);
        check_reference(p, &independent, "abc", 0, "sobol").unwrap();
        assert!(check_reference(p, &independent, "abc", 0, "independent").is_err());
    }

    #[test]
    fn the_fingerprint_is_read_from_a_resumable_files_job() {
        let p = Path::new("ref.exr");
        let state = r#"{"job":{"scene_fingerprint":"abc","seed":0},"iterations":3}"#;
        let resumable = attrs(&[("pir.seed", "0"), ("pir.job.state", state)]);
        assert!(check_reference(p, &resumable, "abc", 0, "sobol").is_err());
        check_reference(p, &resumable, "xyz", 0, "sobol").unwrap();
        // Without any fingerprint the scene counts as the same one.
        assert!(check_reference(p, &attrs(&[("pir.seed", "0")]), "xyz", 0, "sobol").is_err());
    }

    #[test]
    fn the_reference_seed_differs_from_the_scenes() {
        for s in [0, 1, 7, u64::MAX] {
            assert_ne!(reference_seed(s), s);
        }
    }
}
