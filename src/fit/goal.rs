//! The goal shape the fit approximates: the voxelized mesh (paper 4.1), its signed distance
//! (4.2), its boundary voxels ∂f_goal and their radii of regularity (4.3), and, for the
//! sub-voxel measure, the mesh's exact distance.

use std::collections::HashSet;
use std::sync::Arc;

use rayon::prelude::*;

use super::slit;
use super::surface::{self, SurfaceDisks};
use crate::edt;
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};
use crate::mesh_query::MeshQuery;
use crate::metrics::{self, AGREEMENT, RegularityOptions, SubVoxel};

/// Everything the fit needs to know about the goal shape, computed once.
///
/// Its parts are derived from one another (the signed distance from the densities, the
/// boundary voxels from the signed distance, ...), so they are read through methods and only
/// [`Goal::from_density`] makes them.
#[derive(Debug, Clone)]
pub struct Goal {
    /// Densities in [0, 1], 1 inside; boundary constraints sit where they cross 1/2.
    pub(super) density: Volume<f32>,
    /// The goal's signed distance sd_goal, voxel units, inside positive.
    pub(super) sd: Volume<f32>,
    /// The goal's boundary voxels ∂f_goal.
    pub(super) boundary: Vec<[usize; 3]>,
    /// The goal's radius of regularity at each boundary voxel, in voxels.
    pub(super) rreg: Vec<f32>,
    /// The point where the densities cross 1/2 at each boundary voxel, in continuous voxel
    /// coordinates: where boundary constraints go (5.3, "at sub-voxel precision").
    pub(super) surface: Vec<DVec3>,
    /// The surface points as disks, for [`Goal::fine_signed_distance`].
    pub(super) disks: SurfaceDisks,
    /// The mesh the densities were voxelized from, for [`Goal::fine_signed_distance`] to
    /// measure its exact distance (see [`Goal::with_mesh`]).
    mesh: Option<Arc<MeshQuery>>,
    /// Points on the mesh's triangles where the goal agrees with it, mesh units (see
    /// [`Goal::with_mesh_points`]).
    mesh_points: Option<Vec<DVec3>>,
    /// The slits narrower than a voxel carved in the goal (see [`Goal::with_mesh_samples`]).
    slits: Option<slit::Slits>,
}

/// A point sampled on the mesh is kept for the detail levels where the goal's sub-voxel
/// signed distance there is at most this, in voxels, times the factor by which the goal's
/// voxels are larger than the grid's (see [`Goal::with_mesh_points`]).
pub(crate) const MESH_AGREEMENT: f32 = 1.0;

impl Goal {
    /// The goal of a density volume (from [`crate::voxelize::voxelize`], or an image in 2D).
    pub fn from_density(density: Volume<f32>, regularity: &RegularityOptions) -> Goal {
        let sd = edt::signed_distance(&edt::inside(&density));
        Goal::from_signed_distance(density, sd, regularity)
    }

    /// The goal of a density volume whose signed distance `sd` is already known (that of
    /// [`edt::inside`] of the densities, as [`Goal::from_density`] computes it).
    pub fn from_signed_distance(
        density: Volume<f32>,
        sd: Volume<f32>,
        regularity: &RegularityOptions,
    ) -> Goal {
        let boundary = edt::boundary_voxels(&sd);
        let rreg = metrics::radii_of_regularity(&sd, &boundary, regularity);
        let surface: Vec<DVec3> =
            boundary.par_iter().map(|&v| edt::surface_point(&density, v)).collect();
        let disks = SurfaceDisks::new(&surface, &density);
        Goal {
            density,
            sd,
            boundary,
            rreg,
            surface,
            disks,
            mesh: None,
            mesh_points: None,
            slits: None,
        }
    }

    /// This goal, with [`Goal::fine_signed_distance`] measuring the exact distance to `mesh`,
    /// the mesh its densities were voxelized from (at the same place: the grid's mesh units).
    pub fn with_mesh(self, mesh: Arc<MeshQuery>) -> Goal {
        Goal { mesh: Some(mesh), ..self }
    }

