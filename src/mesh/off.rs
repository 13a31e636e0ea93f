//! OFF (Object File Format), text.
//!
//! Read by hand: no well-kept crate reads OFF, and the format is a few lines of grammar. What
//! this reader accepts: an optional header keyword `OFF` (or a variant such as `COFF`, `NOFF`,
//! `STOFF` whose vertex lines carry extra values, which are ignored), the counts
//! `vertices faces [edges]` on the header line or the next, then one vertex per line (its first
//! three numbers are the position, f64) and one face per line (`n i1 ... in`, indices from 0,
//! any trailing colour ignored). Faces with more than three corners become a fan of triangles.
//! `#` starts a comment and blank lines are skipped. Binary OFF and the 4D and n-dimensional
//! variants are reported as unsupported.
//!
//! The writer prints each coordinate in the shortest form that reads back to the same f64.

use std::io::{self, Write};
use std::path::Path;

use crate::error::{Error, Location, Result};

use super::assemble::Builder;
use super::text::{self, parse, show};
use super::{Mesh, ReadReport};

/// Reads OFF text; `path` names the file in messages.
pub(super) fn read(bytes: &[u8], path: &Path) -> Result<(Mesh, ReadReport)> {
    let lines: Vec<(Location, &[u8])> = text::lines(bytes)
        .map(|(at, line)| (at, text::strip_comment(line)))
        .filter(|(_, line)| text::tokens(line).next().is_some())
        .collect();
    let last = lines.last().map_or(Location::Line(1), |&(at, _)| at);
    let truncated =
        |what: String| Error::parse(path, Some(last), format!("truncated: the file ends {what}"));
    let mut mesh = Builder::new(path);
    let mut lines = lines.into_iter();
    let (at, first) = lines.next().ok_or_else(|| truncated("before the 'OFF' header".into()))?;
    let mut counts_at = at;
    let mut counts_tokens: Vec<&[u8]> = text::tokens(first).collect();
    if counts_tokens[0].ends_with(b"OFF") {
        check_keyword(&counts_tokens).map_err(|m| mesh.error(at, m))?;
        counts_tokens.remove(0);
        if counts_tokens.is_empty() {
            let (at, line) =
                lines.next().ok_or_else(|| truncated("before the counts line".into()))?;
            counts_at = at;
            counts_tokens = text::tokens(line).collect();
        }
    }
    let (vertex_count, face_count) =
        counts(&counts_tokens).map_err(|m| mesh.error(counts_at, m))?;
    for k in 0..vertex_count {
        let (at, line) = lines
            .next()
            .ok_or_else(|| truncated(format!("after {k} of {vertex_count} vertices")))?;
        let p =
            text::position(&mut text::tokens(line), "a vertex").map_err(|m| mesh.error(at, m))?;
        mesh.vertex(p, at)?;
    }
    let mut corners = Vec::new();
    for k in 0..face_count {
        let (at, line) =
            lines.next().ok_or_else(|| truncated(format!("after {k} of {face_count} faces")))?;
        corners.clear();
        for index in face(line).map_err(|m| mesh.error(at, m))? {
            corners.push(mesh.corner(index, vertex_count, at)?);
        }
        mesh.polygon(&corners, at)?;
    }
    mesh.finish()
}

/// Checks the header keyword (the first of `tokens`, ending in `OFF`) names a variant this
/// reader reads.
fn check_keyword(tokens: &[&[u8]]) -> std::result::Result<(), String> {
    let keyword = tokens[0];
    let prefix = &keyword[..keyword.len() - 3];
    if tokens.get(1).is_some_and(|t| t.eq_ignore_ascii_case(b"BINARY")) {
        return Err("binary OFF is not supported; convert it to text OFF, PLY or STL".into());
    }
    let known = [&b""[..], b"C", b"N", b"CN", b"ST", b"STC", b"STN", b"STCN"];
    if known.contains(&prefix) {
        Ok(())
    } else {
        Err(format!(
            "'{}' is not a supported OFF variant (only 3D OFF, with optional ST, C, N prefixes)",
            show(keyword)
        ))
    }
}

/// The vertex and face counts from the counts line (the edge count, if any, is ignored).
fn counts(tokens: &[&[u8]]) -> std::result::Result<(usize, usize), String> {
    match tokens {
        [v, f, ..] => match (parse(v), parse(f)) {
            (Some(v), Some(f)) => Ok((v, f)),
            _ => Err(format!(
                "expected the counts 'vertices faces edges', found '{} {}'",
                show(v),
                show(f)
            )),
        },
        _ => Err("expected the counts 'vertices faces edges' on one line".into()),
    }
}

/// The vertex indices of a face line `n i1 ... in [colour]`.
fn face(line: &[u8]) -> std::result::Result<Vec<i64>, String> {
    let mut tokens = text::tokens(line);
    let n: usize =
        tokens.next().and_then(parse).ok_or("a face line must start with its number of corners")?;
    let indices: Vec<i64> = tokens.take(n).map_while(parse).collect();
    if indices.len() < n {
        return Err(format!(
            "the face declares {n} corners but lists {} integer indices",
            indices.len()
        ));
    }
    Ok(indices)
}

/// Writes `mesh` as OFF text.
pub(super) fn write(out: &mut impl Write, mesh: &Mesh) -> io::Result<()> {
    writeln!(out, "OFF")?;
    writeln!(out, "{} {} 0", mesh.vertices.len(), mesh.triangles.len())?;
    for v in &mesh.vertices {
        writeln!(out, "{:?} {:?} {:?}", v.x, v.y, v.z)?;
    }
    for [a, b, c] in &mesh.triangles {
        writeln!(out, "3 {a} {b} {c}")?;
    }
    Ok(())
}
