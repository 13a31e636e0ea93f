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
//! centre (see [`crate::edt`]), so a boundary voxel lying on the other shape's boundary too
//! has an error of half a voxel: that is the floor of E, not zero. Errors are honest distances
//! from voxel centres to the other surface.
//!
//! Beside the paper's figures, [`ErrorMetrics`] carries E and the RMS error to sub-voxel
//! precision, measured from points on each surface (see [`SubVoxel`]); the fit ranks its
//! candidates by these, so the half-voxel steps of voxel-centre distances do not turn into
//! constraints.

pub mod surface;

use rayon::prelude::*;

use crate::edt;
use crate::geometry::DVec3;
use crate::grid::Volume;

/// How the discrete radius of regularity is measured.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RegularityOptions {
    /// The walk stops once the distance travelled exceeds the distance to the boundary by this
    /// much, in voxels (the paper's two-voxel tolerance for discretization errors).
    pub tolerance: f64,
    /// Radii are capped here, in voxels. The paper sets no cap; without one a broad flat region
    /// of the goal gets radii of tens of voxels and Ew ignores errors of several voxels there.
    pub max_radius: f64,
    /// Radii are never below this, in voxels, so Ew stays finite at sharp creases.
    pub min_radius: f64,
}

impl Default for RegularityOptions {
    fn default() -> Self {
        RegularityOptions { tolerance: 2.0, max_radius: 16.0, min_radius: 1.0 }
    }
}

/// The discrete radius of regularity at a boundary voxel (paper 4.3): walk up the gradient of
/// the signed distance from the voxel, and stop when the distance travelled exceeds the
/// distance from the walker to the boundary plus the tolerance; the distance travelled is the
/// radius.
///
/// The walk is discrete, as the paper's volumes are: each step goes to the one of the 26
/// neighbouring voxels with the steepest rise of the signed distance (rise over step length)
/// and adds that step's length (1, √2 or √3) to the distance travelled; it also stops at a
/// local maximum of the signed distance (the middle of a thin part, or the centre of a ball).
///
/// The paper walks up the gradient only, into the solid, which measures thinness. We also walk
/// down it, out into the empty space, which measures narrow gaps and concave creases (the
/// "sharp indentations by the bunny's leg" the paper found hardest), and return the smaller of
/// the two, which is the discrete analogue of the r-regularity definition: a circle of radius r
/// tangent on either side. The result is clamped to `[min_radius, max_radius]`, in voxels.
pub fn radius_of_regularity(
    sd: &Volume<f32>,
    voxel: [usize; 3],
    options: &RegularityOptions,
) -> f32 {
    let inward = walk(sd, voxel, 1.0, options);
    let outward =
        if inward <= options.min_radius { inward } else { walk(sd, voxel, -1.0, options) };
    inward.min(outward).clamp(options.min_radius, options.max_radius) as f32
}

/// Walks from `start` up `direction` times the signed distance (1 inward, -1 outward) and
/// returns the distance travelled when the stopping rule fires, at most `max_radius`.
fn walk(sd: &Volume<f32>, start: [usize; 3], direction: f32, options: &RegularityOptions) -> f64 {
    let mut voxel = start;
    let mut travelled = 0.0;
    while travelled < options.max_radius {
        let Some((next, step)) = steepest_neighbour(sd, voxel, direction) else {
            break;
        };
        voxel = next;
        travelled += step;
        if travelled > f64::from(sd.get(voxel).abs()) + options.tolerance {
            break;
        }
    }
    travelled.min(options.max_radius)
}

/// The neighbour of `voxel` (of 26) where `direction * sd` rises most steeply, with the step's
/// length, or `None` at a local maximum. The first of equally steep neighbours (in
/// [`NEIGHBOURS`]' order) wins.
fn steepest_neighbour(
    sd: &Volume<f32>,
    voxel: [usize; 3],
    direction: f32,
) -> Option<([usize; 3], f64)> {
    let dims = sd.grid.dims;
    let here = direction * *sd.get(voxel);
    let interior = (0..3).all(|a| voxel[a] >= 1 && voxel[a] + 1 < dims[a]);
    let mut best: Option<usize> = None;
    let mut best_slope = 0.0f32;
    let mut consider = |n: usize, value: f32| {
        let slope = (direction * value - here) / LENGTHS[ORDERS[n]];
        if slope > best_slope {
            best_slope = slope;
            best = Some(n);
        }
    };
    if interior {
        // Away from the grid's faces every neighbour exists: read them by flat offsets.
        let at = sd.grid.index(voxel);
        let (row, slab) = (dims[2], dims[1] * dims[2]);
        for (n, o) in NEIGHBOURS.iter().enumerate() {
            let i = at.wrapping_add_signed(o[0] * slab as isize + o[1] * row as isize + o[2]);
            consider(n, sd.data[i]);
        }
    } else {
        for (n, o) in NEIGHBOURS.iter().enumerate() {
            let next = neighbour(voxel, *o);
            if next.iter().zip(dims).all(|(&c, d)| c < d) {
                consider(n, *sd.get(next));
            }
        }
    }
    best.map(|n| (neighbour(voxel, NEIGHBOURS[n]), f64::from(LENGTHS[ORDERS[n]])))
}

