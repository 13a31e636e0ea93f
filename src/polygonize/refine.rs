//! Moving vertices from the linear interpolation of the samples onto the field's true zero.
//!
//! Each vertex lies on a grid edge whose ends have values of opposite classes (one `>= 0`,
//! one `< 0`), so the edge brackets a zero of a continuous field. A few steps of regula falsi
//! with the Illinois modification narrow the bracket; a step that would leave the bracket, or
//! a NaN value, falls back to bisection. Every step evaluates all unfinished vertices at once
//! through [`Field::values`], so a field's vectorized, parallel evaluation is used.

use rayon::prelude::*;

use super::extract::{END_MARGIN, EdgeVertex};
use super::tables::offset;
use crate::field::Field;
use crate::geometry::DVec3;
use crate::grid::Grid;

/// The most field evaluations per vertex.
const MAX_STEPS: usize = 6;

/// A bracket is done when it is this narrow, as a fraction of its edge.
const TOLERANCE: f64 = 1e-9;

/// The part of an edge known to hold the zero, by the edge parameter `t` of its ends.
#[derive(Debug, Clone, Copy)]
struct Bracket {
    vertex: usize,
    /// The end with a value `>= 0` (inside).
    t_in: f64,
    g_in: f64,
    /// The end with a value `< 0` or NaN (outside).
    t_out: f64,
    g_out: f64,
    /// Which end the last step moved: 1 inside, -1 outside, 0 none yet.
    last: i8,
}

impl Bracket {
    /// The next estimate of the zero: regula falsi, or bisection when that is not usable.
    fn estimate(&self) -> f64 {
        let (lo, hi) = (self.t_in.min(self.t_out), self.t_in.max(self.t_out));
        let t = self.t_out + self.g_out * (self.t_in - self.t_out) / (self.g_out - self.g_in);
        if t >= lo && t <= hi { t } else { 0.5 * (lo + hi) }
    }

    /// Narrows the bracket with the value `g` at `t`.
    fn update(&mut self, t: f64, g: f64) {
        if g >= 0.0 {
            self.t_in = t;
            self.g_in = g;
            if self.last == 1 {
                self.g_out *= 0.5;
            }
            self.last = 1;
        } else {
            self.t_out = t;
            self.g_out = g;
            if self.last == -1 {
                self.g_in *= 0.5;
            }
            self.last = -1;
        }
    }

    fn done(&self) -> bool {
        self.g_in == 0.0 || (self.t_in - self.t_out).abs() < TOLERANCE
    }
}

/// Moves every vertex onto the zero of `field` along its edge of `grid`. `ends(v)` gives the
/// field's values at the base and the far end of a vertex's edge, the values the surface was
/// extracted from.
pub(super) fn refine<F: Field + ?Sized>(
    field: &F,
    grid: &Grid,
    vertices: &mut [EdgeVertex],
    ends: impl Fn(&EdgeVertex) -> [f64; 2] + Sync,
) {
    let mut open: Vec<Bracket> =
        vertices.par_iter().enumerate().map(|(n, v)| initial_bracket(n, ends(v))).collect();
    let mut closed = Vec::with_capacity(open.len());
    for _ in 0..MAX_STEPS {
        if open.is_empty() {
            break;
        }
        let steps: Vec<f64> = open.par_iter().map(Bracket::estimate).collect();
        let points: Vec<DVec3> = open
            .par_iter()
            .zip(&steps)
            .map(|(b, &t)| edge_point(grid, &vertices[b.vertex], t))
            .collect();
        let values = field.values(&points);
        assert_eq!(values.len(), points.len(), "Field::values must return one value per point");
        open.par_iter_mut()
            .zip(steps.par_iter().zip(values.par_iter()))
            .for_each(|(b, (&t, &g))| b.update(t, g));
        let (finished, unfinished): (Vec<Bracket>, Vec<Bracket>) =
            open.into_par_iter().partition(Bracket::done);
        closed.extend(finished);
        open = unfinished;
    }
    closed.extend(open);
    let mut t = vec![0.5; vertices.len()];
    for b in &closed {
        t[b.vertex] = b.estimate().clamp(END_MARGIN, 1.0 - END_MARGIN);
    }
    vertices
        .par_iter_mut()
        .zip(t.par_iter())
        .for_each(|(v, &t)| v.position = edge_point(grid, v, t));
}

/// The bracket of the whole edge of vertex number `vertex`, from the sampled values at its base
/// and far end.
fn initial_bracket(vertex: usize, [a, b]: [f64; 2]) -> Bracket {
    let (t_in, g_in, t_out, g_out) = if a >= 0.0 { (0.0, a, 1.0, b) } else { (1.0, b, 0.0, a) };
    Bracket { vertex, t_in, g_in, t_out, g_out, last: 0 }
}

/// The point at parameter `t` along a vertex's edge, in the mesh's units.
fn edge_point(grid: &Grid, v: &EdgeVertex, t: f64) -> DVec3 {
    let [i, j, k] = grid.voxel(v.base);
    grid.to_world(DVec3::new(i as f64, j as f64, k as f64) + t * offset(v.direction))
}
