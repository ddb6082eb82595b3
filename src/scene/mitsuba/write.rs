//! A loaded scene written as a Mitsuba 3 scene file, so that Mitsuba can render any pir scene
//! (`pir convert`): the triangles of each material as a binary PLY beside the XML (world
//! space, with their shading normals where every vertex has one, else `face_normals`), the
//! analytic spheres as `sphere` shapes placed by a `to_world` matrix, the
//! camera as a `perspective` sensor (a `thinlens` one where it has a lens) with a `lookat`, the
//! field of view along its axis (vertical for the TOML format's camera) and its clip planes (Mitsuba's defaults where it has none), a
//! box-filtered `hdrfilm`, the `path` integrator with the scene's `max_depth`, and each
//! material as Mitsuba's equivalent:
//!
//! | pir | Mitsuba 3 |
//! |---|---|
//! | diffuse | `diffuse` |
//! | glossy | `blendbsdf` of `diffuse` and `roughconductor` (material none, GGX), weighted so that the sum is albedo/π + specular · GGX (`shared/tools/mitsuba_ref.py`'s mapping) |
//! | mirror | `conductor`, material none, `specular_reflectance` |
//! | glass | `dielectric`, `int_ior`, `ext_ior` 1 |
//! | two-sided | `twosided` around it |
//! | emission | an `area` emitter of that radiance |

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::{Mat4, Vec3};

use crate::image::write_atomically;
use crate::material::{Bsdf, Material};
use crate::scene::{Filter, Scene};

