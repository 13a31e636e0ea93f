//! The ray marcher that draws a [`Field`] from the function itself.
//!
//! A field here is not a distance field (a fitted implicit is a sum of radial basis functions
//! with no Lipschitz bound), so rays cannot take sphere-tracing steps. Instead every ray steps
//! through a lattice of exact field samples whose spacing `h` is the march step, and the root
//! where the field turns from outside (<= 0) to inside (> 0) is refined with the exact function:
//!
//! 1. **Lattice, coarse to fine.** The field is sampled at the corners and centres of cells
//!    of side `8h` over the bounds (padded by two steps), then each cell that may hold the
//!    surface is split in eight and its new corners sampled, down to cells of side `h`. A cell
//!    may hold the surface when its samples change sign, or when its smallest corner magnitude
//!    is within a margin: for the coarse cells their spread of sample values, for finer ones
//!    half the largest gap between the parent cell's trilinear interpolant and the samples that
//!    split it (an a-posteriori bound on the interpolation error, which shrinks about fourfold
//!    per halving, doubled for safety). So the band of sampled cells stays one or two cells
//!    thick where the field is smooth and widens where it bends. Each level is one batch for
//!    [`Field::values`]. Samples are stored as `f32`: they only locate the root, which is then
//!    refined in `f64`.
//! 2. **Marching.** Each pixel's ray is clipped to the lattice box, walks the 8h blocks that hold
//!    a sign change and, inside them, the cells of side `h`; the field along the ray is the
//!    trilinear interpolant of the samples, checked at three sub-steps per cell. The first
//!    sub-step where it turns positive brackets the hit, which regula falsi narrows on the
//!    interpolant.
//! 3. **Refinement.** One secant step on the exact field (its value at the bracketed root, all
//!    rays in one batch, over the interpolant's slope) moves the hit onto the function's own
//!    zero, kept inside the bracketing cell, and the exact analytic gradient there gives the
//!    normal. So every hit pixel costs two exact evaluations, and the lattice about one per
//!    surface cell.
//!
//! Guarantee: a pixel is covered exactly when the trilinear interpolant of exact samples at
//! spacing `h` turns positive along its ray inside the padded bounds, and its shading is the
//! function's own gradient at the refined hit. Parts thinner than about `h` (a tapering rim or
//! tip) can be lost or shortened, as with any march at step `h`, and sharp creases are rounded
//! by about `h`; raise [`March::cells`] for those (the sampling cost grows with its square).
//! Where the inside reaches the padded box, the box face is drawn (the bounds clip the shape),
//! decided on the `8h` samples.

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::field::Field;
use crate::geometry::{Aabb, DVec3};

use super::camera::Camera;
use super::color::{Surface, field_normal, shade};
use super::image::Image;

/// Settings of the ray marcher.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct March {
    /// Lattice cells along the longest side of the bounds: the march step is that side divided
    /// by this. Rounded up to a multiple of 8, and at least 8.
    pub cells: usize,
}

impl Default for March {
    /// 128 cells along the longest side (the step is 1/128 of it).
    fn default() -> Self {
        March { cells: 128 }
    }
}

impl March {
    /// The largest number of cells accepted along the longest side. The samples are kept in a
    /// dense `f32` array of `(cells + 1)^3` at most: 8.6 MB at the default, 540 MB at this limit.
    pub const MAX_CELLS: usize = 512;
}

/// Cells of side `h` per block side.
const BLOCK: usize = 8;

/// How close to zero, relative to the spread of its corner values, a coarse cell whose corners
/// agree in sign must come to be split: loosely, as nothing is known yet of the field's
/// curvature at that scale.
const COARSE_TOLERANCE: f32 = 1.0;

/// Sub-steps at which the interpolant is checked inside one cell.
const SUB_STEPS: usize = 3;

/// Where the march's lattice lies: cubic cells of side `step` from the corner `origin`, `cells`
/// per axis, around the bounds with two cells to spare on every side. The page of
/// `implicitize view` samples the same lattice, so it draws what [`super::render_field`] draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatticeGeometry {
    /// The lattice's least corner.
    pub origin: DVec3,
    /// The side of a cell: the longest side of the bounds over `March::cells` (rounded up to a
    /// multiple of 8).
    pub step: f64,
    /// Cells per axis, multiples of 8.
    pub cells: [usize; 3],
}

