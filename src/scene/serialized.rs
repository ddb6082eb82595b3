//! Mitsuba's `.serialized` meshes (file versions 3 and 4), as Mitsuba 3's `serialized` shape
//! reads them, into [`MeshData`].
//!
//! # Layout (all little endian)
//!
//! The file is a sequence of shapes, then a dictionary:
//!
//! - each shape: `u16` format identifier `0x041C`, `u16` version (3 or 4), then one zlib
//!   stream holding
//!   - `u32` flags: `0x0001` per-vertex normals, `0x0002` texture coordinates, `0x0008`
//!     vertex colours, `0x0010` face normals (flat shading asked for), `0x1000` single,
//!     `0x2000` double precision (neither: single);
//!   - version 4 only: the shape's name, UTF-8, ending in a zero byte;
//!   - `u64` vertex count, `u64` triangle count;
//!   - positions (x y z per vertex), then normals, texture coordinates (u v) and colours
//!     (r g b) when flagged, as `f32` or `f64`;
//!   - triangles, three `u32` indices each (`u64` when the vertex count exceeds 2^32);
//! - the dictionary at the end of the file: the byte offset of each shape's header (`u64` in
//!   version 4, `u32` in version 3; the first is 0), then the `u32` number of shapes.
//!
//! `shape_index` picks a shape through the dictionary (which is therefore required, also for
//! shape 0). The shape's compressed bytes run from its header to the next shape's offset (or
//! to the dictionary).
//!
//! # What is returned
//!
//! Positions, normals (as stored, not normalised), texture coordinates and triangles, all as
//! `f32`/`u32` (double precision is converted); colours are read and dropped; the name is
//! dropped; the face-normals flag is reported in [`MeshData::face_normals`] (normals stored
//! alongside it are returned too: the caller decides). Flag bits other than the ones above
//! are ignored, as Mitsuba does.
//!
//! # What is refused (a [`SceneError::Syntax`] naming the shape and the field or byte offset)
//!
//! A wrong format identifier or version, or a shape header differing from the file's; a
//! dictionary that does not fit in the file, has no shapes, or an offset outside the shape
//! area; a `shape_index` past the last shape (Mitsuba 3 checks `>` and reads past the
//! dictionary for `index == count`); both precision flags at once; a corrupt or short zlib
//! stream; a vertex or triangle count above 2^31 (so `u64` indices, which need more than
//! 2^32 vertices, are refused by this bound rather than read); a name longer than 64 KiB; a
//! position, normal or texture coordinate that is not finite (also after conversion to
//! `f32`); an index out of range (the error names the triangle).
//!
//! # Bounds on allocation and time
//!
//! Counts are bounded by 2^31 each; the bytes they imply (vertex count × record size +
//! triangle count × 12) must not exceed what the shape's compressed bytes can hold (deflate
//! expands by at most 1032:1). The stream is then decompressed through `Read::take` of
//! exactly that many bytes into a buffer that grows with the data actually produced, so a
//! zip bomb or a lying count can neither allocate more than the counts imply nor more than
//! the compressed bytes can produce; a stream that ends early is an error. Decoding walks the
//! buffer once.

use std::io::Read;
use std::path::Path;

use flate2::read::ZlibDecoder;
use glam::{Vec2, Vec3};

use super::error::SceneError;
use super::mesh_data::MeshData;

/// The format identifier of every shape header.
const FORMAT: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const SINGLE_PRECISION: u32 = 0x1000;
const DOUBLE_PRECISION: u32 = 0x2000;
/// Largest vertex or triangle count read.
const MAX_COUNT: u64 = 1 << 31;
/// Largest shape name read (version 4).
const MAX_NAME: usize = 64 * 1024;
/// Deflate's largest expansion: 258 bytes from one length/distance pair of 2 bits.
const MAX_DEFLATE_RATIO: u64 = 1032;

/// Reads shape `shape_index` (0 the first) of the `.serialized` file `path`.
pub fn read_serialized(path: &Path, shape_index: u32) -> Result<MeshData, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    read_serialized_from_bytes(&bytes, path, shape_index)
}

