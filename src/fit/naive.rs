//! The simple method of paper 3.2, kept to show why the iterative method matters: the mesh's
//! vertices are boundary constraints and each gets an exterior constraint a little way out
//! along its normal.
//!
//! The vertices are a seeded random subset of the mesh's (35,000 for the bunny), spaced like the
//! iterative fit's constraints, of at most half the constraint budget (`max_constraints`,
//! 2,000 where it sets none). The result is measured with the
//! same metrics as the iterative fit.

use std::time::Instant;

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::{FitConstraint, FitOptions, FitReport, Goal, IterationReport, Termination, Timings};
use crate::edt;
use crate::error::Result;
use crate::geometry::DVec3;
use crate::mesh::Mesh;

/// How far out along the normal the exterior constraints sit, in voxels.
pub(crate) const NORMAL_OFFSET: f64 = 2.0;

/// Fits `mesh` (voxelized as `goal`) by the naive method.
pub fn fit(mesh: &Mesh, goal: &Goal, options: &FitOptions) -> Result<super::Fit> {
    let started = Instant::now();
    let grid = *goal.grid();
    let constraints = naive_constraints(mesh, goal, options);
    let mut timings = Timings::default();
    let clock = Instant::now();
    let implicit = super::solve(&grid, &constraints, options.kernel, None)?;
    timings.misc += clock.elapsed().as_secs_f64();
    let measured = super::measure(goal, &implicit, options, &mut timings);
    timings.total = started.elapsed().as_secs_f64();
    let counts = super::ConstraintCounts::of_values(constraints.iter().map(|c| c.value));
    let metrics = measured.metrics;
    let report = FitReport {
        version: super::REPORT_VERSION,
        method: "naive".into(),
        iterations: 1,
        best_iteration: 1,
        termination: Termination::SingleSolve,
        constraints: counts,
        max_error_voxels: metrics.max_error,
        max_error: f64::from(metrics.max_error) * grid.voxel_size,
        weighted_error: metrics.weighted_error,
        rms_error_voxels: metrics.rms_error,
        timings_s: timings,
        dims: grid.dims,
        origin: grid.origin,
        voxel_size: grid.voxel_size,
        per_iteration: vec![IterationReport::new(1, counts, metrics, timings)],
        model_bytes: None,
        mesh_bytes: None,
        winding_near_half: None,
        thickness: None,
        shell_voxels: None,
        levels: None,
        mesh_distance: None,
        byte_budget: None,
        target: None,
        paper_loop: None,
    };
    Ok(super::Fit { implicit, report })
}

/// The naive method's constraint count where none is given: 1,000 mesh vertices, each with an
/// exterior constraint.
pub(crate) const DEFAULT_CONSTRAINTS: usize = 2000;

/// Vertex boundary constraints and their exterior partners, in voxel coordinates.
fn naive_constraints(mesh: &Mesh, goal: &Goal, options: &FitOptions) -> Vec<FitConstraint> {
    let grid = goal.grid();
    let normals = vertex_normals(mesh);
    let mut order: Vec<usize> =
        (0..mesh.vertices.len()).filter(|&v| normals[v] != DVec3::ZERO).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(options.seed));
    let mut boundary: Vec<FitConstraint> = Vec::new();
    let mut exterior: Vec<FitConstraint> = Vec::new();
    for v in order {
        if 2 * boundary.len() + 2 > options.max_constraints.unwrap_or(DEFAULT_CONSTRAINTS) {
            break;
        }
        let position = grid.to_grid(mesh.vertices[v]);
        if boundary.iter().all(|c| c.position.distance(position) >= options.min_constraint_spacing)
        {
            boundary.push(FitConstraint { position, value: 0.0, error: 0.0 });
            let outside = outward_offset(goal, position, normals[v]);
            exterior.push(FitConstraint { position: outside, value: -NORMAL_OFFSET, error: 0.0 });
        }
    }
    boundary.extend(exterior);
    boundary
}

/// The point `NORMAL_OFFSET` voxels from `position` along the normal, on whichever side the
/// goal says is outside: meshes with inward or inconsistently oriented faces (the horse's PLY
/// faces inward) still get their exterior constraints outside.
fn outward_offset(goal: &Goal, position: DVec3, normal: DVec3) -> DVec3 {
    let along = position + normal * NORMAL_OFFSET;
    let against = position - normal * NORMAL_OFFSET;
    if edt::sample(&goal.sd, against) < edt::sample(&goal.sd, along) { against } else { along }
}

/// Area-weighted unit vertex normals (zero for a vertex no triangle uses).
fn vertex_normals(mesh: &Mesh) -> Vec<DVec3> {
    let mut normals = vec![DVec3::ZERO; mesh.vertices.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = mesh.corners(t);
        let n = (b - a).cross(c - a);
        for &i in tri {
            normals[i as usize] += n;
        }
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}
