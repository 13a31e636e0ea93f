//! Triangle meshes: the input of the whole pipeline and the output of polygonization.
//!
//! A [`Mesh`] is a list of vertex positions (f64, in the file's own units) and triangles that
//! index them. This module reads and writes the mesh files the paper's method starts from
//! (section 3.2 takes "a polygonal mesh" as the surface to approximate): Wavefront OBJ, PLY
//! (ASCII and both binary byte orders), STL (ASCII and binary) and OFF.
//!
//! # What reading guarantees
//! [`read`] and [`read_bytes`] either return a usable mesh or one [`Error`] naming the file
//! and, where it applies, the line (text formats) or byte offset (binary formats). They never
//! panic, whatever the bytes. A mesh they return has:
//! - only finite coordinates, kept as f64 in the file's units (no scaling, no centring);
//! - at least one triangle, every index in range;
//! - no degenerate triangle: triangles with a repeated corner or with zero area (up to
//!   rounding, see [`ReadReport::degenerate_dropped`]) are dropped and counted, not fatal;
//! - volume: the used vertices span a non-zero extent along every axis (a flat mesh is an
//!   error, because it encloses nothing to fit an implicit surface to).
//!
//! Polygons with more than three corners are split into a fan of triangles around their first
//! corner, which is exact for the convex polygons mesh files hold in practice. Vertices that no
//! triangle uses are kept (the Stanford bunny has some), so indices match the file's.
//! Readers for STL weld corners with identical positions, so a closed STL solid comes back
//! with shared vertices like the other formats.
//!
//! Each format's module says which crate it uses and, where it reads by hand, why.
//!
//! # Example
//! ```
//! use std::path::Path;
//! use implicitize::mesh::{self, Format};
//!
//! let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
//! let (tetrahedron, report) = mesh::read_bytes(obj, Format::Obj, Path::new("tet.obj"))?;
//! assert_eq!((tetrahedron.vertices.len(), tetrahedron.triangles.len()), (4, 4));
//! assert_eq!(report.degenerate_dropped, 0);
//!
//! let bad = mesh::read_bytes(b"v 0 0 0\nf 1 2 3\n", Format::Obj, Path::new("bad.obj"));
//! let message = bad.unwrap_err().to_string();
//! assert!(message.starts_with("bad.obj (line 2): vertex index 2 out of range"));
//! # Ok::<(), implicitize::Error>(())
//! ```

use std::path::Path;

use crate::error::{Error, Result};
use crate::geometry::{Aabb, DVec3};

pub(crate) mod area;
mod assemble;
pub(crate) mod edges;
pub(crate) mod inside;
mod obj;
mod off;
mod ply;
mod stl;
mod text;

/// A triangle mesh.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions in the mesh's own units.
    pub vertices: Vec<DVec3>,
    /// Triangles as indices into `vertices`, counter-clockwise seen from outside when the
    /// mesh is consistently oriented.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// The bounding box of the vertices that some triangle uses, or `None` for a mesh with no
    /// triangles.
    pub fn bounds(&self) -> Option<Aabb> {
        // The used vertices marked first, then boxed in order: reading every triangle's
        // corners from the vertices would jump about memory millions of times on large meshes.
        let mut used = vec![false; self.vertices.len()];
        for &i in self.triangles.iter().flatten() {
            used[i as usize] = true;
        }
        Aabb::of_points(self.vertices.iter().zip(used).filter_map(|(v, used)| used.then_some(v)))
    }

    /// The three corners of triangle `t`.
    #[inline]
    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|i| self.vertices[i as usize])
    }

    /// The edges not shared by exactly two triangles (holes' rims, non-manifold edges), with
    /// vertices at the same position counted as one, so a closed STL file (one vertex per
    /// corner) has none. 0 means the mesh is watertight. Triangles indexing a missing vertex
    /// are left out.
    pub fn open_edges(&self) -> usize {
        let n = self.vertices.len();
        let triangles: Vec<[u32; 3]> = self
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&i| (i as usize) < n))
            .copied()
            .collect();
        edges::Edges::of(&edges::weld(&self.vertices, &triangles), n).open()
    }
}

