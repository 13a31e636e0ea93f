//! Coarse-to-fine evaluation of a field over a voxel grid (paper 5.2).
//!
//! The fit evaluates the current implicit function over the whole volume every iteration, to
//! find its boundary voxels and signed distance. Evaluating every voxel is wasteful: far from
//! the surface the sign does not change. As in the paper, the field is sampled coarsely everywhere and voxel by voxel only where the sign may change or
//! near the goal boundary; [`evaluate_on_grid`] states the rule and what it can miss.

use rayon::prelude::*;

use crate::field::Field;
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};

/// The spacing of the coarse samples, in voxels.
pub const STEP: usize = 4;

/// Cubes with a voxel this close to the goal boundary (in voxels) are always sampled finely.
pub const NEAR_GOAL: f32 = 8.0;

/// The coarse samples along one axis and which coarse cells each voxel lies in.
struct Axis {
    /// Voxel indices of the coarse samples: 0, 4, 8, ... and the last voxel.
    nodes: Vec<usize>,
}

impl Axis {
    fn new(n: usize) -> Axis {
        let mut nodes: Vec<usize> = (0..n).step_by(STEP).collect();
        if nodes.last() != Some(&(n - 1)) {
            nodes.push(n - 1);
        }
        Axis { nodes }
    }

    /// The number of cells: one between each pair of samples, or one flat cell for one voxel.
    fn cells(&self) -> usize {
        (self.nodes.len() - 1).max(1)
    }

    /// The first and last voxel of cell `c`.
    fn span(&self, c: usize) -> (usize, usize) {
        (self.nodes[c], self.nodes[(c + 1).min(self.nodes.len() - 1)])
    }

    /// The first cell that holds voxel `i`, and the last (the same unless `i` is a sample
    /// between two cells).
    fn cells_of(&self, i: usize) -> (usize, usize) {
        let c = (i / STEP).min(self.cells() - 1);
        let (lo, _) = self.span(c);
        if i == lo && c > 0 { (c - 1, c) } else { (c, c) }
    }

    /// The sample index of voxel `i`, if it is a sample.
    fn node_of(&self, i: usize) -> Option<usize> {
        let c = i / STEP;
        if i % STEP == 0 {
            Some(c)
        } else if i == *self.nodes.last().expect("at least one node") {
            Some(self.nodes.len() - 1)
        } else {
            None
        }
    }

    /// The interpolation cell of voxel `i` and its fraction across it.
    fn locate(&self, i: usize) -> (usize, f64) {
        let (c, _) = self.cells_of(i);
        let (lo, hi) = self.span(c);
        let t = if hi > lo { (i - lo) as f64 / (hi - lo) as f64 } else { 0.0 };
        (c, t)
    }
}

/// Evaluates `field` at every voxel of `grid`, coarse to fine as in paper 5.2. Values are the
/// field's own (inside positive, outside negative), stored as f32: a volume needs the sign and
/// the rough size of the value, and f32 halves the memory of the paper's 200^3 volumes.
///
/// 1. The field is sampled at every 4th voxel along each axis (and at the last voxel, so grids
///    of any size are covered), which cuts the grid into coarse cubes.
/// 2. Every coarse cube whose eight corners do not all have the same strict sign, or, when
///    `goal_sd` (the goal's signed distance in voxels, on the same grid) is given, that has a
///    voxel with `|goal_sd| <= 8`, is sampled voxel by voxel.
/// 3. Every other voxel is filled by trilinear interpolation of its cube's corners, which keeps
///    their common sign.
///
/// # What this can miss
/// A piece of surface that lies entirely inside one coarse cube whose eight corners share a
/// sign, more than 8 voxels from the goal boundary: a detached component smaller than a coarse
/// cube (4 voxels across), or a thin bump poking between corners, far from where the shape
/// should be. Near the goal boundary, where the fit works, nothing is missed, and a stray
/// component at least a coarse cube across always contains a corner and is found.
///
/// # Panics
/// If `goal_sd` is on a grid of other dimensions than `grid`.
pub fn evaluate_on_grid<F: Field + ?Sized>(
    field: &F,
    grid: &Grid,
    goal_sd: Option<&Volume<f32>>,
) -> Volume<f32> {
    if let Some(goal) = goal_sd {
        assert_eq!(goal.grid.dims, grid.dims, "the goal volume must be on the evaluation grid");
    }
    let axes = grid.dims.map(Axis::new);
    let coarse = coarse_values(field, grid, &axes);
    let flagged = flag_cells(grid, &axes, &coarse, goal_sd);
    let exact = exact_voxels(grid, &axes, &flagged);
    let positions: Vec<DVec3> = exact.par_iter().map(|&v| grid.position(grid.voxel(v))).collect();
    let exact_values = field.values(&positions);
    let mut data = interpolate(grid, &axes, &coarse);
    for (&v, &value) in exact.iter().zip(&exact_values) {
        data[v] = value as f32;
    }
    Volume { grid: *grid, data }
}

/// The field at the coarse samples, C order over the sample indices.
struct Coarse {
    dims: [usize; 3],
    values: Vec<f64>,
}

impl Coarse {
    #[inline]
    fn at(&self, [a, b, c]: [usize; 3]) -> f64 {
        self.values[(a * self.dims[1] + b) * self.dims[2] + c]
    }
}

