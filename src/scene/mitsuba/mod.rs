//! Mitsuba 3 scene files (`.xml`) into pir's one scene model: what they mean is Mitsuba 3's
//! documentation, and anything pir cannot render exactly as Mitsuba would is refused with one
//! line naming the file, the line, the plugin and what pir supports.
//!
//! Supported so far:
//! - the document ([`xml`]): `<default>`, `-D name=value`, `$name`, `<include>`, ids and
//!   `<ref>`, Mitsuba 0.6 files (upgraded as Mitsuba 3 does), `<transform>`s ([`transform`]);
//! - shapes ([`shapes`]): `obj`, `ply`, `serialized` ([`super::ply`], [`super::serialized`]),
//!   `rectangle`, `cube`, `disk`, `sphere`, with `to_world`,
//!   `flip_normals`, `face_normals` and Mitsuba's vertex normals for meshes without them;
//! - textures ([`textures`]): `bitmap` (PNG, JPEG, OpenEXR, Radiance HDR) and `checkerboard`,
//!   for a `diffuse` BSDF's `reflectance`; shapes' texture coordinates as Mitsuba's
//!   ([`shapes`]);
//! - BSDFs: `diffuse` (its `reflectance` a colour or a texture) and `twosided` around it
//!   ([`crate::material::Material::two_sided`]); a shape without one gets Mitsuba's default,
//!   a one-sided diffuse of reflectance 0.5, black (0) on an emitter;
//! - emitters ([`emitters`]): `area` with a constant `radiance` on shapes; `point`, `spot`,
//!   `directional`, `constant` and `envmap` (any image pir reads as a texture);
//! - the sensor: `perspective` (`fov`, `fov_axis`, `to_world`; `near_clip`, `far_clip` and
//!   `focus_distance` are accepted and change nothing in front of the near plane), its
//!   `hdrfilm` (`width`, `height`; a `box` filter is pir's own, a `tent` or `gaussian` one is
//!   rendered with a box filter and a warning) and its sampler (pir's own is used);
//! - the integrator: `path` or `volpath` (`max_depth`, −1 for unbounded: pir's largest,
//!   [`MAX_DEPTH`]; `rr_depth` 5, pir's).
//!
//! A reflectance above 1 creates energy: refused, as Mitsuba does.

mod bsdfs;
mod emitters;
mod shapes;
mod textures;
mod transform;
mod write;
mod xml;

pub use write::write;

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};

use super::format::MAX_DEPTH;
use super::{Camera, Filter, Geometry, RenderDefaults, Scene, SceneError};
use crate::material::{Bsdf, Material, Slot, Textured};
use crate::texture::Texture;

/// A BSDF's textured slots.
type Slots = Vec<(Slot, Texture)>;
use shapes::{Normals, WorldMesh};
use transform::{numbers, parse_number};
use xml::Element;

/// What a scene file may leave the command line to set (`-D name=value`).
#[derive(Clone, Debug, Default)]
pub struct Options {
    pub defines: Vec<(String, String)>,
}

