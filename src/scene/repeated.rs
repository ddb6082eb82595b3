//! Emitting faces that a mesh lists twice.
//!
//! A scene file can repeat a face: McGuire's Cornell-box OBJ lists one face of each box
//! twice. Where the face emits, next-event estimation picks points on both copies, so it
//! counts the face's light twice, while a ray that meets the face hits one copy and counts
//! it once. Every renderer that samples emitters by area (Mitsuba 3 too) then renders light
//! that no single reading of the file gives, brighter beside the face than the face
//! alone would make it, by an amount that depends on how the weights share the two
//! techniques. The file is at fault, and the loader says so.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use super::Scene;

/// A warning where emitting triangles of `scene` (loaded from `path`) repeat the corners of
/// another emitting triangle facing the same way (in any order that keeps the facing): how
/// many, and the first one's material and corners.
pub fn repeated_emitter_warning(path: &Path, scene: &Scene) -> Option<String> {
    let mut seen: HashMap<[[u32; 3]; 3], u32> = HashMap::new();
    let mut repeats = 0usize;
    let mut first = None;
    for prim in 0..scene.triangle_count() as u32 {
        if !scene.material_of(prim).is_emitter() {
            continue;
        }
        // The corners from the least, in their order (so a copy facing the other way, which
        // emits on its own side, is another face), −0 as 0.
        let c = scene.triangle(prim).map(|v| (v + Vec3::ZERO).to_array().map(f32::to_bits));
        let k = (0..3).min_by_key(|&i| c[i]).unwrap_or(0);
        let key = [c[k], c[(k + 1) % 3], c[(k + 2) % 3]];
        if let Some(&earlier) = seen.get(&key) {
            repeats += 1;
            first.get_or_insert((earlier, prim));
        } else {
            seen.insert(key, prim);
        }
    }
    let (earlier, prim) = first?;
    let [a, b, c] = scene.triangle(prim);
    Some(format!(
        "{}: {repeats} emitting triangle(s) repeat the corners of another (the first, of material {:?}, \
         at {a} {b} {c}, repeats triangle {earlier}): light samples count such a face once per copy and \
         rays that hit it once, so the light beside it is too bright, as in any renderer that samples \
         emitters by area; remove the repeated faces from the mesh",
        path.display(),
        scene.material_of(prim).name,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Bsdf, Material};
    use crate::scene::{Camera, Geometry, RenderDefaults};

    /// A unit square light (two triangles) and a grey floor square below it; `extra` adds
    /// triangles over the same four light corners and the floor's.
    fn scene(extra: &[[u32; 3]], extra_material: u32) -> Scene {
        let positions = vec![
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let mut indices = vec![[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7]];
        let mut tri_material = vec![0, 0, 1, 1];
        indices.extend_from_slice(extra);
        tri_material.extend(std::iter::repeat_n(extra_material, extra.len()));
        let material = |name: &str, emission: f32| Material {
            name: name.into(),
            bsdf: Bsdf::Diffuse { albedo: Vec3::splat(0.5) },
            emission: Vec3::splat(emission),
            two_sided: false,
            textures: None,
        };
        let camera = Camera::pinhole(Vec3::new(0.5, 0.5, 3.0), Vec3::splat(0.5), Vec3::Y, 40.0, 4, 4);
        let geometry = Geometry::flat(positions, indices, tri_material);
        let materials = vec![material("lamp", 4.0), material("floor", 0.0)];
        Scene::new("room.toml".into(), camera, RenderDefaults::default(), geometry, materials).unwrap()
    }

    #[test]
    fn a_repeated_emitting_face_is_named_whatever_corner_it_starts_from() {
        let path = Path::new("room.toml");
        assert_eq!(repeated_emitter_warning(path, &scene(&[], 0)), None);
        // The same corners from another corner: both repeat the first triangle.
        let w = repeated_emitter_warning(path, &scene(&[[2, 1, 0], [1, 0, 2]], 0)).unwrap();
        assert!(w.starts_with("room.toml: 2 emitting triangle(s)"), "{w}");
        assert!(w.contains("\"lamp\"") && w.contains("repeats triangle 0"), "{w}");
        // Repeated faces that do not emit are not the renderer's concern.
        assert_eq!(repeated_emitter_warning(path, &scene(&[[4, 5, 6]], 1)), None);
        // Facing the other way, it emits on its own side: another face; so is one that
        // shares two corners only.
        assert_eq!(repeated_emitter_warning(path, &scene(&[[0, 1, 2]], 0)), None);
        assert_eq!(repeated_emitter_warning(path, &scene(&[[0, 2, 5]], 0)), None);
    }
}