/// `voxel + offset`, with coordinates that would fall below 0 wrapped past any grid.
fn neighbour(voxel: [usize; 3], offset: [isize; 3]) -> [usize; 3] {
    std::array::from_fn(|a| voxel[a].wrapping_add_signed(offset[a]))
}

/// The length of a step to a neighbour of each order (how many coordinates change).
const LENGTHS: [f32; 4] = [0.0, 1.0, std::f32::consts::SQRT_2, 1.732_050_8];

/// The order of each of [`NEIGHBOURS`].
const ORDERS: [usize; 26] = {
    let mut orders = [0; 26];
    let mut n = 0;
    while n < 26 {
        let o = NEIGHBOURS[n];
        orders[n] = (o[0] != 0) as usize + (o[1] != 0) as usize + (o[2] != 0) as usize;
        n += 1;
    }
    orders
};

/// The 26 offsets to a voxel's neighbours.
const NEIGHBOURS: [[isize; 3]; 26] = {
    let mut offsets = [[0isize; 3]; 26];
    let mut n = 0;
    let mut i = 0;
    while i < 27 {
        let o = [(i / 9) as isize - 1, ((i / 3) % 3) as isize - 1, (i % 3) as isize - 1];
        if o[0] != 0 || o[1] != 0 || o[2] != 0 {
            offsets[n] = o;
            n += 1;
        }
        i += 1;
    }
    offsets
};

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
///
/// Each voxel also carries a point on this shape's surface next to it and the other shape's
/// signed distance at that point, to sub-voxel precision (see [`SubVoxel`]): the fit ranks and
/// places new constraints by these, free of the half-voxel steps of the voxel-centre distances.
#[derive(Debug, Clone, Default)]
pub struct BoundaryErrors {
    /// The boundary voxels ∂f of this shape.
    pub voxels: Vec<[usize; 3]>,
    /// The other shape's signed distance at each voxel (voxel units, inside positive).
    pub other_sd: Vec<f32>,
    /// This shape's radius of regularity at each voxel, in voxels; NaN where it was not
    /// measured because it could change neither Ew nor the fit's choices (see the fit).
    pub rreg: Vec<f32>,
    /// A point on this shape's surface at each voxel, in continuous voxel coordinates.
    pub points: Vec<DVec3>,
    /// The other shape's signed distance at each point, to sub-voxel precision (voxels).
    pub other_fine_sd: Vec<f32>,
}

impl BoundaryErrors {
    /// Errors at `voxels` (boundary voxels of a shape whose radii are `rreg` and whose surface
    /// passes through `points`) against the other shape, seen through its voxel signed distance
    /// `other` and its sub-voxel signed distance `other_fine` (voxels, inside positive, at a
    /// point in continuous voxel coordinates).
    pub fn new(
        voxels: Vec<[usize; 3]>,
        rreg: Vec<f32>,
        points: Vec<DVec3>,
        other: &Volume<f32>,
        other_fine: impl Fn(DVec3) -> f32 + Sync,
    ) -> Self {
        let other_sd = voxels.iter().map(|&v| *other.get(v)).collect();
        let other_fine_sd = points.par_iter().map(|&p| other_fine(p)).collect();
        BoundaryErrors { voxels, other_sd, rreg, points, other_fine_sd }
    }

    /// The error |sd| at voxel number `i`, in voxels, as the paper measures it.
    pub fn error(&self, i: usize) -> f32 {
        self.other_sd[i].abs()
    }

