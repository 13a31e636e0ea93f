//! Exact distance from points to a triangle mesh: the closest point of the mesh's surface, the
//! triangle it lies on and its barycentric coordinates, and the distance signed by the
//! voxelizer's inside decision (ray votes, the generalized winding number where they disagree).
//!
//! [`MeshQuery`] holds a bounding volume hierarchy over the triangles, leaves of at most
//! `LEAF` triangles: each node split across the longest axis of its triangles' centroids
//! where the surface area heuristic finds it cheapest (the children's box areas weighted by
//! their triangles, over 16 bins), which makes tighter boxes than the median and so
//! fewer nodes and triangles a query must open. The two subtrees of a node of many triangles
//! are built in parallel, each small subtree from a work list; no split leaves less than a
//! quarter of a node's triangles on one side, so a mesh of millions of triangles neither
//! overflows a stack (the parallel recursion is as deep as the tree) nor makes a deep tree.
//! Queries descend a four-wide hierarchy collapsed from it (as Wald et al. 2008, "Getting rid
//! of packets"): a node holds the boxes of up to four children side by side, measured in one
//! pass, so a descent passes about half the levels, with fewer branches, than through the
//! binary one.
//!
//! # What it guarantees
//! * **Exact:** [`MeshQuery::nearest`] visits every node whose box could hold a closer point
//!   than the best found so far (nearest child first, pruned by the squared distance to the
//!   box), and finds each triangle's closest point with Ericson's region test (*Real-Time
//!   Collision Detection*, 5.1.5). The answer is the brute-force minimum over all triangles up
//!   to rounding, for any finite query point, near the surface or far outside its box.
//! * **Degenerate triangles** (zero area, collinear or repeated corners) are measured as the
//!   segments or point they are, so they never give a wrong or non-finite distance.
//! * **Sign** ([`MeshQuery::signed`]): positive inside, negative outside, in the mesh's
//!   units, like every value of this crate. Inside is decided as the voxelizer decides it at a
//!   voxel centre ([`crate::voxelize`]), over the triangles re-oriented as it re-orients them
//!   (consistently across shared edges, outward), so a flipped or partly flipped mesh has the
//!   same inside as the original: the lines through the point along the three axes (their
//!   triangles listed in a grid across each axis), vote (by the nonzero rule along a line whose entries and exits
//!   balance, by parity along another with an even number of crossings; a line through a hole
//!   abstains); where fewer than two vote or they disagree, the generalized winding number
//!   (Jacobson et al. 2013, evaluated as the voxelizer does) decides: inside where it is at
//!   least 1/2. For a closed mesh that is the true inside; over the holes of an open mesh the
//!   winding number closes it like a soap film.
//! * **Errors:** a mesh with no triangles, an index out of range or a non-finite coordinate is
//!   refused with an [`Error`] naming the problem; no input panics.
//!
//! Users reach it through the distance job (`pipeline::distance`: the exact distance and
//! closest point of each query point) and the exact signed distance volumes and samples.

use std::cmp::Ordering;
use std::sync::OnceLock;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::geometry::{Aabb, DVec3, MORTON_BITS, morton_key};
use crate::mesh::Mesh;
use crate::mesh::inside::Votes;
use crate::mesh::inside::orient::{centre, orient_about};
use crate::mesh::inside::rays::{Projected, Tally, plane_axes};
use crate::mesh::inside::winding::Winding;
use glam::Vec3;

pub mod grid;

/// Most triangles in a leaf of the hierarchy.
pub(crate) const LEAF: usize = 4;

/// Bytes per triangle of a mesh that building a [`MeshQuery`] needs at its peak: the
/// triangles' corners twice (as read from the mesh and in the hierarchy's order), their
/// centroids, boxes and indices while sorting, which way each faces, which are slivers, and
/// the nodes, fewer than `4 / LEAF` a triangle (leaves hold more than `LEAF / 2` triangles
/// each). The four-wide nodes, fewer than `2 / LEAF` a triangle, are made once the sort's
/// entries and the corners as read are freed, and take less than those. Not counted: what the
/// first sign ([`MeshQuery::inside`]) builds: the re-orientation and its tables (those of
/// reading a mesh, [`crate::memory`]), the lines' grids and boxes and the winding number's
/// tree.
pub(crate) const BYTES_PER_TRIANGLE: usize = 2 * size_of::<[DVec3; 3]>()
    + size_of::<Item>()
    + size_of::<u32>()
    + 2 * size_of::<bool>()
    + size_of::<Node>() * 4 / LEAF;

/// The closest point of a mesh's surface to a query point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Nearest {
    /// The (unsigned) distance from the query to `point`, in the mesh's units.
    pub distance: f64,
    /// The closest point of the surface.
    pub point: DVec3,
    /// The index, in the mesh's `triangles`, of a triangle `point` lies on.
    pub triangle: usize,
    /// `point`'s barycentric coordinates on that triangle: the weights of its three corners,
    /// in the order the triangle lists them, each in [0, 1], summing to 1.
    pub barycentric: [f64; 3],
}

/// A node of the hierarchy: its box and either its triangles (a leaf) or its children. The box
/// is stored in f32, rounded outward so that it still holds every triangle under it: the
/// distance to it stays a lower bound of the distance to them, and a node takes 32 bytes,
/// two to a cache line.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// A leaf's first triangle in `MeshQuery::triangles`, or an inner node's first child
    /// (the second follows it).
    first: u32,
    /// A leaf's number of triangles; 0 for an inner node.
    count: u32,
}

impl Node {
    /// A node with the box from `min` to `max`, rounded outward to f32.
    fn new(min: DVec3, max: DVec3) -> Node {
        let [min, max] = rounded_outward(min, max);
        Node { min, max, first: 0, count: 0 }
    }
}

/// The box from `min` to `max` in f32, rounded outward: it holds the original.
fn rounded_outward(min: DVec3, max: DVec3) -> [Vec3; 2] {
    let down = |v: f64| {
        let r = v as f32;
        if f64::from(r) > v { r.next_down() } else { r }
    };
    let up = |v: f64| {
        let r = v as f32;
        if f64::from(r) < v { r.next_up() } else { r }
    };
    [Vec3::from_array(min.to_array().map(down)), Vec3::from_array(max.to_array().map(up))]
}

/// Children of a node of the four-wide hierarchy.
const WIDTH: usize = 4;

/// `first` of an empty child slot.
const EMPTY: u32 = u32::MAX;

/// A node of the four-wide hierarchy that queries descend ([`widen`]): the boxes of up to
/// [`WIDTH`] children side by side, so that one pass measures the four, and each child's
/// triangles or node. An empty slot has an empty box (min +∞, max −∞), never opened.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Wide {
    /// The children's boxes, by axis then child: f32, rounded outward, as a [`Node`]'s.
    min: [[f32; WIDTH]; 3],
    max: [[f32; WIDTH]; 3],
    /// A leaf child's first triangle, an inner child's node, or [`EMPTY`].
    first: [u32; WIDTH],
    /// A leaf child's number of triangles; 0 for an inner child or an empty slot.
    count: [u32; WIDTH],
}

impl Wide {
    /// A node of empty slots.
    const EMPTY: Wide = Wide {
        min: [[f32::INFINITY; WIDTH]; 3],
        max: [[f32::NEG_INFINITY; WIDTH]; 3],
        first: [EMPTY; WIDTH],
        count: [0; WIDTH],
    };

    /// The squared distance from `p` to each child's box (0 inside it, +∞ for an empty slot).
    #[inline]
    fn distances_squared(&self, p: DVec3) -> [f64; WIDTH] {
        let mut d2 = [0.0; WIDTH];
        for axis in 0..3 {
            let x = p[axis];
            for (k, d2) in d2.iter_mut().enumerate() {
                let below = f64::from(self.min[axis][k]) - x;
                let above = x - f64::from(self.max[axis][k]);
                let outside = below.max(above).max(0.0);
                *d2 += outside * outside;
            }
        }
        d2
    }
}

