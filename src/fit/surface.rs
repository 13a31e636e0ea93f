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

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use rayon::prelude::*;

use crate::edt;
use crate::geometry::DVec3;
use crate::grid::Volume;
use crate::polygonize::IndexHasher;

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
#[derive(Debug, Clone, Default)]
pub struct SurfaceDisks {
    /// Unit normals pointing inside (up the densities), zero where the densities are flat.
    normals: Vec<DVec3>,
    /// The points of each cell, by [`key`].
    cells: HashMap<u64, Vec<u32>, BuildHasherDefault<IndexHasher>>,
}

impl SurfaceDisks {
    /// The disks at `points`, on the surface of `density`.
    pub fn new(points: &[DVec3], density: &Volume<f32>) -> SurfaceDisks {
        let normals = points
            .par_iter()
            .map(|&p| edt::gradient(density, p).try_normalize().unwrap_or(DVec3::ZERO))
            .collect();
        let mut cells: HashMap<u64, Vec<u32>, BuildHasherDefault<IndexHasher>> = HashMap::default();
        for (i, &p) in points.iter().enumerate() {
            cells.entry(key(cell_of(p))).or_default().push(i as u32);
        }
        SurfaceDisks { normals, cells }
    }

    /// The signed distance (voxels, inside positive) from `q` to the nearest disk at `points`
    /// (the points these disks were made from), or `None`
    /// where no point lies in `q`'s cell or the 26 around it. Cells are visited from `q`'s own,
    /// and a cell whose box is further from `q` than the nearest disk so far (less the disks'
    /// radius) is skipped.
    pub(super) fn signed_distance(&self, points: &[DVec3], q: DVec3) -> Option<f32> {
        let home = cell_of(q);
        let mut nearest: Option<(f64, f64)> = None;
        for offset in AROUND {
            let cell: [i64; 3] = std::array::from_fn(|a| home[a] + offset[a]);
            let reach = nearest.map_or(f64::INFINITY, |(best, _)| best + DISK_RADIUS);
            if box_distance(q, cell) >= reach {
                continue;
            }
            let Some(indices) = self.cells.get(&key(cell)) else { continue };
            for &i in indices {
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

/// The 27 cells around a cell, its own first.
const AROUND: [[i64; 3]; 27] = {
    let mut around = [[0; 3]; 27];
    let mut n = 1;
    let mut i = 0;
    while i < 27 {
        let offset = [i as i64 / 9 - 1, i as i64 / 3 % 3 - 1, i as i64 % 3 - 1];
        if i != 13 {
            around[n] = offset;
            n += 1;
        }
        i += 1;
    }
    around
};

fn cell_of(p: DVec3) -> [i64; 3] {
    (p / CELL).floor().to_array().map(|c| c as i64)
}

/// A cell's key in the map: 21 bits an axis (the cells of any grid, and their wrapped
/// neighbours below 0, stay apart).
fn key(cell: [i64; 3]) -> u64 {
    cell.iter().fold(0, |k, &c| (k << 21) | (c as u64 & 0x1f_ffff))
}

/// The distance from `q` to the box of `cell`.
fn box_distance(q: DVec3, cell: [i64; 3]) -> f64 {
    let lo = DVec3::from_array(cell.map(|c| c as f64)) * CELL;
    let outside = (lo - q).max(q - (lo + CELL)).max(DVec3::ZERO);
    outside.length()
}
