//! Compactly supported radial basis functions: Wendland's C2 function, a uniform grid index of
//! the supports, local evaluation and the sparse interpolation solve of one detail level.
//!
//! A detail level (see [`crate::rbf::MultiScale`]) is `g(x) = sum_j w_j psi_rho(|x - c_j|)` with
//!
//! ```text
//! psi_rho(r) = (1 - r/rho)^4 (4 r/rho + 1)   for r < rho,   0 beyond,
//! ```
//!
//! Wendland's C2 function, positive definite in 3D (Wendland 1995), so interpolation at distinct
//! centres has a unique solution and its matrix `A_ij = psi_rho(|c_i - c_j|)` is symmetric
//! positive definite and sparse: each row holds only the centres within `rho`. Unlike the global
//! kernels of [`super::Kernel`], it carries a length (its support radius), needs no polynomial
//! and is only used in 3D, so it is its own type rather than an arm of the (dimension, kernel)
//! dispatch, whose loops sum every centre.
//!
//! ## Guarantees
//! * [`DetailLevel::value`] and [`DetailLevel::gradient`] read only the centres whose support
//!   covers the point, through a hash grid of cells of side `rho` in which each centre is
//!   listed in every cell its support meets: one cell is looked up per point, and the centres
//!   are stored along a Morton curve so that a cell's lie close in memory. They equal the sums over
//!   every centre ([`DetailLevel::value_brute_force`]) up to rounding, since a centre left out
//!   contributes exactly zero.
//! * [`DetailLevel::interpolate`] solves the sparse system by conjugate gradients (the diagonal
//!   is 1, `psi(0)`, so Jacobi preconditioning would change nothing) to a residual of at most
//!   [`CG_TOLERANCE`] of the values' norm, and reports the largest interpolation residual
//!   relative to the largest |value|, measured after the solve.
//! * Positions and values are f64; centres are assumed distinct (the fit spaces them a fraction
//!   of `rho` apart), which positive definiteness needs.

use rayon::prelude::*;

use super::lattice::Lattice;
use crate::error::{Error, Result};
use crate::geometry::{CellMap, DVec3, MORTON_BITS, cell_key, cell_of, morton_key};

/// `psi_rho(r)` given `t = r / rho`: Wendland's C2 function, 1 at 0, 0 from 1 on.
#[inline]
pub fn wendland(t: f64) -> f64 {
    if t >= 1.0 {
        return 0.0;
    }
    let s = 1.0 - t;
    let s2 = s * s;
    s2 * s2 * (4.0 * t + 1.0)
}

/// `psi'(r) / r` times `rho^2`, given `t = r / rho`: the gradient of `psi_rho(|x - c|)` is this
/// divided by `rho^2`, times `x - c`. Zero from `t = 1` on; `-20` at the centre.
#[inline]
fn wendland_slope(t: f64) -> f64 {
    if t >= 1.0 {
        return 0.0;
    }
    let s = 1.0 - t;
    -20.0 * s * s * s
}

/// The conjugate gradient iterations stop once the residual's norm is at most this fraction of
/// the values' norm.
pub(crate) const CG_TOLERANCE: f64 = 1e-10;

/// The conjugate gradient iterations stop after this many in any case (the systems the fit
/// makes need tens to a few hundred).
const CG_MAX_ITERATIONS: usize = 5000;

/// Cells of the support index per support radius: a cell of side `rho` lists the centres
/// within `rho` of any of its points, and each centre is listed in at most 27 cells. Cells of
/// side `rho / 2` list fewer centres that miss a given point, but each centre in up to 125
/// cells, and building them costs more than the shorter lists save (docs/results.md, "What
/// was tried and not kept").
const CELLS_PER_RADIUS: f64 = 1.0;

/// Centres a task of [`SupportIndex::new`] takes at a time.
const INDEX_BLOCK: usize = 1024;

/// A uniform grid over the supports of centres of one radius: cells of side
/// `rho / CELLS_PER_RADIUS`, each listing every centre whose support ball meets it, so the
/// centres that can cover a point are those of its one cell.
#[derive(Debug, Clone)]
struct SupportIndex {
    side: f64,
    /// Where each cell's centres lie in `entries`.
    cells: CellTable,
    /// Each cell's centres, in their order, cell after cell.
    entries: Vec<u32>,
}

