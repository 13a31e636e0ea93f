//! Surface following: the zero set of a field extracted from seed cubes outward, evaluating the
//! field only at the corners of the cubes the surface crosses.
//!
//! A cube *crosses* the surface when its corners are not all on one side (inside is `>= 0`,
//! NaN outside). The extracted surface passes from a cube to its neighbour exactly through the
//! faces whose four corners are not all on one side, so growing from a crossing cube through
//! such faces reaches every cube of every surface component that passes through it, and no
//! other cube. The growth goes a frontier at a time: the corners of a whole frontier are
//! evaluated in one [`Field::values`] call (vectorized and parallel), the frontier's cubes are
//! classified in parallel, and the next frontier is the unvisited neighbours across crossed
//! faces.
//!
//! Seeds come from two places (see [the guarantee](super#which-components-surface-following-finds)):
//! the eight cubes around the voxel nearest each of the field's surface points, and every
//! crossed grid edge on the edges of a coarse lattice whose two ends lie on opposite sides.
//!
//! The crossing cubes and the crossed edges are then put in the order the dense extraction
//! makes them (cubes by linear index; edges by layer, in-plane before across, row, direction,
//! voxel), and the same per-cube code emits the triangles, so every component found is the
//! dense extraction's, vertex for vertex and triangle for triangle.
//!
//! A field whose sums are faster per point in large batches (a treecode over many centres,
//! [`Field::fast_batch`]) would sum each frontier (a thin sheet of voxels) at a high cost per
//! point. On a large grid, the surface is therefore first followed on the grid of every other
//! voxel, and the voxels of the cubes it crosses there are evaluated in one batch with the
//! lattice: the frontiers then find most of their corners known. The prediction only adds
//! values: the cubes found are those of the growth without it, but for a value within the fast
//! summation's error of zero, whose side can depend on the batch it was summed in.
//!
//! Only what is visited is stored: values in bricks of 4^3 voxels made as the surface reaches
//! them (found through a table of 8 bytes a brick), visited cubes by index in a hash set, the
//! crossing cubes in a list.

use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

use rayon::prelude::*;

use super::extract::{EdgeVertex, Surface, crossing, emit, inside};
use super::tables::{CASES, EdgeId, edge_base, edge_direction, offset};
use crate::field::Field;
use crate::geometry::DVec3;
use crate::grid::Grid;

/// The spacing of the coarse lattice whose sign changes seed the growth, in voxels.
pub(super) const LATTICE_STEP: usize = 8;

/// The fewest voxels along a grid's longest axis for which the surface is first followed on
/// the grid of half the resolution, to predict the band of voxels it needs.
const PREDICT_FROM: usize = 256;

/// Crossing cubes whose edge keys are made distinct together ([`Tracker::edge_keys`]).
const KEY_RUN: usize = 1 << 12;

/// A hasher for voxel and edge indices: the murmur3 finalizer, which spreads indices that
/// differ only in their high bits (voxels of one column) over the whole table.
#[derive(Default)]
struct IndexHasher(u64);

impl Hasher for IndexHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(self.0.rotate_left(8) ^ u64::from(b));
        }
    }

    fn write_u64(&mut self, n: u64) {
        self.0 = n;
    }

    fn write_usize(&mut self, n: usize) {
        self.0 = n as u64;
    }

    fn finish(&self) -> u64 {
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
        h ^ h >> 33
    }
}

type IndexMap<V> = HashMap<usize, V, BuildHasherDefault<IndexHasher>>;
type IndexSet = HashSet<usize, BuildHasherDefault<IndexHasher>>;

/// Voxels along each axis of a [`Brick`]: a power of two.
const BRICK: usize = 4;

/// The values of a block of `BRICK^3` voxels, and which of them are known.
struct Brick {
    values: [f64; BRICK * BRICK * BRICK],
    known: [u64; BRICK * BRICK * BRICK / 64],
}

/// The field's values by voxel, kept in bricks made as the surface reaches them: neighbouring
/// voxels, which the growth reads together, stay together in memory. A table of every brick
/// (8 bytes a brick, an eighth of a byte a voxel) finds a voxel's brick without hashing.
struct Bricks {
    grid: Grid,
    /// Bricks along each axis.
    counts: [usize; 3],
    /// The bricks made so far, by brick index.
    bricks: Vec<Option<Box<Brick>>>,
}