/// The slots of a four-wide node in the order of `d2`, farthest first (a sorting network:
/// no branches to mispredict).
#[inline]
fn farthest_first(d2: &[f64; WIDTH]) -> [usize; WIDTH] {
    let mut order = [0, 1, 2, 3];
    let mut swap = |i: usize, j: usize| {
        if d2[order[i]] < d2[order[j]] {
            order.swap(i, j);
        }
    };
    swap(0, 1);
    swap(2, 3);
    swap(0, 2);
    swap(1, 3);
    swap(1, 2);
    order
}

/// The four-wide hierarchy of the binary one `binary` (its root first, as [`hierarchy`] makes
/// it): each wide node holds the children of a binary node, with the inner child of the
/// largest box replaced by its own two children while there are fewer than [`WIDTH`] (the
/// collapse of Wald et al. 2008, "Getting rid of packets"). The leaves and the triangles'
/// order are the binary hierarchy's; a root that is a leaf becomes a wide root's one child.
/// Each wide node stands for a different inner binary node, so there are fewer of them than
/// `2 / LEAF` a triangle.
fn widen(binary: &[Node]) -> Vec<Wide> {
    let mut wide = vec![Wide::EMPTY];
    // Binary nodes whose children a wide node still has to take, and that wide node.
    let mut pending = vec![(0, 0)];
    while let Some((n, w)) = pending.pop() {
        for (k, c) in collapsed(binary, n).into_iter().enumerate() {
            let node = binary[c];
            for axis in 0..3 {
                wide[w].min[axis][k] = node.min[axis];
                wide[w].max[axis][k] = node.max[axis];
            }
            if node.count > 0 {
                (wide[w].first[k], wide[w].count[k]) = (node.first, node.count);
            } else {
                wide[w].first[k] = wide.len() as u32;
                pending.push((c, wide.len()));
                wide.push(Wide::EMPTY);
            }
        }
    }
    wide
}

/// The children of binary node `n` in a wide node: its own two, each inner one of the largest
/// box replaced by its two while there are fewer than [`WIDTH`]; `n` itself for a leaf.
fn collapsed(binary: &[Node], n: usize) -> Vec<usize> {
    if binary[n].count > 0 {
        return vec![n];
    }
    let children = |c: usize| [binary[c].first as usize, binary[c].first as usize + 1];
    let mut taken = children(n).to_vec();
    while taken.len() < WIDTH {
        let extent = |c: usize| (binary[c].max - binary[c].min).as_dvec3();
        let inner = taken.iter().enumerate().filter(|&(_, &c)| binary[c].count == 0);
        let Some((k, _)) = inner.max_by(|a, b| area(extent(*a.1)).total_cmp(&area(extent(*b.1))))
        else {
            break;
        };
        let c = taken.swap_remove(k);
        taken.extend(children(c));
    }
    taken
}

/// A triangle mesh prepared for exact distance queries.
#[derive(Debug, Clone)]
pub struct MeshQuery {
    /// The four-wide hierarchy that queries descend, its root first ([`widen`]).
    nodes: Vec<Wide>,
    /// The box of all the triangles (f32, rounded outward, as a [`Node`]'s).
    bounds: [DVec3; 2],
    /// The triangles' corners, in the hierarchy's order.
    triangles: Vec<[DVec3; 3]>,
    /// The index in the mesh of each of `triangles`.
    indices: Vec<u32>,
    /// Whether each of `triangles` is a sliver (see [`closest_on_triangle`]).
    slivers: Vec<bool>,
    /// The mean of the mesh's vertices, about which the re-orientation measures its volume.
    centre: DVec3,
    /// Whether each of `triangles` faces against the orientation the voxelizer gives the mesh
    /// (consistent across edges, outward: see [`crate::voxelize`]), for the sign: found when a
    /// sign is first asked for ([`MeshQuery::flipped`]), so that unsigned queries skip it.
    flipped: OnceLock<Vec<bool>>,
}

impl MeshQuery {
    /// Builds the hierarchy over `mesh`'s triangles.
    ///
    /// Refuses a mesh with no triangles, a vertex index out of range, a non-finite coordinate
    /// of a vertex some triangle uses, or more triangles than fit in 32 bits.
    pub fn new(mesh: &Mesh) -> Result<MeshQuery> {
        let context = "mesh";
        if mesh.triangles.is_empty() {
            return Err(Error::invalid(context, "no triangles to measure a distance to"));
        }
        // The sign's planes list up to 8 entries a triangle, indexed in 32 bits.
        if mesh.triangles.len() > u32::MAX as usize / PLANE_ENTRIES_PER_TRIANGLE as usize {
            return Err(Error::invalid(
                context,
                format!("{} triangles, more than a distance query can index", mesh.triangles.len()),
            ));
        }
        let mut triangles = Vec::with_capacity(mesh.triangles.len());
        for (t, corners) in mesh.triangles.iter().enumerate() {
            let mut points = [DVec3::ZERO; 3];
            for (point, &i) in points.iter_mut().zip(corners) {
                let Some(&v) = mesh.vertices.get(i as usize) else {
                    return Err(Error::invalid(
                        context,
                        format!(
                            "triangle {t} uses vertex {i}, out of range for {} vertices",
                            mesh.vertices.len()
                        ),
                    ));
                };
                if !v.is_finite() {
                    return Err(Error::invalid(
                        context,
                        format!("vertex {i} (of triangle {t}) has a non-finite coordinate: {v}"),
                    ));
                }
                *point = v;
            }
            triangles.push(points);
        }
        Ok(MeshQuery::build(triangles, centre(&mesh.vertices)))
    }

    /// The hierarchy over `triangles` (at least one), with the triangles in its order;
    /// `centre`: the mean of the mesh's vertices.
    fn build(corners: Vec<[DVec3; 3]>, centre: DVec3) -> MeshQuery {
        let (binary, indices) = hierarchy(&corners, LEAF);
        let triangles: Vec<_> = indices.par_iter().map(|&t| corners[t as usize]).collect();
        drop(corners);
        let slivers = triangles.par_iter().map(is_sliver).collect();
        let bounds = [binary[0].min.as_dvec3(), binary[0].max.as_dvec3()];
        let nodes = widen(&binary);
        MeshQuery { nodes, bounds, triangles, indices, slivers, centre, flipped: OnceLock::new() }
    }

