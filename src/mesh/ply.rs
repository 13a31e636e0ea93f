//! Stanford PLY: ASCII, binary little endian and binary big endian.
//!
//! Built on `ply-rs-bw`: its parser reads the header and decodes ASCII elements one at a time;
//! binary elements are decoded here straight from the header's property types (the parser
//! hands every property of every element over by name, too slow for meshes of millions of
//! triangles). The file is read element by element so that every error
//! carries its place in the file (the line for ASCII, the byte offset where the element starts
//! for binary). What it accepts:
//! - a `vertex` element with scalar `x`, `y` and `z` properties of any numeric type (float and
//!   double are usual), read as f64; other vertex properties (normals, colours) are ignored;
//! - a `face` element with a `vertex_indices` (or `vertex_index`) list of any integer type
//!   with any integer count type, indices from 0; faces with more than three corners become a
//!   fan of triangles; other face properties are ignored;
//! - any other elements, which are read past and ignored. In ASCII, blank lines between
//!   elements are skipped.
//!
//! Reading takes time in proportion to the file's size, whatever counts its header declares.
//!
//! The writer writes binary little endian with double positions and `list uchar uint` faces,
//! so a written mesh reads back exactly.

use std::io::{self, Write};
use std::path::Path;

use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    Addable, ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult,
    PropertyDef, PropertyType, ScalarType,
};
use ply_rs_bw::writer::Writer;

use crate::error::{Error, Location, Result};

use super::assemble::Builder;
use super::{Mesh, ReadReport};

/// The names a face's index list goes by.
const INDEX_LISTS: [&str; 2] = ["vertex_indices", "vertex_index"];

/// The parts of an element this reader keeps, whichever element it is.
#[derive(Default)]
struct Element {
    position: [f64; 3],
    indices: Vec<i64>,
}

