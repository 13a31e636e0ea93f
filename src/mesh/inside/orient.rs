//! Consistent re-orientation of a triangle mesh, for the generalized winding number and for
//! the winding rule along rays.
//!
//! 1. Vertices at the same position are welded (exact match), so unwelded meshes (STL) connect.
//! 2. Orientation propagates across every manifold edge (an edge of exactly two triangles):
//!    neighbours must traverse their shared edge in opposite directions.
//! 3. Each connected component keeps the orientation of the larger part (by area) of its
//!    triangles as the file gave them, so inward-facing inner shells (hollows) stay inward.
//! 4. If the whole mesh then encloses a negative signed volume it is turned inside out, so a
//!    file that is mostly flipped comes out outward facing.

use rayon::prelude::*;

use crate::geometry::DVec3;
use crate::mesh::edges::{Edges, weld};

/// A mesh's triangles re-oriented, and whether the result is closed.
pub(crate) struct Oriented {
    /// The triangles re-oriented as described in the module doc (same vertex indices).
    pub triangles: Vec<[u32; 3]>,
    /// Every edge (between welded vertices) is traversed as often in one direction as in the
    /// other: the triangles form a closed surface (whose parts may cancel), so the exact
    /// winding number is a whole number everywhere off it (never near one half), however the
    /// mesh is nested, duplicated, non-manifold or self-intersecting.
    pub closed: bool,
    /// The edges not used exactly twice ([`Edges::open`]).
    pub open_edges: usize,
}

/// Re-orients the triangles as described in the module doc.
pub(crate) fn orient(vertices: &[DVec3], triangles: &[[u32; 3]]) -> Oriented {
    orient_about(vertices, triangles, centre(vertices))
}

/// The mean of `vertices` (the origin for none): where [`orient`] measures the signed volume.
pub(crate) fn centre(vertices: &[DVec3]) -> DVec3 {
    vertices.iter().copied().sum::<DVec3>() / vertices.len().max(1) as f64
}

/// [`orient`], measuring the signed volume of step 4 about `centre` (which decides it only
/// for an open mesh).
pub(crate) fn orient_about(vertices: &[DVec3], triangles: &[[u32; 3]], centre: DVec3) -> Oriented {
    let welded = weld(vertices, triangles);
    let edges = Edges::of(&welded, vertices.len());
    let neighbours = manifold_neighbours(&edges, triangles.len());
    let (flip, component) = propagate(&neighbours);
    let area: Vec<f64> = triangles.par_iter().map(|t| vector_area(vertices, *t).length()).collect();
    let flip = keep_majority(&flip, &component, &area);
    let closed = balanced(&edges, &flip);
    let mut oriented: Vec<[u32; 3]> = triangles
        .iter()
        .zip(&flip)
        .map(|(&[a, b, c], &f)| if f { [a, c, b] } else { [a, b, c] })
        .collect();
    let volume: f64 = oriented
        .par_iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize] - centre);
            a.dot(b.cross(c))
        })
        .sum();
    if volume < 0.0 {
        oriented.iter_mut().for_each(|t| t.swap(1, 2));
    }
    Oriented { triangles: oriented, closed, open_edges: edges.open() }
}

/// Twice the vector area of triangle `t` (its normal times twice its area).
fn vector_area(vertices: &[DVec3], t: [u32; 3]) -> DVec3 {
    let [a, b, c] = t.map(|i| vertices[i as usize]);
    (b - a).cross(c - a)
}

/// No neighbour, in [`manifold_neighbours`]' lists.
const NONE: u32 = u32::MAX;

/// For every triangle, its neighbours across manifold edges (at most one an edge, so three;
/// [`NONE`] fills the rest) and whether the neighbour traverses the shared edge in the same
/// direction (so one of the two must be flipped).
fn manifold_neighbours(edges: &Edges, triangles: usize) -> Vec<[(u32, bool); 3]> {
    let mut neighbours = vec![[(NONE, false); 3]; triangles];
    let mut add = |s: u32, t: u32, same: bool| {
        if let Some(slot) = neighbours[s as usize].iter_mut().find(|n| n.0 == NONE) {
            *slot = (t, same);
        }
    };
    for group in edges.groups() {
        if let [(_, s, ds), (_, t, dt)] = *group
            && s != t
        {
            add(s, t, ds == dt);
            add(t, s, ds == dt);
        }
    }
    neighbours
}