/// Where each cell of a [`SupportIndex`] lists its centres.
#[derive(Debug, Clone)]
enum CellTable {
    /// Every cell of the box of cells from `low` (cell coordinates) with `dims` cells along
    /// each axis: cell `i` (x-major) lists `entries[starts[i]..starts[i + 1]]`. For a level
    /// whose box holds at most [`DENSE_CELLS_PER_ENTRY`] cells an entry: found without hashing.
    Dense { low: [i64; 3], dims: [i64; 3], starts: Vec<u32> },
    /// The cells that list a centre, by key, with their range of `entries`.
    Sparse(CellMap<(u32, u32)>),
}

/// The index, x-major, of cell `c` in the box of cells from `low` with `dims` cells along each
/// axis, or `None` outside it.
#[inline]
fn box_index(low: [i64; 3], dims: [i64; 3], c: [i64; 3]) -> Option<usize> {
    let local: [i64; 3] = std::array::from_fn(|a| c[a] - low[a]);
    if (0..3).any(|a| local[a] < 0 || local[a] >= dims[a]) {
        return None;
    }
    Some(((local[0] * dims[1] + local[1]) * dims[2] + local[2]) as usize)
}

/// The most cells of its box a level's index holds per entry in a [`CellTable::Dense`] table
/// (4 bytes each): with more, the box is mostly empty and the table sparse.
const DENSE_CELLS_PER_ENTRY: u64 = 4;

impl CellTable {
    /// The range of `entries` that cell `c` lists, if any.
    #[inline]
    fn range(&self, c: [i64; 3]) -> Option<(u32, u32)> {
        match self {
            CellTable::Dense { low, dims, starts } => {
                let i = box_index(*low, *dims, c)?;
                Some((starts[i], starts[i + 1]))
            }
            CellTable::Sparse(cells) => cells.get(&cell_key(c)).copied(),
        }
    }

    fn bytes(&self) -> usize {
        match self {
            CellTable::Dense { starts, .. } => starts.len() * 4,
            CellTable::Sparse(cells) => cells.len() * 24,
        }
    }
}

impl SupportIndex {
    /// The index over `centres` with support radius `rho`. Each centre's cells are counted
    /// first and written into one vector of their exact size, in parallel (no vector grows,
    /// which on a large level costs more than the rest); then, where the centres' box of cells
    /// is small enough for a dense table, each cell's centres are counted and placed in it in
    /// one pass, and otherwise the (cell, centre) pairs are sorted by cell. Either way a cell
    /// lists its centres in their order.
    fn new(centres: &[DVec3], rho: f64) -> SupportIndex {
        let side = rho / CELLS_PER_RADIUS;
        let reach = DVec3::splat(rho);
        let span = |c: DVec3| (cell_of(c - reach, side), cell_of(c + reach, side));
        // The cells whose box `c`'s support ball meets.
        let cells_of = |c: DVec3| {
            let (lo, hi) = span(c);
            (lo[0]..=hi[0])
                .flat_map(move |x| {
                    (lo[1]..=hi[1]).flat_map(move |y| (lo[2]..=hi[2]).map(move |z| [x, y, z]))
                })
                .filter(move |&cell| box_distance2(c, cell, side) < rho * rho)
        };
        if centres.is_empty() {
            return SupportIndex {
                side,
                cells: CellTable::Sparse(CellMap::default()),
                entries: vec![],
            };
        }
        let counts: Vec<u32> = centres.par_iter().map(|&c| cells_of(c).count() as u32).collect();
        let (low, high) = centres.iter().fold(([i64::MAX; 3], [i64::MIN; 3]), |(low, high), &c| {
            let (lo, hi) = span(c);
            (
                std::array::from_fn(|a| low[a].min(lo[a])),
                std::array::from_fn(|a| high[a].max(hi[a])),
            )
        });
        let dims: [i64; 3] = std::array::from_fn(|a| (high[a] - low[a] + 1).max(1));
        let total: u64 = counts.iter().map(|&k| u64::from(k)).sum();
        let boxed = dims.iter().map(|&d| d as f64).product::<f64>();
        let dense = boxed <= (DENSE_CELLS_PER_ENTRY * total.max(1024)) as f64
            && total < u64::from(u32::MAX);
        // A centre's cells lie in the box of all of them, so a dense id always exists.
        let key = |c: [i64; 3]| match box_index(low, dims, c) {
            Some(i) if dense => i as u64,
            _ => cell_key(c),
        };
        let mut cells_by_centre = vec![0u64; total as usize];
        {
            let mut rest = cells_by_centre.as_mut_slice();
            let mut slices = Vec::with_capacity(centres.len());
            for &count in &counts {
                let (slice, tail) = rest.split_at_mut(count as usize);
                slices.push(slice);
                rest = tail;
            }
            slices.into_par_iter().zip(centres).with_min_len(INDEX_BLOCK).for_each(
                |(slice, &c)| {
                    for (out, cell) in slice.iter_mut().zip(cells_of(c)) {
                        *out = key(cell);
                    }
                },
            );
        }
        let (cells, entries) = if dense {
            let starts = Self::starts(&cells_by_centre, dims.iter().product::<i64>() as usize);
            let entries = Self::place(&cells_by_centre, &counts, starts.clone());
            (CellTable::Dense { low, dims, starts }, entries)
        } else {
            Self::sparse(cells_by_centre, &counts)
        };
        SupportIndex { side, cells, entries }
    }

