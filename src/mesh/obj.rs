//! Wavefront OBJ: `v` and `f` lines.
//!
//! Read by hand rather than with `tobj`: tobj's `LoadError` is a bare enum with no line
//! number, so it cannot say where a file is wrong, and it reads positions as f32 unless a
//! crate-wide feature is switched on. What this reader accepts:
//! - `v x y z [w ...]`: the first three numbers are the position (f64); further values
//!   (a homogeneous w, vertex colours) are ignored.
//! - `f` with corners written `v`, `v/vt`, `v//vn` or `v/vt/vn`; only the position index is
//!   used, and the texture and normal parts need only be integers (some exporters write
//!   `1/0/0`, as the built-in triceratops does). Indices count from 1; negative ones count back
//!   from the last vertex defined so far (`-1` is the latest). An index must name a vertex
//!   defined above its face.
//! - Faces with more than three corners become a fan of triangles.
//! - Everything else (`vt`, `vn`, `g`, `o`, `s`, `usemtl`, `mtllib`, lines, points, unknown
//!   statements) is ignored, and `#` starts a comment. Line continuations (`\`) are not
//!   supported.
//!
//! The writer prints `v` and `f` lines with each coordinate in the shortest decimal form that
//! reads back to the same f64, so a written mesh reads back exactly.

use std::io::{self, Write};
use std::path::Path;

use crate::error::Result;

use super::assemble::Builder;
use super::text::{self, parse, show};
use super::{Mesh, ReadReport};

/// Reads OBJ text; `path` names the file in messages.
pub(super) fn read(bytes: &[u8], path: &Path) -> Result<(Mesh, ReadReport)> {
    let mut mesh = Builder::new(path);
    let mut corners = Vec::new();
    for (at, line) in text::lines(bytes) {
        let mut tokens = text::tokens(text::strip_comment(line));
        match tokens.next() {
            Some(b"v") => {
                let position =
                    text::position(&mut tokens, "a vertex").map_err(|m| mesh.error(at, m))?;
                mesh.vertex(position, at)?;
            }
            Some(b"f") => {
                corners.clear();
                for corner in tokens {
                    let index = read_corner(corner, mesh.vertex_count());
                    corners.push(index.map_err(|m| mesh.error(at, m))?);
                }
                mesh.polygon(&corners, at)?;
            }
            _ => {}
        }
    }
    mesh.finish()
}

/// The 0-based position index of one corner of an `f` line, given the number of vertices
/// defined so far.
fn read_corner(token: &[u8], defined: usize) -> std::result::Result<u32, String> {
    let mut parts = token.split(|&b| b == b'/');
    let position = parts.next().and_then(parse::<i64>);
    let others_ok = parts.by_ref().take(2).all(|p| p.is_empty() || parse::<i64>(p).is_some());
    let (Some(i), true, None) = (position, others_ok, parts.next()) else {
        return Err(format!(
            "face corner '{}' is not of the form v, v/vt, v//vn or v/vt/vn with integer indices",
            show(token)
        ));
    };
    let index = if i < 0 { defined as i64 + i } else { i - 1 };
    match u32::try_from(index) {
        Ok(v) if (v as usize) < defined => Ok(v),
        _ => Err(format!(
            "vertex index {i} out of range: {defined} vertices are defined above this line \
             (indices count from 1, negative ones back from the last)"
        )),
    }
}

/// Writes `mesh` as OBJ text.
pub(super) fn write(out: &mut impl Write, mesh: &Mesh) -> io::Result<()> {
    for v in &mesh.vertices {
        writeln!(out, "v {:?} {:?} {:?}", v.x, v.y, v.z)?;
    }
    for [a, b, c] in &mesh.triangles {
        writeln!(out, "f {} {} {}", a + 1, b + 1, c + 1)?;
    }
    Ok(())
}