/// Whether, with the triangles flipped as `flip` says, every edge is traversed as often in
/// each direction.
fn balanced(edges: &Edges, flip: &[bool]) -> bool {
    edges.par_groups().all(|group| {
        let forward = group.iter().filter(|&&(_, t, up)| up ^ flip[t as usize]).count();
        2 * forward == group.len()
    })
}

/// Breadth-first propagation of orientation: for each triangle whether to flip it relative
/// to the file, and its connected component. Conflicts (non-orientable surfaces) are ignored.
fn propagate(neighbours: &[[(u32, bool); 3]]) -> (Vec<bool>, Vec<u32>) {
    let n = neighbours.len();
    let mut flip = vec![false; n];
    let mut component = vec![u32::MAX; n];
    let mut queue = std::collections::VecDeque::new();
    let mut next = 0;
    for seed in 0..n {
        if component[seed] != u32::MAX {
            continue;
        }
        component[seed] = next;
        queue.push_back(seed);
        while let Some(t) = queue.pop_front() {
            for &(u, same) in neighbours[t].iter().filter(|n| n.0 != NONE) {
                let u = u as usize;
                if component[u] == u32::MAX {
                    component[u] = next;
                    flip[u] = flip[t] ^ same;
                    queue.push_back(u);
                }
            }
        }
        next += 1;
    }
    (flip, component)
}

/// Inverts the flips of every component whose flipped triangles outweigh (by area) the others,
/// so each component keeps the file's majority orientation.
fn keep_majority(flip: &[bool], component: &[u32], area: &[f64]) -> Vec<bool> {
    let count = component.iter().map(|&c| c as usize + 1).max().unwrap_or(0);
    let mut balance = vec![0.0f64; count];
    for t in 0..flip.len() {
        balance[component[t] as usize] += if flip[t] { area[t] } else { -area[t] };
    }
    (0..flip.len()).map(|t| flip[t] ^ (balance[component[t] as usize] > 0.0)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let v = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let t = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        (v, t)
    }

    fn signed_volume(v: &[DVec3], t: &[[u32; 3]]) -> f64 {
        t.iter().map(|t| v[t[0] as usize].dot(v[t[1] as usize].cross(v[t[2] as usize]))).sum()
    }

    #[test]
    fn fixes_flipped_and_inverted_tetrahedra() {
        let (v, t) = tetrahedron();
        assert!(signed_volume(&v, &t) > 0.0);
        let o = orient(&v, &t);
        assert!(o.closed);
        assert_eq!(o.triangles, t);
        let mut flipped = t.clone();
        flipped[1].swap(1, 2);
        assert_eq!(orient(&v, &flipped).triangles, t);
        let inverted: Vec<[u32; 3]> = t.iter().map(|&[a, b, c]| [a, c, b]).collect();
        let o = orient(&v, &inverted);
        assert!(signed_volume(&v, &o.triangles) > 0.0);
    }

    #[test]
    fn closed_only_without_a_boundary() {
        let (v, t) = tetrahedron();
        assert!(!orient(&v, &t[..3]).closed);
        // The same tetrahedron twice, once inside out: every edge used four times, balanced.
        let mut twice = t.clone();
        twice.extend(t.iter().map(|&[a, b, c]| [a, c, b]));
        assert!(orient(&v, &twice).closed);
        // Unwelded copies of the vertices (as STL gives them) still close.
        let mut unwelded = v.clone();
        unwelded.extend_from_slice(&v);
        let split: Vec<[u32; 3]> = t
            .iter()
            .enumerate()
            .map(|(i, t)| if i % 2 == 0 { t.map(|x| x + 4) } else { *t })
            .collect();
        assert!(orient(&unwelded, &split).closed);
    }
}
