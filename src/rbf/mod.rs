//! Variational implicit functions: constraints, the interpolation solve and evaluation
//! (paper 3.1 and 5.2).
//!
//! A variational implicit function interpolates a set of constraints: positions `c_j` with
//! values `h_j`. Boundary constraints have the value zero and the surface passes exactly through
//! them; interior constraints are positive and exterior constraints negative (the paper's sign
//! convention, used throughout this crate: **inside positive, outside negative**). The function is
//!
//! ```text
//! f(x) = sum_j d_j phi(|x - c_j|) + P(x),    P of degree one,
//! ```
//!
//! with the weights `d_j` and the coefficients of `P` found by solving the square system of
//! paper equation (2) plus the side conditions `sum_j d_j = 0` and `sum_j d_j c_j = 0`
//! ([`Implicit::solve`]). The kernel `phi` is `r^2 log r` by default (the paper's), or `r^3` or
//! `r` ([`Kernel`]).
//!
//! The same code serves the plane (paper figure 2), space, and space-time: the dimension is a
//! runtime parameter (2, 3 or 4) and the hot loops are specialized for each by const generics.
//!
//! ## Guarantees
//! * Up to `DIRECT_MAX` constraints the solve is exact (a dense factorization in f64, by the
//!   null-space method and Cholesky, refined); above, it is iterative (FGMRES with a domain
//!   decomposition preconditioner), to a residual of at most `1e-8` of the largest |value|, in
//!   `O(n)` memory. Either way it is checked: [`Implicit::solve`] reports the largest
//!   interpolation residual relative to the largest |value| and refuses a system whose
//!   residual shows it is numerically singular. Coincident or nearly coincident constraints,
//!   too few affinely independent positions for the polynomial, and NaN or infinite input are
//!   errors, never a silent garbage model.
//! * Positions are normalized internally (translated to their centroid and scaled by their
//!   largest extent), so meshes far from the origin or in large units are as well conditioned as
//!   a unit-sized one, and this changes nothing in the function (see below).
//! * The solve, single values and gradients, and the values of [`Implicit::values3`],
//!   [`Implicit::values_flat`] and [`Field::values`] are f64 (see below); only
//!   `SinglePrecision`, for the fit's volume passes, sums in f32.
//! * [`evaluate_on_grid`] is the paper's coarse-to-fine volume evaluation (5.2), with its one
//!   blind spot documented there.
//!
//! ## Normalization leaves the function unchanged
//! With `c' = (c - m) / s`, the kernels `r^3` and `r` only scale by `s^3` or `s`, which the
//! weights absorb. For `r^2 log r`, `phi(s r') = s^2 phi(r') + s^2 log(s) r'^2`, and the extra
//! term contributes `s^2 log(s) sum_j d_j |x' - c'_j|^2`, which expands to
//! `s^2 log(s) (|x'|^2 sum_j d_j - 2 x' . sum_j d_j c'_j + sum_j d_j |c'_j|^2)`. The side
//! conditions `sum_j d_j = 0` and `sum_j d_j c_j = 0` reduce it to a constant that the polynomial
//! absorbs, so both systems have the same unique solution function.
//!
//! ## Evaluation: f64 lanes, and f32 where a fit allows it
//! The sum `sum_j d_j phi(|x - c_j|)` cancels heavily (the weights sum to zero and the far-field
//! growth of `r^2 log r` cancels against the polynomial), so its terms are orders of magnitude
//! larger than the result. f32 lanes would leave an error near `1e-7 sum_j |d_j phi_j|`, far
//! above the `1e-6` relative agreement the fit and the peer comparison need; f64 keeps it near
//! `1e-15` of that sum. Points are evaluated sixteen at a time (two AVX-512 vectors of 8 lanes,
//! four AVX2 ones of 4), against centres stored axis by axis (SoA); `r^2 log r = 0.5 r^2
//! ln(r^2)` needs no square root, and the logarithm is fdlibm's reduction and series (within 3
//! ulps of std's) written branch-free so that it vectorizes. The loops are compiled for
//! AVX-512, AVX2 + FMA and the baseline target, and the best the CPU supports is chosen at run
//! time ([`Isa`]; `IMPLICITIZE_ISA` forces one). Blocks of points are spread over threads with
//! rayon.
//!
//! The fit's volume passes need each voxel's sign and the surface's position to a small
//! fraction of a voxel, no more: through `SinglePrecision` they sum the thin-plate kernel in
//! f32 (a loop on every instruction set, see `kernel/`), and the fit measures a model's
//! f32 error at its boundary constraints first, keeping f64 where f32 would misplace the surface
//! by more than a share of its target error.
//!
//! ## Layers
//! [`Isa`] (`isa.rs`) and the kernels and their loops (`kernel/`) are the bottom; the treecode
//! (`treecode.rs`) sums with those loops; evaluation (`evaluate.rs`) chooses between the direct
//! sum and the treecode. The dense factorization (`dense.rs`) serves both the direct solve and
//! the local problems of the Schwarz preconditioner (`schwarz.rs`), which with FGMRES
//! (`gmres.rs`) makes the iterative solve (`iterative.rs`); `solve.rs` checks the input and
//! the result and chooses between the two. The compactly supported functions of detail levels
//! (`compact.rs`) stand apart: their own kernel, index and sparse solve. No module imports one that imports it back
//! (`tests/layers.rs`).