impl Bricks {
    fn new(grid: &Grid) -> Bricks {
        let counts = grid.dims.map(|n| n.div_ceil(BRICK));
        let bricks = std::iter::repeat_with(|| None).take(counts.iter().product()).collect();
        Bricks { grid: *grid, counts, bricks }
    }

    /// A voxel's brick and its place in it.
    fn locate(&self, voxel: usize) -> (usize, usize) {
        let [i, j, k] = self.grid.voxel(voxel);
        let [_, cy, cz] = self.counts;
        let brick = ((i / BRICK) * cy + j / BRICK) * cz + k / BRICK;
        let place = ((i % BRICK) * BRICK + j % BRICK) * BRICK + k % BRICK;
        (brick, place)
    }

    fn get(&self, voxel: usize) -> Option<f64> {
        let (brick, place) = self.locate(voxel);
        let b = self.bricks[brick].as_ref()?;
        (b.known[place / 64] >> (place % 64) & 1 == 1).then(|| b.values[place])
    }

    fn contains(&self, voxel: usize) -> bool {
        self.get(voxel).is_some()
    }

    fn insert(&mut self, voxel: usize, value: f64) {
        let (brick, place) = self.locate(voxel);
        let b = self.bricks[brick].get_or_insert_with(|| {
            Box::new(Brick {
                values: [0.0; BRICK * BRICK * BRICK],
                known: [0; BRICK * BRICK * BRICK / 64],
            })
        });
        b.values[place] = value;
        b.known[place / 64] |= 1 << (place % 64);
    }
}

/// Extracts the zero set of `field` on `grid` from the cubes around `seeds` and the coarse
/// lattice's sign changes, and returns it with the values it read (for refinement), which
/// include every voxel on the line of a vertex's edge one step beyond each end, as the dense
/// extraction has them.
pub(super) fn track<F: Field + ?Sized>(
    field: &F,
    grid: &Grid,
    seeds: &[DVec3],
) -> (Surface, impl Fn(&EdgeVertex) -> [f64; 4] + Sync) {
    let mut tracker = Tracker::new(field, grid);
    if grid.dims.iter().any(|&n| n < 2) {
        return (Surface::default(), tracker.ends());
    }
    tracker.follow(seeds);
    let surface = tracker.surface();
    let lines: Vec<usize> = surface
        .vertices
        .par_iter()
        .flat_map_iter(|v| v.line(grid))
        .flatten()
        .filter(|&n| !tracker.values.contains(n))
        .collect();
    tracker.evaluate(lines);
    (surface, tracker.ends())
}

/// The state of one surface following.
struct Tracker<'a, F: ?Sized> {
    field: &'a F,
    grid: Grid,
    /// The linear offsets of a cube's corners from its base voxel, by corner number.
    corners: [usize; 8],
    /// The field's value at every voxel evaluated so far.
    values: Bricks,
    /// Every cube (by its base voxel) that has been in a frontier.
    visited: IndexSet,
    /// The cubes found to cross the surface.
    crossing: Vec<usize>,
}

impl<'a, F: Field + ?Sized> Tracker<'a, F> {
    fn new(field: &'a F, grid: &Grid) -> Self {
        let corners = std::array::from_fn(|c| {
            let d = |bit: usize| c >> bit & 1;
            grid.index([d(0), d(1), d(2)])
        });
        Tracker {
            field,
            grid: *grid,
            corners,
            values: Bricks::new(grid),
            visited: IndexSet::default(),
            crossing: Vec::new(),
        }
    }

    /// Finds the crossing cubes: from the cubes around the seeds and the lattice's sign
    /// changes, frontier by frontier, after evaluating the predicted band, if any, with the
    /// lattice.
    fn follow(&mut self, seeds: &[DVec3]) {
        let band = self.predicted_band(seeds);
        let mut frontier = self.seed_cubes(seeds);
        frontier.extend(self.lattice_cubes(band));
        while !frontier.is_empty() {
            frontier = self.grow(&frontier);
        }
    }