fn coarse_values<F: Field + ?Sized>(field: &F, grid: &Grid, axes: &[Axis; 3]) -> Coarse {
    let dims = [0, 1, 2].map(|a| axes[a].nodes.len());
    let positions: Vec<DVec3> = (0..dims[0] * dims[1] * dims[2])
        .into_par_iter()
        .map(|s| {
            let (a, b, c) = (s / (dims[1] * dims[2]), (s / dims[2]) % dims[1], s % dims[2]);
            grid.position([axes[0].nodes[a], axes[1].nodes[b], axes[2].nodes[c]])
        })
        .collect();
    Coarse { dims, values: field.values(&positions) }
}

/// Whether each coarse cell must be sampled finely, C order over the cell indices.
fn flag_cells(
    grid: &Grid,
    axes: &[Axis; 3],
    coarse: &Coarse,
    goal_sd: Option<&Volume<f32>>,
) -> Vec<bool> {
    let cells = [0, 1, 2].map(|a| axes[a].cells());
    (0..cells[0] * cells[1] * cells[2])
        .into_par_iter()
        .map(|s| {
            let cell = [s / (cells[1] * cells[2]), (s / cells[2]) % cells[1], s % cells[2]];
            let spans = [0, 1, 2].map(|a| axes[a].span(cell[a]));
            sign_changes(coarse, axes, cell) || goal_sd.is_some_and(|g| near_goal(grid, g, spans))
        })
        .collect()
}

/// Whether the corners of a cell do not all share a strict sign.
fn sign_changes(coarse: &Coarse, axes: &[Axis; 3], cell: [usize; 3]) -> bool {
    let (mut positive, mut negative) = (false, false);
    let corner = |a: usize, d: usize| (cell[a] + d).min(axes[a].nodes.len() - 1);
    for da in 0..2 {
        for db in 0..2 {
            for dc in 0..2 {
                let v = coarse.at([corner(0, da), corner(1, db), corner(2, dc)]);
                positive |= v > 0.0;
                negative |= v < 0.0;
                if v == 0.0 || v.is_nan() || (positive && negative) {
                    return true;
                }
            }
        }
    }
    false
}

/// Whether any voxel of the cell spanning `spans` is within [`NEAR_GOAL`] of the goal boundary.
fn near_goal(grid: &Grid, goal: &Volume<f32>, spans: [(usize, usize); 3]) -> bool {
    for i in spans[0].0..=spans[0].1 {
        for j in spans[1].0..=spans[1].1 {
            let row = grid.index([i, j, 0]);
            if goal.data[row + spans[2].0..=row + spans[2].1].iter().any(|v| v.abs() <= NEAR_GOAL) {
                return true;
            }
        }
    }
    false
}

/// The linear indices of the voxels to evaluate exactly: those of a flagged cell that are not
/// coarse samples, in increasing order.
fn exact_voxels(grid: &Grid, axes: &[Axis; 3], flagged: &[bool]) -> Vec<usize> {
    let cells = [0, 1, 2].map(|a| axes[a].cells());
    let [nx, ny, nz] = grid.dims;
    let is_flagged = |voxel: [usize; 3]| {
        let ranges = [0, 1, 2].map(|a| axes[a].cells_of(voxel[a]));
        (ranges[0].0..=ranges[0].1).any(|a| {
            (ranges[1].0..=ranges[1].1).any(|b| {
                (ranges[2].0..=ranges[2].1).any(|c| flagged[(a * cells[1] + b) * cells[2] + c])
            })
        })
    };
    (0..nx)
        .into_par_iter()
        .flat_map_iter(|i| {
            (0..ny).flat_map(move |j| (0..nz).map(move |k| [i, j, k])).filter_map(move |v| {
                let sample = (0..3).all(|a| axes[a].node_of(v[a]).is_some());
                (!sample && is_flagged(v)).then(|| grid.index(v))
            })
        })
        .collect()
}

/// Every voxel from the coarse samples: exact at samples, trilinear in between.
fn interpolate(grid: &Grid, axes: &[Axis; 3], coarse: &Coarse) -> Vec<f32> {
    let [_, ny, nz] = grid.dims;
    let locate: [Vec<(usize, f64)>; 3] =
        [0, 1, 2].map(|a| (0..grid.dims[a]).map(|i| axes[a].locate(i)).collect());
    let last = coarse.dims.map(|d| d - 1);
    let mut data = vec![0.0f32; grid.len()];
    data.par_chunks_mut(ny * nz).enumerate().for_each(|(i, slab)| {
        let (a, ta) = locate[0][i];
        for j in 0..ny {
            let (b, tb) = locate[1][j];
            for k in 0..nz {
                let (c, tc) = locate[2][k];
                let mut v = 0.0;
                for (da, wa) in [(0, 1.0 - ta), (1, ta)] {
                    for (db, wb) in [(0, 1.0 - tb), (1, tb)] {
                        for (dc, wc) in [(0, 1.0 - tc), (1, tc)] {
                            let w = wa * wb * wc;
                            if w != 0.0 {
                                let s = [
                                    (a + da).min(last[0]),
                                    (b + db).min(last[1]),
                                    (c + dc).min(last[2]),
                                ];
                                v += w * coarse.at(s);
                            }
                        }
                    }
                }
                slab[j * nz + k] = v as f32;
            }
        }
    });
    data
}
