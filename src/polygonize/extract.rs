//! Marching tetrahedra over a volume, in parallel over slabs of `i` layers.
//!
//! Each slab owns the surface vertices on the grid edges that start in its layers, and keeps
//! them in rolling per-layer maps from edge to vertex index (three in-plane directions per
//! layer, four directions to the next layer), so a vertex is made once and shared by every
//! triangle that uses it. The in-plane edges of the layer just past a slab belong to the next
//! slab; triangles that use them carry [`EXTERNAL`] references that are resolved once every
//! slab is done. Nothing is allocated per voxel: a slab allocates its maps once.

use rayon::prelude::*;

use super::tables::{CASES, EdgeId, Piece, edge_base, edge_direction, offset};
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};
use crate::mesh::Mesh;

/// How far from an edge's ends a vertex is kept, as a fraction of the edge.
///
/// A value exactly at the iso level counts as inside, which would put every vertex on the
/// edges around that voxel at its centre and collapse their triangles to zero area. Keeping
/// vertices this far inside their edges keeps every triangle's corners apart (a triangle's
/// corners lie on three distinct edges of one tetrahedron, never all on a line through a
/// corner) at the cost of at most 0.002 voxel of position.
pub(super) const END_MARGIN: f64 = 1e-3;

/// Marks a triangle corner that refers to the next slab's first layer.
const EXTERNAL: u32 = 1 << 31;

/// A volume value: f32 for stored volumes, f64 for sampled fields.
pub(super) trait Sample: Copy + Send + Sync + PartialOrd + Into<f64> {}
impl Sample for f32 {}
impl Sample for f64 {}

/// A surface vertex and the grid edge it lies on.
#[derive(Debug, Clone, Copy)]
pub(super) struct EdgeVertex {
    /// Position in the mesh's own units.
    pub position: DVec3,
    /// Linear index of the edge's base voxel.
    pub base: usize,
    /// Direction of the edge from its base (axis mask, 1..=7).
    pub direction: u8,
}

impl EdgeVertex {
    /// The voxels on the edge's line one step before its base, at its base, at its far end
    /// and one step past it (`t = -1, 0, 1, 2`), those outside the grid `None`.
    pub(super) fn line(&self, grid: &Grid) -> [Option<usize>; 4] {
        let base = grid.voxel(self.base);
        let d = |bit: u8| (self.direction >> bit & 1) as isize;
        [-1, 0, 1, 2].map(|t: isize| {
            let mut v = [0; 3];
            for (a, bit) in [0u8, 1, 2].into_iter().enumerate() {
                let c = base[a] as isize + t * d(bit);
                v[a] = usize::try_from(c).ok().filter(|&c| c < grid.dims[a])?;
            }
            Some(grid.index(v))
        })
    }
}

/// The extracted surface before it becomes a [`Mesh`].
#[derive(Debug, Default)]
pub(super) struct Surface {
    pub vertices: Vec<EdgeVertex>,
    pub triangles: Vec<[u32; 3]>,
}

impl Surface {
    pub(super) fn into_mesh(self) -> Mesh {
        Mesh {
            vertices: self.vertices.par_iter().map(|v| v.position).collect(),
            triangles: self.triangles,
        }
    }
}

/// Whether a value counts as inside (at or above the iso level; NaN is outside).
#[inline(always)]
pub(super) fn inside<T: Sample>(value: T, iso: T) -> bool {
    value >= iso
}

/// Where the iso level crosses an edge from value `a` (t = 0) to `b` (t = 1), kept within
/// [`END_MARGIN`] of the ends.
#[inline]
pub(super) fn crossing<T: Sample>(a: T, b: T, iso: T) -> f64 {
    let (a, b, iso): (f64, f64, f64) = (a.into(), b.into(), iso.into());
    let t = (iso - a) / (b - a);
    if t.is_nan() { 0.5 } else { t.clamp(END_MARGIN, 1.0 - END_MARGIN) }
}

/// Extracts the iso-surface of `volume` at `iso` (inside is `>= iso`).
pub(super) fn extract<T: Sample>(volume: &Volume<T>, iso: T) -> Surface {
    let grid = &volume.grid;
    assert_eq!(volume.data.len(), grid.len(), "a volume must hold one value per voxel of its grid");
    let [nx, ny, nz] = grid.dims;
    if nx < 2 || ny < 2 || nz < 2 {
        return Surface::default();
    }
    let signs = Signs::of(volume, iso);
    let slab = Slabber { volume, iso, signs: &signs };
    let count = (rayon::current_num_threads() * 4).clamp(1, nx - 1);
    let slabs: Vec<SlabSurface> = (0..count)
        .into_par_iter()
        .map(|s| slab.march(s * nx / count, (s + 1) * nx / count))
        .collect();
    stitch(slabs)
}