    /// The voxels the surface will most likely need, for a field that sums faster in large
    /// batches ([`Field::fast_batch`]) on a grid of at least [`PREDICT_FROM`] voxels along its
    /// longest axis: the voxels of every cube that crosses the surface followed on the grid of
    /// every other voxel (itself predicted the same way where it is large enough). None
    /// otherwise.
    fn predicted_band(&self, seeds: &[DVec3]) -> Vec<usize> {
        let grid = self.grid;
        let half = Grid {
            dims: grid.dims.map(|n| n.div_ceil(2)),
            origin: grid.origin,
            voxel_size: 2.0 * grid.voxel_size,
        };
        let large = grid.dims.iter().max().is_some_and(|&n| n >= PREDICT_FROM);
        if self.field.fast_batch().is_none() || !large || half.dims.iter().any(|&n| n < 2) {
            return Vec::new();
        }
        let mut coarse = Tracker::new(self.field, &half);
        coarse.follow(seeds);
        coarse
            .crossing
            .par_iter()
            .flat_map_iter(|&cube| {
                let base = half.voxel(cube).map(|c| 2 * c);
                (0..27).filter_map(move |n| {
                    let v = [base[0] + n / 9, base[1] + n / 3 % 3, base[2] + n % 3];
                    (0..3).all(|a| v[a] < grid.dims[a]).then(|| grid.index(v))
                })
            })
            .collect()
    }

    /// Evaluates the field at the voxels not yet known among `voxels`, in one batch.
    fn evaluate(&mut self, mut voxels: Vec<usize>) {
        voxels.par_sort_unstable();
        voxels.dedup();
        let voxels: Vec<usize> =
            voxels.into_par_iter().filter(|&v| !self.values.contains(v)).collect();
        let points: Vec<DVec3> =
            voxels.par_iter().map(|&v| self.grid.position(self.grid.voxel(v))).collect();
        let values = self.field.values(&points);
        assert_eq!(values.len(), points.len(), "Field::values must return one value per point");
        for (v, value) in voxels.into_iter().zip(values) {
            self.values.insert(v, value);
        }
    }

    /// The value at a voxel already evaluated.
    fn value(&self, voxel: usize) -> f64 {
        self.values.get(voxel).expect("the growth reads only voxels it has evaluated")
    }

    /// The cubes not yet visited among `cubes`, now marked visited.
    fn unvisited(&mut self, cubes: impl IntoIterator<Item = usize>) -> Vec<usize> {
        cubes.into_iter().filter(|&c| self.visited.insert(c)).collect()
    }

    /// The cubes around the voxel nearest each seed inside the grid: the eight that have it
    /// as a corner (fewer at the grid's bounds).
    fn seed_cubes(&mut self, seeds: &[DVec3]) -> Vec<usize> {
        let dims = self.grid.dims;
        let nearest = |p: DVec3| -> Option<[usize; 3]> {
            let g = self.grid.to_grid(p).round().to_array();
            let within = (0..3).all(|a| g[a] >= 0.0 && g[a] <= (dims[a] - 1) as f64);
            within.then(|| g.map(|c| c as usize))
        };
        let cubes: Vec<usize> =
            seeds.iter().filter_map(|&p| nearest(p)).flat_map(|v| self.cubes_around(v)).collect();
        self.unvisited(cubes)
    }

    /// The cubes that have voxel `v` as a corner.
    fn cubes_around(&self, v: [usize; 3]) -> impl Iterator<Item = usize> + use<F> {
        let grid = self.grid;
        (0..8).filter_map(move |c: usize| {
            let mut base = [0; 3];
            for a in 0..3 {
                base[a] = v[a].checked_sub(c >> a & 1).filter(|&b| b + 2 <= grid.dims[a])?;
            }
            Some(grid.index(base))
        })
    }

    /// A cube holding each crossed grid edge on the coarse lattice's edges whose ends lie on
    /// opposite sides. The lattice has a node every [`LATTICE_STEP`] voxels and at the last
    /// voxel along each axis. The lattice's nodes are evaluated in one batch with `band`.
    fn lattice_cubes(&mut self, band: Vec<usize>) -> Vec<usize> {
        let [xs, ys, zs] = &self.grid.dims.map(lattice_nodes);
        let nodes: Vec<[usize; 3]> = xs
            .par_iter()
            .flat_map_iter(|&i| ys.iter().flat_map(move |&j| zs.iter().map(move |&k| [i, j, k])))
            .collect();
        let mut voxels: Vec<usize> = nodes.par_iter().map(|&v| self.grid.index(v)).collect();
        voxels.extend(band);
        self.evaluate(voxels);
        let this = &*self;
        let edges: Vec<LatticeEdge> = nodes
            .par_iter()
            .flat_map_iter(|&v| (0..3).filter_map(move |axis| this.opposite_edge(v, axis)))
            .collect();
        self.evaluate(edges.par_iter().flat_map_iter(|e| e.voxels(&self.grid)).collect());
        let cubes: Vec<usize> = edges.par_iter().flat_map_iter(|e| self.crossed_on(e)).collect();
        self.unvisited(cubes)
    }

