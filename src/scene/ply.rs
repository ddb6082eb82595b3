//! PLY (Stanford polygon) meshes, as Mitsuba 3's `ply` shape reads them, into [`MeshData`].
//!
//! # What is read
//!
//! A header of text lines: `ply`, then `format ascii|binary_little_endian|binary_big_endian
//! 1.0`, `element <name> <count>` and its `property <type> <name>` or `property list
//! <count type> <item type> <name>` lines, ending with `end_header`. `comment` and `obj_info`
//! lines and blank lines are ignored. Types are `char uchar short ushort int uint float
//! double`, their sized names (`int8 uint8 int16 uint16 int32 uint32 float32 float64`) and
//! Mitsuba's extensions `long ulong int64 uint64 half float16`. Lines may end in `\n` or
//! `\r\n`.
//!
//! Then the elements' records in header order: in ASCII, whitespace-separated numbers (line
//! breaks carry no meaning, as in Mitsuba); in binary, packed values in the declared byte
//! order, a list as its count then its items.
//!
//! - `element vertex`: `x`, `y`, `z` (any numeric type, taken at their numeric value,
//!   converted to `f32`), optional normals `nx ny nz` (all three or none) and texture
//!   coordinates `texture_u texture_v`, else `s t`, else `u v` (Mitsuba's preference). Every
//!   other property, lists included, is read and dropped.
//! - `element face`: the list `vertex_indices` (or `vertex_index`), integer counts and
//!   indices. A face of n ≥ 3 vertices becomes the fan (v0, vi, vi+1), i = 1..n−1 (Mitsuba 3
//!   itself accepts triangles only). Other face properties are read and dropped.
//! - Any other element is skipped record by record by its declared properties (lists
//!   included); a record of fixed size is skipped in one step.
//!
//! # What is refused (a [`SceneError::Syntax`], never a panic)
//!
//! A malformed header (unknown keyword or type, missing or excess tokens, `format` other than
//! version 1.0, a property before any element, a duplicate `vertex` or `face` element or a
//! duplicate property name in one element, a list counted by a non-integer type); no `vertex`
//! element or no `x`, `y`, `z`; a position, normal or texture coordinate that is not finite
//! (also after conversion to `f32`); a `face` element without a `vertex_indices` list; a
//! face of fewer than 3 vertices (Mitsuba refuses those too); a negative or out-of-range
//! index (the error names the face); a number that does not parse as its declared type or
//! does not fit it; data that ends early; and content after the last element (Mitsuba's
//! "trailing content"). A `face` element with no records, or none at all, is not an error:
//! the mesh then has no triangles, and the caller decides. ASCII errors carry their line,
//! binary errors the byte offset, both the element, record and property.
//!
//! # Bounds on allocation and time
//!
//! No count is trusted: before an element is read, its record count times the smallest size
//! a record can have (binary: the scalar sizes plus each list's count; ASCII: one byte per
//! value) must fit in the bytes left, so a header claiming 10^12 vertices in a small file is
//! refused before anything is allocated. The vertex arrays reserved up front are then at most
//! 4 × the bytes left per array (12 bytes per vertex of at least 3 bytes), the triangles at
//! most 3 × (12 bytes per face of at least 4); fans grow the triangles by one per index read.
//! A list's items are read one at a time into a reused buffer, so a claimed count of 2^60
//! items ends at the end of the data. Every loop consumes input, except for elements whose
//! records have no properties, which are not looped over.

use std::path::Path;

use glam::{Vec2, Vec3};

use super::error::SceneError;
use super::mesh_data::MeshData;

/// Reads the PLY file `path` (see the module documentation).
pub fn read_ply(path: &Path) -> Result<MeshData, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    read_ply_from_bytes(&bytes, path)
}

/// Reads a PLY file from its bytes; errors name `name_for_errors`.
pub fn read_ply_from_bytes(bytes: &[u8], name_for_errors: &Path) -> Result<MeshData, SceneError> {
    let header =
        parse_header(bytes).map_err(|(line, p)| SceneError::syntax(name_for_errors, Some(line), p))?;
    let data = bytes.get(header.data_start..).unwrap_or(&[]);
    match header.format {
        Format::Ascii => {
            let mut r = Ascii { text: data, pos: 0, line: header.lines + 1 };
            read_body(&mut r, &header).map_err(|p| SceneError::syntax(name_for_errors, Some(r.line), p))
        }
        Format::Binary { big_endian } => {
            let mut r = Binary { bytes: data, pos: 0, big_endian, base: header.data_start };
            read_body(&mut r, &header).map_err(|p| SceneError::syntax(name_for_errors, None, p))
        }
    }
}

