//! PLY meshes: ASCII, binary little-endian and binary big-endian, read with `ply-rs-bw`
//! (the maintained fork of `ply-rs`: both byte orders, list properties of every integer
//! type, header-first reading and element-by-element payload reading).
//!
//! Read: the `vertex` element's `x y z` (any numeric type), `nx ny nz`, texture coordinates
//! (`u v`, `s t` or `texture_u texture_v`), colours (`red green blue`: integers are 0-255
//! and floats 0-1, both sRGB-encoded as every PLY writer we know stores them, so they are
//! decoded to linear); the `face` element's `vertex_indices` (or `vertex_index`) list, fanned
//! into triangles. Every other property is skipped; other elements are skipped with a warning.
//!
//! Errors name the file and, for ASCII, the line; for binary files the element, counted from
//! 0 as PLY indices count ("vertex 17", "face 3"). The header's counts are checked against the
//! file's length, and the memory the mesh needs against the load's [`LoadBudget`], before anything is
//! allocated for the payload.

use super::{FileMesh, MeshFile};
use crate::film::srgb_to_linear;
use crate::geometry::TriMesh;
use crate::memory::LoadBudget;
use crate::scene::{SceneError, input};
use glam::{Vec2, Vec3};
use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult, PropertyType};
use std::io::{BufRead, BufReader, ErrorKind, Read};
use std::path::Path;

/// Bytes per vertex while loading: position (12), normal (12), texture coordinates (8) and
/// colour (12) when the file has them, as the arrays the mesh keeps (reserved exactly).
fn vertex_bytes(normals: bool, uvs: bool, colors: bool) -> u64 {
    12 + 12 * normals as u64 + 8 * uvs as u64 + 12 * colors as u64
}

/// Bytes per triangle: the index triple (12) and, after loading, the degenerate-triangle
/// pass's list (8 per dropped triangle, bounded by this margin). The file is streamed, so its
/// size does not count. Measured: loading a binary PLY of 501,264 vertices and 999,698
/// triangles (as triangles or as quads) peaks 16 MB above the process's 11 MB baseline; the
/// estimate is 26 MB.
const TRIANGLE_BYTES: u64 = 20;

/// Loads a PLY file: the file is streamed, not read whole.
pub(super) fn load(path: &Path, budget: &LoadBudget) -> Result<MeshFile, SceneError> {
    let (file, len) = input::open(path)?;
    // No more than its size says (a /proc file says 0).
    parse(file.take(len), len, path, budget)
}

