//! A set of distinct lattice points as an octree's occupancy: one byte per occupied node, a
//! bit per occupied child, breadth first (the coding of point-set geometry in Draco and MPEG
//! G-PCC; [`super::occupancy`] codes the bytes with their context models).
//!
//! Points on a surface cost a few bits each: near the root most children are occupied, near the
//! leaves one child of eight, three bits. The points come back in the octree's order, the
//! Morton order of [`crate::rbf::lattice_order`].

use crate::geometry::{MORTON_BITS, morton_key};

/// The occupancy bytes of `points` (distinct, each coordinate below `2^depth`, `depth` at most
/// [`MORTON_BITS`]), sorted by Morton key as [`crate::rbf::lattice_order`] sorts them.
pub(crate) fn encode(points: &[[u64; 3]], depth: u32) -> Vec<u8> {
    let keys: Vec<u64> = points.iter().map(|&p| morton_key(p)).collect();
    debug_assert!(keys.windows(2).all(|w| w[0] < w[1]), "sorted and distinct");
    let mut masks = Vec::new();
    for d in 0..depth {
        let shift = 3 * (depth - d - 1);
        let mut parent = None;
        for key in &keys {
            let child = key >> shift;
            let (node, bit) = (child >> 3, child & 7);
            if parent != Some(node) {
                masks.push(0u8);
                parent = Some(node);
            }
            *masks.last_mut().expect("pushed above") |= 1 << bit;
        }
    }
    masks
}

/// The occupancy bytes `masks` of one octree, each with its depth (0 at the root): the first
/// byte is the root's, and each level holds as many bytes as the one above has occupied
/// children.
pub(crate) fn depths(masks: &[u8]) -> impl Iterator<Item = (u32, u8)> + '_ {
    let (mut depth, mut left, mut next) = (0, 1usize, 0usize);
    masks.iter().map(move |&mask| {
        if left == 0 {
            (depth, left, next) = (depth + 1, next, 0);
        }
        left -= 1;
        next += mask.count_ones() as usize;
        (depth, mask)
    })
}

/// The points of an octree of `depth` levels whose occupancy bytes `mask(d)` gives, node by
/// node breadth first (`d` the node's depth), in Morton order; `count` is the number of points,
/// no byte asked for beyond them.
///
/// # Errors
/// A message when `mask` fails, a node has no child, or a level holds more nodes than `count`.
pub(crate) fn decode(
    mut mask: impl FnMut(u32) -> Result<u8, String>,
    depth: u32,
    count: usize,
) -> Result<Vec<[u64; 3]>, String> {
    if depth > MORTON_BITS {
        return Err(format!("an octree of depth {depth} (at most {MORTON_BITS})"));
    }
    let mut nodes: Vec<u64> = if count == 0 { Vec::new() } else { vec![0] };
    for d in 0..depth {
        let mut next = Vec::with_capacity(nodes.len() * 2);
        for &node in &nodes {
            let mask = mask(d)?;
            if mask == 0 {
                return Err("an octree node without children".into());
            }
            next.extend((0..8).filter(|b| mask >> b & 1 == 1).map(|b| node << 3 | b));
            if next.len() > count {
                return Err(format!("the octree holds more than its {count} points"));
            }
        }
        nodes = next;
    }
    if nodes.len() != count {
        return Err(format!("the octree holds {} points, not {count}", nodes.len()));
    }
    Ok(nodes.into_iter().map(coordinates).collect())
}

/// The next occupancy byte of `masks` (which it consumes), for [`decode`] of bytes as they are.
///
/// # Errors
/// A message when the bytes run out.
pub(crate) fn next_byte(masks: &mut &[u8]) -> Result<u8, String> {
    let (&mask, rest) = masks.split_first().ok_or("the octree's occupancy ends early")?;
    *masks = rest;
    Ok(mask)
}

/// The coordinates of a Morton key (the inverse of [`morton_key`]).
fn coordinates(key: u64) -> [u64; 3] {
    [compact(key >> 2), compact(key >> 1), compact(key)]
}

/// Every third bit of `v`, from bit 0, packed together.
fn compact(v: u64) -> u64 {
    let mut x = v & 0x1249_2492_4924_9249;
    x = (x | (x >> 2)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x >> 4)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x >> 8)) & 0x001f_0000_ff00_00ff;
    x = (x | (x >> 16)) & 0x001f_0000_0000_ffff;
    x = (x | (x >> 32)) & 0x1f_ffff;
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_morton_key_gives_its_coordinates_back() {
        for p in [[0, 0, 0], [1, 2, 3], [(1 << 21) - 1, 12345, 777_777]] {
            assert_eq!(coordinates(morton_key(p)), p);
        }
    }

    #[test]
    fn points_come_back_in_morton_order_and_damage_is_refused() {
        let mut points: Vec<[u64; 3]> =
            (0..500u64).map(|i| [(i * 37) % 200, (i * 91) % 150 + 3, (i * i) % 256]).collect();
        points.sort_by_key(|&p| morton_key(p));
        points.dedup();
        let masks = encode(&points, 8);
        let bytes = |masks: &[u8], count| {
            let mut read = masks;
            decode(|_| next_byte(&mut read), 8, count).map(|p| (p, read.is_empty()))
        };
        assert_eq!(bytes(&masks, points.len()).unwrap(), (points.clone(), true));
        assert!(bytes(&masks[..masks.len() - 1], points.len()).is_err());
        assert!(bytes(&masks, points.len() - 1).is_err());
        let mut zeroed = masks.clone();
        zeroed[3] = 0;
        assert!(bytes(&zeroed, points.len()).is_err());
        let none = |_| Err("no byte".to_string());
        assert_eq!(decode(none, 0, 0).unwrap(), Vec::<[u64; 3]>::new());
        assert_eq!(decode(none, 0, 1).unwrap(), vec![[0, 0, 0]]);
        // Each byte's depth: one root, then as many bytes as the level above has children.
        let levels: Vec<u32> = depths(&masks).map(|(d, _)| d).collect();
        assert_eq!(levels.len(), masks.len());
        assert!(levels.windows(2).all(|w| w[1] == w[0] || w[1] == w[0] + 1));
        assert_eq!((levels[0], levels[1], levels[masks.len() - 1]), (0, 1, 7));
        let leaves: u32 =
            depths(&masks).filter(|&(d, _)| d == 7).map(|(_, m)| m.count_ones()).sum();
        assert_eq!(leaves as usize, points.len());
    }
}