    /// The dense table's starts, one more than its `boxed` cells: each cell's centres counted
    /// (`cells`: each centre's cells, dense ids), the counts summed.
    fn starts(cells: &[u64], boxed: usize) -> Vec<u32> {
        let mut starts = vec![0u32; boxed + 1];
        for &cell in cells {
            starts[cell as usize + 1] += 1;
        }
        for i in 1..starts.len() {
            starts[i] += starts[i - 1];
        }
        starts
    }

    /// The dense table's entries: each centre placed, centre by centre, at the next free entry
    /// of each of its cells (`cells`, dense ids, `counts` of them a centre); `next`: the
    /// table's starts, where each cell's first centre goes.
    fn place(cells: &[u64], counts: &[u32], mut next: Vec<u32>) -> Vec<u32> {
        let mut entries = vec![0u32; cells.len()];
        let mut cell_lists = cells.iter();
        for (j, &count) in counts.iter().enumerate() {
            for &cell in cell_lists.by_ref().take(count as usize) {
                let slot = &mut next[cell as usize];
                entries[*slot as usize] = j as u32;
                *slot += 1;
            }
        }
        entries
    }

    /// The sparse table and the entries: the (cell, centre) pairs sorted by cell (and centre).
    /// `cells`: each centre's cells (keys), `counts` of them a centre.
    fn sparse(cells: Vec<u64>, counts: &[u32]) -> (CellTable, Vec<u32>) {
        let owners =
            counts.iter().enumerate().flat_map(|(j, &k)| std::iter::repeat_n(j as u32, k as usize));
        let mut pairs: Vec<(u64, u32)> = cells.into_iter().zip(owners).collect();
        pairs.par_sort_unstable();
        let mut table = CellMap::default();
        table.reserve(pairs.chunk_by(|a, b| a.0 == b.0).count());
        let mut start = 0;
        for run in pairs.chunk_by(|a, b| a.0 == b.0) {
            table.insert(run[0].0, (start as u32, (start + run.len()) as u32));
            start += run.len();
        }
        (CellTable::Sparse(table), pairs.into_par_iter().map(|(_, j)| j).collect())
    }

    /// The centres whose support may cover `p`: every one that does, and a few more.
    #[inline]
    fn near(&self, p: DVec3) -> &[u32] {
        self.list(cell_of(p, self.side))
    }

    /// The centres cell `c` lists.
    #[inline]
    fn list(&self, c: [i64; 3]) -> &[u32] {
        match self.cells.range(c) {
            Some((start, end)) => &self.entries[start as usize..end as usize],
            None => &[],
        }
    }

    fn bytes(&self) -> usize {
        self.entries.len() * 4 + self.cells.bytes()
    }
}

