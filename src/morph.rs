//! Morphing between two implicit surfaces (paper sections 1 and 7): "interpolating between
//! implicit surfaces effectively morphs between the two shapes of arbitrary manifold topology".
//!
//! A [`Morph`] from a source model A to a target model B gives, for every time `t` in `[0, 1]`,
//! a [`Frame`]: a [`Field`] (**inside positive, outside negative**) whose zero set is the shape
//! at that time, A at `t = 0` and B at `t = 1`. Genus may change on the way: the frames are
//! functions over all of space, not deformed meshes. Two methods ([`Method`]):
//!
//! * **Blend**: `f_t = (1 - t) a / s_A + t b / s_B`, a linear blend of the two functions. At
//!   `t = 0` and `t = 1` it is exactly A and B (scaled by a positive factor, so the same shapes).
//! * **Variational**: the shape transformation of Turk and O'Brien (SIGGRAPH 1999). The
//!   constraints of A are placed at time 0 and those of B at time `L`, as 4D points
//!   `(x, y, z, w)`, and one variational implicit function `g` is solved through all of them in
//!   4D ([`Implicit::solve`] with `dim = 4`); the frame at `t` is its slice at `w = t L`, plus
//!   an end correction:
//!
//!   ```text
//!   f_t(x) = g(x, t L) + (1 - t) (a(x) - g(x, 0)) + t (b(x) - g(x, L))
//!   ```
//!
//!   The slices `g(x, 0)` and `g(x, L)` interpolate A's and B's constraints but differ from A
//!   and B between them, the more so the closer the two ends are in time; the correction
//!   vanishes at every constraint and makes the first and last frames A and B (up to rounding).
//!   `L` is [`MorphOptions::time_scale`] times the largest side of the morph's bounds: long
//!   enough that the ends' slices stay close to A and B (the correction small), short enough that
//!   the in-between shapes keep detail (at `L` equal to the shapes' size the middle frames are
//!   far from every constraint in 4D and come out as smooth blobs). The solve is dense: its
//!   cost grows with the cube of the constraints of A and B together.
//!
//! ## Comparable scales
//! Both methods first divide each model's values by its distance scale
//! ([`crate::shape::Shape::distance_scale`]: the median gradient magnitude at its boundary
//! constraints),
//! so both functions approximate signed distances in mesh units near their surfaces and neither
//! dominates the blend because it happens to be steeper.
//!
//! ## Alignment
//! With [`MorphOptions::align`], B is first moved and uniformly scaled onto A's bounding box
//! ([`Similarity::onto`]: centre onto centre, scaled by the ratio of the box diagonals, so B
//! keeps its proportions). Values scale with the map, so the moved function stays a distance in
//! mesh units: the blend evaluates `sigma b(map^-1(x))`, the variational method moves B's
//! constraint positions and multiplies their values by `sigma`. Without it the shapes stay where
//! they are.
//!
//! Both models must be 3D; the blend accepts any model (a CSG composite too), the variational
//! method needs fitted variational implicit functions, whose constraints it reads.

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::field::Field;
use crate::geometry::{Aabb, DVec3};
use crate::model::Model;
use crate::rbf::{Constraint, Implicit, Kernel};
use crate::shape::Shape;

/// How the in-between shapes are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// A linear blend of the two scaled functions.
    #[default]
    Blend,
    /// Turk and O'Brien's 4D variational shape transformation.
    Variational,
}

/// The options of a morph.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MorphOptions {
    /// The method.
    pub method: Method,
    /// Move and scale B onto A's bounding box first.
    pub align: bool,
    /// The kernel of the 4D solve of the variational method.
    pub kernel: Kernel,
    /// The variational method's time separation `L` of the two ends, as a fraction of the
    /// largest side of the morph's bounds (default 0.25).
    pub time_scale: f64,
}

impl Default for MorphOptions {
    fn default() -> Self {
        MorphOptions {
            method: Method::default(),
            align: false,
            kernel: Kernel::default(),
            time_scale: 0.25,
        }
    }
}

/// The map `x -> to + scale (x - from)`: a translation and a uniform scaling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity {
    /// The point mapped onto `to`.
    pub from: DVec3,
    /// Where `from` goes.
    pub to: DVec3,
    /// The scale factor, positive.
    pub scale: f64,
}

impl Similarity {
    /// The map that leaves everything in place.
    pub const IDENTITY: Similarity = Similarity { from: DVec3::ZERO, to: DVec3::ZERO, scale: 1.0 };

