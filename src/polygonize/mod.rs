//! Iso-surface extraction: volumes and fields to closed, consistently oriented triangle meshes.
//!
//! The paper shows its implicit surfaces as polygon meshes (figures 1, 4 and 5) and evaluates
//! them on the voxel grid (section 5.2); this module turns such a grid of values back into a
//! mesh. [`polygonize`] extracts any iso level of a stored volume; [`polygonize_field`]
//! extracts the zero set of a [`Field`] sampled on a grid and moves each vertex onto the
//! field's true zero along its grid edge. It follows the surface from points known to lie on it
//! when the field offers them (a fitted model's boundary constraints), evaluating the field
//! only around the surface, and evaluates the whole grid ([`polygonize_field_dense`])
//! otherwise.
//!
//! ## Method: marching tetrahedra
//! Every cube of eight neighbouring voxel centres is split into six tetrahedra along its main
//! diagonal, the same way in every cube, and the surface is extracted tetrahedron by
//! tetrahedron (one triangle or one quad each). This was chosen over marching cubes because
//! a tetrahedron has no ambiguous cases: the split tiles space, neighbouring cubes agree on the
//! diagonals of the faces they share, and so the surface is watertight and consistently
//! oriented by construction, with a table small enough to be derived in code rather than
//! copied. The cost is about twice as many triangles as marching cubes. The marching cubes
//! crates on crates.io (marching-cubes, mcubes, isosurface) are single-threaded and use the
//! classic ambiguous table, so they miss the guarantees below or the speed target.
//!
//! ## Guarantees
//! - Sign convention: inside is positive. A value at or above the iso level is inside, below
//!   it (or NaN) is outside, consistently for every cube.
//! - Triangles are counter-clockwise seen from outside: normals point toward decreasing
//!   values. Vertices are shared: each lies on one grid edge and is made once.
//! - Where the surface is closed inside the grid, every edge of the mesh is used by exactly
//!   two triangles, in opposite directions. A surface cut by the grid's bounds is left open
//!   there and only there.
//! - No triangle has zero area: vertices are kept at least 0.001 of an edge from its ends (a
//!   value exactly at the iso level would otherwise collapse triangles onto a voxel centre).
//! - Vertices are in the mesh's units ([`Grid::to_world`] of their continuous voxel position).
//!   Positions are f64; [`polygonize`] reads f32 volumes, [`polygonize_field`] samples in f64.
//! - A grid with fewer than two voxels along some axis (such as a 2D grid) holds no cube and
//!   gives an empty mesh.
//!
//! ## Which components surface following finds
//! [`polygonize_field`] of a field with surface points does not look at every voxel. It starts
//! from seed cubes and grows through the faces the surface crosses, so it finds whole
//! components of the surface [`polygonize_field_dense`] extracts, and a component it finds is
//! exactly the dense one: the same vertex positions, the same triangles, in the same order
//! (the indices skip what is left out), given a field whose value at a point does not depend
//! on the other points of a [`Field::values`] call, as every field of this crate. Everything
//! above therefore holds for it too. A component is found when
//! 1. it passes through one of the eight cubes that have as a corner the voxel nearest one of
//!    the field's surface points ([`Field::surface_points`]); or
//! 2. it crosses the grid line between two neighbouring nodes of a coarse lattice that lie on
//!    opposite sides of the surface. The lattice's nodes are the voxels whose indices are
//!    multiples of 8 or the last along every axis.
//!
//! Every other component is missed. A closed piece that holds no lattice node can be (a ball
//! less than 8√3 ≈ 13.9 voxels across may fit between the nodes, and so may a plate thinner
//! than 8 voxels), unless it passes by a surface point or a lattice edge with opposite ends
//! crosses it. A fitted model has surface points all over its surface, so what can be missed
//! are such small or thin detached pieces away from its constraints;
//! [`polygonize_field_dense`] shows those too.
//!
//! ## Cost
//! [`polygonize`] runs in parallel over slabs of the grid with rayon; the only allocations are
//! per slab (vertex maps of a few layers) and the output itself. [`polygonize_field_dense`]
//! evaluates the field once per voxel, then at most six times per vertex. Surface following
//! evaluates the field at the corners of the cubes the surface crosses, at the coarse lattice's
//! nodes (one voxel in 512), at the voxels of the lattice edges with a sign change and around
//! the surface points, a frontier of cubes per [`Field::values`] call, then at most six times
//! per vertex; it stores only the values and cubes it visits, in hash maps.

