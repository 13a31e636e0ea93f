//! Fast summation of the radial part `s(x) = sum_j d_j phi(|x - c_j|)` at many points: a
//! barycentric Lagrange treecode with interpolation on both sides, traversing a source tree and
//! a target tree together (BLDTT), after Wang, Krasny & Tlupova, "A kernel-independent treecode
//! based on barycentric Lagrange interpolation", Commun. Comput. Phys. 28 (2020), and its
//! dual-tree variant (Wilson, Vaughn & Krasny, "A GPU-accelerated fast summation method based on
//! barycentric Lagrange interpolation and dual tree traversal", Comput. Phys. Commun. 2021).
//!
//! ## The method
//! * Centres and points are each sorted along a Morton curve into a kd-tree that halves boxes
//!   along x, y and z in turn, with tight bounding boxes; leaves hold at most
//!   [`Params::source_leaf`] centres or [`Params::target_leaf`] points.
//! * A source node with more centres than the `(p + 1)^3` Chebyshev points of the second kind of
//!   its box (`p` = [`Params::degree`]) gets proxy weights `q_k = sum_j L_k(c_j) d_j` at those
//!   points, `L_k` the tensor-product barycentric Lagrange basis of its box.
//! * A target node with more points than `(p + 1)^3` gets a potential at the Chebyshev points
//!   of its box, interpolated down the tree to the children's points and, at the bottom, to
//!   the points themselves.
//! * The two trees are traversed together. A side that interpolates must be well separated from
//!   the other: its radius below [`Params::theta`] times the distance from its centre to the
//!   other's bounding sphere (the sum of both radii below `theta` times the distance between
//!   centres when both interpolate). Accepted pairs interact through proxies and grids where
//!   the nodes have them, others are split (the larger node first), and pairs where neither side
//!   could interpolate are summed directly.
//! * Every interaction list, gathered as centres per axis and weights, is summed by the same
//!   vectorized loop as the direct sum ([`super::kernel`]). Each thread gathers into buffers
//!   it keeps from one list to the next, and each leaf interpolates its far field from the
//!   smallest grid above it, eight points at a time (a vector lane each).
//!
//! Interpolation of degree `p` reproduces polynomials of degree at most `p` exactly, in either
//! variable, so the `r^2` far-field growth of `r^2 log r` (a quadratic) is carried without
//! error and the cancellation between large terms (the weights sum to zero) costs no accuracy
//! beyond that of the sums themselves.
//!
//! ## Guarantees
//! * With [`PARAMS`] (`p = 8`, `theta = 0.6`) the values are within `1e-5` of the function's
//!   value range (the largest `|f|` over the evaluated points) of the direct sum. The tests
//!   check it for every kernel on the bunny fit (700 constraints), on a fitted 5,000-constraint
//!   torus and on 20,000 centres with random weights, and that the zero crossing near the
//!   bunny's surface moves by less than a hundredth of a voxel of a 200-voxel grid.
//! * The result depends only on the centres, weights and points, never on the number of
//!   threads: every list is gathered and summed in a fixed order.
//! * Only three-dimensional functions are summed this way; evaluation keeps the direct sum in
//!   two and four dimensions.
//!
//! ## Cost and where it is used
//! The cost per point is about `(p + 1)^3` times the centres in a shell around the smallest
//! target node with a grid, over that node's points, plus the centres near the point: some 4,000
//! kernel evaluations per point for 20,000 centres on a surface and 1,000,000 points in its box
//! (20,000 for the direct sum). The trees and grids cost more than they save for few centres or
//! few points, so evaluation uses the treecode only from the sizes [`pays`] names, where the
//! criterion bench (`benches/rbf.rs`, `treecode`) finds it ahead of the direct sum.

use rayon::prelude::*;

use super::Implicit;
use super::isa::Isa;
use super::kernel::{self, Centres, LANES, Phi};
use crate::geometry::{MORTON_BITS, morton_key};

/// The most Chebyshev points per axis of any [`Params::degree`].
const MAX_NODES: usize = 12;

/// The treecode's accuracy and granularity.
#[derive(Debug, Clone, Copy)]
pub(super) struct Params {
    /// The degree `p` of the Chebyshev interpolation on each axis (below [`MAX_NODES`]).
    pub degree: usize,
    /// The multipole acceptance criterion: nodes interact through proxies when the sum of
    /// their radii is less than `theta` times the distance between their centres.
    pub theta: f64,
    /// The most centres in a leaf of the source tree.
    pub source_leaf: usize,
    /// The most points in a leaf of the target tree.
    pub target_leaf: usize,
}

