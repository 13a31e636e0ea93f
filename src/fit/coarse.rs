//! The coarse start: the first iterations of the fit run on the goal at half the resolution
//! (and on a grid of 512 voxels or more, those at half the resolution start at a quarter, and
//! so on: a pyramid of at most four levels).
//!
//! Paper 5.2 evaluates each model coarse to fine; this carries the idea across iterations. An
//! iteration costs about the same whatever its error: the volume evaluation and the current
//! surface's signed distance are linear in the number of voxels. The early ones, whose E is
//! tens of voxels, ask questions that a grid of half the resolution answers as well, for an
//! eighth of the cost. So when the grid is large, the loop first runs on the goal at half the
//! resolution (initialization of 5.1 included) until E there is at most `coarse_target_error`
//! or three quarters of the iteration limit are used; then the constraints of its best model,
//! moved to the full grid, are where the loop at full resolution starts, in place of the
//! initialization.
//!
//! The half-resolution goal is made from the goal's own densities: each coarse voxel averages a
//! 2 x 2 x 2 block of voxels, which is the density a voxelization at half the resolution with
//! twice the supersampling would give, without needing the mesh. Constraint positions and values
//! move to the full grid exactly (coarse voxel `c` is centred at fine coordinate `2c + 1/2`, less
//! the padding), and a coarse constraint's value, a signed distance, doubles.

use rayon::prelude::*;

use super::{FitConstraint, FitOptions, Goal};
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};

/// Empty coarse voxels added on every side, so that the coarse grid keeps a margin of at least
/// two empty voxels around the shape (the full grid's three make one and a half).
const PADDING: usize = 1;

/// The goal at half the resolution.
pub struct CoarseStart {
    /// The half-resolution goal.
    pub goal: Goal,
}

impl CoarseStart {
    /// The half-resolution goal of `goal`, or `None` where the fit starts at full resolution
    /// (a 2D grid, one smaller than `coarse_start_min_axis`, `coarse_start` off, or an iteration
    /// limit of 1).
    pub fn of(goal: &Goal, options: &FitOptions) -> Option<CoarseStart> {
        if !CoarseStart::wanted(goal.grid(), options) {
            return None;
        }
        let density = downsample(&goal.density);
        let mut coarse = Goal::from_density(density, &options.regularity);
        if let Some(mesh) = goal.mesh() {
            coarse = coarse.with_mesh(mesh.clone());
        }
        Some(CoarseStart { goal: coarse })
    }

    /// Whether a fit on `grid` with `options` has a coarse start ([`CoarseStart::of`] says
    /// when), known before its goal is made.
    pub fn wanted(grid: &Grid, options: &FitOptions) -> bool {
        let longest = grid.dims.iter().copied().max().unwrap_or(0);
        !grid.is_2d()
            && options.coarse_start
            && longest >= options.coarse_start_min_axis
            && options.max_iterations >= 2
    }

    /// The options of the loop at half the resolution: its target is the coarse start's, in
    /// its own voxels and measured at voxel centres, its growth per iteration the coarse
    /// start's, and it leaves at least a quarter of the iterations to the full grid (an
    /// iteration at half the resolution costs about an eighth of one on the full grid). Only a
    /// lower E counts as progress there (an RMS error 100% lower, never): once E stops falling
    /// for `patience` iterations, the next grid takes over, where the same constraints measure
    /// finer errors. It has a coarse start of its own only from twice the axis that gave it
    /// one, so that no level is shorter than `coarse_start_min_axis / 2` along its longest
    /// axis: a grid of 512 voxels starts at 128, one of 337 at 169.
    pub fn options(&self, options: &FitOptions) -> FitOptions {
        let target = options.coarse_target_error.max(options.target_error);
        FitOptions {
            target_error: target / 2.0,
            error_measure: super::ErrorMeasure::Voxel,
            max_iterations: options.max_iterations * 3 / 4,
            max_growth: options.coarse_max_growth,
            min_rms_improvement: 1.0,
            coarse_start_min_axis: options.coarse_start_min_axis.saturating_mul(2),
            ..options.clone()
        }
    }

    /// A constraint of the half-resolution loop on the grid of `full`, made as exact as the
    /// full grid allows: a boundary constraint moves to the nearest point of the full goal's
    /// surface (where [`Goal::project_to_surface`] finds one), a soft constraint takes the full
    /// goal's signed distance at its place.
    pub fn to_full(&self, c: &FitConstraint, full: &Goal) -> FitConstraint {
        let moved = self.moved(c);
        if c.value == 0.0 {
            let position = full.project_to_surface(moved.position).unwrap_or(moved.position);
            FitConstraint { position, ..moved }
        } else {
            let value = f64::from(full.sub_voxel().signed_distance(moved.position));
            FitConstraint { value, ..moved }
        }
    }