mod compact;
mod csv;
mod dense;
mod evaluate;
mod gmres;
mod grid;
mod isa;
mod iterative;
mod kernel;
mod lattice;
mod multiscale;
mod schwarz;
mod solve;
mod treecode;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::field::Field;
use crate::geometry::DVec3;

pub use compact::DetailLevel;
pub(crate) use compact::wendland;
pub use csv::{read_constraints, read_points};
pub use grid::evaluate_on_grid;
pub use isa::Isa;
pub use isa::{ENV as ISA_ENV, IsaLevel};
pub use kernel::Kernel;
pub(crate) use lattice::Lattice;
pub(crate) use lattice::{extent as lattice_extent, morton_order as lattice_order};
pub use multiscale::MultiScale;
pub(crate) use solve::DIRECT_MAX;

/// What a constraint asks of the surface, read from the sign of its value (paper 3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ConstraintKind {
    /// Value zero: the surface passes through the position.
    Boundary,
    /// A positive value: the position is inside.
    Interior,
    /// A negative value: the position is outside.
    Exterior,
}

impl ConstraintKind {
    /// The kind of a constraint of value `value` (inside positive).
    pub fn of_value(value: f64) -> ConstraintKind {
        if value > 0.0 {
            ConstraintKind::Interior
        } else if value < 0.0 {
            ConstraintKind::Exterior
        } else {
            ConstraintKind::Boundary
        }
    }
}

/// A position (2, 3 or 4 coordinates, in the mesh's units) and the value the function must take
/// there: zero on the boundary, positive inside, negative outside.
#[derive(Debug, Clone, PartialEq)]
pub struct Constraint {
    position: Vec<f64>,
    value: f64,
}

impl Constraint {
    /// A constraint at `position` with `value`. The number of coordinates is checked against
    /// the dimension, and every number for being finite, by [`Implicit::solve`].
    pub fn new(position: &[f64], value: f64) -> Constraint {
        Constraint { position: position.to_vec(), value }
    }

    /// The position.
    pub fn position(&self) -> &[f64] {
        &self.position
    }

    /// The value: zero on the boundary, positive inside, negative outside.
    pub fn value(&self) -> f64 {
        self.value
    }

    /// Boundary, interior or exterior, from the sign of the value.
    pub fn kind(&self) -> ConstraintKind {
        ConstraintKind::of_value(self.value)
    }
}

/// A solved variational implicit function: `f(x) = sum_j d_j phi(|x - c_j|) + P(x)`, positive
/// inside and negative outside.
///
/// Internally the centres are normalized (`c' = (c - m) / s`, `m` the centroid, `s` the largest
/// extent) and the weights and polynomial are those of the same function written in normalized
/// coordinates: `f(x) = sum_j d_j phi(|x' - c'_j|) + p_0 + sum_a p_a x'_a`.
#[derive(Debug, Clone)]
pub struct Implicit {
    dim: usize,
    kernel: Kernel,
    constraints: Vec<Constraint>,
    normalization: Normalization,
    /// Normalized centres, one axis after another (`centres[a * n + j]`), for vector loads.
    centres: Vec<f64>,
    weights: Vec<f64>,
    /// `p_0`, then one coefficient per axis, in normalized coordinates.
    polynomial: Vec<f64>,
    residual: f64,
    /// The lattice its centres, weights and values lie on, when it was made compact.
    lattice: Option<Lattice>,
}

/// The map from the mesh's units to the normalized coordinates the function is solved in:
/// `x' = (x - translate) / scale`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Normalization {
    /// Subtracted from every position: the centroid of the constraints.
    pub translate: Vec<f64>,
    /// Divides every translated position: the largest extent of the constraints.
    pub scale: f64,
}

impl Normalization {
    /// Writes the normalized coordinates of `x` into `out`. Constraint positions and evaluation
    /// points go through this same function, so a point equal to a constraint maps to exactly
    /// the normalized centre.
    #[inline]
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        for ((o, &v), &t) in out.iter_mut().zip(x).zip(&self.translate) {
            *o = (v - t) / self.scale;
        }
    }
}