mod extract;
mod refine;
mod tables;
mod track;

use rayon::prelude::*;

use crate::field::Field;
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};
use crate::mesh::Mesh;
use extract::EdgeVertex;

/// The iso-surface of `volume` at level `iso`, as a triangle mesh in the volume's mesh units.
///
/// Values `>= iso` are inside (positive side, per the crate's sign convention); triangles are
/// counter-clockwise seen from outside, so normals point toward decreasing values. The mesh is
/// closed wherever the surface is closed inside the grid.
///
/// The result is the same whatever the number of threads.
///
/// # Panics
/// If `volume.data` does not hold exactly one value per voxel of `volume.grid`, or if the mesh
/// would need more than 2^32 vertices (far beyond any volume that fits in memory today).
pub fn polygonize(volume: &Volume<f32>, iso: f32) -> Mesh {
    extract::extract(volume, iso).into_mesh()
}

/// The zero set of `field` (inside positive) sampled on `grid`, with every vertex moved onto
/// the field's zero along its grid edge.
///
/// When the field offers surface points ([`Field::surface_points`]), the surface is followed
/// from them and from the sign changes of a coarse lattice, evaluating the field only around
/// the surface; the result is [`polygonize_field_dense`]'s mesh without the components that
/// neither reaches (see [the guarantee](self#which-components-surface-following-finds)).
/// Otherwise this is [`polygonize_field_dense`].
///
/// # Panics
/// As for [`polygonize_field_dense`].
pub fn polygonize_field<F: Field + ?Sized>(field: &F, grid: &Grid) -> Mesh {
    let seeds = field.surface_points();
    if seeds.is_empty() {
        return polygonize_field_dense(field, grid);
    }
    let (mut surface, ends) = track::track(field, grid, &seeds);
    refine::refine(field, grid, &mut surface.vertices, ends);
    surface.into_mesh()
}

/// The zero set of `field` (inside positive) sampled at every voxel of `grid`, with every
/// vertex moved onto the field's zero along its grid edge: every component, at the cost of
/// evaluating the whole grid.
///
/// The field is evaluated at every voxel centre through [`Field::values`] (in parallel), the
/// surface is extracted as by [`polygonize`] at level 0, then each vertex is refined with a few
/// safeguarded regula falsi steps within its edge, so it lies on the field's surface rather
/// than on the linear interpolation of the samples. Orientation, sharing and closedness are as
/// for [`polygonize`].
///
/// # Panics
/// If the field's [`Field::values`] returns a different number of values than points, or as
/// for [`polygonize`].
pub fn polygonize_field_dense<F: Field + ?Sized>(field: &F, grid: &Grid) -> Mesh {
    let samples = sample(field, grid);
    let mut surface = extract::extract(&samples, 0.0);
    let ends = |v: &EdgeVertex| v.line(grid).map(|n| n.map_or(f64::NAN, |n| samples.data[n]));
    refine::refine(field, grid, &mut surface.vertices, ends);
    surface.into_mesh()
}

/// Voxels evaluated per call of [`Field::values`], to bound the memory of the point lists.
const SAMPLE_CHUNK: usize = 1 << 20;

/// The field's values at every voxel centre of `grid`, in f64 so that the signs extracted are
/// the field's own.
fn sample<F: Field + ?Sized>(field: &F, grid: &Grid) -> Volume<f64> {
    let mut data = Vec::with_capacity(grid.len());
    let mut start = 0;
    while start < grid.len() {
        let end = (start + SAMPLE_CHUNK).min(grid.len());
        let points: Vec<DVec3> =
            (start..end).into_par_iter().map(|n| grid.position(grid.voxel(n))).collect();
        let values = field.values(&points);
        assert_eq!(values.len(), points.len(), "Field::values must return one value per point");
        data.extend(values);
        start = end;
    }
    Volume { grid: *grid, data }
}
