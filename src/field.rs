//! Scalar fields over space: what polygonization, rendering, morphing and CSG read.
//!
//! A [`Field`] is a function of position in the mesh's own units that is positive inside the
//! shape and negative outside (the paper's sign convention), with its gradient. Fitted
//! variational implicit functions implement it, and so do composites built from them.

use rayon::prelude::*;

use crate::geometry::DVec3;

/// A scalar field, positive inside and negative outside, in the mesh's own units.
///
/// Two-dimensional fields (the paper's figure 2) read `x` and `y` and ignore `z`.
pub trait Field: Sync {
    /// The value at `p`: positive inside, negative outside, zero on the surface.
    fn value(&self, p: DVec3) -> f64;

    /// The gradient at `p`; it points into the shape, since the inside is positive.
    fn gradient(&self, p: DVec3) -> DVec3;

    /// The values at many points, in parallel. Implementations may override this with a
    /// vectorized version.
    fn values(&self, points: &[DVec3]) -> Vec<f64> {
        points.par_iter().map(|&p| self.value(p)).collect()
    }

    /// Points known to lie on (or very near) the zero set, such as a fitted function's boundary
    /// constraints; none by default. Polygonization follows the surface from them instead of
    /// evaluating the whole grid (see [`crate::polygonize::polygonize()`]), so a field should offer points
    /// spread over every part of its surface, or none.
    fn surface_points(&self) -> Vec<DVec3> {
        Vec::new()
    }

    /// The fewest points from which [`Field::values`] costs less per point in one call than in
    /// several smaller ones (a fast summation that pays only on many points), or `None` when
    /// the cost per point does not depend on how many are asked at once (the default).
    /// Polygonization evaluates larger, partly speculative, batches for such a field.
    fn fast_batch(&self) -> Option<usize> {
        None
    }
}