    /// A constraint of the half-resolution loop in the full grid's coordinates and voxels.
    fn moved(&self, c: &FitConstraint) -> FitConstraint {
        let shift = 0.5 - 2.0 * PADDING as f64;
        FitConstraint {
            position: c.position * 2.0 + DVec3::splat(shift),
            value: 2.0 * c.value,
            error: 2.0 * c.error,
        }
    }
}

/// The densities averaged over 2 x 2 x 2 blocks, with [`PADDING`] empty voxels on every side;
/// a block running past the grid's edge counts the voxels beyond it as empty.
fn downsample(fine: &Volume<f32>) -> Volume<f32> {
    let g = fine.grid;
    let dims = g.dims.map(|n| n.div_ceil(2) + 2 * PADDING);
    let shift = (0.5 - 2.0 * PADDING as f64) * g.voxel_size;
    let grid = Grid { dims, origin: g.origin.map(|o| o + shift), voxel_size: 2.0 * g.voxel_size };
    let mut data = vec![0.0f32; grid.len()];
    // The fine voxels of coarse index `c` along axis `a`.
    let block = |a: usize, c: usize| {
        let first = (2 * c).saturating_sub(2 * PADDING);
        let end = if c < PADDING { 0 } else { (2 * (c - PADDING) + 2).min(g.dims[a]) };
        first..end.max(first)
    };
    data.par_chunks_mut(dims[1] * dims[2]).enumerate().for_each(|(i, slab)| {
        for j in 0..dims[1] {
            for k in 0..dims[2] {
                let mut sum = 0.0;
                for fi in block(0, i) {
                    for fj in block(1, j) {
                        for fk in block(2, k) {
                            sum += fine.get([fi, fj, fk]);
                        }
                    }
                }
                slab[j * dims[2] + k] = sum / 8.0;
            }
        }
    });
    Volume { grid, data }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block of fine voxels lands on the coarse voxel whose centre is the block's centre, and
    /// a constraint there moves back to that centre.
    #[test]
    fn coarse_voxels_average_the_block_around_their_centre() {
        let fine_grid = Grid { dims: [8, 7, 6], origin: [10.0, -3.0, 0.5], voxel_size: 0.5 };
        let mut fine = Volume::filled(fine_grid, 0.0f32);
        for v in [[4, 2, 2], [5, 2, 2], [4, 3, 2], [5, 3, 2], [4, 2, 3], [5, 2, 3], [4, 3, 3]] {
            fine.data[fine_grid.index(v)] = 1.0;
        }
        let coarse = downsample(&fine);
        assert_eq!(coarse.grid.dims, [6, 6, 5]);
        assert_eq!(coarse.grid.voxel_size, 1.0);
        let c = [2 + PADDING, 1 + PADDING, 1 + PADDING];
        assert_eq!(*coarse.get(c), 7.0 / 8.0);
        assert_eq!(coarse.data.iter().sum::<f32>(), 7.0 / 8.0);
        // The coarse voxel's centre in world units is the block's centre.
        let centre = coarse.grid.to_world(DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64));
        let block_centre = fine_grid.to_world(DVec3::new(4.5, 2.5, 2.5));
        assert!(centre.distance(block_centre) < 1e-12);
        // And a constraint there moves to the block's centre, its value doubled.
        let density = Volume::filled(fine_grid, 0.0f32);
        let start = CoarseStart {
            goal: Goal::from_density(density, &crate::metrics::RegularityOptions::default()),
        };
        let position = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        let full = start.moved(&FitConstraint { position, value: -1.5, error: 2.0 });
        assert_eq!(full.position, DVec3::new(4.5, 2.5, 2.5));
        assert_eq!((full.value, full.error), (-3.0, 4.0));
    }

    /// A grid of 512 voxels starts at a quarter of its resolution (128 voxels), one of 300 at
    /// half (152, which would make a level of 77 below it), one of 100 on its own grid.
    #[test]
    fn large_grids_start_from_a_pyramid_of_coarse_starts() {
        let options = FitOptions::default();
        let levels = |longest: usize| {
            let grid = Grid { dims: [longest, 6, 5], origin: [0.0; 3], voxel_size: 1.0 };
            let density = Volume::filled(grid, 0.0f32);
            let mut goal = Goal::from_density(density, &options.regularity);
            let mut options = options.clone();
            let mut axes = vec![goal.grid().dims[0]];
            while let Some(start) = CoarseStart::of(&goal, &options) {
                options = start.options(&options);
                goal = start.goal;
                axes.push(goal.grid().dims[0]);
            }
            axes
        };
        assert_eq!(levels(512), [512, 258, 131]);
        assert_eq!(levels(300), [300, 152]);
        assert_eq!(levels(100), [100]);
    }
}
