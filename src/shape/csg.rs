//! Constructive solid geometry on implicit surfaces (paper section 1): union, intersection and
//! difference of fitted models, sharp or with a smooth fillet.
//!
//! The paper's point is that CSG on implicit surfaces "reduces to just looking at the signs of
//! the implicit functions": with the sign convention of this crate (**inside positive, outside
//! negative**), a point is inside the union when it is inside either shape, so
//!
//! ```text
//! union        = max(a, b)
//! intersection = min(a, b)
//! difference   = min(a, -b)        (a minus b)
//! ```
//!
//! and more than two children fold left to right (`a - b - c` for a difference). A
//! [`Composite`] is such a tree of shapes and operators; it is a [`Field`] like any model, and
//! [`crate::model::Model`] holds one as [`Shape::Csg`], so `eval`, `mesh` and rendering read it like a
//! fitted model. Each child is a [`Shape`] with its bounds, so trees nest.
//!
//! ## Comparable scales
//! A fitted function is only defined up to its values at the constraints, so two models can
//! differ in slope by a large factor, and `max(a, b)` would then follow the steeper one far
//! from where the shapes meet. Each child is divided by its *distance scale*
//! ([`Shape::distance_scale`]): the median gradient magnitude of its function at its own boundary
//! constraints. Near the surface the divided function then changes by about one per mesh unit,
//! so its values approximate signed distances in mesh units, and a fillet radius in mesh units
//! means the same thing on both shapes. The scale is stored with each child in the model file,
//! so a file always describes the same function.
//!
//! ## Smooth operators
//! With a blend radius `k > 0` the sharp minimum is replaced by Quilez's quadratic polynomial
//! smooth minimum
//!
//! ```text
//! h = clamp(1/2 + (b - a) / (2k), 0, 1)
//! smin(a, b) = h a + (1 - h) b - k h (1 - h)
//! ```
//!
//! and `smax(a, b) = -smin(-a, -b)`. It equals `min(a, b)` wherever `|a - b| >= k`, lies at most
//! `k/4` below it, and is C1. Its gradient is exactly `h grad a + (1 - h) grad b` (the
//! derivative with respect to `h` vanishes), which is what [`Field::gradient`] returns, so
//! values and gradients are consistent. For two unit-slope fields meeting at a right angle the
//! fillet leaves each surface at distance `k` from the sharp edge and follows a parabola whose
//! middle is `0.25 k` from the corner along each axis, against `0.29 k` for a circular arc of
//! radius `k`: `--blend RADIUS` sets `k = RADIUS` in mesh units.
//!
//! ## Guarantees
//! * Away from the surfaces the sign of a sharp composite is exactly the boolean combination of
//!   the children's signs. A smooth composite agrees with it wherever every child's scaled
//!   value is at least `k/4` from zero.
//! * Values are f64 throughout; [`Field::values`] evaluates each child vectorized and in
//!   parallel, then combines.
//! * Children must all be 2D or all 3D; a 4D (space-time) model cannot be combined.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::Shape;
use crate::error::{Error, Result};
use crate::field::Field;
use crate::geometry::{Aabb, DVec3};

/// A boolean operation on shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Operation {
    /// Inside either shape: `max(a, b)`.
    Union,
    /// Inside both shapes: `min(a, b)`.
    Intersection,
    /// Inside the first shape and outside the others: `min(a, -b)`.
    Difference,
}

impl Operation {
    /// Every operation, in the order the command line lists them.
    pub const ALL: [Operation; 3] =
        [Operation::Union, Operation::Intersection, Operation::Difference];

    /// The operation's name in model files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Operation::Union => "union",
            Operation::Intersection => "intersection",
            Operation::Difference => "difference",
        }
    }

    /// The operation named `name` (`union`, `intersection` or `difference`).
    pub fn from_name(name: &str) -> Option<Operation> {
        Operation::ALL.into_iter().find(|op| op.name() == name)
    }

    /// The boolean combination of "inside the accumulated shape" and "inside the next child".
    pub fn combine_inside(self, acc: bool, next: bool) -> bool {
        match self {
            Operation::Union => acc || next,
            Operation::Intersection => acc && next,
            Operation::Difference => acc && !next,
        }
    }
}