/// The order of `centres` along a Morton curve of cells of side `side`, so that the centres a
/// cell of the support index lists lie close together in memory.
fn morton_order(centres: &[DVec3], side: f64) -> Vec<usize> {
    let lo = centres.iter().fold(DVec3::splat(f64::INFINITY), |m, &c| m.min(c));
    let top = ((1u64 << MORTON_BITS) - 1) as f64;
    let key = |c: DVec3| {
        let q = ((c - lo) / side).floor().clamp(DVec3::ZERO, DVec3::splat(top));
        morton_key([q.x as u64, q.y as u64, q.z as u64])
    };
    // Ties (centres in one cell) are broken by the coordinates, so that the order depends on
    // the set of centres alone, not on the order they came in: a level read from a file whose
    // centres come in another order sums in the same order as the one written.
    let mut order: Vec<usize> = (0..centres.len()).collect();
    order.sort_by_cached_key(|&i| {
        let c = centres[i];
        (key(c), [c.x, c.y, c.z].map(|v| v.to_bits()))
    });
    order
}

/// The squared distance from `c` to the cell `key` of side `side`.
fn box_distance2(c: DVec3, key: [i64; 3], side: f64) -> f64 {
    let lo = DVec3::new(key[0] as f64, key[1] as f64, key[2] as f64) * side;
    let hi = lo + DVec3::splat(side);
    let d = (lo - c).max(DVec3::ZERO).max(c - hi);
    d.length_squared()
}

/// One detail level: `g(x) = sum_j w_j psi_rho(|x - c_j|)`, centres in the mesh's units.
#[derive(Debug, Clone)]
pub struct DetailLevel {
    radius: f64,
    centres: Vec<DVec3>,
    weights: Vec<f64>,
    index: SupportIndex,
    /// The lattice its centres and weights lie on, when it was made compact.
    lattice: Option<Lattice>,
}

/// What [`DetailLevel::interpolate`] reports of its solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SparseSolve {
    /// Conjugate gradient iterations.
    pub iterations: usize,
    /// Stored entries of the sparse matrix (both triangles and the diagonal).
    pub entries: usize,
    /// The largest `|g(c_i) - v_i|`, relative to the largest `|v_i|` (0 when every value is 0).
    pub residual: f64,
}

