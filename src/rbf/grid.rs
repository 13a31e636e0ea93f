//! Coarse-to-fine evaluation of a field over a voxel grid (paper 5.2).
//!
//! The fit evaluates the current implicit function over the whole volume every iteration, to
//! find its boundary voxels and signed distance. Evaluating every voxel is wasteful: far from
//! the surface the sign does not change. As in the paper, the field is sampled coarsely
//! everywhere and voxel by voxel only where the sign may change or near the goal boundary, with
//! one level in between; [`evaluate_on_grid`] states the rule and what it can miss.

use rayon::prelude::*;

use crate::field::Field;
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};

/// The spacing of the coarse samples, in voxels.
pub(crate) const STEP: usize = 4;

/// Cubes with a voxel this close to the goal boundary (in voxels) are always refined.
pub(crate) const NEAR_GOAL: f32 = 8.0;

/// The middle level's margin on its slope bound (see [`evaluate_on_grid`]).
pub(crate) const SLOPE_SAFETY: f64 = 2.0;

/// Grids with at least this many voxels along an axis start from a sparser lattice, every
/// `2 STEP`th voxel (see [`evaluate_on_grid`]).
pub(crate) const SPARSE_FROM: usize = 256;

/// The samples of one level along one axis: every `step`th voxel and the last one.
struct Axis {
    nodes: Vec<usize>,
    /// The cell holding each voxel (a voxel on a cell's upper end belongs to the next cell,
    /// except the last voxel).
    cell: Vec<u32>,
    /// How far across its cell each voxel lies, from 0 at the cell's start to 1 at its end.
    fraction: Vec<f32>,
}

impl Axis {
    fn new(n: usize, step: usize) -> Axis {
        let mut nodes: Vec<usize> = (0..n).step_by(step).collect();
        if nodes.last() != Some(&(n - 1)) {
            nodes.push(n - 1);
        }
        let cells = (nodes.len() - 1).max(1);
        let cell: Vec<u32> = (0..n).map(|i| (i / step).min(cells - 1) as u32).collect();
        let fraction = (0..n)
            .map(|i| {
                let c = cell[i] as usize;
                let (lo, hi) = (nodes[c], nodes[(c + 1).min(nodes.len() - 1)]);
                if hi > lo { (i - lo) as f32 / (hi - lo) as f32 } else { 0.0 }
            })
            .collect();
        Axis { nodes, cell, fraction }
    }

    /// The number of cells: one between each pair of samples, or one flat cell for one voxel.
    fn cells(&self) -> usize {
        (self.nodes.len() - 1).max(1)
    }

    /// The first and last voxel of cell `c`.
    fn span(&self, c: usize) -> (usize, usize) {
        (self.nodes[c], self.nodes[(c + 1).min(self.nodes.len() - 1)])
    }

    /// Where voxel `i` lies: its cell's span and the fraction across it.
    fn locate(&self, i: usize) -> ((usize, usize), f64) {
        let (lo, hi) = self.span(self.cell[i] as usize);
        ((lo, hi), if hi > lo { (i - lo) as f64 / (hi - lo) as f64 } else { 0.0 })
    }

    /// The cells of this (finer) axis inside the span `(lo, hi)` of a coarser one.
    fn cells_within(&self, (lo, hi): (usize, usize)) -> std::ops::Range<usize> {
        let first = self.cell[lo] as usize;
        if hi == lo { first..first + 1 } else { first..self.cell[hi - 1] as usize + 1 }
    }
}

/// One level of samples over the grid: an axis per dimension.
struct Level {
    axes: [Axis; 3],
}

impl Level {
    fn new(grid: &Grid, step: usize) -> Level {
        Level { axes: grid.dims.map(|n| Axis::new(n, step)) }
    }

    fn cell_count(&self) -> usize {
        self.axes.iter().map(Axis::cells).product()
    }

    fn cell_of_index(&self, s: usize) -> [usize; 3] {
        let cells = self.axes.each_ref().map(Axis::cells);
        [s / (cells[1] * cells[2]), (s / cells[2]) % cells[1], s % cells[2]]
    }