/// Loads the Mitsuba scene `path`; what it renders differently from Mitsuba (a reconstruction
/// filter pir approximates) comes back as warnings.
pub fn load(path: &Path, options: &Options) -> Result<(Scene, Vec<String>), SceneError> {
    let doc = xml::read(path, &options.defines)?;
    let mut ids = HashMap::new();
    collect_ids(&doc.elements, &mut ids)?;
    let mut b = Builder {
        ids,
        warnings: Vec::new(),
        late_warnings: Default::default(),
        materials: Vec::new(),
        geometry: Geometry::default(),
        images: textures::ImageCache::default(),
        filter: Filter::Gaussian { stddev: 0.5 },
    };
    let mut camera = None;
    let mut render = RenderDefaults { max_depth: MAX_DEPTH, seed: 0 };
    let mut integrator_seen = false;
    let mut shape_elements = Vec::new();
    let mut lights = Vec::new();
    for e in &doc.elements {
        match e.tag.as_str() {
            "integrator" => {
                if std::mem::replace(&mut integrator_seen, true) {
                    return Err(e.error("a second integrator"));
                }
                render.max_depth = b.integrator(e)?;
            }
            "sensor" => {
                if camera.is_some() {
                    return Err(e.error("a second sensor: pir renders one camera"));
                }
                camera = Some(b.sensor(e)?);
            }
            "shape" => shape_elements.push(e),
            // Definitions, instantiated where a shape refers to them.
            "bsdf" | "texture" if e.attr("id").is_some() => {}
            "emitter" => lights.push(b.light(e)?),
            other => return Err(e.error(format!("<{other}> is not supported at the top of a scene"))),
        }
    }
    // The shapes' files are read in parallel, and added in the document's order.
    let shapes: Vec<Result<(WorldMesh, Material), SceneError>> = {
        use rayon::prelude::*;
        let b = &b;
        shape_elements.par_iter().map(|e| b.shape(e)).collect()
    };
    for shape in shapes {
        let (mesh, material) = shape?;
        let material = b.material(material);
        b.add(mesh, material);
    }
    // Texture coordinates of the vertices after the last textured shape's.
    if !b.geometry.uvs.is_empty() {
        let n = b.geometry.positions.len();
        b.geometry.uvs.resize(n, glam::Vec2::NAN);
    }
    let camera = camera.ok_or_else(|| SceneError::Value {
        path: path.to_path_buf(),
        line: None,
        key: "<sensor>".into(),
        problem: "the scene has no sensor".into(),
    })?;
    if !b.materials.iter().any(|m| m.is_emitter()) && lights.is_empty() {
        return Err(SceneError::NoEmitter { path: path.to_path_buf() });
    }
    let mut scene =
        Scene::new(path.to_path_buf(), camera, render, b.geometry, b.materials)?.with_lights(lights);
    scene.set_filter(b.filter);
    let mut warnings = b.warnings;
    let mut late = b.late_warnings.into_inner().unwrap_or_else(|e| e.into_inner());
    late.sort();
    late.dedup();
    warnings.extend(late);
    Ok((scene, warnings))
}

/// Every element with an id, by id (a second element of the same id is an error).
fn collect_ids<'a>(
    elements: &'a [Element],
    ids: &mut HashMap<String, &'a Element>,
) -> Result<(), SceneError> {
    for e in elements {
        if let Some(id) = e.attr("id")
            && e.tag != "ref"
            && ids.insert(id.to_string(), e).is_some()
        {
            return Err(e.error(format!("a second element of id \"{id}\"")));
        }
        collect_ids(&e.children, ids)?;
    }
    Ok(())
}

struct Builder<'a> {
    ids: HashMap<String, &'a Element>,
    warnings: Vec<String>,
    /// Warnings of the plugins read in parallel (the shapes' BSDFs), added to `warnings` at
    /// the end.
    late_warnings: std::sync::Mutex<Vec<String>>,
    materials: Vec<Material>,
    geometry: Geometry,
    images: textures::ImageCache,
    /// The film's reconstruction filter: Mitsuba's default, a Gaussian of σ = 0.5, unless the
    /// film names one.
    filter: Filter,
}

/// Property tags: the children of a plugin that are its parameters.
const PROPERTY_TAGS: [&str; 10] =
    ["float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector", "transform", "texture"];

/// A plugin's parameters, each marked when read, so that one pir does not read is an error
/// rather than a silently different image.
struct Params<'a> {
    e: &'a Element,
    used: RefCell<Vec<bool>>,
}

impl<'a> Params<'a> {
    fn new(e: &'a Element) -> Self {
        Params { e, used: RefCell::new(vec![false; e.children.len()]) }
    }