impl LatticeGeometry {
    /// The lattice [`super::render_field`] marches through around `bounds`.
    ///
    /// # Errors
    /// Bounds that are not finite or have no extent, or `march.cells` out of range.
    pub fn new(bounds: &Aabb, march: March) -> Result<LatticeGeometry> {
        let size = bounds.size();
        let longest = size.max_element();
        let finite = bounds.min.is_finite() && bounds.max.is_finite();
        if !finite || longest <= 0.0 || size.min_element() < 0.0 {
            return Err(Error::invalid(
                "render",
                format!("cannot march through the box {bounds:?}"),
            ));
        }
        if march.cells == 0 || march.cells > March::MAX_CELLS {
            return Err(Error::invalid(
                "render",
                format!(
                    "{} march cells is outside the accepted 1..={}",
                    march.cells,
                    March::MAX_CELLS
                ),
            ));
        }
        let step = longest / march.cells.next_multiple_of(BLOCK) as f64;
        let cells = [size.x, size.y, size.z]
            .map(|s| ((s / step).ceil() as usize + 4).next_multiple_of(BLOCK).max(BLOCK));
        let extent = DVec3::new(cells[0] as f64, cells[1] as f64, cells[2] as f64) * step;
        Ok(LatticeGeometry { origin: bounds.center() - 0.5 * extent, step, cells })
    }
}

/// Exact field samples on a lattice, known near the surface only.
pub(crate) struct Lattice {
    origin: DVec3,
    step: f64,
    /// Cells per axis (multiples of [`BLOCK`]).
    cells: [usize; 3],
    /// Samples at the `(cells + 1)` lattice points per axis, C order; NaN where not sampled.
    values: Vec<f32>,
    /// Per block of `BLOCK`^3 cells: whether one of its cells changes sign.
    blocks: Vec<bool>,
    /// How many exact samples were taken.
    pub(crate) samples: usize,
}

impl Lattice {
    /// Samples `field` around `bounds` with `march.cells` cells along the longest side.
    pub(crate) fn sample<F: Field + ?Sized>(
        field: &F,
        bounds: &Aabb,
        march: March,
    ) -> Result<Lattice> {
        let LatticeGeometry { origin, step, cells } = LatticeGeometry::new(bounds, march)?;
        let points = (cells[0] + 1) * (cells[1] + 1) * (cells[2] + 1);
        let mut lattice = Lattice {
            origin,
            step,
            cells,
            values: vec![f32::NAN; points],
            blocks: vec![false; cells.iter().map(|c| c / BLOCK).product()],
            samples: 0,
        };
        lattice.build(field);
        Ok(lattice)
    }

    fn point_index(&self, [i, j, k]: [usize; 3]) -> usize {
        (i * (self.cells[1] + 1) + j) * (self.cells[2] + 1) + k
    }

    fn position(&self, [i, j, k]: [usize; 3]) -> DVec3 {
        self.origin + self.step * DVec3::new(i as f64, j as f64, k as f64)
    }

    /// Samples every lattice point in `points` not yet sampled, in one batch.
    fn fill<F: Field + ?Sized>(&mut self, field: &F, mut points: Vec<[usize; 3]>) {
        points.retain(|&p| self.values[self.point_index(p)].is_nan());
        points.sort_unstable();
        points.dedup();
        let positions: Vec<DVec3> = points.iter().map(|&p| self.position(p)).collect();
        let values = field.values(&positions);
        for (p, v) in points.iter().zip(values) {
            let i = self.point_index(*p);
            // A value that is not a number counts as outside; the sign is all the march reads.
            self.values[i] =
                if v.is_nan() { -f32::MAX } else { (v as f32).clamp(-f32::MAX, f32::MAX) };
        }
        self.samples += points.len();
    }

    /// The 8 corner values of the cell of side `stride` at `corner`, x-major
    /// (bit 2 = x, bit 1 = y, bit 0 = z).
    fn corners(&self, [i, j, k]: [usize; 3], stride: usize) -> [f32; 8] {
        std::array::from_fn(|c| {
            let p = [i + stride * (c >> 2), j + stride * ((c >> 1) & 1), k + stride * (c & 1)];
            self.values[self.point_index(p)]
        })
    }

