//! The scene format contract (`shared/scene-format.md`), one test per rule, plus bad inputs.
//! Fixtures are written inline into temporary directories.

mod common;

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use pir::material::Bsdf;
use pir::scene::{Scene, SceneError, load};
use tempfile::TempDir;

const CAMERA: &str = "[camera]\neye = [0.0, 1.0, 3.9]\ntarget = [0.0, 1.0, 0.0]\n\
                      up = [0.0, 1.0, 0.0]\nfov = 40.0\nresolution = [64, 32]\n";

/// A unit quad in the y = 0 plane facing +y, with an emitting material.
const QUAD: &str = "mtllib q.mtl\nv 0 0 0\nv 0 0 1\nv 1 0 1\nv 1 0 0\nusemtl light\nf 1 2 3 4\n";
const QUAD_MTL: &str = "newmtl light\nKd 0.5 0.5 0.5\nKe 1 2 3\n";

struct Fixture {
    dir: TempDir,
}

impl Fixture {
    fn new(files: &[(&str, &str)]) -> Fixture {
        let dir = TempDir::new().unwrap();
        for (name, text) in files {
            let p = dir.path().join(name);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        Fixture { dir }
    }
    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
    fn load(&self, name: &str) -> Result<Scene, SceneError> {
        load(&self.path(name))
    }
}

/// A scene file with the default camera and `rest`, plus the emitting quad and other files.
fn scene(rest: &str, files: &[(&str, &str)]) -> Fixture {
    let toml = format!("{CAMERA}{rest}");
    let mut all = vec![("s.toml", toml.as_str()), ("q.obj", QUAD), ("q.mtl", QUAD_MTL)];
    all.extend_from_slice(files);
    Fixture::new(&all)
}

fn ok(rest: &str, files: &[(&str, &str)]) -> Scene {
    match scene(rest, files).load("s.toml") {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    }
}

/// Loads and expects an error whose message contains every one of `want` and the file name.
fn err(rest: &str, files: &[(&str, &str)], file: &str, want: &[&str]) -> String {
    let e = match scene(rest, files).load("s.toml") {
        Ok(_) => panic!("expected an error containing {want:?}"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains(file), "{e:?} does not name {file}");
    for w in want {
        assert!(e.contains(w), "{e:?} does not contain {w:?}");
    }
    e
}

const LIGHT: &str = "[[mesh]]\nobj = \"q.obj\"\n";

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

// ---------------------------------------------------------------- camera and render

#[test]
fn camera_fields_are_read() {
    let s = ok(LIGHT, &[]);
    let c = s.camera();
    assert_eq!(c.eye, Vec3::new(0.0, 1.0, 3.9));
    assert_eq!(c.target, Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(c.up, Vec3::Y);
    assert_eq!(c.fov_deg, 40.0);
    assert_eq!((c.width, c.height), (64, 32));
}

#[test]
fn integers_are_accepted_where_numbers_are_expected() {
    let f = Fixture::new(&[
        (
            "s.toml",
            "[camera]\neye = [0, 1, 4]\ntarget = [0, 1, 0]\nup = [0, 1, 0]\nfov = 40\n\
             resolution = [8, 8]\n[[mesh]]\nobj = \"q.obj\"\nscale = 2\nrotate_y = 90\n",
        ),
        ("q.obj", QUAD),
        ("q.mtl", QUAD_MTL),
    ]);
    let s = f.load("s.toml").unwrap();
    assert_eq!(s.camera().fov_deg, 40.0);
    assert_eq!(s.camera().eye, Vec3::new(0.0, 1.0, 4.0));
}

#[test]
fn camera_fields_are_required() {
    for key in ["eye", "target", "up", "fov", "resolution"] {
        let cam: String = CAMERA.lines().filter(|l| !l.starts_with(key)).map(|l| format!("{l}\n")).collect();
        let f = Fixture::new(&[("s.toml", &format!("{cam}{LIGHT}")), ("q.obj", QUAD), ("q.mtl", QUAD_MTL)]);
        let e = f.load("s.toml").unwrap_err().to_string();
        assert!(e.contains("s.toml") && e.contains(key), "{e}");
    }
    let f = Fixture::new(&[("s.toml", LIGHT), ("q.obj", QUAD), ("q.mtl", QUAD_MTL)]);
    let e = f.load("s.toml").unwrap_err().to_string();
    assert!(e.contains("s.toml") && e.contains("camera"), "{e}");
}

#[test]
fn render_defaults_and_values() {
    let s = ok(LIGHT, &[]);
    assert_eq!((s.defaults().max_depth, s.defaults().seed), (8, 0));
    let s = ok(&format!("[render]\nmax_depth = 3\nseed = 42\n{LIGHT}"), &[]);
    assert_eq!((s.defaults().max_depth, s.defaults().seed), (3, 42));
    let s = ok(&format!("[render]\nseed = 7\n{LIGHT}"), &[]);
    assert_eq!((s.defaults().max_depth, s.defaults().seed), (8, 7));
}

#[test]
fn bad_render_values() {
    err(&format!("[render]\nmax_depth = 0\n{LIGHT}"), &[], "s.toml", &["max_depth = 0"]);
    err(&format!("[render]\nmax_depth = 100000\n{LIGHT}"), &[], "s.toml", &["max_depth"]);
    err(&format!("[render]\nmax_depth = -1\n{LIGHT}"), &[], "s.toml", &["max_depth"]);
    err(&format!("[render]\nseed = 1.5\n{LIGHT}"), &[], "s.toml", &["seed"]);
}

fn with_camera(replace: &str, by: &str) -> Fixture {
    let cam = CAMERA.replace(replace, by);
    Fixture::new(&[("s.toml", &format!("{cam}{LIGHT}")), ("q.obj", QUAD), ("q.mtl", QUAD_MTL)])
}

fn camera_err(replace: &str, by: &str, want: &[&str]) {
    let e = with_camera(replace, by).load("s.toml").unwrap_err().to_string();
    assert!(e.contains("s.toml"), "{e}");
    for w in want {
        assert!(e.contains(w), "{e:?} lacks {w:?}");
    }
}

#[test]
fn bad_camera_values() {
    camera_err("resolution = [64, 32]", "resolution = [0, 32]", &["resolution", "at least 1"]);
    camera_err("resolution = [64, 32]", "resolution = [64, 0]", &["resolution"]);
    camera_err("resolution = [64, 32]", "resolution = [100000, 1]", &["resolution", "too large"]);
    camera_err("resolution = [64, 32]", "resolution = [60000, 60000]", &["resolution", "too large"]);
    camera_err("resolution = [64, 32]", "resolution = [-1, 32]", &["resolution"]);
    camera_err("resolution = [64, 32]", "resolution = [64]", &["resolution"]);
    camera_err("fov = 40.0", "fov = 0.0", &["fov"]);
    camera_err("fov = 40.0", "fov = 180.0", &["fov"]);
    camera_err("fov = 40.0", "fov = nan", &["fov"]);
    camera_err("fov = 40.0", "fov = \"wide\"", &["fov"]);
    camera_err("eye = [0.0, 1.0, 3.9]", "eye = [0.0, 1.0, 0.0]", &["eye", "target", "different"]);
    camera_err("eye = [0.0, 1.0, 3.9]", "eye = [0.0, nan, 3.9]", &["eye", "finite"]);
    camera_err("eye = [0.0, 1.0, 3.9]", "eye = [0.0, inf, 3.9]", &["eye", "finite"]);
    camera_err("up = [0.0, 1.0, 0.0]", "up = [0.0, 0.0, -2.0]", &["up", "parallel"]);
    camera_err("up = [0.0, 1.0, 0.0]", "up = [0.0, 0.0, 0.0]", &["up"]);
}

// ---------------------------------------------------------------- TOML syntax and keys

#[test]
fn unknown_keys_are_errors_naming_the_key() {
    let cases = [
        format!("{CAMERA}aperture = 1.0\n{LIGHT}"),
        format!("{CAMERA}[render]\nspp = 4\n{LIGHT}"),
        format!("{CAMERA}{LIGHT}rotate_x = 3.0\n"),
        format!(
            "{CAMERA}{LIGHT}[materials.light]\nkind = \"diffuse\"\nalbedo = [1, 1, 1]\ncolour = [1, 1, 1]\n"
        ),
        format!("{CAMERA}{LIGHT}[lights]\nx = 1\n"),
    ];
    for (toml, key) in cases.iter().zip(["aperture", "spp", "rotate_x", "colour", "lights"]) {
        let f = Fixture::new(&[("s.toml", toml), ("q.obj", QUAD), ("q.mtl", QUAD_MTL)]);
        let e = f.load("s.toml").unwrap_err().to_string();
        assert!(e.contains("s.toml") && e.contains(key) && e.contains("line"), "{e}");
    }
}

#[test]
fn malformed_toml_and_wrong_types() {
    err(&format!("{LIGHT}obj = [\n"), &[], "s.toml", &["line"]);
    err("[[mesh]]\nobj = 3\n", &[], "s.toml", &["obj"]);
    err(
        &format!("{LIGHT}scale = \"big\"\n"),
        &[],
        "s.toml",
        &["scale", "a number or an array of three numbers"],
    );
    err(&format!("{LIGHT}translate = [1, 2]\n"), &[], "s.toml", &["translate"]);
    err("", &[], "s.toml", &["no mesh"]);
}

#[test]
fn missing_files_are_named() {
    let f = Fixture::new(&[]);
    let e = f.load("nope.toml").unwrap_err().to_string();
    assert!(e.contains("nope.toml") && e.contains("cannot read"), "{e}");
    err("[[mesh]]\nobj = \"missing.obj\"\n", &[], "missing.obj", &["s.toml", "[[mesh]] #1", "cannot read"]);
    err(
        "[[mesh]]\nobj = \"m.obj\"\n",
        &[("m.obj", "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n")],
        "m.obj",
        &["line 1", "gone.mtl", "cannot read"],
    );
}

// ---------------------------------------------------------------- geometry

#[test]
fn quads_and_pentagons_are_fans() {
    let pent = "mtllib q.mtl\nusemtl light\nv 0 0 0\nv 1 0 0\nv 2 0 1\nv 1 0 2\nv 0 0 2\nf 1 2 3 4 5\n";
    let s = ok("[[mesh]]\nobj = \"p.obj\"\n", &[("p.obj", pent)]);
    let tris: Vec<[Vec3; 3]> = (0..s.indices().len() as u32).map(|i| s.triangle(i)).collect();
    let v = [
        Vec3::ZERO,
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 2.0),
        Vec3::new(0.0, 0.0, 2.0),
    ];
    assert_eq!(tris, vec![[v[0], v[1], v[2]], [v[0], v[2], v[3]], [v[0], v[3], v[4]]]);
    let s = ok(LIGHT, &[]);
    let q = [Vec3::ZERO, Vec3::Z, Vec3::new(1.0, 0.0, 1.0), Vec3::X];
    let tris: Vec<[Vec3; 3]> = (0..s.indices().len() as u32).map(|i| s.triangle(i)).collect();
    assert_eq!(tris, vec![[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
}

#[test]
fn geometric_normal_is_b_minus_a_cross_c_minus_a() {
    // The quad (0,0,0) (0,0,1) (1,0,1): (b−a) × (c−a) = z × (x+z) = +y.
    let s = ok(LIGHT, &[]);
    let sp = s.surface_at(0, Vec2::new(0.25, 0.25));
    assert!(close(sp.ng, Vec3::Y), "{}", sp.ng);
    // Reversed winding faces down.
    let down = QUAD.replace("f 1 2 3 4", "f 4 3 2 1");
    let s = ok("[[mesh]]\nobj = \"d.obj\"\n", &[("d.obj", &down)]);
    assert!(close(s.surface_at(0, Vec2::new(0.25, 0.25)).ng, -Vec3::Y));
}

#[test]
fn vertex_normals_are_shading_normals_and_absent_ones_are_zero() {
    let obj = "mtllib q.mtl\nv 0 0 0\nv 0 0 1\nv 1 0 1\nvn 1 1 0\nvn 1 1 0\nvn 1 1 0\nvt 0.5 0.5\n\
               usemtl light\nf 1/1/1 2/1/2 3/1/3\n";
    let s = ok("[[mesh]]\nobj = \"n.obj\"\n", &[("n.obj", obj)]);
    let sp = s.surface_at(0, Vec2::new(0.2, 0.3));
    let want = Vec3::new(1.0, 1.0, 0.0).normalize();
    assert!(close(sp.frame.n, want), "{}", sp.frame.n);
    assert!(close(sp.ng, Vec3::Y));
    assert!(s.normals().iter().all(|n| close(*n, want)));
    // Without vn: zero normals, and shading uses the geometric normal.
    let s = ok(LIGHT, &[]);
    assert!(s.normals().iter().all(|n| *n == Vec3::ZERO));
    assert!(close(s.surface_at(0, Vec2::new(0.2, 0.3)).frame.n, Vec3::Y));
    // A material whose faces have vn only in part is shaded flat (as the reference does).
    let part = "mtllib q.mtl\nv 0 0 0\nv 0 0 1\nv 1 0 1\nvn 1 1 0\nusemtl light\nf 1//1 2//1 3//1\nf 1 3 2\n";
    let s = ok("[[mesh]]\nobj = \"n.obj\"\n", &[("n.obj", part)]);
    assert!(s.normals().iter().all(|n| *n == Vec3::ZERO));
}

#[test]
fn texture_coordinates_are_ignored() {
    let with_vt = "mtllib q.mtl\nv 0 0 0\nv 0 0 1\nv 1 0 1\nv 1 0 0\nvt 0 0\nvt 1 0 0\nvt 7\n\
                   usemtl light\nf 1/1 2/2 3/3 4/1\n";
    let a = ok("[[mesh]]\nobj = \"t.obj\"\n", &[("t.obj", with_vt)]);
    let b = ok(LIGHT, &[]);
    assert_eq!(a.indices().len(), b.indices().len());
    for i in 0..a.indices().len() as u32 {
        assert_eq!(a.triangle(i), b.triangle(i));
    }
}

#[test]
fn transforms_apply_scale_then_rotate_y_then_translate() {
    // One triangle with a vertex at (1, 0, 0) and one at (0, 0, 1).
    let tri = "mtllib q.mtl\nusemtl light\nv 1 0 0\nv 0 0 1\nv 0 1 0\nf 1 2 3\n";
    let files = [("t.obj", tri)];
    let s = ok("[[mesh]]\nobj = \"t.obj\"\nrotate_y = 90\n", &files);
    // Right-handed about +Y: x' = x cos + z sin, z' = −x sin + z cos → (1,0,0) ↦ (0,0,−1).
    let [a, b, c] = s.triangle(0);
    assert!(close(a, Vec3::new(0.0, 0.0, -1.0)), "{a}");
    assert!(close(b, Vec3::new(1.0, 0.0, 0.0)), "{b}");
    assert!(close(c, Vec3::new(0.0, 1.0, 0.0)), "{c}");
    // Per-axis scale, then rotation, then translation.
    let s = ok(
        "[[mesh]]\nobj = \"t.obj\"\nscale = [2.0, 3.0, 5.0]\nrotate_y = 90\ntranslate = [10, 20, 30]\n",
        &files,
    );
    let [a, b, c] = s.triangle(0);
    assert!(close(a, Vec3::new(10.0, 20.0, 28.0)), "{a}"); // (2,0,0) → (0,0,−2) → +t
    assert!(close(b, Vec3::new(15.0, 20.0, 30.0)), "{b}"); // (0,0,5) → (5,0,0) → +t
    assert!(close(c, Vec3::new(10.0, 23.0, 30.0)), "{c}"); // (0,3,0) → +t
    // Uniform scale as a number.
    let s = ok("[[mesh]]\nobj = \"t.obj\"\nscale = 2.0\n", &files);
    assert!(close(s.triangle(0)[2], Vec3::new(0.0, 2.0, 0.0)));
    assert_eq!(s.bounds().min, Vec3::ZERO);
    assert_eq!(s.bounds().max, Vec3::splat(2.0));
}

#[test]
fn normals_transform_by_the_inverse_transpose() {
    let obj = "mtllib q.mtl\nusemtl light\nv 0 0 0\nv 1 -1 0\nv 0 0 1\nvn 1 1 0\nf 1//1 2//1 3//1\n";
    let s = ok(
        "[[mesh]]\nobj = \"n.obj\"\nscale = [2, 1, 1]\nrotate_y = 90\ntranslate = [5, 5, 5]\n",
        &[("n.obj", obj)],
    );
    // Divide by the scale: (0.5, 1, 0); rotate 90° about +Y: (0, 1, −0.5); normalise.
    let want = Vec3::new(0.0, 1.0, -0.5).normalize();
    assert!(close(s.normals()[0], want), "{}", s.normals()[0]);
    // It stays perpendicular to the transformed surface.
    let [a, b, c] = s.triangle(0);
    assert!((b - a).dot(want).abs() < 1e-5 && (c - a).dot(want).abs() < 1e-5);
}

#[test]
fn degenerate_triangles_are_dropped_and_counted() {
    let obj = "mtllib q.mtl\nusemtl light\nv 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 1 4\n";
    let s = ok("[[mesh]]\nobj = \"d.obj\"\n", &[("d.obj", obj)]);
    assert_eq!(s.indices().len(), 1);
    assert_eq!(s.degenerate_dropped(), 2);
    assert_eq!(s.triangle_count(), 1);
}

#[test]
fn several_meshes_merge_with_their_own_offsets() {
    let s = ok(&format!("{LIGHT}{LIGHT}translate = [0, 5, 0]\n"), &[]);
    assert_eq!(s.indices().len(), 4);
    assert_eq!(s.positions().len(), 8);
    assert!(close(s.triangle(2)[0], Vec3::new(0.0, 5.0, 0.0)));
    assert_eq!(s.materials().len(), 1, "equal materials are stored once");
    assert_eq!(s.bounds().max, Vec3::new(1.0, 5.0, 1.0));
}

// ---------------------------------------------------------------- OBJ errors

fn obj_err(obj: &str, want: &[&str]) -> String {
    err("[[mesh]]\nobj = \"b.obj\"\n", &[("b.obj", obj)], "b.obj", want)
}

#[test]
fn bad_obj_files() {
    let head = "mtllib q.mtl\nusemtl light\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
    obj_err(&format!("{head}f 1 2 4\n"), &["line 6", "index 4 is out of range"]);
    obj_err(&format!("{head}f 0 1 2\n"), &["line 6", "index 0"]);
    obj_err(&format!("{head}f -1 -2 -4\n"), &["line 6", "out of range"]);
    obj_err(&format!("{head}f 1 2 x\n"), &["line 6", "not an integer"]);
    obj_err(&format!("{head}f 1//1 2//1 3//1\n"), &["line 6", "normal", "out of range"]);
    obj_err("mtllib q.mtl\nv 0 0 zero\n", &["line 2", "three finite numbers"]);
    obj_err("mtllib q.mtl\nv 0 0 nan\n", &["line 2", "finite"]);
    obj_err("mtllib q.mtl\nv 0 0\n", &["line 2"]);
    obj_err("mtllib q.mtl\nv 0 0 0\nvn 0 inf 0\n", &["line 3", "vn"]);
    obj_err("mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", &["no faces"]);
    obj_err("mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\nl 1 2\n", &["no faces"]);
    obj_err(&format!("{head}f 1 1 1\n"), &["degenerate"]);
    obj_err("mtllib q.mtl\nusemtl\n", &["line 2", "usemtl"]);
    // Relative indices, comments and a fourth coordinate read like mitsuba_ref.py.
    let s = ok(
        "[[mesh]]\nobj = \"r.obj\"\n",
        &[("r.obj", "mtllib q.mtl # lib\nusemtl light\nv 0 0 0 2\nv 1 0 0 # x\nv 0 1 0\nf -3 -2 -1\n")],
    );
    assert_eq!(s.triangle(0), [Vec3::ZERO, Vec3::X, Vec3::Y]);
}

#[test]
fn bad_mtl_files_name_file_and_line() {
    let e = err(
        "[[mesh]]\nobj = \"m.obj\"\n",
        &[
            ("m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n"),
            ("m.mtl", "newmtl a\nKd 1 -1 1\n"),
        ],
        "m.mtl",
        &["line 2", "Kd"],
    );
    assert!(!e.contains("panic"));
    err(
        "[[mesh]]\nobj = \"m.obj\"\n",
        &[
            ("m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n"),
            ("m.mtl", "newmtl a\nKe 1 1\n"),
        ],
        "m.mtl",
        &["line 2", "Ke"],
    );
}

// ---------------------------------------------------------------- materials

fn tri_with(mtl: &str) -> Scene {
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
    ok(&format!("{LIGHT}[[mesh]]\nobj = \"m.obj\"\n"), &[("m.obj", obj), ("m.mtl", mtl)])
}

fn material_named<'a>(s: &'a Scene, name: &str) -> &'a pir::material::Material {
    s.materials().iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no material {name}"))
}

#[test]
fn mtl_illum_5_is_mirror_with_specular_ks() {
    let s = tri_with("newmtl a\nKd 0.01 0.01 0.01\nKs 0.95 0.9 0.85\nNs 1000\nillum 5\n");
    assert_eq!(material_named(&s, "a").bsdf, Bsdf::Mirror { specular: Vec3::new(0.95, 0.9, 0.85) });
}

#[test]
fn mtl_illum_7_is_glass_with_ior_ni() {
    let s = tri_with("newmtl a\nKs 0.3 0.3 0.3\nNi 2.5\nillum 7\n");
    assert_eq!(material_named(&s, "a").bsdf, Bsdf::Glass { ior: 2.5 });
}

#[test]
fn mtl_ks_positive_is_glossy() {
    let s = tri_with("newmtl a\nKd 0.5 0.4 0.3\nKs 0.3 0 0\nNs 32\nillum 2\n");
    let Bsdf::Glossy { albedo, specular, roughness } = material_named(&s, "a").bsdf else { panic!() };
    assert_eq!(albedo, Vec3::new(0.5, 0.4, 0.3));
    assert_eq!(specular, Vec3::new(0.3, 0.0, 0.0));
    assert!((roughness - (2.0f32 / 34.0).sqrt()).abs() < 1e-7);
}

#[test]
fn mtl_otherwise_is_diffuse_and_ke_makes_an_emitter() {
    let s = tri_with("newmtl a\nKd 0.5 0.4 0.3\nKs 0 0 0\nKe 0 0 0\nillum 2\n");
    let m = material_named(&s, "a");
    assert_eq!(m.bsdf, Bsdf::Diffuse { albedo: Vec3::new(0.5, 0.4, 0.3) });
    assert!(!m.is_emitter());
    let s = tri_with("newmtl a\nKs 0.9 0.9 0.9\nillum 5\nKe 0 0 4\n");
    let m = material_named(&s, "a");
    assert!(matches!(m.bsdf, Bsdf::Mirror { .. }));
    assert_eq!(m.emission, Vec3::new(0.0, 0.0, 4.0));
}

#[test]
fn scene_materials_replace_mtl_materials_whole() {
    let s = ok(
        &format!(
            "{LIGHT}[materials.light]\nkind = \"glossy\"\nspecular = [0.2, 0.2, 0.2]\nroughness = 0.3\nemission = [5, 5, 5]\n"
        ),
        &[],
    );
    let m = material_named(&s, "light");
    // Whole replacement: Kd of the MTL (0.5) is not kept; glossy albedo defaults to 0.
    assert_eq!(m.bsdf, Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::splat(0.2), roughness: 0.3 });
    assert_eq!(m.emission, Vec3::splat(5.0));
    assert_eq!(s.materials().len(), 1);
    // Replacing without emission removes the emitter (and then the scene has none).
    err(
        &format!("{LIGHT}[materials.light]\nkind = \"diffuse\"\nalbedo = [1, 1, 1]\n"),
        &[],
        "s.toml",
        &["no emitter"],
    );
}

#[test]
fn mesh_material_applies_to_every_face() {
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl a\nf 1 2 3\nusemtl b\nf 2 4 3\n";
    let mtl = "newmtl a\nKd 1 0 0\nnewmtl b\nKd 0 1 0\n";
    let s = ok(
        &format!(
            "{LIGHT}[[mesh]]\nobj = \"m.obj\"\nmaterial = \"red\"\n[materials.red]\nkind = \"mirror\"\nspecular = [1, 0, 0]\n"
        ),
        &[("m.obj", obj), ("m.mtl", mtl)],
    );
    assert_eq!(s.indices().len(), 4);
    assert_eq!(s.material_of(2).name, "red");
    assert_eq!(s.material_of(3).name, "red");
    assert!(s.materials().iter().all(|m| m.name != "a" && m.name != "b"));
    // `material` may name a material of the OBJ's own MTL.
    let s = ok(
        &format!("{LIGHT}[[mesh]]\nobj = \"m.obj\"\nmaterial = \"b\"\n"),
        &[("m.obj", obj), ("m.mtl", mtl)],
    );
    assert_eq!(s.material_of(2).bsdf, Bsdf::Diffuse { albedo: Vec3::Y });
    assert_eq!(s.material_of(3).name, "b");
    // And it is required (and sufficient) for an OBJ without MTL.
    let bare = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let s = ok(
        &format!(
            "{LIGHT}[[mesh]]\nobj = \"bare.obj\"\nmaterial = \"w\"\n[materials.w]\nkind = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n"
        ),
        &[("bare.obj", bare)],
    );
    assert_eq!(s.material_of(2).name, "w");
}

#[test]
fn emission_on_scene_materials_makes_emitters() {
    let bare = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let s = ok(
        "[[mesh]]\nobj = \"bare.obj\"\nmaterial = \"lamp\"\n[materials.lamp]\nkind = \"glass\"\nior = 1.5\nemission = [1, 2, 3]\n",
        &[("bare.obj", bare)],
    );
    assert!(s.material_of(0).is_emitter());
    assert_eq!(s.material_of(0).emission, Vec3::new(1.0, 2.0, 3.0));
}

#[test]
fn missing_materials_are_errors_naming_the_mesh() {
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl nothere\nf 1 2 3\n";
    let mesh = format!("{LIGHT}[[mesh]]\nobj = \"m.obj\"\n");
    err(
        &mesh,
        &[("m.obj", obj), ("m.mtl", "newmtl a\n")],
        "s.toml",
        &["[[mesh]] #2", "m.obj", "\"nothere\"", "line 6"],
    );
    // A face before any usemtl.
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    err(&mesh, &[("m.obj", obj), ("m.mtl", "newmtl a\n")], "s.toml", &["[[mesh]] #2", "no usemtl", "line 5"]);
    // No MTL and no `material`.
    let bare = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    err(
        &format!("{LIGHT}[[mesh]]\nobj = \"bare.obj\"\n"),
        &[("bare.obj", bare)],
        "s.toml",
        &["[[mesh]] #2", "bare.obj", "no MTL"],
    );
    // `material` naming nothing.
    err(
        &format!("{LIGHT}[[mesh]]\nobj = \"bare.obj\"\nmaterial = \"ghost\"\n"),
        &[("bare.obj", bare)],
        "s.toml",
        &["[[mesh]] #2", "\"ghost\""],
    );
    // A usemtl name missing from the MTL may be defined in [materials].
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl extra\nf 1 2 3\n";
    let s = ok(
        &format!("{mesh}[materials.extra]\nkind = \"diffuse\"\nalbedo = [0.1, 0.2, 0.3]\n"),
        &[("m.obj", obj), ("m.mtl", "newmtl a\n")],
    );
    assert_eq!(s.material_of(2).name, "extra");
}

#[test]
fn scene_material_keys_by_kind() {
    let m = |body: &str| format!("{LIGHT}[materials.x]\n{body}");
    // Required keys.
    err(&m("kind = \"diffuse\"\n"), &[], "s.toml", &["[materials.x] albedo", "missing"]);
    err(
        &m("kind = \"glossy\"\nspecular = [1, 1, 1]\n"),
        &[],
        "s.toml",
        &["[materials.x] roughness", "missing"],
    );
    err(&m("kind = \"mirror\"\n"), &[], "s.toml", &["[materials.x] specular", "missing"]);
    err(&m("kind = \"glass\"\n"), &[], "s.toml", &["[materials.x] ior", "missing"]);
    err(&m("albedo = [1, 1, 1]\n"), &[], "s.toml", &["kind"]);
    // Keys of another kind.
    err(
        &m("kind = \"diffuse\"\nalbedo = [1, 1, 1]\nior = 1.5\n"),
        &[],
        "s.toml",
        &["[materials.x] ior", "not used by kind = \"diffuse\""],
    );
    err(
        &m("kind = \"mirror\"\nspecular = [1, 1, 1]\nalbedo = [1, 1, 1]\n"),
        &[],
        "s.toml",
        &["[materials.x] albedo", "not used"],
    );
    err(
        &m("kind = \"glass\"\nior = 1.5\nroughness = 0.1\n"),
        &[],
        "s.toml",
        &["[materials.x] roughness", "not used"],
    );
    err(&m("kind = \"plastic\"\n"), &[], "s.toml", &["[materials.x] kind = \"plastic\""]);
    // Values.
    err(
        &m("kind = \"diffuse\"\nalbedo = [0.5, -0.1, 0.5]\n"),
        &[],
        "s.toml",
        &["[materials.x] albedo", "≥ 0"],
    );
    err(&m("kind = \"diffuse\"\nalbedo = [0.5, nan, 0.5]\n"), &[], "s.toml", &["[materials.x] albedo"]);
    err(
        &m("kind = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\nemission = [-1, 0, 0]\n"),
        &[],
        "s.toml",
        &["[materials.x] emission"],
    );
    err(
        &m("kind = \"glossy\"\nspecular = [1, 1, 1]\nroughness = -1\n"),
        &[],
        "s.toml",
        &["[materials.x] roughness = -1", "GGX"],
    );
    err(&m("kind = \"glossy\"\nspecular = [1, 1, 1]\nroughness = 0\n"), &[], "s.toml", &["roughness = 0"]);
    err(&m("kind = \"glossy\"\nspecular = [1, 1, 1]\nroughness = 7\n"), &[], "s.toml", &["roughness = 7"]);
    err(&m("kind = \"glass\"\nior = 0\n"), &[], "s.toml", &["[materials.x] ior = 0"]);
    err(&m("kind = \"glass\"\nior = inf\n"), &[], "s.toml", &["[materials.x] ior"]);
    err(&m("kind = \"diffuse\"\nalbedo = [1, 1]\n"), &[], "s.toml", &["albedo", "line"]);
}

#[test]
fn bad_mesh_placement() {
    err(&format!("{LIGHT}scale = 0\n"), &[], "s.toml", &["[[mesh]] #1 scale", "non-zero"]);
    err(&format!("{LIGHT}scale = [1, nan, 1]\n"), &[], "s.toml", &["[[mesh]] #1 scale"]);
    err(&format!("{LIGHT}rotate_y = inf\n"), &[], "s.toml", &["[[mesh]] #1 rotate_y"]);
    err(&format!("{LIGHT}translate = [0, 0, nan]\n"), &[], "s.toml", &["[[mesh]] #1 translate"]);
    err(
        &format!("{LIGHT}scale = 1e38\ntranslate = [3e38, 0, 0]\n"),
        &[],
        "s.toml",
        &["[[mesh]] #1", "not finite"],
    );
}

#[test]
fn a_scene_without_emitter_is_an_error() {
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
    let f = Fixture::new(&[
        ("s.toml", &format!("{CAMERA}[[mesh]]\nobj = \"m.obj\"\n")),
        ("m.obj", obj),
        ("m.mtl", "newmtl a\nKd 1 1 1\nKe 0 0 0\n"),
    ]);
    let e = f.load("s.toml").unwrap_err().to_string();
    assert!(e.contains("s.toml") && e.contains("no emitter"), "{e}");
}

#[test]
fn paths_are_relative_to_the_scene_file() {
    let f = Fixture::new(&[
        ("scenes/deep/s.toml", &format!("{CAMERA}[[mesh]]\nobj = \"../meshes/q.obj\"\n")),
        ("scenes/meshes/q.obj", QUAD),
        ("scenes/meshes/q.mtl", QUAD_MTL),
    ]);
    let s = f.load("scenes/deep/s.toml").unwrap();
    assert_eq!(s.indices().len(), 2);
    assert_eq!(s.path(), f.path("scenes/deep/s.toml"));
}

// ---------------------------------------------------------------- real scenes

fn shared() -> Option<PathBuf> {
    common::shared_dir("the shared example scenes").map(|d| d.join("scenes"))
}

fn load_ok(p: &Path) -> Scene {
    load(p).unwrap_or_else(|e| panic!("{e}"))
}

fn check_original(s: &Scene) {
    // 18 quads (CRLF line ends, some with trailing blanks).
    assert_eq!(s.indices().len(), 18 * 2);
    assert_eq!(s.degenerate_dropped(), 0);
    let light = material_named(s, "light");
    assert_eq!(light.emission, Vec3::new(17.0, 12.0, 4.0));
    assert_eq!(light.bsdf, Bsdf::Diffuse { albedo: Vec3::splat(0.78) });
    let left = material_named(s, "leftWall");
    assert_eq!(left.bsdf, Bsdf::Diffuse { albedo: Vec3::new(0.63, 0.065, 0.05) });
    assert_eq!(s.materials().len(), 8);
    assert!(close(s.bounds().min, Vec3::new(-1.02, 0.0, -1.04)), "{:?}", s.bounds());
    assert!(close(s.bounds().max, Vec3::new(1.0, 1.99, 0.99)), "{:?}", s.bounds());
    // The light faces down, into the box.
    let li = (0..s.indices().len() as u32).find(|&i| s.material_of(i).is_emitter()).unwrap();
    assert!(s.surface_at(li, Vec2::new(0.3, 0.3)).ng.y < -0.99);
}

fn check_sphere(s: &Scene) {
    assert_eq!(s.indices().len() + s.degenerate_dropped(), 2188);
    assert_eq!(material_named(s, "leftSphere").bsdf, Bsdf::Mirror { specular: Vec3::splat(0.95) });
    assert_eq!(material_named(s, "rightSphere").bsdf, Bsdf::Glass { ior: 2.5 });
    assert_eq!(material_named(s, "light").emission, Vec3::splat(10.0));
    // The spheres carry vertex normals.
    assert!(s.normals().iter().filter(|n| **n != Vec3::ZERO).count() > 1000);
}

#[test]
fn shared_example_scenes_load() {
    let Some(dir) = shared() else { return };
    let s = load_ok(&dir.join("cornell-box/original.toml"));
    check_original(&s);
    assert_eq!((s.camera().width, s.camera().height, s.defaults().max_depth), (256, 256, 8));
    let s = load_ok(&dir.join("cornell-box/sphere.toml"));
    check_sphere(&s);
    assert_eq!(s.camera().eye, Vec3::new(0.0, 0.795, 3.2));
    let t = std::time::Instant::now();
    let s = load_ok(&dir.join("bunny/cornell-bunny.toml"));
    eprintln!(
        "cornell-bunny: {} triangles, {} degenerate dropped, {} materials, bounds {:?}, {:?}",
        s.indices().len(),
        s.degenerate_dropped(),
        s.materials().len(),
        s.bounds(),
        t.elapsed()
    );
    assert_eq!(s.indices().len() + s.degenerate_dropped(), 6 * 2 + 69451);
    assert_eq!(material_named(&s, "bunny").bsdf, Bsdf::Diffuse { albedo: Vec3::new(0.725, 0.71, 0.68) });
    assert_eq!(material_named(&s, "light").emission, Vec3::new(17.0, 12.0, 4.0));
    assert!(s.bounds().min.y < 0.0 + 1e-6 && s.bounds().max.y > 1.98);
}

#[test]
fn cornell_glossy_gotcha_is_a_clear_error() {
    // CornellBox-Glossy.obj uses `light`, which its MTL does not define.
    let Some(dir) = shared() else { return };
    let obj = dir.join("cornell-box/CornellBox-Glossy.obj");
    let f =
        Fixture::new(&[("s.toml", &format!("{CAMERA}[[mesh]]\nobj = {:?}\n", obj.display().to_string()))]);
    let e = f.load("s.toml").unwrap_err().to_string();
    assert!(e.contains("\"light\"") && e.contains("[[mesh]] #1"), "{e}");
}

#[test]
fn repo_scenes_load_without_shared() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box");
    let s = load_ok(&dir.join("scene.toml"));
    check_original(&s);
    assert_eq!((s.camera().width, s.camera().height, s.defaults().max_depth), (512, 512, 8));
    assert_eq!(s.camera().eye, Vec3::new(0.0, 1.0, 3.9));
    let s = load_ok(&dir.join("sphere.toml"));
    check_sphere(&s);
    assert_eq!((s.camera().width, s.camera().height, s.defaults().max_depth), (512, 512, 8));
    assert_eq!(s.camera().eye, Vec3::new(0.0, 0.795, 3.2));
}

#[test]
fn messages_name_file_line_and_key() {
    let f = scene(
        &format!("{LIGHT}[materials.floor]\nkind = \"glossy\"\nspecular = [0.3, 0.3, 0.3]\nroughness = -1\n"),
        &[],
    );
    let e = f.load("s.toml").unwrap_err().to_string();
    let want = format!(
        "{}: line 12: [materials.floor] roughness = -1: must be a GGX alpha in (0, 1]",
        f.path("s.toml").display()
    );
    assert_eq!(e, want);

    let head = "mtllib q.mtl\nusemtl light\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let f = scene("[[mesh]]\nobj = \"b.obj\"\n", &[("b.obj", &format!("{head}f 1 2 4\n"))]);
    let e = f.load("s.toml").unwrap_err().to_string();
    let want = format!(
        "{}: line 6: face corner \"4\": vertex index 4 is out of range (3 defined so far)",
        f.path("b.obj").display()
    );
    assert_eq!(e, want);

