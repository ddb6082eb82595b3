use super::params::{MAX_GATHER_SAMPLES, MAX_VPLS};
use super::pir_bdpt::{BDPT_GATHER, BDPT_MAX_PATHS, BDPT_PATHS};
use super::pir_mis::MIS_GATHER;
use super::*;

fn method(name: &str) -> Method {
    name.parse().unwrap()
}

#[test]
fn names_round_trip_and_are_unique() {
    let all = Method::all();
    for m in &all {
        assert_eq!(m.name().parse::<Method>(), Ok(*m));
        assert_eq!(all.iter().filter(|n| n.name() == m.name()).count(), 1, "{m}");
        assert!(!m.description().is_empty(), "{m}");
        let json = serde_json::to_string(m).unwrap();
        assert_eq!(json, format!("\"{}\"", m.name()));
        assert_eq!(serde_json::from_str::<Method>(&json).unwrap(), *m);
    }
    let e = "photon".parse::<Method>().unwrap_err();
    assert!(e.contains("photon") && e.contains("pir-vsl") && e.contains("pir-bdpt"), "{e}");
    assert!(serde_json::from_str::<Method>("\"ir-mis\"").is_err());
    assert!(register(&Pt).is_err(), "a taken name");
}

#[test]
fn validate_names_the_flag() {
    let ok = MethodParams::default();
    assert!(ok.validate().is_ok());
    for (bad, flag) in [
        (MethodParams { vpls: Some(0), ..ok }, "--vpls 0: must be 1 to"),
        (MethodParams { vpls: Some(MAX_VPLS + 1), ..ok }, "--vpls 16777217"),
        (MethodParams { clamp: Some(-2.0), ..ok }, "--clamp -2: must be a positive number"),
        (MethodParams { radius: Some(f32::NAN), ..ok }, "--radius NaN"),
        (MethodParams { alpha: 1.0, ..ok }, "--alpha 1: must lie strictly between 0 and 1"),
        (MethodParams { gather_samples: Some(0), ..ok }, "--gather-samples 0"),
        (MethodParams { gather_samples: Some(MAX_GATHER_SAMPLES + 1), ..ok }, "--gather-samples 65"),
        (MethodParams { gather_candidates: Some(0), ..ok }, "--gather-candidates 0"),
        (MethodParams { light_samples: Some(0), ..ok }, "--light-samples 0"),
        (MethodParams { light_samples: Some(65), ..ok }, "--light-samples 65"),
        (MethodParams { merge_radius: Some(-1.0), ..ok }, "--merge-radius -1: must be 0"),
        (MethodParams { merge_radius: Some(65.0), ..ok }, "--merge-radius 65"),
        (MethodParams { merge_radius: Some(f32::NAN), ..ok }, "--merge-radius NaN"),
    ] {
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.starts_with(flag), "{e}");
    }
}

#[test]
fn identity_keeps_what_decides_the_image() {
    let mut a = MethodConfig::new(method("pt"));
    let mut b = a;
    b.params.alpha = 0.3;
    b.params.vpls = Some(9);
    assert_eq!(a.identity(2.0), b.identity(2.0));
    a.method = method("pir-clamp");
    let c = a.identity(2.0);
    assert_eq!(c.params.clamp, Some(Clamping::default_bound(2.0)));
    assert_eq!(c.report(2.0, Vec::new()), a.report(2.0, Vec::new()));
    b.method = method("pir-clamp");
    assert_ne!(a.identity(2.0), b.identity(2.0));
}

