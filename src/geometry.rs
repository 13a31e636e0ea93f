//! Small geometric types shared by every stage: points and axis-aligned boxes.
//!
//! Positions are `f64` ([`DVec3`] from glam) everywhere a position is stored, so a mesh far
//! from the origin or in large units loses nothing before it is normalized onto a grid.

pub use glam::DVec3;

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The smallest corner.
    pub min: DVec3,
    /// The largest corner.
    pub max: DVec3,
}

impl Aabb {
    /// The smallest box holding every point, or `None` when there are none.
    pub fn of_points<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> Option<Aabb> {
        let mut it = points.into_iter();
        let first = *it.next()?;
        Some(it.fold(Aabb { min: first, max: first }, |b, &p| Aabb {
            min: b.min.min(p),
            max: b.max.max(p),
        }))
    }

    /// The box's extent along each axis.
    pub fn size(&self) -> DVec3 {
        self.max - self.min
    }

    /// The box's centre.
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// The length of the box's diagonal.
    pub fn diagonal(&self) -> f64 {
        self.size().length()
    }
}
