//! Random query points, seeded.

use implicitize::{Aabb, DVec3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `n` points uniform in `bounds` grown by `pad` on every side, from generator `seed`.
pub fn random_points(bounds: &Aabb, pad: f64, n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (lo, hi) = (bounds.min - pad, bounds.max + pad);
    (0..n)
        .map(|_| {
            DVec3::new(
                rng.random_range(lo.x..hi.x),
                rng.random_range(lo.y..hi.y),
                rng.random_range(lo.z..hi.z),
            )
        })
        .collect()
}
