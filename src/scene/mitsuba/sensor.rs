//! The sensor: Mitsuba 3's `perspective` and `thinlens` cameras as pir's [`Camera`], read as
//! Mitsuba's `ProjectiveCamera`, `parse_fov` and the two plugins read them
//! (`src/render/sensor.cpp`, `src/sensors/perspective.cpp`, `src/sensors/thinlens.cpp`):
//!
//! - the field of view: `fov` in degrees along `fov_axis` (`x`, the default, `y`, `diagonal`,
//!   `smaller`, `larger`, in any case), or else `focal_length` (a string, `"50mm"` by
//!   default: the diagonal field of view of a 36 × 24 mm film), never both;
//! - `perspective`: `principal_point_offset_x` and `_y`, fractions of the film's size by
//!   which every film position is shifted;
//! - `near_clip` (0.01) and `far_clip` (10⁴): camera rays see the surfaces between the two
//!   planes orthogonal to the view axis;
//! - `to_world` without scale or shear (Mitsuba refuses both), nor a mirror (pir's right is
//!   forward × up);
//! - `thinlens`: `aperture_radius` (required; 0 is a pinhole, as Mitsuba's stand-in radius of
//!   one float ε renders) and `focus_distance` (default `far_clip`), positive.
//!
//! `shutter_open` and `shutter_close` change nothing (pir's scenes do not move), nor does a
//! `perspective` camera's `focus_distance`; the film's crop window is refused.

use glam::{Mat4, Vec2, Vec3};

use super::{Builder, Params};
use crate::scene::{Camera, FovAxis, SceneError, ThinLens};

/// Mitsuba's default field of view: a 50 mm lens on 35 mm film.
const DEFAULT_FOCAL_LENGTH: &str = "50mm";

impl<'a> Builder<'a> {
    /// The perspective or thin-lens sensor as pir's camera.
    pub(super) fn sensor(&mut self, e: &'a super::Element) -> Result<Camera, SceneError> {
        let p = Params::new(e);
        let thin_lens = match e.type_name() {
            "perspective" => false,
            "thinlens" => true,
            other => {
                return Err(e.error(format!(
                    "sensor type \"{other}\" is not supported: pir renders perspective and thinlens cameras"
                )));
            }
        };
        let films = p.plugins(self, "film")?;
        let (width, height) = match films.as_slice() {
            [] => (768, 576),
            [film] => self.film(film)?,
            _ => return Err(e.error("more than one film")),
        };
        let (x_fov, fov_axis) = horizontal_fov(e, &p, width as f64 / height as f64)?;
        let m = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let near_clip = p.float("near_clip")?.unwrap_or(1e-2);
        let far_clip = p.float("far_clip")?.unwrap_or(1e4);
        if near_clip <= 0.0 {
            return Err(e.error(format!("near_clip {near_clip}: must be greater than zero")));
        }
        if near_clip >= far_clip {
            return Err(e.error(format!("near_clip {near_clip}: must be smaller than far_clip {far_clip}")));
        }
        let focus_distance = p.float("focus_distance")?.unwrap_or(far_clip);
        let lens = if thin_lens {
            let aperture_radius = p
                .float("aperture_radius")?
                .ok_or_else(|| e.error("needs an aperture_radius (scene units)"))?;
            if focus_distance <= 0.0 {
                return Err(e.error(format!("focus_distance {focus_distance}: must be positive")));
            }
            (aperture_radius != 0.0).then_some(ThinLens { aperture_radius, focus_distance })
        } else {
            None
        };
        // (A thin lens has none: Mitsuba refuses the parameters there, as `finish` does.)
        let principal_point_offset = if thin_lens {
            Vec2::ZERO
        } else {
            Vec2::new(
                p.float("principal_point_offset_x")?.unwrap_or(0.0),
                p.float("principal_point_offset_y")?.unwrap_or(0.0),
            )
        };
        p.ignore(&["shutter_open", "shutter_close"]);
        p.plugins(self, "sampler")?;
        p.finish(self)?;

        // Mitsuba's `has_scale`: the rows of the linear part must be orthonormal within 1e-3.
        let rows = [m.row(0).truncate(), m.row(1).truncate(), m.row(2).truncate()];
        for i in 0..3 {
            for j in i..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                if (rows[i].dot(rows[j]) - want).abs() > 1e-3 {
                    return Err(e.error(
                        "to_world scales or shears the camera: Mitsuba allows neither (a camera's transform \
                         is a rotation and a translation)",
                    ));
                }
            }
        }
        let eye = m.transform_point3(Vec3::ZERO);
        let (forward, up, left) = (
            m.transform_vector3(Vec3::Z).normalize(),
            m.transform_vector3(Vec3::Y).normalize(),
            m.transform_vector3(Vec3::X).normalize(),
        );
        if up.cross(forward).dot(left) < 0.0 {
            return Err(e.error(
                "to_world mirrors the image (e.g. a negative scale): not supported, a pir camera's right is forward × up",
            ));
        }
        // pir's field of view is vertical.
        let tan_v = (x_fov.to_radians() / 2.0).tan() * height as f64 / width as f64;
        Ok(Camera {
            eye,
            target: eye + forward,
            up,
            fov_deg: (2.0 * tan_v.atan().to_degrees()) as f32,
            width,
            height,
            near_clip,
            far_clip,
            lens,
            principal_point_offset,
            fov_axis,
        })
    }
}