    /// The child property of this name.
    fn get(&self, name: &str) -> Option<&'a Element> {
        let i = self
            .e
            .children
            .iter()
            .position(|c| PROPERTY_TAGS.contains(&c.tag.as_str()) && c.attr("name") == Some(name))?;
        self.used.borrow_mut()[i] = true;
        Some(&self.e.children[i])
    }

    /// Marks parameters that change nothing pir renders.
    fn ignore(&self, names: &[&str]) {
        for n in names {
            self.get(n);
        }
    }

    fn value(&self, p: &'a Element) -> Result<&'a str, SceneError> {
        p.attr("value").ok_or_else(|| p.error("needs a value"))
    }

    fn float(&self, name: &str) -> Result<Option<f32>, SceneError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        if p.tag != "float" && p.tag != "integer" {
            return Err(p.error(format!("{name}: expected a <float>")));
        }
        let v = self.value(p)?;
        parse_number(v).map(Some).ok_or_else(|| p.error(format!("\"{v}\": not a finite number")))
    }

    fn integer(&self, name: &str) -> Result<Option<i64>, SceneError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        let v = self.value(p)?;
        if p.tag != "integer" {
            return Err(p.error(format!("{name}: expected an <integer>")));
        }
        v.trim().parse().map(Some).map_err(|_| p.error(format!("\"{v}\": not an integer")))
    }

    fn boolean(&self, name: &str) -> Result<Option<bool>, SceneError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        match self.value(p)?.trim() {
            "true" => Ok(Some(true)),
            "false" => Ok(Some(false)),
            v => Err(p.error(format!("\"{v}\": expected true or false"))),
        }
    }

    fn string(&self, name: &str) -> Result<Option<&'a str>, SceneError> {
        self.get(name).map(|p| self.value(p)).transpose()
    }

    fn point(&self, name: &str) -> Result<Option<Vec3>, SceneError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        let v = match p.attr("value") {
            Some(v) => numbers(p, v)?,
            None => ["x", "y", "z"]
                .iter()
                .map(|k| {
                    p.attr(k)
                        .map_or(Some(0.0), parse_number)
                        .ok_or_else(|| p.error(format!("{k}: not a finite number")))
                })
                .collect::<Result<_, _>>()?,
        };
        match v.as_slice() {
            [x, y, z] => Ok(Some(Vec3::new(*x, *y, *z))),
            _ => Err(p.error("expected three numbers")),
        }
    }

    fn transform(&self, name: &str) -> Result<Option<Mat4>, SceneError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        if p.tag != "transform" {
            return Err(p.error(format!("{name}: expected a <transform>")));
        }
        transform::parse(p).map(Some)
    }

    /// A colour: `<rgb>`, a constant `<spectrum>` or a `<float>`.
    fn colour(&self, name: &str) -> Result<Option<Vec3>, SceneError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        match p.tag.as_str() {
            "rgb" | "float" => {
                let v = numbers(p, self.value(p)?)?;
                match v.as_slice() {
                    [x] => Ok(Some(Vec3::splat(*x))),
                    [r, g, b] if p.tag == "rgb" => Ok(Some(Vec3::new(*r, *g, *b))),
                    _ => Err(p.error("expected one number or three")),
                }
            }
            "spectrum" => {
                let v = self.value(p)?;
                if v.contains(':') {
                    return Err(p.error(
                        "a spectrum sampled at wavelengths is not supported: pir renders RGB (give an <rgb>)",
                    ));
                }
                match numbers(p, v)?.as_slice() {
                    [x] => Ok(Some(Vec3::splat(*x))),
                    _ => Err(p.error("expected one number (a constant spectrum)")),
                }
            }
            "texture" => Err(p.error(format!(
                "{name}: a texture (type \"{}\") is not supported here yet: pir reads textures on a diffuse \
                 BSDF's reflectance; give a colour (<rgb>)",
                p.type_name()
            ))),
            other => Err(p.error(format!("{name}: expected a colour (<rgb>), not <{other}>"))),
        }
    }

    /// Nested plugins of this tag (a `<ref>` counts as the plugin it names).
    fn plugins(&self, b: &Builder<'a>, tag: &str) -> Result<Vec<&'a Element>, SceneError> {
        let mut out = Vec::new();
        for (i, c) in self.e.children.iter().enumerate() {
            let e = if c.tag == "ref" { b.resolve(c)? } else { c };
            if e.tag == tag {
                self.used.borrow_mut()[i] = true;
                out.push(e);
            }
        }
        Ok(out)
    }

    /// The parameters and nested plugins nobody read: an error for the first.
    fn finish(&self, b: &Builder<'a>) -> Result<(), SceneError> {
        for (c, used) in self.e.children.iter().zip(self.used.borrow().iter()) {
            if *used {
                continue;
            }
            let plugin = if c.tag == "ref" { b.resolve(c)? } else { c };
            return Err(if PROPERTY_TAGS.contains(&c.tag.as_str()) {
                c.error(format!(
                    "parameter \"{}\" of {} is not supported by pir",
                    c.attr("name").unwrap_or("?"),
                    self.e.describe()
                ))
            } else {
                c.error(format!("{} inside {} is not supported by pir", plugin.describe(), self.e.describe()))
            });
        }
        Ok(())
    }
}