/// The parameters evaluation uses.
pub(super) const PARAMS: Params =
    Params { degree: 8, theta: 0.6, source_leaf: 32, target_leaf: 64 };

impl Params {
    /// Chebyshev points per node: `(p + 1)^3`.
    fn grid(&self) -> usize {
        (self.degree + 1).pow(3)
    }
}

/// Whether `centres` centres at `points` points are summed faster by the treecode than
/// directly.
pub(super) fn pays(centres: usize, points: usize) -> bool {
    least_points(centres).is_some_and(|least| points >= least)
}

/// The fewest points at which a function of `centres` centres is summed by the treecode, if
/// it has enough centres to be summed that way at all.
pub(super) fn least_points(centres: usize) -> Option<usize> {
    (centres >= 5000).then_some(200_000)
}

/// Points (or centres) given per axis.
type Axes<'a> = [&'a [f64]; 3];

/// The values of the three-dimensional `implicit` at `count` points, the `i`th written (in the
/// mesh's units) by `point(i, buffer)`, with the radial part summed by the treecode: every
/// point normalized at once, the polynomial added in f64. `None` when a coordinate is not
/// finite (the direct sum confines such a point's NaN to its own value).
pub(super) fn values<K: Phi>(
    isa: Isa,
    params: &Params,
    implicit: &Implicit,
    count: usize,
    point: &(impl Fn(usize, &mut [f64]) + Sync),
) -> Option<Vec<f64>> {
    let normalized: Vec<[f64; 3]> = (0..count)
        .into_par_iter()
        .map(|i| {
            let (mut raw, mut x) = ([0.0; 3], [0.0; 3]);
            point(i, &mut raw);
            implicit.normalization.apply(&raw, &mut x);
            x
        })
        .collect();
    if !normalized.par_iter().all(|x| x.iter().all(|v| v.is_finite())) {
        return None;
    }
    let axes: [Vec<f64>; 3] =
        std::array::from_fn(|a| normalized.par_iter().map(|x| x[a]).collect());
    let poly = &implicit.polynomial;
    let mut out: Vec<f64> = normalized
        .par_iter()
        .map(|x| poly[0] + poly[1] * x[0] + poly[2] * x[1] + poly[3] * x[2])
        .collect();
    let points = std::array::from_fn(|a| axes[a].as_slice());
    radial::<K>(isa, params, &implicit.centres, &implicit.weights, points, &mut out);
    Some(out)
}

/// `sum_j d_j phi(|x_i - c_j|)` for every point `x_i`, added to `out` (as long as the
/// points): `centres` per axis one after another.
fn radial<K: Phi>(
    isa: Isa,
    params: &Params,
    centres: &[f64],
    weights: &[f64],
    points: Axes,
    out: &mut [f64],
) {
    let n = weights.len();
    let c: Axes = std::array::from_fn(|a| &centres[a * n..(a + 1) * n]);
    let sources = Tree::new(c, params.source_leaf);
    let source_weights: Vec<f64> = sources.order.iter().map(|&j| weights[j]).collect();
    let proxies = proxy_weights(params, &sources, &source_weights);
    let targets = Tree::new(points, params.target_leaf);
    let lists = Lists::traverse(params, &targets, &sources);
    // Each thread gathers its lists into buffers of its own, kept from one list to the next.
    let sum = |gathered: &mut Gathered, list: &[Source], at: Axes| {
        gathered.gather(params, list, &sources, &source_weights, &proxies);
        sum_at::<K>(isa, gathered, at)
    };
    let mut grids: Vec<Option<Vec<f64>>> = (0..targets.nodes.len())
        .into_par_iter()
        .map_init(Gathered::default, |gathered, t| {
            let points = targets.nodes[t].grid(params)?.points();
            Some(sum(gathered, &lists.grid[t], std::array::from_fn(|a| points[a].as_slice())))
        })
        .collect();
    down(params, &targets, &mut grids);
    let leaves: Vec<usize> =
        (0..targets.nodes.len()).filter(|&t| targets.nodes[t].is_leaf()).collect();
    let sorted: Vec<Vec<f64>> = leaves
        .par_iter()
        .map_init(Gathered::default, |gathered, &t| {
            let at = targets.points(&targets.nodes[t]);
            let mut values = sum(gathered, &lists.direct[t], at);
            if let Some((grid, potential)) = far_field(params, &targets, t, &grids) {
                let far = grid.interpolate(potential, at);
                values.iter_mut().zip(far).for_each(|(v, f)| *v += f);
            }
            values
        })
        .collect();
    for (&t, values) in leaves.iter().zip(&sorted) {
        let node = &targets.nodes[t];
        for (&i, v) in targets.order[node.start..node.end].iter().zip(values) {
            out[i] += v;
        }
    }
}