    /// Samples coarse to fine, then marks the blocks whose cells change sign.
    ///
    /// Each cell carries the margin within which its smallest corner magnitude must fall for
    /// the cell to be split although its corners agree in sign: for the coarse cells a fraction
    /// of their corner spread, for finer ones half the largest gap between the parent's
    /// interpolant and the new samples (the interpolation error, which drops about fourfold
    /// per halving, doubled for safety).
    fn build<F: Field + ?Sized>(&mut self, field: &F) {
        let coarse = self.cells.map(|c| c / BLOCK);
        let mut cells: Vec<([usize; 3], f32)> = Vec::new();
        for i in 0..coarse[0] {
            for j in 0..coarse[1] {
                for k in 0..coarse[2] {
                    cells.push(([i * BLOCK, j * BLOCK, k * BLOCK], f32::NAN));
                }
            }
        }
        let mut points = sub_lattice(&cells, BLOCK, 2);
        points.extend(cells.iter().map(|&(c, _)| c.map(|x| x + BLOCK / 2)));
        self.fill(field, points);
        for c in &mut cells {
            // The centre sample also splits a cell whose corners straddle a thin part.
            let centre = self.values[self.point_index(c.0.map(|x| x + BLOCK / 2))];
            let v = self.corners(c.0, BLOCK);
            let (lo, hi) = v.iter().fold((centre, centre), |(lo, hi), &x| (lo.min(x), hi.max(x)));
            c.1 = if (centre > 0.0) != (v[0] > 0.0) {
                f32::INFINITY
            } else {
                COARSE_TOLERANCE * (hi - lo)
            };
        }
        let mut stride = BLOCK;
        while stride > 1 {
            cells.retain(|&(c, margin)| {
                let v = self.corners(c, stride);
                changes_sign(&v) || v.iter().fold(f32::MAX, |m, &x| m.min(x.abs())) <= margin
            });
            let half = stride / 2;
            self.fill(field, sub_lattice(&cells, half, 3));
            cells = cells
                .iter()
                .flat_map(|&(c, _)| {
                    let margin = 0.5 * self.interpolation_gap(c, stride);
                    sub_lattice(&[(c, margin)], half, 2)
                        .into_iter()
                        .map(move |child| (child, margin))
                })
                .collect();
            stride = half;
        }
        for (c, _) in cells {
            if changes_sign(&self.corners(c, 1)) {
                let b = c.map(|x| x / BLOCK);
                self.blocks[(b[0] * coarse[1] + b[1]) * coarse[2] + b[2]] = true;
            }
        }
    }

    /// The largest gap between the samples at the corners, edge midpoints, face centres and
    /// centre of the cell of side `stride` at `c` and its trilinear interpolant.
    fn interpolation_gap(&self, c: [usize; 3], stride: usize) -> f32 {
        let corners = self.corners(c, stride);
        let half = stride / 2;
        let mut gap = 0.0f64;
        for p in sub_lattice(&[(c, 0.0)], half, 3) {
            let f = DVec3::new(
                (p[0] - c[0]) as f64 / stride as f64,
                (p[1] - c[1]) as f64 / stride as f64,
                (p[2] - c[2]) as f64 / stride as f64,
            );
            gap = gap.max((self.values[self.point_index(p)] as f64 - trilinear(&corners, f)).abs());
        }
        gap as f32
    }

    /// The lattice coordinates (in cells) of world point `p`.
    fn local(&self, p: DVec3) -> DVec3 {
        (p - self.origin) / self.step
    }

    /// The parameter range along the ray `eye + t * dir` inside the lattice box.
    fn clip(&self, eye: DVec3, dir: DVec3) -> Option<(f64, f64)> {
        let q = self.local(eye);
        let n = DVec3::new(self.cells[0] as f64, self.cells[1] as f64, self.cells[2] as f64);
        let d = dir / self.step;
        let inv = d.recip();
        let (a, b) = ((-q) * inv, (n - q) * inv);
        let (near, far) = (a.min(b).max_element().max(0.0), a.max(b).min_element());
        (near < far && near.is_finite() && far.is_finite()).then_some((near, far))
    }

    /// The first hit of the ray from `eye` along unit `dir`.
    fn trace(&self, eye: DVec3, dir: DVec3) -> Option<Probe> {
        let (near, far) = self.clip(eye, dir)?;
        let q0 = self.local(eye);
        let d = dir / self.step;
        if let Some(normal) = self.cap(q0 + near * d) {
            return Some(Probe::Cap(normal));
        }
        let coarse = self.cells.map(|c| c / BLOCK);
        let mut hit = None;
        walk(q0, d, (near, far), BLOCK as f64, coarse, |b, span| {
            if !self.blocks[(b[0] * coarse[1] + b[1]) * coarse[2] + b[2]] {
                return false;
            }
            walk(q0, d, span, 1.0, self.cells, |c, span| {
                hit = self.cross_cell(c, q0, d, span);
                hit.is_some()
            });
            hit.is_some()
        });
        hit
    }