impl<'a> Builder<'a> {
    /// The element a `<ref id>` names.
    fn resolve(&self, r: &'a Element) -> Result<&'a Element, SceneError> {
        let id = r.attr("id").ok_or_else(|| r.error("<ref> needs an id"))?;
        self.ids.get(id).copied().ok_or_else(|| r.error(format!("no element has id \"{id}\"")))
    }

    /// The integrator's `max_depth`.
    fn integrator(&mut self, e: &'a Element) -> Result<u32, SceneError> {
        let p = Params::new(e);
        if !matches!(e.type_name(), "path" | "volpath") {
            return Err(e.error(format!(
                "integrator type \"{}\" is not supported: pir renders Mitsuba's path integrator (path, volpath \
                 without media) with any of its methods (--method)",
                e.type_name()
            )));
        }
        let max_depth = match p.integer("max_depth")? {
            None | Some(-1) => MAX_DEPTH,
            Some(d) if (1..=MAX_DEPTH as i64).contains(&d) => d as u32,
            Some(d) if d > MAX_DEPTH as i64 => MAX_DEPTH,
            Some(d) => return Err(e.error(format!("max_depth {d}: must be -1 (unbounded) or at least 1"))),
        };
        if let Some(rr) = p.integer("rr_depth")?
            && rr != 5
        {
            return Err(e.error(format!(
                "rr_depth {rr}: pir's Russian roulette starts at depth 5 (Mitsuba's default); give 5 or leave it out"
            )));
        }
        if p.boolean("hide_emitters")? == Some(true) {
            return Err(e.error("hide_emitters: pir always shows the emitters a camera ray hits"));
        }
        p.finish(self)?;
        Ok(max_depth)
    }

    /// The perspective sensor as pir's camera.
    fn sensor(&mut self, e: &'a Element) -> Result<Camera, SceneError> {
        let p = Params::new(e);
        if e.type_name() != "perspective" {
            return Err(e.error(format!(
                "sensor type \"{}\" is not supported: pir renders a perspective (pinhole) camera",
                e.type_name()
            )));
        }
        if p.get("focal_length").is_some() {
            return Err(e.error("focal_length is not supported: give the field of view (fov)"));
        }
        let fov = p.float("fov")?.ok_or_else(|| e.error("needs a fov (degrees)"))?;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(e.error(format!("fov {fov}: must be between 0 and 180 degrees")));
        }
        let axis = p.string("fov_axis")?.unwrap_or("x");
        let m = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        p.ignore(&["near_clip", "far_clip", "focus_distance", "shutter_open", "shutter_close"]);
        let films = p.plugins(self, "film")?;
        let (width, height) = match films.as_slice() {
            [] => (768, 576),
            [film] => self.film(film)?,
            _ => return Err(e.error("more than one film")),
        };
        p.plugins(self, "sampler")?;
        p.finish(self)?;
        let (w, h) = (width as f32, height as f32);
        let tan_half = (fov.to_radians() / 2.0).tan();
        // pir's field of view is vertical.
        let tan_v = match axis {
            "x" => tan_half * h / w,
            "y" => tan_half,
            "diagonal" => tan_half * h / (w * w + h * h).sqrt(),
            "smaller" if w < h => tan_half * h / w,
            "smaller" => tan_half,
            "larger" if w > h => tan_half * h / w,
            "larger" => tan_half,
            other => {
                return Err(
                    e.error(format!("fov_axis \"{other}\": expected x, y, diagonal, smaller or larger"))
                );
            }
        };
        let eye = m.transform_point3(Vec3::ZERO);
        let (forward, up, left) =
            (m.transform_vector3(Vec3::Z), m.transform_vector3(Vec3::Y), m.transform_vector3(Vec3::X));
        let (Some(forward), Some(up), Some(left)) =
            (forward.try_normalize(), up.try_normalize(), left.try_normalize())
        else {
            return Err(e.error("to_world collapses the camera's axes"));
        };
        if forward.dot(up).abs() > 1e-3 || forward.dot(left).abs() > 1e-3 || up.dot(left).abs() > 1e-3 {
            return Err(e.error("to_world shears the camera: pir's camera needs orthogonal axes"));
        }
        if up.cross(forward).dot(left) < 0.0 {
            return Err(e.error(
                "to_world mirrors the image (e.g. a negative scale): not supported, a pir camera's right is forward × up",
            ));
        }
        Ok(Camera { eye, target: eye + forward, up, fov_deg: 2.0 * tan_v.atan().to_degrees(), width, height })
    }

