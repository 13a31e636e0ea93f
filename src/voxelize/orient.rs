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

use std::collections::HashMap;

use crate::geometry::DVec3;

/// The triangles re-oriented as described in the module doc (same vertex indices).
pub(crate) fn orient(vertices: &[DVec3], triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let welded = weld(vertices, triangles);
    let neighbours = manifold_neighbours(&welded);
    let (flip, component) = propagate(&neighbours);
    let area: Vec<f64> = triangles.iter().map(|t| vector_area(vertices, *t).length()).collect();
    let flip = keep_majority(&flip, &component, &area);
    let mut oriented: Vec<[u32; 3]> = triangles
        .iter()
        .zip(&flip)
        .map(|(&[a, b, c], &f)| if f { [a, c, b] } else { [a, b, c] })
        .collect();
    let centre = vertices.iter().copied().sum::<DVec3>() / vertices.len().max(1) as f64;
    let volume: f64 = oriented
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize] - centre);
            a.dot(b.cross(c))
        })
        .sum();
    if volume < 0.0 {
        oriented.iter_mut().for_each(|t| t.swap(1, 2));
    }
    oriented
}

/// Twice the vector area of triangle `t` (its normal times twice its area).
fn vector_area(vertices: &[DVec3], t: [u32; 3]) -> DVec3 {
    let [a, b, c] = t.map(|i| vertices[i as usize]);
    (b - a).cross(c - a)
}

/// The triangles with every vertex replaced by the first vertex at the same position.
fn weld(vertices: &[DVec3], triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut first: HashMap<[u64; 3], u32> = HashMap::with_capacity(vertices.len());
    let canonical: Vec<u32> = vertices
        .iter()
        .enumerate()
        .map(|(i, p)| {
            // +0.0 so that -0.0 and 0.0 weld.
            let key = (*p + DVec3::ZERO).to_array().map(f64::to_bits);
            *first.entry(key).or_insert(i as u32)
        })
        .collect();
    triangles.iter().map(|t| t.map(|i| canonical[i as usize])).collect()
}

/// For every triangle, its neighbours across manifold edges and whether the neighbour
/// traverses the shared edge in the same direction (so one of the two must be flipped).
fn manifold_neighbours(triangles: &[[u32; 3]]) -> Vec<Vec<(u32, bool)>> {
    // (edge key, triangle, whether the triangle traverses it from the smaller vertex)
    let mut edges: Vec<(u64, u32, bool)> = Vec::with_capacity(triangles.len() * 3);
    for (t, tri) in triangles.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (tri[e], tri[(e + 1) % 3]);
            if a != b {
                let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
                edges.push((key, t as u32, a < b));
            }
        }
    }
    edges.sort_unstable();
    let mut neighbours = vec![Vec::new(); triangles.len()];
    for group in edges.chunk_by(|x, y| x.0 == y.0) {
        if let [(_, s, ds), (_, t, dt)] = *group
            && s != t
        {
            neighbours[s as usize].push((t, ds == dt));
            neighbours[t as usize].push((s, ds == dt));
        }
    }
    neighbours
}

/// Breadth-first propagation of orientation: for each triangle whether to flip it relative
/// to the file, and its connected component. Conflicts (non-orientable surfaces) are ignored.
fn propagate(neighbours: &[Vec<(u32, bool)>]) -> (Vec<bool>, Vec<u32>) {
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
            for &(u, same) in &neighbours[t] {
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
        assert_eq!(orient(&v, &t), t);
        let mut flipped = t.clone();
        flipped[1].swap(1, 2);
        assert_eq!(orient(&v, &flipped), t);
        let inverted: Vec<[u32; 3]> = t.iter().map(|&[a, b, c]| [a, c, b]).collect();
        let o = orient(&v, &inverted);
        assert!(signed_volume(&v, &o) > 0.0);
    }
}