    let f = scene(&format!("{LIGHT}\n[[mesh]]\nobj = \"nope.obj\"\n"), &[]);
    let e = f.load("s.toml").unwrap_err().to_string();
    let want = format!(
        "{}: line 11: [[mesh]] #2 (obj = \"nope.obj\"): cannot read {}: ",
        f.path("s.toml").display(),
        f.path("nope.obj").display()
    );
    assert!(e.starts_with(&want), "{e}");

    let f = scene(&format!("{LIGHT}scale = 1\nrotate_z = 3\n"), &[]);
    let e = f.load("s.toml").unwrap_err().to_string();
    assert!(e.starts_with(&format!("{}: TOML parse error at line 10", f.path("s.toml").display())), "{e}");
    assert!(e.contains("unknown field `rotate_z`"), "{e}");
}

/// Mutated inputs never panic: each load either succeeds or returns an error.
#[test]
fn mutated_inputs_never_panic() {
    let toml = format!(
        "{CAMERA}[render]\nmax_depth = 4\n[[mesh]]\nobj = \"m.obj\"\nscale = [1, 2, 1]\nrotate_y = 30\n[materials.x]\nkind = \"glossy\"\nspecular = [0.5, 0.5, 0.5]\nroughness = 0.2\n"
    );
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nusemtl light\nf 1/1/1 2/1/1 3/1/1 4/1/1\nusemtl x\nf -4 -2 -1\n";
    let mtl = "newmtl light\nKd 0.5 0.5 0.5\nKs 0.1 0.1 0.1\nNs 10\nKe 1 1 1\nillum 2\n";
    let f = Fixture::new(&[("s.toml", &toml), ("m.obj", obj), ("m.mtl", mtl)]);
    f.load("s.toml").unwrap();
    let alphabet = b"0123456789-./ #\n\tefinavxf[]=\"";
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rnd = |n: usize| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % n as u64) as usize
    };
    for round in 0..300 {
        let (name, base) = [("s.toml", toml.as_str()), ("m.obj", obj), ("m.mtl", mtl)][round % 3];
        let mut bytes = base.as_bytes().to_vec();
        for _ in 0..1 + rnd(3) {
            let at = rnd(bytes.len());
            match rnd(3) {
                0 => {
                    bytes.remove(at);
                }
                1 => bytes.insert(at, alphabet[rnd(alphabet.len())]),
                _ => bytes[at] = alphabet[rnd(alphabet.len())],
            }
        }
        std::fs::write(f.path(name), &bytes).unwrap();
        let _ = f.load("s.toml");
        std::fs::write(f.path(name), base).unwrap();
    }
}

