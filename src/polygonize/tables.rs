//! The fixed split of a cube into six tetrahedra and the per-cube case table derived from it.
//!
//! Corners of a cube are numbered by their offsets as bits: bit 0 is `x`, bit 1 is `y`, bit 2
//! is `z`, so corner 7 is the far corner. Every cube is split along its main diagonal 0-7 into
//! the six tetrahedra `0 → a → a|b → 7` over the orderings `(a, b, c)` of the three axes (the
//! Kuhn, or Freudenthal, split). Every edge of these tetrahedra joins two corners one of which
//! is a subset of the other, so it starts at the smaller corner (its *base*) and runs along a
//! non-empty set of axes (its *direction*, 1..=7). Since every cube uses the same split, the
//! diagonals of shared faces agree and the tetrahedra tile the whole grid: that is what makes
//! the extracted surface watertight.
//!
//! The table is computed once from these rules, not typed in: for each of the 256 sign patterns
//! of a cube's corners it lists the surface pieces of its six tetrahedra as triangles and quads
//! of edge ids, ordered counter-clockwise seen from outside (from the negative side).

use std::sync::LazyLock;

use crate::geometry::DVec3;

/// The six tetrahedra of a cube, as corner numbers along the path `0 → a → a|b → 7`.
pub(super) const TETRAHEDRA: [[u8; 4]; 6] =
    [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];

/// An edge of the split as `base * 8 + direction`, both 3-bit corner/axis masks.
pub(super) type EdgeId = u8;

/// The edge joining corners `a` and `b`, one a subset of the other.
const fn edge_id(a: u8, b: u8) -> EdgeId {
    (a & b) * 8 + (a ^ b)
}

/// The base corner of an edge.
#[inline]
pub(super) const fn edge_base(e: EdgeId) -> u8 {
    e >> 3
}

/// The direction (axis mask) of an edge.
#[inline]
pub(super) const fn edge_direction(e: EdgeId) -> u8 {
    e & 7
}

/// The offset of a corner or direction mask as a vector.
pub(super) fn offset(mask: u8) -> DVec3 {
    DVec3::new((mask & 1) as f64, ((mask >> 1) & 1) as f64, ((mask >> 2) & 1) as f64)
}

/// A surface piece inside one tetrahedron: a triangle (`len == 3`) or a quad (`len == 4`),
/// counter-clockwise seen from outside.
#[derive(Debug, Clone, Copy)]
pub(super) struct Piece {
    /// Edge ids of the corners, in order; the fourth is unused for a triangle.
    pub edges: [EdgeId; 4],
    /// 3 or 4.
    pub len: u8,
}

/// The surface pieces of every sign pattern of a cube (bit `c` set when corner `c` is inside).
pub(super) struct CaseTable {
    start: [u16; 257],
    pieces: Vec<Piece>,
}

impl CaseTable {
    /// The pieces of the cube whose inside corners are the set bits of `case`.
    #[inline]
    pub(super) fn pieces(&self, case: u8) -> &[Piece] {
        let c = case as usize;
        &self.pieces[self.start[c] as usize..self.start[c + 1] as usize]
    }
}

/// The table, built on first use.
pub(super) static CASES: LazyLock<CaseTable> = LazyLock::new(build_table);

fn build_table() -> CaseTable {
    let mut start = [0u16; 257];
    let mut pieces = Vec::new();
    for (case, first) in start.iter_mut().take(256).enumerate() {
        *first = pieces.len() as u16;
        pieces.extend(TETRAHEDRA.iter().filter_map(|tet| tetrahedron_piece(tet, case as u8)));
    }
    start[256] = pieces.len() as u16;
    CaseTable { start, pieces }
}

/// The surface piece of one tetrahedron for the cube's sign pattern `case`, oriented so that
/// its normal points from the inside corners toward the outside ones.
fn tetrahedron_piece(tet: &[u8; 4], case: u8) -> Option<Piece> {
    let is_inside = |c: u8| case >> c & 1 == 1;
    let inside: Vec<u8> = tet.iter().copied().filter(|&c| is_inside(c)).collect();
    let outside: Vec<u8> = tet.iter().copied().filter(|&c| !is_inside(c)).collect();
    let mut edges: Vec<EdgeId> = match (inside.as_slice(), outside.as_slice()) {
        ([a], [b, c, d]) | ([b, c, d], [a]) => {
            vec![edge_id(*a, *b), edge_id(*a, *c), edge_id(*a, *d)]
        }
        // Consecutive quad corners share a tetrahedron corner, so this is a cycle.
        ([a, b], [c, d]) => {
            vec![edge_id(*a, *c), edge_id(*a, *d), edge_id(*b, *d), edge_id(*b, *c)]
        }
        _ => return None,
    };
    let centroid = |cs: &[u8]| cs.iter().map(|&c| offset(c)).sum::<DVec3>() / cs.len() as f64;
    let outward = centroid(&outside) - centroid(&inside);
    if piece_normal(&edges).dot(outward) < 0.0 {
        edges.reverse();
    }
    let mut piece = Piece { edges: [0; 4], len: edges.len() as u8 };
    piece.edges[..edges.len()].copy_from_slice(&edges);
    Some(piece)
}

/// The area vector of a triangle or quad through the midpoints of its edges.
fn piece_normal(edges: &[EdgeId]) -> DVec3 {
    let q: Vec<DVec3> =
        edges.iter().map(|&e| offset(edge_base(e)) + 0.5 * offset(edge_direction(e))).collect();
    match q.as_slice() {
        [a, b, c] => (*b - *a).cross(*c - *a),
        [a, b, c, d] => (*c - *a).cross(*d - *b),
        _ => DVec3::ZERO,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_six_tetrahedra_fill_the_cube() {
        let volume: f64 = TETRAHEDRA
            .iter()
            .map(|t| {
                let [a, b, c, d] = t.map(offset);
                ((b - a).cross(c - a).dot(d - a) / 6.0).abs()
            })
            .sum();
        assert!((volume - 1.0).abs() < 1e-12, "{volume}");
    }

    #[test]
    fn complementary_cases_have_the_same_pieces_reversed() {
        for case in 0..=255u8 {
            let a = CASES.pieces(case);
            let b = CASES.pieces(!case);
            assert_eq!(a.len(), b.len());
            for (p, q) in a.iter().zip(b) {
                let mut reversed = q.edges[..q.len as usize].to_vec();
                reversed.reverse();
                let n = p.len as usize;
                // Same cycle, opposite direction: equal up to rotation.
                let same = (0..n).any(|r| (0..n).all(|i| p.edges[(i + r) % n] == reversed[i]));
                assert!(same, "case {case}: {p:?} vs {q:?}");
            }
        }
        assert!(CASES.pieces(0).is_empty() && CASES.pieces(255).is_empty());
    }
}
