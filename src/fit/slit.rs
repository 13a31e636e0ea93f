//! Slits narrower than a voxel: where two parts of the surface come closer than the grid's
//! spacing, the voxelization (paper 4.1) classifies too few voxel centres in the gap to keep
//! it, and the goal bridges it. Its walls then lie inside the goal's solid, as deep as the slit
//! goes, and a fit of the goal, however exact, misses them by that depth.
//!
//! ```text
//! walls = points on the mesh that the goal buries (its signed distance > the agreement)
//!         and whose two sides, a hundredth of a voxel off their triangle, the mesh's exact
//!         inside test puts one in and one out
//! carve : the goal's voxels nearest to each wall point and to the point half a voxel
//!         into the slit get density 0; the goal is made again from the densities
//! levels: the wall points are points on the mesh (goal value 0), and the opened voxels are
//!         outside (the side the model must have there, as for the band's voxels)
//! ```
//!
//! A carved slit is a gap of one or two voxels in the goal where the mesh has one narrower than
//! a voxel; the walls stay within about a voxel of the goal's surface. The detail levels put
//! the model's zero set through the walls and keep the opened voxels outside, so that the gap
//! is there at the grid's voxel centres, where a polygonizer on the grid sees it. A face with
//! the solid on both sides (an interior face, or two parts pressed together) is not a wall:
//! nothing is carved there. Only fits with detail levels have points on the mesh to find walls
//! with.

use rayon::prelude::*;
use serde::Serialize;

use crate::geometry::DVec3;
use crate::grid::Volume;
use crate::mesh_query::MeshQuery;
use crate::metrics::SubVoxel;

/// How far off its triangle the inside test looks at each side of a point, in voxels of the
/// grid asked for: far enough that rounding cannot put both points on the triangle, near
/// enough that a slit a tenth of a voxel wide has its gap within reach.
pub(crate) const WALL_STEP: f64 = 0.01;

/// Points drawn on the mesh to find slits' walls, for each point the detail levels fit: a slit
/// a few voxels across has few points of the levels' density on its walls, and each opens at
/// most two voxels of its gap.
pub(crate) const WALL_SAMPLES: usize = 4;

/// A point on a wall of a slit, mesh units, and the unit direction into the slit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    /// The point on the mesh.
    pub point: DVec3,
    /// The unit normal of its triangle, turned towards the slit (the mesh's outside).
    pub into_slit: DVec3,
}

/// The slits a goal was carved for ([`crate::fit::Goal::with_mesh_samples`]).
#[derive(Debug, Clone)]
pub struct Slits {
    /// The points on their walls, mesh units.
    pub(crate) walls: Vec<DVec3>,
    /// The share of the points on the mesh that lie on their walls.
    pub(crate) share: f64,
    /// The goal's voxels opened, by index: where the model must be outside.
    pub(crate) carved: Vec<u32>,
}

/// What a fit's report says of the slits narrower than a voxel that its goal was carved for.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SlitReport {
    /// The share of the mesh's surface on their walls (of the points sampled on it).
    pub share: f64,
    /// The points sampled on their walls.
    pub wall_points: usize,
    /// The goal's voxels opened.
    pub carved_voxels: usize,
    /// Of those, the voxels where the model is still inside after its last level: where a
    /// polygonizer on the grid may miss the slit.
    pub closed_voxels: usize,
    /// The box of their walls' points, mesh units: where they are.
    pub bounds: [[f64; 3]; 2],
}

impl Slits {
    /// The report of these slits, `closed_voxels` of the opened voxels left inside by the fit.
    pub fn report(&self, closed_voxels: usize) -> SlitReport {
        let (lo, hi) =
            self.walls.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            );
        SlitReport {
            share: self.share,
            wall_points: self.walls.len(),
            carved_voxels: self.carved.len(),
            closed_voxels,
            bounds: [lo.to_array(), hi.to_array()],
        }
    }
}

/// The points of `samples` (points on the mesh, mesh units, with their triangle's unit normal)
/// that lie on a slit's wall: the goal's sub-voxel signed distance `goal` buries them deeper
/// than `agreement` (its voxels), and `query`'s inside test has one side in and one out at
/// `step` (mesh units) off their triangle. `to_goal` takes a point to the goal's continuous
/// voxel coordinates.
pub fn walls(
    samples: &[(DVec3, DVec3)],
    goal: &SubVoxel<'_>,
    to_goal: impl Fn(DVec3) -> DVec3 + Sync,
    agreement: f32,
    query: &MeshQuery,
    step: f64,
) -> Vec<Wall> {
    let buried: Vec<(DVec3, DVec3)> = samples
        .par_iter()
        .filter(|(p, n)| *n != DVec3::ZERO && goal.signed_distance(to_goal(*p)) > agreement)
        .copied()
        .collect();
    let front: Vec<DVec3> = buried.iter().map(|&(p, n)| p + n * step).collect();
    let back: Vec<DVec3> = buried.iter().map(|&(p, n)| p - n * step).collect();
    let (front, back) = (query.inside(&front), query.inside(&back));
    buried
        .iter()
        .zip(front.iter().zip(&back))
        .filter(|(_, (f, b))| f != b)
        .map(|(&(point, n), (&front_inside, _))| Wall {
            point,
            into_slit: if front_inside { -n } else { n },
        })
        .collect()
}

/// Opens the slits of `walls` in `density` (the goal's densities, 1 inside): the voxel nearest
/// each wall point, and the one nearest the point half a voxel into the slit, get density 0.
/// `to_goal` as for [`walls`]. The voxels opened, by index.
pub fn carve(
    density: &mut Volume<f32>,
    walls: &[Wall],
    to_goal: impl Fn(DVec3) -> DVec3,
) -> Vec<u32> {
    let grid = density.grid;
    let voxel = grid.voxel_size;
    let mut opened = Vec::new();
    for wall in walls {
        for p in [wall.point, wall.point + wall.into_slit * (0.5 * voxel)] {
            let g = to_goal(p).round();
            let inside_grid = (0..3).all(|a| g[a] >= 0.0 && (g[a] as usize) < grid.dims[a]);
            if !inside_grid {
                continue;
            }
            let index = grid.index([g.x as usize, g.y as usize, g.z as usize]);
            if density.data[index] != 0.0 {
                density.data[index] = 0.0;
                opened.push(index as u32);
            }
        }
    }
    opened
}