    /// Where the ray enters the lattice box at lattice point `q`: the box face's outward
    /// normal if the coarse samples there are inside.
    fn cap(&self, q: DVec3) -> Option<DVec3> {
        let cell = q.map(|x| (x / BLOCK as f64).floor() * BLOCK as f64);
        let at = |a: usize| (cell[a] as usize).min(self.cells[a] - BLOCK);
        let corner = [at(0), at(1), at(2)];
        let f =
            (q - DVec3::new(corner[0] as f64, corner[1] as f64, corner[2] as f64)) / BLOCK as f64;
        if trilinear(&self.corners(corner, BLOCK), f.clamp(DVec3::ZERO, DVec3::ONE)) <= 0.0 {
            return None;
        }
        let n = DVec3::new(self.cells[0] as f64, self.cells[1] as f64, self.cells[2] as f64);
        let gaps = [q.x, q.y, q.z, n.x - q.x, n.y - q.y, n.z - q.z];
        let face = (0..6).min_by(|&a, &b| gaps[a].total_cmp(&gaps[b])).unwrap_or(0);
        let mut normal = DVec3::ZERO;
        normal[face % 3] = if face < 3 { -1.0 } else { 1.0 };
        Some(normal)
    }

    /// The root of the interpolant in cell `c` over the ray parameters `span`, if the ray turns
    /// from outside to inside there.
    fn cross_cell(
        &self,
        c: [usize; 3],
        q0: DVec3,
        d: DVec3,
        (t0, t1): (f64, f64),
    ) -> Option<Probe> {
        let corners = self.corners(c, 1);
        if !changes_sign(&corners) {
            return None;
        }
        let base = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        let g = |t: f64| trilinear(&corners, (q0 + t * d - base).clamp(DVec3::ZERO, DVec3::ONE));
        let dt = (t1 - t0) / SUB_STEPS as f64;
        let mut a = (t0, g(t0));
        for s in 1..=SUB_STEPS {
            let tb = if s == SUB_STEPS { t1 } else { t0 + s as f64 * dt };
            let b = (tb, g(tb));
            if a.1 <= 0.0 && b.1 > 0.0 {
                let (t, slope) = regula_falsi(g, a, b);
                return Some(Probe::Root { t, slope, span: (t0, t1) });
            }
            a = b;
        }
        None
    }
}

/// What a ray found.
#[derive(Debug, Clone, Copy)]
enum Probe {
    /// The inside reaches the box face with this outward normal.
    Cap(DVec3),
    /// The interpolant's root at `t`, its slope there, and the cell's parameter span.
    Root { t: f64, slope: f64, span: (f64, f64) },
}

fn changes_sign(v: &[f32; 8]) -> bool {
    v.iter().any(|&x| x > 0.0) && v.iter().any(|&x| x <= 0.0)
}

/// The lattice points `c + stride * (a, b, d)` for `a, b, d < n`, for every cell `c`.
fn sub_lattice(cells: &[([usize; 3], f32)], stride: usize, n: usize) -> Vec<[usize; 3]> {
    cells
        .iter()
        .flat_map(|&([i, j, k], _)| {
            (0..n * n * n).map(move |c| {
                let (a, b, d) = (c / (n * n), (c / n) % n, c % n);
                [i + stride * a, j + stride * b, k + stride * d]
            })
        })
        .collect()
}

/// The trilinear interpolant of corner values (bit 2 = x, bit 1 = y, bit 0 = z) at `f` in
/// the unit cube.
fn trilinear(v: &[f32; 8], f: DVec3) -> f64 {
    let v = v.map(|x| x as f64);
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x0 = lerp(lerp(v[0], v[1], f.z), lerp(v[2], v[3], f.z), f.y);
    let x1 = lerp(lerp(v[4], v[5], f.z), lerp(v[6], v[7], f.z), f.y);
    lerp(x0, x1, f.x)
}