impl DetailLevel {
    /// The level of support radius `radius` with these centres and weights (kept ordered along
    /// a Morton curve, each weight with its centre); `context` names the source in errors.
    ///
    /// # Errors
    /// A radius that is not finite and positive, as many weights as centres, or a non-finite
    /// number.
    pub fn new(
        context: &str,
        radius: f64,
        centres: Vec<DVec3>,
        weights: Vec<f64>,
    ) -> Result<DetailLevel> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(Error::invalid(
                context,
                format!("support radius {radius} is not positive"),
            ));
        }
        if centres.len() != weights.len() {
            return Err(Error::invalid(
                context,
                format!("{} weights for {} centres", weights.len(), centres.len()),
            ));
        }
        if centres.iter().any(|c| !c.is_finite()) || weights.iter().any(|w| !w.is_finite()) {
            return Err(Error::invalid(context, "a centre or weight is not finite"));
        }
        let order = morton_order(&centres, radius / CELLS_PER_RADIUS);
        let centres: Vec<DVec3> = order.iter().map(|&i| centres[i]).collect();
        let weights = order.iter().map(|&i| weights[i]).collect();
        let index = SupportIndex::new(&centres, radius);
        Ok(DetailLevel { radius, centres, weights, index, lattice: None })
    }

    /// The level through `values` at `centres` (distinct points, mesh units) with support
    /// radius `radius`: the weights solve the sparse system `A w = v`.
    ///
    /// # Errors
    /// As [`DetailLevel::new`]; a system the iterations do not bring to `CG_TOLERANCE`
    /// (coincident centres).
    pub fn interpolate(
        radius: f64,
        centres: Vec<DVec3>,
        values: &[f64],
    ) -> Result<(DetailLevel, SparseSolve)> {
        // The values ride as weights through `new`, which orders the centres, then make way for
        // the solved weights.
        let mut level = DetailLevel::new("a detail level", radius, centres, values.to_vec())?;
        let values = std::mem::take(&mut level.weights);
        let matrix = level.matrix();
        let (weights, iterations) = conjugate_gradients(&matrix, &values).ok_or_else(|| {
            Error::invalid(
                "a detail level",
                format!(
                    "the sparse solve of {} centres did not converge (coincident centres?)",
                    values.len()
                ),
            )
        })?;
        level.weights = weights;
        let fitted = matrix.product(&level.weights);
        let largest = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = fitted.iter().zip(&values).map(|(f, v)| (f - v).abs()).fold(0.0f64, f64::max);
        let residual = if largest > 0.0 { worst / largest } else { worst };
        Ok((level, SparseSolve { iterations, entries: matrix.values.len(), residual }))
    }

    /// The lattice its centres and weights lie on, when the fit made it compact (see
    /// `Lattice`).
    pub fn lattice(&self) -> Option<&Lattice> {
        self.lattice.as_ref()
    }

    /// The same level, declared to lie on `lattice` (not checked here: a model file that finds
    /// a number off it stores the numbers as they are).
    pub(crate) fn on_lattice(mut self, lattice: Lattice) -> DetailLevel {
        self.lattice = Some(lattice);
        self
    }

    /// The support radius, mesh units.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The centres, mesh units, in the level's own order (along a Morton curve, not
    /// necessarily the order given to [`DetailLevel::new`]); [`DetailLevel::weights`] follow it.
    pub fn centres(&self) -> &[DVec3] {
        &self.centres
    }

    /// The weights, one per centre.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Bytes the level holds in memory: centres, weights and the support index.
    pub fn bytes(&self) -> usize {
        self.centres.len() * 32 + self.index.bytes()
    }

    /// `g(p)`, reading only the centres whose support covers `p`.
    #[inline]
    pub fn value(&self, p: DVec3) -> f64 {
        let reach2 = self.radius * self.radius;
        let mut sum = 0.0;
        for &j in self.index.near(p) {
            let j = j as usize;
            let d2 = p.distance_squared(self.centres[j]);
            if d2 < reach2 {
                sum += self.weights[j] * wendland(d2.sqrt() / self.radius);
            }
        }
        sum
    }

    /// The gradient of `g` at `p`, reading only the centres whose support covers `p`.
    #[inline]
    pub fn gradient(&self, p: DVec3) -> DVec3 {
        let mut sum = DVec3::ZERO;
        for &j in self.index.near(p) {
            let j = j as usize;
            let d = p - self.centres[j];
            sum += d * (self.weights[j] * wendland_slope(d.length() / self.radius));
        }
        sum / (self.radius * self.radius)
    }

    /// The centres whose support may meet the box `[min, max]` (every one that does, each
    /// once), read from the cells of the support index the box meets.
    pub fn centres_near(&self, min: DVec3, max: DVec3) -> Vec<u32> {
        let side = self.index.side;
        let (lo, hi) = (cell_of(min, side), cell_of(max, side));
        let mut near = Vec::new();
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    near.extend_from_slice(self.index.list([x, y, z]));
                }
            }
        }
        near.sort_unstable();
        near.dedup();
        near
    }

    /// `g(p)` summed over every centre: the oracle of [`DetailLevel::value`].
    pub fn value_brute_force(&self, p: DVec3) -> f64 {
        self.centres
            .iter()
            .zip(&self.weights)
            .map(|(&c, &w)| w * wendland(p.distance(c) / self.radius))
            .sum()
    }

    /// The interpolation matrix in compressed rows.
    fn matrix(&self) -> SparseMatrix {
        let rows: Vec<Vec<(u32, f64)>> = self
            .centres
            .par_iter()
            .map(|&c| {
                let mut row: Vec<(u32, f64)> = self
                    .index
                    .near(c)
                    .iter()
                    .filter_map(|&j| {
                        let t = c.distance(self.centres[j as usize]) / self.radius;
                        (t < 1.0).then(|| (j, wendland(t)))
                    })
                    .collect();
                row.sort_unstable_by_key(|e| e.0);
                row
            })
            .collect();
        let mut starts = Vec::with_capacity(rows.len() + 1);
        starts.push(0);
        let mut columns = Vec::new();
        let mut values = Vec::new();
        for row in rows {
            for (j, v) in row {
                columns.push(j);
                values.push(v);
            }
            starts.push(columns.len());
        }
        SparseMatrix { starts, columns, values }
    }

    /// A dense grid index of the supports, for shaders ([`crate::shader`]): a uniform grid of
    /// cubic cells over the supports' box, each cell listing every centre whose support meets
    /// it, with at most about `max_cells` cells (the side is the support radius, or larger when
    /// that would make more).
    pub fn grid_index(&self, max_cells: usize) -> GridIndex {
        let rho = self.radius;
        let Some(hull) = crate::geometry::Aabb::of_points(&self.centres) else {
            return GridIndex {
                origin: DVec3::ZERO,
                side: rho,
                dims: [1; 3],
                starts: vec![0, 0],
                entries: vec![],
            };
        };
        let (min, size) = (hull.min - rho, hull.size() + 2.0 * rho);
        let count = |side: f64| (size / side).ceil().max(DVec3::ONE).as_uvec3();
        let mut side = rho;
        while count(side).as_u64vec3().element_product() > max_cells.max(1) as u64 {
            side *= 1.1;
        }
        let dims = count(side).to_array().map(|d| d as usize);
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); dims.iter().product()];
        for (j, &c) in self.centres.iter().enumerate() {
            let cell = |p: DVec3| ((p - min) / side).floor().max(DVec3::ZERO).as_uvec3();
            let (lo, hi) = (cell(c - rho), cell(c + rho));
            for z in lo.z..=hi.z.min(dims[2] as u32 - 1) {
                for y in lo.y..=hi.y.min(dims[1] as u32 - 1) {
                    for x in lo.x..=hi.x.min(dims[0] as u32 - 1) {
                        let corner =
                            min + side * DVec3::new(f64::from(x), f64::from(y), f64::from(z));
                        let near = (corner - c).max(DVec3::ZERO).max(c - corner - side);
                        if near.length_squared() < rho * rho {
                            let at = (z as usize * dims[1] + y as usize) * dims[0] + x as usize;
                            lists[at].push(j as u32);
                        }
                    }
                }
            }
        }
        let mut starts = Vec::with_capacity(lists.len() + 1);
        let mut entries = Vec::new();
        starts.push(0);
        for list in lists {
            entries.extend(list);
            starts.push(entries.len() as u32);
        }
        GridIndex { origin: min, side, dims, starts, entries }
    }
}