    /// Which triangles (in the hierarchy's order) the voxelizer's re-orientation flips,
    /// found the first time it is asked: the mesh is rebuilt from the corners, in its order,
    /// each triangle with corners of its own, which the re-orientation welds where they
    /// coincide as it welds the mesh's vertices, and re-oriented about the mesh's centre, as
    /// [`crate::voxelize`] re-orients the mesh.
    fn flipped(&self) -> &[bool] {
        self.flipped.get_or_init(|| {
            let mut corners = vec![DVec3::ZERO; 3 * self.len()];
            for (&t, triangle) in self.indices.iter().zip(&self.triangles) {
                let t = 3 * t as usize;
                corners[t..t + 3].copy_from_slice(triangle);
            }
            let own: Vec<[u32; 3]> =
                (0..self.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
            let oriented = orient_about(&corners, &own, self.centre).triangles;
            self.indices.iter().map(|&t| oriented[t as usize] != own[t as usize]).collect()
        })
    }

    /// The triangles' corners in the hierarchy's order: a leaf's triangles side by side, and
    /// neighbouring leaves near each other.
    pub(crate) fn triangles(&self) -> &[[DVec3; 3]] {
        &self.triangles
    }

    /// The number of triangles.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// Always false: a [`MeshQuery`] has at least one triangle.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The closest point of the surface to `p`, exactly (see the module doc). A non-finite
    /// `p` gives a NaN distance.
    pub fn nearest(&self, p: DVec3) -> Nearest {
        self.answer(p, self.search(p, self.seed(p, 0)))
    }

    /// [`MeshQuery::nearest`] of each point, in parallel. The points are taken in the
    /// order of a space-filling curve (Morton order over their box), in runs of `RUN`, and
    /// each search starts from the triangle nearest to the point before it in its run: a
    /// candidate at most the two points' distance apart from the answer, so the descent prunes
    /// from its first node. The distances are those of [`MeshQuery::nearest`]: the start
    /// only changes which boxes are opened (where two triangles are equally near, either may
    /// be named).
    pub fn nearest_all(&self, points: &[DVec3]) -> Vec<Nearest> {
        self.search_all(points, |i, found| self.answer(points[i], found))
    }

    /// The distance of each point to the surface: [`MeshQuery::nearest_all`]'s distances,
    /// without the closest points.
    pub fn distances(&self, points: &[DVec3]) -> Vec<f64> {
        self.search_all(points, |_, (d2, _)| d2.sqrt())
    }

    /// `answer(i, found)` of each point `i` and what [`MeshQuery::search`] found for it,
    /// the points searched as [`MeshQuery::nearest_all`] says, each from the answer before.
    fn search_all<T: Send + Sync + Copy + Default>(
        &self,
        points: &[DVec3],
        answer: impl Fn(usize, (f64, usize)) -> T + Sync + Send,
    ) -> Vec<T> {
        along_curve(points, |run, answers| {
            let mut start = 0;
            for (&i, answered) in run.iter().zip(answers) {
                let found = self.search(points[i], self.seed(points[i], start));
                start = found.1;
                *answered = answer(i, found);
            }
        })
    }

    /// The squared distance from `p` to triangle `t` (in the hierarchy's order) and `t`: a
    /// start for [`MeshQuery::search`].
    #[inline]
    fn seed(&self, p: DVec3, t: usize) -> (f64, usize) {
        (p.distance_squared(self.closest(p, t).0), t)
    }

    /// The closest point of triangle `t` (in the hierarchy's order) to `p` and its barycentric
    /// coordinates.
    #[inline]
    fn closest(&self, p: DVec3, t: usize) -> (DVec3, [f64; 3]) {
        closest_on(p, &self.triangles[t], self.slivers[t])
    }

    /// The nearest triangle to `p` (in the hierarchy's order) and its squared distance, or
    /// `best` when none is nearer: every node whose box could hold a nearer point than the
    /// best so far is visited, nearer child first. `best` is a triangle's squared distance
    /// (the answer is then exact whatever the triangle) or a bound with no triangle
    /// (`usize::MAX`), returned as it is when nothing is nearer.
    fn search(&self, p: DVec3, mut best: (f64, usize)) -> (f64, usize) {
        // Each entry: a child's `first` and `count` and its box's squared distance, computed
        // once when it was pushed; the root's node first. A level leaves at most three
        // entries on the stack (see `WIDE_DEPTH`).
        let mut stack = [(0u32, 0u32, 0.0f64); WIDE_DEPTH];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (first, count, d2) = stack[top];
            // Pruned unless nearer than the best (so everything is, for a NaN query).
            if d2.partial_cmp(&best.0) != Some(Ordering::Less) {
                continue;
            }
            let first = first as usize;
            if count > 0 {
                for t in first..first + count as usize {
                    // The triangle's own box first: a cheaper lower bound than its distance.
                    if corner_box_distance_squared(p, &self.triangles[t]) >= best.0 {
                        continue;
                    }
                    let d2 = p.distance_squared(self.closest(p, t).0);
                    if d2 < best.0 {
                        best = (d2, t);
                    }
                }
                continue;
            }
            let node = &self.nodes[first];
            let d2 = node.distances_squared(p);
            // The children nearer than the best, the nearest pushed last so visited first.
            for k in farthest_first(&d2) {
                if d2[k] < best.0 {
                    stack[top] = (node.first[k], node.count[k], d2[k]);
                    top += 1;
                }
            }
        }
        best
    }

    /// Calls `found` with every triangle (in the hierarchy's order) whose squared distance to
    /// `p` is at most `radius2`, that squared distance and its closest point to `p`.
    fn within(&self, p: DVec3, radius2: f64, mut found: impl FnMut(usize, f64, DVec3)) {
        let mut stack = [(0u32, 0u32); WIDE_DEPTH];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (first, count) = stack[top];
            let first = first as usize;
            if count > 0 {
                for t in first..first + count as usize {
                    let (point, _) = self.closest(p, t);
                    let d2 = p.distance_squared(point);
                    if d2 <= radius2 {
                        found(t, d2, point);
                    }
                }
                continue;
            }
            let node = &self.nodes[first];
            let d2 = node.distances_squared(p);
            for ((&d2, &first), &count) in d2.iter().zip(&node.first).zip(&node.count) {
                if d2 <= radius2 && first != EMPTY {
                    stack[top] = (first, count);
                    top += 1;
                }
            }
        }
    }

    /// What [`MeshQuery::search`] found for `p`, in the mesh's terms.
    fn answer(&self, p: DVec3, (d2, t): (f64, usize)) -> Nearest {
        let (point, barycentric) = self.closest(p, t);
        Nearest { distance: d2.sqrt(), point, triangle: self.indices[t] as usize, barycentric }
    }

    /// The distance of each point to the surface, positive inside and negative outside, inside
    /// as [`MeshQuery::inside`] decides it (see the module doc). Each point's distance and
    /// side are found together, along one curve.
    pub fn signed(&self, points: &[DVec3]) -> Vec<f64> {
        let sign = Sign::new(self);
        self.search_all(points, |i, (d2, _)| signed(d2.sqrt(), sign.inside(points[i])))
    }

    /// Whether each point is inside, as [`MeshQuery::signed`] signs it (see the module doc):
    /// the verdict of the rays through it along the three axes where at least two vote and all
    /// agree, else whether the generalized winding number is at least 1/2. The winding number's
    /// tree is built for the call, only if some point needs it. The points are taken along the
    /// same curve as [`MeshQuery::nearest_all`], so that neighbouring queries read the same
    /// nodes.
    pub fn inside(&self, points: &[DVec3]) -> Vec<bool> {
        let sign = Sign::new(self);
        along_curve(points, |run, answers| {
            for (&i, answered) in run.iter().zip(answers) {
                *answered = sign.inside(points[i]);
            }
        })
    }

    /// The winding number's tree over the triangles (in the hierarchy's order: the sum does
    /// not depend on it), and the frame it is built in: the triangles moved and scaled so that
    /// the longest side of their box is [`WINDING_FRAME`] long, as a voxelizer's grid would
    /// place them (the tree rounds centroids to 1/1024 of a unit of that frame, and the winding
    /// number does not change under moves and scales).
    fn winding(&self) -> (Winding, Frame) {
        let frame = Frame::around(self.bounds);
        let oriented = (0..self.len()).map(|t| self.oriented(t).map(|p| frame.to_grid(p)));
        (Winding::new(oriented.collect()), frame)
    }

    /// The corners of triangle `t` (in the hierarchy's order), re-oriented as the voxelizer
    /// re-orients them.
    fn oriented(&self, t: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[t];
        if self.flipped()[t] { [a, c, b] } else { [a, b, c] }
    }
}

/// Bins along an axis over which [`hierarchy`] weighs its splits.
const BINS: usize = 16;

/// The fewest triangles a split leaves on either side, as a fraction of its node's: with fewer
/// than 2^31 triangles, a hierarchy is at most log(2^31) / log(4/3) < 75 levels deep.
const SIDE: f64 = 0.25;

/// More levels than a hierarchy has (see [`SIDE`]).
const DEPTH: usize = 128;

/// The stack of a descent through the four-wide hierarchy: each level leaves at most
/// `WIDTH - 1` children on the stack, and it has no more levels than the binary one.
const WIDE_DEPTH: usize = (WIDTH - 1) * DEPTH + 1;

/// Half the surface area of a box of sides `extent`: the measure of the surface area heuristic.
fn area(extent: DVec3) -> f64 {
    extent.x * extent.y + extent.y * extent.z + extent.z * extent.x
}