/// The root of `g` in `[a, b]` (with `g(a) <= 0 < g(b)`) by Illinois regula falsi, and the
/// slope of the final bracket.
fn regula_falsi(g: impl Fn(f64) -> f64, mut a: (f64, f64), mut b: (f64, f64)) -> (f64, f64) {
    let mut side = 0;
    for _ in 0..8 {
        let t = (a.0 * b.1 - b.0 * a.1) / (b.1 - a.1);
        let m = (t, g(t));
        if m.1 > 0.0 {
            b = m;
            if side == 1 {
                a.1 *= 0.5;
            }
            side = 1;
        } else {
            a = m;
            if side == -1 {
                b.1 *= 0.5;
            }
            side = -1;
        }
    }
    let t = (a.0 * b.1 - b.0 * a.1) / (b.1 - a.1);
    let slope = (g(b.0) - g(a.0)) / (b.0 - a.0);
    (if t.is_finite() { t } else { 0.5 * (a.0 + b.0) }, slope)
}

/// Walks the cells of side `cell` (lattice units) of a grid of `dims` such cells that the ray
/// `q0 + t * d` crosses for `t` in `span`, in order, calling `visit(cell index, its span)` until
/// it returns true.
fn walk(
    q0: DVec3,
    d: DVec3,
    (start, end): (f64, f64),
    cell: f64,
    dims: [usize; 3],
    mut visit: impl FnMut([usize; 3], (f64, f64)) -> bool,
) {
    let entry = (q0 + (start + 1e-9 * (end - start)) * d) / cell;
    let mut index = [0usize; 3];
    let mut next = [f64::INFINITY; 3];
    let mut delta = [f64::INFINITY; 3];
    let mut step = [0isize; 3];
    for a in 0..3 {
        index[a] = (entry[a].floor().max(0.0) as usize).min(dims[a] - 1);
        if d[a] != 0.0 {
            step[a] = if d[a] > 0.0 { 1 } else { -1 };
            let boundary = (index[a] as f64 + if d[a] > 0.0 { 1.0 } else { 0.0 }) * cell;
            next[a] = (boundary - q0[a]) / d[a];
            delta[a] = cell / d[a].abs();
        }
    }
    let mut t = start;
    loop {
        let a = if next[0] <= next[1] && next[0] <= next[2] {
            0
        } else if next[1] <= next[2] {
            1
        } else {
            2
        };
        let exit = next[a].min(end);
        if visit(index, (t, exit)) || exit >= end {
            return;
        }
        let moved = index[a] as isize + step[a];
        if moved < 0 || moved as usize >= dims[a] {
            return;
        }
        index[a] = moved as usize;
        t = exit;
        next[a] += delta[a];
    }
}

/// Draws `field` inside `bounds` as seen by `camera`.
pub(crate) fn march<F: Field + ?Sized>(
    field: &F,
    bounds: &Aabb,
    camera: &Camera,
    surface: Surface,
    settings: March,
) -> Result<Image> {
    let lattice = Lattice::sample(field, bounds, settings)?;
    let (width, height) = (camera.width(), camera.height());
    let eye = camera.eye();
    let probes: Vec<Option<Probe>> = (0..width * height)
        .into_par_iter()
        .map(|i| lattice.trace(eye, camera.ray(i % width, i / width)))
        .collect();
    let roots: Vec<(usize, f64, f64, (f64, f64))> = probes
        .iter()
        .enumerate()
        .filter_map(|(i, p)| match *p {
            Some(Probe::Root { t, slope, span }) => Some((i, t, slope, span)),
            _ => None,
        })
        .collect();
    let ray = |i: usize| camera.ray(i % width, i / width);
    let at: Vec<DVec3> = roots.par_iter().map(|&(i, t, ..)| eye + t * ray(i)).collect();
    let values = field.values(&at);
    let mut image = Image::empty(width, height);
    let pixels: Vec<(usize, [u8; 4])> = roots
        .par_iter()
        .zip(values)
        .map(|(&(i, t, slope, (lo, hi)), value)| {
            let step = -value / slope;
            let t = if step.is_finite() { (t + step).clamp(lo, hi) } else { t };
            let dir = ray(i);
            let normal = field_normal(field.gradient(eye + t * dir), dir);
            (i, shade(surface, normal, dir, camera))
        })
        .collect();
    for (i, pixel) in pixels {
        image.rgba[i * 4..i * 4 + 4].copy_from_slice(&pixel);
    }
    for (i, p) in probes.iter().enumerate() {
        if let Some(Probe::Cap(normal)) = *p {
            image.rgba[i * 4..i * 4 + 4].copy_from_slice(&shade(surface, normal, ray(i), camera));
        }
    }
    Ok(image)
}