    /// The map taking the centre of `moved` onto the centre of `fixed`, scaled by the ratio of
    /// their diagonals (1 when `moved` has no extent).
    pub fn onto(moved: &Aabb, fixed: &Aabb) -> Similarity {
        let ratio = fixed.diagonal() / moved.diagonal();
        let scale = if ratio.is_finite() && ratio > 0.0 { ratio } else { 1.0 };
        Similarity { from: moved.center(), to: fixed.center(), scale }
    }

    /// The image of `p`.
    pub fn apply(&self, p: DVec3) -> DVec3 {
        self.to + self.scale * (p - self.from)
    }

    /// The point whose image is `p`.
    pub fn invert(&self, p: DVec3) -> DVec3 {
        self.from + (p - self.to) / self.scale
    }

    /// The image of a box.
    pub fn apply_box(&self, b: &Aabb) -> Aabb {
        Aabb { min: self.apply(b.min), max: self.apply(b.max) }
    }
}

/// A model divided by its distance scale and placed by a similarity: the field
/// `sigma f(map^-1(x)) / s`.
#[derive(Debug, Clone)]
struct Placed {
    model: Model,
    scale: f64,
    placement: Similarity,
}

impl Placed {
    fn value(&self, p: DVec3) -> f64 {
        self.placement.scale * self.model.value(self.placement.invert(p)) / self.scale
    }

    /// The gradient: the map's scale cancels against the chain rule's `1 / sigma`.
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.model.gradient(self.placement.invert(p)) / self.scale
    }

    fn values(&self, points: &[DVec3]) -> Vec<f64> {
        let factor = self.placement.scale / self.scale;
        if self.placement == Similarity::IDENTITY {
            return self.model.values(points).into_iter().map(|v| v * factor).collect();
        }
        let moved: Vec<DVec3> = points.par_iter().map(|&p| self.placement.invert(p)).collect();
        self.model.values(&moved).into_iter().map(|v| v * factor).collect()
    }
}

/// The 4D function of the variational method and the time `L` of its end.
#[derive(Debug, Clone)]
struct SpaceTime {
    implicit: Implicit,
    duration: f64,
}

impl SpaceTime {
    fn value(&self, p: DVec3, w: f64) -> f64 {
        self.implicit.value_at(&[p.x, p.y, p.z, w])
    }

    fn gradient(&self, p: DVec3, w: f64) -> DVec3 {
        let g = self.implicit.gradient_at(&[p.x, p.y, p.z, w]);
        DVec3::new(g[0], g[1], g[2])
    }

    fn values(&self, points: &[DVec3], w: f64) -> Vec<f64> {
        let flat: Vec<f64> = points.iter().flat_map(|p| [p.x, p.y, p.z, w]).collect();
        self.implicit.values_flat(&flat)
    }
}

/// A morph from a source model to a target model; see the [module doc](self).
#[derive(Debug, Clone)]
pub struct Morph {
    source: Placed,
    target: Placed,
    space_time: Option<SpaceTime>,
    bounds: Aabb,
    placement: Similarity,
}

impl Morph {
    /// The morph from `source` to `target` with `options`.
    ///
    /// # Errors
    /// A model that is not 3D, a time scale that is not finite and positive; for the
    /// variational method, a model that is not a variational implicit function (a CSG
    /// composite), or a 4D solve that fails (see [`Implicit::solve`]).
    pub fn new(source: &Model, target: &Model, options: &MorphOptions) -> Result<Morph> {
        for (name, model) in [("the source", source), ("the target", target)] {
            if model.dim() != 3 {
                return Err(Error::invalid(
                    "morph",
                    format!("{name} is a {}D model; only 3D models morph", model.dim()),
                ));
            }
        }
        let placement = if options.align {
            Similarity::onto(&target.bounds(), &source.bounds())
        } else {
            Similarity::IDENTITY
        };
        let moved = placement.apply_box(&target.bounds());
        let a = source.bounds();
        let bounds = Aabb { min: a.min.min(moved.min), max: a.max.max(moved.max) };
        if !(options.time_scale.is_finite() && options.time_scale > 0.0) {
            return Err(Error::invalid(
                "morph",
                format!("the time scale {} is not finite and positive", options.time_scale),
            ));
        }
        let space_time = match options.method {
            Method::Blend => None,
            Method::Variational => {
                let side = bounds.size().max_element();
                let duration = options.time_scale * if side > 0.0 { side } else { 1.0 };
                let mut constraints = space_time(source, "the source", &Similarity::IDENTITY, 0.0)?;
                constraints.extend(space_time(target, "the target", &placement, duration)?);
                let implicit = Implicit::solve(4, options.kernel, &constraints)?;
                Some(SpaceTime { implicit, duration })
            }
        };
        Ok(Morph {
            source: Placed {
                model: source.clone(),
                scale: source.shape().distance_scale(),
                placement: Similarity::IDENTITY,
            },
            target: Placed {
                model: target.clone(),
                scale: target.shape().distance_scale(),
                placement,
            },
            space_time,
            bounds,
            placement,
        })
    }

