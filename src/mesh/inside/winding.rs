//! The generalized winding number (Jacobson, Kavan and Sorkine-Hornung 2013), evaluated fast
//! with a bounding volume hierarchy and a far-field expansion (Barill et al. 2018).
//!
//! `w(q)` is the signed solid angle the triangles subtend at `q` over 4π: 1 inside and 0
//! outside a closed, outward-oriented mesh; a smooth, harmonic value in between for open
//! meshes, so `w > 1/2` closes holes the way a soap film would. Clusters farther than
//! [`BETA`] times their radius from the query use their expansion to second order, as Barill et
//! al. do (the dipole of their vector area, the first-order moment that carries how their
//! normals turn, and the second-order one that carries how they spread); the others are summed
//! exactly, triangle by triangle. Positions are f64 throughout.
//!
//! The expansion is taken to second order because the dipole alone is not enough: from inside
//! a finely tessellated sphere its error adds up over the clusters, all curved the same way,
//! whatever the number of triangles. The second order at `BETA = 2` is both more accurate and
//! cheaper than the first at 3: it opens fewer clusters (the errors of both against the exact
//! sum are in `docs/results.md`, "The winding number's expansion"). The tests check the value
//! within 0.03 of the exact sum on a hollow ball, a cube and a hemisphere.

use glam::DMat3;

use crate::geometry::DVec3;

/// A cluster is approximated when the query is farther than `BETA` times its radius (see the
/// module doc for the error); the voxelizer only compares `w` with 1/2 and 1/4.
const BETA: f64 = 2.0;
/// Most triangles in a leaf.
const LEAF: usize = 8;

/// A cluster of the hierarchy. The fields every visit reads (where the cluster is, how large,
/// its children) come first, in one cache line; the expansion, read only where it is used, after.
#[repr(C)]
struct Node {
    /// Area-weighted centroid of the cluster.
    centre: DVec3,
    /// The distance from `centre` to the cluster's farthest vertex.
    radius: f64,
    /// Range of the cluster's triangles in `Winding::triangles`.
    start: u32,
    end: u32,
    /// Index of the second child (the first follows the node); 0 for a leaf.
    right: u32,
    /// Sum of the triangles' vector areas (normal times area).
    area: DVec3,
    /// Sum of the triangles' unsigned areas.
    weight: f64,
    /// `sum over triangles of area_t (c_t - centre)^T` (c_t the centroid, area_t the vector
    /// area): how the normals turn across the cluster, the expansion's first-order term.
    moment: DMat3,
    /// The second-order term: `spread[i] = sum over triangles of area_t,i times the integral
    /// of (x - centre)(x - centre)^T over the triangle per unit area`.
    spread: [DMat3; 3],
}

/// A mesh prepared for fast winding number queries.
pub(crate) struct Winding {
    nodes: Vec<Node>,
    triangles: Vec<[DVec3; 3]>,
}

impl Winding {
    /// Builds the hierarchy over the triangles' corners.
    ///
    /// The tree depends only on the triangles' centroids rounded to 1/1024 (of a voxel, in
    /// grid coordinates), with ties broken by triangle order, so the same mesh scaled and moved
    /// gets the same tree and the same approximations.
    pub(crate) fn new(triangles: Vec<[DVec3; 3]>) -> Winding {
        let quantize = |t: &[DVec3; 3]| ((t[0] + t[1] + t[2]) * (1024.0 / 3.0)).round();
        let mut order: Vec<(DVec3, usize)> = triangles.iter().map(quantize).zip(0..).collect();
        let mut nodes = Vec::with_capacity(2 * triangles.len() / LEAF + 1);
        if !order.is_empty() {
            split(&mut nodes, &mut order, 0);
        }
        let triangles = order.iter().map(|&(_, t)| triangles[t]).collect();
        let mut w = Winding { nodes, triangles };
        w.summarize(0);
        w.measure_radii();
        w
    }

