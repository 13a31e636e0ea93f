//! A set of distinct lattice points as an octree's occupancy: one byte per occupied node, a
//! bit per occupied child, breadth first (the coding of point-set geometry in Draco and MPEG
//! G-PCC, here without their context models; the model file's compressor codes the bytes).
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

/// The points of an octree of `depth` levels read from `masks` (which it consumes), in Morton
/// order; `count` is the number of points, none read beyond it.
///
/// # Errors
/// A message when the bytes run out, a node has no child, or a level holds more nodes than
/// `count`.
pub(crate) fn decode(masks: &mut &[u8], depth: u32, count: usize) -> Result<Vec<[u64; 3]>, String> {
    if depth > MORTON_BITS {
        return Err(format!("an octree of depth {depth} (at most {MORTON_BITS})"));
    }
    let mut nodes: Vec<u64> = if count == 0 { Vec::new() } else { vec![0] };
    for _ in 0..depth {
        let (level, rest) =
            masks.split_at_checked(nodes.len()).ok_or("the octree's occupancy ends early")?;
        *masks = rest;
        let mut next = Vec::with_capacity(nodes.len() * 2);
        for (&node, &mask) in nodes.iter().zip(level) {
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
        let mut read = &masks[..];
        assert_eq!(decode(&mut read, 8, points.len()).unwrap(), points);
        assert!(read.is_empty());
        let mut short = &masks[..masks.len() - 1];
        assert!(decode(&mut short, 8, points.len()).is_err());
        let mut fewer = &masks[..];
        assert!(decode(&mut fewer, 8, points.len() - 1).is_err());
        let mut zeroed = masks.clone();
        zeroed[3] = 0;
        assert!(decode(&mut &zeroed[..], 8, points.len()).is_err());
        assert_eq!(decode(&mut &[][..], 0, 0).unwrap(), Vec::<[u64; 3]>::new());
        assert_eq!(decode(&mut &[][..], 0, 1).unwrap(), vec![[0, 0, 0]]);
    }
}
