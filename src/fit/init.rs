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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Grid;

    /// Half extents of the box (voxels) and its centre, which lies between voxel centres so
    /// that every face is half a voxel outside a layer of voxel centres.
    const HALF: [f64; 3] = [12.0, 10.0, 8.0];
    const CENTRE: [f64; 3] = [16.5, 24.5, 24.5];

    /// The goal of the box in a grid of 48^3 unit voxels. The face at -x is 4.5 voxels from
    /// the grid's edge, nearer than the box's middle, so the walks from it are longer inward;
    /// the other faces are 13.5 voxels or more from the edge, so theirs are longer outward.
    fn box_goal() -> Goal {
        let grid = Grid { dims: [48, 48, 48], origin: [0.0; 3], voxel_size: 1.0 };
        let data = (0..grid.len())
            .map(|n| f32::from(u8::from(box_distance(grid.position(grid.voxel(n))) > 0.0)))
            .collect();
        Goal::from_density(Volume { grid, data }, &FitOptions::default().regularity)
    }

    /// The distances from `p` to the box's six face planes, inside positive, smallest first.
    fn face_distances(p: DVec3) -> [f64; 6] {
        let mut d = [0.0; 6];
        for a in 0..3 {
            d[2 * a] = HALF[a] - (p[a] - CENTRE[a]);
            d[2 * a + 1] = HALF[a] + (p[a] - CENTRE[a]);
        }
        d.sort_by(f64::total_cmp);
        d
    }

    /// The signed Euclidean distance from `p` to the box's surface, inside positive.
    fn box_distance(p: DVec3) -> f64 {
        let q = DVec3::from_array(std::array::from_fn(|a| (p[a] - CENTRE[a]).abs() - HALF[a]));
        let outside = q.max(DVec3::ZERO).length();
        let inside = q.max_element().min(0.0);
        -(outside + inside)
    }

    /// Boundary constraints lie on the box's surface, interior ones on its medial axis (where
    /// the nearest face is not unique) at their distance from the surface, exterior ones
    /// outside it at theirs: each value within half a voxel of the exact distance.
    #[test]
    fn initial_constraints_land_on_the_surface_the_medial_axis_and_outside() {
        let goal = box_goal();
        let options = FitOptions::default();
        let constraints = initial_constraints(&goal, &options);
        let (mut interior, mut exterior) = (0, 0);
        for c in &constraints {
            let exact = box_distance(c.position);
            if c.value == 0.0 {
                // On a face exactly; a quarter voxel in along an edge, where the sub-voxel point
                // averages the crossings along two axes.
                assert!(exact.abs() <= 0.25, "boundary constraint {} is {exact} off", c.position);
                continue;
            }
            assert!((c.value - exact).abs() <= 0.5, "{} has {} for {exact}", c.position, c.value);
            if c.value > 0.0 {
                let faces = face_distances(c.position);
                assert!(
                    faces[1] - faces[0] <= 1.0,
                    "{} is off the medial axis: {faces:?}",
                    c.position
                );
                interior += 1;
            } else {
                assert!(exact < -1.0, "exterior constraint {} is {exact} outside", c.position);
                exterior += 1;
            }
        }
        let boundary = constraints.len() - interior - exterior;
        assert_eq!(boundary, options.initial_constraints);
        assert!(interior > 0 && exterior > 0, "{interior} interior, {exterior} exterior");
    }
}