/// Parses PLY data of `len` bytes from `source` within `budget`; `path` names it in messages.
pub fn parse(source: impl Read, len: u64, path: &Path, budget: &LoadBudget) -> Result<MeshFile, SceneError> {
    let err = |line: Option<usize>, msg: String| SceneError::new(path, line, msg);
    let mut reader = Reader::new(BufReader::new(Counting { inner: source, count: 0 }));
    let header = Parser::<Skip>::new().read_header(&mut reader).map_err(|e| {
        let msg = match e.kind() {
            ErrorKind::UnexpectedEof => "PLY header: the file ends before end_header".to_string(),
            _ => format!("PLY header: {}", first_line(&e)),
        };
        err(e.line(), msg)
    })?;
    // Bytes of the header, read so far by the parser (the buffered rest is payload).
    let header_len = {
        let buf = reader.get_ref();
        buf.get_ref().count - buf.buffer().len() as u64
    };
    // The parser's line is the next one to read.
    let header_lines = reader.line().saturating_sub(1);
    let layout = Layout::of(&header).map_err(|m| err(None, format!("PLY header: {m}")))?;

    // Every element takes at least some bytes: a header whose counts the file cannot hold is
    // refused before anything is allocated for them.
    let payload = len.saturating_sub(header_len);
    let mut least = 0u64;
    for (_, def) in &header.elements {
        least = least.saturating_add((def.count as u64).saturating_mul(min_element_bytes(def, header.encoding)));
    }
    if least > payload {
        let counts: Vec<String> = header.elements.iter().map(|(n, d)| format!("{} {n}", d.count)).collect();
        return Err(err(
            None,
            format!(
                "PLY header declares {} but the {} bytes after the header can hold fewer (at least {} needed): \
                 wrong counts, or a truncated file",
                counts.join(" and "),
                payload,
                least
            ),
        ));
    }
    let vertex_count = layout.vertices;
    let face_count = layout.faces;
    let per_vertex = vertex_bytes(layout.normals, layout.uvs, layout.colors);
    let estimate = |triangles: u64| {
        (vertex_count as u64).saturating_mul(per_vertex).saturating_add(triangles.saturating_mul(TRIANGLE_BYTES))
    };
    let check = |triangles: u64| {
        budget
            .admit(format!("PLY mesh of {vertex_count} vertices and {triangles} triangles"), estimate(triangles))
            .map_err(|e| err(None, e.to_string()))
    };
    // Each face is at least one triangle; polygons add more, checked as they come.
    let mut checked_triangles = face_count as u64;
    check(checked_triangles)?;

    let mut positions: Vec<Vec3> = Vec::with_capacity(vertex_count);
    let mut normals: Vec<Vec3> = Vec::with_capacity(if layout.normals { vertex_count } else { 0 });
    let mut uvs: Vec<Vec2> = Vec::with_capacity(if layout.uvs { vertex_count } else { 0 });
    let mut colors: Vec<Vec3> = Vec::with_capacity(if layout.colors { vertex_count } else { 0 });
    let mut indices: Vec<[u32; 3]> = Vec::with_capacity(face_count);
    let mut warnings = Vec::new();

    let mut line = header_lines; // the last line read (ASCII)
    let mut text = String::new();
    // What a line (ASCII) or a list (binary) may take: what the budget has left beside the
    // mesh counted so far, so one face of 60 million indices is refused before it is read.
    let headroom = |triangles: u64| {
        budget.available().map_or(usize::MAX, |a| a.saturating_sub(estimate(triangles)).min(usize::MAX as u64) as usize)
    };
    let too_long = |what: String, bytes: u64, triangles: u64| {
        let e = budget.admit(what, estimate(triangles).saturating_add(bytes));
        e.err().map_or_else(|| "more than the memory limit allows".to_string(), |e| e.to_string())
    };
    let big_endian = header.encoding == Encoding::BinaryBigEndian;
    for (name, def) in &header.elements {
        let what = match name.as_str() {
            "vertex" => "vertex",
            "face" => "face",
            _ => {
                warnings.push(format!("{}: PLY element {name:?} ({} entries) ignored", path.display(), def.count));
                name.as_str()
            }
        };
        for k in 0..def.count {
            // Where element k is, for messages: its line (ASCII) or its number (binary).
            let at = |line: usize| -> (Option<usize>, String) {
                match header.encoding {
                    Encoding::Ascii => (Some(line), String::new()),
                    _ => (None, format!("{what} {k}: ")),
                }
            };
            let room = headroom(checked_triangles);
            if header.encoding == Encoding::Ascii {
                text.clear();
                // A line is read into memory whole: at most a quarter of the room (its text, and
                // the values it holds).
                let most = (room / 4).max(4096) as u64;
                let n = reader.get_mut().take(most).read_line(&mut text).map_err(|e| SceneError::io(path, &e))?;
                line += 1;
                if n == 0 {
                    return Err(err(
                        Some(line),
                        format!("the file ends after {k} of {} {what} lines (truncated?)", def.count),
                    ));
                }
                if n as u64 == most && !text.ends_with('\n') {
                    let what = format!("a {what} line of more than {most} bytes");
                    return Err(err(Some(line), too_long(what, (most + 1).saturating_mul(4), checked_triangles)));
                }
            }
            // A list's values as they are read, as the face's indices and as triangles.
            let max_list = room / LIST_ITEM_BYTES as usize;
            let mut element = |e: &mut dyn FnMut(&mut dyn Read) -> Result<(), Bad>| e(reader.get_mut());
            let parse_error = |e: Bad| {
                let (l, prefix) = at(line);
                let reason = match e {
                    Bad::Eof => format!("the file ends early, in {what} {k} of {} (truncated?)", def.count),
                    Bad::Io(e) => format!("cannot read: {e}"),
                    Bad::Text(m) => format!("{what}: {m}"),
                    Bad::Long(n) => {
                        let bytes = (n as u64).saturating_mul(LIST_ITEM_BYTES);
                        too_long(format!("a {what} of {n} values"), bytes, checked_triangles)
                    }
                };
                err(l, format!("{prefix}{reason}"))
            };
            match what {
                "vertex" => {
                    let mut v = None;
                    element(&mut |r| {
                        v = Some(match header.encoding {
                            Encoding::Ascii => ascii_element::<Vertex>(&text, def, max_list)?,
                            _ => binary_element::<Vertex>(r, def, big_endian, max_list)?,
                        });
                        Ok(())
                    })
                    .map_err(parse_error)?;
                    let v = v.unwrap_or_default();
                    let (l, prefix) = at(line);
                    let finite = |x: &[f32], what: &str| -> Result<(), SceneError> {
                        match x.iter().find(|v| !v.is_finite()) {
                            Some(v) => Err(err(l, format!("{prefix}vertex {what}: {v} is not a finite number"))),
                            None => Ok(()),
                        }
                    };
                    // Non-finite positions only make their triangles degenerate (dropped with a
                    // warning below); other attributes have no such remedy.
                    positions.push(Vec3::from(v.p));
                    if layout.normals {
                        finite(&v.n, "normal")?;
                        normals.push(Vec3::from(v.n));
                    }
                    if layout.uvs {
                        finite(&v.uv, "texture coordinate")?;
                        uvs.push(Vec2::from(v.uv));
                    }
                    if layout.colors {
                        finite(&v.rgb, "colour")?;
                        if let Some(c) = v.rgb.iter().find(|&&c| !(0.0..=1.0).contains(&c)) {
                            return Err(err(
                                l,
                                format!("{prefix}vertex colour: {c} is outside 0-1 (0-255 for integers)"),
                            ));
                        }
                        colors.push(Vec3::from(v.rgb).map(srgb_to_linear));
                    }
                }
                "face" => {
                    let mut f = None;
                    element(&mut |r| {
                        f = Some(match header.encoding {
                            Encoding::Ascii => ascii_element::<Face>(&text, def, max_list)?,
                            _ => binary_element::<Face>(r, def, big_endian, max_list)?,
                        });
                        Ok(())
                    })
                    .map_err(parse_error)?;
                    let f = f.unwrap_or_default();
                    let (l, prefix) = at(line);
                    if f.indices.len() < 3 {
                        return Err(err(
                            l,
                            format!("{prefix}a face needs at least 3 vertices, found {}", f.indices.len()),
                        ));
                    }
                    if let Some(&i) = f.indices.iter().find(|&&i| i < 0 || i >= vertex_count as i64) {
                        return Err(err(
                            l,
                            format!(
                                "{prefix}face vertex index {i} is out of range (the file has {vertex_count} vertices, 0 to {})",
                                vertex_count as i64 - 1
                            ),
                        ));
                    }
                    let added = f.indices.len() - 2;
                    if (indices.len() + added) as u64 > checked_triangles {
                        checked_triangles = ((indices.len() + added) as u64).max(checked_triangles * 2);
                        check(checked_triangles)?;
                    }
                    let i0 = f.indices[0] as u32;
                    for w in f.indices[1..].windows(2) {
                        indices.push([i0, w[0] as u32, w[1] as u32]);
                    }
                }
                _ => {
                    element(&mut |r| {
                        match header.encoding {
                            Encoding::Ascii => ascii_element::<Skip>(&text, def, max_list)?,
                            _ => binary_element::<Skip>(r, def, big_endian, max_list)?,
                        };
                        Ok(())
                    })
                    .map_err(parse_error)?;
                }
            }
        }
    }
    if indices.is_empty() {
        return Err(err(None, "no triangles: the file has no faces".into()));
    }
    let name = path.file_stem().map_or_else(|| "ply".to_string(), |s| s.to_string_lossy().into_owned());
    let mesh = TriMesh::new(name, positions, indices, normals, uvs).map_err(|e| err(None, e.to_string()))?;
    let mut meshes = Vec::new();
    if let Some(m) = super::keep_hittable(path, mesh, &mut warnings) {
        budget.keep(m.heap_bytes() + size_of_val(&colors[..]) as u64);
        budget.keep_primitives(m.triangle_count() as u64, 0);
        meshes.push(FileMesh { mesh: m, instances: Vec::new(), material: None, colors });
    } else {
        return Err(err(None, "no triangles: every face is degenerate".into()));
    }
    Ok(MeshFile { meshes, materials: Vec::new(), camera: None, point_lights: Vec::new(), warnings, inputs: Vec::new() })
}