/// The grid (and its potential) that leaf `t`'s points take their far field from: that of the
/// smallest node with a grid that holds them (the leaf itself or an ancestor), which [`down`]
/// has given the far field of every node above it.
fn far_field<'a>(
    params: &Params,
    targets: &Tree,
    t: usize,
    grids: &'a [Option<Vec<f64>>],
) -> Option<(Chebyshev, &'a [f64])> {
    let mut t = t;
    loop {
        let node = &targets.nodes[t];
        if let (Some(grid), Some(potential)) = (node.grid(params), grids[t].as_deref()) {
            return Some((grid, potential));
        }
        t = node.parent?;
    }
}

/// Adds each grid node's parent potential, interpolated, to its own: top down, so that every
/// grid ends up holding the whole far field of its box.
fn down(params: &Params, targets: &Tree, grids: &mut [Option<Vec<f64>>]) {
    for t in 1..targets.nodes.len() {
        let node = &targets.nodes[t];
        let (Some(grid), Some(parent)) = (node.grid(params), node.parent) else { continue };
        let Some(from) = targets.nodes[parent].grid(params) else { continue };
        let Some(potential) = grids[parent].as_deref() else { continue };
        let moved = from.to_grid(potential, &grid);
        if let Some(own) = grids[t].as_mut() {
            own.iter_mut().zip(moved).for_each(|(o, m)| *o += m);
        }
    }
}

/// A tight axis-aligned box.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Bounds {
    fn of(points: Axes, range: std::ops::Range<usize>) -> Bounds {
        let mut b = Bounds { lo: [f64::INFINITY; 3], hi: [f64::NEG_INFINITY; 3] };
        for (a, axis) in points.iter().enumerate() {
            for &v in &axis[range.clone()] {
                b.lo[a] = b.lo[a].min(v);
                b.hi[a] = b.hi[a].max(v);
            }
        }
        b
    }

    fn centre(&self) -> [f64; 3] {
        std::array::from_fn(|a| 0.5 * (self.lo[a] + self.hi[a]))
    }

    fn radius(&self) -> f64 {
        (0..3).map(|a| (0.5 * (self.hi[a] - self.lo[a])).powi(2)).sum::<f64>().sqrt()
    }
}

/// A node of a tree: a range of the sorted points and its children's indices.
#[derive(Debug, Clone)]
struct Node {
    start: usize,
    end: usize,
    bounds: Bounds,
    parent: Option<usize>,
    children: std::ops::Range<usize>,
}

impl Node {
    fn len(&self) -> usize {
        self.end - self.start
    }

    fn is_leaf(&self) -> bool {
        self.children.is_empty()
    }

    /// The Chebyshev grid of the node's box, if it has more points than the grid.
    fn grid(&self, params: &Params) -> Option<Chebyshev> {
        (self.len() > params.grid()).then(|| Chebyshev::new(params.degree, &self.bounds))
    }
}

/// A kd-tree over points sorted along a Morton curve: each node is split in two by the next
/// bit of the keys.
struct Tree {
    /// The points, sorted, per axis.
    axes: [Vec<f64>; 3],
    /// The original index of each sorted point.
    order: Vec<usize>,
    /// Node 0 is the root; children follow their parent and are contiguous.
    nodes: Vec<Node>,
}

impl Tree {
    fn new(points: Axes, leaf: usize) -> Tree {
        let n = points[0].len();
        let all = Bounds::of(points, 0..n);
        let keys = morton_keys(points, &all);
        let mut sorted: Vec<(u64, usize)> = keys.into_iter().zip(0..n).collect();
        sorted.par_sort_unstable();
        let order: Vec<usize> = sorted.iter().map(|&(_, i)| i).collect();
        let keys: Vec<u64> = sorted.iter().map(|&(k, _)| k).collect();
        let axes: [Vec<f64>; 3] =
            std::array::from_fn(|a| order.par_iter().map(|&i| points[a][i]).collect());
        let mut tree = Tree { axes, order, nodes: Vec::new() };
        tree.nodes.push(Node { start: 0, end: n, bounds: all, parent: None, children: 0..0 });
        tree.split(0, &keys, 3 * MORTON_BITS, leaf);
        tree
    }

