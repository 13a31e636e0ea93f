//! Small geometric types shared by every stage: points, axis-aligned boxes, and the hash grid
//! of cubic cells that finds the points near a point.
//!
//! Positions are `f64` ([`DVec3`] from glam) everywhere a position is stored, so a mesh far
//! from the origin or in large units loses nothing before it is normalized onto a grid.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

pub use glam::DVec3;

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The smallest corner.
    pub min: DVec3,
    /// The largest corner.
    pub max: DVec3,
}

impl Aabb {
    /// The smallest box holding every point, or `None` when there are none.
    pub fn of_points<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> Option<Aabb> {
        let mut it = points.into_iter();
        let first = *it.next()?;
        Some(it.fold(Aabb { min: first, max: first }, |b, &p| Aabb {
            min: b.min.min(p),
            max: b.max.max(p),
        }))
    }

    /// The box's extent along each axis.
    pub fn size(&self) -> DVec3 {
        self.max - self.min
    }

    /// The box's centre.
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// The length of the box's diagonal.
    pub fn diagonal(&self) -> f64 {
        self.size().length()
    }
}

/// Bits of each coordinate in a [`morton_key`]: three coordinates fill 63 bits.
pub(crate) const MORTON_BITS: u32 = 21;

/// The Morton (Z-order) key of a cell's integer coordinates, each below `2^MORTON_BITS`: their
/// bits interleaved, so that cells sorted by key follow a space-filling curve on which
/// neighbours are mostly neighbours in space.
pub(crate) fn morton_key([x, y, z]: [u64; 3]) -> u64 {
    (spread(x) << 2) | (spread(y) << 1) | spread(z)
}

/// The low 21 bits of `v`, two zero bits after each.
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    (x | (x << 2)) & 0x1249_2492_4924_9249
}

/// Items at points hashed into cubic cells of side `side`, so that those within `side` of a
/// point are found among the 27 cells around its own, in time proportional to what those cells
/// hold rather than to all the items: the one hash grid of the crate (the fit's constraint
/// spacing, the goal's surface disks, the detail levels' points and centres).
#[derive(Debug, Clone)]
pub(crate) struct Cells<T> {
    side: f64,
    map: CellMap<Vec<T>>,
}

impl<T> Cells<T> {
    /// No items, in cells of side `side`.
    pub(crate) fn new(side: f64) -> Cells<T> {
        Cells { side, map: CellMap::default() }
    }

    /// The integer coordinates of the cell holding `p`.
    pub(crate) fn cell(&self, p: DVec3) -> [i64; 3] {
        cell_of(p, self.side)
    }

    /// Files `item` under the cell of `p`.
    pub(crate) fn insert(&mut self, p: DVec3, item: T) {
        self.map.entry(cell_key(self.cell(p))).or_default().push(item);
    }

    /// The items of `cell`, in the order they were inserted.
    pub(crate) fn in_cell(&self, cell: [i64; 3]) -> &[T] {
        self.map.get(&cell_key(cell)).map_or(&[], Vec::as_slice)
    }

    /// The items of the 27 cells around the cell of `p`, its own first: every item within
    /// `side` of `p`, and some more.
    pub(crate) fn near(&self, p: DVec3) -> impl Iterator<Item = &T> + '_ {
        let home = self.cell(p);
        AROUND.iter().flat_map(move |d| self.in_cell(std::array::from_fn(|a| home[a] + d[a])))
    }

    /// The distance from `q` to the box of `cell`.
    pub(crate) fn box_distance(&self, q: DVec3, cell: [i64; 3]) -> f64 {
        let lo = DVec3::from_array(cell.map(|c| c as f64)) * self.side;
        let outside = (lo - q).max(q - (lo + DVec3::splat(self.side))).max(DVec3::ZERO);
        outside.length()
    }
}

/// The offsets of the 27 cells around a cell, its own first.
pub(crate) const AROUND: [[i64; 3]; 27] = {
    let mut around = [[0; 3]; 27];
    let mut n = 1;
    let mut i = 0;
    while i < 27 {
        let offset = [i as i64 / 9 - 1, i as i64 / 3 % 3 - 1, i as i64 % 3 - 1];
        if i != 13 {
            around[n] = offset;
            n += 1;
        }
        i += 1;
    }
    around
};

/// A table keyed by [`cell_key`].
pub(crate) type CellMap<V> = HashMap<u64, V, BuildHasherDefault<CellHasher>>;

/// Bits of each coordinate in a [`cell_key`].
const KEY_BITS: u32 = 21;

/// The key of the cell of integer coordinates `c` in a [`CellMap`]: their low [`KEY_BITS`] bits
/// packed. Cells `2^KEY_BITS` apart share a key (far beyond any grid of the crate); a reader
/// of such a cell finds items too far to count, which every reader checks.
#[inline]
pub(crate) fn cell_key(c: [i64; 3]) -> u64 {
    let mask = (1u64 << KEY_BITS) - 1;
    c.iter().fold(0, |key, &x| (key << KEY_BITS) | (x as u64 & mask))
}

/// The integer coordinates of the cell of side `side` holding `p`.
#[inline]
pub(crate) fn cell_of(p: DVec3, side: f64) -> [i64; 3] {
    (p / side).floor().as_i64vec3().to_array()
}

/// A hasher for cell keys (one `u64` each): a multiply and a fold, enough for keys that pack
/// small integer triples (std's default SipHash costs several times more per lookup).
#[derive(Default)]
pub(crate) struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }

    fn write_u64(&mut self, v: u64) {
        let h = (self.0 ^ v).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.0 = h ^ (h >> 29);
    }
}