/// Bytes a list value may take while read: as a `Property` (32), as the face's index (8), as
/// part of a triangle (12), with room to spare.
const LIST_ITEM_BYTES: u64 = 64;

/// Why an element could not be read.
enum Bad {
    /// The file ends inside it.
    Eof,
    Io(std::io::Error),
    /// A value that is not what the header says.
    Text(String),
    /// A list of this many values, more than memory allows.
    Long(usize),
}

/// One element from binary data (`big_endian` or not): the header's properties in order, each
/// list's values counted against `max_list` before any is read (read here rather than by the
/// crate, which takes a list's length on trust).
fn binary_element<E: PropertyAccess>(
    r: &mut dyn Read,
    def: &ElementDef,
    big_endian: bool,
    max_list: usize,
) -> Result<E, Bad> {
    use ply_rs_bw::ply::ScalarType as S;
    let scalar = |r: &mut dyn Read, t: &S| -> Result<Property, Bad> {
        let mut b = [0u8; 8];
        let n = scalar_size(t) as usize;
        r.read_exact(&mut b[..n])
            .map_err(|e| if e.kind() == ErrorKind::UnexpectedEof { Bad::Eof } else { Bad::Io(e) })?;
        macro_rules! num {
            ($ty:ty, $variant:ident) => {{
                let bytes: [u8; size_of::<$ty>()] = b[..size_of::<$ty>()].try_into().unwrap();
                Property::$variant(if big_endian { <$ty>::from_be_bytes(bytes) } else { <$ty>::from_le_bytes(bytes) })
            }};
        }
        Ok(match t {
            S::Char => num!(i8, Char),
            S::UChar => num!(u8, UChar),
            S::Short => num!(i16, Short),
            S::UShort => num!(u16, UShort),
            S::Int => num!(i32, Int),
            S::UInt => num!(u32, UInt),
            S::Float => num!(f32, Float),
            S::Double => num!(f64, Double),
        })
    };
    let mut e = E::new();
    for (name, p) in &def.properties {
        let value = match &p.data_type {
            PropertyType::Scalar(t) => scalar(r, t)?,
            PropertyType::List(count_type, item) => {
                let count = scalar(r, count_type)?;
                let n = list_length(&count).ok_or_else(|| Bad::Text(format!("{name}: a negative list length")))?;
                if n > max_list {
                    return Err(Bad::Long(n));
                }
                let mut items = Vec::with_capacity(n.min(64));
                for _ in 0..n {
                    items.push(scalar(r, item)?);
                }
                list(items, item)
            }
        };
        e.set_property(name, value);
    }
    Ok(e)
}