/// The identity of every method with the flags given or not, as its JSON: the resume
/// identity of checkpoints and the lines of studies written before the registry read back
/// the same.
#[test]
fn identities_are_the_stored_ones() {
    let all = MethodParams {
        vpls: Some(7),
        clamp: Some(3.5),
        radius: Some(0.25),
        alpha: 0.3,
        gather: Some(GatherKind::Tree),
        gather_samples: Some(5),
        gather_candidates: Some(77),
        connect: Some(Connect::All),
        light_samples: Some(3),
        merge_radius: Some(1.5),
    };
    let expected = [
        (
            "pt",
            r#"{"method":"pt","vpls":null,"clamp":null,"radius":null,"alpha":0.6,"gather":null,"gather_samples":null,"gather_candidates":null,"connect":null,"light_samples":null}"#,
            r#"{"method":"pt","vpls":null,"clamp":null,"radius":null,"alpha":0.6,"gather":null,"gather_samples":null,"gather_candidates":null,"connect":null,"light_samples":null}"#,
        ),
        (
            "ir",
            r#"{"method":"ir","vpls":32,"clamp":null,"radius":null,"alpha":0.6,"gather":"all","gather_samples":null,"gather_candidates":null,"connect":null,"light_samples":null}"#,
            r#"{"method":"ir","vpls":7,"clamp":null,"radius":null,"alpha":0.6,"gather":"tree","gather_samples":5,"gather_candidates":null,"connect":null,"light_samples":null}"#,
        ),
        (
            "ir-clamp",
            r#"{"method":"ir-clamp","vpls":32,"clamp":25.0,"radius":null,"alpha":0.6,"gather":"all","gather_samples":null,"gather_candidates":null,"connect":null,"light_samples":null}"#,
            r#"{"method":"ir-clamp","vpls":7,"clamp":3.5,"radius":null,"alpha":0.6,"gather":"tree","gather_samples":5,"gather_candidates":null,"connect":null,"light_samples":null}"#,
        ),
        (
            "pir-clamp",
            r#"{"method":"pir-clamp","vpls":32,"clamp":25.0,"radius":null,"alpha":0.6,"gather":"all","gather_samples":null,"gather_candidates":null,"connect":null,"light_samples":null}"#,
            r#"{"method":"pir-clamp","vpls":7,"clamp":3.5,"radius":null,"alpha":0.3,"gather":"tree","gather_samples":5,"gather_candidates":null,"connect":null,"light_samples":null}"#,
        ),
        (
            "vsl",
            r#"{"method":"vsl","vpls":32,"clamp":null,"radius":null,"alpha":0.6,"gather":"all","gather_samples":null,"gather_candidates":null,"connect":null,"light_samples":null}"#,
            r#"{"method":"vsl","vpls":7,"clamp":null,"radius":0.25,"alpha":0.6,"gather":"tree","gather_samples":5,"gather_candidates":null,"connect":null,"light_samples":null}"#,
        ),
        (
            "pir-vsl",
            r#"{"method":"pir-vsl","vpls":32,"clamp":null,"radius":null,"alpha":0.6,"gather":"all","gather_samples":null,"gather_candidates":null,"connect":null,"light_samples":null}"#,
            r#"{"method":"pir-vsl","vpls":7,"clamp":null,"radius":0.25,"alpha":0.3,"gather":"tree","gather_samples":5,"gather_candidates":null,"connect":null,"light_samples":null}"#,
        ),
        (
            "pir-mis",
            r#"{"method":"pir-mis","vpls":32,"clamp":25.0,"radius":null,"alpha":0.6,"gather":"resample","gather_samples":4,"gather_candidates":64,"connect":null,"light_samples":null}"#,
            r#"{"method":"pir-mis","vpls":7,"clamp":3.5,"radius":null,"alpha":0.3,"gather":"tree","gather_samples":5,"gather_candidates":null,"connect":null,"light_samples":null}"#,
        ),
        (
            "pir-bdpt",
            r#"{"method":"pir-bdpt","vpls":null,"clamp":25.0,"radius":null,"alpha":0.6,"gather":"resample","gather_samples":null,"gather_candidates":128,"connect":null,"light_samples":null,"merge_radius":2.0}"#,
            r#"{"method":"pir-bdpt","vpls":7,"clamp":3.5,"radius":null,"alpha":0.3,"gather":"tree","gather_samples":5,"gather_candidates":null,"connect":"all","light_samples":3,"merge_radius":1.5}"#,
        ),
    ];
    for (name, default, given) in expected {
        let c = MethodConfig::new(method(name));
        assert_eq!(serde_json::to_string(&c.identity(2.0)).unwrap(), default, "{name}");
        let c = MethodConfig { params: all, ..c };
        assert_eq!(serde_json::to_string(&c.identity(2.0)).unwrap(), given, "{name}");
        let back: MethodConfig = serde_json::from_str(given).unwrap();
        assert_eq!(back, c.identity(2.0), "{name}");
    }
}

