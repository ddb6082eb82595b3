//! Emitters other than area lights, and area lights of textured radiance, end to end: tiny
//! Mitsuba 3 scenes of `tests/data/emitters/` (a diffuse floor and cube lit by a point, spot,
//! directional, constant or envmap emitter, or by textured area emitters)
//! rendered by `pt`, `pir-clamp`, `pir-vsl`, `pir-mis` and `pir-bdpt` match Mitsuba 3's image
//! means within 1 % per channel.

mod common;

use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/emitters").join(name)
}

fn mean(path: &Path) -> glam::DVec3 {
    glam::DVec3::from(pir::image::read_exr(path).unwrap().0.mean())
}

/// One scene per kind, and area emitters whose radiance is a texture (`textured-area`).
const KINDS: [&str; 6] = ["point", "spot", "directional", "constant", "envmap", "textured-area"];

/// The scenes with Mitsuba references: one per kind, and the envmap's map as Radiance HDR.
const SCENES: [&str; 7] =
    ["point", "spot", "directional", "constant", "envmap", "envmap-hdr", "textured-area"];

/// `pt` at 256 spp and the consistent VPL methods at 1,024 (their bias fades) against
/// Mitsuba 3's 16,384 spp (`tests/data/emitters/refs.py`).
#[test]
fn consistent_methods_match_mitsuba_for_every_emitter_kind() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, (method, spp)) in KINDS.iter().flat_map(|k| {
        [("pt", "256"), ("pir-clamp", "1024"), ("pir-vsl", "1024"), ("pir-mis", "256"), ("pir-bdpt", "256")]
            .map(|m| (*k, m))
    }) {
        let out = dir.path().join(format!("{kind}-{method}.exr"));
        let what = format!("{kind}, {method}");
        let img = common::binary::render(
            &data(&format!("{kind}.xml")),
            &["--spp", spp, "--method", method],
            &out,
            dir.path(),
            &what,
        );
        let (got, want) = (glam::DVec3::from(img.mean()), mean(&data(&format!("{kind}-64x36.exr"))));
        let rel = (got - want) / want;
        assert!(
            rel.abs().max_element() < 0.01,
            "{kind}, {method}: means {got} against Mitsuba's {want} ({rel})"
        );
    }
}

/// The lights are part of the scene's fingerprint: a render is not resumed with other lights.
#[test]
fn lights_change_the_fingerprint() {
    let prints: Vec<String> =
        SCENES.iter().map(|k| pir::scene::load(&data(&format!("{k}.xml"))).unwrap().fingerprint()).collect();
    for (i, a) in prints.iter().enumerate() {
        for b in &prints[i + 1..] {
            assert_ne!(a, b);
        }
    }
}

/// The thesis' biased methods render these lights too (no reference: they only must run and
/// give a finite, positive image).
#[test]
fn the_biased_vpl_methods_render_such_lights() {
    let dir = tempfile::tempdir().unwrap();
    for method in ["ir", "ir-clamp", "vsl"] {
        for kind in KINDS {
            let out = dir.path().join(format!("{kind}-{method}.exr"));
            let what = format!("{kind}, {method}");
            let img = common::binary::render(
                &data(&format!("{kind}.xml")),
                &["--spp", "4", "--method", method],
                &out,
                dir.path(),
                &what,
            );
            let m = glam::DVec3::from(img.mean());
            assert!(m.is_finite() && m.min_element() > 0.0, "{kind}, {method}: {m}");
        }
    }
}

/// The shared material-preview scene's envmap (a 512 × 256 map, turned by its `to_world`,
/// `scale` 3) on diffuse copies of its materials (`tests/data/emitters/matpreview-diffuse.xml`):
/// `pt` at 256 spp within 1 % of Mitsuba 3's means (`matpreview-diffuse-64x48.exr`,
/// 16,384 spp, `max_depth` 8).
#[test]
fn pt_matches_mitsuba_on_the_material_preview_envmap() {
    let Some(shared) = common::shared_dir("pt_matches_mitsuba_on_the_material_preview_envmap") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("matpreview.exr");
    let define = format!("dir={}", shared.join("scenes/mitsuba/matpreview").display());
    let scene = data("matpreview-diffuse.xml");
    let o = common::binary::pir(
        &[
            "render",
            scene.to_str().unwrap(),
            "-D",
            &define,
            "-D",
            "width=64",
            "-D",
            "height=48",
            "-D",
            "max_depth=8",
            "--spp",
            "256",
            "--method",
            "pt",
            "-q",
            "--no-preview",
            "--out",
            out.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", common::binary::stderr(&o));
    let (got, want) = (mean(&out), mean(&data("matpreview-diffuse-64x48.exr")));
    let rel = (got - want) / want;
    assert!(rel.abs().max_element() < 0.01, "means {got} against Mitsuba's {want} ({rel})");
}

/// `pir convert` does not write these lights yet: it refuses, naming the scene and the kind,
/// rather than write a scene without them.
#[test]
fn convert_refuses_such_lights() {
    let dir = tempfile::tempdir().unwrap();
    let scene = data("spot.xml");
    let out = dir.path().join("out.xml");
    let o =
        common::binary::pir(&["convert", scene.to_str().unwrap(), "--to", out.to_str().unwrap()], dir.path());
    common::binary::assert_clean_failure(&o, &["spot.xml", "spot lights"]);
    assert!(!out.exists());
}