/// A list's length, from its count property (`None`: negative, or not an integer).
fn list_length(count: &Property) -> Option<usize> {
    match *count {
        Property::Char(v) => usize::try_from(v).ok(),
        Property::Short(v) => usize::try_from(v).ok(),
        Property::Int(v) => usize::try_from(v).ok(),
        Property::UChar(v) => Some(v as usize),
        Property::UShort(v) => Some(v as usize),
        Property::UInt(v) => usize::try_from(v).ok(),
        _ => None,
    }
}

/// One element from its ASCII line: the header's properties in order, whitespace-separated
/// (read here rather than by the crate, whose grammar takes no `nan` or `inf` — values ember
/// must see to report or drop — and whose messages name no property); a list longer than
/// `max_list` is refused before its values are read.
fn ascii_element<E: PropertyAccess>(text: &str, def: &ElementDef, max_list: usize) -> Result<E, Bad> {
    use ply_rs_bw::ply::ScalarType as S;
    let mut e = E::new();
    let mut tokens = text.split_ascii_whitespace();
    let declared = def.properties.len();
    for (name, p) in &def.properties {
        let mut next = || tokens.next().ok_or_else(|| Bad::Text(format!("too few values: {name} is missing")));
        let bad = |s: &str, t: &S| {
            Bad::Text(format!(
                "{name}: {s:?} is not a{} {}",
                if matches!(t, S::Int | S::UInt | S::UChar | S::UShort) { "n" } else { "" },
                type_name(t)
            ))
        };
        let scalar = |s: &str, t: &S| -> Result<Property, Bad> {
            let v = match t {
                S::Char => s.parse().map(Property::Char).ok(),
                S::UChar => s.parse().map(Property::UChar).ok(),
                S::Short => s.parse().map(Property::Short).ok(),
                S::UShort => s.parse().map(Property::UShort).ok(),
                S::Int => s.parse().map(Property::Int).ok(),
                S::UInt => s.parse().map(Property::UInt).ok(),
                S::Float => s.parse().map(Property::Float).ok(),
                S::Double => s.parse().map(Property::Double).ok(),
            };
            v.ok_or_else(|| bad(s, t))
        };
        let value = match &p.data_type {
            PropertyType::Scalar(t) => scalar(next()?, t)?,
            PropertyType::List(count_type, item) => {
                let s = next()?;
                let n: usize = list_length(&scalar(s, count_type)?)
                    .ok_or_else(|| Bad::Text(format!("{name}: list length {s:?} is negative")))?;
                if n > max_list {
                    return Err(Bad::Long(n));
                }
                let mut items = Vec::with_capacity(n.min(64));
                for _ in 0..n {
                    items.push(scalar(next()?, item)?);
                }
                list(items, item)
            }
        };
        e.set_property(name, value);
    }
    if tokens.next().is_some() {
        return Err(Bad::Text(format!("more values than the {declared} properties the header declares")));
    }
    Ok(e)
}

