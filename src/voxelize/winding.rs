//! The generalized winding number (Jacobson, Kavan and Sorkine-Hornung 2013), evaluated fast
//! with a bounding volume hierarchy and a far-field dipole expansion (Barill et al. 2018).
//!
//! `w(q)` is the signed solid angle the triangles subtend at `q` over 4π: 1 inside and 0
//! outside a closed, outward-oriented mesh; a smooth, harmonic value in between for open
//! meshes, so `w > 1/2` closes holes the way a soap film would. Clusters farther than
//! [`BETA`] times their radius from the query use their first-order (dipole) expansion;
//! the others are summed exactly, triangle by triangle. Positions are f64 throughout.

use crate::geometry::DVec3;

/// A cluster is approximated when the query is farther than `BETA` times its radius. The
/// dipole's error is then a few hundredths at most, next to a surface; the voxelizer only
/// compares `w` with 1/2.
const BETA: f64 = 2.0;
/// Most triangles in a leaf.
const LEAF: usize = 8;

struct Node {
    /// Area-weighted centroid of the cluster.
    centre: DVec3,
    /// Sum of the triangles' vector areas (normal times area).
    area: DVec3,
    /// Largest distance from `centre` to a vertex of the cluster.
    radius: f64,
    /// Range of the cluster's triangles in `Winding::triangles`.
    start: u32,
    end: u32,
    /// Index of the second child (the first follows the node); 0 for a leaf.
    right: u32,
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
        w
    }

    /// Fills in the centre, vector area and radius of node `n` and its descendants.
    fn summarize(&mut self, n: usize) {
        if self.nodes.is_empty() {
            return;
        }
        if self.nodes[n].right != 0 {
            self.summarize(n + 1);
            self.summarize(self.nodes[n].right as usize);
        }
        let node = &self.nodes[n];
        let tris = &self.triangles[node.start as usize..node.end as usize];
        let mut area = DVec3::ZERO;
        let mut weighted = DVec3::ZERO;
        let mut total = 0.0;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for [a, b, c] in tris {
            let va = 0.5 * (*b - *a).cross(*c - *a);
            let len = va.length();
            area += va;
            weighted += len * (*a + *b + *c) / 3.0;
            total += len;
            for p in [a, b, c] {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let centre = if total > 0.0 { weighted / total } else { 0.5 * (lo + hi) };
        let radius = tris.iter().flatten().map(|p| p.distance(centre)).fold(0.0, f64::max);
        let node = &mut self.nodes[n];
        (node.centre, node.area, node.radius) = (centre, area, radius);
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
                // Dipole: each unit of vector area at distance d subtends d.n / |d|^3.
                sum += node.area.dot(d) / (dist * dist * dist);
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

/// Splits `order[..]` (quantized centroid, triangle) at the median of its widest axis,
/// recursively, pushing the nodes in depth-first order; `start` is the slice's offset.
fn split(nodes: &mut Vec<Node>, order: &mut [(DVec3, usize)], start: usize) -> usize {
    let index = nodes.len();
    let end = start + order.len();
    nodes.push(Node {
        centre: DVec3::ZERO,
        area: DVec3::ZERO,
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
    fn cube(n: usize) -> Vec<[DVec3; 3]> {
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
        assert!((w.at(DVec3::splat(0.5)) - 1.0).abs() < 1e-2);
        assert!((w.at(DVec3::new(0.2, 0.3, 0.9)) - 1.0).abs() < 5e-2);
        assert!(w.at(DVec3::new(1.5, 0.5, 0.5)).abs() < 2e-2);
        assert!(w.at(DVec3::new(40.0, -3.0, 7.0)).abs() < 1e-3);
        // Without the top face (z = 1) the centre sees 5/6 of the sphere.
        let open: Vec<_> = cube(12).into_iter().filter(|t| t.iter().any(|p| p.z < 1.0)).collect();
        assert!((Winding::new(open).at(DVec3::splat(0.5)) - 5.0 / 6.0).abs() < 1e-2);
    }
}