/// The dimensions a variational implicit function can have.
pub(crate) const DIMENSIONS: std::ops::RangeInclusive<usize> = 2..=4;

impl Implicit {
    /// The dimension: 2, 3 or 4.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The kernel.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The number of constraints (and of radial basis functions).
    pub fn len(&self) -> usize {
        self.constraints.len()
    }

    /// Whether there are no constraints (never true of a solved function).
    pub fn is_empty(&self) -> bool {
        self.constraints.is_empty()
    }

    /// The constraints, in the order they were given.
    pub fn constraints(&self) -> &[Constraint] {
        &self.constraints
    }

    /// The largest `|f(c_i) - h_i|` over the constraints, relative to the largest `|h_i|` (or to
    /// the constraints' largest extent when every value is zero), as evaluated after the solve.
    pub fn residual(&self) -> f64 {
        self.residual
    }

    /// The normalization from the mesh's units to the coordinates the weights refer to.
    pub fn normalization(&self) -> &Normalization {
        &self.normalization
    }

    /// The weights `d_j`, one per constraint, in normalized coordinates.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The polynomial in normalized coordinates: the constant, then one coefficient per axis.
    pub fn polynomial(&self) -> &[f64] {
        &self.polynomial
    }

    /// The lattice its centres, weights and values lie on, when the fit made it compact (see
    /// `Lattice`): what lets a binary model file store them as small integers.
    pub fn lattice(&self) -> Option<&Lattice> {
        self.lattice.as_ref()
    }

    /// The same function, declared to lie on `lattice` (not checked here: a model file that
    /// finds a number off it stores the numbers as they are).
    pub(crate) fn on_lattice(mut self, lattice: Lattice) -> Implicit {
        self.lattice = Some(lattice);
        self
    }

    /// The value at `x` (`dim` coordinates in the mesh's units): positive inside, negative
    /// outside. Missing coordinates count as zero and extra ones are ignored.
    pub fn value_at(&self, x: &[f64]) -> f64 {
        evaluate::value_at(self, x)
    }

    /// The gradient at `x` (`dim` coordinates in the mesh's units), `dim` values; it points
    /// into the shape since the inside is positive.
    pub fn gradient_at(&self, x: &[f64]) -> Vec<f64> {
        evaluate::gradient_at(self, x)
    }

    /// The typical gradient magnitude of the function at its surface, in value units per mesh
    /// unit: dividing by it makes values approximate signed distances in mesh units (what CSG
    /// and morphing compare). The median of `|grad f|` over the boundary constraints (over
    /// every constraint when there is no boundary constraint), in every dimension the function
    /// has; 1 for a degenerate function whose median is zero or not finite.
    pub fn distance_scale(&self) -> f64 {
        let constraints = self.constraints();
        let boundary: Vec<_> = constraints.iter().filter(|c| c.value() == 0.0).collect();
        let sites = if boundary.is_empty() { constraints.iter().collect() } else { boundary };
        let mut slopes: Vec<f64> = sites
            .iter()
            .map(|c| self.gradient_at(c.position()).iter().map(|g| g * g).sum::<f64>().sqrt())
            .collect();
        slopes.sort_unstable_by(f64::total_cmp);
        let median = slopes.get(slopes.len() / 2).copied().unwrap_or(1.0);
        if median.is_finite() && median > 0.0 { median } else { 1.0 }
    }

    /// The values at many 3D points (a 2D function reads x and y, a 4D one takes `t = 0`), in
    /// parallel and vectorized. Positive inside, negative outside. Many points of a 3D function
    /// of many centres are summed by a treecode, within `1e-5` of the value range of the exact
    /// sum (see [`values3_exact`](Implicit::values3_exact)).
    pub fn values3(&self, points: &[[f64; 3]]) -> Vec<f64> {
        evaluate::values(self, points.len(), |i, out| {
            let k = 3.min(out.len());
            out[..k].copy_from_slice(&points[i][..k]);
        })
    }

    /// [`values3`](Implicit::values3) by the direct sum over every centre at any size: exact to
    /// the rounding of f64, and slower for many points of many centres.
    pub fn values3_exact(&self, points: &[[f64; 3]]) -> Vec<f64> {
        evaluate::values_exact(self, points.len(), |i, out| {
            let k = 3.min(out.len());
            out[..k].copy_from_slice(&points[i][..k]);
        })
    }