    /// Splits node `t` (whose keys agree above bit `level`) in two by the next bit, and the
    /// halves in turn, down to `leaf` points: a kd-tree that cuts boxes in the middle along x,
    /// y and z in turn.
    fn split(&mut self, t: usize, keys: &[u64], level: u32, leaf: usize) {
        let (start, end) = (self.nodes[t].start, self.nodes[t].end);
        if end - start <= leaf || level == 0 {
            return;
        }
        let level = level - 1;
        let middle = start + keys[start..end].partition_point(|&k| (k >> level) & 1 == 0);
        if middle == start || middle == end {
            // One half holds everything: the node is split at the next bit instead.
            return self.split(t, keys, level, leaf);
        }
        let first = self.nodes.len();
        for (s, e) in [(start, middle), (middle, end)] {
            let bounds = Bounds::of(self.slices(), s..e);
            self.nodes.push(Node { start: s, end: e, bounds, parent: Some(t), children: 0..0 });
        }
        self.nodes[t].children = first..first + 2;
        for c in first..first + 2 {
            self.split(c, keys, level, leaf);
        }
    }

    fn slices(&self) -> Axes<'_> {
        std::array::from_fn(|a| self.axes[a].as_slice())
    }

    /// The sorted points of `node`, per axis.
    fn points(&self, node: &Node) -> Axes<'_> {
        std::array::from_fn(|a| &self.axes[a][node.start..node.end])
    }
}

/// Morton keys of `points` quantized in `bounds`, `MORTON_BITS` bits per axis.
fn morton_keys(points: Axes, bounds: &Bounds) -> Vec<u64> {
    let scale: [f64; 3] = std::array::from_fn(|a| {
        let w = bounds.hi[a] - bounds.lo[a];
        if w > 0.0 { ((1u64 << MORTON_BITS) - 1) as f64 / w } else { 0.0 }
    });
    (0..points[0].len())
        .into_par_iter()
        .map(|i| {
            let q: [u64; 3] =
                std::array::from_fn(|a| ((points[a][i] - bounds.lo[a]) * scale[a]) as u64);
            morton_key(q)
        })
        .collect()
}

/// Points interpolated together by [`Chebyshev::interpolate`], one a vector lane.
const BATCH: usize = 8;

/// Lagrange basis values on one axis: the first `p + 1` entries are used.
type Basis = [f64; MAX_NODES];

/// The tensor grid of Chebyshev points of the second kind in a box, `p + 1` per axis.
#[derive(Debug, Clone)]
struct Chebyshev {
    /// Points per axis: `p + 1`.
    n: usize,
    nodes: [Basis; 3],
}

impl Chebyshev {
    fn new(degree: usize, bounds: &Bounds) -> Chebyshev {
        let extent = (0..3).map(|a| bounds.hi[a] - bounds.lo[a]).fold(0.0, f64::max);
        // A flat box (points in a plane) gets a sliver of width, so that the points stay apart.
        let least = 1e-6 * extent + 1e-12;
        let nodes = std::array::from_fn(|a| {
            let mid = 0.5 * (bounds.lo[a] + bounds.hi[a]);
            let half = (0.5 * (bounds.hi[a] - bounds.lo[a])).max(least);
            std::array::from_fn(|k| {
                let angle = std::f64::consts::PI * k.min(degree) as f64 / degree as f64;
                mid + half * angle.cos()
            })
        });
        Chebyshev { n: degree + 1, nodes }
    }