    /// Sets each node's radius: the distance from its centre to its farthest vertex (every
    /// level of the tree reads all its triangles once). Serial on purpose: the tree is built
    /// lazily from inside the voxelizer's parallel loops, where a nested parallel loop could
    /// hand this thread one of their tasks, which would ask for the tree being built.
    fn measure_radii(&mut self) {
        let triangles = &self.triangles;
        for node in &mut self.nodes {
            let tris = &triangles[node.start as usize..node.end as usize];
            node.radius = tris
                .iter()
                .flatten()
                .map(|p| p.distance_squared(node.centre))
                .fold(0.0, f64::max)
                .sqrt();
        }
    }

    /// Fills in the centre, areas and moment of node `n` and its descendants, children first: a leaf from its triangles (each at its centroid), an inner
    /// node from its children's summaries, so the whole tree costs time linear in its size.
    fn summarize(&mut self, n: usize) {
        if self.nodes.is_empty() {
            return;
        }
        let right = self.nodes[n].right as usize;
        let parts: Vec<Summary> = if right != 0 {
            self.summarize(n + 1);
            self.summarize(right);
            [n + 1, right].map(|c| Summary::of_node(&self.nodes[c])).into()
        } else {
            let node = &self.nodes[n];
            self.triangles[node.start as usize..node.end as usize]
                .iter()
                .map(Summary::of_triangle)
                .collect()
        };
        let total: f64 = parts.iter().map(|p| p.weight).sum();
        let centre = if total > 0.0 {
            parts.iter().map(|p| p.weight * p.centre).sum::<DVec3>() / total
        } else {
            parts.iter().map(|p| p.centre).sum::<DVec3>() / parts.len() as f64
        };
        let mut area = DVec3::ZERO;
        let mut moment = DMat3::ZERO;
        let mut spread = [DMat3::ZERO; 3];
        for p in &parts {
            area += p.area;
            // Moved to the new centre: each triangle's offset grows by s = p.centre - centre.
            let s = p.centre - centre;
            moment += p.moment + outer(p.area, s);
            for (i, spread) in spread.iter_mut().enumerate() {
                let m = p.moment.row(i);
                *spread += p.spread[i] + outer(m, s) + outer(s, m) + outer(s, s) * p.area[i];
            }
        }
        let node = &mut self.nodes[n];
        (node.centre, node.area, node.weight, node.moment) = (centre, area, total, moment);
        node.spread = spread;
    }

    /// The generalized winding number at `q`.
    pub(crate) fn at(&self, q: DVec3) -> f64 {
        if self.nodes.is_empty() {
            return 0.0;
        }
        let mut sum = 0.0;
        // The tree is balanced (median splits), so its depth is about log2(triangles / LEAF).
        let mut stack = [0usize; 128];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = stack[top];
            let node = &self.nodes[n];
            let d = node.centre - q;
            let dist = d.length();
            if dist > BETA * node.radius {
                sum += far_field(node, d, dist);
            } else if node.right == 0 {
                for t in &self.triangles[node.start as usize..node.end as usize] {
                    sum += solid_angle(t, q);
                }
            } else {
                stack[top] = n + 1;
                stack[top + 1] = node.right as usize;
                top += 2;
            }
        }
        sum / (4.0 * std::f64::consts::PI)
    }
}

/// What a node needs of each of its parts (triangles or child nodes) to summarize itself.
struct Summary {
    centre: DVec3,
    /// The part's total unsigned area, weighting its centre.
    weight: f64,
    area: DVec3,
    moment: DMat3,
    spread: [DMat3; 3],
}

impl Summary {
    /// A triangle about its centroid: no first moment, and as second moment its covariance
    /// per unit area, `(1/12) sum over corners of (p - centroid)(p - centroid)^T`.
    fn of_triangle(&[a, b, c]: &[DVec3; 3]) -> Summary {
        let centre = (a + b + c) / 3.0;
        let area = 0.5 * (b - a).cross(c - a);
        let covariance =
            [a, b, c].iter().map(|&p| outer(p - centre, p - centre)).sum::<DMat3>() * (1.0 / 12.0);
        let spread = [0, 1, 2].map(|i| covariance * area[i]);
        Summary { centre, weight: area.length(), area, moment: DMat3::ZERO, spread }
    }

