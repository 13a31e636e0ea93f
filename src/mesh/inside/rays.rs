//! Where grids of parallel rays cross the mesh, along each axis (the scan conversion of 4.1).
//!
//! For ray axis `a`, the rays run along `a` through a lattice of pitch `1/s` in the plane of
//! the two other axes (`u = a + 1`, `v = a + 2`, cyclically), `s` the supersampling. Lattice
//! line `U` lies at grid coordinate `(U - h) / s` with `h = (s - 1) / 2`, so with `s` odd the
//! rays through voxel centres are part of the lattice. The rays through coarse column `(u, v)`
//! are its `s * s` sub-rays `(U mod s) * s + (V mod s)`.
//!
//! A ray that passes exactly through an edge or a vertex of the mesh counts it once: every
//! edge function is computed with its two endpoints in a fixed (lexicographic) order, so two
//! triangles sharing an edge get the same value with opposite signs, and ties are broken by
//! the symbolic perturbation `p + (ε, ε²)` of the ray, the same for every triangle.

use rayon::prelude::*;

use crate::geometry::DVec3;

/// One crossing of a ray with a triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Hit {
    /// Where along the ray, in grid coordinates.
    pub t: f64,
    /// The sub-ray of the column (needed only while sorting).
    pub sub: u8,
    /// +1 if the ray enters the (re-oriented) mesh here going forward, -1 if it leaves.
    pub enter: i8,
}

/// Every crossing of the rays along one axis, grouped by coarse column and sub-ray.
pub(crate) struct Rays {
    n_v: usize,
    /// Sub-rays per column, `s * s`.
    subs: usize,
    /// Hits of sub-ray `r` of column `c = u * n_v + v` are `hits[start[i]..start[i + 1]]`
    /// with `i = c * subs + r`, sorted along the ray.
    start: Vec<usize>,
    hits: Vec<Hit>,
}

/// The two axes of the plane across rays along `axis`.
pub(crate) fn plane_axes(axis: usize) -> (usize, usize) {
    ((axis + 1) % 3, (axis + 2) % 3)
}

impl Rays {
    /// Casts the rays along `axis` through `triangles` (corners in grid coordinates) on a grid
    /// of `dims` voxels with supersampling `s` (odd).
    pub(crate) fn cast(axis: usize, triangles: &[[DVec3; 3]], dims: [usize; 3], s: usize) -> Rays {
        let (u, v) = plane_axes(axis);
        let (n_u, n_v) = (dims[u], dims[v]);
        let h = ((s - 1) / 2) as f64;
        let sf = s as f64;
        // Lattice lines a triangle's projection covers along one axis, clamped to the grid.
        let span = |tri: &[DVec3; 3], axis: usize, n: usize| -> Option<(usize, usize)> {
            let lo = tri.iter().map(|p| p[axis]).fold(f64::INFINITY, f64::min) * sf + h;
            let hi = tri.iter().map(|p| p[axis]).fold(f64::NEG_INFINITY, f64::max) * sf + h;
            let (lo, hi) = (lo.ceil().max(0.0), hi.floor().min((n * s) as f64 - 1.0));
            (lo <= hi).then_some((lo as usize, hi as usize))
        };
        // Triangles by the coarse rows u their projection covers.
        let mut rows: Vec<Vec<u32>> = vec![Vec::new(); n_u];
        for (t, tri) in triangles.iter().enumerate() {
            if let (Some((lo, hi)), Some(_)) = (span(tri, u, n_u), span(tri, v, n_v)) {
                for row in &mut rows[lo / s..=hi / s] {
                    row.push(t as u32);
                }
            }
        }
        let per_row: Vec<(Vec<usize>, Vec<Hit>)> = rows
            .par_iter()
            .enumerate()
            .map(|(row, tris)| {
                let mut found: Vec<(u32, Hit)> = Vec::new();
                for &t in tris {
                    let tri = &triangles[t as usize];
                    let (Some((ulo, uhi)), Some((vlo, vhi))) =
                        (span(tri, u, n_u), span(tri, v, n_v))
                    else {
                        continue;
                    };
                    let projected = Projected::new(tri, axis);
                    for uu in ulo.max(row * s)..=uhi.min(row * s + s - 1) {
                        for vv in vlo..=vhi {
                            let p = [(uu as f64 - h) / sf, (vv as f64 - h) / sf];
                            if let Some((t, enter)) = projected.cross(p) {
                                let sub = ((uu % s) * s + vv % s) as u8;
                                found.push(((vv / s) as u32, Hit { t, sub, enter }));
                            }
                        }
                    }
                }
                found.sort_unstable_by(|(c, x), (d, y)| {
                    (c, x.sub).cmp(&(d, y.sub)).then(x.t.total_cmp(&y.t))
                });
                let mut counts = vec![0usize; n_v * s * s];
                for (c, hit) in &found {
                    counts[*c as usize * s * s + usize::from(hit.sub)] += 1;
                }
                (counts, found.into_iter().map(|(_, hit)| hit).collect())
            })
            .collect();
        let mut start = Vec::with_capacity(n_u * n_v * s * s + 1);
        let mut hits = Vec::with_capacity(per_row.iter().map(|r| r.1.len()).sum());
        start.push(0);
        for (counts, row_hits) in per_row {
            for c in counts {
                start.push(start.last().copied().unwrap_or(0) + c);
            }
            hits.extend(row_hits);
        }
        Rays { n_v, subs: s * s, start, hits }
    }