/// A dense uniform grid over the supports of one detail level ([`DetailLevel::grid_index`]):
/// the centres that can cover a point are `entries[starts[c]..starts[c + 1]]` for the point's
/// cell `c = (z * dims[1] + y) * dims[0] + x`; points outside the grid are covered by none.
#[derive(Debug, Clone, PartialEq)]
pub struct GridIndex {
    /// The grid's least corner, mesh units.
    pub origin: DVec3,
    /// The side of a cell, mesh units.
    pub side: f64,
    /// Cells per axis.
    pub dims: [usize; 3],
    /// Where each cell's run of `entries` starts; one more than there are cells.
    pub starts: Vec<u32>,
    /// Centre numbers, cell after cell.
    pub entries: Vec<u32>,
}

impl GridIndex {
    /// The centres listed for the cell holding `p`.
    pub fn near(&self, p: DVec3) -> &[u32] {
        let g = ((p - self.origin) / self.side).floor();
        let dims = DVec3::new(self.dims[0] as f64, self.dims[1] as f64, self.dims[2] as f64);
        if g.cmplt(DVec3::ZERO).any() || g.cmpge(dims).any() {
            return &[];
        }
        let at = (g.z as usize * self.dims[1] + g.y as usize) * self.dims[0] + g.x as usize;
        &self.entries[self.starts[at] as usize..self.starts[at + 1] as usize]
    }
}

/// A square matrix in compressed rows.
struct SparseMatrix {
    starts: Vec<usize>,
    columns: Vec<u32>,
    values: Vec<f64>,
}