    /// The film's size.
    fn film(&mut self, f: &'a Element) -> Result<(u32, u32), SceneError> {
        let p = Params::new(f);
        if f.type_name() != "hdrfilm" {
            return Err(
                f.error(format!("film type \"{}\" is not supported: pir writes an hdrfilm", f.type_name()))
            );
        }
        let side = |v: Option<i64>, default: u32, what: &str| -> Result<u32, SceneError> {
            match v {
                None => Ok(default),
                Some(v) if (1..=super::format::MAX_RESOLUTION as i64).contains(&v) => Ok(v as u32),
                Some(v) => {
                    Err(f.error(format!("{what} {v}: must be 1 to {}", super::format::MAX_RESOLUTION)))
                }
            }
        };
        let width = side(p.integer("width")?, 768, "width")?;
        let height = side(p.integer("height")?, 576, "height")?;
        p.ignore(&["file_format", "pixel_format", "component_format", "banner", "sample_border"]);
        for r in p.plugins(self, "rfilter")? {
            let q = Params::new(r);
            self.filter = match r.type_name() {
                "box" => Filter::Box,
                "tent" => match q.float("radius")?.unwrap_or(1.0) {
                    radius if radius > 0.0 && radius <= 8.0 => Filter::Tent { radius },
                    radius => return Err(r.error(format!("radius {radius}: must lie in (0, 8] pixels"))),
                },
                "gaussian" => match q.float("stddev")?.unwrap_or(0.5) {
                    stddev if stddev > 0.0 && stddev <= 2.0 => Filter::Gaussian { stddev },
                    stddev => return Err(r.error(format!("stddev {stddev}: must lie in (0, 2] pixels"))),
                },
                other => {
                    return Err(r.error(format!(
                        "reconstruction filter \"{other}\" is not supported: pir reads box, tent and gaussian"
                    )));
                }
            };
            q.finish(self)?;
        }
        p.finish(self)?;
        Ok((width, height))
    }