    /// The hits of sub-ray `sub` of coarse column `(u, v)`, sorted along the ray.
    #[inline]
    pub(crate) fn ray(&self, u: usize, v: usize, sub: usize) -> &[Hit] {
        let i = (u * self.n_v + v) * self.subs + sub;
        &self.hits[self.start[i]..self.start[i + 1]]
    }
}

/// What one ray says about a point at `x` along it: `None` when the ray is unreliable (see
/// [`Tally::vote`]).
#[inline]
pub(crate) fn vote(hits: &[Hit], x: f64) -> Option<bool> {
    let mut tally = Tally::default();
    for hit in hits {
        tally.add(hit.t, hit.enter, x);
    }
    tally.vote()
}

/// The crossings of one ray counted against a point on it, in any order.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Tally {
    /// The signed crossings before the point.
    winding: i32,
    /// The crossings before the point.
    below: usize,
    /// The signed crossings along the whole ray.
    total: i32,
    /// The crossings along the whole ray.
    count: usize,
}

impl Tally {
    /// Counts a crossing at `t` along the ray (`enter` as in [`Hit`]) against the point at `x`.
    #[inline]
    pub(crate) fn add(&mut self, t: f64, enter: i8, x: f64) {
        if t < x {
            self.winding += i32::from(enter);
            self.below += 1;
        }
        self.total += i32::from(enter);
        self.count += 1;
    }

    /// What the ray says about the point: `None` when it is unreliable.
    ///
    /// A ray whose entries and exits balance (signed total 0) votes by the nonzero winding
    /// rule (inside when the signed count before the point is not 0), which keeps overlapping
    /// closed parts solid; otherwise a ray with an even number of crossings votes by parity; a
    /// ray with an odd number of crossings went through a hole and abstains.
    #[inline]
    pub(crate) fn vote(self) -> Option<bool> {
        if self.total == 0 {
            Some(self.winding != 0)
        } else if self.count.is_multiple_of(2) {
            Some(self.below % 2 == 1)
        } else {
            None
        }
    }
}

/// A triangle projected along a ray axis.
pub(crate) struct Projected {
    /// Corners in the plane (u, v).
    p: [[f64; 2]; 3],
    /// Corner positions along the ray axis.
    depth: [f64; 3],
    /// Sign of the projected area: +1 counter-clockwise in (u, v), -1 clockwise, 0 flat.
    orientation: f64,
}