/// Scalar properties of type `t` as one list property.
fn list(items: Vec<Property>, t: &ply_rs_bw::ply::ScalarType) -> Property {
    use ply_rs_bw::ply::ScalarType as S;
    macro_rules! collect {
        ($variant:ident, $list:ident) => {
            Property::$list(
                items.into_iter().filter_map(|p| if let Property::$variant(v) = p { Some(v) } else { None }).collect(),
            )
        };
    }
    match t {
        S::Char => collect!(Char, ListChar),
        S::UChar => collect!(UChar, ListUChar),
        S::Short => collect!(Short, ListShort),
        S::UShort => collect!(UShort, ListUShort),
        S::Int => collect!(Int, ListInt),
        S::UInt => collect!(UInt, ListUInt),
        S::Float => collect!(Float, ListFloat),
        S::Double => collect!(Double, ListDouble),
    }
}

fn type_name(t: &ply_rs_bw::ply::ScalarType) -> &'static str {
    use ply_rs_bw::ply::ScalarType as S;
    match t {
        S::Char => "char",
        S::UChar => "uchar",
        S::Short => "short",
        S::UShort => "ushort",
        S::Int => "int",
        S::UInt => "uint",
        S::Float => "float",
        S::Double => "double",
    }
}

/// The first line of a parser message, without the parser's own "Line N:" (the caller
/// says where).
fn first_line(e: &ParseError) -> String {
    let s = e.to_string();
    let s = match s.strip_prefix("Line ") {
        Some(rest) => rest.split_once(": ").map_or(rest, |(_, m)| m),
        None => &s,
    };
    s.lines().next().unwrap_or("").trim().to_string()
}

/// What the header says the vertices and faces carry.
#[derive(Debug, Default)]
struct Layout {
    vertices: usize,
    faces: usize,
    normals: bool,
    uvs: bool,
    colors: bool,
}

