//! The paper's figure 3: the goal surface of a voxelized mesh coloured by its radius of
//! regularity (section 4.3), small radii red and large ones green.
//!
//! The goal surface is where the densities of the mesh's voxelization cross 1/2 (4.1), the
//! same sub-voxel surface the fit places its boundary constraints on (5.3); it lies between
//! the goal's boundary voxels (signed distance 1/2 inside, 4.2) and their outside neighbours.
//! The zero set of the signed distance itself would be a staircase of voxel faces. Each vertex
//! takes the radius of the nearest goal boundary voxel.

use std::collections::HashMap;

use implicitize::fit::Goal;
use implicitize::fit::RegularityOptions;
use implicitize::polygonize::polygonize;
use implicitize::render::{Camera, Image, render_mesh_scalars};
use implicitize::{DVec3, Result, mesh::Mesh};

/// How far, in voxels along each axis, the nearest boundary voxel is looked for. A goal
/// surface vertex lies on the segment between an inside voxel with signed distance 1/2 (a
/// boundary voxel) and an outside one, so the nearest boundary voxel is at most one step from
/// the voxel nearest the vertex; two steps leave room for the corners of the lattice walk.
const RREG_REACH: i64 = 2;

/// The goal surface of `goal` (mesh units) and the radius of regularity at each of its
/// vertices, in voxels: that of the nearest goal boundary voxel, or NaN where there is none
/// within two voxels (drawn grey).
fn goal_surface_rreg(goal: &Goal) -> (Mesh, Vec<f32>) {
    let grid = goal.grid();
    let surface = polygonize(goal.density(), 0.5);
    let rreg_at: HashMap<[usize; 3], f32> =
        goal.boundary().iter().copied().zip(goal.rreg().iter().copied()).collect();
    let rreg = surface
        .vertices
        .iter()
        .map(|&v| nearest_rreg(&rreg_at, grid.dims, grid.to_grid(v)))
        .collect();
    (surface, rreg)
}

/// The goal surface of `goal` seen through `camera`, coloured by its radius of regularity
/// from red at `regularity.min_radius` to green at `regularity.max_radius` (figure 3).
///
/// # Errors
/// As [`render_mesh_scalars`].
pub fn figure3(goal: &Goal, regularity: &RegularityOptions, camera: &Camera) -> Result<Image> {
    let (surface, rreg) = goal_surface_rreg(goal);
    let range = (regularity.min_radius as f32, regularity.max_radius as f32);
    render_mesh_scalars(&surface, &rreg, range, camera)
}

/// The radius of regularity of the boundary voxel nearest `g` (continuous voxel coordinates)
/// within [`RREG_REACH`], or NaN when there is none.
fn nearest_rreg(rreg_at: &HashMap<[usize; 3], f32>, dims: [usize; 3], g: DVec3) -> f32 {
    let centre = g.round();
    let mut best = (f64::INFINITY, f32::NAN);
    for di in -RREG_REACH..=RREG_REACH {
        for dj in -RREG_REACH..=RREG_REACH {
            for dk in -RREG_REACH..=RREG_REACH {
                let v = centre + DVec3::new(di as f64, dj as f64, dk as f64);
                let Some(voxel) = voxel_at(v, dims) else { continue };
                if let Some(&r) = rreg_at.get(&voxel) {
                    let d = v.distance_squared(g);
                    if d < best.0 {
                        best = (d, r);
                    }
                }
            }
        }
    }
    best.1
}

/// The voxel at integer coordinates `v`, if it lies in a grid of `dims`.
fn voxel_at(v: DVec3, dims: [usize; 3]) -> Option<[usize; 3]> {
    let inside = v.cmpge(DVec3::ZERO).all()
        && v.x < dims[0] as f64
        && v.y < dims[1] as f64
        && v.z < dims[2] as f64;
    inside.then_some([v.x as usize, v.y as usize, v.z as usize])
}