impl PropertyAccess for Element {
    fn new() -> Self {
        Element::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let axis = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ if INDEX_LISTS.contains(&name) => return self.set_indices(property),
            _ => return PropertyAccessResult::Ignored,
        };
        // The header check made sure the vertex element's coordinates are numbers; a list of
        // that name in another element is not read, as in binary.
        match as_number(&property) {
            Some(value) => {
                self.position[axis] = value;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }
}

impl Element {
    fn set_indices(&mut self, property: Property) -> PropertyAccessResult {
        fn widen<T: Into<i64>>(list: Vec<T>) -> Vec<i64> {
            list.into_iter().map(Into::into).collect()
        }
        self.indices = match property {
            Property::ListChar(l) => widen(l),
            Property::ListUChar(l) => widen(l),
            Property::ListShort(l) => widen(l),
            Property::ListUShort(l) => widen(l),
            Property::ListInt(l) => widen(l),
            Property::ListUInt(l) => widen(l),
            // The header check made sure the face element's index lists hold integers; a
            // property of that name in another element is not read, as in binary.
            _ => return PropertyAccessResult::Ignored,
        };
        PropertyAccessResult::Set
    }
}

/// A scalar property's value as f64.
fn as_number(property: &Property) -> Option<f64> {
    Some(match *property {
        Property::Char(v) => v.into(),
        Property::UChar(v) => v.into(),
        Property::Short(v) => v.into(),
        Property::UShort(v) => v.into(),
        Property::Int(v) => v.into(),
        Property::UInt(v) => v.into(),
        Property::Float(v) => v.into(),
        Property::Double(v) => v,
        _ => return None,
    })
}

/// Reads a PLY file's bytes; `path` names the file in messages.
pub(super) fn read(bytes: &[u8], path: &Path) -> Result<(Mesh, ReadReport)> {
    let parser = Parser::<Element>::new();
    let mut reader = Reader::new(bytes);
    let header = parser.read_header(&mut reader).map_err(|e| header_error(path, &e))?;
    let body = reader.into_inner();
    let vertex_count = check_header(&header, path)?;
    check_counts(&header, body.len(), path)?;
    let header_lines = bytes[..bytes.len() - body.len()].iter().filter(|&&b| b == b'\n').count();
    let mut payload =
        Payload { parser, encoding: header.encoding, file: bytes, rest: body, line: header_lines };
    let mut mesh = Builder::new(path);
    let mut corners = Vec::new();
    // An element without properties takes no bytes (and, in ASCII, blank lines, which are
    // skipped anyway): skip it rather than count through however many the header claims.
    for (name, def) in header.elements.iter().filter(|(_, d)| !d.properties.is_empty()) {
        let layout = Layout::new(name, def);
        let mut element = Element::default();
        for i in 0..def.count {
            let at = payload.next(def, &layout, &mut element).map_err(|(at, message)| {
                mesh.error(at, format!("{name} {i} of {}: {message}", def.count))
            })?;
            match name.as_str() {
                "vertex" => mesh.vertex(element.position, at)?,
                "face" => {
                    corners.clear();
                    for &c in &element.indices {
                        corners.push(mesh.corner(c, vertex_count, at)?);
                    }
                    mesh.polygon(&corners, at)?;
                }
                _ => {}
            }
        }
    }
    mesh.finish()
}

/// Checks that the header declares what a mesh needs and returns the number of vertices.
fn check_header(header: &Header, path: &Path) -> Result<usize> {
    let error = |message: String| Error::parse(path, None, message);
    let vertex = header
        .elements
        .get("vertex")
        .ok_or_else(|| error("the header declares no 'vertex' element".into()))?;
    for axis in ["x", "y", "z"] {
        match vertex.properties.get(axis).map(|p| &p.data_type) {
            Some(PropertyType::Scalar(_)) => {}
            Some(PropertyType::List(..)) => {
                return Err(error(format!("vertex property '{axis}' is a list, not a number")));
            }
            None => {
                return Err(error(format!("the vertex element has no '{axis}' property")));
            }
        }
    }
    if let Some(face) = header.elements.get("face") {
        let lists: Vec<_> = INDEX_LISTS.iter().filter_map(|n| face.properties.get(*n)).collect();
        for list in &lists {
            match &list.data_type {
                PropertyType::List(_, ScalarType::Float | ScalarType::Double) => {
                    return Err(error(format!(
                        "the face's '{}' list holds floating-point numbers",
                        list.name
                    )));
                }
                PropertyType::List(..) => {}
                PropertyType::Scalar(_) => {
                    return Err(error(format!("face property '{}' is not a list", list.name)));
                }
            }
        }
        if lists.is_empty() {
            return Err(error("the face element has no 'vertex_indices' list of integers".into()));
        }
    }
    // A list's length is a whole number: the binary reader takes it as one of the integer types.
    for (name, element) in &header.elements {
        for property in element.properties.values() {
            if let PropertyType::List(ScalarType::Float | ScalarType::Double, _) =
                property.data_type
            {
                return Err(error(format!(
                    "{name} property '{}': a list's length is declared floating-point",
                    property.name
                )));
            }
        }
    }
    Ok(vertex.count)
}

/// Refuses a header whose elements need more bytes than the `body` bytes after it hold, before
/// reading any: at least the size of every scalar (and list count) in binary, and a character
/// and a separator for each in ASCII.
fn check_counts(header: &Header, body: usize, path: &Path) -> Result<()> {
    let mut needed = 0u64;
    for (name, def) in &header.elements {
        let size: u64 =
            def.properties.values().map(|p| least_bytes(&p.data_type, header.encoding)).sum();
        let bytes = size.saturating_mul(def.count as u64);
        needed = needed.saturating_add(bytes);
        if needed > body as u64 + 1 {
            return Err(Error::parse(
                path,
                None,
                format!(
                    "the header declares {} '{name}' elements, which need at least {bytes} bytes; \
                     the file has {body} bytes after its header",
                    def.count
                ),
            ));
        }
    }
    Ok(())
}

/// The fewest bytes a property of this type takes in a file of this encoding.
fn least_bytes(data_type: &PropertyType, encoding: Encoding) -> u64 {
    let scalar = match data_type {
        PropertyType::Scalar(s) | PropertyType::List(s, _) => s,
    };
    match (encoding, scalar) {
        (Encoding::Ascii, _) => 2,
        (_, ScalarType::Char | ScalarType::UChar) => 1,
        (_, ScalarType::Short | ScalarType::UShort) => 2,
        (_, ScalarType::Int | ScalarType::UInt | ScalarType::Float) => 4,
        (_, ScalarType::Double) => 8,
    }
}

/// A header error, with the line ply-rs-bw found it on when it knows.
fn header_error(path: &Path, e: &ParseError) -> Error {
    let text = e.to_string();
    let message = match e.line() {
        Some(n) => text.strip_prefix(&format!("Line {n}: ")).unwrap_or(&text).to_string(),
        None => text,
    };
    Error::parse(path, e.line().map(Location::Line), one_line(&message))
}

/// A parser message on one short line.
fn one_line(message: &str) -> String {
    let words = message.split_whitespace().collect::<Vec<_>>().join(" ");
    match words.char_indices().nth(200) {
        Some((cut, _)) => format!("{}...", &words[..cut]),
        None => words,
    }
}

/// The part of the file after the header, read one element at a time.
struct Payload<'a> {
    parser: Parser<Element>,
    encoding: Encoding,
    file: &'a [u8],
    rest: &'a [u8],
    /// The number of lines read so far (ASCII).
    line: usize,
}