/// What a reader repaired on its way, for the caller to report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReadReport {
    /// Triangles dropped because two of their corners are the same vertex or because their
    /// area is zero up to rounding: twice the area is at most `4 * f64::EPSILON` times the
    /// squared length of the longest edge. Polygons count once per triangle of their fan.
    pub degenerate_dropped: usize,
}

/// A mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// Wavefront OBJ (`.obj`), text.
    Obj,
    /// Stanford PLY (`.ply`): ASCII, binary little endian or binary big endian.
    Ply,
    /// STL (`.stl`): ASCII or binary.
    Stl,
    /// Object File Format (`.off`), text.
    Off,
}

impl Format {
    /// The format named by a file's extension, compared without regard to case.
    ///
    /// # Errors
    /// An error naming the file when the extension is missing or not one of `obj`, `ply`,
    /// `stl`, `off`.
    pub fn from_path(path: &Path) -> Result<Format> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("obj") => Ok(Format::Obj),
            Some("ply") => Ok(Format::Ply),
            Some("stl") => Ok(Format::Stl),
            Some("off") => Ok(Format::Off),
            _ => Err(Error::parse(
                path,
                None,
                "unknown mesh format: expected a file ending in .obj, .ply, .stl or .off",
            )),
        }
    }
}

/// Reads a mesh file, choosing the format by the file's extension (case-insensitive).
///
/// # Errors
/// One error naming the file (and the line or byte where it applies) when the file cannot be
/// read, its format is unknown, it is malformed or truncated, an index is out of range, a
/// coordinate is NaN or infinite, or the mesh is empty or flat. See the module doc.
pub fn read(path: &Path) -> Result<(Mesh, ReadReport)> {
    let format = Format::from_path(path)?;
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_bytes(&bytes, format, path)
}

/// Reads a mesh from the bytes of a file in `format`; `path` is used only in messages.
///
/// # Errors
/// As [`read`], except that nothing is read from disk.
pub fn read_bytes(bytes: &[u8], format: Format, path: &Path) -> Result<(Mesh, ReadReport)> {
    match format {
        Format::Obj => obj::read(bytes, path),
        Format::Ply => ply::read(bytes, path),
        Format::Stl => stl::read(bytes, path),
        Format::Off => off::read(bytes, path),
    }
}

/// Writes a mesh, choosing the format by the file's extension (case-insensitive):
/// OBJ as text, PLY as binary little endian with double (f64) positions, so it reads back
/// exactly, STL as binary (f32 positions, as the format requires), OFF as text. OBJ and OFF
/// print each coordinate in the shortest form that reads back to the same f64, so they too
/// round-trip exactly. The file is written atomically ([`crate::output`]).
///
/// # Errors
/// An error naming the file when its extension is unknown or it cannot be written, and an
/// error when a triangle indexes a vertex the mesh does not have.
pub fn write(path: &Path, mesh: &Mesh) -> Result<()> {
    let format = Format::from_path(path)?;
    check_indices(mesh, path)?;
    crate::output::write_with(path, |out| {
        let written = match format {
            Format::Obj => obj::write(out, mesh),
            Format::Ply => ply::write(out, mesh),
            Format::Stl => stl::write(out, mesh),
            Format::Off => off::write(out, mesh),
        };
        written.map_err(|e| Error::io(path, e))
    })
}

/// Checks that every triangle indexes an existing vertex, so the writers can index freely.
fn check_indices(mesh: &Mesh, path: &Path) -> Result<()> {
    let n = mesh.vertices.len();
    match mesh.triangles.iter().position(|t| t.iter().any(|&i| i as usize >= n)) {
        None => Ok(()),
        Some(t) => Err(Error::invalid(
            path.display().to_string(),
            format!(
                "cannot write the mesh: triangle {t} {:?} indexes past its {n} vertices",
                mesh.triangles[t]
            ),
        )),
    }
}