/// Which voxels are inside, one bit per voxel, each row of `k` in whole 64-bit words.
///
/// Crossing edges and cubes with mixed corners are found a word at a time from these bits, so
/// the values themselves are read only where the surface is.
struct Signs {
    words: usize,
    bits: Vec<u64>,
}

impl Signs {
    fn of<T: Sample>(volume: &Volume<T>, iso: T) -> Signs {
        let nz = volume.grid.dims[2];
        let words = nz.div_ceil(64);
        let mut bits = vec![0u64; volume.data.len() / nz * words];
        bits.par_chunks_mut(words).zip(volume.data.par_chunks(nz)).for_each(|(row_bits, row)| {
            for (word, values) in row_bits.iter_mut().zip(row.chunks(64)) {
                let mut w = 0u64;
                for (b, &v) in values.iter().enumerate() {
                    w |= (inside(v, iso) as u64) << b;
                }
                *word = w;
            }
        });
        Signs { words, bits }
    }

    /// The bits of row `(i, j)`.
    #[inline]
    fn row(&self, ny: usize, i: usize, j: usize) -> &[u64] {
        &self.bits[(i * ny + j) * self.words..][..self.words]
    }
}

/// Word `w` of a row's bits moved down by one voxel (bit `k` holds voxel `k + 1`).
#[inline(always)]
fn shifted(row: &[u64], w: usize) -> u64 {
    row[w] >> 1 | row.get(w + 1).map_or(0, |next| next << 63)
}

/// The bits of word `w` that stand for voxels `k < n`.
#[inline(always)]
fn below(n: usize, w: usize) -> u64 {
    match n.saturating_sub(w * 64) {
        0 => 0,
        m if m >= 64 => !0,
        m => (1 << m) - 1,
    }
}

/// Calls `f(k)` for every set bit `k` of `bits(w)` over the words of a row.
#[inline(always)]
fn for_each_bit(words: usize, bits: impl Fn(usize) -> u64, mut f: impl FnMut(usize)) {
    for w in 0..words {
        let mut x = bits(w);
        while x != 0 {
            f(w * 64 + x.trailing_zeros() as usize);
            x &= x - 1;
        }
    }
}

/// The bit of voxel `k` in a row.
#[inline(always)]
fn bit(row: &[u64], k: usize) -> u8 {
    (row[k / 64] >> (k % 64)) as u8 & 1
}

/// The surface of one slab, with vertex indices local to it.
struct SlabSurface {
    vertices: Vec<EdgeVertex>,
    triangles: Vec<[u32; 3]>,
    /// The vertex map of the in-plane edges of the slab's first layer.
    first_layer: Vec<u32>,
}

/// Marches the slabs of one volume.
struct Slabber<'a, T> {
    volume: &'a Volume<T>,
    iso: T,
    signs: &'a Signs,
}

/// In-plane directions (y, z, yz) and their slots in a layer map.
const IN_PLANE: [(u8, usize); 3] = [(2, 0), (4, 1), (6, 2)];
/// Directions to the next layer (x, xy, xz, xyz) and their slots in a cross map.
const ACROSS: [(u8, usize); 4] = [(1, 0), (3, 1), (5, 2), (7, 3)];

/// Which map holds an edge's vertex, seen from the cube it belongs to.
#[derive(Clone, Copy)]
enum MapKind {
    /// In-plane edges of the cube's first layer.
    Layer,
    /// Edges from the cube's first layer to its second.
    Across,
    /// In-plane edges of the cube's second layer.
    NextLayer,
}

/// Where a cube edge's vertex is kept: the map, the (j, k) offset and the slot.
#[derive(Clone, Copy)]
struct EdgeSlot {
    map: MapKind,
    dj: usize,
    dk: usize,
    slot: usize,
}

fn edge_slot(e: EdgeId) -> EdgeSlot {
    let (base, dir) = (edge_base(e), edge_direction(e));
    let (dj, dk) = ((base >> 1 & 1) as usize, (base >> 2 & 1) as usize);
    let (map, slot) = match (base & 1, dir & 1) {
        (1, _) => (MapKind::NextLayer, (dir >> 1) as usize - 1),
        (_, 1) => (MapKind::Across, (dir >> 1) as usize),
        _ => (MapKind::Layer, (dir >> 1) as usize - 1),
    };
    EdgeSlot { map, dj, dk, slot }
}