/// The horizontal field of view in degrees of a film of aspect `aspect` (width / height), as
/// Mitsuba's `parse_fov` computes it (in double precision) from `fov` and `fov_axis` or from
/// `focal_length`, and the axis that the field of view is given along (to be kept there at
/// another resolution).
fn horizontal_fov(e: &super::Element, p: &Params, aspect: f64) -> Result<(f64, FovAxis), SceneError> {
    let (fov, axis, kept) = match p.float("fov")? {
        Some(fov) => {
            if p.get("focal_length").is_some() {
                return Err(e.error("give either a fov or a focal_length, not both"));
            }
            let axis = p.string("fov_axis")?.unwrap_or("x").trim().to_lowercase();
            let kept = match axis.as_str() {
                "x" => FovAxis::X,
                "y" => FovAxis::Y,
                "diagonal" => FovAxis::Diagonal,
                "smaller" => FovAxis::Smaller,
                "larger" => FovAxis::Larger,
                other => {
                    return Err(
                        e.error(format!("fov_axis \"{other}\": expected x, y, diagonal, smaller or larger"))
                    );
                }
            };
            let axis = match axis.as_str() {
                "smaller" if aspect > 1.0 => "y".to_string(),
                "smaller" => "x".to_string(),
                "larger" if aspect > 1.0 => "x".to_string(),
                "larger" => "y".to_string(),
                _ => axis,
            };
            (fov as f64, axis, kept)
        }
        None => {
            if p.get("fov_axis").is_some() {
                return Err(e.error("fov_axis applies to a fov; Mitsuba refuses it with a focal_length"));
            }
            let text = match p.get("focal_length") {
                None => DEFAULT_FOCAL_LENGTH,
                Some(f) if f.tag == "string" => p.value(f)?,
                Some(f) => {
                    return Err(f.error(format!(
                        "focal_length: expected a <string> such as \"{DEFAULT_FOCAL_LENGTH}\" (Mitsuba reads \
                         no <{}>)",
                        f.tag
                    )));
                }
            };
            let number = text.trim().strip_suffix("mm").unwrap_or(text.trim());
            let f = match number.trim().parse::<f64>() {
                Ok(f) if f.is_finite() && f > 0.0 => f,
                _ => {
                    return Err(e.error(format!(
                        "focal_length \"{text}\": expected a positive length in millimetres, e.g. \"35mm\""
                    )));
                }
            };
            // The diagonal of 35 mm film, 36 × 24 mm.
            let fov = 2.0 * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * f)).atan().to_degrees();
            (fov, "diagonal".to_string(), FovAxis::Diagonal)
        }
    };
    let half_tan = (0.5 * fov.to_radians()).tan();
    let x_fov = match axis.as_str() {
        "x" => fov,
        "y" => 2.0 * (half_tan * aspect).atan().to_degrees(),
        "diagonal" => {
            let width = 2.0 * half_tan / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            2.0 * (width * 0.5).atan().to_degrees()
        }
        other => {
            return Err(e.error(format!("fov_axis \"{other}\": expected x, y, diagonal, smaller or larger")));
        }
    };
    if !(x_fov > 0.0 && x_fov < 180.0) {
        return Err(e.error(format!(
            "fov {fov} along {axis}: the horizontal field of view, {x_fov} degrees, must lie strictly between 0 \
             and 180"
        )));
    }
    Ok((x_fov, kept))
}