/// A triangle as [`hierarchy`] sorts it: its centroid (the key its splits compare), the box of
/// its corners (rounded outward, as the nodes' boxes are), and its index, in f32 (40 bytes, so
/// that a node's passes read half as much); kept together so that a pass reads them in order.
#[derive(Debug, Clone, Copy)]
struct Item {
    centroid: Vec3,
    min: Vec3,
    max: Vec3,
    t: u32,
}

/// Triangles from which a node's two subtrees are built in parallel.
const PARALLEL: usize = 1 << 14;

/// A bounding volume hierarchy over `triangles` (at least one): each node split across the
/// longest axis of its triangles' centroids, at the boundary between [`BINS`] equal bins of
/// that axis where the children's boxes' [`area`] times their triangles sums least (the
/// surface area heuristic), among the boundaries that leave at least [`SIDE`] of the triangles
/// on each side, or else at the median; leaves of at most `leaf` triangles. The subtrees of
/// nodes of at least [`PARALLEL`] triangles are built in parallel; the hierarchy is the same
/// whatever the number of threads. The nodes (the root first, an inner node's children
/// side by side), and the triangles' indices in the hierarchy's order (a leaf's `first` and
/// `count` are a range of it).
///
/// A node split at a bin boundary takes its children's [`Bounds`] from its bins (unions of
/// minima and maxima, the same numbers a pass over the children's triangles finds), so each
/// level of the hierarchy reads its triangles twice (binning, then partitioning), not three
/// times.
fn hierarchy(triangles: &[[DVec3; 3]], leaf: usize) -> (Vec<Node>, Vec<u32>) {
    let mut items: Vec<Item> = (0..triangles.len() as u32)
        .into_par_iter()
        .map(|t| {
            let corners = &triangles[t as usize];
            let (min, max) = corner_box(corners);
            let [min, max] = rounded_outward(min, max);
            let centroid = ((corners[0] + corners[1] + corners[2]) / 3.0).as_vec3();
            Item { centroid, min, max, t }
        })
        .collect();
    let bounds = items.par_iter().map(Bounds::of).reduce(Bounds::empty, Bounds::union);
    let nodes = subtree(&mut items, bounds, 0, leaf);
    (nodes, items.iter().map(|item| item.t).collect())
}

/// The box of a run of [`Item`]s and the box of their centroids.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    min: Vec3,
    max: Vec3,
    /// The centroids' least and greatest coordinates.
    low: Vec3,
    high: Vec3,
}

impl Bounds {
    /// The bounds of no item: every union with it is the other.
    fn empty() -> Bounds {
        let (inf, neg) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        Bounds { min: inf, max: neg, low: inf, high: neg }
    }

    /// The bounds of one item.
    fn of(item: &Item) -> Bounds {
        Bounds { min: item.min, max: item.max, low: item.centroid, high: item.centroid }
    }

    /// The bounds of the items of both.
    fn union(self, other: Bounds) -> Bounds {
        Bounds {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
            low: self.low.min(other.low),
            high: self.high.max(other.high),
        }
    }

    /// The bounds of `items`, by a pass over them.
    fn over(items: &[Item]) -> Bounds {
        items.iter().map(Bounds::of).fold(Bounds::empty(), Bounds::union)
    }
}

/// The nodes of the hierarchy over `items` (of bounds `bounds`), which start at `start` in the
/// hierarchy's order, its root first: the two halves of a large node built in parallel, then
/// put side by side.
fn subtree(items: &mut [Item], bounds: Bounds, start: usize, leaf: usize) -> Vec<Node> {
    if items.len() < PARALLEL {
        return sequential_subtree(items, bounds, start, leaf);
    }
    let (root, children) = split(items, bounds, leaf);
    let (middle, below_bounds, above_bounds) =
        children.expect("a node of PARALLEL triangles is split");
    let (below, above) = items.split_at_mut(middle);
    let (left, right) = rayon::join(
        || subtree(below, below_bounds, start, leaf),
        || subtree(above, above_bounds, start + middle, leaf),
    );
    side_by_side(root, left, right)
}

/// The hierarchy of `root` over the subtrees `left` and `right` (each its root first): the
/// root, the two children, then the rest of the left subtree and of the right one, with the
/// children's indices of inner nodes moved accordingly.
fn side_by_side(root: Node, left: Vec<Node>, right: Vec<Node>) -> Vec<Node> {
    // Left's node i (from 1) goes to i + 2, right's to left.len() + 1 + i.
    let moved = |node: Node, shift: usize| match node.count {
        0 => Node { first: node.first + shift as u32, ..node },
        _ => node,
    };
    let (l, r) = (2, left.len() + 1);
    let mut nodes = Vec::with_capacity(1 + left.len() + right.len());
    nodes.extend([Node { first: 1, count: 0, ..root }, moved(left[0], l), moved(right[0], r)]);
    nodes.extend(left[1..].iter().map(|&n| moved(n, l)));
    nodes.extend(right[1..].iter().map(|&n| moved(n, r)));
    nodes
}

/// [`subtree`] on one thread, from a work list.
fn sequential_subtree(items: &mut [Item], bounds: Bounds, start: usize, leaf: usize) -> Vec<Node> {
    let mut nodes = Vec::with_capacity(4 * items.len() / leaf + 1);
    nodes.push(Node::new(DVec3::ZERO, DVec3::ZERO));
    // (node, range of `items`, their bounds) still to fill in.
    let mut work = vec![(0usize, 0usize, items.len(), bounds)];
    while let Some((n, from, to, bounds)) = work.pop() {
        let (node, children) = split(&mut items[from..to], bounds, leaf);
        nodes[n] = node;
        let Some((middle, below, above)) = children else {
            (nodes[n].first, nodes[n].count) = ((start + from) as u32, (to - from) as u32);
            continue;
        };
        let child = nodes.len();
        nodes[n].first = child as u32;
        nodes.extend([node, node]);
        work.push((child, from, from + middle, below));
        work.push((child + 1, from + middle, to, above));
    }
    nodes
}

/// The node over `part`, whose bounds are `bounds` (its box; no children yet), and, unless it
/// is a leaf of at most `leaf` triangles, `part` reordered so that its first child's triangles
/// come first, how many, and the two children's bounds.
fn split(
    part: &mut [Item],
    bounds: Bounds,
    leaf: usize,
) -> (Node, Option<(usize, Bounds, Bounds)>) {
    let Bounds { min, max, low, high } = bounds;
    let node = Node { min, max, first: 0, count: 0 };
    if part.len() <= leaf {
        return (node, None);
    }
    let axis = (high - low).max_position();
    let children = Bins::split(part, axis, (low[axis], high[axis])).unwrap_or_else(|| {
        let middle = part.len() / 2;
        part.select_nth_unstable_by(middle, |a, b| {
            a.centroid[axis].total_cmp(&b.centroid[axis]).then(a.t.cmp(&b.t))
        });
        (middle, Bounds::over(&part[..middle]), Bounds::over(&part[middle..]))
    });
    (node, Some(children))
}

/// The bins of [`hierarchy`]'s split: each one's bounds and number of triangles.
struct Bins {
    boxes: [(Bounds, usize); BINS],
}

impl Bins {
    /// Splits `part` across `axis`, whose centroids span `range`, at the cheapest boundary
    /// between bins: the triangles of the bins below it first. The number below and the bounds
    /// of each side, or `None` (`part` untouched) when no boundary leaves enough on each side.
    fn split(
        part: &mut [Item],
        axis: usize,
        (low, high): (f32, f32),
    ) -> Option<(usize, Bounds, Bounds)> {
        let width = high - low;
        // Also none for a NaN width.
        if width.partial_cmp(&0.0) != Some(Ordering::Greater) {
            return None;
        }
        let scale = BINS as f32 / width;
        let bin = |key: Vec3| (((key[axis] - low) * scale) as usize).min(BINS - 1);
        let mut bins = Bins { boxes: [(Bounds::empty(), 0); BINS] };
        for item in part.iter() {
            let slot = &mut bins.boxes[bin(item.centroid)];
            *slot = (slot.0.union(Bounds::of(item)), slot.1 + 1);
        }
        let boundary = bins.cheapest()?;
        let mut below = 0;
        for i in 0..part.len() {
            if bin(part[i].centroid) < boundary {
                part.swap(i, below);
                below += 1;
            }
        }
        let side = |range: std::ops::Range<usize>| {
            bins.boxes[range].iter().fold(Bounds::empty(), |acc, b| acc.union(b.0))
        };
        Some((below, side(0..boundary), side(boundary..BINS)))
    }