impl<T: Sample> Slabber<'_, T> {
    fn grid(&self) -> &Grid {
        &self.volume.grid
    }

    #[inline(always)]
    fn value(&self, i: usize, j: usize, k: usize) -> T {
        self.volume.data[self.grid().index([i, j, k])]
    }

    /// Marches the cubes of layers `i0..i1` (and owns the vertices starting in them).
    fn march(&self, i0: usize, i1: usize) -> SlabSurface {
        let [nx, ny, nz] = self.grid().dims;
        let plane = ny * nz;
        let mut out =
            SlabSurface { vertices: Vec::new(), triangles: Vec::new(), first_layer: Vec::new() };
        let mut layer = vec![0u32; 3 * plane];
        let mut next = vec![0u32; 3 * plane];
        let mut across = vec![0u32; 4 * plane];
        self.make_vertices(i0, &IN_PLANE, &mut layer, &mut out.vertices);
        out.first_layer = layer.clone();
        for i in i0..i1.min(nx - 1) {
            self.make_vertices(i, &ACROSS, &mut across, &mut out.vertices);
            let next_is_ours = i + 1 < i1;
            if next_is_ours {
                self.make_vertices(i + 1, &IN_PLANE, &mut next, &mut out.vertices);
            }
            let maps = [&layer[..], &across[..], if next_is_ours { &next[..] } else { &[] }];
            self.march_layer(i, maps, &mut out.triangles);
            std::mem::swap(&mut layer, &mut next);
        }
        assert!(
            out.vertices.len() < EXTERNAL as usize,
            "too many surface vertices for u32 indices"
        );
        out
    }

    /// Adds the vertex on the edge from voxel `(i, j, k)` along `direction`, which the surface
    /// crosses, and records its index in `slot`.
    #[inline(always)]
    fn edge_vertex(
        &self,
        [i, j, k]: [usize; 3],
        direction: u8,
        slot: &mut u32,
        vertices: &mut Vec<EdgeVertex>,
    ) {
        let d = |bit: u8| (direction >> bit & 1) as usize;
        let a = self.value(i, j, k);
        let b = self.value(i + d(0), j + d(1), k + d(2));
        let t = crossing(a, b, self.iso);
        let g = DVec3::new(i as f64, j as f64, k as f64) + t * offset(direction);
        *slot = vertices.len() as u32;
        vertices.push(EdgeVertex {
            position: self.grid().to_world(g),
            base: self.grid().index([i, j, k]),
            direction,
        });
    }

    /// Makes the vertices on the edges from voxels of layer `i` along `directions` (the
    /// in-plane ones, or the ones to layer `i + 1`), recording them in `map`.
    fn make_vertices(
        &self,
        i: usize,
        directions: &[(u8, usize)],
        map: &mut [u32],
        vertices: &mut Vec<EdgeVertex>,
    ) {
        let [_, ny, nz] = self.grid().dims;
        let words = self.signs.words;
        let slots = directions.len();
        for j in 0..ny {
            let here = self.signs.row(ny, i, j);
            for &(direction, slot) in directions {
                let (dx, dy, dz) = (
                    (direction & 1) as usize,
                    (direction >> 1 & 1) as usize,
                    direction >> 2 & 1 == 1,
                );
                if j + dy == ny {
                    continue;
                }
                let there = self.signs.row(ny, i + dx, j + dy);
                let valid = if dz { nz - 1 } else { nz };
                let crossing = |w: usize| {
                    (here[w] ^ if dz { shifted(there, w) } else { there[w] }) & below(valid, w)
                };
                for_each_bit(words, crossing, |k| {
                    self.edge_vertex(
                        [i, j, k],
                        direction,
                        &mut map[(j * nz + k) * slots + slot],
                        vertices,
                    );
                });
            }
        }
    }

    /// Emits the triangles of the cubes between layers `i` and `i + 1`. `maps` holds the
    /// vertex maps of layer `i`, of the edges across, and of layer `i + 1` (empty when that
    /// layer belongs to the next slab).
    fn march_layer(&self, i: usize, maps: [&[u32]; 3], triangles: &mut Vec<[u32; 3]>) {
        let [_, ny, nz] = self.grid().dims;
        let slots: [EdgeSlot; 64] = std::array::from_fn(|e| edge_slot(e as EdgeId));
        let cases = &*CASES;
        let words = self.signs.words;
        for j in 0..ny - 1 {
            // The four rows of corners, in corner-bit order (x is bit 0, y bit 1).
            let rows: [&[u64]; 4] =
                std::array::from_fn(|c| self.signs.row(ny, i + (c & 1), j + (c >> 1)));
            let mixed = |w: usize| {
                let any = rows[0][w] | rows[1][w] | rows[2][w] | rows[3][w];
                let all = rows[0][w] & rows[1][w] & rows[2][w] & rows[3][w];
                let any_next = shifted(rows[0], w)
                    | shifted(rows[1], w)
                    | shifted(rows[2], w)
                    | shifted(rows[3], w);
                let all_next = shifted(rows[0], w)
                    & shifted(rows[1], w)
                    & shifted(rows[2], w)
                    & shifted(rows[3], w);
                (any | any_next) & !(all & all_next) & below(nz - 1, w)
            };
            for_each_bit(words, mixed, |k| {
                let case = (0..4).fold(0u8, |case, c| {
                    case | bit(rows[c], k) << c | bit(rows[c], k + 1) << (c + 4)
                });
                let lookup = |e: EdgeId| -> u32 {
                    let s = slots[e as usize];
                    let cell = (j + s.dj) * nz + k + s.dk;
                    match s.map {
                        MapKind::Layer => maps[0][cell * 3 + s.slot],
                        MapKind::Across => maps[1][cell * 4 + s.slot],
                        MapKind::NextLayer if maps[2].is_empty() => {
                            EXTERNAL | (cell * 3 + s.slot) as u32
                        }
                        MapKind::NextLayer => maps[2][cell * 3 + s.slot],
                    }
                };
                let corner = |m: u8| {
                    let d = |bit: u8| (m >> bit & 1) as usize;
                    self.value(i + d(0), j + d(1), k + d(2))
                };
                for piece in cases.pieces(case) {
                    emit(piece, self.iso, corner, lookup, triangles);
                }
            });
        }
    }
}