    /// The grid points per axis, `(i, j, k)` at `(i * (p + 1) + j) * (p + 1) + k`.
    fn points(&self) -> [Vec<f64>; 3] {
        let mut points: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; self.n.pow(3)]);
        self.write_points(points.each_mut().map(|axis| axis.as_mut_slice()));
        points
    }

    /// [`Chebyshev::points`] written into `out` (each axis `(p + 1)^3` long).
    fn write_points(&self, out: [&mut [f64]; 3]) {
        let n = self.n;
        let [xs, ys, zs] = out;
        for (i, &x) in self.nodes[0][..n].iter().enumerate() {
            for (j, &y) in self.nodes[1][..n].iter().enumerate() {
                let row = (i * n + j) * n;
                xs[row..row + n].fill(x);
                ys[row..row + n].fill(y);
                zs[row..row + n].copy_from_slice(&self.nodes[2][..n]);
            }
        }
    }

    /// The values on the grid of `sum_m w_m L_k(x_m)` over the points `x_m` with weights `w_m`:
    /// the proxy weights of a cluster.
    fn anterpolate(&self, at: Axes, weights: &[f64]) -> Vec<f64> {
        let n = self.n;
        let mut q = vec![0.0; n * n * n];
        for (m, &w) in weights.iter().enumerate() {
            let [lx, ly, lz] = std::array::from_fn(|a| self.basis(a, at[a][m]));
            for (i, &x) in lx[..n].iter().enumerate() {
                for (j, &y) in ly[..n].iter().enumerate() {
                    let wxy = w * x * y;
                    let row = &mut q[(i * n + j) * n..][..n];
                    row.iter_mut().zip(&lz).for_each(|(q, &z)| *q += wxy * z);
                }
            }
        }
        q
    }

    /// The interpolant of `potential` (values on the grid) at each point of `at`, [`BATCH`]
    /// points at a time, one point a lane.
    fn interpolate(&self, potential: &[f64], at: Axes) -> Vec<f64> {
        let n = self.n;
        let count = at[0].len();
        let mut out = Vec::with_capacity(count);
        for start in (0..count).step_by(BATCH) {
            let lanes = BATCH.min(count - start);
            // The basis functions per axis, `[k][lane]`.
            let mut basis = [[[0.0; BATCH]; MAX_NODES]; 3];
            for (a, axis) in basis.iter_mut().enumerate() {
                for lane in 0..lanes {
                    let l = self.basis(a, at[a][start + lane]);
                    for (row, &v) in axis.iter_mut().zip(&l[..n]) {
                        row[lane] = v;
                    }
                }
            }
            let [lx, ly, lz] = &basis;
            let mut v = [0.0; BATCH];
            for (i, x) in lx[..n].iter().enumerate() {
                let mut vy = [0.0; BATCH];
                for (j, y) in ly[..n].iter().enumerate() {
                    let row = &potential[(i * n + j) * n..][..n];
                    let mut vz = [0.0; BATCH];
                    for (&p, z) in row.iter().zip(lz) {
                        (0..BATCH).for_each(|l| vz[l] += p * z[l]);
                    }
                    (0..BATCH).for_each(|l| vy[l] += y[l] * vz[l]);
                }
                (0..BATCH).for_each(|l| v[l] += x[l] * vy[l]);
            }
            out.extend_from_slice(&v[..lanes]);
        }
        out
    }

    /// The interpolant of `potential` at the points of grid `to`, axis by axis.
    fn to_grid(&self, potential: &[f64], to: &Chebyshev) -> Vec<f64> {
        let mut values = potential.to_vec();
        for a in 0..3 {
            let basis: Vec<Basis> =
                to.nodes[a][..self.n].iter().map(|&x| self.basis(a, x)).collect();
            values = self.along_axis(&values, a, &basis);
        }
        values
    }

    /// Applies the matrix `basis` (row `k'`: the basis functions at new point `k'`) along axis
    /// `a` of the `(p + 1)^3` tensor `values`.
    fn along_axis(&self, values: &[f64], a: usize, basis: &[Basis]) -> Vec<f64> {
        let n = self.n;
        let stride = n.pow(2 - a as u32);
        (0..values.len())
            .map(|index| {
                let k_new = index / stride % n;
                let base = index - k_new * stride;
                (0..n).map(|k| basis[k_new][k] * values[base + k * stride]).sum()
            })
            .collect()
    }

    /// The `p + 1` Lagrange basis functions of axis `a` at `x`, by the barycentric formula
    /// (weights `(-1)^k`, halved at the ends).
    fn basis(&self, a: usize, x: f64) -> Basis {
        let nodes = &self.nodes[a][..self.n];
        let mut l = [0.0; MAX_NODES];
        if let Some(k) = nodes.iter().position(|&s| s == x) {
            l[k] = 1.0;
            return l;
        }
        let mut total = 0.0;
        for (k, (l, &s)) in l.iter_mut().zip(nodes).enumerate() {
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            let weight = if k == 0 || k == self.n - 1 { 0.5 * sign } else { sign };
            *l = weight / (x - s);
            total += *l;
        }
        l.iter_mut().for_each(|v| *v /= total);
        l
    }
}