    /// A box holding both shapes (B as placed): where to polygonize or draw the frames.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The map applied to B: the identity unless aligned.
    pub fn placement(&self) -> Similarity {
        self.placement
    }

    /// The shape at time `t`, A at 0 and B at 1.
    pub fn frame(&self, t: f64) -> Frame<'_> {
        Frame { morph: self, t }
    }

    /// The variational method's 4D function `g` and the time `L` of B, if that is the method.
    pub fn space_time(&self) -> Option<(&Implicit, f64)> {
        self.space_time.as_ref().map(|s| (&s.implicit, s.duration))
    }
}

/// The constraints of `model` moved by `placement`, at time `w`, with values divided by the
/// model's distance scale and multiplied by the placement's scale.
fn space_time(
    model: &Model,
    name: &str,
    placement: &Similarity,
    w: f64,
) -> Result<Vec<Constraint>> {
    let implicit = match model.shape() {
        Shape::Rbf(implicit) => implicit,
        _ => {
            return Err(Error::invalid(
                "morph",
                format!(
                    "{name} is not a fitted variational implicit function (a CSG composite, or \
                     one with detail levels, which it cannot read yet?); the variational method \
                     needs its constraints, the blend method does not"
                ),
            ));
        }
    };
    let factor = placement.scale / model.shape().distance_scale();
    Ok(implicit
        .constraints()
        .iter()
        .map(|c| {
            let p = c.position();
            let q = placement.apply(DVec3::new(p[0], p[1], p[2]));
            Constraint::new(&[q.x, q.y, q.z, w], c.value() * factor)
        })
        .collect())
}

/// The times of `steps` frames from 0 to 1 inclusive, evenly spaced.
///
/// # Errors
/// Fewer than two steps: a morph needs at least its two ends.
pub fn frame_times(steps: usize) -> Result<Vec<f64>> {
    if steps < 2 {
        return Err(Error::invalid(
            "morph",
            format!("{steps} steps: a morph needs at least 2 (its first and last shapes)"),
        ));
    }
    Ok((0..steps).map(|i| i as f64 / (steps - 1) as f64).collect())
}

/// The shape of a [`Morph`] at one time: positive inside, negative outside.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    morph: &'a Morph,
    t: f64,
}

impl Frame<'_> {
    /// The time: 0 is the source, 1 the target.
    pub fn time(&self) -> f64 {
        self.t
    }
}

impl Field for Frame<'_> {
    /// The frame's value: positive inside, negative outside.
    fn value(&self, p: DVec3) -> f64 {
        let (m, t) = (self.morph, self.t);
        let (a, b) = (m.source.value(p), m.target.value(p));
        match &m.space_time {
            None => (1.0 - t) * a + t * b,
            Some(g) => {
                g.value(p, t * g.duration)
                    + (1.0 - t) * (a - g.value(p, 0.0))
                    + t * (b - g.value(p, g.duration))
            }
        }
    }

    /// The frame's spatial gradient, pointing inside.
    fn gradient(&self, p: DVec3) -> DVec3 {
        let (m, t) = (self.morph, self.t);
        let (a, b) = (m.source.gradient(p), m.target.gradient(p));
        match &m.space_time {
            None => (1.0 - t) * a + t * b,
            Some(g) => {
                g.gradient(p, t * g.duration)
                    + (1.0 - t) * (a - g.gradient(p, 0.0))
                    + t * (b - g.gradient(p, g.duration))
            }
        }
    }

    /// The frame's values at many points, each function vectorized and in parallel; a term
    /// whose weight is zero (an end of the morph) is not evaluated.
    fn values(&self, points: &[DVec3]) -> Vec<f64> {
        let (m, t) = (self.morph, self.t);
        let mut out = vec![0.0; points.len()];
        let mut add = |weight: f64, values: &dyn Fn() -> Vec<f64>| {
            if weight != 0.0 {
                for (o, v) in out.iter_mut().zip(values()) {
                    *o += weight * v;
                }
            }
        };
        add(1.0 - t, &|| m.source.values(points));
        add(t, &|| m.target.values(points));
        if let Some(g) = &m.space_time {
            add(1.0, &|| g.values(points, t * g.duration));
            add(-(1.0 - t), &|| g.values(points, 0.0));
            add(-t, &|| g.values(points, g.duration));
        }
        out
    }
}