/// Emits one tetrahedron's piece of a cube whose corner `c` has the value `corner(c)`; a quad
/// is split along its shorter diagonal. `lookup` gives the index of the vertex on a cube edge.
#[inline]
pub(super) fn emit<T: Sample>(
    piece: &Piece,
    iso: T,
    corner: impl Fn(u8) -> T,
    lookup: impl Fn(EdgeId) -> u32,
    triangles: &mut Vec<[u32; 3]>,
) {
    let e = piece.edges;
    let [a, b, c] = [lookup(e[0]), lookup(e[1]), lookup(e[2])];
    if piece.len == 3 {
        triangles.push([a, b, c]);
        return;
    }
    let d = lookup(e[3]);
    let p = e.map(|edge| edge_point(&corner, iso, edge));
    if p[0].distance_squared(p[2]) <= p[1].distance_squared(p[3]) {
        triangles.push([a, b, c]);
        triangles.push([a, c, d]);
    } else {
        triangles.push([a, b, d]);
        triangles.push([b, c, d]);
    }
}

/// The crossing on cube edge `e` of a cube whose corner `c` has the value `corner(c)`, in voxel
/// coordinates relative to the cube.
#[inline]
fn edge_point<T: Sample>(corner: impl Fn(u8) -> T, iso: T, e: EdgeId) -> DVec3 {
    let (base, dir) = (edge_base(e), edge_direction(e));
    offset(base) + crossing(corner(base), corner(base | dir), iso) * offset(dir)
}

/// Joins the slabs into one surface, resolving references to each next slab's first layer.
fn stitch(slabs: Vec<SlabSurface>) -> Surface {
    let mut vertex_start = Vec::with_capacity(slabs.len());
    let (mut nv, mut nt) = (0usize, 0usize);
    for s in &slabs {
        vertex_start.push(nv);
        nv += s.vertices.len();
        nt += s.triangles.len();
    }
    assert!(nv <= u32::MAX as usize, "too many surface vertices for u32 indices");
    let mut triangles = vec![[0u32; 3]; nt];
    let mut vertices = vec![EdgeVertex { position: DVec3::ZERO, base: 0, direction: 0 }; nv];
    let triangle_parts = split_by(&mut triangles, slabs.iter().map(|s| s.triangles.len()));
    let vertex_parts = split_by(&mut vertices, slabs.iter().map(|s| s.vertices.len()));
    triangle_parts.into_par_iter().zip(vertex_parts).enumerate().for_each(
        |(n, (triangles, vertices))| {
            let own = vertex_start[n] as u32;
            let resolve = |v: u32| {
                if v & EXTERNAL == 0 {
                    own + v
                } else {
                    let next = &slabs[n + 1];
                    vertex_start[n + 1] as u32 + next.first_layer[(v & !EXTERNAL) as usize]
                }
            };
            for (out, t) in triangles.iter_mut().zip(&slabs[n].triangles) {
                *out = t.map(resolve);
            }
            vertices.copy_from_slice(&slabs[n].vertices);
        },
    );
    Surface { vertices, triangles }
}

/// Splits `items` into consecutive parts of the given lengths.
fn split_by<T>(mut items: &mut [T], lengths: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut parts = Vec::new();
    for n in lengths {
        let (part, rest) = items.split_at_mut(n);
        parts.push(part);
        items = rest;
    }
    parts
}