impl Layout {
    fn of(header: &Header) -> Result<Layout, String> {
        let Some(vertex) = header.elements.get("vertex") else {
            return Err("no vertex element".into());
        };
        let scalar = |names: &[&str]| -> Result<bool, String> {
            let found: Vec<&str> = names.iter().copied().filter(|n| vertex.properties.contains_key(*n)).collect();
            if found.is_empty() {
                return Ok(false);
            }
            if found.len() < names.len() {
                return Err(format!("the vertex element has {} but not all of {}", found.join(", "), names.join(", ")));
            }
            match names.iter().find(|n| !matches!(vertex.properties[**n].data_type, PropertyType::Scalar(_))) {
                Some(n) => Err(format!("vertex property {n} is a list, expected a number")),
                None => Ok(true),
            }
        };
        if !scalar(&["x", "y", "z"])? {
            return Err("the vertex element has no x, y, z properties".into());
        }
        let normals = scalar(&["nx", "ny", "nz"])?;
        let mut uvs = false;
        for pair in UV_NAMES {
            uvs |= scalar(pair)?;
        }
        let colors = scalar(&["red", "green", "blue"])?;
        let faces = match header.elements.get("face") {
            None => 0,
            Some(face) => {
                let list = FACE_LISTS.iter().find_map(|n| face.properties.get(*n));
                match list.map(|p| &p.data_type) {
                    Some(PropertyType::List(..)) => {}
                    Some(_) => return Err("the face element's vertex_indices is not a list".into()),
                    None => return Err("the face element has no vertex_indices list".into()),
                }
                face.count
            }
        };
        Ok(Layout { vertices: vertex.count, faces, normals, uvs, colors })
    }
}

/// The names texture coordinates go by, in order of preference.
const UV_NAMES: [&[&str]; 3] = [&["u", "v"], &["s", "t"], &["texture_u", "texture_v"]];

/// The names of a face's vertex list.
const FACE_LISTS: [&str; 2] = ["vertex_indices", "vertex_index"];

/// The fewest bytes one element can take: binary, each scalar's size and each list's count;
/// ASCII, one character and a separator per property.
fn min_element_bytes(def: &ElementDef, encoding: Encoding) -> u64 {
    def.properties
        .iter()
        .map(|(_, p)| match encoding {
            Encoding::Ascii => 2,
            _ => match &p.data_type {
                PropertyType::Scalar(t) | PropertyType::List(t, _) => scalar_size(t),
            },
        })
        .sum::<u64>()
        .max(1)
}

fn scalar_size(t: &ply_rs_bw::ply::ScalarType) -> u64 {
    use ply_rs_bw::ply::ScalarType::*;
    match t {
        Char | UChar => 1,
        Short | UShort => 2,
        Int | UInt | Float => 4,
        Double => 8,
    }
}

/// Counts the bytes read through it, so the header's length is known.
struct Counting<R> {
    inner: R,
    count: u64,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count += n as u64;
        Ok(n)
    }
}

/// The value of a numeric scalar property, and whether it is an integer type.
fn scalar_value(p: &Property) -> Option<(f64, bool)> {
    Some(match *p {
        Property::Char(v) => (v as f64, true),
        Property::UChar(v) => (v as f64, true),
        Property::Short(v) => (v as f64, true),
        Property::UShort(v) => (v as f64, true),
        Property::Int(v) => (v as f64, true),
        Property::UInt(v) => (v as f64, true),
        Property::Float(v) => (v as f64, false),
        Property::Double(v) => (v, false),
        _ => return None,
    })
}