    /// This goal, with `points` sampled on the mesh it was voxelized from (mesh units) kept
    /// where the goal's surface is within `agreement` of its voxels of them: where the goal and
    /// the mesh agree, the detail levels fit the mesh itself (see `fit/detail.rs`), not the
    /// staircase of its voxelization; faces the voxelization buried or filled are left out.
    ///
    /// On the grid asked for the agreement is one voxel (`MESH_AGREEMENT`); a goal at half the
    /// resolution (`fit::detail::goal_grid`) takes two of its own voxels, as it misses relief
    /// that the grid resolves by up to a voxel of its own more: the horse with relief at 1024
    /// (bumps 3 voxels high) lay 3.06 voxels from the mesh at worst with one voxel of its goal,
    /// 1.70 with two.
    pub fn with_mesh_points(self, points: Vec<DVec3>, agreement: f32) -> Goal {
        let kept = self.agreeing(points, agreement);
        Goal { mesh_points: Some(kept), ..self }
    }

    /// Those of `points` (mesh units) near which the goal's surface lies within `agreement` of
    /// its voxels, as [`Goal::with_mesh_points`] keeps them.
    pub fn agreeing(&self, points: Vec<DVec3>, agreement: f32) -> Vec<DVec3> {
        let grid = *self.grid();
        let sub_voxel = self.sub_voxel();
        points
            .into_par_iter()
            .filter(|&p| sub_voxel.signed_distance(grid.to_grid(p)).abs() <= agreement)
            .collect()
    }

    /// This goal with the first `points` of `samples` (points on its mesh, mesh units, with
    /// their triangle's unit normal) for the detail levels, as [`Goal::with_mesh_points`] keeps
    /// them, once the slits narrower than a voxel that the goal bridged are carved (see
    /// `fit/slit.rs`): the slits' walls are found among all the samples the goal buries, with
    /// `query` (the mesh's) at `step` (mesh units) off their triangles, the goal is made again
    /// from its carved densities with `regularity`, and the walls are added to the points on
    /// the mesh: the model's zero set should pass through them, and the gap between them is
    /// outside.
    pub fn with_mesh_samples(
        self,
        mut samples: Vec<(DVec3, DVec3)>,
        points: usize,
        agreement: f32,
        query: &MeshQuery,
        step: f64,
        regularity: &RegularityOptions,
    ) -> Goal {
        let grid = *self.grid();
        let to_goal = |p: DVec3| grid.to_grid(p);
        let walls = slit::walls(&samples, &self.sub_voxel(), to_goal, agreement, query, step);
        let share = walls.len() as f64 / samples.len() as f64;
        samples.truncate(points);
        if walls.is_empty() {
            return self.with_mesh_points(samples.into_iter().map(|(p, _)| p).collect(), agreement);
        }
        let mesh = self.mesh.clone();
        let mut density = self.density;
        let carved = slit::carve(&mut density, &walls, to_goal);
        let walls: Vec<DVec3> = walls.iter().map(|w| w.point).collect();
        let on_wall: HashSet<[u64; 3]> = walls.iter().map(|&p| bits(p)).collect();
        let others = samples.into_iter().map(|(p, _)| p).filter(|&p| !on_wall.contains(&bits(p)));
        let goal =
            Goal::from_density(density, regularity).with_mesh_points(others.collect(), agreement);
        let mut mesh_points = goal.mesh_points.unwrap_or_default();
        mesh_points.extend_from_slice(&walls);
        let slits = slit::Slits { walls, share, carved };
        Goal { slits: Some(slits), mesh, mesh_points: Some(mesh_points), ..goal }
    }

    /// The slits narrower than a voxel carved by [`Goal::with_mesh_samples`], if any.
    pub(crate) fn slits(&self) -> Option<&slit::Slits> {
        self.slits.as_ref()
    }

    /// The points of [`Goal::with_mesh_points`], if any.
    pub fn mesh_points(&self) -> Option<&[DVec3]> {
        self.mesh_points.as_deref()
    }

    /// The mesh's distance query given by [`Goal::with_mesh`], if any.
    pub fn mesh(&self) -> Option<&Arc<MeshQuery>> {
        self.mesh.as_ref()
    }

    /// The grid the goal lives on.
    pub fn grid(&self) -> &Grid {
        &self.density.grid
    }

    /// The densities in [0, 1], 1 inside (paper 4.1); boundary constraints sit where they
    /// cross 1/2.
    pub fn density(&self) -> &Volume<f32> {
        &self.density
    }