    /// The weighted error |sd| / rreg at voxel number `i` (NaN where rreg was not measured,
    /// which every maximum here ignores).
    pub fn weighted_error(&self, i: usize) -> f32 {
        self.error(i) / self.rreg[i]
    }

    /// The error at voxel number `i` to sub-voxel precision: the other shape's distance from
    /// the point of this shape's surface there, in voxels.
    pub fn fine_error(&self, i: usize) -> f32 {
        self.other_fine_sd[i].abs()
    }
}

/// A shape's signed distance to sub-voxel precision near its surface, from a volume of values
/// that vary smoothly across it (densities, or the implicit function's values) and, further
/// away, from its voxel signed distance.
///
/// Near the surface the distance is the first-order estimate `(v(p) - level) / |∇v(p)|` of the
/// trilinear interpolation of the values, which is exact for a plane and within a small
/// fraction of a voxel for surfaces curved on the scale of a few voxels. Where that estimate is
/// unavailable (a flat stretch of values), further than `reach` voxels, or more than
/// `AGREEMENT` voxels from the voxel signed distance, the trilinear interpolation of the
/// voxel signed distance is used instead.
///
/// The last case is where the values dip towards the level without crossing it: where a thin
/// part of the current surface pinches off, the implicit function inside it falls to just below
/// zero, and `v / |∇v|` says the surface is a fraction of a voxel away while the nearest point
/// across is several voxels off. The voxel signed distance, within a voxel of the true
/// distance, tells the two apart.
#[derive(Debug, Clone, Copy)]
pub struct SubVoxel<'a> {
    /// Values whose `level` set is the surface, larger inside.
    pub values: &'a Volume<f32>,
    /// The surface's level.
    pub level: f32,
    /// The shape's voxel signed distance (voxel units, inside positive).
    pub sd: &'a Volume<f32>,
    /// How far from the surface (voxels) the first-order estimate is trusted.
    pub reach: f32,
}

impl SubVoxel<'_> {
    /// The signed distance at `p` (continuous voxel coordinates), inside positive, in voxels.
    pub fn signed_distance(&self, p: DVec3) -> f32 {
        let coarse = edt::sample(self.sd, p);
        if coarse.abs() > self.reach + 1.0 {
            return coarse;
        }
        match self.first_order(p) {
            Some(d) if d.abs() <= self.reach && (d - coarse).abs() <= AGREEMENT => d,
            _ => coarse,
        }
    }

    /// `(v(p) - level) / |∇v(p)|`, or `None` where the gradient vanishes.
    fn first_order(&self, p: DVec3) -> Option<f32> {
        let gradient = edt::gradient(self.values, p).length();
        let value = f64::from(edt::sample(self.values, p) - self.level);
        (gradient > 1e-12).then(|| (value / gradient) as f32)
    }

    /// The point of the surface nearest `p` to first order (one Newton step along the
    /// gradient, at most `reach` voxels), or `p` itself where the gradient vanishes.
    pub fn project(&self, p: DVec3) -> DVec3 {
        let gradient = edt::gradient(self.values, p);
        let g2 = gradient.length_squared();
        if g2 <= 1e-24 {
            return p;
        }
        let value = f64::from(edt::sample(self.values, p) - self.level);
        p - (gradient * (value / g2)).clamp_length_max(f64::from(self.reach))
    }
}

/// How far (voxels) the first-order distance of [`SubVoxel`] may be from the voxel signed
/// distance: a voxel centre's signed distance is within about half a voxel of its true distance to
/// the surface, and trilinear interpolation between centres adds at most as much again.
pub(crate) const AGREEMENT: f32 = 1.0;

/// E, Ew and the RMS error of one current surface against the goal.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct ErrorMetrics {
    /// E (equation 3), in voxels, from voxel-centre signed distances as in the paper.
    pub max_error: f32,
    /// Ew (equation 4), dimensionless.
    pub weighted_error: f32,
    /// Root mean square of the errors over both boundaries, in voxels.
    pub rms_error: f32,
    /// E to sub-voxel precision: the largest distance from a surface point of either shape to
    /// the other shape, in voxels.
    pub max_error_subvoxel: f32,
    /// The root mean square of the sub-voxel errors, in voxels.
    pub rms_error_subvoxel: f32,
}

