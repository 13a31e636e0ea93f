//! Initialization (paper 5.1): a first set of constraints that gives a reasonable first surface.
//!
//! Boundary constraints are drawn at random (from a seeded generator) from the goal's boundary
//! voxels, placed at sub-voxel precision on the surface, skipping a voxel too close to an earlier
//! constraint or where the radius of regularity is too small. From each, the signed distance is
//! followed uphill and downhill to a local extremum, and an interior or exterior constraint is
//! placed at the end of the longer path, so they fan out instead of bunching in ridges.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::{FitConstraint, FitOptions};
use crate::distance;
use crate::geometry::DVec3;
use crate::grid::Volume;

use super::goal::Goal;

/// The initial constraints: up to `options.initial_constraints` boundary constraints and one
/// interior or exterior constraint for each (fewer where two walks end at the same place).
pub fn initial_constraints(goal: &Goal, options: &FitOptions) -> Vec<FitConstraint> {
    let boundary = random_boundary_constraints(goal, options);
    let mut constraints = boundary.clone();
    for c in &boundary {
        let end = longer_extremum_path(&goal.sd, c.position);
        let value = f64::from(distance::sample(&goal.sd, end));
        let far_enough =
            constraints.iter().all(|o| o.position.distance(end) >= options.min_constraint_spacing);
        if far_enough && value != 0.0 {
            constraints.push(FitConstraint { position: end, value, error: 0.0 });
        }
    }
    constraints
}

/// Boundary constraints at random goal boundary voxels, spaced and regular enough.
fn random_boundary_constraints(goal: &Goal, options: &FitOptions) -> Vec<FitConstraint> {
    let mut order: Vec<usize> = (0..goal.boundary.len()).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(options.seed));
    let mut chosen: Vec<FitConstraint> = Vec::with_capacity(options.initial_constraints);
    for i in order {
        if chosen.len() == options.initial_constraints {
            break;
        }
        if f64::from(goal.rreg[i]) < options.initial_min_rreg {
            continue;
        }
        let position = goal.surface[i];
        if chosen.iter().all(|c| c.position.distance(position) >= options.initial_spacing) {
            chosen.push(FitConstraint { position, value: 0.0, error: 0.0 });
        }
    }
    chosen
}

/// Follows the gradient of `sd` both ways from `start` to a local extremum and returns the end
/// of the longer path.
fn longer_extremum_path(sd: &Volume<f32>, start: DVec3) -> DVec3 {
    let (up_end, up_length) = follow_gradient(sd, start, 1.0);
    let (down_end, down_length) = follow_gradient(sd, start, -1.0);
    if up_length >= down_length { up_end } else { down_end }
}

/// Steps of half a voxel along `direction` times the gradient of `sd` until the signed distance
/// stops improving or the walk reaches the grid's edge. Returns the end and the path length.
fn follow_gradient(sd: &Volume<f32>, start: DVec3, direction: f64) -> (DVec3, f64) {
    const STEP: f64 = 0.5;
    let dims = sd.grid.dims;
    let upper = DVec3::new(dims[0] as f64 - 1.0, dims[1] as f64 - 1.0, dims[2] as f64 - 1.0);
    let max_steps = (upper.length() / STEP) as usize * 2;
    let mut p = start;
    let mut level = direction * f64::from(distance::sample(sd, p));
    let mut length = 0.0;
    for _ in 0..max_steps {
        let g = distance::gradient(sd, p) * direction;
        let norm = g.length();
        if norm < 1e-6 {
            break;
        }
        let next = (p + g * (STEP / norm)).clamp(DVec3::ZERO, upper);
        let next_level = direction * f64::from(distance::sample(sd, next));
        if next_level <= level || next == p {
            break;
        }
        length += next.distance(p);
        p = next;
        level = next_level;
    }
    (p, length)
}
