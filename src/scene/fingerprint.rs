//! A fingerprint of a loaded scene's contents, so that a render is only resumed or merged
//! with renders of the same scene. It hashes what the image depends on (geometry, normals,
//! materials, camera placement, clip planes, lens and principal point, lights), not the file names or the
//! resolution (which is part of the render job and checked separately).

use super::Scene;
use crate::hash::Fnv1a;

impl Scene {
    /// A 16-hex-digit fingerprint of the scene's contents.
    pub fn fingerprint(&self) -> String {
        let mut h = Fnv1a::default();
        for p in self.positions.iter().chain(self.normals.iter()) {
            h.f32s(&p.to_array());
        }
        for t in &self.indices {
            h.u32s(t);
        }
        h.u32s(&self.tri_material);
        // Analytic spheres, only where there are some (older scenes keep their fingerprints).
        for s in &self.spheres {
            h.bytes(format!("{s:?}").as_bytes());
        }
        for m in &self.materials {
            // The Debug form spells out every field of the BSDF and its emission exactly; the
            // two-sided flag is added only where it is set, so that the fingerprints of scenes
            // without it are those of pirs that did not have it.
            let crate::material::Material { name, bsdf, emission, two_sided, textures } = m;
            h.bytes(
                format!("Material {{ name: {name:?}, bsdf: {bsdf:?}, emission: {emission:?} }}").as_bytes(),
            );
            if *two_sided {
                h.bytes(b"two-sided");
            }
            // A composite's parts' textures (its Debug form names only their slots).
            if let crate::material::Bsdf::Composite { parts, .. } = bsdf {
                parts.hash_textures(&mut |b| h.bytes(b));
            }
            // Textures likewise, only where there are some.
            if let Some(t) = textures {
                for (slot, texture) in &t.slots {
                    h.bytes(slot.name().as_bytes());
                    texture.hash_into(&mut |b| h.bytes(b));
                }
                if let Some(map) = &t.map {
                    use crate::material::shading_map::Perturbation;
                    let scale = match map.perturbation {
                        Perturbation::Normal(_) => f32::NAN,
                        Perturbation::Bump { scale, .. } => scale,
                    };
                    h.bytes(format!("map {:?} {scale:?}", map.back).as_bytes());
                    map.texture().hash_into(&mut |b| h.bytes(b));
                }
            }
        }
        // Texture coordinates only in scenes that have some.
        if !self.uvs.is_empty() {
            h.bytes(b"uvs");
            for uv in &self.uvs {
                h.f32s(&uv.to_array());
            }
        }
        // The reconstruction filter, only where it is not the box.
        if self.filter != super::Filter::Box {
            h.bytes(format!("{:?}", self.filter).as_bytes());
        }
        // Where Russian roulette starts, only where a Mitsuba scene moved it.
        if self.render.rr_depth != super::DEFAULT_RR_DEPTH {
            h.bytes(format!("rr_depth {}", self.render.rr_depth).as_bytes());
        }
        let c = &self.camera;
        h.f32s(&[
            c.eye.x, c.eye.y, c.eye.z, c.target.x, c.target.y, c.target.z, c.up.x, c.up.y, c.up.z, c.fov_deg,
        ]);
        // The axis the field of view is kept along at another resolution, only where it is
        // not the vertical one (the TOML format's camera's), as the clip planes and the lens.
        // (With it, the film's own size decides the field of view at another resolution.)
        if c.fov_axis != super::FovAxis::Y {
            h.bytes(format!("fov_axis {} {}x{}", c.fov_axis.name(), c.width, c.height).as_bytes());
        }
        // The clip planes and the lens only where there are some (the TOML format's camera
        // has neither), so that the other scenes keep their fingerprints.
        if (c.near_clip, c.far_clip) != (0.0, f32::INFINITY) {
            h.bytes(b"clip");
            h.f32s(&[c.near_clip, c.far_clip]);
        }
        if let Some(lens) = c.lens {
            h.bytes(b"thin lens");
            h.f32s(&[lens.aperture_radius, lens.focus_distance]);
        }
        if c.principal_point_offset != glam::Vec2::ZERO {
            h.bytes(b"principal point offset");
            h.f32s(&c.principal_point_offset.to_array());
        }
        // Only scenes with other lights hash them, so that the others keep their fingerprints.
        for light in &self.lights {
            light.fingerprint(&mut h);
        }
        // Likewise the emitting spheres, which next-event estimation samples by their cones.
        for s in &self.sphere_lights {
            h.bytes(b"sphere light");
            h.f32s(&[s.center.x, s.center.y, s.center.z, s.radius]);
            h.u32s(&[s.prims.start, s.prims.end]);
        }
        format!("{:016x}", h.finish())
    }
}

#[cfg(test)]
mod tests {
    /// The default scene's fingerprint as pir 0.1.0 computed it: checkpoints of that pir
    /// resume only while it stays the same.
    #[test]
    fn the_cornell_box_keeps_its_fingerprint() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/scene.toml");
        let scene = crate::scene::load(&path).unwrap();
        assert_eq!(scene.fingerprint(), "e3f0af534ef3a9a9");
    }
}
