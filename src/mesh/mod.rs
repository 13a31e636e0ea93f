//! Triangle meshes: the input of the whole pipeline and the output of polygonization.
//!
//! A [`Mesh`] is a list of vertex positions (f64, in the file's own units) and triangles that
//! index them. Readers and writers for OBJ, PLY, STL and OFF live in the submodules.

use crate::geometry::{Aabb, DVec3};

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
        Aabb::of_points(self.triangles.iter().flatten().map(|&i| &self.vertices[i as usize]))
    }

    /// The three corners of triangle `t`.
    #[inline]
    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|i| self.vertices[i as usize])
    }
}