/// A scalar type of the header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F16,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "long" | "int64" => Scalar::I64,
            "ulong" | "uint64" => Scalar::U64,
            "half" | "float16" => Scalar::F16,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 | Scalar::F16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    fn is_int(self) -> bool {
        !matches!(self, Scalar::F16 | Scalar::F32 | Scalar::F64)
    }

    /// Inclusive range of an integer type.
    fn range(self) -> (i128, i128) {
        match self {
            Scalar::I8 => (i8::MIN.into(), i8::MAX.into()),
            Scalar::U8 => (0, u8::MAX.into()),
            Scalar::I16 => (i16::MIN.into(), i16::MAX.into()),
            Scalar::U16 => (0, u16::MAX.into()),
            Scalar::I32 => (i32::MIN.into(), i32::MAX.into()),
            Scalar::U32 => (0, u32::MAX.into()),
            Scalar::I64 => (i64::MIN.into(), i64::MAX.into()),
            _ => (0, u64::MAX.into()),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::I64 => "long",
            Scalar::U64 => "ulong",
            Scalar::F16 => "half",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

impl Element {
    /// The byte size of a record when it has no lists.
    fn fixed_size(&self) -> Option<usize> {
        self.props.iter().try_fold(0usize, |sum, p| match p.kind {
            Kind::Scalar(s) => sum.checked_add(s.size()),
            Kind::List { .. } => None,
        })
    }

    /// The fewest bytes a record takes: binary, the scalars and the lists' counts; ASCII, one
    /// byte per value (a list at least its count).
    fn min_size(&self, format: Format) -> usize {
        self.props
            .iter()
            .map(|p| match (format, p.kind) {
                (Format::Ascii, _) => 1,
                (_, Kind::Scalar(s)) => s.size(),
                (_, Kind::List { count, .. }) => count.size(),
            })
            .sum()
    }

    fn position(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|p| p.name == name)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    Binary { big_endian: bool },
}

#[derive(Debug)]
struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the first record.
    data_start: usize,
    /// Number of header lines (the data's first line is the next one).
    lines: usize,
}

/// Parses the header; errors are (1-based line, problem).
fn parse_header(bytes: &[u8]) -> Result<Header, (usize, String)> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut format: Option<Format> = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(rest) = bytes.get(pos..).filter(|r| !r.is_empty()) else {
            let problem = if line_no == 0 {
                "empty file, not a PLY file"
            } else {
                "the header has no `end_header` line"
            };
            return Err((line_no.max(1), problem.into()));
        };
        line_no += 1;
        let (raw, next) = match rest.iter().position(|&b| b == b'\n') {
            Some(n) => (&rest[..n], pos + n + 1),
            None => (rest, bytes.len()),
        };
        pos = next;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let err = |p: String| Err((line_no, p));
        let Ok(text) = std::str::from_utf8(raw) else {
            return err(if line_no == 1 {
                "not a PLY file (no `ply` line)".into()
            } else {
                "header line is not text".into()
            });
        };
        let mut tokens = text.split_ascii_whitespace();
        if line_no == 1 {
            if text.trim_end() != "ply" {
                return err("not a PLY file: the first line must be `ply`".into());
            }
            continue;
        }
        let Some(keyword) = tokens.next() else { continue };
        let rest: Vec<&str> = tokens.collect();
        match keyword {
            "comment" | "obj_info" => {}
            "ply" => return err("duplicate `ply` line".into()),
            "format" => {
                if format.is_some() {
                    return err("duplicate `format` line".into());
                }
                let f = match rest.first().copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Binary { big_endian: false },
                    Some("binary_big_endian") => Format::Binary { big_endian: true },
                    Some(other) => return err(format!("unknown format `{other}`")),
                    None => return err("`format` needs a format and a version".into()),
                };
                match rest.get(1..) {
                    Some(["1.0"]) => {}
                    Some([]) => return err("`format` needs a version (1.0)".into()),
                    Some([v]) => return err(format!("unknown PLY version `{v}` (only 1.0 is read)")),
                    _ => return err("excess tokens after `format`".into()),
                }
                format = Some(f);
            }
            "element" => {
                if format.is_none() {
                    return err("`element` before `format`".into());
                }
                let [name, count] = rest[..] else {
                    return err("`element` needs a name and a count".into());
                };
                let Ok(count) = count.parse::<u64>() else {
                    return err(format!("element `{name}`: count `{count}` is not a non-negative integer"));
                };
                if (name == "vertex" || name == "face") && elements.iter().any(|e| e.name == name) {
                    return err(format!("duplicate element `{name}`"));
                }
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return err("`property` before any `element`".into());
                };
                let type_of = |t: &str| {
                    Scalar::parse(t).ok_or_else(|| (line_no, format!("unknown property type `{t}`")))
                };
                let (kind, name) = match rest[..] {
                    ["list", count, item, name] => {
                        let count = type_of(count)?;
                        if !count.is_int() {
                            return err(format!(
                                "list `{name}`: its count type `{}` is not an integer type",
                                count.name()
                            ));
                        }
                        (Kind::List { count, item: type_of(item)? }, name)
                    }
                    ["list", ..] => {
                        return err("`property list` needs a count type, an item type and a name".into());
                    }
                    [ty, name] => (Kind::Scalar(type_of(ty)?), name),
                    _ => return err("`property` needs a type and a name".into()),
                };
                if element.position(name).is_some() {
                    return err(format!("element `{}`: duplicate property `{name}`", element.name));
                }
                element.props.push(Property { name: name.to_string(), kind });
            }
            "end_header" => {
                if !rest.is_empty() {
                    return err("excess tokens after `end_header`".into());
                }
                let Some(format) = format else {
                    return err("the header has no `format` line".into());
                };
                return Ok(Header { format, elements, data_start: pos, lines: line_no });
            }
            other => return err(format!("unknown header keyword `{other}`")),
        }
    }
}

