//! Mitsuba 3's textures into [`Texture`]s: `bitmap` (`filename`, `filter_type`, `wrap_mode`,
//! `raw`, `to_uv`; `format` and `accel` change nothing pir renders) and `checkerboard`
//! (`color0`, `color1`, `to_uv`), inline or by `<ref>`; a colour given where a texture may be
//! (`<rgb>`, `<float>`, `<spectrum>`) is a constant one ([`Params::texture`]).
//!
//! Images are read once per file and `raw` flag however many textures and shapes use them,
//! while the shapes are read in parallel ([`ImageCache`]).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use glam::{Affine2, Vec3};

use super::xml::Element;
use super::{Builder, PROPERTY_TAGS, Params};
use crate::scene::SceneError;
use crate::texture::{Bitmap, Checkerboard, Filter, Image, Texture, Wrap, uv_transform};

/// The images read so far, by file and `raw` flag; each is read by the first shape that needs
/// it while others wait for it (and read other files meanwhile).
#[derive(Default)]
pub(super) struct ImageCache {
    images: Mutex<HashMap<(PathBuf, bool), Slot>>,
}

/// One image, read once.
type Slot = Arc<OnceLock<Loaded>>;

/// An image read (or why not).
type Loaded = Result<Arc<Image>, String>;

impl ImageCache {
    fn get(&self, path: &Path, raw: bool) -> Result<Arc<Image>, String> {
        let slot = {
            let mut images = self.images.lock().unwrap_or_else(|e| e.into_inner());
            images.entry((path.to_path_buf(), raw)).or_default().clone()
        };
        slot.get_or_init(|| crate::image::read_texels(path).map(|t| Arc::new(Image::new(t, raw)))).clone()
    }
}

impl<'a> Params<'a> {
    /// A parameter that may be a texture: a nested `<texture>`, a `<ref name=… id=…>` to one,
    /// or a colour (a constant texture).
    pub(super) fn texture(&self, b: &Builder<'a>, name: &str) -> Result<Option<Texture>, SceneError> {
        let children = &self.e.children;
        let named = |c: &Element| c.attr("name") == Some(name);
        if let Some(i) = children.iter().position(|c| c.tag == "ref" && named(c)) {
            self.used.borrow_mut()[i] = true;
            let t = b.resolve(&children[i])?;
            if t.tag != "texture" {
                return Err(children[i].error(format!("{name}: {} is not a texture", t.describe())));
            }
            return b.texture(t).map(Some);
        }
        match children.iter().position(|c| PROPERTY_TAGS.contains(&c.tag.as_str()) && named(c)) {
            Some(i) if children[i].tag == "texture" => {
                self.used.borrow_mut()[i] = true;
                b.texture(&children[i]).map(Some)
            }
            _ => Ok(self.colour(name)?.map(Texture::Constant)),
        }
    }
}

impl<'a> Builder<'a> {
    /// A `<texture>` plugin.
    pub(super) fn texture(&self, e: &'a Element) -> Result<Texture, SceneError> {
        let p = Params::new(e);
        let to_uv = p.transform("to_uv")?.map_or(Affine2::IDENTITY, uv_transform);
        let t = match e.type_name() {
            "bitmap" => {
                let name = p.string("filename")?.ok_or_else(|| e.error("needs a filename"))?;
                let path = e.file.parent().unwrap_or(Path::new("")).join(name);
                let filter = match p.string("filter_type")?.unwrap_or("bilinear") {
                    "bilinear" => Filter::Bilinear,
                    "nearest" => Filter::Nearest,
                    f => return Err(e.error(format!("filter_type \"{f}\": must be bilinear or nearest"))),
                };
                let wrap = match p.string("wrap_mode")?.unwrap_or("repeat") {
                    "repeat" => Wrap::Repeat,
                    "mirror" => Wrap::Mirror,
                    "clamp" => Wrap::Clamp,
                    w => return Err(e.error(format!("wrap_mode \"{w}\": must be repeat, mirror or clamp"))),
                };
                let raw = p.boolean("raw")?.unwrap_or(false);
                match p.string("format")?.unwrap_or("auto") {
                    "auto" | "variant" | "fp16" => {}
                    f => return Err(e.error(format!("format \"{f}\": must be auto, variant or fp16"))),
                }
                p.ignore(&["accel"]);
                p.finish(self)?;
                let image = self.images.get(&path, raw).map_err(|problem| e.error(problem))?;
                Texture::Bitmap(Arc::new(Bitmap::new(image, filter, wrap, to_uv)))
            }
            "checkerboard" => {
                let color0 = p.texture(self, "color0")?.unwrap_or(Texture::Constant(Vec3::splat(0.4)));
                let color1 = p.texture(self, "color1")?.unwrap_or(Texture::Constant(Vec3::splat(0.2)));
                p.finish(self)?;
                Texture::Checkerboard(Arc::new(Checkerboard { color0, color1, to_uv }))
            }
            other => {
                return Err(e.error(format!(
                    "texture type \"{other}\" is not supported: pir reads bitmap and checkerboard"
                )));
            }
        };
        Ok(t)
    }
}
