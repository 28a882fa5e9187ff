//! Stanford PLY meshes (Turk, "The PLY Polygon File Format", 1994; the
//! format as Paul Bourke's page and rply document it): `ascii`,
//! `binary_little_endian` and `binary_big_endian`.
//!
//! What is read: the `vertex` element's `x y z`, its normals `nx ny nz` (smooth
//! shading) and texture coordinates (`u v`, `s t` or `texture_u texture_v`);
//! the `face` element's `vertex_indices` (or `vertex_index`) list, polygons of
//! 3 to [`MAX_POLYGON`] corners, fan-triangulated. Every scalar type of the
//! format is accepted for every property, list counts and indices included,
//! under both spellings (`char uchar short ushort int uint float double` and
//! `int8 uint8 int16 uint16 int32 uint32 float32 float64`); a count or index
//! must hold a whole, non-negative number. Other elements and properties
//! (colours, `material_index`, ...) are read past and ignored. Every triangle
//! gets the default material (or the scene's `material = {...}` override).
//!
//! The header is untrusted: before anything is allocated, every element's
//! claimed count is checked against what the file can hold (in binary, the
//! bytes one element needs at the least, list counts taken as their smallest
//! legal value; in ASCII, two bytes a value, a digit and a separator) and
//! against the scene limits ([`MAX_VERTICES`], [`MAX_TRIANGLES`]). A
//! four-billion-vertex claim in a hundred-byte file is one error, at once.
//!
//! Errors are one line naming the file and where: the line for the header
//! and for ASCII data, the element (by name and index) and its byte offset
//! for binary data.

use super::{Material, MeshData};
use crate::error::{Error, Result};
use crate::limits::{MAX_COORDINATE, MAX_TRIANGLES, MAX_VERTICES};
use crate::math::{DVec3, Vec2, Vec3};
use std::path::Path;

/// Most corners a face may have; a larger polygon is an error (fan
/// triangulation of a long, likely non-planar outline is no longer the
/// surface the file meant).
pub const MAX_POLYGON: usize = 64;

/// A scalar type of the format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
    /// Header line of the `element` statement.
    line: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Where a vertex property goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    Position(usize),
    Normal(usize),
    Uv(usize),
}

fn slot_of(name: &str) -> Option<Slot> {
    Some(match name {
        "x" => Slot::Position(0),
        "y" => Slot::Position(1),
        "z" => Slot::Position(2),
        "nx" => Slot::Normal(0),
        "ny" => Slot::Normal(1),
        "nz" => Slot::Normal(2),
        "u" | "s" | "texture_u" | "texture_s" => Slot::Uv(0),
        "v" | "t" | "texture_v" | "texture_t" => Slot::Uv(1),
        _ => return None,
    })
}

/// The header: format, elements, and where the data begins.
struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the first data byte.
    body: usize,
    /// Line number of the first data line (ASCII).
    body_line: usize,
}