/// Reads shape `shape_index` of a `.serialized` file from its bytes; errors name
/// `name_for_errors`.
pub fn read_serialized_from_bytes(
    bytes: &[u8],
    name_for_errors: &Path,
    shape_index: u32,
) -> Result<MeshData, SceneError> {
    let err = |p: String| SceneError::syntax(name_for_errors, None, p);
    let file = Dictionary::read(bytes).map_err(err)?;
    read_shape(bytes, &file, shape_index).map_err(|p| err(format!("shape {shape_index}: {p}")))
}

/// The number of shapes of the `.serialized` file `path`, from its dictionary.
pub fn serialized_shape_count(path: &Path) -> Result<u32, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    serialized_shape_count_from_bytes(&bytes, path)
}

/// The number of shapes of a `.serialized` file from its bytes.
pub fn serialized_shape_count_from_bytes(bytes: &[u8], name_for_errors: &Path) -> Result<u32, SceneError> {
    let file = Dictionary::read(bytes).map_err(|p| SceneError::syntax(name_for_errors, None, p))?;
    Ok(file.offsets.len() as u32)
}

fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(bytes.get(at..at.checked_add(2)?)?.try_into().ok()?))
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at.checked_add(4)?)?.try_into().ok()?))
}

fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(bytes.get(at..at.checked_add(8)?)?.try_into().ok()?))
}

/// The file's version and the shapes' offsets, checked to lie before the dictionary.
struct Dictionary {
    version: u16,
    offsets: Vec<usize>,
    /// Byte offset of the dictionary (the end of the last shape).
    start: usize,
}

impl Dictionary {
    fn read(bytes: &[u8]) -> Result<Dictionary, String> {
        let (Some(format), Some(version)) = (u16_at(bytes, 0), u16_at(bytes, 2)) else {
            return Err(format!("{} bytes: too short for a .serialized file", bytes.len()));
        };
        if format != FORMAT {
            return Err(format!(
                "not a .serialized file: format identifier {format:#06x}, not {FORMAT:#06x}"
            ));
        }
        if version != 3 && version != 4 {
            return Err(format!("unknown .serialized version {version} (3 and 4 are read)"));
        }
        let entry = if version == 4 { 8 } else { 4 };
        let count_at = bytes.len().checked_sub(4).filter(|&c| c >= 4);
        let Some(count) = count_at.and_then(|c| u32_at(bytes, c)) else {
            return Err(format!("{} bytes: no room for the dictionary at the end of the file", bytes.len()));
        };
        let size = (count as usize).checked_mul(entry).and_then(|s| s.checked_add(4));
        // The shapes start at byte 0 and take at least their 4-byte header.
        let Some(start) = size.and_then(|s| bytes.len().checked_sub(s)).filter(|&s| s >= 4) else {
            return Err(format!(
                "the dictionary at the end of the file claims {count} shapes, which do not fit in {} bytes",
                bytes.len()
            ));
        };
        if count == 0 {
            return Err("the dictionary at the end of the file lists no shapes".into());
        }
        let mut offsets = Vec::with_capacity(count as usize);
        for i in 0..count as usize {
            let at = start + i * entry;
            let offset = if version == 4 { u64_at(bytes, at) } else { u32_at(bytes, at).map(u64::from) };
            let offset = offset
                .and_then(|o| usize::try_from(o).ok())
                .filter(|&o| o.checked_add(4).is_some_and(|e| e <= start));
            let Some(offset) = offset else {
                return Err(format!(
                    "dictionary entry {i} (byte {at}): the shape's offset is not within the {start} bytes of shapes"
                ));
            };
            offsets.push(offset);
        }
        Ok(Dictionary { version, offsets, start })
    }
}