/// A number as read, before conversion to what the mesh needs.
#[derive(Clone, Copy, Debug)]
enum Num {
    Int(i128),
    Float(f64),
}

impl Num {
    fn as_f64(self) -> f64 {
        match self {
            Num::Int(i) => i as f64,
            Num::Float(f) => f,
        }
    }
}

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Num::Int(i) => write!(f, "{i}"),
            Num::Float(x) => write!(f, "{x}"),
        }
    }
}

/// The records' data, ASCII or binary.
trait Source {
    /// Reads one value of type `ty`; the error is the problem (without the field).
    fn read(&mut self, ty: Scalar) -> Result<Num, String>;
    /// Skips `records` records of `size` bytes each (binary), or reads and drops them.
    fn skip_fixed(&mut self, element: &Element, records: u64, size: usize) -> Result<(), String>;
    /// Bytes not yet read.
    fn remaining(&self) -> usize;
    /// Whether values are text (ASCII) rather than packed bytes.
    fn is_text(&self) -> bool;
    /// An error if anything but whitespace (ASCII) or nothing (binary) is left.
    fn finish(&mut self) -> Result<(), String>;
}

struct Binary<'a> {
    bytes: &'a [u8],
    pos: usize,
    big_endian: bool,
    /// File offset of `bytes[0]`, for messages.
    base: usize,
}

impl Binary<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let end = self.pos.checked_add(N);
        match end.and_then(|end| self.bytes.get(self.pos..end)) {
            Some(b) => {
                let mut a = [0u8; N];
                a.copy_from_slice(b);
                if self.big_endian {
                    a.reverse();
                }
                self.pos += N;
                Ok(a)
            }
            None => Err(format!(
                "the file ends at byte {} ({N} bytes needed at byte {})",
                self.base + self.bytes.len(),
                self.base + self.pos
            )),
        }
    }
}

impl Source for Binary<'_> {
    fn read(&mut self, ty: Scalar) -> Result<Num, String> {
        Ok(match ty {
            Scalar::I8 => Num::Int(i8::from_le_bytes(self.take()?).into()),
            Scalar::U8 => Num::Int(u8::from_le_bytes(self.take()?).into()),
            Scalar::I16 => Num::Int(i16::from_le_bytes(self.take()?).into()),
            Scalar::U16 => Num::Int(u16::from_le_bytes(self.take()?).into()),
            Scalar::I32 => Num::Int(i32::from_le_bytes(self.take()?).into()),
            Scalar::U32 => Num::Int(u32::from_le_bytes(self.take()?).into()),
            Scalar::I64 => Num::Int(i64::from_le_bytes(self.take()?).into()),
            Scalar::U64 => Num::Int(u64::from_le_bytes(self.take()?).into()),
            Scalar::F16 => Num::Float(half_to_f32(u16::from_le_bytes(self.take()?)).into()),
            Scalar::F32 => Num::Float(f32::from_le_bytes(self.take()?).into()),
            Scalar::F64 => Num::Float(f64::from_le_bytes(self.take()?)),
        })
    }

    fn skip_fixed(&mut self, _: &Element, records: u64, size: usize) -> Result<(), String> {
        let bytes = usize::try_from(records).ok().and_then(|r| r.checked_mul(size));
        match bytes.filter(|&b| b <= self.remaining()) {
            Some(b) => {
                self.pos += b;
                Ok(())
            }
            None => Err(format!(
                "{records} records of {size} bytes do not fit in the {} bytes left",
                self.remaining()
            )),
        }
    }

    fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    fn is_text(&self) -> bool {
        false
    }

    fn finish(&mut self) -> Result<(), String> {
        match self.remaining() {
            0 => Ok(()),
            n => Err(format!(
                "{n} bytes of trailing content after the last element, from byte {}",
                self.base + self.pos
            )),
        }
    }
}

