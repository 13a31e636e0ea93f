//! Error metrics between the goal shape and the current implicit surface (paper 4.3).
//!
//! Both shapes are seen through their signed distance volumes (voxel units, inside positive)
//! and their boundary voxels ∂f. The error at a boundary voxel of one shape is the magnitude of
//! the other shape's signed distance there:
//!
//! * [`ErrorMetrics::max_error`] is the paper's E (equation 3), a discrete Hausdorff distance;
//! * [`ErrorMetrics::weighted_error`] is Ew (equation 4), each error divided by the radius of
//!   regularity of its own shape at that voxel, so a voxel of error on a thin horn weighs more
//!   than on a broad belly;
//! * [`ErrorMetrics::rms_error`] is the root mean square over both boundaries, the tie-breaker
//!   of section 5.4.
//!
//! Signed distances put the surface halfway between the last inside and the first outside voxel
//! centre (see [`crate::distance`]), so a boundary voxel lying on the other shape's boundary too
//! has an error of half a voxel: that is the floor of E, not zero. Errors are honest distances
//! from voxel centres to the other surface.

use rayon::prelude::*;

use crate::distance;
use crate::geometry::DVec3;
use crate::grid::Volume;

/// How the discrete radius of regularity is measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegularityOptions {
    /// The walk stops once the distance travelled exceeds the distance to the boundary by this
    /// much, in voxels (the paper's two-voxel tolerance for discretization errors).
    pub tolerance: f64,
    /// Step length of the walk along the gradient, in voxels.
    pub step: f64,
    /// Radii are capped here, in voxels. The paper sets no cap; without one a broad flat region
    /// of the goal gets radii of tens of voxels and Ew ignores errors of several voxels there.
    pub max_radius: f64,
    /// Radii are never below this, in voxels, so Ew stays finite at sharp creases.
    pub min_radius: f64,
}

impl Default for RegularityOptions {
    fn default() -> Self {
        RegularityOptions { tolerance: 2.0, step: 0.5, max_radius: 16.0, min_radius: 1.0 }
    }
}

/// The discrete radius of regularity at a boundary voxel (paper 4.3): walk up the gradient of
/// the signed distance from the voxel, and stop when the distance travelled exceeds the
/// distance from the walker to the boundary plus the tolerance; the distance travelled is the
/// radius.
///
/// The paper walks up the gradient only, into the solid, which measures thinness. We also walk
/// down it, out into the empty space, which measures narrow gaps and concave creases (the
/// "sharp indentations by the bunny's leg" the paper found hardest), and return the smaller of
/// the two, which is the discrete analogue of the r-regularity definition: a circle of radius r
/// tangent on either side. The result is clamped to `[min_radius, max_radius]`, in voxels.
pub fn radius_of_regularity(sd: &Volume<f32>, voxel: [usize; 3], options: &RegularityOptions) -> f32 {
    let start = DVec3::new(voxel[0] as f64, voxel[1] as f64, voxel[2] as f64);
    let inward = walk(sd, start, 1.0, options);
    let outward = if inward <= options.min_radius { inward } else { walk(sd, start, -1.0, options) };
    inward.min(outward).clamp(options.min_radius, options.max_radius) as f32
}

/// Walks from `start` along `direction` times the gradient of `sd` (1 uphill, -1 downhill) and
/// returns the distance travelled when the stopping rule fires, at most `max_radius`.
fn walk(sd: &Volume<f32>, start: DVec3, direction: f64, options: &RegularityOptions) -> f64 {
    let dims = sd.grid.dims;
    let upper = DVec3::new(dims[0] as f64 - 1.0, dims[1] as f64 - 1.0, dims[2] as f64 - 1.0);
    let mut p = start;
    let mut travelled = 0.0;
    while travelled < options.max_radius {
        let g = distance::gradient(sd, p) * direction;
        let length = g.length();
        if length < 1e-6 {
            break;
        }
        p = (p + g * (options.step / length)).clamp(DVec3::ZERO, upper);
        travelled += options.step;
        let to_boundary = f64::from(distance::sample(sd, p)).abs();
        if travelled > to_boundary + options.tolerance {
            break;
        }
    }
    travelled.min(options.max_radius)
}

/// The radius of regularity at each of `voxels`, in parallel.
pub fn radii_of_regularity(
    sd: &Volume<f32>,
    voxels: &[[usize; 3]],
    options: &RegularityOptions,
) -> Vec<f32> {
    voxels.par_iter().map(|&v| radius_of_regularity(sd, v, options)).collect()
}

/// One shape's boundary voxels with the other shape's signed distance at each, and this
/// shape's radius of regularity there: one half of equations 3 and 4.
#[derive(Debug, Clone, Default)]
pub struct BoundaryErrors {
    /// The boundary voxels ∂f of this shape.
    pub voxels: Vec<[usize; 3]>,
    /// The other shape's signed distance at each voxel (voxel units, inside positive).
    pub other_sd: Vec<f32>,
    /// This shape's radius of regularity at each voxel, in voxels.
    pub rreg: Vec<f32>,
}

impl BoundaryErrors {
    /// Errors at `voxels` (boundary voxels of a shape whose radii are `rreg`) against the other
    /// shape's signed distance `other`.
    pub fn new(voxels: Vec<[usize; 3]>, rreg: Vec<f32>, other: &Volume<f32>) -> Self {
        let other_sd = voxels.iter().map(|&v| *other.get(v)).collect();
        BoundaryErrors { voxels, other_sd, rreg }
    }

    /// The error |sd| at voxel number `i`, in voxels.
    pub fn error(&self, i: usize) -> f32 {
        self.other_sd[i].abs()
    }

    /// The weighted error |sd| / rreg at voxel number `i`.
    pub fn weighted_error(&self, i: usize) -> f32 {
        self.error(i) / self.rreg[i]
    }
}

/// E, Ew and the RMS error of one current surface against the goal.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct ErrorMetrics {
    /// E (equation 3), in voxels.
    pub max_error: f32,
    /// Ew (equation 4), dimensionless.
    pub weighted_error: f32,
    /// Root mean square of the errors over both boundaries, in voxels.
    pub rms_error: f32,
}

impl ErrorMetrics {
    /// The metrics over the goal's boundary (errors against the current surface) and the
    /// current surface's boundary (errors against the goal).
    pub fn measure(goal: &BoundaryErrors, current: &BoundaryErrors) -> Self {
        let mut metrics = ErrorMetrics::default();
        let mut sum_sq = 0.0f64;
        let mut count = 0usize;
        for side in [goal, current] {
            for i in 0..side.voxels.len() {
                let e = side.error(i);
                metrics.max_error = metrics.max_error.max(e);
                metrics.weighted_error = metrics.weighted_error.max(side.weighted_error(i));
                sum_sq += f64::from(e) * f64::from(e);
                count += 1;
            }
        }
        if count > 0 {
            metrics.rms_error = (sum_sq / count as f64).sqrt() as f32;
        }
        metrics
    }
}