    /// A shape's world-space triangles and its material (shapes are read in parallel).
    fn shape(&self, e: &'a Element) -> Result<(WorldMesh, Material), SceneError> {
        let p = Params::new(e);
        let dir = e.file.parent().unwrap_or(Path::new("")).to_path_buf();
        let file = |p: &Params<'a>| -> Result<PathBuf, SceneError> {
            let name = p.string("filename")?.ok_or_else(|| e.error("needs a filename"))?;
            Ok(dir.join(name))
        };
        let file_err = |err: SceneError| match err {
            SceneError::Io { path, error } => e.error(format!("cannot read {}: {error}", path.display())),
            other => other,
        };
        let (mesh, kind, placement) = match e.type_name() {
            "rectangle" => (shapes::rectangle(), Normals::Analytic, Mat4::IDENTITY),
            "disk" => (shapes::disk(), Normals::Analytic, Mat4::IDENTITY),
            "cube" => (shapes::cube(), Normals::Winding, Mat4::IDENTITY),
            "sphere" => {
                let center = p.point("center")?.unwrap_or(Vec3::ZERO);
                let radius = p.float("radius")?.unwrap_or(1.0);
                (shapes::sphere(), Normals::Analytic, shapes::sphere_placement(e, center, radius)?)
            }
            "obj" => (shapes::obj(&file(&p)?).map_err(file_err)?, Normals::Winding, Mat4::IDENTITY),
            "ply" => {
                let path = file(&p)?;
                let data = super::ply::read_ply(&path).map_err(file_err)?;
                (shapes::from_data(data, &path)?, Normals::Winding, Mat4::IDENTITY)
            }
            "serialized" => {
                let path = file(&p)?;
                let index = match p.integer("shape_index")? {
                    None => 0,
                    Some(i) if (0..=u32::MAX as i64).contains(&i) => i as u32,
                    Some(i) => return Err(e.error(format!("shape_index {i}: must not be negative"))),
                };
                let data = super::serialized::read_serialized(&path, index).map_err(file_err)?;
                (shapes::from_data(data, &path)?, Normals::Winding, Mat4::IDENTITY)
            }
            other => {
                return Err(e.error(format!(
                    "shape type \"{other}\" is not supported: pir reads obj, ply, serialized, rectangle, cube, disk and sphere"
                )));
            }
        };
        let mut mesh = mesh;
        if p.boolean("face_normals")? == Some(true) {
            mesh.face_normals = true;
        }
        let flip = p.boolean("flip_normals")?.unwrap_or(false);
        let to_world = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY) * placement;
        let bsdfs = p.plugins(self, "bsdf")?;
        let emitters = p.plugins(self, "emitter")?;
        p.finish(self)?;
        let (bsdf, two_sided, textures) = match bsdfs.as_slice() {
            // Mitsuba's default (`Shape`'s constructor): a one-sided diffuse of 0.5, black on
            // an emitter.
            [] if !emitters.is_empty() => (Bsdf::Diffuse { albedo: Vec3::ZERO }, false, None),
            [] => (Bsdf::Diffuse { albedo: Vec3::splat(0.5) }, false, None),
            [b] => self.bsdf(b)?,
            _ => return Err(e.error("more than one bsdf")),
        };
        let emission = match emitters.as_slice() {
            [] => Vec3::ZERO,
            [em] => self.area_emitter(em)?,
            _ => return Err(e.error("more than one emitter")),
        };
        let name =
            e.attr("id").or_else(|| bsdfs.first().and_then(|b| b.attr("id"))).unwrap_or("shape").to_string();
        let mut mesh = shapes::to_world(mesh, to_world, flip, kind);
        // Texture coordinates are kept only where a texture reads them; a textured mesh
        // without them gets Mitsuba's barycentric ones (meshes are never analytic shapes, so
        // only `flip_normals` swaps their winding).
        if textures.is_none() {
            mesh.uvs = Vec::new();
        } else if mesh.uvs.is_empty() {
            mesh = shapes::barycentric_uvs(mesh, flip);
        }
        let textures = textures.map(|slots| std::sync::Arc::new(Textured::new(slots)));
        Ok((mesh, Material { name, bsdf, emission, two_sided, textures }))
    }

    /// The index of `m` among the scene's materials (equal ones are stored once).
    fn material(&mut self, m: Material) -> u32 {
        let same = |a: &Material| {
            a.bsdf == m.bsdf
                && a.emission == m.emission
                && a.two_sided == m.two_sided
                && a.textures == m.textures
        };
        match self.materials.iter().position(same) {
            Some(i) => i as u32,
            None => {
                self.materials.push(m);
                self.materials.len() as u32 - 1
            }
        }
    }

    fn add(&mut self, m: WorldMesh, material: u32) {
        let g = &mut self.geometry;
        let base = g.positions.len() as u32;
        for t in m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            if (b - a).cross(c - a).length_squared() > 0.0 {
                g.indices.push(t.map(|i| i + base));
                g.tri_material.push(material);
            } else {
                g.degenerate_dropped += 1;
            }
        }
        if !m.uvs.is_empty() {
            g.uvs.resize(g.positions.len(), glam::Vec2::NAN);
            g.uvs.extend(m.uvs);
        }
        g.positions.extend(m.positions);
        g.normals.extend(m.normals);
    }

    /// A BSDF, whether it is two-sided, and its textured slots (`None` where it has none).
    fn bsdf(&self, e: &'a Element) -> Result<(Bsdf, bool, Option<Slots>), SceneError> {
        let p = Params::new(e);
        let out = match e.type_name() {
            "twosided" => {
                let inner = p.plugins(self, "bsdf")?;
                match inner.as_slice() {
                    [b] if b.type_name() == "twosided" => return Err(b.error("a twosided inside a twosided")),
                    [b] => {
                        let (bsdf, _, textures) = self.bsdf(b)?;
                        (bsdf, true, textures)
                    }
                    [_, _] => {
                        return Err(
                            e.error("a twosided with two BSDFs (front, back) is not supported: give one")
                        );
                    }
                    _ => return Err(e.error("needs one nested bsdf")),
                }
            }
            "diffuse" => {
                let (albedo, slots) = self.reflectance_texture(e, &p, "reflectance")?;
                (Bsdf::Diffuse { albedo }, false, slots)
            }
            "dielectric" => (bsdfs::dielectric(e, &p)?, false, None),
            "thindielectric" => (bsdfs::thin_dielectric(e, &p)?, false, None),
            "roughdielectric" => (bsdfs::rough_dielectric(e, &p)?, false, None),
            "conductor" => (bsdfs::conductor(e, &p)?, false, None),
            "roughconductor" => (bsdfs::rough_conductor(e, &p)?, false, None),
            "plastic" | "roughplastic" => {
                let (diffuse, slots) = self.reflectance_texture(e, &p, "diffuse_reflectance")?;
                (bsdfs::plastic(e, &p, diffuse, e.type_name() == "roughplastic")?, false, slots)
            }
            "mask" => {
                let inner = p.plugins(self, "bsdf")?;
                let [b] = inner.as_slice() else { return Err(e.error("needs one nested bsdf")) };
                let (inner, two_sided, slots) = self.bsdf(b)?;
                let (bsdf, two_sided) = bsdfs::mask(e, &p, (inner, two_sided))?;
                (bsdf, two_sided, slots)
            }
            "blendbsdf" => {
                let w = p
                    .float("weight")?
                    .ok_or_else(|| e.error("needs a weight (a texture weight is not supported)"))?;
                if !(0.0..=1.0).contains(&w) {
                    return Err(e.error(format!("weight {w}: must lie between 0 and 1")));
                }
                let inner = p.plugins(self, "bsdf")?;
                let [a, b] = inner.as_slice() else { return Err(e.error("needs two nested bsdfs")) };
                // (1 − w) · a + w · b, a Lambertian lobe and a GGX one: pir's glossy material.
                let parts = |d: &'a Element, g: &'a Element, wd: f32, wg: f32| -> Result<Bsdf, SceneError> {
                    let (pd, pg) = (Params::new(d), Params::new(g));
                    let albedo = diffuse_albedo(&pd)?;
                    let (specular, roughness) = rough_mirror(g, &pg)?;
                    pd.finish(self)?;
                    pg.finish(self)?;
                    Ok(Bsdf::Glossy { albedo: albedo * wd, specular: specular * wg, roughness })
                };
                let bsdf = match (a.type_name(), b.type_name()) {
                    ("diffuse", "roughconductor") => parts(a, b, 1.0 - w, w)?,
                    ("roughconductor", "diffuse") => parts(b, a, w, 1.0 - w)?,
                    _ => {
                        return Err(e.error(
                            "a blendbsdf is supported of a diffuse and a roughconductor (material none, ggx): \
                             pir's glossy material",
                        ));
                    }
                };
                (bsdf, false, None)
            }
            other => {
                return Err(e.error(format!(
                    "bsdf type \"{other}\" is not supported yet: pir reads diffuse, plastic, roughplastic, conductor, \
                     roughconductor, dielectric, thindielectric, roughdielectric, mask (of a diffuse), twosided \
                     and blendbsdf of diffuse and roughconductor (material none, ggx)"
                )));
            }
        };
        p.finish(self)?;
        Ok(out)
    }

    /// A reflectance that may be a texture (default 0.5): its value for the BSDF (a texture's
    /// mean, which also steers a plastic's lobe choice, as Mitsuba's `mean()`), and the texture
    /// for the material's reflectance slot; every value must lie in [0, 1].
    fn reflectance_texture(
        &self,
        e: &'a Element,
        p: &Params<'a>,
        name: &str,
    ) -> Result<(Vec3, Option<Slots>), SceneError> {
        match p.texture(self, name)? {
            Some(Texture::Constant(v)) => {
                reflectance(e, name, v)?;
                Ok((v, None))
            }
            Some(t) => {
                let (lo, hi) = t.range();
                if lo < 0.0 || hi > 1.0 {
                    return Err(e.error(format!(
                        "{name}: the texture's values span {lo} to {hi}; they must lie between 0 and 1 \
                         (above 1 the material creates energy; Mitsuba refuses it too)"
                    )));
                }
                Ok((t.mean(), Some(vec![(Slot::Reflectance, t)])))
            }
            None => Ok((Vec3::splat(0.5), None)),
        }
    }

    /// An area emitter's radiance.
    fn area_emitter(&self, e: &'a Element) -> Result<Vec3, SceneError> {
        let p = Params::new(e);
        if e.type_name() != "area" {
            return Err(e.error(format!(
                "emitter type \"{}\" on a shape: only area emitters can be attached to shapes",
                e.type_name()
            )));
        }
        let radiance = p.colour("radiance")?.ok_or_else(|| e.error("needs a radiance"))?;
        if radiance.min_element() < 0.0 {
            return Err(e.error(format!("radiance {radiance}: must not be negative")));
        }
        p.finish(self)?;
        Ok(radiance)
    }
}