/// Reads one shape; errors are the problem.
fn read_shape(bytes: &[u8], file: &Dictionary, index: u32) -> Result<MeshData, String> {
    let count = file.offsets.len();
    let Some(&offset) = file.offsets.get(index as usize) else {
        return Err(format!("the file has {count} shapes (0..{})", count.saturating_sub(1)));
    };
    let end = file.offsets.iter().copied().filter(|&o| o > offset).min().unwrap_or(file.start);
    let (format, version) = (u16_at(bytes, offset), u16_at(bytes, offset + 2));
    if format != Some(FORMAT) || version != Some(file.version) {
        return Err(format!(
            "no shape header at byte {offset} (format {:#06x}, version {}; the file's is {FORMAT:#06x}, {})",
            format.unwrap_or(0),
            version.unwrap_or(0),
            file.version
        ));
    }
    let compressed = bytes.get(offset + 4..end).unwrap_or(&[]);
    let mut z = ZlibDecoder::new(compressed);
    let zerr = |what: &str, e: std::io::Error| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => {
            format!("the compressed stream (bytes {offset}..{end}) ends before the {what}")
        }
        _ => format!("the compressed stream (bytes {offset}..{end}) is corrupt at the {what}: {e}"),
    };
    let mut word = [0u8; 4];
    z.read_exact(&mut word).map_err(|e| zerr("flags", e))?;
    let flags = u32::from_le_bytes(word);
    if file.version == 4 {
        let mut name_len = 0usize;
        loop {
            let mut byte = [0u8; 1];
            z.read_exact(&mut byte).map_err(|e| zerr("shape name", e))?;
            if byte[0] == 0 {
                break;
            }
            name_len += 1;
            if name_len > MAX_NAME {
                return Err(format!("the shape name is longer than {MAX_NAME} bytes"));
            }
        }
    }
    let mut counts = [0u8; 16];
    z.read_exact(&mut counts).map_err(|e| zerr("vertex and triangle counts", e))?;
    let vertex_count = u64_at(&counts, 0).unwrap_or(0);
    let triangle_count = u64_at(&counts, 8).unwrap_or(0);
    for (what, n) in [("vertex", vertex_count), ("triangle", triangle_count)] {
        if n > MAX_COUNT {
            return Err(format!("{what} count {n} is above the {MAX_COUNT} this reader takes"));
        }
    }
    let double = match (flags & SINGLE_PRECISION != 0, flags & DOUBLE_PRECISION != 0) {
        (true, true) => return Err(format!("flags {flags:#06x} ask for both single and double precision")),
        (_, double) => double,
    };
    let float_size: u64 = if double { 8 } else { 4 };
    let has = |f: u32| flags & f != 0;
    let floats_per_vertex = 3
        + 3 * u64::from(has(HAS_NORMALS))
        + 2 * u64::from(has(HAS_TEXCOORDS))
        + 3 * u64::from(has(HAS_COLORS));
    // Both counts ≤ 2^31, so neither product overflows a u64.
    let total = vertex_count * floats_per_vertex * float_size + triangle_count * 12;
    let can_hold = (compressed.len() as u64).saturating_mul(MAX_DEFLATE_RATIO);
    if total > can_hold {
        return Err(format!(
            "{vertex_count} vertices and {triangle_count} triangles need {total} bytes, more than the \
             {} compressed bytes can hold",
            compressed.len()
        ));
    }
    let mut data = Vec::new();
    z.take(total).read_to_end(&mut data).map_err(|e| zerr("mesh data", e))?;
    if (data.len() as u64) < total {
        return Err(format!(
            "the compressed stream ends after {} of the {total} bytes that {vertex_count} vertices and \
             {triangle_count} triangles need",
            data.len()
        ));
    }
    decode(&data, flags, double, vertex_count as usize, triangle_count as usize)
}

