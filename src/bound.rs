//! Bounds of a shape's function over a box: an interval holding every value the function takes
//! in the box, from its coefficients alone. The page of `implicitize view` crosses in one step
//! the blocks whose upper bound is not positive (no part of the surface can be there) and
//! samples only the others, so thin parts are never skipped.
//!
//! For a variational implicit function `f(q) = p0 + l.q + sum_j w_j phi(|q - c_j|)` (in its
//! normalized coordinates `q`) over a box of centre `b` and half-diagonal `rho`:
//!
//! * a centre *near* the box (closer to it than `rho`) enters by the range of its own term,
//!   `w_j phi(r)` for `r` between its nearest and farthest distance to the box;
//! * the other terms and the polynomial, summed as `s`, by Taylor's theorem at `b`:
//!   `|s(q) - s(b)| <= rho |grad s(b)| + rho^2 / 2 * sum_j |w_j| H_j`, where `H_j` bounds the
//!   spectral norm of the Hessian of `phi(|q - c_j|)` over the box, `max(|phi''|, |phi'(r)/r|)`
//!   over its distances to the box (each is monotone in `r` for every kernel, so it is read at
//!   the two ends).
//!
//! A detail level ([`crate::rbf::MultiScale`]) adds the range of each of its terms whose support meets the
//! box: Wendland's function falls from 1 to 0 over its support, so a term lies between its
//! values at the farthest and the nearest distance. A CSG composite ([`crate::shape::csg`]) combines
//! its children's intervals, each divided by its distance scale, through its operation: the
//! smooth minimum of radius `k` is nondecreasing in both arguments and lies between
//! `min(a, b) - k/4` and `min(a, b)`.
//!
//! The intervals hold in exact arithmetic and are widened by `1e-12` of the sum of the terms'
//! magnitudes for rounding. They are loose where large weights cancel (the Hessian term sums
//! `|w_j|`), which costs the viewer time (more blocks sampled) but never a part of the surface.
//! A shape that is not 3D gets the whole real line.

use rayon::prelude::*;

use crate::geometry::{Aabb, DVec3};
use crate::rbf::MultiScale;
use crate::rbf::{DetailLevel, Implicit, Kernel, wendland};
use crate::render::LatticeGeometry;
use crate::shape::Shape;
use crate::shape::csg::{Composite, Operation};

/// The values a function can take: `lo <= f <= hi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Interval {
    /// The least value possible.
    pub lo: f64,
    /// The largest value possible.
    pub hi: f64,
}

impl Interval {
    /// Every real number: nothing is known.
    pub const EVERYTHING: Interval = Interval { lo: f64::NEG_INFINITY, hi: f64::INFINITY };

    fn add(self, other: Interval) -> Interval {
        Interval { lo: self.lo + other.lo, hi: self.hi + other.hi }
    }

    fn scaled(self, s: f64) -> Interval {
        let (a, b) = (self.lo * s, self.hi * s);
        Interval { lo: a.min(b), hi: a.max(b) }
    }

    fn negated(self) -> Interval {
        Interval { lo: -self.hi, hi: -self.lo }
    }
}

/// An interval holding every value of `shape`'s function in `region` (mesh units).
pub(crate) fn range(shape: &Shape, region: &Aabb) -> Interval {
    match shape {
        Shape::Rbf(implicit) => implicit_range(implicit, region),
        Shape::Levels(levels) => levels_range(levels, region),
        Shape::Csg(composite) => composite_range(composite, region),
    }
}

/// An upper bound of `shape`'s function over `region`, tightened by splitting the region in
/// eight, up to `depth` times, where [`range`] cannot tell its sign: not positive when some
/// partition of the region proves the function is nowhere positive there. (Only the sign is
/// sought: a positive bound is returned as soon as a smallest part may be positive.)
pub(crate) fn upper(shape: &Shape, region: &Aabb, depth: u32) -> f64 {
    match shape {
        // The levels' interval over the whole region holds over each part of it: it is found
        // once, and only level 0's is split.
        Shape::Levels(levels) => {
            let detail =
                levels.levels().iter().fold(Interval { lo: 0.0, hi: 0.0 }, |sum, level| {
                    sum.add(level_range(level, region))
                });
            split_upper(&|part| implicit_range(levels.base(), part).add(detail), region, depth)
        }
        _ => split_upper(&|part| range(shape, part), region, depth),
    }
}