    /// The boundary (1 to `BINS - 1`, the first bin above it) whose two sides' measures
    /// times their triangles sum least, among those with at least [`SIDE`] of the triangles on
    /// each side.
    fn cheapest(&self) -> Option<usize> {
        let total: usize = self.boxes.iter().map(|b| b.1).sum();
        let fewest = ((SIDE * total as f64).ceil() as usize).max(1);
        let grow = |acc: (Vec3, Vec3, usize), b: &(Bounds, usize)| {
            (acc.0.min(b.0.min), acc.1.max(b.0.max), acc.2 + b.1)
        };
        let cost = |(a, b, n): (Vec3, Vec3, usize)| area((b - a).as_dvec3()) * n as f64;
        let empty = (Vec3::INFINITY, Vec3::NEG_INFINITY, 0);
        let mut above = [0.0; BINS];
        let mut counts = [0; BINS];
        let mut acc = empty;
        for i in (1..BINS).rev() {
            acc = grow(acc, &self.boxes[i]);
            (above[i], counts[i]) = (cost(acc), acc.2);
        }
        let mut acc = empty;
        let mut best: Option<(f64, usize)> = None;
        for i in 1..BINS {
            acc = grow(acc, &self.boxes[i - 1]);
            if acc.2 < fewest || counts[i] < fewest {
                continue;
            }
            let total = cost(acc) + above[i];
            if best.is_none_or(|(least, _)| total < least) {
                best = Some((total, i));
            }
        }
        best.map(|(_, boundary)| boundary)
    }
}

/// The box of a triangle's corners.
fn corner_box([a, b, c]: &[DVec3; 3]) -> (DVec3, DVec3) {
    (a.min(*b).min(*c), a.max(*b).max(*c))
}

/// The squared distance from `p` to the box of a triangle's corners: a lower bound of its
/// squared distance to the triangle.
#[inline]
fn corner_box_distance_squared(p: DVec3, corners: &[DVec3; 3]) -> f64 {
    let (min, max) = corner_box(corners);
    (min - p).max(p - max).max(DVec3::ZERO).length_squared()
}

/// The most cells a triangle's projection covers on average in a [`Plane`]: the grid is made
/// coarser until its lists hold at most this many entries a triangle.
const PLANE_ENTRIES_PER_TRIANGLE: u64 = 8;

/// The triangles for the lines along each axis: the triangles re-oriented, in the hierarchy's
/// order, and for each axis a [`Plane`], a uniform grid across the axis listing the triangles
/// whose projected box covers each cell, so that a line finds its triangles in one cell.
struct Lines {
    triangles: Vec<[DVec3; 3]>,
    /// Each triangle's box, f32, rounded outward: a line outside it misses the triangle,
    /// found from a third of the bytes of its corners.
    boxes: Vec<[Vec3; 2]>,
    planes: [Plane; 3],
}

impl Lines {
    /// The three planes over `query`'s triangles, built in parallel.
    fn new(query: &MeshQuery) -> Lines {
        let triangles: Vec<[DVec3; 3]> = (0..query.len()).map(|t| query.oriented(t)).collect();
        let [low, high] = query.bounds;
        let plane = |axis| Plane::new(&triangles, axis, low, high);
        let (x, (y, z)) = rayon::join(|| plane(0), || rayon::join(|| plane(1), || plane(2)));
        let boxes = triangles
            .iter()
            .map(|t| {
                let (min, max) = corner_box(t);
                rounded_outward(min, max)
            })
            .collect();
        Lines { triangles, boxes, planes: [x, y, z] }
    }

    /// The votes at `p` of the rays through it along the three axes.
    fn votes(&self, p: DVec3) -> Votes {
        let mut votes = Votes::default();
        for (axis, plane) in self.planes.iter().enumerate() {
            votes.add(self.ray(plane, p, axis).vote());
        }
        votes
    }

    /// The crossings of the line through `p` along `axis` with the re-oriented triangles,
    /// counted against `p`: the triangles listed in the line's cell of `plane` are crossed as
    /// the voxelizer crosses them (shared edges and corners count once).
    fn ray(&self, plane: &Plane, p: DVec3, axis: usize) -> Tally {
        let (u, v) = plane_axes(axis);
        let q = [p[u], p[v]];
        let mut tally = Tally::default();
        for &t in plane.listed(q) {
            // Wholly to one side of the line (a tie is left to the crossing test).
            let [min, max] = self.boxes[t as usize];
            let aside = |k: usize, x: f64| (f64::from(max[k]) < x) | (f64::from(min[k]) > x);
            if aside(u, q[0]) | aside(v, q[1]) {
                continue;
            }
            let corners = &self.triangles[t as usize];
            if let Some((depth, enter)) = Projected::new(corners, axis).cross(q) {
                tally.add(depth, enter, p[axis]);
            }
        }
        tally
    }
}

/// A uniform grid of square cells over the plane across one axis, each cell listing the
/// triangles whose projected box (closed) meets it. A point's cell is found by the same
/// monotone rounding as a box's cells, so every triangle whose box holds the point is listed
/// in its cell, points outside the grid falling into its border cells.
struct Plane {
    /// The axes of the plane: (u, v) of [`plane_axes`].
    axes: (usize, usize),
    /// The (u, v) corner of the grid.
    origin: [f64; 2],
    /// Cells per unit of length (0 for a grid of one cell).
    scale: f64,
    /// Cells along u and v.
    dims: [usize; 2],
    /// Where each cell's list starts in `listed`, row after row along u, and where the last
    /// one ends.
    starts: Vec<u32>,
    /// The triangles of each cell, in their order.
    listed: Vec<u32>,
}

impl Plane {
    /// The plane across `axis` over `triangles`, whose box is `low` to `high`: about as many
    /// cells as triangles, made coarser until the lists hold at most
    /// [`PLANE_ENTRIES_PER_TRIANGLE`] entries a triangle.
    fn new(triangles: &[[DVec3; 3]], axis: usize, low: DVec3, high: DVec3) -> Plane {
        let (u, v) = plane_axes(axis);
        let longest = (high[u] - low[u]).max(high[v] - low[v]);
        let budget = PLANE_ENTRIES_PER_TRIANGLE * triangles.len() as u64;
        let mut across = (triangles.len() as f64).sqrt().ceil().clamp(1.0, 4096.0);
        loop {
            let scale = across / longest;
            let mut plane = Plane {
                axes: (u, v),
                origin: [low[u], low[v]],
                scale: if scale.is_finite() { scale } else { 0.0 },
                dims: [usize::MAX; 2],
                starts: Vec::new(),
                listed: Vec::new(),
            };
            plane.dims = [plane.cell(0, high[u]) + 1, plane.cell(1, high[v]) + 1];
            let covered = |t: &[DVec3; 3]| {
                let [a, b] = plane.cells(t);
                ((b[0] - a[0] + 1) * (b[1] - a[1] + 1)) as u64
            };
            if across <= 1.0 || triangles.iter().map(covered).sum::<u64>() <= budget {
                plane.fill(triangles);
                return plane;
            }
            across = (across / 2.0).floor();
        }
    }

