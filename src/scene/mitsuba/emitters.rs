//! Mitsuba 3's emitters that are not attached to shapes: `point`, `spot`, `directional`,
//! `constant` and `envmap` (OpenEXR or Radiance HDR images), into pir's lights ([`crate::light::Light`]) with
//! Mitsuba's parameters, defaults and units (intensity W/sr, irradiance W/m², radiance).

use std::path::Path;

use glam::{Mat3, Mat4, Vec3};

use super::xml::Element;
use super::{Builder, Params};
use crate::light::Light;
use crate::light::constant::ConstantLight;
use crate::light::directional::DirectionalLight;
use crate::light::envmap::Envmap;
use crate::light::point::PointLight;
use crate::light::spot::SpotLight;
use crate::scene::SceneError;

impl<'a> Builder<'a> {
    /// A top-level `<emitter>`.
    pub(super) fn light(&self, e: &'a Element) -> Result<Light, SceneError> {
        let p = Params::new(e);
        let light = match e.type_name() {
            "point" => {
                let position = match (p.point("position")?, p.transform("to_world")?) {
                    (Some(_), Some(_)) => return Err(e.error("give either position or to_world, not both")),
                    (Some(x), None) => x,
                    (None, Some(m)) => m.w_axis.truncate(),
                    (None, None) => Vec3::ZERO,
                };
                Light::Point(PointLight { position, intensity: colour(e, &p, "intensity")? })
            }
            "spot" => {
                let intensity = colour(e, &p, "intensity")?;
                let cutoff = p.float("cutoff_angle")?.unwrap_or(20.0);
                let beam = p.float("beam_width")?.unwrap_or(cutoff * 3.0 / 4.0);
                if !(cutoff > 0.0 && cutoff <= 180.0) {
                    return Err(e.error(format!("cutoff_angle {cutoff}: must lie in (0, 180] degrees")));
                }
                if !(0.0..cutoff).contains(&beam) {
                    return Err(e.error(format!(
                        "beam_width {beam}: must lie in [0, cutoff_angle {cutoff}) degrees"
                    )));
                }
                let to_world = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
                rigid(e, "a spot light's", to_world)?;
                Light::Spot(SpotLight::new(to_world, intensity, cutoff, beam))
            }
            "directional" => {
                let direction = match (p.point("direction")?, p.transform("to_world")?) {
                    (Some(_), Some(_)) => return Err(e.error("give either direction or to_world, not both")),
                    (Some(d), None) => d,
                    (None, Some(m)) => Mat3::from_mat4(m) * Vec3::Z,
                    (None, None) => Vec3::Z,
                };
                let direction = direction.normalize();
                if !direction.is_finite() {
                    return Err(e.error("the direction is zero"));
                }
                Light::Directional(DirectionalLight { direction, irradiance: colour(e, &p, "irradiance")? })
            }
            "constant" => Light::Constant(ConstantLight { radiance: colour(e, &p, "radiance")? }),
            "envmap" => {
                let name = p.string("filename")?.ok_or_else(|| e.error("needs a filename"))?;
                let path = e.file.parent().unwrap_or(Path::new("")).join(name);
                let scale = p.float("scale")?.unwrap_or(1.0);
                let to_world = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
                // Changes how Mitsuba samples the map, not the image.
                p.ignore(&["mis_compensation"]);
                rigid(e, "an environment map's", to_world)?;
                // Any image pir reads as a texture, linear (sRGB-encoded ones converted, as
                // Mitsuba's envmap does).
                let mut texels = crate::image::read_texels(&path).map_err(|err| e.error(err))?;
                texels.linearize();
                let image = texels.to_rgb();
                let map = Envmap::new(image.width, image.height, &image.pixels, scale, to_world)
                    .map_err(|problem| e.error(format!("{}: {problem}", path.display())))?;
                Light::Envmap(Box::new(map))
            }
            "area" => return Err(e.error("an area emitter must be attached to a shape")),
            other => {
                return Err(e.error(format!(
                    "emitter type \"{other}\" is not supported: pir reads area (on shapes), point, spot, \
                     directional, constant and envmap"
                )));
            }
        };
        p.finish(self)?;
        Ok(light)
    }
}

/// A non-negative colour parameter, Mitsuba's default 1.
fn colour(e: &Element, p: &Params, name: &str) -> Result<Vec3, SceneError> {
    let v = p.colour(name)?.unwrap_or(Vec3::ONE);
    if v.min_element() < 0.0 {
        return Err(e.error(format!("{name} {v}: must not be negative")));
    }
    Ok(v)
}

/// A transform whose linear part is a rotation: what pir's sampling of a spot light's cone
/// and an environment map's directions assume.
fn rigid(e: &Element, whose: &str, m: Mat4) -> Result<(), SceneError> {
    let l = Mat3::from_mat4(m);
    if !(l.transpose() * l).abs_diff_eq(Mat3::IDENTITY, 1e-3) || l.determinant() < 0.0 {
        return Err(e.error(format!(
            "to_world: {whose} transform must be a rotation and translation (no scale, shear or mirror)"
        )));
    }
    Ok(())
}