/// [`upper`] of the function whose interval over a box `range` gives.
fn split_upper(range: &dyn Fn(&Aabb) -> Interval, region: &Aabb, depth: u32) -> f64 {
    let interval = range(region);
    if interval.hi <= 0.0 || interval.lo > 0.0 || depth == 0 {
        return interval.hi;
    }
    let half = 0.5 * region.size();
    let mut most = f64::NEG_INFINITY;
    for corner in 0..8 {
        let pick = |bit: usize| if corner >> bit & 1 == 1 { 1.0 } else { 0.0 };
        let min = region.min + half * DVec3::new(pick(0), pick(1), pick(2));
        let part = split_upper(range, &Aabb { min, max: min + half }, depth - 1);
        if part > 0.0 {
            return part;
        }
        most = most.max(part);
    }
    most
}

/// `upper` over every block of `block`^3 cells of `lattice` (the last block of an axis may be
/// cut short by the lattice) to `depth`, in parallel; the blocks in the order of a 3D texture:
/// x fastest, then y, then z. Also returns the blocks per axis.
pub fn block_uppers(
    shape: &Shape,
    lattice: &LatticeGeometry,
    block: usize,
    depth: u32,
) -> (Vec<f64>, [usize; 3]) {
    let block = block.max(1);
    let blocks = lattice.cells.map(|c| c.div_ceil(block));
    let side = lattice.step * block as f64;
    let end = lattice.origin
        + lattice.step
            * DVec3::new(lattice.cells[0] as f64, lattice.cells[1] as f64, lattice.cells[2] as f64);
    let ranges = (0..blocks.iter().product::<usize>())
        .into_par_iter()
        .map(|n| {
            let (i, j, k) = (n % blocks[0], n / blocks[0] % blocks[1], n / (blocks[0] * blocks[1]));
            let min = lattice.origin + side * DVec3::new(i as f64, j as f64, k as f64);
            upper(shape, &Aabb { min, max: (min + side).min(end) }, depth)
        })
        .collect();
    (ranges, blocks)
}

/// The nearest and farthest distance from `c` to the box.
fn distances(c: DVec3, region: &Aabb) -> (f64, f64) {
    let near = (region.min - c).max(DVec3::ZERO).max(c - region.max).length();
    let far = (region.min - c).abs().max((region.max - c).abs()).length();
    (near, far)
}

/// The range of `phi(r)` for `r` in `[a, b]`.
fn phi_range(kernel: Kernel, a: f64, b: f64) -> Interval {
    let (pa, pb) = (kernel.phi_of_r2(a * a), kernel.phi_of_r2(b * b));
    let mut lo = pa.min(pb);
    if kernel == Kernel::ThinPlate {
        // r^2 ln r falls to its minimum -1/(2e) at r = e^(-1/2), then rises.
        let bottom = (-0.5f64).exp();
        if a <= bottom && bottom <= b {
            lo = -0.5 / std::f64::consts::E;
        }
    }
    Interval { lo, hi: pa.max(pb) }
}

/// A bound of the spectral norm of the Hessian of `phi(|q|)` for `|q|` in `[a, b]`, `a > 0`:
/// the largest of `|phi''(r)|` and `|phi'(r) / r|` there.
fn hessian_bound(kernel: Kernel, a: f64, b: f64) -> f64 {
    match kernel {
        // phi'' = 2 ln r + 3, phi'/r = 2 ln r + 1: both monotone.
        Kernel::ThinPlate => [a, b]
            .into_iter()
            .map(|r| (2.0 * r.ln() + 3.0).abs().max((2.0 * r.ln() + 1.0).abs()))
            .fold(0.0, f64::max),
        // phi'' = 6 r, phi'/r = 3 r.
        Kernel::Cubic => 6.0 * b,
        // phi'' = 0, phi'/r = 1 / r.
        Kernel::Linear => 1.0 / a,
    }
}

