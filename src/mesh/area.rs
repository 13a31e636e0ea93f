//! Points drawn on a mesh's surface uniformly by area: a triangle chosen with probability
//! proportional to its area, a point uniform on it. The signed-distance samples
//! ([`crate::sample`]) and the surface metrics ([`crate::metrics::surface`]) draw their
//! points here, in blocks of [`BLOCK`] points each drawn from its own random stream, so the
//! points do not depend on the number of threads.

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::Distribution;
use rand_distr::weighted::WeightedAliasIndex;
use rayon::prelude::*;

use crate::geometry::DVec3;
use crate::mesh::Mesh;

/// Points drawn from one random stream.
pub(crate) const BLOCK: usize = 1 << 14;

/// A mesh's surface to draw points on, uniformly by area: the triangles' corners and an alias
/// table of their areas (Walker's method, [`WeightedAliasIndex`]), which draws a triangle in
/// constant time.
pub(crate) struct ByArea {
    corners: Vec<[DVec3; 3]>,
    triangles: WeightedAliasIndex<f64>,
}

impl ByArea {
    /// The surface of `mesh`; `None` where its triangles have no area (or a corner's index is
    /// out of range, or an area is not finite).
    pub(crate) fn of(mesh: &Mesh) -> Option<ByArea> {
        let corner = |i: u32| mesh.vertices.get(i as usize).copied();
        let corners: Vec<[DVec3; 3]> = mesh
            .triangles
            .par_iter()
            .map(|&[a, b, c]| Some([corner(a)?, corner(b)?, corner(c)?]))
            .collect::<Option<_>>()?;
        let areas = corners.par_iter().map(|&[a, b, c]| (b - a).cross(c - a).length() / 2.0);
        let triangles = WeightedAliasIndex::new(areas.collect()).ok()?;
        Some(ByArea { corners, triangles })
    }

    /// A point uniform on the surface: a triangle chosen by area, a point uniform on it.
    pub(crate) fn point(&self, rng: &mut ChaCha8Rng) -> DVec3 {
        self.point_and_normal(rng).0
    }

    /// [`ByArea::point`] (the same draws) and its triangle's unit normal, by the right-hand
    /// rule of the triangle's corners (zero for a triangle without a normal).
    pub(crate) fn point_and_normal(&self, rng: &mut ChaCha8Rng) -> (DVec3, DVec3) {
        let corners = &self.corners[self.triangles.sample(rng)];
        let [a, b, c] = *corners;
        (on_triangle(corners, rng), (b - a).cross(c - a).normalize_or_zero())
    }
}

/// A point uniform on the triangle with corners `a`, `b`, `c`.
pub(crate) fn on_triangle(&[a, b, c]: &[DVec3; 3], rng: &mut ChaCha8Rng) -> DVec3 {
    let s = rng.random::<f64>().sqrt();
    let v = rng.random::<f64>();
    a * (1.0 - s) + b * (s * (1.0 - v)) + c * (s * v)
}
