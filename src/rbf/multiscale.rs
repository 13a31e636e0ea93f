//! Multi-scale implicit surfaces: the paper's variational implicit function as level 0, plus
//! detail levels of compactly supported functions fitted to what it leaves (Ohtake, Belyaev
//! and Seidel, "A multi-scale approach to 3D scattered data interpolation with compactly
//! supported basis functions", 2003).
//!
//! ```text
//! F(x) = f_0(x) + sum_k g_k(x),    g_k(x) = sum_j w_kj psi_rho_k(|x - c_kj|)
//! ```
//!
//! `f_0` is an [`Implicit`] (globally supported, with its polynomial); each `g_k` is a
//! [`DetailLevel`] of Wendland's C2 function with support radius `rho_k`, halving from one
//! level to the next. `F` is positive inside and negative outside, in the mesh's units, like
//! `f_0`: the levels correct its values near the surface, where they were fitted (see
//! `fit/detail.rs`), and vanish beyond their supports.
//!
//! Evaluation is local: a value or gradient reads level 0 and, per level, only the centres
//! whose support covers the point (one cell of the level's support index). The values equal
//! the sums over every centre up to rounding.

use rayon::prelude::*;

use super::{DetailLevel, Implicit};
use crate::error::{Error, Result};
use crate::field::Field;
use crate::geometry::DVec3;

/// A variational implicit function (level 0) with detail levels over it.
#[derive(Debug, Clone)]
pub struct MultiScale {
    base: Implicit,
    levels: Vec<DetailLevel>,
}

impl MultiScale {
    /// Level 0 `base` with `levels` over it; `context` names the source in errors.
    ///
    /// # Errors
    /// A base that is not 3D (detail levels are 3D functions).
    pub fn new(context: &str, base: Implicit, levels: Vec<DetailLevel>) -> Result<MultiScale> {
        if base.dim() != 3 {
            return Err(Error::invalid(
                context,
                format!("detail levels need a 3D level 0, not {}D", base.dim()),
            ));
        }
        Ok(MultiScale { base, levels })
    }

    /// Level 0: the paper's variational implicit function.
    pub fn base(&self) -> &Implicit {
        &self.base
    }

    /// The detail levels, coarsest first.
    pub fn levels(&self) -> &[DetailLevel] {
        &self.levels
    }

    /// Centres in all: level 0's and every level's.
    pub fn centre_count(&self) -> usize {
        self.base.len() + self.levels.iter().map(|l| l.centres().len()).sum::<usize>()
    }

    /// The sum of the detail levels at `p`.
    #[inline]
    fn detail(&self, p: DVec3) -> f64 {
        self.levels.iter().map(|l| l.value(p)).sum()
    }

    /// [`Field::value`] with every level summed over all its centres: the oracle of local
    /// evaluation.
    pub fn value_brute_force(&self, p: DVec3) -> f64 {
        self.base.value(p) + self.levels.iter().map(|l| l.value_brute_force(p)).sum::<f64>()
    }
}

impl Field for MultiScale {
    /// Level 0's value plus the levels': positive inside, negative outside.
    fn value(&self, p: DVec3) -> f64 {
        self.base.value(p) + self.detail(p)
    }

    /// Level 0's gradient plus the levels', pointing inside.
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.base.gradient(p) + self.levels.iter().map(|l| l.gradient(p)).sum::<DVec3>()
    }

    /// Level 0's values (vectorized, by its treecode where that pays) plus the levels', in
    /// parallel.
    fn values(&self, points: &[DVec3]) -> Vec<f64> {
        let mut values = self.base.values(points);
        values.par_iter_mut().zip(points).for_each(|(v, &p)| *v += self.detail(p));
        values
    }

    /// Level 0's boundary constraints and the finest level's centres, which the fit places on
    /// the goal's surface.
    fn surface_points(&self) -> Vec<DVec3> {
        let mut points = self.base.surface_points();
        if let Some(finest) = self.levels.last() {
            points.extend_from_slice(finest.centres());
        }
        points
    }

    /// Level 0's batch size: the levels cost the same per point at any batch size.
    fn fast_batch(&self) -> Option<usize> {
        self.base.fast_batch()
    }
}
