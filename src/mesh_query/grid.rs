//! The exact signed distance at the voxel centres of a grid ([`signed_distance`]): what
//! `implicitize sdf --exact` writes.
//!
//! Each voxel centre's distance to the triangles is [`MeshQuery`]'s exact one (f64, mesh
//! units, the same number [`MeshQuery::nearest`] gives), stored as f32. The sign is the
//! voxelization's: positive where the voxel's density exceeds 1/2, the inside of the voxel
//! signed distance ([`crate::edt::signed_distance`]) and of the fit, voxel for voxel.
//!
//! # Grid coherence
//! The voxels are measured in blocks of 4³ (slabs of blocks in parallel, rayon). A
//! block gathers once, from the hierarchy, every triangle that can be nearest to one of its
//! voxels: within `d(c) + 2ρ` of its centre `c` (ρ: the farthest voxel centre from `c`),
//! since `|d(p) - d(c)| <= |p - c|` for any distance. Each gathered triangle `T` keeps its
//! distance `d_T` and direction `g_T` (unit, from its closest point to `c`). The distance to a
//! convex set is a convex function, so `d_T + g_T · (p - c)` is a lower bound of `T`'s distance
//! at any `p` (tight near `c`); a voxel measures exactly the triangle of the least bound, then
//! only the triangles whose bound is below the best so far. The bounds are lowered by a
//! relative 1e-10 against rounding, so no triangle is skipped that could be nearest: the answer
//! is the minimum over all triangles, the number [`MeshQuery::nearest`] gives, bit for bit.
//!
//! # Band
//! With a band of K voxels, every value is clamped to ±K voxels (K times the voxel size, mesh
//! units) and only the voxels that may lie within K voxels of the surface are measured, each
//! block gathering the triangles within K voxels plus ρ of its centre instead of `d(c) + 2ρ`:
//! the volume is the unbanded one clamped, voxel for voxel. The voxels measured are those within R = ⌊K + 1/2⌋ voxels along every axis of a cell a
//! triangle may touch (a cell whose centre is within half its diagonal, √3/2 voxel, of the
//! triangle). None within K voxels is missed: if a voxel centre p lies within K voxels of its
//! closest point q, and q lies in the cell of voxel c, then along each axis p is at most
//! K + 1/2 voxels from c, and voxel centres are whole voxels apart.

use rayon::prelude::*;

use super::{MeshQuery, closest_on_triangle, signed};
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};

/// The exact distance from each voxel centre of `density`'s grid to the surface of `query`,
/// mesh units, positive where the density exceeds 1/2 (see the module doc); with `band` (K
/// voxels, positive), clamped to ±K voxels. The densities' storage becomes the volume's.
pub fn signed_distance(query: &MeshQuery, density: Volume<f32>, band: Option<f64>) -> Volume<f32> {
    let grid = density.grid;
    let mut values = density;
    let near = band.map(|k| near_surface(query, &grid, reach(k)));
    let limit = band.map(|k| k * grid.voxel_size);
    let [_, ny, nz] = grid.dims;
    let slab = BLOCK * ny * nz;
    values.data.par_chunks_mut(slab).enumerate().for_each_init(
        Candidates::default,
        |c, (s, values)| {
            let first = s * slab;
            let near = near.as_deref().map(|near| &near[first..first + values.len()]);
            let i = s * BLOCK;
            for j in (0..ny).step_by(BLOCK) {
                for k in (0..nz).step_by(BLOCK) {
                    let block = Block { grid: &grid, start: [i, j, k], first, limit };
                    block.measure(query, c, near, values);
                }
            }
        },
    );
    values
}

/// Voxels along each axis of a block measured together (see the module doc).
pub(crate) const BLOCK: usize = 4;

/// R of the module doc: the voxels along each axis from a touched cell that a voxel within
/// `band` voxels of the surface can be.
fn reach(band: f64) -> usize {
    (band + 0.5 + 1e-9).floor() as usize
}