    fn cell_index(&self, cell: [usize; 3]) -> usize {
        let cells = self.axes.each_ref().map(Axis::cells);
        (cell[0] * cells[1] + cell[1]) * cells[2] + cell[2]
    }

    fn spans(&self, cell: [usize; 3]) -> [(usize, usize); 3] {
        [0, 1, 2].map(|a| self.axes[a].span(cell[a]))
    }
}

/// The values found so far, one per voxel, and which voxels have one.
struct Samples {
    grid: Grid,
    values: Vec<f32>,
    known: Vec<bool>,
}

impl Samples {
    /// Evaluates `field` at the voxels `indices` (distinct, not yet known) and records them.
    fn evaluate<F: Field + ?Sized>(&mut self, field: &F, indices: &[usize]) {
        let positions: Vec<DVec3> =
            indices.par_iter().map(|&v| self.grid.position(self.grid.voxel(v))).collect();
        for (&v, value) in indices.iter().zip(field.values(&positions)) {
            self.values[v] = value as f32;
            self.known[v] = true;
        }
    }

    fn at(&self, [i, j, k]: [usize; 3]) -> f32 {
        self.values[self.grid.index([i, j, k])]
    }

    /// The values at the (up to) eight corners of the box `spans`.
    fn corners(&self, spans: [(usize, usize); 3]) -> [f32; 8] {
        std::array::from_fn(|c| {
            let pick = |a: usize| if c >> a & 1 == 1 { spans[a].1 } else { spans[a].0 };
            self.at([pick(0), pick(1), pick(2)])
        })
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
///    voxel with `|goal_sd| <= 8`, is refined, as the paper refines it. Where the paper then
///    samples such a cube voxel by voxel, we first sample it at every 2nd voxel and estimate
///    the field's steepest slope `G` over it from those samples.
/// 3. Each half-size cube of a refined cube is sampled voxel by voxel when its corners do not
///    share a strict sign, or when one corner's `|f|` is at most `2 G` times the cube's
///    half-diagonal: a zero inside the cube lies within the half-diagonal of its nearest
///    corner, so with a slope of at most `G` that corner would have `|f| <= G` times it; the
///    factor 2 covers a slope estimated from samples two voxels apart.
/// 4. Every other voxel is filled by trilinear interpolation of the corners of the finest cube
///    sampled around it, which keeps their common sign.
///
/// On grids of 256 voxels or more along an axis, step 1 itself starts sparser: the
/// field is sampled at every 8th voxel, and the 4th-voxel lattice only in the cubes of 8 voxels
/// that step 2's rule refines (a sign change among their corners, or a voxel within 8 voxels of
/// the goal boundary); elsewhere it is interpolated from their corners, which share a strict
/// sign. At 512 voxels that lattice was 1.7 of the 9 million points evaluated on a bunny model.
///
/// # What this can miss
/// A piece of surface that lies entirely inside one coarse cube whose eight corners share a
/// sign, more than 8 voxels from the goal boundary: a detached component smaller than a coarse
/// cube (4 voxels across, 8 on grids from 256: the same fraction of the grid as 4
/// voxels of 128), or a thin bump poking between corners, far from where the shape should be,
/// as in the paper. Near the goal boundary, the middle level misses a zero only where
/// the field is more than twice as steep between samples as across them, which a smooth
/// variational function is not at the scale of two voxels; a stray component at least a coarse
/// cube across always contains a corner and is found.
///
/// # Panics
/// If `goal_sd` is on a grid of other dimensions than `grid`.
pub fn evaluate_on_grid<F: Field + ?Sized>(
    field: &F,
    grid: &Grid,
    goal_sd: Option<&Volume<f32>>,
) -> Volume<f32> {
    let sparse = grid.dims.iter().any(|&n| n >= SPARSE_FROM);
    evaluate_levels(field, grid, goal_sd, sparse)
}

/// [`evaluate_on_grid`], from the sparser lattice or not.
fn evaluate_levels<F: Field + ?Sized>(
    field: &F,
    grid: &Grid,
    goal_sd: Option<&Volume<f32>>,
    sparse: bool,
) -> Volume<f32> {
    if let Some(goal) = goal_sd {
        assert_eq!(goal.grid.dims, grid.dims, "the goal volume must be on the evaluation grid");
    }
    let coarse = Level::new(grid, STEP);
    let middle = Level::new(grid, STEP / 2);
    let mut samples =
        Samples { grid: *grid, values: vec![0.0; grid.len()], known: vec![false; grid.len()] };

    if sparse {
        let sparser = Level::new(grid, 2 * STEP);
        let nodes = lattice_voxels(grid, &sparser, None);
        samples.evaluate(field, &nodes);
        let refined = refined_cells(&sparser, &samples, goal_sd);
        let nodes = lattice_voxels(grid, &coarse, Some((&sparser, &refined, &samples.known)));
        samples.evaluate(field, &nodes);
        interpolate_lattice(&mut samples, &coarse, &sparser);
    } else {
        let nodes = lattice_voxels(grid, &coarse, None);
        samples.evaluate(field, &nodes);
    }
    let refined = refined_cells(&coarse, &samples, goal_sd);

    let nodes = lattice_voxels(grid, &middle, Some((&coarse, &refined, &samples.known)));
    samples.evaluate(field, &nodes);
    let fine = fine_cells(&coarse, &middle, &refined, &samples);

    let voxels = fine_voxels(grid, &middle, &fine, &samples.known);
    samples.evaluate(field, &voxels);
    fill(&mut samples, &coarse, &middle, &refined);
    Volume { grid: *grid, data: samples.values }
}

/// The cells of `level` that step 2 of [`evaluate_on_grid`] refines: a sign change among their
/// corners, or a voxel near the goal boundary.
fn refined_cells(level: &Level, samples: &Samples, goal_sd: Option<&Volume<f32>>) -> Vec<bool> {
    (0..level.cell_count())
        .into_par_iter()
        .map(|s| {
            let spans = level.spans(level.cell_of_index(s));
            sign_changes(&samples.corners(spans))
                || goal_sd.is_some_and(|g| near_goal(&samples.grid, g, spans))
        })
        .collect()
}

/// Gives every voxel of `level`'s lattice not yet known the trilinear interpolation of the
/// corners of the cell of `coarser` around it, and counts it known.
fn interpolate_lattice(samples: &mut Samples, level: &Level, coarser: &Level) {
    let grid = samples.grid;
    let [ax, ay, az] = &level.axes;
    let missing: Vec<(usize, f32)> = ax
        .nodes
        .par_iter()
        .flat_map_iter(|&i| {
            ay.nodes.iter().flat_map(move |&j| az.nodes.iter().map(move |&k| [i, j, k]))
        })
        .filter(|&v| !samples.known[grid.index(v)])
        .map(|v| {
            let located = [0, 1, 2].map(|a| coarser.axes[a].locate(v[a]));
            let corners = samples.corners(located.map(|(span, _)| span));
            (grid.index(v), trilinear(&corners, located.map(|(_, t)| t as f32)))
        })
        .collect();
    for (v, value) in missing {
        samples.values[v] = value;
        samples.known[v] = true;
    }
}

/// The trilinear interpolation of a box's corners (ordered as [`Samples::corners`]) at the
/// fractions `t` across it.
fn trilinear(corners: &[f32; 8], t: [f32; 3]) -> f32 {
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let along_x = |c: usize| lerp(corners[c], corners[c | 1], t[0]);
    let low = lerp(along_x(0), along_x(2), t[1]);
    let high = lerp(along_x(4), along_x(6), t[1]);
    lerp(low, high, t[2])
}

/// The voxels of a level's lattice, in increasing order: all of them, or with `within`, those
/// in a refined cell of the coarser level that are not yet known.
fn lattice_voxels(
    grid: &Grid,
    level: &Level,
    within: Option<(&Level, &[bool], &[bool])>,
) -> Vec<usize> {
    let [ax, ay, az] = &level.axes;
    ax.nodes
        .par_iter()
        .flat_map_iter(|&i| {
            ay.nodes.iter().flat_map(move |&j| az.nodes.iter().map(move |&k| [i, j, k]))
        })
        .filter_map(|v| {
            let index = grid.index(v);
            let wanted = within.is_none_or(|(coarser, refined, known)| {
                !known[index] && in_refined_cell(coarser, refined, v)
            });
            wanted.then_some(index)
        })
        .collect()
}

/// Whether voxel `v` lies in (or on the boundary of) a refined cell of `level`.
fn in_refined_cell(level: &Level, refined: &[bool], v: [usize; 3]) -> bool {
    let ranges = [0, 1, 2].map(|a| {
        let axis = &level.axes[a];
        let c = axis.cell[v[a]] as usize;
        let below = c > 0 && axis.span(c).0 == v[a];
        if below { c - 1..=c } else { c..=c }
    });
    ranges[0].clone().any(|a| {
        ranges[1].clone().any(|b| ranges[2].clone().any(|c| refined[level.cell_index([a, b, c])]))
    })
}

/// Whether the corners do not all share a strict sign.
fn sign_changes(corners: &[f32; 8]) -> bool {
    let positive = corners.iter().all(|&v| v > 0.0);
    let negative = corners.iter().all(|&v| v < 0.0);
    !(positive || negative)
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

/// The middle-level cells to sample voxel by voxel (step 3 of [`evaluate_on_grid`]), as
/// indices into the middle level's cells.
fn fine_cells(coarse: &Level, middle: &Level, refined: &[bool], samples: &Samples) -> Vec<usize> {
    (0..coarse.cell_count())
        .into_par_iter()
        .filter(|&s| refined[s])
        .flat_map_iter(|s| {
            let spans = coarse.spans(coarse.cell_of_index(s));
            let ranges = [0, 1, 2].map(|a| middle.axes[a].cells_within(spans[a]));
            let slope = steepest_slope(middle, &ranges, samples);
            let cells: Vec<usize> = ranges[0]
                .clone()
                .flat_map(|a| {
                    let r = ranges.clone();
                    r[1].clone().flat_map(move |b| r[2].clone().map(move |c| [a, b, c]))
                })
                .filter(|&cell| {
                    let spans = middle.spans(cell);
                    let corners = samples.corners(spans);
                    let half_diagonal = 0.5
                        * spans
                            .iter()
                            .map(|(lo, hi)| ((hi - lo) as f64).powi(2))
                            .sum::<f64>()
                            .sqrt();
                    let nearest =
                        corners.iter().map(|v| f64::from(v.abs())).fold(f64::INFINITY, f64::min);
                    sign_changes(&corners) || nearest <= SLOPE_SAFETY * slope * half_diagonal
                })
                .map(|cell| middle.cell_index(cell))
                .collect();
            cells
        })
        .collect()
}

/// The largest `|Δf| / distance` between neighbouring samples of the middle level over the
/// cells `ranges`.
fn steepest_slope(middle: &Level, ranges: &[std::ops::Range<usize>; 3], samples: &Samples) -> f64 {
    let nodes = |a: usize| -> Vec<usize> {
        let axis = &middle.axes[a];
        let mut n: Vec<usize> = ranges[a].clone().map(|c| axis.span(c).0).collect();
        n.push(axis.span(ranges[a].end - 1).1);
        n.dedup();
        n
    };
    let [xs, ys, zs] = [nodes(0), nodes(1), nodes(2)];
    let mut slope = 0.0f64;
    for (a, &i) in xs.iter().enumerate() {
        for (b, &j) in ys.iter().enumerate() {
            for (c, &k) in zs.iter().enumerate() {
                let here = f64::from(samples.at([i, j, k]));
                let steps = [
                    xs.get(a + 1).map(|&n| [n, j, k]),
                    ys.get(b + 1).map(|&n| [i, n, k]),
                    zs.get(c + 1).map(|&n| [i, j, n]),
                ];
                for next in steps.into_iter().flatten() {
                    let distance = (0..3).map(|d| next[d] - [i, j, k][d]).sum::<usize>() as f64;
                    slope = slope.max((f64::from(samples.at(next)) - here).abs() / distance);
                }
            }
        }
    }
    slope
}

/// The voxels of the cells `fine` (middle level) not yet known, in increasing order.
///
/// Neighbouring cells share their faces, so the cells' voxels are marked in a mask, one
/// x-slab per task, and the mask is read back in order (cheaper than sorting and deduplicating
/// the voxels of every cell).
fn fine_voxels(grid: &Grid, middle: &Level, fine: &[usize], known: &[bool]) -> Vec<usize> {
    let [_, ny, nz] = grid.dims;
    let slab = ny * nz;
    // The fine cells by the x-cell they lie in, so that each slab task looks at few cells.
    let mut by_x: Vec<Vec<[usize; 3]>> = vec![Vec::new(); middle.axes[0].cells()];
    for &s in fine {
        let cell = middle.cell_of_index(s);
        by_x[cell[0]].push(cell);
    }
    let mut wanted = vec![false; grid.len()];
    wanted.par_chunks_mut(slab).enumerate().for_each(|(i, mask)| {
        let axis = &middle.axes[0];
        // Voxel layer i lies in its own x-cell, and on the upper face of the one below.
        let own = axis.cell[i] as usize;
        let below = (own > 0 && axis.span(own - 1).1 == i).then(|| own - 1);
        let cells = by_x[own].iter().chain(below.into_iter().flat_map(|c| by_x[c].iter()));
        for &cell in cells {
            let spans = middle.spans(cell);
            if !(spans[0].0..=spans[0].1).contains(&i) {
                continue;
            }
            for j in spans[1].0..=spans[1].1 {
                mask[j * nz + spans[2].0..=j * nz + spans[2].1].fill(true);
            }
        }
    });
    wanted
        .par_chunks(slab)
        .zip(known.par_chunks(slab))
        .enumerate()
        .flat_map_iter(|(i, (mask, known))| {
            (0..slab).filter(move |&v| mask[v] && !known[v]).map(move |v| i * slab + v)
        })
        .collect()
}

/// Fills every voxel not sampled by trilinear interpolation of the corners of the finest cell
/// sampled around it: the middle level's in refined coarse cells, the coarse level's elsewhere.
///
/// Along each row (fixed `i`, `j`) the cell changes only every few voxels, so the row keeps the
/// current cell's two ends, interpolated across `i` and `j`, and each voxel costs one lerp.
fn fill(samples: &mut Samples, coarse: &Level, middle: &Level, refined: &[bool]) {
    let grid = samples.grid;
    let [_, ny, nz] = grid.dims;
    let slab = ny * nz;
    let sampled = samples.values.clone();
    let known = &samples.known;
    samples.values.par_chunks_mut(slab).enumerate().for_each(|(i, layer)| {
        let coarse_x = coarse.axes[0].cell[i] as usize;
        let coarse_k = &coarse.axes[2].cell;
        for j in 0..ny {
            let row = &mut layer[j * nz..(j + 1) * nz];
            let known = &known[(i * ny + j) * nz..][..nz];
            let row_cells = coarse.cell_index([coarse_x, coarse.axes[1].cell[j] as usize, 0]);
            // (whether the middle level, the cell along k) of the ends held, and the ends.
            let mut held: Option<(bool, u32)> = None;
            let mut ends = [0.0f32; 2];
            for k in 0..nz {
                if known[k] {
                    continue;
                }
                let fine = refined[row_cells + coarse_k[k] as usize];
                let level = if fine { middle } else { coarse };
                let cell = (fine, level.axes[2].cell[k]);
                if held != Some(cell) {
                    ends = row_ends(&grid, &sampled, level, [i, j], cell.1 as usize);
                    held = Some(cell);
                }
                row[k] = ends[0] + (ends[1] - ends[0]) * level.axes[2].fraction[k];
            }
        }
    });
}

/// The values at the two ends along k of cell `cell_k` of `level`, at row `(i, j)`: each the
/// bilinear interpolation across i and j of that end's four corners.
fn row_ends(
    grid: &Grid,
    sampled: &[f32],
    level: &Level,
    [i, j]: [usize; 2],
    cell_k: usize,
) -> [f32; 2] {
    let ((x0, x1), tx) = level.axes[0].locate(i);
    let ((y0, y1), ty) = level.axes[1].locate(j);
    let (z0, z1) = level.axes[2].span(cell_k);
    let (tx, ty) = (tx as f32, ty as f32);
    [z0, z1].map(|k| {
        let at = |x: usize, y: usize| sampled[grid.index([x, y, k])];
        let lower = at(x0, y0) + (at(x1, y0) - at(x0, y0)) * tx;
        let upper = at(x0, y1) + (at(x1, y1) - at(x0, y1)) * tx;
        lower + (upper - lower) * ty
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Aabb;
    use crate::grid::Resolution;

    /// A field given by a closure.
    struct Analytic<F: Fn(DVec3) -> f64 + Sync>(F);

    impl<F: Fn(DVec3) -> f64 + Sync> Field for Analytic<F> {
        fn value(&self, p: DVec3) -> f64 {
            (self.0)(p)
        }
        fn gradient(&self, _: DVec3) -> DVec3 {
            unimplemented!("not needed by grid evaluation")
        }
    }

    fn cube_grid(n: usize) -> Grid {
        let bounds = Aabb { min: DVec3::splat(-1.0), max: DVec3::splat(1.0) };
        Grid::around(&bounds, Resolution::LongestAxis(n)).unwrap()
    }

    fn full(field: &dyn Field, grid: &Grid) -> Vec<f64> {
        let points: Vec<DVec3> = (0..grid.len()).map(|v| grid.position(grid.voxel(v))).collect();
        field.values(&points)
    }

    /// From the sparser lattice, every voxel still gets the sign a full evaluation gives it,
    /// and the 8th-voxel lattice its exact value, on grids whose last voxel is on and off the
    /// lattices, with and without a goal. The grids are twice the size of `src/tests/rbf.rs`'s for
    /// the lattice of every 4th voxel, so that the fields' features span as many cells.
    #[test]
    fn the_sparser_lattice_finds_every_sign() {
        let sphere = Analytic(|p: DVec3| 0.8 - p.length());
        let blobs = Analytic(|p: DVec3| {
            let centres = [[0.5, 0.5, 0.5], [-0.6, 0.2, -0.4], [0.1, -0.7, 0.3]];
            centres
                .iter()
                .map(|c| 0.2 - (p - DVec3::from_array(*c)).length())
                .fold(f64::MIN, f64::max)
        });
        let wavy = Analytic(|p: DVec3| (5.0 * p.x).sin() * (4.0 * p.y).cos() + 0.5 * p.z);
        for n in [97, 101, 106] {
            let grid = cube_grid(n);
            let shell = Volume {
                grid,
                data: (0..grid.len())
                    .map(|v| (0.7 - grid.position(grid.voxel(v)).length()) / grid.voxel_size)
                    .map(|d| d as f32)
                    .collect(),
            };
            for field in [&sphere as &dyn Field, &blobs, &wavy] {
                let exact = full(field, &grid);
                for goal in [None, Some(&shell)] {
                    let volume = evaluate_levels(field, &grid, goal, true);
                    for (v, (&got, &want)) in volume.data.iter().zip(&exact).enumerate() {
                        let voxel = grid.voxel(v);
                        assert_eq!(got > 0.0, want > 0.0, "{voxel:?}: {got} against {want}");
                        if voxel.iter().all(|&c| c % (2 * STEP) == 0) {
                            assert_eq!(got, want as f32, "lattice voxel {voxel:?}");
                        }
                    }
                }
            }
        }
    }

    /// The documented blind spot of the sparser lattice: a speck in the middle of a cube of 8
    /// voxels, far from the goal, is missed; within 8 voxels of the goal boundary it is found.
    #[test]
    fn the_sparser_lattice_misses_a_speck_only_far_from_the_goal() {
        let grid = cube_grid(57);
        let centre = grid.position([20, 20, 20]);
        let speck = Analytic(move |p: DVec3| 1.5 * grid.voxel_size - (p - centre).length());
        let inside = grid.index([20, 20, 20]);
        assert!(speck.value(centre) > 0.0);
        let far_goal = Volume::filled(grid, -100.0f32);
        assert!(evaluate_levels(&speck, &grid, Some(&far_goal), true).data[inside] < 0.0);
        assert!(evaluate_levels(&speck, &grid, Some(&far_goal), false).data[inside] > 0.0);
        let mut near_goal = far_goal.clone();
        near_goal.data[grid.index([23, 20, 20])] = -8.0;
        assert!(evaluate_levels(&speck, &grid, Some(&near_goal), true).data[inside] > 0.0);
    }
}
