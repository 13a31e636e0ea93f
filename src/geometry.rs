//! Small geometric types shared by every stage: points and axis-aligned boxes.
//!
//! Positions are `f64` ([`DVec3`] from glam) everywhere a position is stored, so a mesh far
//! from the origin or in large units loses nothing before it is normalized onto a grid.

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
