//! The shapes a model can hold: a variational implicit function, one with detail levels, or a
//! CSG tree of shapes.
//!
//! This is the one place that lists them. A [`crate::model::Model`] holds a shape with its bounds,
//! fit grid and report; a CSG child ([`csg::Child`]) holds a shape with its bounds and
//! distance scale, so trees nest. Every shape is a [`Field`]: positive inside, negative
//! outside, in the mesh's units.

pub mod csg;

use crate::field::Field;
use crate::geometry::DVec3;
use crate::rbf::Implicit;
use crate::rbf::MultiScale;
use csg::Composite;

/// The shape a model describes.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum Shape {
    /// A variational implicit function.
    Rbf(Implicit),
    /// A CSG tree of shapes (see [`csg`]).
    Csg(Composite),
    /// A variational implicit function with detail levels over it (see [`crate::rbf::MultiScale`]).
    Levels(MultiScale),
}

impl Shape {
    /// The shape as a field.
    pub fn field(&self) -> &dyn Field {
        match self {
            Shape::Rbf(implicit) => implicit,
            Shape::Csg(composite) => composite,
            Shape::Levels(levels) => levels,
        }
    }

    /// The number of coordinates the shape reads: 2, 3 or 4 (space-time).
    pub fn dim(&self) -> usize {
        match self {
            Shape::Rbf(implicit) => implicit.dim(),
            Shape::Csg(composite) => composite.dim(),
            Shape::Levels(_) => 3,
        }
    }

    /// The variational implicit function, when the shape is one (without detail levels).
    pub fn implicit(&self) -> Option<&Implicit> {
        match self {
            Shape::Rbf(implicit) => Some(implicit),
            Shape::Csg(_) | Shape::Levels(_) => None,
        }
    }

    /// Whether the shape has detail levels anywhere in it (itself or a CSG child): what the
    /// consumers that do not read them yet refuse.
    pub fn has_levels(&self) -> bool {
        match self {
            Shape::Rbf(_) => false,
            Shape::Csg(composite) => composite.children().iter().any(|c| c.shape().has_levels()),
            Shape::Levels(_) => true,
        }
    }

    /// The typical gradient magnitude of the shape's function at its surface, in value units
    /// per mesh unit: dividing by it makes values approximate signed distances in mesh units.
    /// That of the implicit function ([`Implicit::distance_scale`]), of level 0 for a shape with
    /// detail levels (they correct values by a fraction of a voxel's slope); a composite is
    /// already scaled, so its scale is 1.
    pub fn distance_scale(&self) -> f64 {
        match self {
            Shape::Rbf(implicit) => implicit.distance_scale(),
            Shape::Levels(levels) => levels.base().distance_scale(),
            Shape::Csg(_) => 1.0,
        }
    }
}

impl Field for Shape {
    /// The shape's value: positive inside, negative outside.
    fn value(&self, p: DVec3) -> f64 {
        self.field().value(p)
    }

    /// The shape's gradient, pointing inside.
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.field().gradient(p)
    }

    /// The shape's values at many points, vectorized and in parallel.
    fn values(&self, points: &[DVec3]) -> Vec<f64> {
        self.field().values(points)
    }

    /// The shape's points on its surface.
    fn surface_points(&self) -> Vec<DVec3> {
        self.field().surface_points()
    }

    /// The shape's batch size for fast summation.
    fn fast_batch(&self) -> Option<usize> {
        self.field().fast_batch()
    }
}