/// The proxy weights of every source node with a grid (`None` for the others).
fn proxy_weights(params: &Params, sources: &Tree, weights: &[f64]) -> Vec<Option<Vec<f64>>> {
    sources
        .nodes
        .par_iter()
        .map(|node| {
            let grid = node.grid(params)?;
            Some(grid.anterpolate(sources.points(node), &weights[node.start..node.end]))
        })
        .collect()
}

/// A source node in an interaction list: through its proxies or its real centres.
#[derive(Debug, Clone, Copy)]
enum Source {
    Proxies(usize),
    Centres(usize),
}

/// The interaction lists of the target nodes: what each node's grid sums, and what each leaf's
/// points sum directly.
struct Lists {
    grid: Vec<Vec<Source>>,
    direct: Vec<Vec<Source>>,
}

impl Lists {
    fn traverse(params: &Params, targets: &Tree, sources: &Tree) -> Lists {
        let n = targets.nodes.len();
        let mut lists = Lists { grid: vec![Vec::new(); n], direct: vec![Vec::new(); n] };
        lists.pair(params, targets, sources, 0, 0);
        lists.push_down(targets);
        lists
    }

    /// Sorts the interaction of target node `t` with source node `s` into the lists.
    ///
    /// Each side that interpolates (a target node with a grid, a source node with proxies)
    /// must be far from the other's box: its radius less than `theta` times the distance from
    /// its centre to the other box's bounding sphere (both radii against the distance between
    /// centres when both interpolate). A pair where neither side can interpolate is summed
    /// directly at once.
    fn pair(&mut self, params: &Params, targets: &Tree, sources: &Tree, t: usize, s: usize) {
        let (tn, sn) = (&targets.nodes[t], &sources.nodes[s]);
        let (ct, cs) = (tn.bounds.centre(), sn.bounds.centre());
        let distance = (0..3).map(|a| (ct[a] - cs[a]).powi(2)).sum::<f64>().sqrt();
        let (rt, rs) = (tn.bounds.radius(), sn.bounds.radius());
        let grid = params.grid();
        let theta = params.theta;
        let far = match (tn.len() > grid, sn.len() > grid) {
            (true, true) => rt + rs < theta * distance,
            (true, false) => rt < theta * (distance - rs),
            (false, true) => rs < theta * (distance - rt),
            (false, false) => {
                self.direct[t].push(Source::Centres(s));
                return;
            }
        };
        if far {
            let source = if sn.len() > grid { Source::Proxies(s) } else { Source::Centres(s) };
            let list = if tn.len() > grid { &mut self.grid[t] } else { &mut self.direct[t] };
            list.push(source);
        } else if tn.is_leaf() && sn.is_leaf() {
            self.direct[t].push(Source::Centres(s));
        } else if sn.is_leaf() || (!tn.is_leaf() && rt >= rs) {
            for c in tn.children.clone() {
                self.pair(params, targets, sources, c, s);
            }
        } else {
            for c in sn.children.clone() {
                self.pair(params, targets, sources, t, c);
            }
        }
    }

    /// Moves the direct lists of inner nodes to their leaves, which sum them point by point.
    fn push_down(&mut self, targets: &Tree) {
        for t in 0..targets.nodes.len() {
            let children = targets.nodes[t].children.clone();
            if children.is_empty() {
                continue;
            }
            let list = std::mem::take(&mut self.direct[t]);
            for c in children {
                self.direct[c].extend_from_slice(&list);
            }
        }
    }
}

/// The centres (one axis after another) and weights of an interaction list, in its order.
#[derive(Default)]
struct Gathered {
    centres: Vec<f64>,
    weights: Vec<f64>,
}