/// The metadata's parameters of every method, as before the registry (the keys and values
/// that `InstantRadiosity::parameters` reported), the pilot's choices in their places.
#[test]
fn reports_are_the_recorded_ones() {
    let c = |name: &str| MethodConfig::new(method(name));
    let text =
        |r: Vec<(String, String)>| r.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(";");
    assert_eq!(text(c("pt").report(2.0, Vec::new())), "");
    assert_eq!(text(c("ir").report(2.0, vec![("vpls".into(), "32".into())])), "vpls=32");
    assert_eq!(text(c("ir-clamp").report(2.0, Vec::new())), "vpls=32;clamp=25");
    assert_eq!(text(c("pir-clamp").report(2.0, Vec::new())), "vpls=32;clamp=25;alpha=0.6");
    let density = crate::integrator::many_light::spheres::density_radius_name();
    assert_eq!(text(c("vsl").report(2.0, Vec::new())), format!("vpls=32;radius={density}"));
    let mut vsl = c("pir-vsl");
    vsl.params.radius = Some(0.5);
    vsl.params.gather = Some(GatherKind::Tree);
    assert_eq!(
        text(vsl.report(2.0, Vec::new())),
        "vpls=32;gather=tree;gather-samples=8;radius=0.5;alpha=0.6"
    );
    assert_eq!(
        text(c("pir-mis").report(2.0, Vec::new())),
        "vpls=32;gather=resample;gather-candidates=64;gather-samples=4;clamp=25;alpha=0.6"
    );
    let measured = [
        ("vpls", "525"),
        ("connect", "glossy"),
        ("lit-share", "0.040"),
        ("light-samples", "4"),
        ("emitter-visibility", "0.120"),
    ];
    let measured = measured.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    assert_eq!(
        text(c("pir-bdpt").report(2.0, measured)),
        "vpls=525;gather=resample;gather-candidates=128;gather-samples=4;connect=glossy;lit-share=0.040;\
         light-samples=4;emitter-visibility=0.120;clamp=25;alpha=0.6;merge-radius=2"
    );
}

/// Light paths and gather by method when the flags are not given: `pir-bdpt` its own
/// ([`BDPT_PATHS`] or more, chosen by the scene, [`BDPT_GATHER`]), `pir-mis` its gather, the
/// others the common ones; the identity holds the resolved count, so giving the default
/// explicitly is the same job, except for `pir-bdpt`, whose count chosen by the scene is not a
/// given one; and a job stored with a plain count reads back as that count.
#[test]
fn light_paths_and_gathers_default_by_method() {
    for m in Method::all() {
        let c = MethodConfig::new(m);
        let bdpt = m.name() == "pir-bdpt";
        let (paths, gather) = match m.name() {
            "pt" => (0, None),
            "pir-bdpt" => (BDPT_MAX_PATHS, Some(BDPT_GATHER)),
            "pir-mis" => (DEFAULT_PATHS, Some(MIS_GATHER)),
            _ => (DEFAULT_PATHS, None),
        };
        assert_eq!(c.light_paths(), paths, "{m:?}");
        assert_eq!(c.auto_paths().is_some(), bdpt, "{m:?}");
        if let Some(g) = gather {
            assert_eq!(c.gather_parameters(), g, "{m:?}");
        }
        let mut explicit = c;
        explicit.params.vpls = Some(if bdpt { BDPT_PATHS } else { DEFAULT_PATHS });
        assert_eq!(!bdpt, c.identity(2.0) == explicit.identity(2.0), "{m:?}");
        assert_eq!(explicit.auto_paths(), None, "{m:?}");
        let mut other = c;
        other.params.vpls = Some(5);
        assert_eq!(m.name() == "pt", c.identity(2.0) == other.identity(2.0), "{m:?}");
    }
    let mut stored = serde_json::to_value(MethodParams::default()).unwrap();
    stored["vpls"] = serde_json::json!(32);
    let back: MethodParams = serde_json::from_value(stored).unwrap();
    assert_eq!(back.vpls, Some(32));
}

#[test]
fn unused_flags_are_named() {
    let mut c = MethodConfig::new(method("pir-clamp"));
    c.params.radius = Some(0.1);
    c.params.connect = Some(Connect::All);
    c.params.clamp = Some(2.0);
    assert_eq!(c.unused(), [Parameter::Connect, Parameter::Radius]);
    c.method = method("pt");
    c.params.alpha = 0.5;
    assert_eq!(c.unused(), [Parameter::Connect, Parameter::Clamp, Parameter::Radius, Parameter::Alpha]);
}

#[test]
fn configs_round_trip_through_json_exactly() {
    // Every f32 survives serde_json: the identity of a checkpoint compares them exactly.
    let mut x: u32 = 0x9E37_79B9;
    for _ in 0..20_000 {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        let v = f32::from_bits(x);
        if !v.is_finite() {
            continue;
        }
        let c = MethodConfig {
            method: method("pir-vsl"),
            params: MethodParams {
                clamp: Some(v),
                radius: Some(v.abs()),
                alpha: v,
                vpls: Some(7),
                gather: Some(GatherKind::Resample),
                gather_samples: Some(5),
                gather_candidates: Some(77),
                connect: Some(Connect::All),
                light_samples: Some(3),
                merge_radius: Some(v.abs()),
            },
        };
        let back: MethodConfig = serde_json::from_str(&serde_json::to_string(&c).unwrap()).unwrap();
        assert_eq!(back, c, "{v:e}");
    }
}