/// Decodes the arrays of a shape from `data`, which holds exactly the bytes the counts need.
fn decode(
    data: &[u8],
    flags: u32,
    double: bool,
    vertices: usize,
    triangles: usize,
) -> Result<MeshData, String> {
    let mut at = 0usize;
    let mut floats = |n: usize| -> Vec<f32> {
        let size = if double { 8 } else { 4 };
        let part = data.get(at..at + n * size).unwrap_or(&[]);
        at += n * size;
        if double {
            part.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f32).collect()
        } else {
            part.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap_or([0; 4]))).collect()
        }
    };
    let check = |what: &str, values: &[f32], dim: usize| -> Result<(), String> {
        match values.iter().position(|v| !v.is_finite()) {
            Some(i) => Err(format!("{what} of vertex {}: {} is not a finite f32", i / dim, values[i])),
            None => Ok(()),
        }
    };
    let p = floats(3 * vertices);
    check("position", &p, 3)?;
    let positions = p.chunks_exact(3).map(Vec3::from_slice).collect();
    let mut normals = Vec::new();
    if flags & HAS_NORMALS != 0 {
        let n = floats(3 * vertices);
        check("normal", &n, 3)?;
        normals = n.chunks_exact(3).map(Vec3::from_slice).collect();
    }
    let mut uvs = Vec::new();
    if flags & HAS_TEXCOORDS != 0 {
        let t = floats(2 * vertices);
        check("texture coordinate", &t, 2)?;
        uvs = t.chunks_exact(2).map(Vec2::from_slice).collect();
    }
    if flags & HAS_COLORS != 0 {
        floats(3 * vertices);
    }
    let index_bytes = data.get(at..).unwrap_or(&[]);
    let mut tris = Vec::with_capacity(triangles);
    for (t, c) in index_bytes.chunks_exact(12).take(triangles).enumerate() {
        let mut tri = [0u32; 3];
        for (k, slot) in tri.iter_mut().enumerate() {
            let i = u32_at(c, 4 * k).unwrap_or(u32::MAX);
            if i as usize >= vertices {
                return Err(format!("triangle {t}: vertex index {i} is out of range ({vertices} vertices)"));
            }
            *slot = i;
        }
        tris.push(tri);
    }
    if tris.len() != triangles {
        return Err(format!("{} of {triangles} triangles in the data", tris.len()));
    }
    Ok(MeshData { positions, normals, uvs, triangles: tris, face_normals: flags & FACE_NORMALS != 0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mesh_data::mutation::{Input, survive};
    use flate2::Compression;
    use flate2::write::ZlibEncoder;
    use std::io::Write;

    /// One shape as Mitsuba writes it: header, then its zlib stream of `payload`.
    fn shape(version: u16, payload: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend(FORMAT.to_le_bytes());
        out.extend(version.to_le_bytes());
        let mut z = ZlibEncoder::new(out, Compression::default());
        z.write_all(payload).unwrap();
        z.finish().unwrap()
    }

    /// The uncompressed stream of a mesh; `colors` adds a colour per vertex.
    fn payload(version: u16, mesh: &MeshData, double: bool, colors: bool) -> Vec<u8> {
        let mut flags = if double { DOUBLE_PRECISION } else { SINGLE_PRECISION };
        flags |= if mesh.normals.is_empty() { 0 } else { HAS_NORMALS };
        flags |= if mesh.uvs.is_empty() { 0 } else { HAS_TEXCOORDS };
        flags |= if colors { HAS_COLORS } else { 0 };
        flags |= if mesh.face_normals { FACE_NORMALS } else { 0 };
        let mut out = flags.to_le_bytes().to_vec();
        if version == 4 {
            out.extend(b"a shape\0");
        }
        out.extend((mesh.positions.len() as u64).to_le_bytes());
        out.extend((mesh.triangles.len() as u64).to_le_bytes());
        let mut put = |values: &[f32]| {
            for &v in values {
                if double {
                    out.extend(f64::from(v).to_le_bytes());
                } else {
                    out.extend(v.to_le_bytes());
                }
            }
        };
        mesh.positions.iter().for_each(|p| put(&p.to_array()));
        mesh.normals.iter().for_each(|n| put(&n.to_array()));
        mesh.uvs.iter().for_each(|t| put(&t.to_array()));
        if colors {
            mesh.positions.iter().for_each(|_| put(&[0.25, 0.5, 1.0]));
        }
        for t in &mesh.triangles {
            t.iter().for_each(|i| out.extend(i.to_le_bytes()));
        }
        out
    }

    /// A file of shapes (each from [`shape`]) with its dictionary.
    fn file(version: u16, shapes: &[Vec<u8>]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for s in shapes {
            offsets.push(out.len() as u64);
            out.extend(s);
        }
        for o in offsets {
            if version == 4 {
                out.extend(o.to_le_bytes());
            } else {
                out.extend((o as u32).to_le_bytes());
            }
        }
        out.extend((shapes.len() as u32).to_le_bytes());
        out
    }

    fn mesh(normals: bool, uvs: bool, face_normals: bool) -> MeshData {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.5), Vec3::Y];
        MeshData {
            normals: if normals { vec![Vec3::Z, Vec3::Z, Vec3::new(0.0, 0.6, 0.8), Vec3::Z] } else { vec![] },
            uvs: if uvs { vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::new(0.0, 0.75)] } else { vec![] },
            positions,
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            face_normals,
        }
    }

    fn read(bytes: &[u8], index: u32) -> Result<MeshData, String> {
        read_serialized_from_bytes(bytes, Path::new("t.serialized"), index).map_err(|e| e.to_string())
    }

    #[test]
    fn round_trips_versions_precisions_and_attributes() {
        for version in [3, 4] {
            for double in [false, true] {
                for (normals, uvs, colors) in
                    [(false, false, false), (true, false, true), (false, true, false), (true, true, true)]
                {
                    let a = mesh(normals, uvs, false);
                    let b = MeshData {
                        positions: a.positions.iter().map(|p| *p * 2.0).collect(),
                        face_normals: true,
                        ..a.clone()
                    };
                    let bytes = file(
                        version,
                        &[
                            shape(version, &payload(version, &a, double, colors)),
                            shape(version, &payload(version, &b, double, false)),
                        ],
                    );
                    let case = format!(
                        "version {version}, double {double}, normals {normals}, uvs {uvs}, colors {colors}"
                    );
                    assert_eq!(
                        serialized_shape_count_from_bytes(&bytes, Path::new("t")).unwrap(),
                        2,
                        "{case}"
                    );
                    assert_eq!(read(&bytes, 0).unwrap(), a, "{case}");
                    assert_eq!(read(&bytes, 1).unwrap(), b, "{case}");
                    let e = read(&bytes, 2).unwrap_err();
                    assert_eq!(e, "t.serialized: shape 2: the file has 2 shapes (0..1)", "{case}");
                }
            }
        }
    }

    #[test]
    fn refuses_bad_headers_counts_values_and_indices() {
        let good = mesh(true, true, false);
        let one = |p: &[u8]| file(4, &[shape(4, p)]);
        let base = payload(4, &good, false, false);
        // Offsets of the payload's fields (version 4, name "a shape\0").
        let counts = 4 + 8;
        let with = |at: usize, bytes: &[u8]| {
            let mut p = base.clone();
            p[at..at + bytes.len()].copy_from_slice(bytes);
            one(&p)
        };
        let indices = base.len() - 24;
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (
                with(counts, &(1u64 << 40).to_le_bytes()),
                "shape 0: vertex count 1099511627776 is above the 2147483648",
            ),
            (with(counts + 8, &(1u64 << 31).to_le_bytes()), "more than the"),
            (with(counts, &1000u64.to_le_bytes()), "the compressed stream ends after"),
            (with(0, &0x3001u32.to_le_bytes()), "both single and double precision"),
            (with(counts + 16 + 4, &f32::NAN.to_le_bytes()), "position of vertex 0: NaN is not a finite f32"),
            (with(counts + 16 + 48 + 12, &f32::INFINITY.to_le_bytes()), "normal of vertex 1: inf"),
            (
                with(indices + 16, &4u32.to_le_bytes()),
                "triangle 1: vertex index 4 is out of range (4 vertices)",
            ),
            (one(&base[..10]), "ends before the shape name"),
            (vec![0x1C, 0x04, 5, 0, 0, 0, 0, 0], "unknown .serialized version 5"),
            (vec![0x1D, 0x04, 4, 0, 0, 0, 0, 0], "not a .serialized file: format identifier 0x041d"),
            (vec![0x1C, 0x04, 4, 0, 0, 0, 0, 0], "lists no shapes"),
            (vec![0x1C, 0x04], "too short"),
            (vec![0x1C, 0x04, 4, 0, 0xFF, 0xFF, 0xFF, 0xFF], "claims 4294967295 shapes"),
        ];
        for (bytes, want) in cases {
            let e = read(&bytes, 0).unwrap_err();
            assert!(e.starts_with("t.serialized: ") && e.contains(want), "{e:?} lacks {want:?}");
        }
        let missing = read_serialized(Path::new("/nonexistent/t.serialized"), 0).unwrap_err();
        assert!(matches!(missing, SceneError::Io { .. }), "{missing}");
        // A bad offset, and a corrupt stream.
        let mut bytes = one(&base);
        let n = bytes.len();
        bytes[n - 12..n - 4].copy_from_slice(&(n as u64).to_le_bytes());
        assert!(read(&bytes, 0).unwrap_err().contains("dictionary entry 0"));
        let mut bytes = one(&base);
        bytes[6] ^= 0xFF;
        assert!(read(&bytes, 0).unwrap_err().contains("compressed stream"));
        // A zip bomb whose counts are small reads only what the counts need.
        let mut bomb = base.clone();
        bomb.extend(vec![0u8; 50 << 20]);
        assert_eq!(read(&one(&bomb), 0).unwrap(), good);
    }

    fn matpreview() -> Option<std::path::PathBuf> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/scenes/mitsuba/matpreview/matpreview.serialized");
        if path.exists() {
            return Some(path);
        }
        let missing = format!("{} is absent", path.display());
        if std::env::var("CI").is_ok_and(|v| v.trim().eq_ignore_ascii_case("true")) {
            panic!("{missing}, and CI=true: CI must run this test, not skip it");
        }
        eprintln!("skipping: {missing}");
        None
    }

    #[test]
    fn reads_every_shape_of_matpreview() {
        let Some(path) = matpreview() else { return };
        let count = serialized_shape_count(&path).unwrap();
        assert!((1..100).contains(&count), "{count} shapes");
        for i in 0..count {
            let m = read_serialized(&path, i).unwrap();
            let (v, t) = (m.positions.len(), m.triangles.len());
            eprintln!(
                "matpreview.serialized shape {i}: {v} vertices, {t} triangles, normals {}, uvs {}, face normals {}",
                m.normals.len(),
                m.uvs.len(),
                m.face_normals
            );
            assert!(v >= 3 && t >= 1 && t < 10 * v, "shape {i}: {v} vertices, {t} triangles");
            assert!(m.normals.is_empty() || m.normals.len() == v);
            assert!(m.uvs.is_empty() || m.uvs.len() == v);
            assert!(m.triangles.iter().flatten().all(|&k| (k as usize) < v));
        }
        let e = read_serialized(&path, count).unwrap_err().to_string();
        assert!(e.contains(&format!("the file has {count} shapes")), "{e}");
    }

    /// Valid files to mutate, and the uncompressed streams (version 3, version 4) of shapes.
    fn inputs() -> (Vec<Input<'static>>, [Vec<u8>; 2]) {
        let m = mesh(true, true, true);
        let p3 = payload(3, &m, false, true);
        let p4 = payload(4, &mesh(false, true, false), true, false);
        let files = vec![
            ("v3 two shapes", file(3, &[shape(3, &p3), shape(3, &payload(3, &m, true, false))]), false),
            ("v4 double", file(4, &[shape(4, &p4)]), false),
            ("v4 two shapes", file(4, &[shape(4, &p4), shape(4, &payload(4, &m, false, false))]), false),
        ];
        (files, [p3, p4])
    }

    fn mutations(cases: usize, seed: u64) {
        let (files, payloads) = inputs();
        let size = |m: &MeshData| m.positions.len() + m.triangles.len();
        let read_all = |bytes: &[u8]| {
            // Every shape the (mutated) dictionary lists, up to 4.
            let count = serialized_shape_count_from_bytes(bytes, Path::new("m"))?;
            let mut last = MeshData::default();
            for i in 0..count.min(4) {
                last = read_serialized_from_bytes(bytes, Path::new("m"), i)?;
            }
            Ok(last)
        };
        let (ok, err) = survive("serialized files", &files, cases / 2, seed, 1032, read_all, size);
        assert!(ok > 0 && err > 0, "{ok} Ok, {err} Err");
        // Mutations of the uncompressed stream, then compressed into a valid file: they reach
        // the flags, name, counts, values and indices behind the zlib layer.
        for (version, p) in [3u16, 4].into_iter().zip(payloads) {
            let label = format!("serialized v{version} streams");
            let read_stream = |bytes: &[u8]| {
                read_serialized_from_bytes(&file(version, &[shape(version, bytes)]), Path::new("m"), 0)
            };
            let inputs = [(label.as_str(), p, false)];
            let (ok, err) =
                survive(&label, &inputs, cases / 4, seed ^ u64::from(version), 1032, read_stream, size);
            assert!(ok > 0 && err > 0, "{ok} Ok, {err} Err");
        }
    }

    #[test]
    fn survives_4000_mutations() {
        mutations(4000, 2);
    }

    /// On demand: `cargo test --release -- --ignored mesh_readers_survive_100k_mutations`.
    #[test]
    #[ignore]
    fn mesh_readers_survive_100k_mutations_serialized() {
        mutations(100_000, 0x5EED);
    }
}
