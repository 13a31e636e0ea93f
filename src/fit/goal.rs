//! The goal shape the fit approximates: the voxelized mesh (paper 4.1), its signed distance
//! (4.2), its boundary voxels ∂f_goal and their radii of regularity (4.3).

use rayon::prelude::*;

use crate::distance;
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};
use crate::metrics::{self, RegularityOptions, SubVoxel};

/// Everything the fit needs to know about the goal shape, computed once.
#[derive(Debug, Clone)]
pub struct Goal {
    /// Densities in [0, 1], 1 inside; boundary constraints sit where they cross 1/2.
    pub density: Volume<f32>,
    /// The goal's signed distance sd_goal, voxel units, inside positive.
    pub sd: Volume<f32>,
    /// The goal's boundary voxels ∂f_goal.
    pub boundary: Vec<[usize; 3]>,
    /// The goal's radius of regularity at each boundary voxel, in voxels.
    pub rreg: Vec<f32>,
    /// The point where the densities cross 1/2 at each boundary voxel, in continuous voxel
    /// coordinates: where boundary constraints go (5.3, "at sub-voxel precision").
    pub surface: Vec<DVec3>,
}

impl Goal {
    /// The goal of a density volume (from [`crate::voxelize::voxelize`], or an image in 2D).
    pub fn from_density(density: Volume<f32>, regularity: &RegularityOptions) -> Goal {
        let sd = distance::signed_distance(&distance::inside(&density));
        let boundary = distance::boundary_voxels(&sd);
        let rreg = metrics::radii_of_regularity(&sd, &boundary, regularity);
        let surface = boundary.par_iter().map(|&v| distance::surface_point(&density, v)).collect();
        Goal { density, sd, boundary, rreg, surface }
    }

    /// The grid the goal lives on.
    pub fn grid(&self) -> &Grid {
        &self.density.grid
    }

    /// The goal's signed distance to sub-voxel precision, from the densities near the surface.
    pub fn sub_voxel(&self) -> SubVoxel<'_> {
        SubVoxel { values: &self.density, level: 0.5, sd: &self.sd, reach: 1.5 }
    }
}