impl Payload<'_> {
    /// Reads the next element of type `def` (whose properties `layout` describes) into
    /// `element` and says where it starts; an error says where and what.
    fn next(
        &mut self,
        def: &ElementDef,
        layout: &Layout,
        element: &mut Element,
    ) -> std::result::Result<Location, (Location, String)> {
        if self.encoding == Encoding::Ascii {
            let (read, at) = self.next_ascii(def)?;
            *element = read;
            return Ok(at);
        }
        let at = Location::Byte((self.file.len() - self.rest.len()) as u64);
        let big_endian = self.encoding == Encoding::BinaryBigEndian;
        layout.read(&mut self.rest, big_endian, element).map(|()| at).map_err(|e| {
            let message = match e {
                BinaryError::Truncated => format!(
                    "truncated: the file ends at byte {} inside this element",
                    self.file.len()
                ),
                BinaryError::Invalid(message) => message.to_string(),
            };
            (at, message)
        })
    }

    fn next_ascii(
        &mut self,
        def: &ElementDef,
    ) -> std::result::Result<(Element, Location), (Location, String)> {
        loop {
            if self.rest.is_empty() {
                return Err((
                    Location::Line(self.line),
                    "truncated: the file ends before this element".into(),
                ));
            }
            let end = self.rest.iter().position(|&b| b == b'\n').map_or(self.rest.len(), |p| p + 1);
            let (line, rest) = self.rest.split_at(end);
            self.rest = rest;
            self.line += 1;
            let at = Location::Line(self.line);
            let line = line.trim_ascii();
            if line.is_empty() {
                continue;
            }
            let text = std::str::from_utf8(line)
                .map_err(|_| (at, "the line is not ASCII text".to_string()))?;
            return self
                .parser
                .read_ascii_element(text, def)
                .map(|e| (e, at))
                .map_err(|e| (at, one_line(&e.to_string())));
        }
    }
}

/// What one property of an element gives the mesh.
#[derive(Clone, Copy)]
enum Role {
    /// A vertex coordinate: x, y or z.
    Axis(usize),
    /// A face's corners.
    Corners,
    Ignored,
}

/// An element's properties in the file's order, with what each gives the mesh: what
/// decoding a binary element needs.
struct Layout {
    properties: Vec<(PropertyType, Role)>,
}

/// Why a binary element could not be decoded.
enum BinaryError {
    /// The file ends inside it.
    Truncated,
    Invalid(&'static str),
}

impl Layout {
    /// The layout of the element `name` declared as `def`.
    fn new(name: &str, def: &ElementDef) -> Layout {
        let role = |property: &str| match (name, property) {
            ("vertex", "x") => Role::Axis(0),
            ("vertex", "y") => Role::Axis(1),
            ("vertex", "z") => Role::Axis(2),
            ("face", p) if INDEX_LISTS.contains(&p) => Role::Corners,
            _ => Role::Ignored,
        };
        let properties =
            def.properties.iter().map(|(p, d)| (d.data_type.clone(), role(p))).collect();
        Layout { properties }
    }