/// One vertex's properties that ember reads.
#[derive(Default)]
struct Vertex {
    p: [f32; 3],
    n: [f32; 3],
    uv: [f32; 2],
    rgb: [f32; 3],
    /// Which texture-coordinate naming set `uv` (index in [`UV_NAMES`]; the first wins).
    uv_from: Option<usize>,
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let Some((v, integer)) = scalar_value(&property) else {
            return PropertyAccessResult::Ignored;
        };
        let slot = match name {
            "x" => &mut self.p[0],
            "y" => &mut self.p[1],
            "z" => &mut self.p[2],
            "nx" => &mut self.n[0],
            "ny" => &mut self.n[1],
            "nz" => &mut self.n[2],
            "red" | "green" | "blue" => {
                let k = ["red", "green", "blue"].iter().position(|&c| c == name).unwrap_or(0);
                // Integers: 0-255 (an unsigned short colour: 0-65535).
                let scale = match property {
                    Property::UShort(_) | Property::Short(_) => 65535.0,
                    _ if integer => 255.0,
                    _ => 1.0,
                };
                self.rgb[k] = (v / scale) as f32;
                return PropertyAccessResult::Set;
            }
            _ => {
                for (set, pair) in UV_NAMES.iter().enumerate() {
                    if let Some(k) = pair.iter().position(|&n| n == name) {
                        if self.uv_from.is_none_or(|s| s >= set) {
                            self.uv_from = Some(set);
                            self.uv[k] = v as f32;
                        }
                        return PropertyAccessResult::Set;
                    }
                }
                return PropertyAccessResult::Ignored;
            }
        };
        *slot = v as f32;
        PropertyAccessResult::Set
    }
}

/// One face's vertex list.
#[derive(Default)]
struct Face {
    indices: Vec<i64>,
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if !FACE_LISTS.contains(&name) {
            return PropertyAccessResult::Ignored;
        }
        self.indices = match property {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            _ => return PropertyAccessResult::UnsupportedType,
        };
        PropertyAccessResult::Set
    }
}

