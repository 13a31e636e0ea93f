//! STL, ASCII and binary.
//!
//! Read by hand rather than with `stl_io`, which would serve for writing but not for reading:
//! it takes any file whose first line starts with `solid ` for ASCII, so the many binary
//! files whose 80-byte header begins with "solid" fail to read; its errors carry no line or
//! byte offset; and it reads ASCII coordinates as f32.
//!
//! A file is binary when its size is exactly the 84-byte header plus 50 bytes for each
//! triangle the header declares; otherwise it is ASCII when it starts with `solid` and holds
//! no NUL byte (binary records nearly always hold one: the attribute count is usually zero);
//! anything else is reported as a binary file of the wrong size. ASCII keywords are matched
//! without regard to case, the order `facet` / `outer loop` / `vertex` x3 / `endloop` /
//! `endfacet` is checked only as far as each facet having exactly three vertices, and several
//! `solid` ... `endsolid` blocks may follow each other. Facet normals are ignored.
//!
//! STL stores every triangle's corners separately, so corners with identical positions are
//! welded into one vertex (`-0.0` and `0.0` count as the same); a closed solid comes back with
//! shared vertices. The writer uses `stl_io` and writes binary STL, with f32 positions as the
//! format requires and normals from the triangles' corners.

use std::collections::HashMap;
use std::io::{self, Write};
use std::path::Path;

use crate::error::{Location, Result};
use crate::geometry::DVec3;

use super::assemble::Builder;
use super::text::{self, show};
use super::{Mesh, ReadReport};

/// Bytes before the first binary triangle: an 80-byte header and a u32 triangle count.
const HEADER: u64 = 84;
/// Bytes per binary triangle: normal, three corners (12 f32) and a u16 attribute count.
const RECORD: u64 = 50;

/// Reads an STL file's bytes; `path` names the file in messages.
pub(super) fn read(bytes: &[u8], path: &Path) -> Result<(Mesh, ReadReport)> {
    let declared =
        bytes.get(80..84).map(|c| u64::from(u32::from_le_bytes([c[0], c[1], c[2], c[3]])));
    let size = bytes.len() as u64;
    if declared.is_some_and(|n| HEADER + RECORD * n == size) {
        return read_binary(bytes, path);
    }
    let mut mesh = Welded::new(path);
    if bytes.trim_ascii_start().starts_with(b"solid") && !bytes.contains(&0) {
        read_ascii(bytes, &mut mesh)?;
        return mesh.builder.finish();
    }
    Err(match declared {
        None => mesh.builder.error(
            Location::Byte(size),
            "not an STL file: too short for a binary STL (84-byte header) and not ASCII STL \
             (which starts with 'solid')",
        ),
        Some(n) if size < HEADER + RECORD * n => mesh.builder.error(
            Location::Byte(HEADER + RECORD * ((size - HEADER) / RECORD)),
            format!(
                "truncated binary STL: the header declares {n} triangles ({} bytes) but the file \
                 has {size} bytes, ending inside triangle {}",
                HEADER + RECORD * n,
                (size - HEADER) / RECORD
            ),
        ),
        Some(n) => mesh.builder.error(
            Location::Byte(HEADER + RECORD * n),
            format!(
                "binary STL with {} bytes after the {n} triangles its header declares; \
                 not ASCII STL either (which starts with 'solid' and holds no NUL byte)",
                size - HEADER - RECORD * n
            ),
        ),
    })
}

/// A mesh builder that welds corners with identical positions.
struct Welded<'p> {
    builder: Builder<'p>,
    index: HashMap<[u64; 3], u32>,
}

impl<'p> Welded<'p> {
    fn new(path: &'p Path) -> Self {
        Welded { builder: Builder::new(path), index: HashMap::new() }
    }

    /// The index of the vertex at `p` (read at `at`), added if it is new.
    fn corner(&mut self, p: [f64; 3], at: Location) -> Result<u32> {
        // Adding 0.0 turns -0.0 into 0.0, so both weld together.
        let key = p.map(|c| (c + 0.0).to_bits());
        if let Some(&i) = self.index.get(&key) {
            return Ok(i);
        }
        let i = self.builder.vertex_count() as u32;
        self.builder.vertex(p, at)?;
        self.index.insert(key, i);
        Ok(i)
    }
}

/// Reads a binary STL whose size matches its header.
fn read_binary(bytes: &[u8], path: &Path) -> Result<(Mesh, ReadReport)> {
    let mut mesh = Welded::new(path);
    for (t, record) in bytes[HEADER as usize..].chunks_exact(RECORD as usize).enumerate() {
        let start = HEADER + RECORD * t as u64;
        let mut corners = [0; 3];
        for (k, corner) in corners.iter_mut().enumerate() {
            let offset = 12 + 12 * k;
            let p = [0, 4, 8].map(|o| {
                let b = &record[offset + o..offset + o + 4];
                f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            });
            *corner = mesh.corner(p, Location::Byte(start + offset as u64))?;
        }
        mesh.builder.polygon(&corners, Location::Byte(start))?;
    }
    mesh.builder.finish()
}

/// Reads ASCII STL into `mesh`.
fn read_ascii(bytes: &[u8], mesh: &mut Welded) -> Result<()> {
    let mut facet: Option<Vec<u32>> = None;
    let mut closed = false;
    let mut last = Location::Line(1);
    for (at, line) in text::lines(bytes) {
        let mut tokens = text::tokens(line);
        let Some(keyword) = tokens.next() else {
            continue;
        };
        last = at;
        let keyword = keyword.to_ascii_lowercase();
        let error = |message: String| mesh.builder.error(at, message);
        match (keyword.as_slice(), facet.as_mut()) {
            (b"solid", None) => closed = false,
            (b"endsolid", None) => closed = true,
            (b"facet", None) => facet = Some(Vec::with_capacity(3)),
            (b"outer" | b"endloop", Some(_)) => {}
            (b"vertex", Some(corners)) => {
                let p = text::position(&mut tokens, "a vertex").map_err(error)?;
                corners.push(mesh.corner(p, at)?);
            }
            (b"endfacet", Some(corners)) if corners.len() == 3 => {
                mesh.builder.polygon(corners, at)?;
                facet = None;
            }
            (b"endfacet", Some(corners)) => {
                return Err(error(format!(
                    "a facet needs 3 vertices, this one has {}",
                    corners.len()
                )));
            }
            (b"solid" | b"endsolid" | b"facet", Some(_)) => {
                return Err(error(format!("'{}' inside a facet", show(&keyword))));
            }
            (_, _) => {
                return Err(error(format!("unexpected '{}' in ASCII STL", show(&keyword))));
            }
        }
    }
    if !closed || facet.is_some() {
        return Err(mesh
            .builder
            .error(last, "truncated ASCII STL: the file ends before 'endsolid'"));
    }
    Ok(())
}

/// Writes `mesh` as binary STL.
pub(super) fn write(out: &mut impl Write, mesh: &Mesh) -> io::Result<()> {
    let triangles = (0..mesh.triangles.len()).map(|t| {
        let [a, b, c] = mesh.corners(t);
        let normal = (b - a).cross(c - a).normalize_or_zero();
        let f32s = |p: DVec3| stl_io::Vector::new(p.as_vec3().to_array());
        stl_io::Triangle { normal: f32s(normal), vertices: [f32s(a), f32s(b), f32s(c)] }
    });
    stl_io::write_stl(out, triangles)
}