    /// Frees the densities once nothing reads them: the fit with detail levels, whose pyramid
    /// and level 0 (the densities' readers: [`Goal::sub_voxel`], [`Goal::project_to_surface`]
    /// and the coarser goals) are done, so that its measure on the full grid does not hold them
    /// beside the model's volumes. The grid stays; nothing of the densities may be read after.
    pub(super) fn free_densities(&mut self) {
        self.density.data = Vec::new();
    }

    /// The goal's signed distance sd_goal (paper 4.2), in voxels, inside positive.
    pub fn sd(&self) -> &Volume<f32> {
        &self.sd
    }

    /// The goal's boundary voxels ∂f_goal: inside voxels with a 6-neighbour outside, sorted by
    /// index.
    pub fn boundary(&self) -> &[[usize; 3]] {
        &self.boundary
    }

    /// The radius of regularity at each of [`Goal::boundary`]'s voxels (paper 4.3), in voxels.
    pub fn rreg(&self) -> &[f32] {
        &self.rreg
    }

    /// The point where the densities cross 1/2 at each of [`Goal::boundary`]'s voxels, in
    /// continuous voxel coordinates: where boundary constraints go (paper 5.3, "at sub-voxel
    /// precision").
    pub fn surface(&self) -> &[DVec3] {
        &self.surface
    }

    /// The goal's signed distance to sub-voxel precision, from the densities near the surface.
    pub fn sub_voxel(&self) -> SubVoxel<'_> {
        SubVoxel { values: &self.density, level: 0.5, sd: &self.sd, reach: 1.5 }
    }

    /// The goal's signed distance at `p` (continuous voxel coordinates, inside positive, in
    /// voxels). With a mesh ([`Goal::with_mesh`]), the exact distance to its triangles, with
    /// the side measured as below. Without, the distance to the nearest of its surface disks
    /// (a disk in the tangent plane at each of [`Goal::surface`]'s points) within 2.5 voxels of
    /// its voxel surface, the voxel-centre distance elsewhere and wherever the two differ by
    /// more than `AGREEMENT`. Within a voxel of the surface the side is the disk's, further
    /// out the voxel-centre distance's.
    pub fn fine_signed_distance(&self, p: DVec3) -> f32 {
        let voxelized = self.voxelized_signed_distance(p);
        match &self.mesh {
            Some(mesh) => {
                let grid = self.grid();
                let exact = mesh.nearest(grid.to_world(p)).distance / grid.voxel_size;
                (exact as f32).copysign(voxelized)
            }
            None => voxelized,
        }
    }

    /// [`Goal::fine_signed_distance`] from the voxelization alone: its disks and voxel-centre
    /// distance.
    fn voxelized_signed_distance(&self, p: DVec3) -> f32 {
        let coarse = edt::sample(&self.sd, p);
        if coarse.abs() > surface::REACH {
            return coarse;
        }
        match self.disks.signed_distance(&self.surface, p) {
            Some(d) if (d.abs() - coarse.abs()).abs() <= AGREEMENT => {
                if d.abs() < 1.0 {
                    d
                } else {
                    d.abs().copysign(coarse)
                }
            }
            _ => coarse,
        }
    }

    /// The point of the goal's surface nearest `p` (continuous voxel coordinates), or `None`
    /// where it cannot be found reliably.
    ///
    /// The first step goes from `p` along the gradient of the voxel signed distance by the
    /// sub-voxel signed distance; up to four more correct it along the
    /// densities' gradient (the voxel signed distance's where the densities are flat). Where the
    /// densities saturate (a voxel or more from the surface) their gradient is small and these
    /// steps overshoot, so once two steps end on opposite sides of the surface the crossing of
    /// the densities through 1/2 on the segment between them is found by bisection. The point
    /// is kept only if its sub-voxel signed distance is within a tenth of a voxel
    /// of zero: near a crease or a medial sheet the gradient turns, and a point that does not
    /// settle on the surface would be a boundary constraint off the goal's surface.
    pub fn project_to_surface(&self, p: DVec3) -> Option<DVec3> {
        let fine = self.sub_voxel();
        let mut q = p;
        let mut previous: Option<(DVec3, f64)> = None;
        for step in 0..=PROJECTION_STEPS {
            let d = f64::from(fine.signed_distance(q));
            if d.abs() <= PROJECTION_TOLERANCE {
                return Some(q);
            }
            if let Some((before, d_before)) = previous
                && d_before * d < 0.0
            {
                return self.bisect_crossing(before, q);
            }
            if step == PROJECTION_STEPS {
                break;
            }
            let mut direction = edt::gradient(&self.density, q);
            if step == 0 || direction.length() < 1e-3 {
                direction = edt::gradient(&self.sd, q);
            }
            if direction.length() < 1e-6 {
                break;
            }
            previous = Some((q, d));
            q -= direction.normalize() * d;
        }
        None
    }

    /// The point between `a` and `b`, on opposite sides of the surface, where the densities
    /// cross 1/2, by bisection; `None` if it is not within [`PROJECTION_TOLERANCE`] of the
    /// surface by the sub-voxel signed distance.
    fn bisect_crossing(&self, a: DVec3, b: DVec3) -> Option<DVec3> {
        let excess = |q: DVec3| f64::from(edt::sample(&self.density, q)) - 0.5;
        let (mut inside, mut outside) = if excess(a) > 0.0 { (a, b) } else { (b, a) };
        if excess(inside) <= 0.0 || excess(outside) > 0.0 {
            return None;
        }
        for _ in 0..BISECTION_STEPS {
            let middle = (inside + outside) * 0.5;
            if excess(middle) > 0.0 {
                inside = middle;
            } else {
                outside = middle;
            }
        }
        let q = (inside + outside) * 0.5;
        (f64::from(self.sub_voxel().signed_distance(q)).abs() <= PROJECTION_TOLERANCE).then_some(q)
    }
}