/// The production-sized scene of `docs/batch.md` loads as the contract's reader reads it: the
/// model's 331,179 triangles with its own MTL, and the 12 triangles of the six ceiling panels
/// that the scene file makes emitters, facing down into the room.
#[test]
fn the_conference_room_loads_with_its_ceiling_lights() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/conference-room/scene.toml");
    let scene = load(&path).unwrap();
    assert_eq!(scene.triangle_count(), 331_179 + 12);
    assert_eq!((scene.camera().width, scene.camera().height), (1920, 1080));
    let emitters = pir::light::Emitters::new(&scene).unwrap();
    assert_eq!(emitters.len(), 12);
    let emitting: Vec<u32> =
        (0..scene.triangle_count() as u32).filter(|t| scene.material_of(*t).emission != Vec3::ZERO).collect();
    assert_eq!(emitting.len(), 12);
    for t in emitting {
        let [a, b, c] = scene.triangle(t);
        assert!((b - a).cross(c - a).normalize().dot(Vec3::NEG_Y) > 0.999, "panel {t} faces up");
        assert!(a.y == 645.0);
    }
}

/// A reflectance above 1 creates energy: refused in the scene file and in an MTL file alike,
/// naming the file, the line and the value (as the Mitsuba format refuses it).
#[test]
fn reflectances_above_one_are_refused_in_both_formats() {
    let m = |body: &str| format!("{LIGHT}[materials.x]\n{body}");
    err(
        &m("kind = \"diffuse\"\nalbedo = [1.08, 0.5, 0.5]\n"),
        &[],
        "s.toml",
        &["[materials.x] albedo = [1.08, 0.5, 0.5]", "must not exceed 1"],
    );
    err(
        &m("kind = \"glossy\"\nspecular = [0.5, 1.2, 0.5]\nroughness = 0.2\n"),
        &[],
        "s.toml",
        &["[materials.x] specular", "must not exceed 1"],
    );
    err(
        "[[mesh]]\nobj = \"m.obj\"\n",
        &[
            ("m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n"),
            ("m.mtl", "# a bright white\nnewmtl a\nKd 1.08 1.08 1.08\n"),
        ],
        "m.mtl",
        &["line 2", "Kd 1.08", "must not exceed 1"],
    );
}

/// A glossy material whose albedo and specular reflectance are each at most 1 but add up to
/// more (the conference room's Kd 1 + Ks 0.2) is rendered as written, with one warning that
/// names the file and the material; one that adds up to 1 gets none.
#[test]
fn glossy_reflectances_adding_up_above_one_are_warned_about() {
    let m = |kd: &str| {
        format!(
            "{LIGHT}[[mesh]]\nobj = \"m.obj\"\n[materials.x]\nkind = \"glossy\"\nalbedo = [{kd}, 0.2, 0.2]\n\
             specular = [0.2, 0.2, 0.2]\nroughness = 0.2\n"
        )
    };
    let obj = ("m.obj", "mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n");
    let warnings = |kd: &str| {
        let f = scene(&m(kd), &[obj]);
        let (_, w) = pir::scene::load_with(&f.path("s.toml"), &Default::default()).unwrap();
        w
    };
    let w = warnings("0.9");
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("s.toml") && w[0].contains("\"x\"") && w[0].contains("1.1"), "{w:?}");
    assert!(warnings("0.8").is_empty());
}