impl SparseMatrix {
    fn product(&self, x: &[f64]) -> Vec<f64> {
        (0..self.starts.len() - 1)
            .into_par_iter()
            .map(|i| {
                let range = self.starts[i]..self.starts[i + 1];
                self.columns[range.clone()]
                    .iter()
                    .zip(&self.values[range])
                    .map(|(&j, &v)| v * x[j as usize])
                    .sum()
            })
            .collect()
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.par_iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Solves `A x = b` for a symmetric positive definite `A` by conjugate gradients from zero, to
/// [`CG_TOLERANCE`]; the solution and the iterations, or `None` without convergence.
fn conjugate_gradients(a: &SparseMatrix, b: &[f64]) -> Option<(Vec<f64>, usize)> {
    let mut x = vec![0.0; b.len()];
    let mut r = b.to_vec();
    let mut p = r.clone();
    let mut rr = dot(&r, &r);
    let goal = CG_TOLERANCE * CG_TOLERANCE * rr;
    for iteration in 0..CG_MAX_ITERATIONS {
        if rr <= goal {
            return Some((x, iteration));
        }
        let ap = a.product(&p);
        let pap = dot(&p, &ap);
        if pap.is_nan() || pap <= 0.0 {
            return None;
        }
        let alpha = rr / pap;
        x.par_iter_mut().zip(&p).for_each(|(x, p)| *x += alpha * p);
        r.par_iter_mut().zip(&ap).for_each(|(r, ap)| *r -= alpha * ap);
        let next = dot(&r, &r);
        let beta = next / rr;
        rr = next;
        p.par_iter_mut().zip(&r).for_each(|(p, r)| *p = r + beta * *p);
    }
    (rr <= goal).then_some((x, CG_MAX_ITERATIONS))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_points(n: usize, seed: u64) -> Vec<DVec3> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| DVec3::new(rng.random(), rng.random(), rng.random())).collect()
    }

    #[test]
    fn wendland_is_one_at_the_centre_and_vanishes_with_its_slope_at_the_support() {
        assert_eq!(wendland(0.0), 1.0);
        assert_eq!(wendland(1.0), 0.0);
        assert_eq!(wendland(1.5), 0.0);
        assert!((wendland(0.5) - 0.0625 * 3.0).abs() < 1e-15);
        // The slope by finite differences, and zero at the support's edge (C2 there).
        for t in [0.1, 0.4, 0.8, 0.999] {
            let h = 1e-6;
            let numeric = (wendland(t + h) - wendland(t - h)) / (2.0 * h);
            assert!((numeric - wendland_slope(t) * t).abs() < 1e-6, "{t}");
        }
        assert!(wendland_slope(1.0 - 1e-9).abs() < 1e-20);
    }

    /// The gradient of a level agrees with finite differences of its value.
    #[test]
    fn the_gradient_is_the_derivative_of_the_value() {
        let centres = random_points(40, 2);
        let weights = (0..40).map(|i| (i as f64 * 0.37).sin()).collect();
        let level = DetailLevel::new("test", 0.3, centres, weights).unwrap();
        for p in random_points(50, 3) {
            let h = 1e-6;
            let numeric = DVec3::new(
                level.value(p + DVec3::X * h) - level.value(p - DVec3::X * h),
                level.value(p + DVec3::Y * h) - level.value(p - DVec3::Y * h),
                level.value(p + DVec3::Z * h) - level.value(p - DVec3::Z * h),
            ) / (2.0 * h);
            assert!(numeric.distance(level.gradient(p)) < 1e-6, "{numeric} {}", level.gradient(p));
        }
    }