/// Newton steps of [`Goal::project_to_surface`] after the first.
const PROJECTION_STEPS: usize = 4;

/// Halvings of the bisection of [`Goal::project_to_surface`]: a segment of a few voxels ends
/// some 1e-12 voxel long.
const BISECTION_STEPS: usize = 42;

/// How far (voxels) from the goal's surface a projected point may end.
const PROJECTION_TOLERANCE: f64 = 0.1;

#[cfg(test)]
impl Goal {
    /// A ball of radius `radius` voxels at `centre`, voxelized by supersampling each voxel
    /// 8 x 8 x 8 times.
    pub(crate) fn ball(n: usize, centre: DVec3, radius: f64) -> Goal {
        let grid = Grid { dims: [n; 3], origin: [0.0; 3], voxel_size: 1.0 };
        let data = (0..grid.len())
            .map(|v| {
                let p = DVec3::from_array(grid.voxel(v).map(|c| c as f64));
                let mut inside = 0;
                for s in 0..512 {
                    let offset = DVec3::new((s / 64) as f64, (s / 8 % 8) as f64, (s % 8) as f64);
                    let q = p + (offset + 0.5) / 8.0 - 0.5;
                    inside += usize::from(q.distance(centre) < radius);
                }
                inside as f32 / 512.0
            })
            .collect();
        Goal::from_density(Volume { grid, data }, &RegularityOptions::default())
    }
}

/// The bits of a point's coordinates, to find it again exactly.
fn bits(p: DVec3) -> [u64; 3] {
    p.to_array().map(f64::to_bits)
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::Goal;
    use crate::geometry::DVec3;

    /// Within two voxels of a voxelized ball the distance to the disks is within 0.4 voxels
    /// of the exact one, 0.05 on average (the surface points' own error; measured 0.34 and
    /// 0.04), where the densities' estimate is off by up to 0.78 voxels.
    #[test]
    fn distances_to_a_ball_are_within_the_surface_points_error() {
        let centre = DVec3::splat(20.3);
        let radius = 12.4;
        let goal = Goal::ball(41, centre, radius);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let (mut worst, mut sum) = (0.0f64, 0.0);
        let count = 4000;
        for _ in 0..count {
            let direction = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
            let direction = direction.try_normalize().unwrap_or(DVec3::X);
            let depth = 4.0 * rng.random::<f64>() - 2.0;
            let q = centre + direction * (radius - depth);
            let error = (f64::from(goal.fine_signed_distance(q)) - depth).abs();
            worst = worst.max(error);
            sum += error;
        }
        let mean = sum / count as f64;
        assert!(worst < 0.4 && mean < 0.05, "{worst} voxels off at worst, {mean} on average");
    }
}