fn parse_header(path: &Path, bytes: &[u8]) -> Result<Header> {
    let fail = |line: usize, msg: String| Error::input(path, Some(line), msg);
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        line_no += 1;
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(fail(
                line_no,
                "the header ends without `end_header` (a truncated or non-PLY file)".into(),
            ));
        };
        let raw = &bytes[pos..pos + len];
        pos += len + 1;
        let Ok(text) = std::str::from_utf8(raw) else {
            return Err(fail(line_no, "header line is not text".into()));
        };
        let text = text.trim_end_matches('\r');
        if line_no == 1 {
            if text.trim() != "ply" {
                return Err(fail(
                    1,
                    "expected `ply` on the first line (not a PLY file)".into(),
                ));
            }
            continue;
        }
        let words: Vec<&str> = text.split_whitespace().collect();
        match words.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                if format.is_some() {
                    return Err(fail(line_no, "a second `format` line".into()));
                }
                format = Some(match words.get(1).copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Little,
                    Some("binary_big_endian") => Format::Big,
                    other => {
                        return Err(fail(
                            line_no,
                            format!(
                                "unknown format `{}` (expected ascii, binary_little_endian or binary_big_endian)",
                                other.unwrap_or("")
                            ),
                        ));
                    }
                });
                if words.get(2).is_some_and(|v| !v.starts_with('1')) {
                    return Err(fail(
                        line_no,
                        format!("unsupported PLY version `{}` (expected 1.0)", words[2]),
                    ));
                }
            }
            Some("element") => {
                let [_, name, count] = words[..] else {
                    return Err(fail(line_no, "expected `element NAME COUNT`".into()));
                };
                let count = count.parse::<u64>().map_err(|_| {
                    fail(
                        line_no,
                        format!("element `{name}`: cannot read count `{count}` (expected a whole number)"),
                    )
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                    line: line_no,
                });
            }
            Some("property") => {
                let Some(element) = elements.last_mut() else {
                    return Err(fail(line_no, "`property` before any `element`".into()));
                };
                let bad_type = |t: &str| {
                    fail(
                        line_no,
                        format!(
                            "unknown property type `{t}` (expected char, uchar, short, ushort, int, uint, float, double or int8 ... float64)"
                        ),
                    )
                };
                let (kind, name) = match words[..] {
                    [_, "list", c, i, name] => {
                        let count = Scalar::parse(c).ok_or_else(|| bad_type(c))?;
                        let item = Scalar::parse(i).ok_or_else(|| bad_type(i))?;
                        (Kind::List { count, item }, name)
                    }
                    [_, t, name] if t != "list" => (
                        Kind::Scalar(Scalar::parse(t).ok_or_else(|| bad_type(t))?),
                        name,
                    ),
                    _ => {
                        return Err(fail(
                            line_no,
                            "expected `property TYPE NAME` or `property list COUNT_TYPE ITEM_TYPE NAME`"
                                .into(),
                        ));
                    }
                };
                element.props.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            Some("end_header") => break,
            Some(other) => {
                return Err(fail(line_no, format!("unknown header statement `{other}`")));
            }
        }
    }
    let Some(format) = format else {
        return Err(fail(line_no, "no `format` line before `end_header`".into()));
    };
    Ok(Header {
        format,
        elements,
        body: pos,
        body_line: line_no + 1,
    })
}

/// The data after the header, read value by value.
struct Body<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    pos: usize,
    format: Format,
    /// Current line (ASCII).
    line: usize,
    /// What is being read, for messages: `vertex 12`.
    what: String,
}

impl Body<'_> {
    fn fail(&self, msg: impl std::fmt::Display) -> Error {
        match self.format {
            Format::Ascii => {
                Error::input(self.path, Some(self.line), format!("{}: {msg}", self.what))
            }
            _ => Error::input(
                self.path,
                None,
                format!("{} (byte offset {}): {msg}", self.what, self.pos),
            ),
        }
    }

    /// The next value, of type `ty`, as an f64 (exact for every type).
    fn value(&mut self, ty: Scalar) -> Result<f64> {
        match self.format {
            Format::Ascii => {
                let Some(range) =
                    crate::error::next_word(self.bytes, &mut self.pos, &mut self.line)
                else {
                    return Err(self.fail("the file ends early (expected more values)"));
                };
                let token = String::from_utf8_lossy(&self.bytes[range]);
                let v = token.parse::<f64>().map_err(|_| {
                    self.fail(format!(
                        "cannot read `{}` as a number",
                        crate::error::one_line(&token)
                    ))
                })?;
                let integral = !matches!(ty, Scalar::F32 | Scalar::F64);
                if integral && v.fract() != 0.0 {
                    return Err(self.fail(format!(
                        "`{token}` is not a whole number (its property is an integer type)"
                    )));
                }
                Ok(v)
            }
            Format::Little | Format::Big => {
                let n = ty.size();
                let Some(raw) = self.bytes.get(self.pos..self.pos + n) else {
                    return Err(self.fail(format!(
                        "the file ends early (truncated: {} bytes left, {n} needed)",
                        self.bytes.len() - self.pos.min(self.bytes.len())
                    )));
                };
                let mut b = [0u8; 8];
                b[..n].copy_from_slice(raw);
                if self.format == Format::Big {
                    b[..n].reverse();
                }
                self.pos += n;
                Ok(match ty {
                    Scalar::I8 => b[0] as i8 as f64,
                    Scalar::U8 => b[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(b),
                })
            }
        }
    }

    /// A list count or index: whole, `0 <= v < below`.
    fn whole(&mut self, ty: Scalar, what: &str, below: u64) -> Result<u64> {
        let v = self.value(ty)?;
        if !(v >= 0.0 && v.fract() == 0.0 && v < below as f64) {
            return Err(self.fail(format!(
                "{what} {v} out of range (expected a whole number from 0 to {})",
                below.saturating_sub(1)
            )));
        }
        Ok(v as u64)
    }

    /// Read past a property.
    fn skip(&mut self, kind: Kind) -> Result<()> {
        match kind {
            Kind::Scalar(t) => {
                self.value(t)?;
            }
            Kind::List { count, item } => {
                // a list cannot hold more values than the bytes left
                let n = self.whole(count, "list count", self.bytes.len() as u64 + 1)?;
                if self.format != Format::Ascii {
                    let need = n.saturating_mul(item.size() as u64);
                    if need > (self.bytes.len() - self.pos) as u64 {
                        return Err(self.fail(format!(
                            "a list of {n} values runs past the end of the file (truncated)"
                        )));
                    }
                    self.pos += need as usize;
                } else {
                    for _ in 0..n {
                        self.value(item)?;
                    }
                }
            }
        }
        Ok(())
    }
}