struct Ascii<'a> {
    text: &'a [u8],
    pos: usize,
    /// Line of the last token read (1-based, in the whole file).
    line: usize,
}

impl<'a> Ascii<'a> {
    /// The next whitespace-separated token, `None` at the end.
    fn token(&mut self) -> Option<&'a [u8]> {
        let text = self.text;
        while let Some(&b) = text.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while text.get(self.pos).is_some_and(|b| !b.is_ascii_whitespace()) {
            self.pos += 1;
        }
        text.get(start..self.pos).filter(|t| !t.is_empty())
    }
}

impl Source for Ascii<'_> {
    fn read(&mut self, ty: Scalar) -> Result<Num, String> {
        let Some(token) = self.token() else {
            return Err(format!("the file ends where a `{}` value is expected", ty.name()));
        };
        let text = String::from_utf8_lossy(token);
        let bad =
            || format!("`{}` is not a `{}` value", text.chars().take(40).collect::<String>(), ty.name());
        if ty.is_int() {
            let v: i128 = text.parse().map_err(|_| bad())?;
            let (lo, hi) = ty.range();
            if v < lo || v > hi {
                return Err(format!("{v} does not fit in a `{}`", ty.name()));
            }
            Ok(Num::Int(v))
        } else {
            text.parse::<f64>().map(Num::Float).map_err(|_| bad())
        }
    }

    fn skip_fixed(&mut self, element: &Element, records: u64, _: usize) -> Result<(), String> {
        for _ in 0..records {
            for p in &element.props {
                if let Kind::Scalar(s) = p.kind {
                    self.read(s).map_err(|e| format!("property `{}`: {e}", p.name))?;
                }
            }
        }
        Ok(())
    }

    fn remaining(&self) -> usize {
        self.text.len().saturating_sub(self.pos)
    }

    fn is_text(&self) -> bool {
        true
    }

    fn finish(&mut self) -> Result<(), String> {
        match self.token() {
            None => Ok(()),
            Some(t) => Err(format!(
                "trailing content after the last element: `{}`",
                String::from_utf8_lossy(t).chars().take(40).collect::<String>()
            )),
        }
    }
}

/// What a vertex property is used for.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Role {
    /// Slot in the record's value array: x y z nx ny nz u v.
    Slot(usize),
    Drop,
}

fn read_body(r: &mut impl Source, header: &Header) -> Result<MeshData, String> {
    let vertex_count = match header.elements.iter().find(|e| e.name == "vertex") {
        Some(e) => e.count,
        None => return Err("no `element vertex` in the header".into()),
    };
    let mut mesh = MeshData::default();
    for element in &header.elements {
        let min = element.min_size(header.format);
        let fits = (element.count as u128) * (min as u128) <= r.remaining() as u128;
        if !fits {
            return Err(format!(
                "element `{}` claims {} records of at least {min} bytes each, but {} bytes follow",
                element.name,
                element.count,
                r.remaining()
            ));
        }
        match element.name.as_str() {
            "vertex" => read_vertices(r, element, &mut mesh)?,
            "face" => read_faces(r, element, vertex_count, &mut mesh)?,
            _ if element.props.is_empty() => {}
            _ => skip_element(r, element)?,
        }
    }
    r.finish()?;
    Ok(mesh)
}

/// Reads one list's items, each checked by `item`, with the record named by `at`.
fn read_list(
    r: &mut impl Source,
    count: Scalar,
    item_ty: Scalar,
    at: &dyn Fn() -> String,
    mut item: impl FnMut(Num) -> Result<(), String>,
) -> Result<u64, String> {
    let n = match r.read(count).map_err(|e| format!("{}, list count: {e}", at()))? {
        Num::Int(n) if n >= 0 => n as u64,
        Num::Int(n) => return Err(format!("{}: negative list count {n}", at())),
        Num::Float(_) => return Err(format!("{}: list count is not an integer", at())),
    };
    for i in 0..n {
        let v = r.read(item_ty).map_err(|e| format!("{}, list item {i} of {n}: {e}", at()))?;
        item(v)?;
    }
    Ok(n)
}