impl ErrorMetrics {
    /// The metrics over the goal's boundary (errors against the current surface) and the
    /// current surface's boundary (errors against the goal).
    pub fn measure(goal: &BoundaryErrors, current: &BoundaryErrors) -> Self {
        let mut metrics = ErrorMetrics::default();
        let (mut sum_sq, mut fine_sum_sq) = (0.0f64, 0.0f64);
        let mut count = 0usize;
        for side in [goal, current] {
            for i in 0..side.voxels.len() {
                let (e, fine) = (side.error(i), side.fine_error(i));
                metrics.max_error = metrics.max_error.max(e);
                metrics.weighted_error = metrics.weighted_error.max(side.weighted_error(i));
                metrics.max_error_subvoxel = metrics.max_error_subvoxel.max(fine);
                sum_sq += f64::from(e) * f64::from(e);
                fine_sum_sq += f64::from(fine) * f64::from(fine);
                count += 1;
            }
        }
        if count > 0 {
            metrics.rms_error = (sum_sq / count as f64).sqrt() as f32;
            metrics.rms_error_subvoxel = (fine_sum_sq / count as f64).sqrt() as f32;
        }
        metrics
    }

    /// The same metrics in voxels `scale` times smaller: the errors times `scale`, Ew (a ratio
    /// of two lengths) unchanged.
    pub fn in_smaller_voxels(self, scale: f32) -> Self {
        ErrorMetrics {
            max_error: self.max_error * scale,
            weighted_error: self.weighted_error,
            rms_error: self.rms_error * scale,
            max_error_subvoxel: self.max_error_subvoxel * scale,
            rms_error_subvoxel: self.rms_error_subvoxel * scale,
        }
    }
}

/// The `q`-quantile of `values` (at least one; `q` in [0, 1]), interpolated linearly between
/// the two nearest ranks as numpy's default does: rank `q (n - 1)`. The one definition of a
/// percentile in every report. Reorders `values`.
pub(crate) fn percentile(values: &mut [f64], q: f64) -> f64 {
    let rank = q * (values.len() - 1) as f64;
    let below = rank.floor() as usize;
    let (_, &mut at, above) = values.select_nth_unstable_by(below, f64::total_cmp);
    match above.iter().copied().min_by(f64::total_cmp) {
        Some(next) => at + (next - at) * rank.fract(),
        None => at,
    }
}

#[cfg(test)]
mod tests {
    /// The percentile interpolates between ranks and agrees with a sort, whatever the order.
    #[test]
    fn the_percentile_interpolates_between_the_nearest_ranks() {
        let mut values: Vec<f64> = (0..=1000).rev().map(f64::from).collect();
        assert_eq!(super::percentile(&mut values, 0.999), 999.0);
        let mut values = vec![3.0, 1.0, 2.0, 4.0];
        // rank 0.999 * 3 = 2.997: between 3 and 4.
        let p = super::percentile(&mut values, 0.999);
        assert!((p - 3.997).abs() < 1e-12, "{p}");
        assert_eq!(super::percentile(&mut [5.0], 0.999), 5.0);
        assert_eq!(super::percentile(&mut [2.0, 1.0], 0.0), 1.0);
        assert_eq!(super::percentile(&mut [2.0, 1.0], 1.0), 2.0);
    }

    use super::*;
    use crate::grid::Grid;

    /// Where the values dip towards the level without crossing it (a pinching neck), the
    /// first-order distance (0.8 voxels here) disagrees with the voxel signed distance (2.5)
    /// and the latter is taken; where they agree, the first-order one.
    #[test]
    fn a_dip_that_does_not_cross_the_level_is_not_taken_for_the_surface() {
        let grid = Grid { dims: [12, 12, 12], origin: [0.0; 3], voxel_size: 1.0 };
        let sd = Volume::filled(grid, 2.5f32);
        let mut values = Volume::filled(grid, 0.0f32);
        for (n, v) in values.data.iter_mut().enumerate() {
            *v = 0.1 * grid.voxel(n)[0] as f32 - 0.52;
        }
        let fine = SubVoxel { values: &values, level: 0.0, sd: &sd, reach: 2.0 };
        // At x = 6 the values are 0.08 with a slope of 0.1: 0.8 voxels from their zero.
        let p = DVec3::new(6.0, 6.0, 6.0);
        assert_eq!(fine.signed_distance(p), 2.5);
        // Where the voxel signed distance agrees within a voxel, the first-order one is kept.
        let near = Volume::filled(grid, 1.5f32);
        let fine = SubVoxel { sd: &near, ..fine };
        assert!((fine.signed_distance(p) - 0.8).abs() < 1e-5);
    }
}