/// A diffuse BSDF's reflectance (default 0.5).
fn diffuse_albedo(p: &Params) -> Result<Vec3, SceneError> {
    let albedo = p.colour("reflectance")?.unwrap_or(Vec3::splat(0.5));
    reflectance(p.e, "reflectance", albedo)?;
    Ok(albedo)
}

/// A blend's `roughconductor`, read as every `roughconductor` is ([`bsdfs::rough_conductor`]):
/// of material none and GGX it is pir's glossy lobe without albedo, whose specular reflectance
/// and alpha the blend weighs; with a Fresnel term or Beckmann normals it is refused.
fn rough_mirror(e: &Element, p: &Params) -> Result<(Vec3, f32), SceneError> {
    match bsdfs::rough_conductor(e, p)? {
        Bsdf::Glossy { specular, roughness, .. } => Ok((specular, roughness)),
        _ => Err(e.error(
            "in a blendbsdf, a roughconductor must be of material none and distribution ggx (pir's glossy lobe)",
        )),
    }
}

/// An index of refraction: a number, or a name of Mitsuba's table.
fn ior(p: &Params, name: &str, default: f32) -> Result<f32, SceneError> {
    let Some(e) = p.get(name) else { return Ok(default) };
    let v = p.value(e)?;
    if let Some(x) = parse_number(v) {
        if x > 0.0 {
            return Ok(x);
        }
        return Err(e.error(format!("{name} {x}: must be positive")));
    }
    const TABLE: [(&str, f32); 23] = [
        ("vacuum", 1.0),
        ("helium", 1.000036),
        ("hydrogen", 1.000132),
        ("air", 1.000277),
        ("carbon dioxide", 1.00045),
        ("water", 1.333),
        ("acetone", 1.36),
        ("ethanol", 1.361),
        ("carbon tetrachloride", 1.461),
        ("glycerol", 1.4729),
        ("benzene", 1.501),
        ("silicone oil", 1.52045),
        ("bromine", 1.661),
        ("water ice", 1.31),
        ("fused quartz", 1.458),
        ("pyrex", 1.47),
        ("acrylic glass", 1.49),
        ("polypropylene", 1.49),
        ("bk7", 1.5046),
        ("sodium chloride", 1.544),
        ("amber", 1.55),
        ("pet", 1.575),
        ("diamond", 2.419),
    ];
    TABLE.iter().find(|(n, _)| *n == v.trim()).map(|(_, x)| *x).ok_or_else(|| {
        e.error(format!(
            "{name} \"{v}\": neither a number nor a name of Mitsuba's table (bk7, water, air, …)"
        ))
    })
}

/// A reflectance must lie in [0, 1] in every channel.
fn reflectance(e: &Element, name: &str, v: Vec3) -> Result<(), SceneError> {
    if v.min_element() < 0.0 || v.max_element() > 1.0 {
        return Err(e.error(format!(
            "{name} {} {} {}: must lie between 0 and 1 in every channel (above 1 the material creates energy; \
             Mitsuba refuses it too)",
            v.x, v.y, v.z
        )));
    }
    Ok(())
}
