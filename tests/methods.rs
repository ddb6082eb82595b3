//! The method registry: every registered method renders, resumes bit for bit and records its
//! name, description and parameters; and a method defined outside pir is one type and one
//! registration line (`ir-clamp-10` below: `ir` with its geometry term clamped at a constant
//! b = 10, the same images as `ir-clamp --clamp 10`).

use std::sync::Once;

use pir::integrator::methods::{MethodSpec, Settings};
use pir::integrator::{Clamping, Integrator, Method, MethodConfig, Parameter, VirtualLights, register};
use pir::render::state::{Shard, read_state};
use pir::render::{Budget, Control, Renderer, SceneOptions};

/// A method of its own: one type…
struct IrClamp10;

impl MethodSpec for IrClamp10 {
    fn name(&self) -> &'static str {
        "ir-clamp-10"
    }
    fn description(&self) -> &'static str {
        "VPLs with the geometry term clamped at b = 10: biased"
    }
    fn parameters(&self) -> &'static [Parameter] {
        use Parameter::*;
        &[Vpls, Gather, GatherCandidates, GatherSamples]
    }
    fn integrator(&self, s: &Settings) -> Box<dyn Integrator> {
        s.instant_radiosity(VirtualLights::Points(Clamping::Constant { b: 10.0 }))
    }
}

/// …and one registration line.
fn register_ours() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        register(&IrClamp10).unwrap();
    });
}

fn scene() -> pir::scene::Scene {
    pir::scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box/scene.toml").as_ref()).unwrap()
}

fn options() -> SceneOptions {
    SceneOptions {
        resolution: Some(vec![12, 10]),
        seed: Some(5),
        threads: Some(2),
        ..SceneOptions::default()
    }
}

fn config(name: &str) -> MethodConfig {
    let mut c = MethodConfig::new(name.parse().unwrap());
    // Few light paths (pir-bdpt's are chosen by the scene unless given).
    c.params.vpls = (name != "pir-bdpt").then_some(8);
    c
}

fn iterations(n: u64) -> Budget {
    Budget { iterations: Some(n), time: None }
}

#[test]
fn every_registered_method_renders_resumes_and_records_its_parameters() {
    register_ours();
    let methods = Method::all();
    assert!(methods.iter().any(|m| m.name() == "ir-clamp-10"), "{methods:?}");
    assert_eq!(methods.len(), pir::integrator::methods::METHODS.len() + 1);
    let scene = scene();
    let renderer = Renderer::new(&scene, &options()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for method in methods {
        let name = method.name();
        let c = config(name);
        // Three iterations at once, and two then one more from the checkpoint.
        let (whole, _) = renderer.render(&c, iterations(3), |_, _| Control::Continue);
        let (part, stats) = renderer.render(&c, iterations(2), |_, _| Control::Continue);
        assert!(part.image().mean()[0] > 0.0, "{name}");
        let attributes = renderer.attributes(&c, &stats);
        let path = dir.path().join(format!("{name}.exr"));
        let job = renderer.job(&c);
        renderer.write(&path, &part, &attributes, Some((&job, Shard::ALL)), None).unwrap();

        let saved = read_state(&path).unwrap();
        assert_eq!(saved.job, job, "{name}");
        assert!(saved.job.differences(&renderer.job(&c)).is_empty(), "{name}");
        assert_eq!(saved.job.config.method, method, "{name}");
        // (The budget counts the film's iterations.)
        let (resumed, _) =
            renderer.resume(&c, iterations(3), saved.film, Shard::ALL, |_, _| Control::Continue);
        assert_eq!(resumed.iterations(), 3, "{name}");
        assert_eq!(resumed.sums(), whole.sums(), "{name}: a resumed render is the whole one");

        let (_, attrs) = pir::image::read_exr(&path).unwrap();
        let get = |k: &str| attrs.iter().find(|(a, _)| a == k).map(|(_, v)| v.as_str());
        assert_eq!(get("pir.method"), Some(name));
        assert!(get("pir.method.description").is_some_and(|d| !d.is_empty()), "{name}");
        // Every parameter the method uses and reports, and no other.
        let recorded: Vec<&str> = attrs
            .iter()
            .filter_map(|(k, _)| k.strip_prefix("pir.param."))
            .filter(|k| *k != "emitter-visibility")
            .collect();
        let reported = renderer.parameters(&c);
        assert_eq!(
            recorded.len(),
            reported.len() - reported.iter().filter(|(k, _)| k == "emitter-visibility").count(),
            "{name}: {attrs:?}"
        );
        for (k, v) in &reported {
            assert_eq!(get(&format!("pir.param.{k}")), Some(v.as_str()), "{name}: {k}");
            let p = Parameter::from_key(k);
            assert!(p.is_none_or(|p| method.uses(p)), "{name} records {k}, which it does not use");
        }
        for p in Parameter::ALL.into_iter().filter(|p| !method.uses(*p)) {
            assert_eq!(get(&format!("pir.param.{}", p.key())), None, "{name}: {}", p.key());
        }
        if method.uses(Parameter::Vpls) {
            assert!(get("pir.param.vpls").is_some(), "{name}");
        }
    }
}

#[test]
fn a_method_of_its_own_is_known_by_name_and_renders_as_defined() {
    register_ours();
    let ours: Method = "ir-clamp-10".parse().unwrap();
    assert_eq!(ours.description(), IrClamp10.description());
    assert!(Method::names().contains("ir-clamp-10"));
    assert!(register(&IrClamp10).is_err(), "registered twice");
    // Its identity and a study's JSON name it, and read back.
    let c = config("ir-clamp-10");
    let json = serde_json::to_string(&c.identity(1.0)).unwrap();
    assert!(json.starts_with(r#"{"method":"ir-clamp-10","vpls":8,"#), "{json}");
    assert_eq!(serde_json::from_str::<MethodConfig>(&json).unwrap(), c.identity(1.0));
    // The same image as `ir-clamp --clamp 10`, which it is (at a size where some pixels see
    // the clamp).
    let scene = scene();
    let options = SceneOptions { resolution: Some(vec![40, 30]), ..options() };
    let renderer = Renderer::new(&scene, &options).unwrap();
    let mut ir_clamp = config("ir-clamp");
    ir_clamp.params.clamp = Some(10.0);
    let (a, _) = renderer.render(&c, iterations(2), |_, _| Control::Continue);
    let (b, _) = renderer.render(&ir_clamp, iterations(2), |_, _| Control::Continue);
    assert_eq!(a.sums(), b.sums());
    let (plain, _) = renderer.render(&config("ir"), iterations(2), |_, _| Control::Continue);
    assert_ne!(a.sums(), plain.sums(), "the clamp changes the image");
}
