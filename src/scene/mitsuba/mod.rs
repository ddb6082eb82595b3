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
//!   for the parameters of [`TEXTURED_PARAMETERS`]; shapes' texture coordinates as Mitsuba's
//!   ([`shapes`]);
//! - BSDFs: `diffuse` (its `reflectance` a colour or a texture), those of [`bsdfs`], `twosided`
//!   around them ([`crate::material::Material::two_sided`]), and `normalmap` and `bumpmap`
//!   around them ([`crate::material::shading_map`]), `blendbsdf` of any two and `mask` of
//!   any one ([`crate::material::composite`]); a shape without one gets Mitsuba's
//!   default, a one-sided diffuse of reflectance 0.5, black (0) on an emitter;
//! - emitters ([`emitters`]): `area` with a constant `radiance` on shapes; `point`, `spot`,
//!   `directional`, `constant` and `envmap` (any image pir reads as a texture);
//! - the sensor ([`sensor`]): `perspective` and `thinlens` (`fov` and `fov_axis` or
//!   `focal_length`, `near_clip`, `far_clip`, `to_world`; the thin lens's `aperture_radius`
//!   and `focus_distance`), its `hdrfilm` (`width`, `height`, a `box`, `tent` or `gaussian`
//!   reconstruction filter) and its sampler (pir's own is used);
//! - the integrator: `path` or `volpath` (`max_depth`, −1 for unbounded: pir's largest,
//!   [`MAX_DEPTH`]; `rr_depth`, where the camera paths' Russian roulette starts).
//!
//! A reflectance above 1 creates energy: refused, as Mitsuba does.

mod bsdfs;
mod emitters;
mod sensor;
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
use super::{DEFAULT_RR_DEPTH, Filter, Geometry, RenderDefaults, Scene, SceneError, SphereShape};
use crate::accel::MAX_SPHERES;
use crate::light::SphereLight;
use crate::material::composite::{Composite, Part};
use crate::material::shading_map::{BackSide, Perturbation, ShadingMap};
use crate::material::{Bsdf, Material, Slot, Textured};
use crate::texture::Texture;

/// A BSDF's textured slots and its normal or bump map.
type Slots = Textured;
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
    let mut render = RenderDefaults { max_depth: MAX_DEPTH, ..RenderDefaults::default() };
    let mut integrator_seen = false;
    let mut shape_elements = Vec::new();
    let mut lights = Vec::new();
    for e in &doc.elements {
        match e.tag.as_str() {
            "integrator" => {
                if std::mem::replace(&mut integrator_seen, true) {
                    return Err(e.error("a second integrator"));
                }
                (render.max_depth, render.rr_depth) = b.integrator(e)?;
            }
            "sensor" => {
                if camera.is_some() {
                    return Err(e.error("a second sensor: pir renders one camera"));
                }
                camera = Some(b.sensor(e)?);
            }
            "shape" => match e.type_name() {
                // Shapes drawn where an instance places them (Mitsuba's instancing), copied.
                "shapegroup" => {}
                "instance" => shape_elements.extend(b.instance(e)?),
                _ => shape_elements.push((e, Mat4::IDENTITY)),
            },
            // Definitions, instantiated where a shape refers to them.
            "bsdf" | "texture" if e.attr("id").is_some() => {}
            "emitter" => lights.push(b.light(e)?),
            other => return Err(e.error(format!("<{other}> is not supported at the top of a scene"))),
        }
    }
    // The shapes' files are read in parallel, and added in the document's order.
    let shapes: Vec<Result<Shape, SceneError>> = {
        use rayon::prelude::*;
        let b = &b;
        shape_elements.par_iter().map(|&(e, outer)| b.shape(e, outer)).collect()
    };
    // The emitting spheres' primitives, for next-event estimation by their cones.
    let mut spheres = Vec::new();
    // Analytic spheres (the first MAX_SPHERES), with whether they emit and their triangles in
    // case the scene has no other triangles.
    let mut analytic: Vec<PendingSphere> = Vec::new();
    for shape in shapes {
        let Shape { mesh, material, exact, analytic: sphere } = shape?;
        let emits = material.is_emitter();
        let material = b.material(material);
        if let Some(s) = sphere
            && analytic.len() < MAX_SPHERES
        {
            analytic.push((SphereShape { material, ..s }, emits, mesh, exact));
            continue;
        }
        b.add_tessellated(mesh, material, exact, &mut spheres);
    }
    // A scene needs triangles: one of spheres only is tessellated after all.
    if b.geometry.indices.is_empty() {
        for (s, _, mesh, exact) in analytic.drain(..) {
            b.add_tessellated(mesh, s.material, exact, &mut spheres);
        }
    }
    let first = b.geometry.indices.len() as u32;
    for (k, (s, emits, _, _)) in analytic.iter().enumerate() {
        if *emits && !s.flip {
            let prim = first + k as u32;
            spheres.push(SphereLight {
                center: s.sphere.center,
                radius: s.sphere.radius,
                prims: prim..prim + 1,
            });
        }
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
    let mut scene = Scene::new(path.to_path_buf(), camera, render, b.geometry, b.materials)?
        .with_lights(lights)
        .with_spheres(analytic.into_iter().map(|(s, ..)| s).collect())?
        .with_sphere_lights(spheres)?;
    scene.set_filter(b.filter);
    let mut warnings = b.warnings;
    let mut late = b.late_warnings.into_inner().unwrap_or_else(|e| e.into_inner());
    late.sort();
    late.dedup();
    warnings.extend(late);
    Ok((scene, warnings))
}

