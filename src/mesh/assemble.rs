//! What every reader shares: collecting vertices and polygons, splitting polygons into
//! triangles, dropping degenerate triangles and checking that the result is a usable mesh
//! (non-empty, with volume). The guarantees are listed in the parent module's doc.

use std::path::Path;

use crate::error::{Error, Location, Result};
use crate::geometry::DVec3;

use super::{Mesh, ReadReport};

/// Twice a triangle's area at or below this times its longest edge squared counts as zero:
/// a few units of rounding in the cross product of two edges.
const ZERO_AREA: f64 = 4.0 * f64::EPSILON;

/// An extent along an axis at or below this times the largest extent counts as flat.
const FLAT: f64 = 1e-12;

/// Collects a mesh as a reader finds it, then checks it.
pub(super) struct Builder<'p> {
    path: &'p Path,
    vertices: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
}

impl<'p> Builder<'p> {
    /// An empty mesh read from `path` (named in every error).
    pub fn new(path: &'p Path) -> Self {
        Builder { path, vertices: Vec::new(), triangles: Vec::new() }
    }

    /// The number of vertices added so far.
    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// Adds a vertex read at `at`, which must have finite coordinates.
    pub fn vertex(&mut self, p: [f64; 3], at: Location) -> Result<()> {
        if let Some(axis) = p.iter().position(|c| !c.is_finite()) {
            return Err(self.error(
                at,
                format!(
                    "vertex {} has a non-finite {} coordinate ({})",
                    self.vertices.len(),
                    ["x", "y", "z"][axis],
                    p[axis]
                ),
            ));
        }
        if self.vertices.len() > u32::MAX as usize {
            return Err(self.error(at, format!("more than {} vertices", u32::MAX)));
        }
        self.vertices.push(DVec3::from_array(p));
        Ok(())
    }

    /// Checks a 0-based vertex index `i` read at `at` against the file's `count` vertices.
    pub fn corner(&self, i: i64, count: usize, at: Location) -> Result<u32> {
        match u32::try_from(i) {
            Ok(c) if (c as usize) < count => Ok(c),
            _ => Err(self.error(
                at,
                format!(
                    "vertex index {i} out of range: the file has {count} vertices, numbered from 0"
                ),
            )),
        }
    }

    /// Adds a polygon read at `at` whose corners are already checked, as a fan of triangles
    /// around its first corner.
    pub fn polygon(&mut self, corners: &[u32], at: Location) -> Result<()> {
        if corners.len() < 3 {
            return Err(self.error(
                at,
                format!("a face needs at least 3 corners, this one has {}", corners.len()),
            ));
        }
        let first = corners[0];
        self.triangles.extend(corners[1..].windows(2).map(|w| [first, w[0], w[1]]));
        Ok(())
    }

    /// A parse error at `at` in this builder's file.
    pub fn error(&self, at: Location, message: impl Into<String>) -> Error {
        Error::parse(self.path, Some(at), message)
    }

    /// Drops degenerate triangles and checks that what is left is a mesh with volume.
    pub fn finish(self) -> Result<(Mesh, ReadReport)> {
        let Builder { path, vertices, mut triangles } = self;
        let read = triangles.len();
        triangles.retain(|t| !is_degenerate(&vertices, *t));
        let report = ReadReport { degenerate_dropped: read - triangles.len() };
        let mesh = Mesh { vertices, triangles };
        let invalid = |message: String| Error::invalid(path.display().to_string(), message);
        let Some(bounds) = mesh.bounds() else {
            return Err(invalid(if read == 0 {
                "empty mesh: the file has no faces".to_string()
            } else {
                format!(
                    "empty mesh: all {read} triangles are degenerate (repeated corners or zero area)"
                )
            }));
        };
        let size = bounds.size();
        if let Some(axis) = (0..3).find(|&a| size[a] <= FLAT * size.max_element()) {
            return Err(invalid(format!(
                "the mesh is flat: it has no extent along {} (its size is {} x {} x {}), so it \
                 encloses no volume",
                ["x", "y", "z"][axis],
                size.x,
                size.y,
                size.z
            )));
        }
        Ok((mesh, report))
    }
}

/// Whether a triangle repeats a corner or has zero area up to rounding.
fn is_degenerate(vertices: &[DVec3], [i, j, k]: [u32; 3]) -> bool {
    if i == j || j == k || k == i {
        return true;
    }
    let [a, b, c] = [i, j, k].map(|v| vertices[v as usize]);
    let longest =
        (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
    (b - a).cross(c - a).length() <= ZERO_AREA * longest
}
