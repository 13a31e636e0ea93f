//! The lattice of a compact function: the points its centres may occupy and the steps of its
//! weights and values, so that a model file stores them as small integers (see
//! `model/binary.rs`).
//!
//! A centre on the lattice is `origin + cell * k` for integers `k` (per axis, in f64), a weight
//! `weight_step * k`, a constraint's value `value_step * k`. A function whose numbers all lie on
//! its lattice ([`Implicit::lattice`](crate::rbf::Implicit::lattice),
//! [`DetailLevel::lattice`](crate::rbf::DetailLevel::lattice)) is stored as those integers and
//! read back bit for bit: [`Lattice::index`] finds `k` and checks that it gives the number back
//! exactly.

use crate::geometry::{DVec3, MORTON_BITS, morton_key};

/// Where the numbers of a compact function lie (see the module doc). Mesh units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lattice {
    /// The lattice point `(0, 0, 0)`.
    pub origin: DVec3,
    /// The spacing of the lattice's points.
    pub cell: f64,
    /// Every weight is a whole multiple of this.
    pub weight_step: f64,
    /// Every constraint value (of a thin-plate function) is a whole multiple of this.
    pub value_step: f64,
}

/// Integers beyond this size are not lattice indices: their products lose exactness.
const MAX_INDEX: f64 = (1u64 << 40) as f64;

impl Lattice {
    /// The lattice point `k`.
    #[inline]
    pub fn point(&self, k: [i64; 3]) -> DVec3 {
        self.origin + DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64) * self.cell
    }

    /// The index of the lattice point nearest to `p`, or None when it is too far out to be
    /// stored exactly.
    pub fn nearest(&self, p: DVec3) -> Option<[i64; 3]> {
        let k = ((p - self.origin) / self.cell).round();
        (k.abs().max_element() < MAX_INDEX).then(|| k.as_i64vec3().to_array())
    }

    /// The index of `p` when it is exactly a lattice point.
    pub fn index(&self, p: DVec3) -> Option<[i64; 3]> {
        self.nearest(p).filter(|&k| self.point(k) == p)
    }

    /// The multiple of `step` nearest to `x` (its integer), None when too large.
    pub fn nearest_multiple(x: f64, step: f64) -> Option<i64> {
        let k = (x / step).round();
        (k.abs() < MAX_INDEX).then_some(k as i64)
    }

    /// The integer `k` with `k * step == x` exactly.
    pub fn multiple(x: f64, step: f64) -> Option<i64> {
        Lattice::nearest_multiple(x, step).filter(|&k| k as f64 * step == x)
    }

    /// Whether every step and the origin are finite, and the steps positive.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && [self.cell, self.weight_step, self.value_step]
                .iter()
                .all(|s| s.is_finite() && *s > 0.0)
    }
}

/// The order of lattice points `keys` along the Morton curve of their offsets from the
/// smallest coordinate of each axis: the order in which an octree over them lists them (the
/// order of a compact function's centres, see `model/binary.rs`). None when they span
/// `2^MORTON_BITS` points or more along an axis.
pub(crate) fn morton_order(keys: &[[i64; 3]]) -> Option<Vec<usize>> {
    let (lo, hi) = extent(keys)?;
    let span = (0..3).map(|a| hi[a] - lo[a]).max().unwrap_or(0);
    if span >= 1 << MORTON_BITS {
        return None;
    }
    let key = |k: &[i64; 3]| morton_key([0, 1, 2].map(|a| (k[a] - lo[a]) as u64));
    let mut order: Vec<usize> = (0..keys.len()).collect();
    order.sort_by_cached_key(|&i| key(&keys[i]));
    Some(order)
}

/// The smallest and largest coordinate of each axis, None for no points.
pub(crate) fn extent(keys: &[[i64; 3]]) -> Option<([i64; 3], [i64; 3])> {
    let first = *keys.first()?;
    Some(keys.iter().fold((first, first), |(lo, hi), k| {
        ([0, 1, 2].map(|a| lo[a].min(k[a])), [0, 1, 2].map(|a| hi[a].max(k[a])))
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lattice_point_is_found_again_exactly_and_others_are_not() {
        let lattice = Lattice {
            origin: DVec3::new(-12.345, 1e5 + 0.1, 3.0),
            cell: 0.013,
            weight_step: 1e-3,
            value_step: 1e-2,
        };
        for k in [[0, 0, 0], [1, -2, 3], [123_456, 7, -99_999]] {
            let p = lattice.point(k);
            assert_eq!(lattice.index(p), Some(k));
        }
        let off = lattice.point([5, 5, 5]) + DVec3::splat(0.004);
        assert_eq!(lattice.nearest(off), Some([5, 5, 5]));
        assert_eq!(lattice.index(off), None);
        assert_eq!(Lattice::multiple(37.0 * 1e-3, 1e-3), Some(37));
        assert_eq!(Lattice::multiple(0.0371, 1e-3), None);
        assert_eq!(lattice.nearest(DVec3::splat(1e300)), None);
    }
}