/// The triangles a block gathered, with their lower bounds' terms (see the module doc).
#[derive(Default)]
struct Candidates {
    /// `d_T`, lowered against rounding.
    distance: Vec<f64>,
    /// `g_T`, by coordinate.
    gradient: [Vec<f64>; 3],
    /// `T`, in the hierarchy's order.
    triangle: Vec<usize>,
    /// The bounds at the current voxel.
    lower: Vec<f64>,
    /// The triangle nearest the previous block's centre: where the next one's search starts.
    previous: usize,
}

impl Candidates {
    /// Gathers the triangles within `radius` of `c`.
    /// `rho`: the farthest voxel centre from `c`, for the margin against rounding.
    fn gather(&mut self, query: &MeshQuery, c: DVec3, radius: f64, rho: f64) {
        self.distance.clear();
        self.gradient.iter_mut().for_each(Vec::clear);
        self.triangle.clear();
        let radius2 = (radius * (1.0 + 1e-9)).powi(2);
        query.within(c, radius2, |t, d2, point| {
            let d = d2.sqrt();
            let g = if d > 0.0 { (c - point) / d } else { DVec3::ZERO };
            self.distance.push(d - 1e-10 * (d + rho));
            for (axis, gradient) in self.gradient.iter_mut().enumerate() {
                gradient.push(g[axis]);
            }
            self.triangle.push(t);
        });
    }

    /// The squared distance from `p` to the nearest gathered triangle (`c`: the block's
    /// centre), or `None` when none was gathered.
    fn nearest(&mut self, query: &MeshQuery, p: DVec3, c: DVec3) -> Option<f64> {
        let offset = p - c;
        let [gx, gy, gz] = &self.gradient;
        self.lower.clear();
        let terms = self.distance.iter().zip(gx).zip(gy).zip(gz);
        self.lower
            .extend(terms.map(|(((d, x), y), z)| d + x * offset.x + y * offset.y + z * offset.z));
        let lower = &self.lower;
        let least = (0..lower.len()).min_by(|&a, &b| lower[a].total_cmp(&lower[b]))?;
        let mut best = query.seed(p, self.triangle[least]).0;
        let mut best_distance = best.sqrt();
        for (i, &bound) in lower.iter().enumerate() {
            if bound < best_distance && i != least {
                let d2 = query.seed(p, self.triangle[i]).0;
                if d2 < best {
                    (best, best_distance) = (d2, d2.sqrt());
                }
            }
        }
        Some(best)
    }
}

/// A block of voxels: the first voxel, clipped to the grid at its far end.
struct Block<'a> {
    grid: &'a Grid,
    start: [usize; 3],
    /// The linear index of the first voxel of the block's slab.
    first: usize,
    /// The band, mesh units, or none.
    limit: Option<f64>,
}

impl Block<'_> {
    /// Replaces the densities of the block's voxels in `values` (its slab) by their signed
    /// distances; `near`: the slab's voxels within the band, if any.
    fn measure(
        &self,
        query: &MeshQuery,
        candidates: &mut Candidates,
        near: Option<&[bool]>,
        values: &mut [f32],
    ) {
        let end =
            std::array::from_fn::<usize, 3, _>(|a| (self.start[a] + BLOCK).min(self.grid.dims[a]));
        let voxels = || {
            let [i0, j0, k0] = self.start;
            (i0..end[0]).flat_map(move |i| {
                (j0..end[1]).flat_map(move |j| (k0..end[2]).map(move |k| [i, j, k]))
            })
        };
        let local = |v: [usize; 3]| self.grid.index(v) - self.first;
        let limit = self.limit.unwrap_or(f64::INFINITY);
        let measured = |v: [usize; 3]| near.is_none_or(|near| near[local(v)]);
        if !voxels().any(measured) {
            for v in voxels() {
                let value = &mut values[local(v)];
                *value = signed(limit, *value > 0.5) as f32;
            }
            return;
        }
        let low = self.grid.position(self.start);
        let high = self.grid.position(end.map(|e| e - 1));
        let c = (low + high) / 2.0;
        let rho = (high - low).length() / 2.0;
        let radius = match self.limit {
            Some(limit) => limit + rho,
            None => {
                let (d2, t) = query.search(c, query.seed(c, candidates.previous));
                candidates.previous = t;
                d2.sqrt() + 2.0 * rho
            }
        };
        candidates.gather(query, c, radius, rho);
        for v in voxels() {
            let value = &mut values[local(v)];
            let inside = *value > 0.5;
            let distance = if measured(v) {
                let p = self.grid.position(v);
                candidates.nearest(query, p, c).map_or(limit, |d2| d2.sqrt().min(limit))
            } else {
                limit
            };
            *value = signed(distance, inside) as f32;
        }
    }
}