impl Gathered {
    /// Replaces the contents with the centres and weights of `list`, reusing the buffers.
    fn gather(
        &mut self,
        params: &Params,
        list: &[Source],
        sources: &Tree,
        weights: &[f64],
        proxies: &[Option<Vec<f64>>],
    ) {
        let count = |source: &Source| match *source {
            Source::Proxies(s) => proxies[s].as_ref().map_or(0, Vec::len),
            Source::Centres(s) => sources.nodes[s].len(),
        };
        let n: usize = list.iter().map(count).sum();
        self.centres.resize(3 * n, 0.0);
        self.weights.clear();
        let (x, rest) = self.centres.split_at_mut(n);
        let (y, z) = rest.split_at_mut(n);
        let mut axes: [&mut [f64]; 3] = [x, y, z];
        let mut at = 0;
        for source in list {
            let len = count(source);
            let to: [&mut [f64]; 3] = axes.each_mut().map(|axis| &mut axis[at..at + len]);
            match *source {
                Source::Proxies(s) => {
                    if let Some(q) = proxies[s].as_deref() {
                        Chebyshev::new(params.degree, &sources.nodes[s].bounds).write_points(to);
                        self.weights.extend_from_slice(q);
                    }
                }
                Source::Centres(s) => {
                    let node = &sources.nodes[s];
                    for (to, from) in to.into_iter().zip(sources.points(node)) {
                        to.copy_from_slice(from);
                    }
                    self.weights.extend_from_slice(&weights[node.start..node.end]);
                }
            }
            at += len;
        }
    }
}

