//! The edges of a triangle mesh, found in time linear in its size: vertices at the same
//! position welded, then every use of an edge by a triangle grouped with the other uses of
//! that edge. Re-orientation (`voxelize`) and the watertightness check ([`Mesh::open_edges`])
//! read them.
//!
//! [`Mesh::open_edges`]: super::Mesh::open_edges

use rayon::prelude::*;

use crate::geometry::DVec3;

/// The triangles with every vertex replaced by the first vertex at the same position.
///
/// The vertices are sorted by their position's bits with their index, the keys stored beside
/// the indices (a comparison reads them in place, not the vertices at random): each run of
/// equal positions starts with its first vertex.
pub(crate) fn weld(vertices: &[DVec3], triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    // +0.0 so that -0.0 and 0.0 weld.
    let mut order: Vec<([u64; 3], u32)> = vertices
        .par_iter()
        .enumerate()
        .map(|(i, v)| ((*v + DVec3::ZERO).to_array().map(f64::to_bits), i as u32))
        .collect();
    order.par_sort_unstable();
    let mut canonical = vec![0u32; vertices.len()];
    for run in order.chunk_by(|a, b| a.0 == b.0) {
        run.iter().for_each(|&(_, i)| canonical[i as usize] = run[0].1);
    }
    triangles.par_iter().map(|t| t.map(|i| canonical[i as usize])).collect()
}

/// Every use of every edge by a triangle, grouped by edge: bucketed by the edge's smaller
/// vertex (a counting sort), each bucket sorted by the other vertex, so the time is linear in
/// the triangles. Edges whose ends coincide are left out.
pub(crate) struct Edges {
    /// The uses of edges whose smaller vertex is `a` are `uses[start[a]..start[a + 1]]`.
    start: Vec<usize>,
    /// (larger vertex, triangle, whether the triangle traverses the edge from the smaller).
    uses: Vec<(u32, u32, bool)>,
}

impl Edges {
    /// The edges of `triangles`, whose corners index `vertices` vertices.
    pub(crate) fn of(triangles: &[[u32; 3]], vertices: usize) -> Edges {
        let each = |&tri: &[u32; 3]| {
            (0..3).map(move |e| (tri[e], tri[(e + 1) % 3])).filter(|(a, b)| a != b)
        };
        let mut start = vec![0usize; vertices + 1];
        for (a, b) in triangles.iter().flat_map(each) {
            start[a.min(b) as usize + 1] += 1;
        }
        for a in 0..vertices {
            start[a + 1] += start[a];
        }
        let mut next = start.clone();
        let mut uses = vec![(0, 0, false); start[vertices]];
        for (t, tri) in triangles.iter().enumerate() {
            for (a, b) in each(tri) {
                let slot = &mut next[a.min(b) as usize];
                uses[*slot] = (a.max(b), t as u32, a < b);
                *slot += 1;
            }
        }
        let mut rest = uses.as_mut_slice();
        let mut buckets = Vec::with_capacity(vertices);
        for a in 0..vertices {
            let (bucket, tail) = rest.split_at_mut(start[a + 1] - start[a]);
            buckets.push(bucket);
            rest = tail;
        }
        buckets.into_par_iter().for_each(|bucket| bucket.sort_unstable());
        Edges { start, uses }
    }

    /// The edges not used exactly twice (a triangle with a repeated corner uses one edge twice).
    pub(crate) fn open(&self) -> usize {
        self.par_groups().filter(|group| group.len() != 2).count()
    }

    /// The uses of each edge, one slice an edge.
    pub(crate) fn groups(&self) -> impl Iterator<Item = &[(u32, u32, bool)]> {
        self.start.windows(2).flat_map(|w| self.uses[w[0]..w[1]].chunk_by(|x, y| x.0 == y.0))
    }

    /// [`Edges::groups`], in parallel.
    pub(crate) fn par_groups(&self) -> impl ParallelIterator<Item = &[(u32, u32, bool)]> {
        self.start
            .par_windows(2)
            .flat_map_iter(|w| self.uses[w[0]..w[1]].chunk_by(|x, y| x.0 == y.0))
    }
}
