//! Initialization (paper 5.1): a first set of constraints that gives a reasonable first surface.
//!
//! Boundary constraints are drawn at random (from a seeded generator) from the goal's boundary
//! voxels, placed at sub-voxel precision on the surface, skipping a voxel too close to an earlier
//! constraint or where the radius of regularity is too small. From each, the signed distance is
//! followed uphill and downhill to a local extremum, and an interior or exterior constraint is
//! placed at the end of the longer path, so they fan out instead of bunching in ridges.
//!
//! A thin wall has no boundary voxel whose radius of regularity reaches the threshold (its two
//! faces are a voxel or two apart): where too few do for a first model, the boundary
//! constraints are drawn from every boundary voxel instead. Constraints that cannot make a first
//! model (fewer than four, or all on one plane: no voxel inside the goal, or none left of its
//! wall) are refused ([`crate::Error::Thin`]) before any solve.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::{FitConstraint, FitOptions};
use crate::edt;
use crate::error::{Error, Result};
use crate::geometry::DVec3;
use crate::grid::Volume;

use super::goal::Goal;

/// The initial constraints: up to `options.initial_constraints` boundary constraints and one
/// interior or exterior constraint for each (fewer where two walks end at the same place).
///
/// # Errors
/// [`Error::Thin`] where they cannot make a first model: fewer than `dim + 1` positions, or all
/// on one plane (one line in 2D).
pub fn initial_constraints(goal: &Goal, options: &FitOptions) -> Result<Vec<FitConstraint>> {
    let mut boundary = random_boundary_constraints(goal, options, options.initial_min_rreg);
    if boundary.len() < MIN_BOUNDARY {
        boundary = random_boundary_constraints(goal, options, 0.0);
    }
    let mut constraints = boundary.clone();
    for c in &boundary {
        let end = longer_extremum_path(&goal.sd, c.position);
        let value = f64::from(edt::sample(&goal.sd, end));
        let far_enough =
            constraints.iter().all(|o| o.position.distance(end) >= options.min_constraint_spacing);
        if far_enough && value != 0.0 {
            constraints.push(FitConstraint { position: end, value, error: 0.0 });
        }
    }
    let dim = if goal.grid().is_2d() { 2 } else { 3 };
    if !spans(constraints.iter().map(|c| c.position), dim) {
        return Err(Error::Thin {
            context: "goal".into(),
            message: format!(
                "{} boundary voxels give {} constraints, too few or too flat for a first model",
                goal.boundary.len(),
                constraints.len()
            ),
        });
    }
    Ok(constraints)
}

/// Below this many boundary constraints regular enough, the initialization takes them from
/// every boundary voxel.
const MIN_BOUNDARY: usize = 8;

/// Whether `positions` span `dim` dimensions: `dim + 1` of them affinely independent (their
/// differences from the first have a component of at least a thousandth of a voxel off the
/// span of the earlier ones).
fn spans(positions: impl Iterator<Item = DVec3>, dim: usize) -> bool {
    let mut positions = positions;
    let Some(first) = positions.next() else { return false };
    let mut basis: Vec<DVec3> = Vec::with_capacity(dim);
    for p in positions {
        let mut d = p - first;
        for b in &basis {
            d -= *b * d.dot(*b);
        }
        if d.length() > 1e-3 {
            basis.push(d.normalize());
            if basis.len() == dim {
                return true;
            }
        }
    }
    false
}

/// Boundary constraints at random goal boundary voxels, spaced and with a radius of regularity
/// of at least `min_rreg`.
fn random_boundary_constraints(
    goal: &Goal,
    options: &FitOptions,
    min_rreg: f64,
) -> Vec<FitConstraint> {
    let mut order: Vec<usize> = (0..goal.boundary.len()).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(options.seed));
    let mut chosen: Vec<FitConstraint> = Vec::with_capacity(options.initial_constraints);
    for i in order {
        if chosen.len() == options.initial_constraints {
            break;
        }
        if f64::from(goal.rreg[i]) < min_rreg {
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
    let mut level = direction * f64::from(edt::sample(sd, p));
    let mut length = 0.0;
    for _ in 0..max_steps {
        let g = edt::gradient(sd, p) * direction;
        let norm = g.length();
        if norm < 1e-6 {
            break;
        }
        let next = (p + g * (STEP / norm)).clamp(DVec3::ZERO, upper);
        let next_level = direction * f64::from(edt::sample(sd, next));
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

    /// Four corners of a tetrahedron span 3D; the same on one plane, or three, do not.
    #[test]
    fn constraints_span_only_off_one_plane() {
        let tetrahedron = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        assert!(spans(tetrahedron.into_iter(), 3));
        assert!(!spans(tetrahedron[..3].iter().copied(), 3));
        let flat = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(3.0, 2.0, 0.0)];
        assert!(!spans(flat.into_iter(), 3));
        assert!(spans(flat.into_iter(), 2));
    }

    /// Boundary constraints lie on the box's surface, interior ones on its medial axis (where
    /// the nearest face is not unique) at their distance from the surface, exterior ones
    /// outside it at theirs: each value within half a voxel of the exact distance.
    #[test]
    fn initial_constraints_land_on_the_surface_the_medial_axis_and_outside() {
        let goal = box_goal();
        let options = FitOptions::default();
        let constraints = initial_constraints(&goal, &options).unwrap();
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