    /// The lattice edge from node `v` along `axis`, if there is one and its ends lie on
    /// opposite sides.
    fn opposite_edge(&self, v: [usize; 3], axis: usize) -> Option<LatticeEdge> {
        let last = self.grid.dims[axis] - 1;
        let length = (LATTICE_STEP).min(last.checked_sub(v[axis])?);
        let edge = LatticeEdge { start: v, axis, length };
        let side = |v: [usize; 3]| inside(self.value(self.grid.index(v)), 0.0);
        (length > 0 && side(v) != side(edge.end())).then_some(edge)
    }

    /// A cube holding each crossed grid edge along lattice edge `e`, whose voxels are known.
    fn crossed_on(&self, e: &LatticeEdge) -> Vec<usize> {
        let voxels: Vec<usize> = e.voxels(&self.grid).collect();
        let dims = self.grid.dims;
        voxels
            .windows(2)
            .filter(|w| inside(self.value(w[0]), 0.0) != inside(self.value(w[1]), 0.0))
            .map(|w| {
                let base = self.grid.voxel(w[0]);
                self.grid.index(std::array::from_fn(|a| base[a].min(dims[a] - 2)))
            })
            .collect()
    }

    /// Visits the cubes of `frontier`: evaluates their corners, keeps those that cross the
    /// surface and returns their unvisited neighbours across crossed faces.
    fn grow(&mut self, frontier: &[usize]) -> Vec<usize> {
        let corners = self.corners;
        self.evaluate(frontier.par_iter().flat_map_iter(|&c| corners.map(|o| c + o)).collect());
        let found: Vec<(usize, u8)> = frontier
            .par_iter()
            .map(|&c| (c, self.corner_values(c).1))
            .filter(|&(_, case)| case != 0 && case != 255)
            .collect();
        let neighbours: Vec<usize> =
            found.par_iter().flat_map_iter(|&(c, case)| self.neighbours(c, case)).collect();
        self.crossing.extend(found.iter().map(|&(c, _)| c));
        self.unvisited(neighbours)
    }

    /// The values at a cube's corners, which are known, and its sign pattern (bit `c` set when
    /// corner `c` is inside).
    fn corner_values(&self, cube: usize) -> ([f64; 8], u8) {
        let values = self.corners.map(|o| self.value(cube + o));
        let case = (0..8).fold(0u8, |case, c| case | (inside(values[c], 0.0) as u8) << c);
        (values, case)
    }

    /// The neighbours of a cube with sign pattern `case` across its faces whose corners are not
    /// all on one side, within the grid.
    fn neighbours(&self, cube: usize, case: u8) -> impl Iterator<Item = usize> {
        let voxel = self.grid.voxel(cube);
        let dims = self.grid.dims;
        let steps = [self.corners[1], self.corners[2], self.corners[4]];
        (0..3).flat_map(move |axis| {
            [0, 1].into_iter().filter_map(move |side| {
                let face = face_mask(axis, side);
                let crossed = case & face != 0 && case & face != face;
                let exists = if side == 0 { voxel[axis] > 0 } else { voxel[axis] + 2 < dims[axis] };
                (crossed && exists)
                    .then(|| if side == 0 { cube - steps[axis] } else { cube + steps[axis] })
            })
        })
    }

    /// The surface of the crossing cubes, in the dense extraction's order.
    fn surface(&mut self) -> Surface {
        self.crossing.par_sort_unstable();
        let keys = self.edge_keys();
        let vertices: Vec<EdgeVertex> = keys.par_iter().map(|&key| self.vertex(key)).collect();
        assert!(vertices.len() <= u32::MAX as usize, "too many surface vertices for u32 indices");
        let index: IndexMap<u32> = keys.iter().enumerate().map(|(n, &k)| (k, n as u32)).collect();
        let triangles: Vec<[u32; 3]> = self
            .crossing
            .par_iter()
            .flat_map_iter(|&cube| {
                let (values, case) = self.corner_values(cube);
                let corner = |c: u8| values[c as usize];
                let lookup = |e: EdgeId| index[&self.edge_key(cube, e)];
                let mut triangles = Vec::new();
                for piece in CASES.pieces(case) {
                    emit(piece, 0.0, corner, lookup, &mut triangles);
                }
                triangles
            })
            .collect();
        Surface { vertices, triangles }
    }