    /// The cell along `k` (0 for u, 1 for v) of coordinate `x`: rounded down, within the grid
    /// (`as` saturates: below the origin, and NaN, is cell 0).
    #[inline]
    fn cell(&self, k: usize, x: f64) -> usize {
        (((x - self.origin[k]) * self.scale) as usize).min(self.dims[k] - 1)
    }

    /// The first and last cells (u, v) of the projected box of `triangle`.
    fn cells(&self, triangle: &[DVec3; 3]) -> [[usize; 2]; 2] {
        let (min, max) = corner_box(triangle);
        let (u, v) = self.axes;
        [[self.cell(0, min[u]), self.cell(1, min[v])], [self.cell(0, max[u]), self.cell(1, max[v])]]
    }

    /// Calls `visit` with each cell (its index, row after row) that `triangle` covers.
    fn each_cell(&self, triangle: &[DVec3; 3], mut visit: impl FnMut(usize)) {
        let [a, b] = self.cells(triangle);
        for j in a[1]..=b[1] {
            for i in a[0]..=b[0] {
                visit(j * self.dims[0] + i);
            }
        }
    }

    /// Lists every triangle in the cells its projected box meets: counted, then placed.
    fn fill(&mut self, triangles: &[[DVec3; 3]]) {
        let mut starts = vec![0u32; self.dims[0] * self.dims[1] + 1];
        for triangle in triangles {
            self.each_cell(triangle, |cell| starts[cell + 1] += 1);
        }
        for c in 1..starts.len() {
            starts[c] += starts[c - 1];
        }
        let mut listed = vec![0u32; starts[starts.len() - 1] as usize];
        let mut next = starts.clone();
        for (t, triangle) in (0u32..).zip(triangles) {
            self.each_cell(triangle, |cell| {
                listed[next[cell] as usize] = t;
                next[cell] += 1;
            });
        }
        (self.starts, self.listed) = (starts, listed);
    }

    /// The triangles listed in the cell of the point `q` (u, v).
    #[inline]
    fn listed(&self, q: [f64; 2]) -> &[u32] {
        let cell = self.cell(1, q[1]) * self.dims[0] + self.cell(0, q[0]);
        &self.listed[self.starts[cell] as usize..self.starts[cell + 1] as usize]
    }
}

/// The voxelizer's inside decision at any point (see [`MeshQuery::inside`]): the lines
/// along the three axes, and the winding number's tree, built the first time the lines
/// disagree.
struct Sign<'a> {
    query: &'a MeshQuery,
    lines: Lines,
    winding: OnceLock<(Winding, Frame)>,
}

impl Sign<'_> {
    /// The lines over `query`'s triangles, re-oriented.
    fn new(query: &MeshQuery) -> Sign<'_> {
        // Found before the lines, so that the two do not hold memory at once.
        query.flipped();
        Sign { query, lines: Lines::new(query), winding: OnceLock::new() }
    }

    /// Whether `p` is inside: outside at once where `p` lies beyond the triangles' box
    /// ([`Sign::beyond`]), else as [`Sign::decided`] decides.
    fn inside(&self, p: DVec3) -> bool {
        !self.beyond(p) && self.decided(p)
    }

    /// The lines' verdict at `p`, or the winding number's where they give none.
    fn decided(&self, p: DVec3) -> bool {
        self.lines.votes(p).verdict().unwrap_or_else(|| {
            let (winding, frame) = self.winding.get_or_init(|| self.query.winding());
            winding.at(frame.to_grid(p)) >= 0.5
        })
    }

    /// Whether `p` lies beyond the triangles' box along some axis, by more than rounding can
    /// move a crossing ([`BEYOND`] of the box's longest side): then the lines decide
    /// outside. The two lines across that axis meet no triangle (two outside votes), and every
    /// crossing of the line along it lies on one side of `p` (an outside vote, or none where
    /// the count is odd).
    fn beyond(&self, p: DVec3) -> bool {
        let [min, max] = self.query.bounds;
        let margin = BEYOND * (max - min).max_element();
        (p - max).max(min - p).max_element() > margin
    }
}

/// The margin of [`Sign::beyond`], as a fraction of the box's longest side: far above the
/// rounding of a crossing's depth (a few units in the last place).
const BEYOND: f64 = 1e-9;

/// The side, in units of the winding number's frame, of the mesh's box's longest side.
const WINDING_FRAME: f64 = 1024.0;

/// A move and uniform scale of the mesh's units.
#[derive(Debug, Clone, Copy)]
struct Frame {
    origin: DVec3,
    scale: f64,
}

impl Frame {
    /// The frame in which the box from `min` to `max` starts at the origin and its longest
    /// side is [`WINDING_FRAME`] long (scale 1 for a box of no size).
    fn around([min, max]: [DVec3; 2]) -> Frame {
        let longest = (max - min).max_element();
        let scale =
            if longest > 0.0 && longest.is_finite() { WINDING_FRAME / longest } else { 1.0 };
        Frame { origin: min, scale }
    }

    fn to_grid(self, p: DVec3) -> DVec3 {
        (p - self.origin) * self.scale
    }
}

/// Queries that [`MeshQuery::nearest_all`] answers one after another, each searched from the
/// answer before it (and that [`MeshQuery::inside`] answers in the same order).
pub(crate) const RUN: usize = 64;

/// The answers for `points`, in their order: `answer(run, answers)` fills the answers of a
/// run of [`RUN`] consecutive points along a Morton curve over their box (their indices), the
/// runs in parallel.
fn along_curve<T: Send + Sync + Copy + Default>(
    points: &[DVec3],
    answer: impl Fn(&[usize], &mut [T]) + Sync + Send,
) -> Vec<T> {
    let order = curve_order(points);
    let mut along = vec![T::default(); points.len()];
    along.par_chunks_mut(RUN).zip(order.par_chunks(RUN)).for_each(|(answers, run)| {
        answer(run, answers);
    });
    let mut answers = vec![T::default(); points.len()];
    for (&i, &answered) in order.iter().zip(&along) {
        answers[i] = answered;
    }
    answers
}