/// The interval of a variational implicit function over `region` (see the [module doc](self)).
fn implicit_range(implicit: &Implicit, region: &Aabb) -> Interval {
    if implicit.dim() != 3 {
        return Interval::EVERYTHING;
    }
    let norm = implicit.normalization();
    let to_q = |p: DVec3| {
        let mut q = [0.0; 3];
        norm.apply(&p.to_array(), &mut q);
        DVec3::from_array(q)
    };
    let boxed = Aabb { min: to_q(region.min), max: to_q(region.max) };
    let b = boxed.center();
    let rho = 0.5 * boxed.size().length();
    let kernel = implicit.kernel();
    let poly = implicit.polynomial();
    let linear = DVec3::new(poly[1], poly[2], poly[3]);
    let mut value = poly[0] + linear.dot(b);
    let mut gradient = linear;
    let mut curvature = 0.0;
    let mut near = Interval { lo: 0.0, hi: 0.0 };
    let mut magnitude = value.abs();
    for (constraint, &w) in implicit.constraints().iter().zip(implicit.weights()) {
        let c = to_q(DVec3::from_slice(constraint.position()));
        let (a, far) = distances(c, &boxed);
        if a < rho {
            let term = phi_range(kernel, a, far).scaled(w);
            near = near.add(term);
            magnitude += term.lo.abs().max(term.hi.abs());
            continue;
        }
        let d = b - c;
        let r2 = d.length_squared();
        let term = w * kernel.phi_of_r2(r2);
        value += term;
        magnitude += term.abs();
        gradient += d * (w * kernel.dphi_over_r(r2));
        curvature += w.abs() * hessian_bound(kernel, a, far);
    }
    let spread = rho * gradient.length() + 0.5 * rho * rho * curvature + 1e-12 * magnitude;
    near.add(Interval { lo: value - spread, hi: value + spread })
}

/// Level 0's interval plus each level's.
fn levels_range(levels: &MultiScale, region: &Aabb) -> Interval {
    levels.levels().iter().fold(implicit_range(levels.base(), region), |sum, level| {
        sum.add(level_range(level, region))
    })
}

/// The interval of one detail level over `region`: the sum of the ranges of the terms whose
/// support meets it (found through the level's support index).
fn level_range(level: &DetailLevel, region: &Aabb) -> Interval {
    let radius = level.radius();
    let mut sum = Interval { lo: 0.0, hi: 0.0 };
    let mut magnitude = 0.0;
    for j in level.centres_near(region.min, region.max) {
        let (c, w) = (level.centres()[j as usize], level.weights()[j as usize]);
        let (a, far) = distances(c, region);
        if a >= radius {
            continue;
        }
        let (top, bottom) = (w * wendland(a / radius), w * wendland(far / radius));
        sum = sum.add(Interval { lo: top.min(bottom), hi: top.max(bottom) });
        magnitude += w.abs();
    }
    let slack = 1e-12 * magnitude;
    Interval { lo: sum.lo - slack, hi: sum.hi + slack }
}