impl Projected {
    pub(crate) fn new(tri: &[DVec3; 3], axis: usize) -> Projected {
        let (u, v) = plane_axes(axis);
        let p = tri.map(|c| [c[u], c[v]]);
        let area = edge_function(p[0], p[1], p[2])
            + edge_function(p[1], p[2], p[0])
            + edge_function(p[2], p[0], p[1]);
        let orientation = if area > 0.0 {
            1.0
        } else if area < 0.0 {
            -1.0
        } else {
            0.0
        };
        Projected { p, depth: tri.map(|c| c[axis]), orientation }
    }

    /// Whether the ray through `q` crosses the triangle: where, and whether it enters.
    #[inline]
    pub(crate) fn cross(&self, q: [f64; 2]) -> Option<(f64, i8)> {
        if self.orientation == 0.0 {
            return None;
        }
        let mut w = [0.0; 3];
        for (k, wk) in w.iter_mut().enumerate() {
            // The edge opposite corner k, from corner k + 1 to corner k + 2.
            let e = signed_edge(self.p[(k + 1) % 3], self.p[(k + 2) % 3], q);
            if e * self.orientation <= 0.0 {
                return None;
            }
            *wk = e.abs().max(f64::MIN_POSITIVE);
        }
        let sum = w[0] + w[1] + w[2];
        let t = (w[0] * self.depth[0] + w[1] * self.depth[1] + w[2] * self.depth[2]) / sum;
        // With (u, v, axis) right-handed, a counter-clockwise projection faces +axis: an exit.
        Some((t, if self.orientation > 0.0 { -1 } else { 1 }))
    }
}

/// The edge function of the directed edge `a -> b` at `q` (positive when `q` is to the left),
/// never zero: computed with the endpoints in lexicographic order so that both triangles of an
/// edge get the same magnitude, and on the edge itself signed by the perturbation `q + (ε, ε²)`.
#[inline]
fn signed_edge(a: [f64; 2], b: [f64; 2], q: [f64; 2]) -> f64 {
    let (lo, hi, sign) = if (a[0], a[1]) <= (b[0], b[1]) { (a, b, 1.0) } else { (b, a, -1.0) };
    let e = edge_function(lo, hi, q);
    let e = if e != 0.0 {
        e
    } else {
        // d/dq of the edge function along (ε, ε²): -(hi.v - lo.v) ε + (hi.u - lo.u) ε².
        let dv = lo[1] - hi[1];
        let tiny = f64::MIN_POSITIVE;
        if dv != 0.0 { dv.signum() * tiny } else { (hi[0] - lo[0]).signum() * tiny }
    };
    sign * e
}

/// Twice the signed area of (a, b, q).
#[inline]
fn edge_function(a: [f64; 2], b: [f64; 2], q: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ray_through_a_shared_edge_or_vertex_counts_once() {
        // A square in the plane z = 0.5 split along its diagonal, and a fan around its centre.
        let c = |x: f64, y: f64| DVec3::new(x, y, 0.5);
        let square =
            [[c(0.0, 0.0), c(2.0, 0.0), c(2.0, 2.0)], [c(0.0, 0.0), c(2.0, 2.0), c(0.0, 2.0)]];
        let fan: Vec<[DVec3; 3]> = {
            let ring = [c(0.0, 0.0), c(2.0, 0.0), c(2.0, 2.0), c(0.0, 2.0)];
            (0..4).map(|i| [c(1.0, 1.0), ring[i], ring[(i + 1) % 4]]).collect()
        };
        for tris in [&square[..], &fan[..]] {
            for q in [[1.0, 1.0], [0.5, 0.5], [1.5, 1.5], [0.0, 0.0], [2.0, 1.0]] {
                let n = tris.iter().filter(|t| Projected::new(t, 2).cross(q).is_some()).count();
                let expect = usize::from(q[0] > 0.0 && q[0] < 2.0 && q[1] > 0.0 && q[1] < 2.0);
                assert!(n == expect || (expect == 0 && n <= 1), "{q:?}: {n} crossings");
            }
        }
    }
}