impl fmt::Display for Operation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One operand of a composite: a shape, its bounds (mesh units) and the distance scale its
/// values are divided by.
#[derive(Debug, Clone)]
pub struct Child {
    shape: Shape,
    bounds: Aabb,
    scale: f64,
}

impl Child {
    /// `shape`, whose inside lies in `bounds`, divided by its [`Shape::distance_scale`]. A
    /// [`crate::model::Model`] converts into a child with `Child::from(model)`.
    pub fn new(shape: Shape, bounds: Aabb) -> Child {
        let scale = shape.distance_scale();
        Child { shape, bounds, scale }
    }

    /// `shape` in `bounds` divided by `scale`, as read from a model file. `context` names the
    /// source for errors: the scale must be finite and positive.
    pub fn with_scale(context: &str, shape: Shape, bounds: Aabb, scale: f64) -> Result<Child> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(Error::invalid(
                context,
                format!("the distance scale {scale} is not finite and positive"),
            ));
        }
        Ok(Child { shape, bounds, scale })
    }

    /// The shape.
    pub fn shape(&self) -> &Shape {
        &self.shape
    }

    /// The bounds of the shape's inside, mesh units.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The distance scale: the child's values are divided by it.
    pub fn scale(&self) -> f64 {
        self.scale
    }
}

/// A CSG tree node: an operation on two or more children, sharp or smoothly blended.
/// Positive inside, negative outside, approximately a signed distance in mesh units near the
/// surface (see the [module doc](self)).
#[derive(Debug, Clone)]
pub struct Composite {
    operation: Operation,
    blend: f64,
    children: Vec<Child>,
    dim: usize,
}

impl Composite {
    /// `operation` applied to `children` in order, with a fillet of radius `blend` in mesh units
    /// (0 for sharp). `context` names the source for errors.
    ///
    /// # Errors
    /// Fewer than two children, a blend radius that is negative or not finite, children of
    /// different dimensions (2D with 3D), or a 4D child.
    pub fn new(
        context: &str,
        operation: Operation,
        blend: f64,
        children: Vec<Child>,
    ) -> Result<Composite> {
        if children.len() < 2 {
            return Err(Error::invalid(
                context,
                format!("a {operation} needs at least two shapes, not {}", children.len()),
            ));
        }
        if !(blend.is_finite() && blend >= 0.0) {
            return Err(Error::invalid(
                context,
                format!("the blend radius {blend} is not a finite number >= 0"),
            ));
        }
        let dim = children[0].shape.dim();
        for (i, child) in children.iter().enumerate() {
            let d = child.shape.dim();
            if d == 4 {
                return Err(Error::invalid(
                    context,
                    format!("shape {} is a 4D (space-time) model, which CSG cannot combine", i + 1),
                ));
            }
            if d != dim {
                return Err(Error::invalid(
                    context,
                    format!(
                        "shape 1 is {dim}D but shape {} is {d}D: only models of the same \
                         dimension combine",
                        i + 1
                    ),
                ));
            }
        }
        Ok(Composite { operation, blend, children, dim })
    }

    /// The operation.
    pub fn operation(&self) -> Operation {
        self.operation
    }

    /// The blend radius in mesh units; 0 for sharp.
    pub fn blend(&self) -> f64 {
        self.blend
    }

    /// The children, in order.
    pub fn children(&self) -> &[Child] {
        &self.children
    }

    /// The dimension of every child: 2 or 3.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// A box holding the composite's inside: the union of the children's bounds for a union
    /// (grown by the blend radius, which a fillet may reach), their intersection for an
    /// intersection and the first child's bounds for a difference.
    ///
    /// # Errors
    /// An intersection of children whose bounds do not overlap: its inside is empty.
    pub fn bounds(&self) -> Result<Aabb> {
        let mut boxes = self.children.iter().map(|c| c.bounds);
        let first = boxes.next().expect("a composite has at least two children");
        Ok(match self.operation {
            Operation::Union => {
                let all =
                    boxes.fold(first, |a, b| Aabb { min: a.min.min(b.min), max: a.max.max(b.max) });
                let grow = DVec3::splat(self.blend);
                let grow = if self.dim == 2 { grow.with_z(0.0) } else { grow };
                Aabb { min: all.min - grow, max: all.max + grow }
            }
            Operation::Intersection => {
                let both =
                    boxes.fold(first, |a, b| Aabb { min: a.min.max(b.min), max: a.max.min(b.max) });
                if both.min.cmpgt(both.max).any() {
                    return Err(Error::invalid(
                        "intersection",
                        "the shapes' bounds do not overlap, so the intersection is empty",
                    ));
                }
                both
            }
            Operation::Difference => first,
        })
    }