    /// The keys of the edges the crossing cubes' pieces use, sorted and distinct. Each edge is
    /// used by several neighbouring cubes, so the keys of a run of cubes (sorted by index) are
    /// made distinct before all are gathered: the list never holds the several copies.
    fn edge_keys(&self) -> Vec<usize> {
        let mut keys: Vec<usize> = self
            .crossing
            .par_chunks(KEY_RUN)
            .flat_map_iter(|run| {
                let mut keys: Vec<usize> = run
                    .iter()
                    .flat_map(|&cube| {
                        let pieces = CASES.pieces(self.corner_values(cube).1);
                        pieces.iter().flat_map(move |p| {
                            p.edges[..p.len as usize].iter().map(move |&e| self.edge_key(cube, e))
                        })
                    })
                    .collect();
                keys.sort_unstable();
                keys.dedup();
                keys
            })
            .collect();
        keys.par_sort_unstable();
        keys.dedup();
        keys.shrink_to_fit();
        keys
    }

    /// The key of edge `e` of a cube: its base voxel `(i, j, k)` and direction `d` as
    /// `(((2 i + (d & 1)) ny + j) 8 + d) nz + k`, whose order is the dense extraction's vertex
    /// order (by layer, in-plane edges before those to the next layer, then row, direction and
    /// voxel).
    fn edge_key(&self, cube: usize, e: EdgeId) -> usize {
        let [_, ny, nz] = self.grid.dims;
        let [i, j, k] = self.grid.voxel(cube + self.corners[edge_base(e) as usize]);
        let d = edge_direction(e) as usize;
        (((2 * i + (d & 1)) * ny + j) * 8 + d) * nz + k
    }

    /// The vertex on the edge of `key`, linearly interpolated between its ends' values.
    fn vertex(&self, key: usize) -> EdgeVertex {
        let [_, ny, nz] = self.grid.dims;
        let (k, rest) = (key % nz, key / nz);
        let (d, rest) = (rest % 8, rest / 8);
        let (j, i) = (rest % ny, rest / ny / 2);
        let base = self.grid.index([i, j, k]);
        let direction = d as u8;
        let far = base + self.corners[d];
        let t = crossing(self.value(base), self.value(far), 0.0);
        let g = DVec3::new(i as f64, j as f64, k as f64) + t * offset(direction);
        EdgeVertex { position: self.grid.to_world(g), base, direction }
    }

    /// The values along a vertex's edge line at `t = -1, 0, 1, 2` for refinement (NaN outside
    /// the grid), all of them evaluated, as the dense extraction has them.
    fn ends(self) -> impl Fn(&EdgeVertex) -> [f64; 4] + Sync {
        let (grid, values) = (self.grid, self.values);
        move |v: &EdgeVertex| {
            v.line(&grid).map(|n| n.and_then(|n| values.get(n)).unwrap_or(f64::NAN))
        }
    }
}

/// An edge of the coarse lattice: from node `start`, `length` voxels along `axis`.
struct LatticeEdge {
    start: [usize; 3],
    axis: usize,
    length: usize,
}

impl LatticeEdge {
    fn end(&self) -> [usize; 3] {
        let mut end = self.start;
        end[self.axis] += self.length;
        end
    }

    /// The linear indices of the edge's voxels, from its start to its end.
    fn voxels<'g>(&self, grid: &'g Grid) -> impl Iterator<Item = usize> + 'g {
        let (start, axis) = (self.start, self.axis);
        (0..=self.length).map(move |n| {
            let mut v = start;
            v[axis] += n;
            grid.index(v)
        })
    }
}

/// The lattice nodes along an axis of `n` voxels: every [`LATTICE_STEP`]th voxel and the last.
fn lattice_nodes(n: usize) -> Vec<usize> {
    let mut nodes: Vec<usize> = (0..n).step_by(LATTICE_STEP).collect();
    if nodes.last() != Some(&(n - 1)) {
        nodes.push(n - 1);
    }
    nodes
}

/// The corners (as a bit mask) of a cube's face on `side` (0 low, 1 high) of `axis`.
fn face_mask(axis: usize, side: usize) -> u8 {
    (0..8).filter(|c| c >> axis & 1 == side).fold(0, |mask, c| mask | 1 << c)
}