/// Which voxels of `grid` lie within `reach` voxels along every axis of a cell that a
/// triangle of `query` may touch (see the module doc).
fn near_surface(query: &MeshQuery, grid: &Grid, reach: usize) -> Vec<bool> {
    let mut touched = vec![false; grid.len()];
    // A cell's centre within half its diagonal of the triangle, with room for rounding.
    let within = (3f64.sqrt() / 2.0 + 1e-6).powi(2);
    for corners in &query.triangles {
        let corners = corners.map(|p| grid.to_grid(p));
        let (min, max) = corners
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |b, &p| (b.0.min(p), b.1.max(p)));
        let range = |axis: usize| {
            let last = grid.dims[axis] as f64 - 1.0;
            let low = (min[axis] - 0.5).floor().clamp(0.0, last) as usize;
            let high = (max[axis] + 0.5).ceil().clamp(0.0, last) as usize;
            low..=high
        };
        for i in range(0) {
            for j in range(1) {
                for k in range(2) {
                    let c = DVec3::new(i as f64, j as f64, k as f64);
                    let (point, _) = closest_on_triangle(c, &corners);
                    if c.distance_squared(point) <= within {
                        touched[grid.index([i, j, k])] = true;
                    }
                }
            }
        }
    }
    dilate(touched, grid.dims, reach)
}

/// `mask` grown by `reach` voxels along each axis (a cube of side `2 reach + 1` around each
/// voxel set), one axis at a time.
fn dilate(mask: Vec<bool>, [nx, ny, nz]: [usize; 3], reach: usize) -> Vec<bool> {
    let window = |i: usize, n: usize| i.saturating_sub(reach)..(i + reach + 1).min(n);
    let plane = ny * nz;
    let mut along_z = vec![false; mask.len()];
    along_z.par_chunks_mut(nz).zip(mask.par_chunks(nz)).for_each(|(out, line)| {
        for (k, out) in out.iter_mut().enumerate() {
            *out = line[window(k, nz)].contains(&true);
        }
    });
    let mut along_y = mask;
    along_y.par_chunks_mut(plane).zip(along_z.par_chunks(plane)).for_each(|(out, slab)| {
        for j in 0..ny {
            let row = &mut out[j * nz..(j + 1) * nz];
            row.fill(false);
            for source in window(j, ny) {
                or_into(row, &slab[source * nz..(source + 1) * nz]);
            }
        }
    });
    let mut along_x = along_z;
    along_x.par_chunks_mut(plane).enumerate().for_each(|(i, out)| {
        out.fill(false);
        for source in window(i, nx) {
            or_into(out, &along_y[source * plane..(source + 1) * plane]);
        }
    });
    along_x
}

/// `out |= other`, element by element.
fn or_into(out: &mut [bool], other: &[bool]) {
    for (a, &b) in out.iter_mut().zip(other) {
        *a |= b;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dilation_is_a_cube_clipped_to_the_grid() {
        let dims = [5, 6, 7];
        let grid = Grid { dims, origin: [0.0; 3], voxel_size: 1.0 };
        let mut mask = vec![false; grid.len()];
        mask[grid.index([1, 3, 6])] = true;
        let grown = dilate(mask, dims, 2);
        for (index, &grown) in grown.iter().enumerate() {
            let [i, j, k] = grid.voxel(index);
            let inside = i <= 3 && (1..=5).contains(&j) && k >= 4;
            assert_eq!(grown, inside, "{:?}", [i, j, k]);
        }
    }

    #[test]
    fn the_reach_covers_half_a_cell_beyond_the_band() {
        assert_eq!(reach(3.0), 3);
        assert_eq!(reach(2.5), 3);
        assert_eq!(reach(2.49), 2);
        assert_eq!(reach(0.1), 0);
    }
}