    /// Decodes one binary element from the front of `rest` into `element`, and moves `rest`
    /// past it.
    fn read(
        &self,
        rest: &mut &[u8],
        big_endian: bool,
        element: &mut Element,
    ) -> std::result::Result<(), BinaryError> {
        for (data_type, role) in &self.properties {
            match (data_type, *role) {
                (PropertyType::Scalar(t), Role::Axis(axis)) => {
                    element.position[axis] = scalar(rest, t, big_endian)?;
                }
                (PropertyType::Scalar(t), _) => {
                    take(rest, scalar_bytes(t))?;
                }
                (PropertyType::List(count, t), role) => {
                    let count = list_length(rest, count, big_endian)?;
                    if let Role::Corners = role {
                        element.indices.clear();
                        for _ in 0..count {
                            // Every integer type holds values f64 represents exactly.
                            element.indices.push(scalar(rest, t, big_endian)? as i64);
                        }
                    } else {
                        let bytes = count.checked_mul(scalar_bytes(t));
                        take(rest, bytes.ok_or(BinaryError::Truncated)?)?;
                    }
                }
            }
        }
        Ok(())
    }
}

/// The size of a binary scalar of type `t`.
fn scalar_bytes(t: &ScalarType) -> usize {
    match *t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The first `n` bytes of `rest`, which moves past them.
fn take<'a>(rest: &mut &'a [u8], n: usize) -> std::result::Result<&'a [u8], BinaryError> {
    let (head, tail) = rest.split_at_checked(n).ok_or(BinaryError::Truncated)?;
    *rest = tail;
    Ok(head)
}

/// A binary scalar of type `t`, as f64 (exact for every type but double-to-double).
fn scalar(
    rest: &mut &[u8],
    t: &ScalarType,
    big_endian: bool,
) -> std::result::Result<f64, BinaryError> {
    let size = scalar_bytes(t);
    let mut b = [0u8; 8];
    b[..size].copy_from_slice(take(rest, size)?);
    if big_endian {
        b[..size].reverse();
    }
    let [b0, b1, b2, b3, ..] = b;
    Ok(match *t {
        ScalarType::Char => f64::from(i8::from_le_bytes([b0])),
        ScalarType::UChar => f64::from(b0),
        ScalarType::Short => f64::from(i16::from_le_bytes([b0, b1])),
        ScalarType::UShort => f64::from(u16::from_le_bytes([b0, b1])),
        ScalarType::Int => f64::from(i32::from_le_bytes([b0, b1, b2, b3])),
        ScalarType::UInt => f64::from(u32::from_le_bytes([b0, b1, b2, b3])),
        ScalarType::Float => f64::from(f32::from_le_bytes([b0, b1, b2, b3])),
        ScalarType::Double => f64::from_le_bytes(b),
    })
}

/// A binary list's length, read as its count type `t`.
fn list_length(
    rest: &mut &[u8],
    t: &ScalarType,
    big_endian: bool,
) -> std::result::Result<usize, BinaryError> {
    // Integer types only: the header check refuses floating-point lengths.
    let length = scalar(rest, t, big_endian)?;
    if length < 0.0 {
        return Err(BinaryError::Invalid("a list's length is negative"));
    }
    Ok(length as usize)
}

/// One vertex or triangle to write.
struct Out {
    position: [f64; 3],
    corners: [u32; 3],
}

impl PropertyAccess for Out {
    fn new() -> Self {
        Out { position: [0.0; 3], corners: [0; 3] }
    }

    fn get_double(&self, name: &str) -> Option<f64> {
        ["x", "y", "z"].iter().position(|&a| a == name).map(|axis| self.position[axis])
    }

    fn get_list_uint(&self, name: &str) -> Option<&[u32]> {
        (name == INDEX_LISTS[0]).then_some(&self.corners[..])
    }
}

/// Writes `mesh` as binary little-endian PLY with double positions.
pub(super) fn write(out: &mut impl Write, mesh: &Mesh) -> io::Result<()> {
    let mut vertex = ElementDef::new("vertex".into());
    vertex.count = mesh.vertices.len();
    for axis in ["x", "y", "z"] {
        vertex
            .properties
            .add(PropertyDef::new(axis.into(), PropertyType::Scalar(ScalarType::Double)));
    }
    let mut face = ElementDef::new("face".into());
    face.count = mesh.triangles.len();
    face.properties.add(PropertyDef::new(
        INDEX_LISTS[0].into(),
        PropertyType::List(ScalarType::UChar, ScalarType::UInt),
    ));
    let mut header = Header::new();
    header.encoding = Encoding::BinaryLittleEndian;
    header.elements.add(vertex.clone());
    header.elements.add(face.clone());
    let writer = Writer::<Out>::new();
    writer.write_header(out, &header)?;
    let mut element = Out::new();
    for v in &mesh.vertices {
        element.position = v.to_array();
        writer.write_little_endian_element(out, &element, &vertex)?;
    }
    for t in &mesh.triangles {
        element.corners = *t;
        writer.write_little_endian_element(out, &element, &face)?;
    }
    Ok(())
}
