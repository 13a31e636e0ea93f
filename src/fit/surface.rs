//! The goal's signed distance to sub-voxel precision, from its surface points (paper 4.3's
//! errors, measured off the voxel centres).
//!
//! The errors of the current surface's boundary are the goal's signed distance at points on the
//! current surface. From the densities alone (`(density - 1/2) / |∇density|`, [`SubVoxel`]) that
//! distance is only right close to the goal's surface: the densities of a voxelization are a
//! ramp about one voxel wide, flat beyond it, so further out the estimate is off (by up to 0.78
//! voxels within two voxels of a voxelized ball) and past its reach of 1.5 voxels gives way to the
//! voxel-centre distance: a current surface one to two voxels off the goal reads about 1.5
//! voxels off.
//!
//! Here the goal's surface is its surface points (one per goal boundary voxel, where the densities
//! cross 1/2), each taken as a small disk across the densities' gradient, and the distance is the
//! distance to the nearest disk. The disks' radius, half a voxel, covers the gaps between points
//! of neighbouring boundary voxels.
//!
//! [`SubVoxel`]: crate::metrics::SubVoxel

use rayon::prelude::*;

use crate::edt;
use crate::geometry::{AROUND, Cells, DVec3};
use crate::grid::Volume;

/// The side of the cells that index the points, in voxels: queries look at the 27 cells around
/// theirs, so every point within this distance is seen.
const CELL: f64 = 3.0;

/// The radius of each point's disk, in voxels.
const DISK_RADIUS: f64 = 0.5;

/// How far from the goal's voxel surface (voxels) distances are measured to the disks; beyond,
/// the voxel-centre distance stands.
pub(crate) const REACH: f32 = 2.5;

/// The normals of the goal's surface points and the points' cells; the points themselves stay
/// the goal's ([`super::Goal::surface`]).
#[derive(Debug, Clone)]
pub struct SurfaceDisks {
    /// Unit normals pointing inside (up the densities), zero where the densities are flat.
    normals: Vec<DVec3>,
    /// The points' indices, in cells of side [`CELL`].
    cells: Cells<u32>,
}

impl Default for SurfaceDisks {
    fn default() -> SurfaceDisks {
        SurfaceDisks { normals: Vec::new(), cells: Cells::new(CELL) }
    }
}

impl SurfaceDisks {
    /// The disks at `points`, on the surface of `density`.
    pub fn new(points: &[DVec3], density: &Volume<f32>) -> SurfaceDisks {
        let normals = points
            .par_iter()
            .map(|&p| edt::gradient(density, p).try_normalize().unwrap_or(DVec3::ZERO))
            .collect();
        let mut cells = Cells::new(CELL);
        for (i, &p) in points.iter().enumerate() {
            cells.insert(p, i as u32);
        }
        SurfaceDisks { normals, cells }
    }

    /// The signed distance (voxels, inside positive) from `q` to the nearest disk at `points`
    /// (the points these disks were made from), or `None`
    /// where no point lies in `q`'s cell or the 26 around it. Cells are visited from `q`'s own,
    /// and a cell whose box is further from `q` than the nearest disk so far (less the disks'
    /// radius) is skipped.
    pub(super) fn signed_distance(&self, points: &[DVec3], q: DVec3) -> Option<f32> {
        let home = self.cells.cell(q);
        let mut nearest: Option<(f64, f64)> = None;
        for offset in AROUND {
            let cell: [i64; 3] = std::array::from_fn(|a| home[a] + offset[a]);
            let reach = nearest.map_or(f64::INFINITY, |(best, _)| best + DISK_RADIUS);
            if self.cells.box_distance(q, cell) >= reach {
                continue;
            }
            for &i in self.cells.in_cell(cell) {
                let i = i as usize;
                let (d, side) = disk_distance(points[i], self.normals[i], q);
                if nearest.is_none_or(|(best, _)| d < best) {
                    nearest = Some((d, side));
                }
            }
        }
        nearest.map(|(d, side)| (d.copysign(side)) as f32)
    }
}

/// The distance from `q` to the disk at `point` across `normal`, and which side of it `q`
/// lies on (positive inside).
fn disk_distance(point: DVec3, normal: DVec3, q: DVec3) -> (f64, f64) {
    let v = q - point;
    let across = normal.dot(v);
    let along = (v.length_squared() - across * across).max(0.0).sqrt();
    let beyond = (along - DISK_RADIUS).max(0.0);
    ((across * across + beyond * beyond).sqrt(), across)
}