    /// On random points, the interpolation matrix is positive definite: its quadratic form is
    /// positive for random vectors and its smallest Cholesky pivot (dense, as an oracle) too.
    #[test]
    fn the_interpolation_matrix_is_positive_definite_on_random_points() {
        for (n, rho, seed) in [(60, 0.5, 4), (200, 0.35, 5), (120, 2.0, 6)] {
            let points = random_points(n, seed);
            let mut a = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    a[i * n + j] = wendland(points[i].distance(points[j]) / rho);
                }
            }
            // Cholesky, in place: every pivot positive.
            for k in 0..n {
                let pivot = a[k * n + k] - (0..k).map(|m| a[k * n + m].powi(2)).sum::<f64>();
                assert!(pivot > 0.0, "pivot {k} is {pivot} for n {n}, rho {rho}");
                a[k * n + k] = pivot.sqrt();
                for i in k + 1..n {
                    let s = a[i * n + k] - (0..k).map(|m| a[i * n + m] * a[k * n + m]).sum::<f64>();
                    a[i * n + k] = s / a[k * n + k];
                }
            }
        }
    }

    /// The dense grid index lists, for points inside and around the supports, every centre
    /// whose support covers the point, at the radius's cells and at coarser ones.
    #[test]
    fn the_grid_index_lists_every_centre_that_covers_a_point() {
        let centres: Vec<DVec3> = random_points(300, 8).into_iter().map(|p| p * 4.0).collect();
        let level = DetailLevel::new("test", 0.5, centres, vec![1.0; 300]).unwrap();
        for max_cells in [1_000_000, 200, 1] {
            let index = level.grid_index(max_cells);
            let cells = index.dims.iter().product::<usize>();
            assert!(cells <= max_cells.max(1), "{cells} cells for at most {max_cells}");
            assert_eq!(index.starts.len(), cells + 1);
            for p in random_points(2000, 9).into_iter().map(|p| p * 5.0 - 0.5) {
                let listed = index.near(p);
                // The level keeps its centres in its own (Morton) order.
                for (j, &c) in level.centres().iter().enumerate() {
                    if p.distance(c) < 0.5 {
                        assert!(listed.contains(&(j as u32)), "centre {j} covers {p}");
                    }
                }
            }
        }
        let fine = level.grid_index(1_000_000);
        assert_eq!(fine.side, 0.5, "the support radius when cells allow");
    }

    /// The index finds every centre that covers a point: local and brute-force sums agree to
    /// rounding, and the support is compact (zero farther than rho from every centre).
    #[test]
    fn local_evaluation_equals_the_sum_over_every_centre() {
        let centres: Vec<DVec3> = random_points(500, 7).into_iter().map(|p| p * 10.0).collect();
        let weights: Vec<f64> = (0..500).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        let level = DetailLevel::new("test", 1.3, centres.clone(), weights.clone()).unwrap();
        for p in random_points(5000, 8).into_iter().map(|p| p * 12.0 - DVec3::ONE) {
            let local = level.value(p);
            let brute = level.value_brute_force(p);
            assert!((local - brute).abs() <= 1e-12 * (1.0 + brute.abs()), "{local} {brute}");
        }
        let far = DVec3::splat(-5.0);
        assert_eq!(level.value(far), 0.0);
        assert_eq!(level.value_brute_force(far), 0.0);
    }

    /// Both kinds of cell table give every covering centre, in the same order: the centres of
    /// a unit cube (a dense table) and the same centres split into two clusters far apart (a
    /// box of cells mostly empty: a sparse one), evaluated locally against every centre.
    #[test]
    fn dense_and_sparse_tables_list_the_same_centres() {
        let cube: Vec<DVec3> = random_points(400, 11).into_iter().map(|p| p * 4.0).collect();
        let apart: Vec<DVec3> = cube
            .iter()
            .enumerate()
            .map(|(i, &c)| if i % 2 == 0 { c } else { c + DVec3::X * 1e4 })
            .collect();
        let weights: Vec<f64> = (0..400).map(|i| ((i * 31) % 11) as f64 - 5.0).collect();
        for (centres, dense) in [(cube, true), (apart, false)] {
            let level = DetailLevel::new("test", 0.9, centres.clone(), weights.clone()).unwrap();
            assert_eq!(matches!(level.index.cells, CellTable::Dense { .. }), dense);
            let points = random_points(3000, 12).into_iter().map(|p| p * 5.0 - DVec3::splat(0.5));
            for p in points.flat_map(|p| [p, p + DVec3::X * 1e4]) {
                let (local, brute) = (level.value(p), level.value_brute_force(p));
                assert!(
                    (local - brute).abs() <= 1e-12 * (1.0 + brute.abs()),
                    "{p}: {local} {brute}"
                );
                let listed = level.index.near(p);
                assert!(listed.windows(2).all(|w| w[0] < w[1]), "{p}: centres in their order");
                for (j, &c) in level.centres.iter().enumerate() {
                    if p.distance(c) < level.radius {
                        assert!(listed.contains(&(j as u32)), "{p}: centre {j} not listed");
                    }
                }
            }
        }
    }

    /// The sparse solve interpolates: at every centre the level takes its value, to the stated
    /// residual.
    #[test]
    fn the_sparse_solve_interpolates_the_values() {
        let centres: Vec<DVec3> = random_points(2000, 9).into_iter().map(|p| p * 8.0).collect();
        let values: Vec<f64> = centres.iter().map(|c| (c.x * 0.7).sin() + c.y * 0.1).collect();
        let (level, solve) = DetailLevel::interpolate(1.0, centres.clone(), &values).unwrap();
        assert!(solve.residual < 1e-8, "{solve:?}");
        assert!(solve.entries > 2000 && solve.entries < 2000 * 200, "{solve:?}");
        let worst = centres
            .iter()
            .zip(&values)
            .map(|(&c, v)| (level.value(c) - v).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-7, "{worst}");
    }
}