    fn of_node(node: &Node) -> Summary {
        let (centre, weight, area, moment) = (node.centre, node.weight, node.area, node.moment);
        Summary { centre, weight, area, moment, spread: node.spread }
    }
}

/// The matrix `a b^T`.
fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// The far-field expansion of a cluster's solid angle at the query, `d = centre - q` at
/// distance `dist`, to second order (Barill et al. 2018, section 3.2): each unit of vector
/// area `A` at offset `r` from the query subtends `A . K(r)`, `K(r) = r / |r|^3`; expanded
/// about the cluster's centre,
/// `sum A_t . K(d + delta_t) = area . K(d) + J(d) : moment + 1/2 H(d) : spread`
/// with the Jacobian `J_ij = δ_ij / |d|^3 - 3 d_i d_j / |d|^5` and the Hessian
/// `H_ijk = -3 (δ_ij d_k + δ_ik d_j + δ_jk d_i) / |d|^5 + 15 d_i d_j d_k / |d|^7`.
/// The first-order term carries the cluster's curvature, which the dipole alone misses (a
/// curved shell seen from inside); the second lets clusters nearer the query be approximated.
fn far_field(node: &Node, d: DVec3, dist: f64) -> f64 {
    let inv2 = 1.0 / (dist * dist);
    let inv3 = inv2 / dist;
    let m = &node.moment;
    let trace = m.x_axis.x + m.y_axis.y + m.z_axis.z;
    let dmd = d.dot(*m * d);
    let first = node.area.dot(d) * inv3 + trace * inv3 - 3.0 * dmd * inv3 * inv2;
    // H : spread, with spread[i] symmetric: its δ_ij d_k and δ_ik d_j terms are equal.
    let c = &node.spread;
    let mut linear = 0.0;
    let mut cubic = 0.0;
    for i in 0..3 {
        let cd = c[i] * d;
        linear += 2.0 * cd[i] + (c[i].x_axis.x + c[i].y_axis.y + c[i].z_axis.z) * d[i];
        cubic += d[i] * d.dot(cd);
    }
    first + 0.5 * inv3 * inv2 * (15.0 * cubic * inv2 - 3.0 * linear)
}

/// Splits `order[..]` (quantized centroid, triangle) at the median of its widest axis,
/// recursively, pushing the nodes in depth-first order; `start` is the slice's offset.
fn split(nodes: &mut Vec<Node>, order: &mut [(DVec3, usize)], start: usize) -> usize {
    let index = nodes.len();
    let end = start + order.len();
    nodes.push(Node {
        centre: DVec3::ZERO,
        area: DVec3::ZERO,
        weight: 0.0,
        moment: DMat3::ZERO,
        spread: [DMat3::ZERO; 3],
        radius: 0.0,
        start: start as u32,
        end: end as u32,
        right: 0,
    });
    if order.len() > LEAF {
        let (lo, hi) = order.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), (c, _)| (lo.min(*c), hi.max(*c)),
        );
        let extent = hi - lo;
        let axis = (0..3).fold(0, |best, a| if extent[a] > extent[best] { a } else { best });
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |x, y| {
            x.0[axis].total_cmp(&y.0[axis]).then(x.1.cmp(&y.1))
        });
        let (left, right) = order.split_at_mut(mid);
        split(nodes, left, start);
        let r = split(nodes, right, start + mid);
        nodes[index].right = r as u32;
    }
    index
}