/// The indices of `points` along a Morton curve over their box (non-finite points first).
fn curve_order(points: &[DVec3]) -> Vec<usize> {
    let finite = points.iter().filter(|p| p.is_finite());
    let Some(bounds) = Aabb::of_points(finite) else {
        return (0..points.len()).collect();
    };
    let cells = ((1u64 << MORTON_BITS) - 1) as f64;
    let scale = bounds.size().recip().map(|s| if s.is_finite() { s * cells } else { 0.0 });
    let mut keyed: Vec<(u64, usize)> = points
        .par_iter()
        .zip(0..points.len())
        .map(|(&p, i)| {
            let q = ((p - bounds.min) * scale).to_array().map(|c| c as u64);
            (if p.is_finite() { morton_key(q) + 1 } else { 0 }, i)
        })
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// `distance` with the sign of the crate: positive inside, negative outside.
pub fn signed(distance: f64, inside: bool) -> f64 {
    if inside { distance } else { -distance }
}

/// The closest point of triangle `abc` to `p` and its barycentric coordinates. A triangle
/// whose area is lost to rounding against its edges' lengths (a sliver, or a segment or point:
/// collinear or repeated corners) can fool the region test, whose answer is on the triangle
/// but perhaps not the closest: it is measured as its three edges too, and the nearer kept.
fn closest_on_triangle(p: DVec3, corners: &[DVec3; 3]) -> (DVec3, [f64; 3]) {
    closest_on(p, corners, is_sliver(corners))
}

/// Whether the region test may fool itself on a triangle (see [`closest_on_triangle`]).
fn is_sliver(corners: &[DVec3; 3]) -> bool {
    let [a, b, c] = *corners;
    let (ab, ac) = (b - a, c - a);
    let area2 = ab.cross(ac).length_squared();
    // Not larger: a NaN measure counts as a sliver, measured by its edges too.
    area2.partial_cmp(&(1e-6 * ab.length_squared() * ac.length_squared()))
        != Some(Ordering::Greater)
}

/// [`closest_on_triangle`], told whether the triangle [`is_sliver`].
#[inline]
fn closest_on(p: DVec3, corners: &[DVec3; 3], sliver: bool) -> (DVec3, [f64; 3]) {
    let regions = region_test(p, corners);
    if !sliver {
        return regions;
    }
    let edges = closest_on_edges(p, *corners);
    if p.distance_squared(regions.0) < p.distance_squared(edges.0) { regions } else { edges }
}

/// `numerator / denominator`, or 0 where the denominator (a squared length) is 0.
fn ratio(numerator: f64, denominator: f64) -> f64 {
    if denominator > 0.0 { numerator / denominator } else { 0.0 }
}

/// Ericson's region test (*Real-Time Collision Detection*, 5.1.5): the closest point of
/// triangle `abc` to `p`, found from the Voronoi region of the triangle's corners, edges or
/// face that `p` is in, and its barycentric coordinates. The point is always on the triangle.
fn region_test(p: DVec3, &[a, b, c]: &[DVec3; 3]) -> (DVec3, [f64; 3]) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = ratio(d1, d1 - d3);
        return (a + ab * v, [1.0 - v, v, 0.0]);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = ratio(d2, d2 - d6);
        return (a + ac * w, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = ratio(d4 - d3, (d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, [0.0, 1.0 - w, w]);
    }
    // Inside the face: va, vb and vc are positive, and their sum is the squared norm of
    // ab x ac (0 only for a degenerate triangle, whose answer is then its first corner).
    let denom = va + vb + vc;
    let (v, w) = (ratio(vb, denom), ratio(vc, denom));
    (a + ab * v + ac * w, [(1.0 - v - w).max(0.0), v, w])
}

/// The closest point to `p` of the three edges of `abc`, with its barycentric coordinates.
fn closest_on_edges(p: DVec3, corners: [DVec3; 3]) -> (DVec3, [f64; 3]) {
    let mut best = (f64::INFINITY, corners[0], [1.0, 0.0, 0.0]);
    for (i, j) in [(0, 1), (1, 2), (2, 0)] {
        let (s, e) = (corners[i], corners[j]);
        let d = e - s;
        let length2 = d.length_squared();
        let t = if length2 > 0.0 { ((p - s).dot(d) / length2).clamp(0.0, 1.0) } else { 0.0 };
        let point = s + d * t;
        let d2 = p.distance_squared(point);
        if d2 < best.0 {
            let mut barycentric = [0.0; 3];
            (barycentric[i], barycentric[j]) = (1.0 - t, t);
            best = (d2, point, barycentric);
        }
    }
    (best.1, best.2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use crate::mesh::area::ByArea;

    /// Points within a few `sigma` of the surface of `mesh`: a point of the surface moved by
    /// up to `sigma` along each axis.
    fn near_surface(mesh: &Mesh, sigma: f64, n: usize) -> Vec<DVec3> {
        let surface = ByArea::of(mesh).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        (0..n)
            .map(|_| {
                let offset = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
                surface.point(&mut rng) + offset * sigma
            })
            .collect()
    }

    /// The rays' votes decide as the winding number alone would near the surface of an open
    /// mesh (the triceratops without its lower part) and of a partly flipped one.
    #[test]
    fn near_the_surface_the_rays_decide_as_the_winding_number() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/triceratops.obj");
        let (whole, _) = crate::mesh::read(&path).unwrap();
        let bounds = whole.bounds().unwrap();
        let cut = bounds.min.y + 0.15 * (bounds.max.y - bounds.min.y);
        let mut open = whole.clone();
        open.triangles.retain(|t| t.iter().all(|&i| open.vertices[i as usize].y > cut));
        let mut flipped = whole;
        for t in flipped.triangles.iter_mut().step_by(3) {
            t.swap(1, 2);
        }
        let diagonal = bounds.size().length();
        for (name, mesh) in [("open", open), ("flipped", flipped)] {
            let query = MeshQuery::new(&mesh).unwrap();
            let (winding, frame) = query.winding();
            let lines = Lines::new(&query);
            for sigma in [0.005, 0.0005] {
                let points = near_surface(&mesh, sigma * diagonal, 20_000);
                let inside = query.inside(&points);
                let truth = points.iter().map(|&p| winding.at(frame.to_grid(p)) >= 0.5);
                let differ = inside.iter().zip(truth).filter(|&(&a, b)| a != b).count();
                let voted = points.iter().filter(|&&p| lines.votes(p).verdict().is_some());
                let voted = voted.count();
                let inside = inside.iter().filter(|&&i| i).count();
                let what = format!(
                    "{name}, sigma {sigma}: {differ} differ, {voted} voted, {inside} inside"
                );
                assert!(inside > 5_000 && inside < 15_000, "{what}");
                assert!(voted > 19_000, "{what}");
                assert!(differ <= 10, "{what}");
            }
        }
    }

    /// Beyond the triangles' box the lines and the winding number decide outside, as
    /// [`Sign::beyond`] argues, even where the winding number passes 1/2: two stacked disks
    /// facing the same way (open, so not re-oriented into a closed solid), seen from just
    /// beyond their box along their axis, and the open and flipped triceratops.
    #[test]
    fn beyond_the_box_every_point_is_outside() {
        let disk = |z: f64| -> Vec<[DVec3; 3]> {
            let ring = |k: usize| {
                let a = std::f64::consts::TAU * k as f64 / 64.0;
                DVec3::new(a.cos(), a.sin(), z)
            };
            (0..64).map(|k| [DVec3::new(0.0, 0.0, z), ring(k), ring(k + 1)]).collect()
        };
        let corners: Vec<[DVec3; 3]> = [disk(0.0), disk(0.01)].concat();
        let disks = Mesh {
            vertices: corners.iter().flatten().copied().collect(),
            triangles: (0..corners.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect(),
        };
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/triceratops.obj");
        let (whole, _) = crate::mesh::read(&path).unwrap();
        let cut = whole.bounds().unwrap().min.y * 0.5 + whole.bounds().unwrap().max.y * 0.5;
        let mut open = whole.clone();
        open.triangles.retain(|t| t.iter().all(|&i| open.vertices[i as usize].y > cut));
        let mut flipped = whole;
        for t in flipped.triangles.iter_mut().step_by(3) {
            t.swap(1, 2);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for (name, mesh) in [("disks", disks), ("open", open), ("flipped", flipped)] {
            let query = MeshQuery::new(&mesh).unwrap();
            let sign = Sign::new(&query);
            let (winding, frame) = query.winding();
            let bounds = mesh.bounds().unwrap();
            let size = bounds.size();
            let mut beyond = 0;
            let mut wound = 0;
            for _ in 0..20_000 {
                // Uniform in the box grown by a tenth, or just beyond one of its faces.
                let u = DVec3::new(rng.random(), rng.random(), rng.random());
                let mut p = bounds.min - size * 0.1 + size * 1.2 * u;
                if rng.random::<bool>() {
                    let axis = rng.random_range(0..3);
                    p[axis] = bounds.min[axis] - size[axis] * 1e-3 * rng.random::<f64>();
                }
                if sign.beyond(p) {
                    beyond += 1;
                    wound += usize::from(winding.at(frame.to_grid(p)) >= 0.5);
                    assert!(!sign.decided(p), "{name}: {p} beyond the box decided inside");
                }
            }
            assert!(beyond > 10_000, "{name}: {beyond} points beyond");
            if name == "disks" {
                assert!(wound > 100, "{name}: the winding number passes 1/2 at {wound} points");
            }
        }
    }

    /// The four-wide hierarchy holds each of the binary one's leaves once, every slot's box
    /// holding the boxes of its node's slots, each node reached once, fewer nodes than
    /// `2 / LEAF` a triangle; one leaf makes a root of one slot.
    #[test]
    fn the_wide_hierarchy_holds_every_leaf_once_in_boxes_that_hold_their_children() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for n in [3, 5_000] {
            let triangles: Vec<[DVec3; 3]> = (0..n)
                .map(|_| {
                    let a = DVec3::new(rng.random(), rng.random(), rng.random());
                    [a, a + DVec3::X * 0.01, a + DVec3::Z * 0.02]
                })
                .collect();
            let (binary, _) = hierarchy(&triangles, LEAF);
            let mut expected: Vec<(u32, u32)> =
                binary.iter().filter(|b| b.count > 0).map(|b| (b.first, b.count)).collect();
            let wide = widen(&binary);
            let mut leaves = Vec::new();
            let mut reached = vec![0; wide.len()];
            let mut stack = vec![0];
            while let Some(w) = stack.pop() {
                reached[w] += 1;
                let node = &wide[w];
                for k in (0..WIDTH).filter(|&k| node.first[k] != EMPTY) {
                    if node.count[k] > 0 {
                        leaves.push((node.first[k], node.count[k]));
                        continue;
                    }
                    let child = &wide[node.first[k] as usize];
                    for j in (0..WIDTH).filter(|&j| child.first[j] != EMPTY) {
                        for axis in 0..3 {
                            assert!(child.min[axis][j] >= node.min[axis][k]);
                            assert!(child.max[axis][j] <= node.max[axis][k]);
                        }
                    }
                    stack.push(node.first[k] as usize);
                }
            }
            expected.sort_unstable();
            leaves.sort_unstable();
            assert_eq!(leaves, expected, "{n} triangles");
            assert!(reached.iter().all(|&r| r == 1), "{n} triangles");
            let nodes = wide.len();
            assert!(nodes * LEAF < 2 * n.max(LEAF), "{n} triangles: {nodes} nodes");
        }
    }

    /// The hierarchy of a skewed mesh (a dense cluster of small triangles and a few large ones
    /// far away, where the heuristic's cheapest split is the most lopsided): every triangle
    /// once, every box holding its triangles, every split leaving at least [`SIDE`] of its
    /// triangles on each side, and so a depth within [`DEPTH`]; its top split into subtrees
    /// built in parallel (more than [`PARALLEL`] triangles), the same on one thread.
    #[test]
    fn a_skewed_mesh_makes_a_shallow_hierarchy_whose_boxes_hold_their_triangles() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut triangles: Vec<[DVec3; 3]> = (0..20_000)
            .map(|_| {
                let a = DVec3::new(rng.random(), rng.random(), rng.random()) * 1e-3;
                [a, a + DVec3::X * 1e-5, a + DVec3::Y * 1e-5]
            })
            .collect();
        for k in 0..5 {
            let a = DVec3::splat(1e3 * f64::from(k + 1));
            triangles.push([a, a + DVec3::X, a + DVec3::Z]);
        }
        assert!(triangles.len() > PARALLEL);
        let (nodes, order) = hierarchy(&triangles, LEAF);
        let one_thread = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        assert_eq!(
            one_thread.install(|| hierarchy(&triangles, LEAF)),
            (nodes.clone(), order.clone())
        );
        let mut seen = vec![0; triangles.len()];
        // (node, depth, triangles under it)
        let mut work = vec![(0usize, 1usize)];
        let mut deepest = 0;
        while let Some((n, depth)) = work.pop() {
            deepest = deepest.max(depth);
            let node = nodes[n];
            let first = node.first as usize;
            if node.count > 0 {
                for &t in &order[first..first + node.count as usize] {
                    seen[t as usize] += 1;
                    for p in triangles[t as usize] {
                        let (min, max) = (node.min.as_dvec3(), node.max.as_dvec3());
                        assert!(p.cmpge(min).all() && p.cmple(max).all(), "{p} outside node {n}");
                    }
                }
                continue;
            }
            let under = |child: usize| leaves_under(&nodes, child);
            let (left, right) = (under(first), under(first + 1));
            let fewest = (SIDE * (left + right) as f64).ceil() as usize;
            assert!(left >= fewest && right >= fewest, "node {n} splits {left} + {right}");
            work.extend([(first, depth + 1), (first + 1, depth + 1)]);
        }
        assert!(seen.iter().all(|&k| k == 1), "every triangle in exactly one leaf");
        assert!(deepest <= 40, "{deepest} levels, the stack holds {DEPTH}");
    }

    /// A split at a bin boundary hands each side the bounds of its triangles: the same box and
    /// centroid box as a pass over them, number for number.
    #[test]
    fn a_split_gives_each_side_the_bounds_of_its_triangles() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut items: Vec<Item> = (0..1_000u32)
            .map(|t| {
                let a = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
                let corners = [a, a + DVec3::X * rng.random::<f64>(), a + DVec3::Z * 0.01];
                let (min, max) = corner_box(&corners);
                let [min, max] = rounded_outward(min, max);
                let centroid = ((corners[0] + corners[1] + corners[2]) / 3.0).as_vec3();
                Item { centroid, min, max, t }
            })
            .collect();
        let bounds = Bounds::over(&items);
        let (_, children) = split(&mut items, bounds, LEAF);
        let (middle, below, above) = children.expect("a thousand triangles are split");
        assert!(middle > 0 && middle < items.len());
        for (given, part) in [(below, &items[..middle]), (above, &items[middle..])] {
            let passed = Bounds::over(part);
            assert_eq!(
                [given.min, given.max, given.low, given.high],
                [passed.min, passed.max, passed.low, passed.high]
            );
        }
    }

    /// The number of triangles in the leaves under node `n`.
    fn leaves_under(nodes: &[Node], n: usize) -> usize {
        let node = nodes[n];
        if node.count > 0 {
            return node.count as usize;
        }
        leaves_under(nodes, node.first as usize) + leaves_under(nodes, node.first as usize + 1)
    }

    /// A plane over small triangles, a few that span the box (which make its grid coarser),
    /// triangles seen edge-on and a point-like one: at points anywhere (random, on corners,
    /// on the box's faces, outside it), the point's cell lists every triangle whose projected
    /// box holds the point, and the lists hold at most their budget of entries.
    #[test]
    fn a_line_finds_every_triangle_whose_box_it_meets_in_its_cell() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut random = || DVec3::new(rng.random(), rng.random(), rng.random());
        let mut triangles: Vec<[DVec3; 3]> = (0..3_000)
            .map(|_| {
                let a = random();
                [a, a + random() * 0.03, a + random() * 0.03]
            })
            .collect();
        for k in 0..40 {
            let a = random();
            triangles.push([a * 0.1, DVec3::new(1.0, a.y, 0.5), DVec3::new(a.x, 1.0, 1.0)]);
            // Edge-on along x, and a triangle whose corners coincide.
            triangles.push([a, a + DVec3::X * 0.2, a + DVec3::X * 0.1 * k as f64]);
            triangles.push([a, a, a]);
        }
        let corners: Vec<DVec3> = triangles.iter().flatten().copied().collect();
        let (low, high) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
        let (low, high) = corners.iter().fold((low, high), |(l, h), &p| (l.min(p), h.max(p)));
        let mut points: Vec<DVec3> =
            (0..4_000).map(|_| random() * 1.4 - DVec3::splat(0.2)).collect();
        points.extend(corners.iter().step_by(7));
        points.extend([low, high, DVec3::new(low.x, high.y, low.z), DVec3::splat(-5.0)]);
        for axis in 0..3 {
            let plane = Plane::new(&triangles, axis, low, high);
            let budget = PLANE_ENTRIES_PER_TRIANGLE as usize * triangles.len();
            assert!(plane.listed.len() <= budget, "{} entries", plane.listed.len());
            let (u, v) = plane_axes(axis);
            for p in &points {
                let q = [p[u], p[v]];
                let listed = plane.listed(q);
                for (t, corners) in triangles.iter().enumerate() {
                    let (min, max) = corner_box(corners);
                    let holds =
                        min[u] <= q[0] && q[0] <= max[u] && min[v] <= q[1] && q[1] <= max[v];
                    assert!(!holds || listed.contains(&(t as u32)), "axis {axis}, {p}: {t}");
                }
            }
        }
    }
}