/// A composite's interval from its children's (see the [module doc](self)).
fn composite_range(composite: &Composite, region: &Aabb) -> Interval {
    let k = composite.blend();
    let mut children =
        composite.children().iter().map(|c| range(c.shape(), region).scaled(1.0 / c.scale()));
    let first = children.next().expect("a composite has at least two children");
    children.fold(first, |acc, b| match composite.operation() {
        Operation::Union => Interval { lo: acc.lo.max(b.lo), hi: acc.hi.max(b.hi) + 0.25 * k },
        Operation::Intersection => {
            Interval { lo: acc.lo.min(b.lo) - 0.25 * k, hi: acc.hi.min(b.hi) }
        }
        Operation::Difference => {
            let b = b.negated();
            Interval { lo: acc.lo.min(b.lo) - 0.25 * k, hi: acc.hi.min(b.hi) }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::Field;
    use crate::rbf::Constraint;

    /// Values at a lattice of points in `region` lie in the interval.
    fn assert_holds(shape: &Shape, region: &Aabb) {
        let interval = range(shape, region);
        assert!(interval.lo <= interval.hi);
        let n = 6;
        for i in 0..=n {
            for j in 0..=n {
                for k in 0..=n {
                    let t = DVec3::new(i as f64, j as f64, k as f64) / n as f64;
                    let p = region.min + t * region.size();
                    let v = shape.value(p);
                    assert!(
                        interval.lo <= v && v <= interval.hi,
                        "{v} at {p} outside [{}, {}] over {region:?}",
                        interval.lo,
                        interval.hi
                    );
                }
            }
        }
    }

    /// A ball of radius 1 from constraints, with `kernel`.
    fn ball(kernel: Kernel) -> Implicit {
        let mut constraints = vec![Constraint::new(&[0.0, 0.0, 0.0], 1.0)];
        for i in 0..40 {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 40.0;
            let a = 2.399_963 * i as f64;
            let s = (1.0 - z * z).sqrt();
            constraints.push(Constraint::new(&[s * a.cos(), s * a.sin(), z], 0.0));
            constraints
                .push(Constraint::new(&[2.0 * s * a.cos(), 2.0 * s * a.sin(), 2.0 * z], -1.0));
        }
        Implicit::solve(3, kernel, &constraints).expect("the ball solves")
    }

    fn boxes() -> Vec<Aabb> {
        let mut boxes = Vec::new();
        for &side in &[0.05, 0.3, 1.0, 3.0] {
            for &x in &[-1.9, -0.9, 0.0, 0.5, 1.2] {
                let min = DVec3::new(x, 0.3 * x, -0.1);
                boxes.push(Aabb { min, max: min + side });
            }
        }
        boxes
    }

    #[test]
    fn every_kernel_s_values_lie_in_its_interval() {
        for kernel in [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear] {
            let shape = Shape::Rbf(ball(kernel));
            for region in boxes() {
                assert_holds(&shape, &region);
            }
        }
    }

    #[test]
    fn a_small_box_far_outside_is_known_to_be_outside_and_one_at_the_centre_inside() {
        let shape = Shape::Rbf(ball(Kernel::ThinPlate));
        let outside = Aabb { min: DVec3::splat(1.5), max: DVec3::splat(1.55) };
        assert!(range(&shape, &outside).hi < 0.0);
        let inside = Aabb { min: DVec3::splat(-0.05), max: DVec3::splat(0.05) };
        assert!(range(&shape, &inside).lo > 0.0);
    }

    #[test]
    fn detail_levels_and_composites_stay_within_their_intervals() {
        let base = ball(Kernel::ThinPlate);
        let centres =
            vec![DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.7, 0.7, 0.0)];
        let level = DetailLevel::new("test", 0.4, centres, vec![0.3, -0.2, 0.5]).unwrap();
        let levels = Shape::Levels(MultiScale::new("test", base.clone(), vec![level]).unwrap());
        for region in boxes() {
            assert_holds(&levels, &region);
            let most = (0..=20)
                .map(|i| levels.value(region.min + region.size() * (f64::from(i) / 20.0)))
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(upper(&levels, &region, 3) >= most.min(1e-300), "{region:?}");
        }
        let moved = ball(Kernel::Cubic);
        for operation in [Operation::Union, Operation::Intersection, Operation::Difference] {
            let children = vec![
                crate::shape::csg::Child::new(
                    Shape::Rbf(base.clone()),
                    Aabb { min: DVec3::splat(-1.0), max: DVec3::splat(1.0) },
                ),
                crate::shape::csg::Child::new(
                    Shape::Rbf(moved.clone()),
                    Aabb { min: DVec3::splat(-1.0), max: DVec3::splat(1.0) },
                ),
            ];
            let composite = Composite::new("test", operation, 0.2, children).unwrap();
            let shape = Shape::Csg(composite);
            for region in boxes() {
                assert_holds(&shape, &region);
            }
        }
    }

    #[test]
    fn splitting_tightens_the_upper_bound_and_keeps_it_one() {
        let shape = Shape::Rbf(ball(Kernel::ThinPlate));
        // A box reaching from outside to just short of the surface (radius 1).
        let region = Aabb { min: DVec3::new(1.05, -0.1, -0.1), max: DVec3::new(1.45, 0.3, 0.3) };
        assert!(range(&shape, &region).hi > 0.0, "unsplit, the bound cannot tell");
        assert!(upper(&shape, &region, 4) <= 0.0, "split, it proves the box outside");
        let across = Aabb { min: DVec3::new(0.8, -0.1, -0.1), max: DVec3::new(1.2, 0.3, 0.3) };
        assert!(upper(&shape, &across, 4) > 0.0);
    }

    #[test]
    fn block_uppers_cover_the_lattice_x_fastest() {
        let shape = Shape::Rbf(ball(Kernel::ThinPlate));
        let bounds = Aabb { min: DVec3::splat(-1.2), max: DVec3::new(1.2, 1.2, 2.4) };
        let lattice = LatticeGeometry::new(&bounds, crate::render::March { cells: 16 }).unwrap();
        let (uppers, blocks) = block_uppers(&shape, &lattice, 4, 2);
        assert_eq!(uppers.len(), blocks.iter().product::<usize>());
        assert!(blocks[2] > blocks[0], "the box is longest in z");
        // The block holding the centre is inside; a corner block is outside.
        let centre = (lattice.origin.x.abs() / (4.0 * lattice.step)) as usize;
        let k = ((0.0 - lattice.origin.z) / (4.0 * lattice.step)) as usize;
        let at = |i: usize, j: usize, k: usize| uppers[(k * blocks[1] + j) * blocks[0] + i];
        assert!(at(centre, centre, k) > 0.0);
        assert!(at(0, 0, 0) <= 0.0);
    }
}