/// The sums of `gathered` at the points `at`, by the vectorized direct loop.
fn sum_at<K: Phi>(isa: Isa, gathered: &Gathered, at: Axes) -> Vec<f64> {
    let count = at[0].len();
    let mut out = vec![0.0; count];
    if gathered.weights.is_empty() {
        return out;
    }
    let padded = count.div_ceil(LANES) * LANES;
    let points: [Vec<f64>; 3] = std::array::from_fn(|a| {
        let mut axis = at[a].to_vec();
        axis.resize(padded, 0.0);
        axis
    });
    let centres = Centres { centres: &gathered.centres, weights: &gathered.weights };
    kernel::sum::<3, K>(isa, &centres, &points, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use crate::rbf::isa::Isa;
    use crate::rbf::kernel::{self, Phi, Specialized};
    use crate::rbf::{Constraint, Implicit, Kernel, read_constraints};

    use super::{PARAMS, Params};

    const KERNELS: [Kernel; 3] = [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear];

    /// The error bound of the module doc, relative to the value range.
    const BOUND: f64 = 1e-5;

    /// The values at `points` by the treecode with `params`.
    fn by_treecode(implicit: &Implicit, params: Params, points: &[[f64; 3]]) -> Vec<f64> {
        let work = ByTreecode { params, implicit, points };
        kernel::specialize(3, implicit.kernel(), work).expect("finite points")
    }

    /// The work of [`by_treecode`].
    struct ByTreecode<'a> {
        params: Params,
        implicit: &'a Implicit,
        points: &'a [[f64; 3]],
    }

    impl Specialized for ByTreecode<'_> {
        type Output = Option<Vec<f64>>;

        fn run<const D: usize, K: Phi>(self) -> Option<Vec<f64>> {
            let (isa, points) = (Isa::selected(), self.points);
            let point = |i: usize, out: &mut [f64]| out.copy_from_slice(&points[i]);
            super::values::<K>(isa, &self.params, self.implicit, points.len(), &point)
        }
    }

    /// The largest difference between treecode and direct sum at `points`, relative to the
    /// largest exact `|f|` there.
    fn relative_error(implicit: &Implicit, params: Params, points: &[[f64; 3]]) -> f64 {
        let exact = implicit.values3_exact(points);
        let fast = by_treecode(implicit, params, points);
        let range = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = exact.iter().zip(&fast).fold(0.0f64, |m, (e, f)| m.max((e - f).abs()));
        worst / range
    }

    fn bunny() -> Vec<Constraint> {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bunny_constraints.csv");
        read_constraints(&data).unwrap().1
    }

    /// `count` random points in the box of `constraints` grown by a fifth on every side.
    fn points_around(constraints: &[Constraint], count: usize, seed: u64) -> Vec<[f64; 3]> {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for c in constraints {
            for a in 0..3 {
                lo[a] = lo[a].min(c.position()[a]);
                hi[a] = hi[a].max(c.position()[a]);
            }
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..count)
            .map(|_| {
                std::array::from_fn(|a| {
                    let w = hi[a] - lo[a];
                    lo[a] - 0.2 * w + 1.4 * w * rng.random::<f64>()
                })
            })
            .collect()
    }

    /// `n` constraints on a torus (radii 1 and 0.4): on it, and 0.05 inside and outside.
    fn torus(n: usize) -> Vec<Constraint> {
        (0..n)
            .map(|i| {
                let u = i as f64 * 2.399_963_229_728_653;
                let v = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / n as f64 * 7.0;
                let (offset, value) = match i % 3 {
                    0 => (0.0, 0.0),
                    1 => (-0.05, 0.05),
                    _ => (0.05, -0.05),
                };
                let r = 0.4 + offset;
                let ring = 1.0 + r * v.cos();
                Constraint::new(&[ring * u.cos(), ring * u.sin(), r * v.sin()], value)
            })
            .collect()
    }

    /// A function of `2 n` centres on a torus (symmetric about the origin) with random weights
    /// that meet the side conditions: equal on each symmetric pair, less their mean.
    fn random_torus(n: usize, kernel: Kernel) -> Implicit {
        let half = torus(n);
        let constraints: Vec<Constraint> = half
            .iter()
            .flat_map(|c| {
                let p = c.position();
                [c.clone(), Constraint::new(&[-p[0], -p[1], -p[2]], c.value())]
            })
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut weights: Vec<f64> = (0..n).flat_map(|_| [rng.random::<f64>() - 0.5; 2]).collect();
        let mean = weights.iter().sum::<f64>() / weights.len() as f64;
        weights.iter_mut().for_each(|w| *w -= mean);
        let normalization = crate::rbf::Normalization { translate: vec![0.0; 3], scale: 2.8 };
        Implicit::from_parts(
            "test",
            3,
            kernel,
            constraints,
            normalization,
            weights,
            vec![0.0; 4],
            0.0,
        )
        .unwrap()
    }

    #[test]
    fn the_bunny_is_within_the_bound_for_every_kernel() {
        let constraints = bunny();
        let points = points_around(&constraints, 30_000, 1);
        for kernel in KERNELS {
            let implicit = Implicit::solve(3, kernel, &constraints).unwrap();
            let error = relative_error(&implicit, PARAMS, &points);
            assert!(error < BOUND, "{kernel}: {error:e}");
        }
    }

    #[test]
    fn a_fitted_torus_of_5000_constraints_is_within_the_bound() {
        let constraints = torus(5000);
        let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
        let points = points_around(&constraints, 30_000, 3);
        let error = relative_error(&implicit, PARAMS, &points);
        assert!(error < BOUND, "{error:e}");
    }

    #[test]
    fn twenty_thousand_centres_are_within_the_bound() {
        let implicit = random_torus(10_000, Kernel::ThinPlate);
        let points = points_around(implicit.constraints(), 20_000, 4);
        let error = relative_error(&implicit, PARAMS, &points);
        assert!(error < BOUND, "{error:e}");
    }

    /// Near the bunny's surface the zero crossing moves by less than a hundredth of a voxel of
    /// a 200-voxel grid, and the sign only changes where the exact value is within the bound.
    #[test]
    fn the_surface_stays_within_a_hundredth_of_a_voxel() {
        let constraints = bunny();
        let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
        let voxel = implicit.normalization().scale / 200.0;
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let points: Vec<[f64; 3]> = constraints
            .iter()
            .filter(|c| c.value() == 0.0)
            .flat_map(|c| {
                let p = c.position().to_vec();
                (0..40)
                    .map(|_| std::array::from_fn(|a| p[a] + voxel * (rng.random::<f64>() - 0.5)))
                    .collect::<Vec<[f64; 3]>>()
            })
            .collect();
        let exact = implicit.values3_exact(&points);
        let fast = by_treecode(&implicit, PARAMS, &points);
        let range = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for ((p, e), f) in points.iter().zip(&exact).zip(&fast) {
            let slope = implicit.gradient_at(p).iter().map(|g| g * g).sum::<f64>().sqrt();
            let shift = (e - f).abs() / slope / voxel;
            assert!(shift < 0.01, "{p:?}: the surface moves {shift} voxels");
            if e.abs() > BOUND * range {
                assert_eq!(e.signum(), f.signum(), "{p:?}: {e} vs {f}");
            }
        }
    }

    #[test]
    fn the_result_does_not_depend_on_the_number_of_threads() {
        let implicit = Implicit::solve(3, Kernel::Cubic, &bunny()).unwrap();
        let points = points_around(implicit.constraints(), 20_000, 6);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| by_treecode(&implicit, PARAMS, &points))
        };
        let one = run(1);
        assert!(one.iter().zip(run(3)).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}
