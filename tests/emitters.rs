//! Emitters other than area lights, end to end: tiny Mitsuba 3 scenes of `tests/data/emitters/`
//! (a diffuse floor and cube lit by a point, spot, directional, constant or envmap emitter)
//! rendered by `pt` match Mitsuba 3's image means within 1 % per channel, and the methods that
//! do not handle these lights yet refuse them in one line naming the method and the kind.

mod common;

use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/emitters").join(name)
}

fn mean(path: &Path) -> glam::DVec3 {
    let (img, _) = pir::image::read_exr(path).unwrap();
    img.pixels.iter().fold(glam::DVec3::ZERO, |a, p| a + p.as_dvec3()) / img.pixels.len() as f64
}

const KINDS: [&str; 5] = ["point", "spot", "directional", "constant", "envmap"];

/// `pt` at 256 spp against Mitsuba 3's 16,384 spp (`tests/data/emitters/refs.py`).
#[test]
fn pt_matches_mitsuba_for_every_emitter_kind() {
    let dir = tempfile::tempdir().unwrap();
    for kind in KINDS {
        let out = dir.path().join(format!("{kind}.exr"));
        let scene = data(&format!("{kind}.xml"));
        let o = common::binary::pir(
            &[
                "render",
                scene.to_str().unwrap(),
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
        assert!(o.status.success(), "{kind}: {}", common::binary::stderr(&o));
        let (got, want) = (mean(&out), mean(&data(&format!("{kind}-64x36.exr"))));
        let rel = (got - want) / want;
        assert!(rel.abs().max_element() < 0.01, "{kind}: means {got} against Mitsuba's {want} ({rel})");
    }
}

/// The VPL methods do not render these lights yet: each refuses, naming itself and the kind.
#[test]
fn the_other_methods_refuse_such_lights() {
    let dir = tempfile::tempdir().unwrap();
    for method in common::methods().into_iter().filter(|m| *m != "pt") {
        for kind in ["point", "envmap"] {
            let scene = data(&format!("{kind}.xml"));
            let o = common::binary::pir(
                &["render", scene.to_str().unwrap(), "--spp", "1", "--method", method, "-q", "--no-preview"],
                dir.path(),
            );
            common::binary::assert_clean_failure(&o, &[method, &format!("{kind} lights"), "pt does"]);
        }
    }
}

/// The lights are part of the scene's fingerprint: a render is not resumed with other lights.
#[test]
fn lights_change_the_fingerprint() {
    let prints: Vec<String> =
        KINDS.iter().map(|k| pir::scene::load(&data(&format!("{k}.xml"))).unwrap().fingerprint()).collect();
    for (i, a) in prints.iter().enumerate() {
        for b in &prints[i + 1..] {
            assert_ne!(a, b);
        }
    }
}