/// The signed solid angle triangle `t` subtends at `q` (Van Oosterom and Strackee),
/// positive when `q` sees its back (inside an outward-oriented mesh).
fn solid_angle(t: &[DVec3; 3], q: DVec3) -> f64 {
    let [a, b, c] = t.map(|p| p - q);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let denom = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * det.atan2(denom)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An outward cube [0, 1]^3 split into many triangles, so the hierarchy has depth.
    pub(super) fn cube(n: usize) -> Vec<[DVec3; 3]> {
        let mut out = Vec::new();
        for axis in 0..3 {
            for side in [0.0, 1.0] {
                for i in 0..n {
                    for j in 0..n {
                        let p = |u: usize, v: usize| {
                            let mut c = [0.0; 3];
                            c[axis] = side;
                            c[(axis + 1) % 3] = u as f64 / n as f64;
                            c[(axis + 2) % 3] = v as f64 / n as f64;
                            DVec3::from_array(c)
                        };
                        let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
                        if side == 1.0 {
                            out.push([a, b, c]);
                            out.push([a, c, d]);
                        } else {
                            out.push([a, c, b]);
                            out.push([a, d, c]);
                        }
                    }
                }
            }
        }
        out
    }

    #[test]
    fn one_inside_zero_outside_half_on_open_half() {
        let w = Winding::new(cube(12));
        assert!((w.at(DVec3::splat(0.5)) - 1.0).abs() < 2e-2);
        assert!((w.at(DVec3::new(0.2, 0.3, 0.9)) - 1.0).abs() < 5e-2);
        assert!(w.at(DVec3::new(1.5, 0.5, 0.5)).abs() < 2e-2);
        assert!(w.at(DVec3::new(40.0, -3.0, 7.0)).abs() < 1e-3);
        // Without the top face (z = 1) the centre sees 5/6 of the sphere.
        let open: Vec<_> = cube(12).into_iter().filter(|t| t.iter().any(|p| p.z < 1.0)).collect();
        assert!((Winding::new(open).at(DVec3::splat(0.5)) - 5.0 / 6.0).abs() < 1e-2);
    }

    /// A sphere of `rings x 2 rings` quads, outward or inward.
    fn sphere(radius: f64, rings: usize, inward: bool) -> Vec<[DVec3; 3]> {
        use std::f64::consts::{PI, TAU};
        let at = |i: usize, j: usize| {
            let (theta, phi) = (PI * i as f64 / rings as f64, TAU * j as f64 / (2 * rings) as f64);
            radius * DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
        };
        let mut out = Vec::new();
        for i in 0..rings {
            for j in 0..2 * rings {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                for mut t in [[a, b, c], [a, c, d]] {
                    if inward {
                        t.swap(1, 2);
                    }
                    out.push(t);
                }
            }
        }
        out
    }

    /// The hierarchical value against the exact sum over every triangle, at points spread
    /// through and around each mesh: a hollow ball (an outer sphere and an inward inner one,
    /// where the dipole alone was off by 0.3), a finely split cube, and an open hemisphere.
    #[test]
    fn within_three_hundredths_of_the_exact_sum() {
        let mut hollow = sphere(1.0, 80, false);
        hollow.extend(sphere(0.6, 80, true));
        let hemisphere: Vec<_> =
            sphere(1.0, 40, false).into_iter().filter(|t| t.iter().all(|p| p.z >= -1e-9)).collect();
        let unit = |i: usize, k: u64| ((i as u64 * 2654435761 + k * 40503) % 1000) as f64 / 1000.0;
        for (name, triangles) in
            [("hollow", hollow), ("cube", cube(30)), ("hemisphere", hemisphere)]
        {
            let w = Winding::new(triangles.clone());
            // Through the box around the meshes, and inside the hollow's inner sphere.
            let worst = (0..400)
                .map(|i| {
                    let scale = if i % 4 == 0 { 0.8 } else { 2.6 };
                    let q = (DVec3::new(unit(i, 1), unit(i, 2), unit(i, 3)) - 0.5) * scale;
                    let exact: f64 = triangles.iter().map(|t| solid_angle(t, q)).sum();
                    (w.at(q) - exact / (4.0 * std::f64::consts::PI)).abs()
                })
                .fold(0.0, f64::max);
            assert!(worst < 0.03, "{name}: {worst}");
        }
    }
}