/// An analytic sphere while the scene is assembled: the sphere, whether it emits, and its
/// tessellation and exact sphere in case the scene has no triangles besides the spheres.
type PendingSphere = (SphereShape, bool, WorldMesh, Option<(Vec3, f32)>);

/// A shape as [`Builder::shape`] reads it.
struct Shape {
    /// Its triangles (a `sphere`'s tessellation too, used where it cannot stay analytic).
    mesh: WorldMesh,
    material: Material,
    /// For an emitting tessellated sphere, the centre and radius of the exact sphere.
    exact: Option<(Vec3, f32)>,
    /// A `sphere` that can be analytic ([`shapes::analytic_sphere`]; its material index is
    /// set when the scene is assembled).
    analytic: Option<SphereShape>,
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

/// The parameters pir reads as textures, for the error about any other.
const TEXTURED_PARAMETERS: &str = "diffuse's reflectance, plastic's and roughplastic's diffuse_reflectance, \
     the specular_reflectance of conductor, roughconductor, plastic, roughplastic, dielectric, thindielectric and \
     roughdielectric, the specular_transmittance of dielectric, thindielectric and roughdielectric, the eta and k \
     of conductor and roughconductor, roughconductor's alpha, mask's opacity, blendbsdf's weight, normalmap's \
     normalmap and bumpmap's height texture";

/// Property tags: the children of a plugin that are its parameters.
const PROPERTY_TAGS: [&str; 10] =
    ["float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector", "transform", "texture"];

/// A plugin's parameters, each marked when read, so that one pir does not read is an error
/// rather than a silently different image.
struct Params<'a> {
    e: &'a Element,
    used: RefCell<Vec<bool>>,
    /// The parameters given as textures that the caller took ([`Params::textured`]), with
    /// their means: what [`Params::colour`] and [`Params::float`] answer for them.
    means: RefCell<Vec<(String, Vec3)>>,
}

impl<'a> Params<'a> {
    fn new(e: &'a Element) -> Self {
        Params { e, used: RefCell::new(vec![false; e.children.len()]), means: RefCell::default() }
    }

    /// The mean of a parameter taken as a texture by [`Params::textured`].
    fn mean(&self, name: &str) -> Option<Vec3> {
        self.means.borrow().iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }

    /// A parameter that may be a texture, for the material's `slot`: `None` when it is absent
    /// or a colour (read later as a colour), else the texture, whose values must lie in
    /// `[lo, hi]`; its mean is what [`Params::colour`] and [`Params::float`] give from then on
    /// (a number parameter's: the mean's luminance).
    fn textured(
        &self,
        b: &Builder<'a>,
        name: &str,
        slot: Slot,
        (lo, hi): (f32, f32),
    ) -> Result<Option<(Slot, Texture)>, SceneError> {
        let t = match self.texture(b, name)? {
            None | Some(Texture::Constant(_)) => return Ok(None),
            Some(t) => t,
        };
        texture_within(self.e, name, &t, (lo, hi), "")?;
        self.means.borrow_mut().push((name.to_string(), slot.mean_value(t.mean())));
        Ok(Some((slot, t)))
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
        if let Some(mean) = self.mean(name) {
            return Ok(Some(mean.x));
        }
        let Some(p) = self.get(name) else { return Ok(None) };
        if p.tag == "texture" {
            return self.colour(name).map(|c| c.map(|c| c.x));
        }
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
        if let Some(mean) = self.mean(name) {
            return Ok(Some(mean));
        }
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
                "parameter \"{name}\" of {}: a texture (type \"{}\") is not supported here yet: pir reads \
                 textures on {TEXTURED_PARAMETERS}; give a colour (<rgb>)",
                self.e.describe(),
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

    /// The integrator's `max_depth` and `rr_depth`.
    fn integrator(&mut self, e: &'a Element) -> Result<(u32, u32), SceneError> {
        let p = Params::new(e);
        match e.type_name() {
            "path" | "volpath" => {}
            // Direct light: the emitters seen and their light reflected once, which is the
            // path integrator's image at max_depth 2 (its sample counts of the emitters and
            // of the BSDF change the noise, not the image).
            "direct" => {
                p.ignore(&["emitter_samples", "bsdf_samples", "shading_samples"]);
                if p.boolean("hide_emitters")? == Some(true) {
                    return Err(e.error("hide_emitters: pir always shows the emitters a camera ray hits"));
                }
                p.finish(self)?;
                return Ok((2, DEFAULT_RR_DEPTH));
            }
            other => {
                return Err(e.error(format!(
                    "integrator type \"{other}\" is not supported: pir renders Mitsuba's path integrator (path, \
                     volpath without media) and direct (as path with max_depth 2), with any of its methods (--method)"
                )));
            }
        }
        let max_depth = match p.integer("max_depth")? {
            None | Some(-1) => MAX_DEPTH,
            Some(d) if (1..=MAX_DEPTH as i64).contains(&d) => d as u32,
            Some(d) if d > MAX_DEPTH as i64 => MAX_DEPTH,
            Some(d) => return Err(e.error(format!("max_depth {d}: must be -1 (unbounded) or at least 1"))),
        };
        // Beyond the deepest path, no roulette: the same as the deepest.
        let rr_depth = match p.integer("rr_depth")? {
            None => DEFAULT_RR_DEPTH,
            Some(d) if d >= 1 => d.min(MAX_DEPTH as i64) as u32,
            Some(d) => return Err(e.error(format!("rr_depth {d}: must be at least 1"))),
        };
        if p.boolean("hide_emitters")? == Some(true) {
            return Err(e.error("hide_emitters: pir always shows the emitters a camera ray hits"));
        }
        p.finish(self)?;
        Ok((max_depth, rr_depth))
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

    /// An `instance`: the shapes of the `shapegroup` it refers to, each with the instance's
    /// `to_world` to apply after its own (pir copies them: an instance costs what its shapes
    /// cost). Mitsuba's groups hold shapes only, and no group or instance inside.
    fn instance(&self, e: &'a Element) -> Result<Vec<(&'a Element, Mat4)>, SceneError> {
        let p = Params::new(e);
        let to_world = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let groups = p.plugins(self, "shape")?;
        p.finish(self)?;
        let group = match groups.as_slice() {
            [g] if g.type_name() == "shapegroup" => *g,
            _ => return Err(e.error("an instance must refer to one shapegroup (<ref id=\"…\"/>)")),
        };
        let g = Params::new(group);
        let shapes = g.plugins(self, "shape")?;
        g.finish(self)?;
        if let Some(s) = shapes.iter().find(|s| matches!(s.type_name(), "shapegroup" | "instance")) {
            return Err(s.error("a shapegroup holds plain shapes, not groups or instances"));
        }
        Ok(shapes.into_iter().map(|s| (s, to_world)).collect())
    }

    /// A shape's world-space triangles and its material (shapes are read in parallel), and
    /// for an emitting sphere the exact sphere they are inscribed in; `outer` is the transform
    /// of the instance that places it (the identity for a shape of the scene).
    fn shape(&self, e: &'a Element, outer: Mat4) -> Result<Shape, SceneError> {
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
                    "shape type \"{other}\" is not supported: pir reads obj, ply, serialized, rectangle, cube, disk, sphere, shapegroup and instance"
                )));
            }
        };
        let mut mesh = mesh;
        if p.boolean("face_normals")? == Some(true) {
            mesh.face_normals = true;
        }
        let flip = p.boolean("flip_normals")?.unwrap_or(false);
        let to_world = outer * p.transform("to_world")?.unwrap_or(Mat4::IDENTITY) * placement;
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
        let (emission, textures) = match emitters.as_slice() {
            [] => (Vec3::ZERO, textures),
            [em] => match self.area_emitter(em)? {
                (radiance, None) => (radiance, textures),
                // A textured radiance: one more slot, read by `Material::emission_at`.
                (mean, Some(t)) => (mean, merge(textures, Some(Textured::new(vec![(Slot::Emission, t)])))),
            },
            _ => return Err(e.error("more than one emitter")),
        };
        let name =
            e.attr("id").or_else(|| bsdfs.first().and_then(|b| b.attr("id"))).unwrap_or("shape").to_string();
        let mut mesh = shapes::to_world(mesh, to_world, flip, kind);
        let sphere = if e.type_name() == "sphere" && emission.max_element() > 0.0 {
            shapes::exact_sphere(&mesh, to_world)
        } else {
            None
        };
        // Texture coordinates are kept only where a texture reads them; a textured mesh
        // without them gets Mitsuba's barycentric ones (meshes are never analytic shapes, so
        // only `flip_normals` swaps their winding).
        if textures.is_none() {
            mesh.uvs = Vec::new();
        } else if mesh.uvs.is_empty() {
            mesh = shapes::barycentric_uvs(mesh, flip);
        }
        // Analytic where Mitsuba's sphere is a sphere (a similarity placement that does not
        // mirror it) and no normal or bump map needs the tessellation's tangents.
        let analytic = (e.type_name() == "sphere" && textures.as_ref().is_none_or(|t| t.map.is_none()))
            .then(|| shapes::analytic_sphere(to_world, flip))
            .flatten();
        let textures = textures.map(std::sync::Arc::new);
        let material = Material { name, bsdf, emission, two_sided, textures };
        Ok(Shape { mesh, material, exact: sphere, analytic })
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

    /// [`Builder::add`], and where the mesh tessellates an exact sphere (`exact`: its centre
    /// and radius), its triangles as one sphere light for next-event estimation by its cone.
    fn add_tessellated(
        &mut self,
        m: WorldMesh,
        material: u32,
        exact: Option<(Vec3, f32)>,
        spheres: &mut Vec<SphereLight>,
    ) {
        let start = self.geometry.indices.len() as u32;
        self.add(m, material);
        let end = self.geometry.indices.len() as u32;
        if let Some((center, radius)) = exact
            && end > start
        {
            spheres.push(SphereLight { center, radius, prims: start..end });
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
                        let (bsdf, _, mut textures) = self.bsdf(b)?;
                        // Mitsuba's twosided mirrors the directions in the unperturbed frame.
                        if let Some(map) = textures.as_mut().and_then(|t| t.map.as_mut()) {
                            map.back = BackSide::Mirrored;
                        }
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
            "dielectric" => {
                let slots = self.textured_slots(&p, &[SPECULAR, TRANSMITTANCE])?;
                (bsdfs::dielectric(&p)?, false, slots)
            }
            "thindielectric" => {
                let slots = self.textured_slots(&p, &[SPECULAR, TRANSMITTANCE])?;
                (bsdfs::thin_dielectric(&p)?, false, slots)
            }
            "roughdielectric" => {
                let alpha = ("alpha", Slot::Alpha, (0.0, super::format::MAX_ROUGHNESS));
                let slots = self.textured_slots(&p, &[SPECULAR, TRANSMITTANCE, alpha])?;
                (bsdfs::rough_dielectric(e, &p)?, false, slots)
            }
            "conductor" => {
                let slots = self.textured_slots(&p, &[SPECULAR, ETA, K])?;
                (bsdfs::conductor(e, &p, textured_ior(&slots))?, false, slots)
            }
            "roughconductor" => {
                let alpha = ("alpha", Slot::Alpha, (0.0, super::format::MAX_ROUGHNESS));
                let slots = self.textured_slots(&p, &[SPECULAR, alpha, ETA, K])?;
                (bsdfs::rough_conductor(e, &p, textured_ior(&slots))?, false, slots)
            }
            "plastic" | "roughplastic" => {
                let (diffuse, slots) = self.reflectance_texture(e, &p, "diffuse_reflectance")?;
                let slots = merge(slots, self.textured_slots(&p, &[SPECULAR])?);
                (bsdfs::plastic(e, &p, diffuse, e.type_name() == "roughplastic")?, false, slots)
            }
            "mask" => {
                let inner = p.plugins(self, "bsdf")?;
                let [b] = inner.as_slice() else { return Err(e.error("needs one nested bsdf")) };
                let (inner, two_sided, mut slots) = self.bsdf(b)?;
                let opacity_slot = self.textured_slots(&p, &[("opacity", Slot::Opacity, (0.0, 1.0))])?;
                let opacity = bsdfs::opacity(e, &p)?;
                if let Bsdf::Diffuse { albedo } = inner {
                    (Bsdf::Mask { opacity, albedo }, two_sided, merge(slots, opacity_slot))
                } else {
                    // A normal or bump map of the nested BSDF is the whole mask's: the null
                    // interaction does not depend on the frame.
                    let map = slots.as_mut().and_then(|t| t.map.take());
                    let part = part(inner, slots);
                    let textured = part.textures.is_some();
                    let parts = Composite::Mask(part).intern();
                    let bsdf = Bsdf::Composite { weight: opacity, parts, uv: None };
                    (bsdf, two_sided, composite_slots(opacity_slot, textured, map))
                }
            }
            "normalmap" | "bumpmap" => {
                let inner = p.plugins(self, "bsdf")?;
                let [b] = inner.as_slice() else { return Err(e.error("needs one nested bsdf")) };
                let (bsdf, two_sided, slots) = self.bsdf(b)?;
                if slots.as_ref().is_some_and(|t| t.map.is_some()) {
                    return Err(b.error("a normalmap or bumpmap inside another is not supported"));
                }
                let map = ShadingMap { perturbation: self.perturbation(e, &p)?, back: BackSide::TurnedOver };
                let mut slots = slots.unwrap_or_else(|| Textured::new(Vec::new()));
                slots.map = Some(map);
                (bsdf, two_sided, Some(slots))
            }
            "blendbsdf" => {
                let weight_slot = self.textured_slots(&p, &[("weight", Slot::Weight, (0.0, 1.0))])?;
                let w = p.float("weight")?.ok_or_else(|| e.error("needs a weight"))?;
                if !(0.0..=1.0).contains(&w) {
                    return Err(e.error(format!("weight {w}: must lie between 0 and 1")));
                }
                let inner = p.plugins(self, "bsdf")?;
                let [a, b] = inner.as_slice() else { return Err(e.error("needs two nested bsdfs")) };
                let (a_bsdf, a_two_sided, a_slots) = self.bsdf(a)?;
                let (b_bsdf, b_two_sided, b_slots) = self.bsdf(b)?;
                if a_two_sided != b_two_sided {
                    return Err(e.error(
                        "a blend of a twosided BSDF and a one-sided one is not supported: make both twosided or \
                         neither",
                    ));
                }
                for (nested, slots) in [(a, &a_slots), (b, &b_slots)] {
                    if slots.as_ref().is_some_and(|t| t.map.is_some()) {
                        return Err(nested.error(
                            "a normalmap or bumpmap inside a blendbsdf is not supported: put it around the blendbsdf",
                        ));
                    }
                }
                // A constant blend of a diffuse and a GGX rough mirror is pir's glossy material,
                // albedo (1 − w) ρ and specular w s (or the other way round).
                let constant =
                    weight_slot.is_none() && a_slots.is_none() && b_slots.is_none() && !a_two_sided;
                let glossy = match (a_bsdf, b_bsdf) {
                    (Bsdf::Diffuse { albedo }, Bsdf::Glossy { albedo: none, specular, roughness })
                        if constant && none == Vec3::ZERO =>
                    {
                        Some(Bsdf::Glossy { albedo: albedo * (1.0 - w), specular: specular * w, roughness })
                    }
                    (Bsdf::Glossy { albedo: none, specular, roughness }, Bsdf::Diffuse { albedo })
                        if constant && none == Vec3::ZERO =>
                    {
                        Some(Bsdf::Glossy { albedo: albedo * w, specular: specular * (1.0 - w), roughness })
                    }
                    _ => None,
                };
                match glossy {
                    Some(bsdf) => (bsdf, false, None),
                    None => {
                        let parts = [part(a_bsdf, a_slots), part(b_bsdf, b_slots)];
                        let textured = parts.iter().any(|p| p.textures.is_some());
                        let bsdf =
                            Bsdf::Composite { weight: w, parts: Composite::Blend(parts).intern(), uv: None };
                        (bsdf, a_two_sided, composite_slots(weight_slot, textured, None))
                    }
                }
            }
            other => {
                return Err(e.error(format!(
                    "bsdf type \"{other}\" is not supported yet: pir reads diffuse, plastic, roughplastic, conductor, \
                     roughconductor, dielectric, thindielectric, roughdielectric, mask, twosided, normalmap, bumpmap \
                     and blendbsdf"
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
        let slots = |t| Some(Textured::new(vec![(Slot::Reflectance, t)]));
        match p.texture(self, name)? {
            Some(Texture::Constant(v)) => {
                reflectance(e, name, v)?;
                Ok((v, None))
            }
            Some(t) => {
                texture_within(e, name, &t, (0.0, 1.0), CREATES_ENERGY)?;
                Ok((t.mean(), slots(t)))
            }
            None => Ok((Vec3::splat(0.5), None)),
        }
    }

    /// The parameters `(name, slot, bounds)` of `p` that are textures, as a material's
    /// textures (`None` when none is); the others are read later as colours or numbers, and
    /// the textured ones as their means ([`Params::textured`]).
    fn textured_slots(
        &self,
        p: &Params<'a>,
        parameters: &[(&str, Slot, (f32, f32))],
    ) -> Result<Option<Slots>, SceneError> {
        let mut slots = Vec::new();
        for &(name, slot, bounds) in parameters {
            slots.extend(p.textured(self, name, slot, bounds)?);
        }
        Ok((!slots.is_empty()).then(|| Textured::new(slots)))
    }

    /// A `normalmap`'s or `bumpmap`'s texture and how it perturbs the frame
    /// ([`crate::material::shading_map`]), with a warning where Mitsuba's viewer-dependent
    /// corrections are on (pir renders them off).
    fn perturbation(&self, e: &'a Element, p: &Params<'a>) -> Result<Perturbation, SceneError> {
        let perturbation = if e.type_name() == "normalmap" {
            let t =
                p.texture(self, "normalmap")?.ok_or_else(|| e.error("needs a texture named normalmap"))?;
            match &t {
                Texture::Bitmap(b) if b.channels() == 3 && b.is_raw() => {}
                Texture::Bitmap(b) if b.channels() == 3 => {
                    return Err(e.error(
                        "normalmap: the bitmap must be raw (<boolean name=\"raw\" value=\"true\"/>): it holds \
                         normals, not sRGB colours",
                    ));
                }
                _ => return Err(e.error("normalmap: must be an RGB bitmap texture (of raw normals)")),
            }
            Perturbation::Normal(t)
        } else {
            let textures = p.plugins(self, "texture")?;
            let [t] = textures.as_slice() else {
                return Err(e.error("needs one nested texture (the height)"));
            };
            let height = self.texture(t)?;
            if !matches!(height, Texture::Bitmap(_)) {
                return Err(
                    t.error("a bumpmap's height must be a bitmap (Mitsuba has no gradient of others)")
                );
            }
            let scale = p.float("scale")?.unwrap_or(1.0);
            Perturbation::Bump { height, scale }
        };
        let flip = p.boolean("flip_invalid_normals")?.unwrap_or(true);
        let shadowing = p.boolean("use_shadowing_function")?.unwrap_or(true);
        if flip || shadowing {
            self.late_warnings.lock().unwrap_or_else(|e| e.into_inner()).push(format!(
                "{}: line {}: {}: rendered with flip_invalid_normals and use_shadowing_function off (Mitsuba's \
                 defaults are on; set both false to render as Mitsuba does)",
                e.file.display(),
                e.line,
                e.describe()
            ));
        }
        Ok(perturbation)
    }

    /// An area emitter's radiance.
    /// (A colour, or a texture's mean with the texture: Mitsuba accepts any texture there.)
    fn area_emitter(&self, e: &'a Element) -> Result<(Vec3, Option<Texture>), SceneError> {
        let p = Params::new(e);
        if e.type_name() != "area" {
            return Err(e.error(format!(
                "emitter type \"{}\" on a shape: only area emitters can be attached to shapes",
                e.type_name()
            )));
        }
        let texture = p.texture(self, "radiance")?.ok_or_else(|| e.error("needs a radiance"))?;
        p.finish(self)?;
        match texture {
            Texture::Constant(radiance) if radiance.min_element() < 0.0 => {
                Err(e.error(format!("radiance {radiance}: must not be negative")))
            }
            Texture::Constant(radiance) => Ok((radiance, None)),
            t => {
                texture_within(e, "radiance", &t, (0.0, f32::MAX), "")?;
                Ok((t.mean(), Some(t)))
            }
        }
    }
}

/// A specular reflectance that may be a texture ([`Builder::textured_slots`]).
const SPECULAR: (&str, Slot, (f32, f32)) = ("specular_reflectance", Slot::Specular, (0.0, 1.0));

/// A dielectric's specular transmittance that may be a texture.
const TRANSMITTANCE: (&str, Slot, (f32, f32)) = ("specular_transmittance", Slot::Transmittance, (0.0, 1.0));

/// A conductor's η and k, which may be textures; Mitsuba reads them unbounded (finite here).
const ETA: (&str, Slot, (f32, f32)) = ("eta", Slot::Eta, (f32::MIN, f32::MAX));
const K: (&str, Slot, (f32, f32)) = ("k", Slot::K, (f32::MIN, f32::MAX));

/// Whether a conductor's η or k is a texture (then it is no perfect mirror, whatever their
/// means).
fn textured_ior(slots: &Option<Slots>) -> bool {
    slots.as_ref().is_some_and(|t| t.get(Slot::Eta).is_some() || t.get(Slot::K).is_some())
}

/// A nested BSDF of a blend or mask, with its textures.
fn part(bsdf: Bsdf, slots: Option<Slots>) -> Part {
    Part { bsdf, textures: slots.map(std::sync::Arc::new) }
}

/// A composite's own textured slots (its weight's), and its map; present, if empty, where only
/// a part is textured, so that the shape keeps its texture coordinates and
/// [`Material::bsdf_at`] resolves the parts there.
fn composite_slots(own: Option<Slots>, parts_textured: bool, map: Option<ShadingMap>) -> Option<Slots> {
    if own.is_none() && !parts_textured && map.is_none() {
        return None;
    }
    let mut slots = own.unwrap_or_else(|| Textured::new(Vec::new()));
    slots.map = map;
    Some(slots)
}

/// Two sets of textured slots as one (the second's map, if any, is dropped: callers give none).
fn merge(a: Option<Slots>, b: Option<Slots>) -> Option<Slots> {
    match (a, b) {
        (Some(mut a), Some(b)) => {
            a.slots.extend(b.slots);
            Some(a)
        }
        (a, b) => a.or(b),
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

/// Why a reflectance above 1 is refused.
const CREATES_ENERGY: &str = " (above 1 the material creates energy; Mitsuba refuses it too)";

/// A reflectance must lie in [0, 1] in every channel.
fn reflectance(e: &Element, name: &str, v: Vec3) -> Result<(), SceneError> {
    if v.min_element() < 0.0 || v.max_element() > 1.0 {
        return Err(e.error(format!(
            "{name} {} {} {}: must lie between 0 and 1 in every channel{CREATES_ENERGY}",
            v.x, v.y, v.z
        )));
    }
    Ok(())
}

/// The texture `name`'s values (every texel, every channel) must be finite and lie in
/// [`lo`, `hi`] (`hi` = `f32::MAX`: not bounded above); `why` is added to the error.
fn texture_within(
    e: &Element,
    name: &str,
    t: &Texture,
    (lo, hi): (f32, f32),
    why: &str,
) -> Result<(), SceneError> {
    let (min, max) = t.range();
    if min >= lo && max <= hi && min.is_finite() && max.is_finite() {
        return Ok(());
    }
    let bounds = match hi {
        f32::MAX if lo == 0.0 => "be finite and not negative".to_string(),
        f32::MAX => format!("be finite and at least {lo}"),
        _ => format!("lie between {lo} and {hi}"),
    };
    Err(e.error(format!("{name}: the texture's values span {min} to {max}; they must {bounds}{why}")))
}