#[cfg(test)]
// Mitsuba's values as its Python bindings print them.
#[allow(clippy::excessive_precision)]
mod tests {
    use glam::{Vec2, Vec3};

    use crate::scene::{Camera, ThinLens};

    /// The camera of a scene whose sensor is `sensor` (its type and parameters) looking from
    /// (1, 2, 3) towards (0.5, 1.5, −2) with up (0.1, 1, 0), on a film of `width` × `height`.
    fn camera(sensor: &str, params: &str, width: u32, height: u32) -> Result<Camera, String> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.xml");
        let text = format!(
            r#"<scene version="3.0.0">
    <sensor type="{sensor}">
        {params}
        <transform name="to_world"><lookat origin="1, 2, 3" target="0.5, 1.5, -2" up="0.1, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/></film>
    </sensor>
    <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"#
        );
        std::fs::write(&path, text).unwrap();
        super::super::load(&path, &Default::default()).map(|(s, _)| *s.camera()).map_err(|e| e.to_string())
    }

    /// Mitsuba's ray (origin on the near plane, direction, `maxt` from there) against pir's.
    fn assert_ray(c: &Camera, film: Vec2, aperture: Vec2, origin: [f32; 3], dir: [f32; 3], maxt: f32) {
        let pixels = Vec2::new(c.width as f32, c.height as f32);
        let r = c.rays().generate_ray(film * pixels, aperture);
        let (o, d) = (Vec3::from(origin), Vec3::from(dir));
        assert!((r.at(r.tmin) - o).length() < 2e-6 * (1.0 + o.length()), "origin {} ≠ {o}", r.at(r.tmin));
        assert!((r.dir - d).length() < 1e-6, "direction {} ≠ {d}", r.dir);
        assert!(((r.tmax - r.tmin) - maxt).abs() < 1e-5 * maxt, "maxt {} ≠ {maxt}", r.tmax - r.tmin);
    }

    /// Rays of Mitsuba 3.9.1's `thinlens` (`sensor.sample_ray(0, 0.5, position, aperture)`,
    /// scalar_rgb, see `tests/data/README.md`), film position
    /// and aperture sample given: pir's lens point, direction and clip interval are Mitsuba's.
    #[test]
    fn thin_lens_rays_are_mitsubas() {
        let params = r#"<float name="fov" value="40"/><float name="aperture_radius" value="0.25"/>
            <float name="focus_distance" value="4"/><float name="near_clip" value="0.1"/>
            <float name="far_clip" value="50"/>"#;
        let c = camera("thinlens", params, 64, 48).unwrap();
        assert_eq!(c.lens, Some(ThinLens { aperture_radius: 0.25, focus_distance: 4.0 }));
        assert_eq!((c.near_clip, c.far_clip), (0.1, 50.0));
        #[rustfmt::skip]
        let cases = [
            ([0.3, 0.7], [0.2, 0.9], [1.0965422, 2.1305306, 2.8762977], [-0.27707765, -0.22524226, -0.93407387], 51.200073),
            ([0.95, 0.05], [0.5, 0.5], [1.0247573, 2.0111778, 2.8954115], [0.22910976, 0.10344172, -0.96788877], 53.921162),
            ([0.5, 0.5], [0.8, 0.1], [0.868251, 1.8402976, 2.9281502], [-0.06768728, -0.0605287, -0.99586886], 49.962334),
            ([0.1, 0.4], [0.05, 0.6], [1.1792433, 2.0146968, 2.879611], [-0.41394109, -0.01914592, -0.9101023], 52.85919),
            ([0.0, 1.0], [0.99, 0.3], [0.7201857, 1.9146162, 2.9355247], [-0.39475515, -0.29727095, -0.86936665], 53.695057),
        ];
        for (film, aperture, o, d, maxt) in cases {
            assert_ray(&c, Vec2::from(film), Vec2::from(aperture), o, d, maxt);
        }
    }

    /// `perspective`'s rays as Mitsuba's: from the eye, started on the near plane.
    #[test]
    fn perspective_rays_are_mitsubas() {
        let params = r#"<float name="fov" value="40"/><float name="near_clip" value="0.1"/><float name="far_clip" value="50"/>"#;
        let c = camera("perspective", params, 64, 48).unwrap();
        assert_eq!(c.lens, None);
        #[rustfmt::skip]
        let cases = [
            ([0.3, 0.7], [0.97469467, 1.9807299, 2.9034624], [-0.24896444, -0.18958634, -0.94977564], 50.719578),
            ([0.95, 0.05], [1.0247573, 2.0111778, 2.8954115], [0.22910973, 0.10344171, -0.96788877], 53.921162),
        ];
        for (film, o, d, maxt) in cases {
            // The aperture sample changes nothing.
            for aperture in [Vec2::ZERO, Vec2::new(0.9, 0.2)] {
                assert_ray(&c, Vec2::from(film), aperture, o, d, maxt);
            }
        }
    }

    /// `perspective`'s principal point offset as Mitsuba's: the rays of shifted film positions.
    #[test]
    fn principal_point_offsets_are_mitsubas() {
        let params = r#"<float name="fov" value="40"/><float name="principal_point_offset_x" value="0.1"/>
            <float name="principal_point_offset_y" value="-0.05"/>"#;
        let c = camera("perspective", params, 64, 48).unwrap();
        assert_eq!(c.principal_point_offset, Vec2::new(0.1, -0.05));
        #[rustfmt::skip]
        let cases = [
            ([0.3, 0.7], [0.99821526, 1.9982711, 2.9902518], [-0.17741005, -0.17185748, -0.96901536], 10059.839),
            ([0.95, 0.05], [1.0032215, 2.0013158, 2.9894466], [0.2899102, 0.11842085, -0.94969928], 11112.191),
        ];
        for (film, o, d, maxt) in cases {
            assert_ray(&c, Vec2::from(film), Vec2::ZERO, o, d, maxt);
        }
    }

    /// The horizontal field of view of every `fov_axis`, of a `focal_length` and of the
    /// default (50 mm) is Mitsuba 3.9.1's `x_fov` (`mi.traverse(sensor)['x_fov']`), on
    /// landscape, portrait and square films.
    #[test]
    fn fields_of_view_are_mitsubas() {
        #[rustfmt::skip]
        let cases: [(u32, u32, &str, f64); 21] = [
            (64, 48, r#"<float name="fov" value="40"/>"#, 40.0),
            (64, 48, r#"<float name="fov" value="40"/><string name="fov_axis" value="y"/>"#, 51.774009704589844),
            (64, 48, r#"<float name="fov" value="40"/><string name="fov_axis" value="diagonal"/>"#, 32.468605041503906),
            (64, 48, r#"<float name="fov" value="40"/><string name="fov_axis" value="smaller"/>"#, 51.774009704589844),
            (64, 48, r#"<float name="fov" value="40"/><string name="fov_axis" value="larger"/>"#, 40.0),
            (64, 48, r#"<string name="focal_length" value="35mm"/>"#, 52.62254333496094),
            (64, 48, "", 38.18484115600586),
            (48, 64, r#"<float name="fov" value="40"/>"#, 40.0),
            (48, 64, r#"<float name="fov" value="40"/><string name="fov_axis" value="y"/>"#, 30.536943435668945),
            (48, 64, r#"<float name="fov" value="40"/><string name="fov_axis" value="diagonal"/>"#, 24.637943267822266),
            (48, 64, r#"<float name="fov" value="40"/><string name="fov_axis" value="smaller"/>"#, 40.0),
            (48, 64, r#"<float name="fov" value="40"/><string name="fov_axis" value="larger"/>"#, 30.536943435668945),
            (48, 64, r#"<string name="focal_length" value="35mm"/>"#, 40.695274353027344),
            (48, 64, "", 29.10546112060547),
            (50, 50, r#"<float name="fov" value="40"/>"#, 40.0),
            (50, 50, r#"<float name="fov" value="40"/><string name="fov_axis" value="y"/>"#, 40.0),
            (50, 50, r#"<float name="fov" value="40"/><string name="fov_axis" value="diagonal"/>"#, 28.865510940551758),
            (50, 50, r#"<float name="fov" value="40"/><string name="fov_axis" value="smaller"/>"#, 40.0),
            (50, 50, r#"<float name="fov" value="40"/><string name="fov_axis" value="larger"/>"#, 40.0),
            (50, 50, r#"<string name="focal_length" value="35mm"/>"#, 47.21631622314453),
            (50, 50, "", 34.022056579589844),
        ];
        for (w, h, params, x_fov) in cases {
            for sensor in ["perspective", "thinlens"] {
                let lens =
                    if sensor == "thinlens" { r#"<float name="aperture_radius" value="0.1"/>"# } else { "" };
                let c = camera(sensor, &format!("{params}{lens}"), w, h).unwrap();
                // pir's vertical field of view, as the horizontal one of the film's aspect.
                let tan_x = (c.fov_deg as f64 / 2.0).to_radians().tan() * w as f64 / h as f64;
                let got = 2.0 * tan_x.atan().to_degrees();
                assert!((got - x_fov).abs() < 1e-4, "{w}×{h} {params}: {got} ≠ Mitsuba's {x_fov}");
            }
        }
        // The axis's name in any case, as Mitsuba lowercases it; a focal length without "mm".
        let upper = camera(
            "perspective",
            r#"<float name="fov" value="40"/><string name="fov_axis" value="Y"/>"#,
            64,
            48,
        );
        assert_eq!(
            upper,
            camera(
                "perspective",
                r#"<float name="fov" value="40"/><string name="fov_axis" value="y"/>"#,
                64,
                48
            )
        );
        let bare = camera("perspective", r#"<string name="focal_length" value="35"/>"#, 64, 48);
        assert_eq!(bare, camera("perspective", r#"<string name="focal_length" value="35mm"/>"#, 64, 48));
    }

    /// A film given another size (`--resolution`, Mitsuba's `resx` and `resy`) keeps the field
    /// of view along the sensor's axis, as Mitsuba does: the camera read at one size and
    /// resized is the camera read at the other, for every axis, a focal length, and square,
    /// landscape and portrait films both ways; the horizontal field of view of the default
    /// axis stays Mitsuba's.
    #[test]
    fn another_film_size_keeps_the_field_of_view_along_its_axis() {
        let sizes = [(1024, 1024), (320, 180), (48, 64), (64, 48)];
        for params in [
            r#"<float name="fov" value="35"/>"#,
            r#"<float name="fov" value="35"/><string name="fov_axis" value="y"/>"#,
            r#"<float name="fov" value="35"/><string name="fov_axis" value="diagonal"/>"#,
            r#"<float name="fov" value="35"/><string name="fov_axis" value="smaller"/>"#,
            r#"<float name="fov" value="35"/><string name="fov_axis" value="larger"/>"#,
            r#"<string name="focal_length" value="28mm"/>"#,
        ] {
            for (w0, h0) in sizes {
                for (w, h) in sizes {
                    let resized = camera("perspective", params, w0, h0).unwrap().with_resolution(w, h);
                    let direct = camera("perspective", params, w, h).unwrap();
                    assert!(
                        (resized.fov_deg - direct.fov_deg).abs() < 1e-4,
                        "{params} {w0}×{h0} → {w}×{h}: {} against {}",
                        resized.fov_deg,
                        direct.fov_deg
                    );
                    assert_eq!((resized.width, resized.height, resized.fov_axis), (w, h, direct.fov_axis));
                }
            }
        }
        // Bitterli's veach-bidir: a square film of fov 35 along x, rendered at 320×180.
        let c = camera("perspective", r#"<float name="fov" value="35"/>"#, 1024, 1024).unwrap();
        let c = c.with_resolution(320, 180);
        let x_fov = 2.0 * ((c.fov_deg as f64 / 2.0).to_radians().tan() * 320.0 / 180.0).atan().to_degrees();
        assert!((x_fov - 35.0).abs() < 1e-4, "{x_fov}");
    }

    /// What Mitsuba refuses, pir refuses, and what pir cannot render: each names the problem.
    #[test]
    fn what_the_sensor_cannot_be_is_refused() {
        let fov = r#"<float name="fov" value="40"/>"#;
        let lens = r#"<float name="aperture_radius" value="0.1"/>"#;
        for (sensor, params, expected) in [
            ("orthographic", fov.to_string(), "sensor type \"orthographic\""),
            ("perspective", format!("{fov}<string name=\"focal_length\" value=\"35mm\"/>"), "not both"),
            ("perspective", r#"<float name="focal_length" value="35"/>"#.into(), "<string>"),
            ("perspective", r#"<string name="focal_length" value="wide"/>"#.into(), "focal_length \"wide\""),
            (
                "perspective",
                r#"<string name="focal_length" value="35mm"/><string name="fov_axis" value="y"/>"#.into(),
                "fov_axis",
            ),
            ("perspective", format!("{fov}<string name=\"fov_axis\" value=\"z\"/>"), "fov_axis \"z\""),
            ("perspective", r#"<float name="fov" value="190"/>"#.into(), "between 0 and 180"),
            ("perspective", format!("{fov}<float name=\"near_clip\" value=\"0\"/>"), "greater than zero"),
            (
                "perspective",
                format!("{fov}<float name=\"near_clip\" value=\"5\"/><float name=\"far_clip\" value=\"2\"/>"),
                "smaller than far_clip",
            ),
            (
                "thinlens",
                format!("{fov}{lens}<float name=\"principal_point_offset_x\" value=\"0.1\"/>"),
                "principal_point_offset_x",
            ),
            ("thinlens", fov.to_string(), "aperture_radius"),
            (
                "thinlens",
                format!("{fov}{lens}<float name=\"focus_distance\" value=\"-1\"/>"),
                "focus_distance -1",
            ),
        ] {
            let err = camera(sensor, &params, 64, 48).unwrap_err();
            assert!(err.contains(expected) && err.contains("s.xml"), "{sensor} {params}: {err}");
        }
        // A scaled transform (Mitsuba: "Scale factors in the camera-to-world transformation
        // are not allowed!").
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scaled.xml");
        std::fs::write(
            &path,
            r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>
                <transform name="to_world"><scale value="2"/></transform></sensor>
                <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape></scene>"#,
        )
        .unwrap();
        let err = super::super::load(&path, &Default::default()).map(|_| ()).unwrap_err().to_string();
        assert!(err.contains("scales or shears"), "{err}");
        // A zero aperture is a pinhole (Mitsuba renders it through a radius of one float ε).
        let pinhole = camera(
            "thinlens",
            r#"<float name="fov" value="40"/><float name="aperture_radius" value="0"/>"#,
            64,
            48,
        );
        assert_eq!(pinhole.unwrap().lens, None);
    }
}