fn read_vertices(r: &mut impl Source, element: &Element, mesh: &mut MeshData) -> Result<(), String> {
    let has = |n: &str| element.position(n).is_some_and(|i| matches!(element.props[i].kind, Kind::Scalar(_)));
    for axis in ["x", "y", "z"] {
        if !has(axis) {
            return Err(format!("element `vertex` has no scalar property `{axis}`"));
        }
    }
    let normals = has("nx") && has("ny") && has("nz");
    let uv_names =
        [("texture_u", "texture_v"), ("s", "t"), ("u", "v")].into_iter().find(|(u, v)| has(u) && has(v));
    let roles: Vec<Role> = element
        .props
        .iter()
        .map(|p| {
            let name = p.name.as_str();
            let slot = match name {
                "x" => Some(0),
                "y" => Some(1),
                "z" => Some(2),
                "nx" if normals => Some(3),
                "ny" if normals => Some(4),
                "nz" if normals => Some(5),
                _ => match uv_names {
                    Some((u, _)) if name == u => Some(6),
                    Some((_, v)) if name == v => Some(7),
                    _ => None,
                },
            };
            match (slot, p.kind) {
                (Some(s), Kind::Scalar(_)) => Role::Slot(s),
                _ => Role::Drop,
            }
        })
        .collect();
    // At most `remaining` records, as checked by the caller.
    let count = element.count as usize;
    mesh.positions.reserve_exact(count);
    if normals {
        mesh.normals.reserve_exact(count);
    }
    if uv_names.is_some() {
        mesh.uvs.reserve_exact(count);
    }
    for v in 0..count {
        let mut values = [0f32; 8];
        for (p, role) in element.props.iter().zip(&roles) {
            let at = || format!("element `vertex` #{v}, property `{}`", p.name);
            match p.kind {
                Kind::Scalar(ty) => {
                    let value = r.read(ty).map_err(|e| format!("{}: {e}", at()))?.as_f64() as f32;
                    if let Role::Slot(s) = *role {
                        if !value.is_finite() {
                            return Err(format!("{}: {value} is not a finite f32", at()));
                        }
                        values[s] = value;
                    }
                }
                Kind::List { count, item } => {
                    read_list(r, count, item, &at, |_| Ok(()))?;
                }
            }
        }
        let [x, y, z, nx, ny, nz, u, w] = values;
        mesh.positions.push(Vec3::new(x, y, z));
        if normals {
            mesh.normals.push(Vec3::new(nx, ny, nz));
        }
        if uv_names.is_some() {
            mesh.uvs.push(Vec2::new(u, w));
        }
    }
    Ok(())
}

fn read_faces(
    r: &mut impl Source,
    element: &Element,
    vertex_count: u64,
    mesh: &mut MeshData,
) -> Result<(), String> {
    let list = match (element.position("vertex_indices"), element.position("vertex_index")) {
        (Some(_), Some(_)) => {
            return Err("element `face` has both `vertex_indices` and `vertex_index`".into());
        }
        (Some(i), None) | (None, Some(i)) => i,
        (None, None) => return Err("element `face` has no `vertex_indices` list".into()),
    };
    let Kind::List { count: count_ty, item } = element.props[list].kind else {
        return Err(format!("element `face`: `{}` is not a list", element.props[list].name));
    };
    if !item.is_int() {
        return Err(format!(
            "element `face`: `{}` has non-integer items (`{}`)",
            element.props[list].name,
            item.name()
        ));
    }
    // A face that reads takes at least a count and three indices (ASCII: one byte each), so
    // the triangles' first allocation is at most three times the bytes left.
    let smallest_face = match r.is_text() {
        true => 4,
        false => count_ty.size() + 3 * item.size(),
    };
    mesh.triangles.reserve((element.count as usize).min(r.remaining() / smallest_face));
    let mut corners: Vec<u32> = Vec::new();
    for f in 0..element.count {
        for (i, p) in element.props.iter().enumerate() {
            let at = || format!("element `face` #{f}, property `{}`", p.name);
            match p.kind {
                Kind::Scalar(ty) => {
                    r.read(ty).map_err(|e| format!("{}: {e}", at()))?;
                }
                Kind::List { count, item } if i == list => {
                    corners.clear();
                    let n = read_list(r, count, item, &at, |v| {
                        let index = match v {
                            Num::Int(i) if i >= 0 && (i as u128) < vertex_count as u128 => i as u32,
                            other => {
                                return Err(format!(
                                    "face {f}: vertex index {other} is out of range ({vertex_count} vertices)"
                                ));
                            }
                        };
                        corners.push(index);
                        Ok(())
                    })?;
                    let (Some(&first), true) = (corners.first(), n >= 3) else {
                        return Err(format!("face {f} has {n} vertices; a face needs at least 3"));
                    };
                    mesh.triangles.extend(corners.windows(2).skip(1).map(|w| [first, w[0], w[1]]));
                }
                Kind::List { count, item } => {
                    read_list(r, count, item, &at, |_| Ok(()))?;
                }
            }
        }
    }
    Ok(())
}