    /// The values at many points given as `N * dim` coordinates, point after point, in parallel
    /// and vectorized. Positive inside, negative outside. A trailing partial point is ignored.
    pub fn values_flat(&self, points: &[f64]) -> Vec<f64> {
        let dim = self.dim;
        evaluate::values(self, points.len() / dim, |i, out| {
            out.copy_from_slice(&points[i * dim..(i + 1) * dim])
        })
    }

    /// Rebuilds a solved function from its parts, as stored in a model file, checking that
    /// they fit together. `context` names the source for errors.
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        context: &str,
        dim: usize,
        kernel: Kernel,
        constraints: Vec<Constraint>,
        normalization: Normalization,
        weights: Vec<f64>,
        polynomial: Vec<f64>,
        residual: f64,
    ) -> Result<Implicit> {
        let bad = |msg: String| Err(Error::invalid(context, msg));
        if !DIMENSIONS.contains(&dim) {
            return bad(format!("dimension {dim} is not 2, 3 or 4"));
        }
        if constraints.is_empty() {
            return bad("the model has no centres".into());
        }
        if weights.len() != constraints.len() {
            return bad(format!("{} weights for {} centres", weights.len(), constraints.len()));
        }
        if polynomial.len() != dim + 1 {
            return bad(format!(
                "{} polynomial coefficients, expected {}",
                polynomial.len(),
                dim + 1
            ));
        }
        if normalization.translate.len() != dim {
            return bad(format!(
                "the normalization has {} coordinates, expected {dim}",
                normalization.translate.len()
            ));
        }
        if !(normalization.scale.is_finite() && normalization.scale > 0.0)
            || normalization.translate.iter().any(|v| !v.is_finite())
        {
            return bad("the normalization is not finite and positive".into());
        }
        if weights.iter().chain(&polynomial).any(|v| !v.is_finite()) {
            return bad("a weight or polynomial coefficient is not finite".into());
        }
        solve::check_constraints(context, dim, &constraints)?;
        let centres = solve::normalized_centres(dim, &constraints, &normalization);
        Ok(Implicit {
            dim,
            kernel,
            constraints,
            normalization,
            centres,
            weights,
            polynomial,
            residual,
            lattice: None,
        })
    }
}

/// An implicit function whose bulk evaluation ([`Field::values`]) runs its radial sum in f32
/// for the thin-plate kernel (a loop on every instruction set; the other kernels stay f64):
/// an error near `1e-7` of `sum_j |d_j phi_j|` instead of `1e-15`, which misplaces the surface
/// by more the more the weights cancel, so a caller measures it before relying on it (as the
/// fit does). For passes that need signs and the surface's position to a small fraction of a
/// voxel, as the fit's volume passes; single values and gradients stay f64.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SinglePrecision<'a>(pub &'a Implicit);

impl Field for SinglePrecision<'_> {
    fn value(&self, p: DVec3) -> f64 {
        self.0.value(p)
    }

    fn gradient(&self, p: DVec3) -> DVec3 {
        self.0.gradient(p)
    }

    fn values(&self, points: &[DVec3]) -> Vec<f64> {
        evaluate::values_f32(self.0, points.len(), |i, out| {
            let p = points[i].to_array();
            let k = out.len().min(3);
            out[..k].copy_from_slice(&p[..k]);
        })
    }
}

impl Field for Implicit {
    /// The value at `p`; 2D functions ignore `z`, 4D functions take `t = 0`.
    fn value(&self, p: DVec3) -> f64 {
        self.value_at(&p.to_array())
    }

    /// The gradient at `p` (its first three components); zero `z` for a 2D function.
    fn gradient(&self, p: DVec3) -> DVec3 {
        let g = self.gradient_at(&p.to_array());
        DVec3::new(g[0], g[1], g.get(2).copied().unwrap_or(0.0))
    }

    /// The values at many points, vectorized and in parallel.
    fn values(&self, points: &[DVec3]) -> Vec<f64> {
        evaluate::values(self, points.len(), |i, out| {
            let p = points[i].to_array();
            let k = 3.min(out.len());
            out[..k].copy_from_slice(&p[..k]);
        })
    }

    /// The positions of the boundary constraints, where the function interpolates zero, for a
    /// 3D function; none for a 2D or 4D one, whose boundary constraints are not points of the
    /// zero set this field has in space.
    fn surface_points(&self) -> Vec<DVec3> {
        if self.dim != 3 {
            return Vec::new();
        }
        self.constraints
            .iter()
            .filter(|c| c.kind() == ConstraintKind::Boundary)
            .map(|c| DVec3::from_slice(&c.position))
            .collect()
    }

    /// The fewest points the treecode takes (see [`Field::fast_batch`]).
    fn fast_batch(&self) -> Option<usize> {
        evaluate::fast_batch(self)
    }
}