/// The fewest bytes one instance of `e` can take in `format`.
fn min_bytes(e: &Element, format: Format, faces: bool) -> u64 {
    e.props
        .iter()
        .map(|p| match (p.kind, format) {
            (_, Format::Ascii) => 2,
            (Kind::Scalar(t), _) => t.size() as u64,
            (Kind::List { count, item }, _) => {
                // the face list holds three indices at the least
                let items = if faces && is_index_list(&p.name) {
                    3
                } else {
                    0
                };
                (count.size() + items * item.size()) as u64
            }
        })
        .sum()
}

fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

/// Read `path` as one mesh with the default material.
pub fn load_ply_mesh(path: &Path) -> Result<MeshData> {
    let bytes = super::read_bounded(
        path,
        crate::limits::MAX_MESH_FILE_BYTES,
        super::Content::Magic(b"ply", "PLY"),
    )?;
    let header = parse_header(path, &bytes)?;
    let at = |line: usize, msg: String| Error::input(path, Some(line), msg);
    let vertex = header.elements.iter().find(|e| e.name == "vertex");
    let Some(vertex) = vertex else {
        return Err(Error::input(
            path,
            Some(header.body_line - 1),
            "no `vertex` element in the header",
        ));
    };
    let face = header.elements.iter().find(|e| e.name == "face");
    let Some(face) = face else {
        return Err(Error::input(
            path,
            Some(vertex.line),
            "no `face` element (a point cloud has nothing to render)",
        ));
    };
    for k in 0..3 {
        let name = ["x", "y", "z"][k];
        if !vertex
            .props
            .iter()
            .any(|p| p.name == name && matches!(p.kind, Kind::Scalar(_)))
        {
            return Err(at(
                vertex.line,
                format!("element `vertex` has no scalar property `{name}`"),
            ));
        }
    }
    if !face
        .props
        .iter()
        .any(|p| is_index_list(&p.name) && matches!(p.kind, Kind::List { .. }))
    {
        return Err(at(
            face.line,
            "element `face` has no `vertex_indices` (or `vertex_index`) list".into(),
        ));
    }
    if vertex.count > MAX_VERTICES {
        return Err(at(
            vertex.line,
            format!(
                "{} vertices (at most {MAX_VERTICES} in a scene)",
                vertex.count
            ),
        ));
    }
    if face.count > MAX_TRIANGLES {
        return Err(at(
            face.line,
            format!(
                "{} faces (at most {MAX_TRIANGLES} triangles in a scene)",
                face.count
            ),
        ));
    }
    // what the file can hold, checked before any allocation
    let available =
        (bytes.len() - header.body) as u128 + if header.format == Format::Ascii { 1 } else { 0 };
    let mut needed = 0u128;
    for e in &header.elements {
        let per = min_bytes(e, header.format, std::ptr::eq(e, face)) as u128;
        needed += per * e.count as u128;
        if needed > available {
            return Err(at(
                e.line,
                format!(
                    "element `{}` claims {} entries, more than the file's {} bytes of data can hold (at least {per} bytes each{})",
                    e.name,
                    e.count,
                    bytes.len() - header.body,
                    if header.format == Format::Ascii {
                        " in ASCII"
                    } else {
                        ""
                    }
                ),
            ));
        }
    }

    let slots: Vec<Option<Slot>> = vertex.props.iter().map(|p| slot_of(&p.name)).collect();
    let has_normals = (0..3).all(|k| slots.contains(&Some(Slot::Normal(k))));
    let has_uvs = (0..2).all(|k| slots.contains(&Some(Slot::Uv(k))));
    let nv = vertex.count as usize;
    let mut positions = Vec::with_capacity(nv);
    let mut normals = Vec::with_capacity(if has_normals { nv } else { 0 });
    let mut uvs = Vec::with_capacity(if has_uvs { nv } else { 0 });
    let mut indices: Vec<[u32; 3]> = Vec::with_capacity(face.count as usize);

    let mut body = Body {
        path,
        bytes: &bytes,
        pos: header.body,
        format: header.format,
        line: header.body_line,
        what: String::new(),
    };
    let index_prop = face.props.iter().position(|p| is_index_list(&p.name));
    for e in &header.elements {
        if e.props.is_empty() {
            // nothing to read, however many there are
            continue;
        }
        let is_vertex = std::ptr::eq(e, vertex);
        let is_face = std::ptr::eq(e, face);
        for i in 0..e.count {
            body.what = format!("element `{}` {i}", e.name);
            if is_vertex {
                let mut v = [0f64; 8];
                for (p, slot) in e.props.iter().zip(&slots) {
                    match (p.kind, slot) {
                        (Kind::Scalar(t), Some(slot)) => {
                            let x = body.value(t)?;
                            match *slot {
                                Slot::Position(k) => v[k] = x,
                                Slot::Normal(k) => v[3 + k] = x,
                                Slot::Uv(k) => v[6 + k] = x,
                            }
                        }
                        (kind, _) => body.skip(kind)?,
                    }
                }
                let p = DVec3::new(v[0], v[1], v[2]);
                if !p.is_finite() || p.abs().max_element() > MAX_COORDINATE as f64 {
                    return Err(body.fail(format!(
                        "position {p} is not finite or beyond +-{MAX_COORDINATE:e}"
                    )));
                }
                positions.push(p);
                if has_normals {
                    normals.push(Vec3::new(v[3] as f32, v[4] as f32, v[5] as f32));
                }
                if has_uvs {
                    let uv = Vec2::new(v[6] as f32, v[7] as f32);
                    uvs.push(if uv.is_finite() { uv } else { Vec2::ZERO });
                }
            } else if is_face {
                for (k, p) in e.props.iter().enumerate() {
                    match p.kind {
                        Kind::List { count, item } if Some(k) == index_prop => {
                            let n = body.whole(count, "corner count", MAX_POLYGON as u64 + 1)?;
                            if n < 3 {
                                return Err(body.fail(format!(
                                    "a face of {n} corners (expected 3 to {MAX_POLYGON})"
                                )));
                            }
                            let mut corners = [0u32; MAX_POLYGON];
                            for c in corners.iter_mut().take(n as usize) {
                                *c = body.whole(item, "vertex index", vertex.count)? as u32;
                            }
                            if indices.len() as u64 + n - 2 > MAX_TRIANGLES {
                                return Err(body.fail(format!(
                                    "this face takes the file past {MAX_TRIANGLES} triangles (the scene limit)"
                                )));
                            }
                            for j in 1..n as usize - 1 {
                                indices.push([corners[0], corners[j], corners[j + 1]]);
                            }
                        }
                        kind => body.skip(kind)?,
                    }
                }
            } else {
                for p in &e.props {
                    body.skip(p.kind)?;
                }
            }
        }
    }

    let corner = |t: &[u32; 3], values: &[Vec3]| t.map(|i| values[i as usize]);
    let mesh_normals = if has_normals {
        indices.iter().map(|t| corner(t, &normals)).collect()
    } else {
        Vec::new()
    };
    let mesh_uvs = if has_uvs {
        indices.iter().map(|t| t.map(|i| uvs[i as usize])).collect()
    } else {
        Vec::new()
    };
    Ok(MeshData {
        name: path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        positions,
        tri_material: vec![0; indices.len()],
        indices,
        materials: vec![Material::default()],
        uvs: mesh_uvs,
        normals: mesh_normals,
        warnings: Vec::new(),
        files: vec![path.to_path_buf()],
    })
}