fn skip_element(r: &mut impl Source, element: &Element) -> Result<(), String> {
    if let Some(size) = element.fixed_size() {
        return r
            .skip_fixed(element, element.count, size)
            .map_err(|e| format!("element `{}`: {e}", element.name));
    }
    for k in 0..element.count {
        for p in &element.props {
            let at = || format!("element `{}` #{k}, property `{}`", element.name, p.name);
            match p.kind {
                Kind::Scalar(ty) => {
                    r.read(ty).map_err(|e| format!("{}: {e}", at()))?;
                }
                Kind::List { count, item } => {
                    read_list(r, count, item, &at, |_| Ok(()))?;
                }
            }
        }
    }
    Ok(())
}

/// An IEEE 754 half-precision value.
fn half_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0f32 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1F);
    let mant = f32::from(h & 0x3FF);
    match exp {
        0 => sign * mant * 2f32.powi(-24),
        31 if mant == 0.0 => sign * f32::INFINITY,
        31 => f32::NAN,
        e => sign * (1.0 + mant / 1024.0) * 2f32.powi(e - 15),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mesh_data::mutation::{Input, survive};
    use std::path::Path;

    fn read(bytes: &[u8]) -> Result<MeshData, SceneError> {
        read_ply_from_bytes(bytes, Path::new("t.ply"))
    }

    fn err(bytes: &[u8]) -> String {
        read(bytes).unwrap_err().to_string()
    }

    /// A value of a binary record.
    #[derive(Clone, Copy)]
    enum V {
        U8(u8),
        I16(i16),
        I32(i32),
        U32(u32),
        F32(f32),
        F64(f64),
    }

    fn binary(big_endian: bool, header: &str, values: &[V]) -> Vec<u8> {
        let order = if big_endian { "binary_big_endian" } else { "binary_little_endian" };
        let mut out = header.replace("FORMAT", &format!("format {order} 1.0")).into_bytes();
        for v in values {
            let (le, be): (Vec<u8>, Vec<u8>) = match *v {
                V::U8(x) => (vec![x], vec![x]),
                V::I16(x) => (x.to_le_bytes().into(), x.to_be_bytes().into()),
                V::I32(x) => (x.to_le_bytes().into(), x.to_be_bytes().into()),
                V::U32(x) => (x.to_le_bytes().into(), x.to_be_bytes().into()),
                V::F32(x) => (x.to_le_bytes().into(), x.to_be_bytes().into()),
                V::F64(x) => (x.to_le_bytes().into(), x.to_be_bytes().into()),
            };
            out.extend(if big_endian { be } else { le });
        }
        out
    }

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment made by hand\nobj_info nothing\n\
        element vertex 5\nproperty float x\nproperty float y\nproperty float z\n\
        property float nx\nproperty float ny\nproperty float nz\nproperty float confidence\n\
        property float u\nproperty float v\n\
        element face 2\nproperty list uchar int vertex_indices\nproperty uchar flags\n\
        element edge 2\nproperty int vertex1\nproperty list uchar int more\n\
        end_header\n\
        0 0 0 0 0 1 0.5 0 0\n1 0 0 0 0 1 0.5 1 0\n1 1 0 0 0 1 0.5 1 1\n\
        0 1 0 0 0 1 0.5 0 1\n2 2 2 1 0 0 0 0.25 0.75\n\
        4 0 1 2 3 7\n3 1 4 2 0\n\
        0 2 1 5\n1 0\n";

    /// The mesh of `ASCII` and of the binary files below.
    fn expected() -> MeshData {
        MeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::splat(2.0)],
            normals: vec![Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Z, Vec3::X],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y, Vec2::new(0.25, 0.75)],
            triangles: vec![[0, 1, 2], [0, 2, 3], [1, 4, 2]],
            face_normals: false,
        }
    }

    const BINARY_HEADER: &str = "ply\r\nFORMAT\r\ncomment binary\r\n\
        element vertex 5\r\nproperty double x\r\nproperty float y\r\nproperty int z\r\n\
        property list uchar short junk\r\nproperty float nx\r\nproperty float ny\r\n\
        property float nz\r\nproperty uchar red\r\nproperty float s\r\nproperty float t\r\n\
        element material 1\r\nproperty float roughness\r\n\
        element face 2\r\nproperty uchar flags\r\nproperty list uchar uint vertex_index\r\n\
        element edge 2\r\nproperty list int int ends\r\nend_header\r\n";

    fn binary_values() -> Vec<V> {
        use V::*;
        let mut v = Vec::new();
        let verts: [([f32; 3], [f32; 3], [f32; 2]); 5] = [
            ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0]),
            ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0]),
            ([1.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0]),
            ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0]),
            ([2.0, 2.0, 2.0], [1.0, 0.0, 0.0], [0.25, 0.75]),
        ];
        for (k, (p, n, uv)) in verts.into_iter().enumerate() {
            v.extend([F64(p[0].into()), F32(p[1]), I32(p[2] as i32), U8(k as u8 % 3)]);
            v.extend((0..k % 3).map(|i| I16(-(i as i16))));
            v.extend([F32(n[0]), F32(n[1]), F32(n[2]), U8(200), F32(uv[0]), F32(uv[1])]);
        }
        v.push(F32(0.5)); // material
        v.extend([U8(1), U8(4), U32(0), U32(1), U32(2), U32(3)]);
        v.extend([U8(0), U8(3), U32(1), U32(4), U32(2)]);
        v.extend([I32(2), I32(0), I32(1), I32(0)]); // edges: a 2-list and an empty list
        v
    }

    #[test]
    fn reads_ascii_with_comments_skipped_properties_elements_and_quads() {
        assert_eq!(read(ASCII.as_bytes()).unwrap(), expected());
        let crlf = ASCII.replace('\n', "\r\n");
        assert_eq!(read(crlf.as_bytes()).unwrap(), expected());
        // Line breaks inside the data carry no meaning (as in Mitsuba).
        let joined = ASCII.replace("0.5 0 1\n2 2 2", "0.5 0 1 2 2 2");
        assert_eq!(read(joined.as_bytes()).unwrap(), expected());
    }

    #[test]
    fn reads_binary_little_and_big_endian() {
        for big in [false, true] {
            let bytes = binary(big, BINARY_HEADER, &binary_values());
            assert_eq!(read(&bytes).unwrap(), expected(), "big endian: {big}");
        }
    }

    #[test]
    fn positions_only_and_no_faces_and_other_uv_names() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty uchar x\nproperty short y\n\
            property half z\nproperty float texture_u\nproperty float texture_v\nproperty float u\n\
            property float v\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n\
            255 -3 0.5 0.1 0.2 9 9\n0 0 0 0 0 9 9\n1 1 1 0 0 9 9\n";
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.positions[0], Vec3::new(255.0, -3.0, 0.5), "integers at their value");
        assert_eq!(m.uvs[0], Vec2::new(0.1, 0.2), "texture_u/texture_v before u/v");
        assert!(m.normals.is_empty() && m.triangles.is_empty());
        // A half-precision binary value.
        let h =
            "ply\nFORMAT\nelement vertex 1\nproperty half x\nproperty half y\nproperty half z\nend_header\n";
        let mut bytes = binary(false, h, &[]);
        bytes.extend([0x00, 0x3C, 0x00, 0xC0, 0x00, 0x35]); // 1, -2, 0.3125
        assert_eq!(read(&bytes).unwrap().positions, [Vec3::new(1.0, -2.0, 0.3125)]);
    }

    #[test]
    fn refuses_malformed_files_with_the_place_and_the_problem() {
        let tri = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
            property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
            0 0 0\n1 0 0\n0 1 0\nFACE\n";
        let with = |face: &str| tri.replace("FACE", face);
        let cases: Vec<(String, &str)> = vec![
            (with("3 0 1 3"), "line 13: face 0: vertex index 3 is out of range (3 vertices)"),
            (with("3 0 -1 2"), "face 0: vertex index -1 is out of range"),
            (with("2 0 1"), "face 0 has 2 vertices; a face needs at least 3"),
            (with("3 0 1"), "the file ends where a `int` value is expected"),
            (with("3 0 1 2 9"), "trailing content after the last element: `9`"),
            (with("300 0 1 2"), "300 does not fit in a `uchar`"),
            (with("3 0 1 2.5"), "`2.5` is not a `int` value"),
            (
                tri.replace("1 0 0\n", "1 nan 0\n").replace("FACE", "3 0 1 2"),
                "line 11: element `vertex` #1, property `y`: NaN is not a finite f32",
            ),
            (tri.replace("1 0 0\n", "1 1e39 0\n").replace("FACE", "3 0 1 2"), "inf is not a finite f32"),
            (
                tri.replace("vertex 3", "vertex 1000000000000"),
                "element `vertex` claims 1000000000000 records",
            ),
            (tri.replace("float x", "float q"), "element `vertex` has no scalar property `x`"),
            (tri.replace("vertex_indices", "corners"), "element `face` has no `vertex_indices` list"),
            (tri.replace("float z", "float32x z"), "line 6: unknown property type `float32x`"),
            (tri.replace("ascii 1.0", "ascii 2.0"), "unknown PLY version `2.0`"),
            (tri.replace("end_header\n", ""), "line 9: unknown header keyword `0`"),
            (tri[..tri.find("end_header").unwrap()].into(), "line 8: the header has no `end_header` line"),
            (tri.replace("ply\n", "plx\n"), "line 1: not a PLY file"),
            (tri.replace("element face 1", "element vertex 1"), "duplicate element `vertex`"),
            (tri.replace("float y", "float x"), "duplicate property `x`"),
            (tri.replace("list uchar int", "list float int"), "count type `float` is not an integer type"),
            (tri.replace("list uchar int", "list uchar float"), "non-integer items"),
            (
                tri.replace("property float z\n", "property float z\nwhatever\n"),
                "unknown header keyword `whatever`",
            ),
            ("".into(), "empty file"),
        ];
        let missing = read_ply(Path::new("/nonexistent/t.ply")).unwrap_err();
        assert!(matches!(missing, SceneError::Io { .. }), "{missing}");
        for (text, want) in cases {
            let e = err(text.as_bytes());
            assert!(e.starts_with("t.ply: ") && e.contains(want), "{e:?} lacks {want:?}");
        }
        // Binary: the byte offset and the element.
        let h = "ply\nFORMAT\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
        let e = err(&binary(false, h, &[V::F32(1.0), V::F32(2.0)]));
        assert!(
            e.contains("element `vertex` claims 1 records of at least 12 bytes each, but 8 bytes follow"),
            "{e}"
        );
        let listed = h.replace("float z\n", "float z\nproperty list uchar float extra\n");
        let e = err(&binary(false, &listed, &[V::F32(1.0), V::F32(2.0), V::F32(3.0), V::U8(3), V::F32(4.0)]));
        let want = "element `vertex` #0, property `extra`, list item 1 of 3: the file ends at byte 164 (4 bytes needed at byte 164)";
        assert!(e.contains(want) && !e.contains("line"), "{e}");
        let h2 = h.replace("vertex 1", "vertex 4294967296000");
        let e = err(&binary(true, &h2, &[V::F32(1.0); 3]));
        assert!(
            e.contains("claims 4294967296000 records of at least 12 bytes each, but 12 bytes follow"),
            "{e}"
        );
        let e = err(&binary(false, h, &[V::F32(1.0); 4]));
        assert!(e.contains("4 bytes of trailing content"), "{e}");
        // A list count of 2^32 - 1 items in a short file ends at the end of the data.
        let h3 = "ply\nFORMAT\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n\
            element face 1\nproperty list uint int vertex_indices\nend_header\n";
        let e = err(&binary(false, h3, &[V::U32(u32::MAX), V::I32(0)]));
        assert!(e.contains("face 0: vertex index 0 is out of range (0 vertices)"), "{e}");
    }

    fn inputs() -> Vec<Input<'static>> {
        vec![
            ("ascii", ASCII.as_bytes().to_vec(), true),
            ("binary_little_endian", binary(false, BINARY_HEADER, &binary_values()), false),
            ("binary_big_endian", binary(true, BINARY_HEADER, &binary_values()), false),
            ("binary header as text", binary(false, BINARY_HEADER, &binary_values()), true),
        ]
    }

    fn mutations(cases: usize, seed: u64) {
        let size = |m: &MeshData| m.positions.len() + m.triangles.len();
        let (ok, err) = survive("ply", &inputs(), cases, seed, 1, read, size);
        assert!(ok > 0 && err > 0, "mutations should give both results: {ok} Ok, {err} Err");
    }

    #[test]
    fn survives_4000_mutations() {
        mutations(4000, 1);
    }

    /// On demand: `cargo test --release -- --ignored mesh_readers_survive_100k_mutations`.
    #[test]
    #[ignore]
    fn mesh_readers_survive_100k_mutations_ply() {
        mutations(100_000, 0x5EED);
    }
}