/// Writes `scene` as the Mitsuba scene `out` (an `.xml`) and its meshes beside it
/// (`OUT-mesh-K.ply`); returns every file written.
pub fn write(scene: &Scene, out: &Path) -> Result<Vec<PathBuf>> {
    if let Some(m) = scene.materials().iter().find(|m| m.textures.is_some()) {
        anyhow::bail!(
            "{}: material \"{}\" is textured: pir convert writes constant materials only",
            scene.path().display(),
            m.name
        );
    }
    if let Some(m) = scene.materials().iter().find(|m| matches!(m.bsdf, Bsdf::Composite { .. })) {
        anyhow::bail!(
            "{}: material \"{}\" is a blendbsdf or mask of nested BSDFs: pir convert does not write those",
            scene.path().display(),
            m.name
        );
    }
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("scene").to_string();
    let dir = out.parent().map(Path::to_path_buf).unwrap_or_default();
    if let Some(light) = scene.lights().first() {
        anyhow::bail!("{}: pir convert does not write {} lights yet", scene.path().display(), light.kind());
    }
    let mut files = Vec::new();
    let c = scene.camera();
    let mut xml = String::new();
    let _ = writeln!(xml, "<scene version=\"3.0.0\">");
    let _ = writeln!(
        xml,
        "    <!-- {} written by pir {} (pir convert) -->",
        scene.path().display(),
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(xml, "    <default name=\"spp\" value=\"256\"/>");
    let _ = writeln!(xml, "    <default name=\"resx\" value=\"{}\"/>", c.width);
    let _ = writeln!(xml, "    <default name=\"resy\" value=\"{}\"/>", c.height);
    let _ = writeln!(xml, "    <default name=\"max_depth\" value=\"{}\"/>", scene.defaults().max_depth);
    let _ = writeln!(
        xml,
        "    <integrator type=\"path\"><integer name=\"max_depth\" value=\"$max_depth\"/></integrator>"
    );
    let _ =
        writeln!(xml, "    <sensor type=\"{}\">", if c.lens.is_some() { "thinlens" } else { "perspective" });
    // Along the camera's own axis, so that Mitsuba keeps it there at another film size too.
    let _ = writeln!(xml, "        <string name=\"fov_axis\" value=\"{}\"/>", c.fov_axis.name());
    let _ = writeln!(xml, "        <float name=\"fov\" value=\"{}\"/>", c.fov_along_axis());
    // A camera without clip planes gets Mitsuba's defaults (0.01 and 10⁴: Mitsuba needs some).
    if c.near_clip > 0.0 {
        let _ = writeln!(xml, "        <float name=\"near_clip\" value=\"{}\"/>", c.near_clip);
    }
    if c.far_clip.is_finite() {
        let _ = writeln!(xml, "        <float name=\"far_clip\" value=\"{}\"/>", c.far_clip);
    }
    if let Some(lens) = c.lens {
        let _ = writeln!(xml, "        <float name=\"aperture_radius\" value=\"{}\"/>", lens.aperture_radius);
        let _ = writeln!(xml, "        <float name=\"focus_distance\" value=\"{}\"/>", lens.focus_distance);
    }
    if c.principal_point_offset != glam::Vec2::ZERO {
        if c.lens.is_some() {
            anyhow::bail!(
                "{}: the camera has a lens and a principal point offset, which Mitsuba's thinlens does not have",
                scene.path().display()
            );
        }
        let [x, y] = c.principal_point_offset.to_array();
        let _ = writeln!(xml, "        <float name=\"principal_point_offset_x\" value=\"{x}\"/>");
        let _ = writeln!(xml, "        <float name=\"principal_point_offset_y\" value=\"{y}\"/>");
    }
    let _ = writeln!(
        xml,
        "        <transform name=\"to_world\"><lookat origin=\"{}\" target=\"{}\" up=\"{}\"/></transform>",
        v3(c.eye),
        v3(c.target),
        v3(c.up)
    );
    let _ = writeln!(
        xml,
        "        <sampler type=\"independent\"><integer name=\"sample_count\" value=\"$spp\"/></sampler>"
    );
    let _ = writeln!(xml, "        <film type=\"hdrfilm\">");
    let _ = writeln!(xml, "            <integer name=\"width\" value=\"$resx\"/>");
    let _ = writeln!(xml, "            <integer name=\"height\" value=\"$resy\"/>");
    let _ = writeln!(xml, "            <string name=\"pixel_format\" value=\"rgb\"/>");
    let _ = match scene.filter() {
        Filter::Box => writeln!(xml, "            <rfilter type=\"box\"/>"),
        Filter::Tent { radius } => {
            writeln!(
                xml,
                "            <rfilter type=\"tent\"><float name=\"radius\" value=\"{radius:?}\"/></rfilter>"
            )
        }
        Filter::Gaussian { stddev } => writeln!(
            xml,
            "            <rfilter type=\"gaussian\"><float name=\"stddev\" value=\"{stddev:?}\"/></rfilter>"
        ),
    };
    let _ = writeln!(xml, "        </film>");
    let _ = writeln!(xml, "    </sensor>");
    let (positions, normals, indices) = (scene.positions(), scene.normals(), scene.indices());
    for (k, m) in scene.materials().iter().enumerate() {
        let tris: Vec<[u32; 3]> = indices
            .iter()
            .zip(scene.triangle_materials())
            .filter(|(_, mat)| **mat as usize == k)
            .map(|(t, _)| *t)
            .collect();
        if tris.is_empty() {
            continue;
        }
        let smooth = tris.iter().flatten().all(|&i| normals[i as usize] != Vec3::ZERO);
        let ply = dir.join(format!("{stem}-mesh-{k}.ply"));
        write_atomically(&ply, |w| {
            writeln!(w, "ply\nformat binary_little_endian 1.0\nelement vertex {}", 3 * tris.len())?;
            writeln!(w, "property float x\nproperty float y\nproperty float z")?;
            if smooth {
                writeln!(w, "property float nx\nproperty float ny\nproperty float nz")?;
            }
            writeln!(w, "element face {}\nproperty list uchar int vertex_indices\nend_header", tris.len())?;
            for &i in tris.iter().flatten() {
                for x in positions[i as usize].to_array() {
                    w.write_all(&x.to_le_bytes())?;
                }
                if smooth {
                    for x in normals[i as usize].to_array() {
                        w.write_all(&x.to_le_bytes())?;
                    }
                }
            }
            for t in 0..tris.len() as i32 {
                w.write_all(&[3])?;
                for i in [3 * t, 3 * t + 1, 3 * t + 2] {
                    w.write_all(&i.to_le_bytes())?;
                }
            }
            Ok(())
        })?;
        let name = ply.file_name().and_then(|n| n.to_str()).context("mesh file name")?.to_string();
        files.push(ply);
        let _ = writeln!(xml, "    <!-- material {:?} -->", m.name);
        let _ = writeln!(xml, "    <shape type=\"ply\">");
        let _ = writeln!(xml, "        <string name=\"filename\" value=\"{}\"/>", escape(&name));
        if !smooth {
            let _ = writeln!(xml, "        <boolean name=\"face_normals\" value=\"true\"/>");
        }
        xml.push_str(&material_xml(m));
        let _ = writeln!(xml, "    </shape>");
    }
    // Analytic spheres: Mitsuba's own, placed by a matrix (centre, rotation, radius).
    for s in scene.spheres() {
        let m = scene.material(s.material);
        let to_world = Mat4::from_translation(s.sphere.center)
            * Mat4::from_mat3(s.rotation)
            * Mat4::from_scale(Vec3::splat(s.sphere.radius));
        let values: Vec<String> =
            to_world.transpose().to_cols_array().iter().map(|x| format!("{x:?}")).collect();
        let _ = writeln!(xml, "    <!-- material {:?} -->", m.name);
        let _ = writeln!(xml, "    <shape type=\"sphere\">");
        let _ = writeln!(
            xml,
            "        <transform name=\"to_world\"><matrix value=\"{}\"/></transform>",
            values.join(" ")
        );
        if s.flip {
            let _ = writeln!(xml, "        <boolean name=\"flip_normals\" value=\"true\"/>");
        }
        xml.push_str(&material_xml(m));
        let _ = writeln!(xml, "    </shape>");
    }
    let _ = writeln!(xml, "</scene>");
    write_atomically(out, |w| Ok(w.write_all(xml.as_bytes())?))?;
    files.push(out.to_path_buf());
    Ok(files)
}

/// A shape's material as Mitsuba XML: its BSDF and, where it emits, its area emitter.
fn material_xml(m: &Material) -> String {
    let mut xml = bsdf_xml(m, "        ");
    if m.is_emitter() {
        let _ = writeln!(
            xml,
            "        <emitter type=\"area\"><rgb name=\"radiance\" value=\"{}\"/></emitter>",
            v3(m.emission)
        );
    }
    xml
}

/// The material's BSDF as Mitsuba XML, indented by `pad`.
fn bsdf_xml(m: &Material, pad: &str) -> String {
    let inner = match m.bsdf {
        Bsdf::Diffuse { albedo } => {
            format!("<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{}\"/></bsdf>", v3(albedo))
        }
        Bsdf::Mirror { specular } => format!(
            "<bsdf type=\"conductor\"><string name=\"material\" value=\"none\"/><rgb name=\"specular_reflectance\" value=\"{}\"/></bsdf>",
            v3(specular)
        ),
        Bsdf::Glass { ior } => format!(
            "<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"{ior}\"/><float name=\"ext_ior\" value=\"1\"/></bsdf>"
        ),
        Bsdf::Conductor { specular, ior } => format!(
            "<bsdf type=\"conductor\"><rgb name=\"eta\" value=\"{}\"/><rgb name=\"k\" value=\"{}\"/><rgb name=\"specular_reflectance\" value=\"{}\"/></bsdf>",
            v3(ior.eta),
            v3(ior.k),
            v3(specular)
        ),
        Bsdf::RoughConductor { specular, ior, microfacet } => format!(
            "<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"{}\"/><float name=\"alpha\" value=\"{:?}\"/><rgb name=\"eta\" value=\"{}\"/><rgb name=\"k\" value=\"{}\"/><rgb name=\"specular_reflectance\" value=\"{}\"/></bsdf>",
            microfacet.kind.name(),
            microfacet.alpha,
            v3(ior.eta),
            v3(ior.k),
            v3(specular)
        ),
        Bsdf::Plastic { diffuse, specular, eta, nonlinear, .. } => format!(
            "<bsdf type=\"plastic\"><rgb name=\"diffuse_reflectance\" value=\"{}\"/><rgb name=\"specular_reflectance\" value=\"{}\"/><float name=\"int_ior\" value=\"{eta:?}\"/><float name=\"ext_ior\" value=\"1\"/><boolean name=\"nonlinear\" value=\"{nonlinear}\"/></bsdf>",
            v3(diffuse),
            v3(specular)
        ),
        Bsdf::RoughPlastic { diffuse, specular, nonlinear, table, .. } => format!(
            "<bsdf type=\"roughplastic\"><string name=\"distribution\" value=\"{}\"/><float name=\"alpha\" value=\"{:?}\"/><rgb name=\"diffuse_reflectance\" value=\"{}\"/><rgb name=\"specular_reflectance\" value=\"{}\"/><float name=\"int_ior\" value=\"{:?}\"/><float name=\"ext_ior\" value=\"1\"/><boolean name=\"nonlinear\" value=\"{nonlinear}\"/></bsdf>",
            table.microfacet.kind.name(),
            table.microfacet.alpha,
            v3(diffuse),
            v3(specular),
            table.eta
        ),
        Bsdf::Dielectric { ior, reflectance, transmittance } => format!(
            "<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"{ior:?}\"/><float name=\"ext_ior\" value=\"1\"/><rgb name=\"specular_reflectance\" value=\"{}\"/><rgb name=\"specular_transmittance\" value=\"{}\"/></bsdf>",
            v3(reflectance),
            v3(transmittance)
        ),
        Bsdf::ThinDielectric { ior, reflectance, transmittance } => format!(
            "<bsdf type=\"thindielectric\"><float name=\"int_ior\" value=\"{ior:?}\"/><float name=\"ext_ior\" value=\"1\"/><rgb name=\"specular_reflectance\" value=\"{}\"/><rgb name=\"specular_transmittance\" value=\"{}\"/></bsdf>",
            v3(reflectance),
            v3(transmittance)
        ),
        Bsdf::RoughDielectric { eta, reflectance, transmittance, microfacet } => format!(
            "<bsdf type=\"roughdielectric\"><string name=\"distribution\" value=\"{}\"/><float name=\"alpha\" value=\"{:?}\"/><float name=\"int_ior\" value=\"{eta:?}\"/><float name=\"ext_ior\" value=\"1\"/><rgb name=\"specular_reflectance\" value=\"{}\"/><rgb name=\"specular_transmittance\" value=\"{}\"/></bsdf>",
            microfacet.kind.name(),
            microfacet.alpha,
            v3(reflectance),
            v3(transmittance)
        ),
        Bsdf::Mask { opacity, albedo } => {
            let inner =
                format!("<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{}\"/></bsdf>", v3(albedo));
            let inner = if m.two_sided { format!("<bsdf type=\"twosided\">{inner}</bsdf>") } else { inner };
            // The mask is the outer plugin: the nested BSDF carries the sidedness.
            return format!(
                "{pad}<bsdf type=\"mask\"><float name=\"opacity\" value=\"{opacity:?}\"/>{inner}</bsdf>\n"
            );
        }
        // Refused by `write` before any file is written.
        Bsdf::Composite { .. } => String::new(),
        Bsdf::Glossy { albedo, specular, roughness } => {
            let (d, s) = (albedo.max_element(), specular.max_element());
            let spec = |scale: f32| {
                format!(
                    "<bsdf type=\"roughconductor\"><string name=\"material\" value=\"none\"/><string name=\"distribution\" \
                     value=\"ggx\"/><float name=\"alpha\" value=\"{roughness}\"/><rgb name=\"specular_reflectance\" value=\"{}\"/></bsdf>",
                    v3(specular / scale)
                )
            };
            if d == 0.0 || s == 0.0 {
                if s == 0.0 {
                    format!(
                        "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{}\"/></bsdf>",
                        v3(albedo)
                    )
                } else {
                    spec(1.0)
                }
            } else {
                // (1 − w) · diffuse(kd / (1 − w)) + w · ggx(ks / w) = kd/π + ks · ggx.
                let w = s / (d + s);
                format!(
                    "<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"{w}\"/><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{}\"/></bsdf>{}</bsdf>",
                    v3(albedo / (1.0 - w)),
                    spec(w)
                )
            }
        }
    };
    if m.two_sided {
        format!("{pad}<bsdf type=\"twosided\">{inner}</bsdf>\n")
    } else {
        format!("{pad}{inner}\n")
    }
}

/// A vector as Mitsuba writes one: "x, y, z", every f32 exactly.
fn v3(v: Vec3) -> String {
    format!("{:?}, {:?}, {:?}", v.x, v.y, v.z)
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;").replace('>', "&gt;")
}