    /// Combines the accumulated value `acc` (with gradient `ga`) and the next child's `b` (`gb`)
    /// into the value and the weight `h` of `ga` in the gradient `h ga + (1 - h) gb`.
    fn step(&self, acc: f64, b: f64) -> (f64, f64) {
        match self.operation {
            Operation::Union => {
                let (v, h) = smooth_min(-acc, -b, self.blend);
                (-v, h)
            }
            Operation::Intersection => smooth_min(acc, b, self.blend),
            Operation::Difference => smooth_min(acc, -b, self.blend),
        }
    }

    /// The sign the next child's gradient enters with: negated for a difference.
    fn sign(&self) -> f64 {
        if self.operation == Operation::Difference { -1.0 } else { 1.0 }
    }
}

/// `(smin(a, b), h)`: Quilez's quadratic smooth minimum of radius `k` and the weight `h` of
/// `a` in its gradient (see the [module doc](self)); the sharp minimum when `k == 0`, with `h`
/// 1 or 0.
fn smooth_min(a: f64, b: f64, k: f64) -> (f64, f64) {
    if k <= 0.0 || (a - b).abs() >= k {
        return if a <= b { (a, 1.0) } else { (b, 0.0) };
    }
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    (h * a + (1.0 - h) * b - k * h * (1.0 - h), h)
}

impl Field for Composite {
    /// The combined value: positive inside, negative outside.
    fn value(&self, p: DVec3) -> f64 {
        let mut values = self.children.iter().map(|c| c.shape.value(p) / c.scale);
        let first = values.next().expect("a composite has at least two children");
        values.fold(first, |acc, b| self.step(acc, b).0)
    }

    /// The gradient of the combined value (pointing inside): the chosen child's for sharp
    /// operators, the smooth minimum's exact blend of the children's for smooth ones.
    fn gradient(&self, p: DVec3) -> DVec3 {
        let mut children = self.children.iter();
        let first = children.next().expect("a composite has at least two children");
        let mut acc = first.shape.value(p) / first.scale;
        let mut grad = first.shape.gradient(p) / first.scale;
        for c in children {
            let b = c.shape.value(p) / c.scale;
            let (v, h) = self.step(acc, b);
            if h < 1.0 {
                let gb = self.sign() * c.shape.gradient(p) / c.scale;
                grad = h * grad + (1.0 - h) * gb;
            }
            acc = v;
        }
        grad
    }

    /// Each child's values (vectorized and in parallel), combined point by point.
    fn values(&self, points: &[DVec3]) -> Vec<f64> {
        let mut children = self.children.iter();
        let first = children.next().expect("a composite has at least two children");
        let mut acc: Vec<f64> =
            first.shape.values(points).into_iter().map(|v| v / first.scale).collect();
        for c in children {
            for (a, b) in acc.iter_mut().zip(c.shape.values(points)) {
                *a = self.step(*a, b / c.scale).0;
            }
        }
        acc
    }

    /// Every child's surface points. The composite's surface is made of pieces of its
    /// children's (moved by at most the fillet where blended), so they are near it where it
    /// keeps the children's surfaces; points a child has inside another shape are not on the
    /// composite's surface, which costs polygonization only the cubes around them.
    fn surface_points(&self) -> Vec<DVec3> {
        self.children.iter().flat_map(|c| c.shape.surface_points()).collect()
    }

    /// The smallest of the children's batch sizes for fast summation: every child is
    /// evaluated at all the points.
    fn fast_batch(&self) -> Option<usize> {
        self.children.iter().filter_map(|c| c.shape.fast_batch()).min()
    }
}