/// An element whose values are read and dropped.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(text: &str) -> Result<MeshFile, SceneError> {
        parse(text.as_bytes(), text.len() as u64, Path::new("t.ply"), &LoadBudget::unlimited())
    }

    const HEAD: &str =
        "ply\nformat ascii 1.0\ncomment x\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n";

    #[test]
    fn ascii_quad_is_fanned() {
        let text = format!(
            "{HEAD}element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"
        );
        let m = parse_str(&text).unwrap();
        assert_eq!(m.meshes.len(), 1);
        assert_eq!(m.meshes[0].mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(m.meshes[0].mesh.normals.is_empty() && m.meshes[0].colors.is_empty());
    }

    #[test]
    fn attributes_are_read_and_others_skipped() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n\
                    property float confidence\nproperty float nx\nproperty float ny\nproperty float nz\n\
                    property float texture_u\nproperty float texture_v\nproperty uchar red\nproperty uchar green\n\
                    property uchar blue\nelement face 1\nproperty list uchar uint vertex_index\nproperty uchar flags\n\
                    element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
                    0 0 0 0.5 0 0 1 0.25 0.75 255 0 0\n1 0 0 0.5 0 0 1 1 0 0 255 0\n0 1 0 0.5 0 0 1 0 1 0 0 255\n\
                    3 0 1 2 7\n0 1\n";
        let m = parse_str(text).unwrap();
        let fm = &m.meshes[0];
        assert_eq!(fm.mesh.normals[0], Vec3::Z);
        assert_eq!(fm.mesh.uvs[0], Vec2::new(0.25, 0.75));
        assert_eq!(fm.colors[0], Vec3::X);
        assert_eq!(fm.colors[2], Vec3::Z);
        assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
        assert!(m.warnings[0].contains("\"edge\""), "{:?}", m.warnings);
    }

    /// A line too long for the memory limit is refused at the limit, not read whole; a list
    /// too long for it before its values are read.
    #[test]
    fn long_lines_and_lists_are_refused_within_the_limit() {
        let budget = LoadBudget::new(crate::memory::MemoryLimit::bytes(1_000_000));
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                    element face 1\nproperty list uint int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
        let long = format!("{head}1000000{}\n", " 0".repeat(1_000_000));
        let e = parse(long.as_bytes(), long.len() as u64, Path::new("t.ply"), &budget).unwrap_err();
        assert_eq!(e.line, Some(13));
        assert!(e.message.starts_with("a face line of more than 249"), "{e}");
        assert!(e.message.contains("more than the 1.0 MB limit"), "{e}");
        let list = format!("{head}100000{}\n", " 0".repeat(10));
        let e = parse(list.as_bytes(), list.len() as u64, Path::new("t.ply"), &budget).unwrap_err();
        assert!(e.message.starts_with("a face of 100000 values needs ~6.4 MB to load"), "{e}");
    }

    #[test]
    fn errors_name_the_line() {
        let face = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let cases = [
            (format!("{HEAD}{face}0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 4\n"), 15, "vertex index 4 is out of range"),
            (format!("{HEAD}{face}0 0 0\n1 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"), 13, "vertex: y: \"x\" is not a float"),
            (format!("{HEAD}{face}0 0 0\n1 0 0\n1 1\n0 1 0\n3 0 1 2\n"), 13, "vertex: too few values: z is missing"),
            (format!("{HEAD}{face}0 0 0\n1 0 0\n1 1 0 0\n0 1 0\n3 0 1 2\n"), 13, "more values than the 3 properties"),
            (format!("{HEAD}{face}0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 1\n"), 15, "at least 3 vertices"),
            (format!("{HEAD}{face}0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 -1\n"), 15, "index -1 is out of range"),
            // Long enough for the size check (2 bytes a value), but the face line is missing.
            (
                format!("{HEAD}{face}0.0 0.0 0.0\n1.0 0.0 0.0\n1.0 1.0 0.0\n0.0 1.0 0.0\n"),
                15,
                "the file ends after 0 of 1 face lines",
            ),
        ];
        for (text, line, needle) in cases {
            let e = parse_str(&text).unwrap_err();
            assert_eq!(e.line, Some(line), "{e}");
            assert!(e.message.contains(needle), "{e}");
        }
        let normals = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                       property float nx\nproperty float ny\nproperty float nz\nelement face 1\n\
                       property list uchar int vertex_indices\nend_header\n0 0 0 0 0 1\n1 0 0 0 nan 1\n0 1 0 0 0 1\n3 0 1 2\n";
        let e = parse_str(normals).unwrap_err();
        assert_eq!(e.line, Some(14), "{e}");
        assert!(e.message.contains("vertex normal: NaN is not a finite number"), "{e}");
    }

    #[test]
    fn non_finite_positions_drop_their_triangles() {
        let text = format!(
            "{HEAD}element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\ninf 1 0\n3 0 1 2\n3 0 2 3\n"
        );
        let m = parse_str(&text).unwrap();
        assert_eq!(m.meshes[0].mesh.indices, vec![[0, 1, 2]]);
        assert!(m.warnings.iter().any(|w| w.contains("degenerate")), "{:?}", m.warnings);
    }

    #[test]
    fn counts_the_file_cannot_hold_are_refused_before_reading() {
        let text = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\n\
                    property float y\nproperty float z\nend_header\n\0\0\0\0";
        let e = parse_str(text).unwrap_err();
        assert!(e.message.contains("declares 1000000000 vertex"), "{e}");
    }

    #[test]
    fn binary_errors_name_the_element() {
        let mut bytes = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                          property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
            .to_vec();
        for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in v {
                bytes.extend(c.to_be_bytes());
            }
        }
        let mut ok = bytes.clone();
        for face in [[0i32, 1, 2], [2, 1, 0]] {
            ok.push(3);
            for i in face {
                ok.extend(i.to_be_bytes());
            }
        }
        let m = parse(&ok[..], ok.len() as u64, Path::new("t.ply"), &LoadBudget::unlimited()).unwrap();
        assert_eq!(m.meshes[0].mesh.triangle_count(), 2);
        let mut bad = ok.clone();
        let n = bad.len();
        bad[n - 4..].copy_from_slice(&3i32.to_be_bytes());
        let e = parse(&bad[..], bad.len() as u64, Path::new("t.ply"), &LoadBudget::unlimited()).unwrap_err();
        assert_eq!(e.line, None);
        assert!(e.message.starts_with("face 1: face vertex index 3 is out of range"), "{e}");
        // Truncated inside face 1 (13 bytes each), but long enough for the size check: the
        // header says 3 vertices of 12 bytes and 2 faces of at least 1.
        let cut = &ok[..ok.len() - 5];
        let e = parse(cut, cut.len() as u64, Path::new("t.ply"), &LoadBudget::unlimited()).unwrap_err();
        assert!(e.message.starts_with("face 1: the file ends early"), "{e}");
    }
}
