//! How thick the goal's solid is, and whether its grid holds it.
//!
//! The paper's fit (section 5) needs a solid at least a few voxels thick: boundary constraints
//! on its faces, interior constraints inside. A hollowed print, a single-sheet scan or an open
//! car body has walls of a voxel or less, which the voxelization keeps in pieces or not at all.
//! [`Thickness::measure`] says how thick the solid is and how much of the mesh's surface the
//! grid lost; [`Thickness::refusal`] turns a wall the grid cannot hold into one line naming
//! what would work (a finer grid, or a fit of the thickened surface, `shell`).
//!
//! * Depth: the inside distance along the goal's medial axis, the inside voxels whose signed
//!   distance is a local maximum (none of their 26 neighbours larger), measured exactly to the
//!   mesh's triangles, in voxels: half the wall's thickness there. The largest is half the
//!   thickest part, a low percentile half the thin walls.
//! * Thin surface: points drawn on the mesh by area, seeded; a point where no voxel within
//!   [`REACH`] voxels (along each axis) is more than [`DEEP`] voxels inside the goal's solid
//!   lies on a wall thinner than about `2 (DEEP + 1/2)` voxels, or on a wall the grid lost.
//! * Wall at a thin point `p` with unit normal `n`: within `h` = [`PROBE`] voxels a wall of
//!   thickness `t < h` has its other face at `t`, so the nearer of `p ± h n` is `h - t` from the
//!   mesh and `t = h - min(d(p + h n), d(p - h n))` (0 for a single sheet).
//!
//! The fit refuses ([`Thickness::refusal`]) where more than [`MAX_THIN`] of the surface is thin
//! on walls under [`MIN_WALL`] voxels: there its constraints have no interior to hold the two
//! faces of a wall apart, and the fit ends far from its target. The resolution it names makes the
//! thin walls [`HELD_WALL`] voxels thick.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::Error;
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};
use crate::mesh::Mesh;
use crate::mesh_query::MeshQuery;

/// How thick a goal's solid is, in voxels of its grid (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Thickness {
    /// The largest inside distance along the medial axis, voxels (half the thickest part); 0
    /// where no voxel is inside.
    pub max_depth: f64,
    /// The 10th percentile of the inside distance along the medial axis, voxels (half the thin
    /// walls).
    pub low_depth: f64,
    /// The fraction of the mesh's surface on thin walls (no voxel within `REACH` more than
    /// `DEEP` voxels inside) or on walls the grid lost.
    pub thin_surface: f64,
    /// The median thickness of those thin walls, voxels (0 for single sheets; at most
    /// `PROBE`); 0 where none is thin.
    pub thin_wall: f64,
}

/// How far (voxels, along each axis) from a point of the surface a deep voxel is looked for.
pub(crate) const REACH: usize = 3;

/// A voxel this deep (voxels) inside the goal's solid: the surface near it is not thin.
pub(crate) const DEEP: f32 = 2.0;

/// How far (voxels) from a thin point the other face of its wall is looked for.
pub(crate) const PROBE: f64 = 6.0;

/// Above this fraction of the surface thin, the fit is refused: a hollow shell is thin all
/// over, where solids with thin limbs that fit have less (measured in `docs/results.md`,
/// "Where the thickness thresholds come from").
pub(crate) const MAX_THIN: f64 = 0.5;

/// Thin walls at least this thick (voxels) are fitted, however much of the surface they hold
/// (the thinnest walls measured to fit and the thickest measured to fail lie on either side:
/// `docs/results.md`, "Where the thickness thresholds come from").
pub(crate) const MIN_WALL: f64 = 4.5;

/// Above this fraction of the surface on walls under [`MIN_WALL`] voxels, a fit the grid holds
/// still warns ([`Thickness::warning`]), below the share that is refused.
pub(crate) const THIN_WARNING: f64 = 0.25;

/// The wall (voxels) the resolution a refusal names gives the thin walls.
pub(crate) const HELD_WALL: f64 = 6.0;

/// Points drawn on the surface.
const SURFACE_POINTS: usize = 4096;

/// At most this many medial voxels are measured (every k-th, in index order).
const MEDIAL_POINTS: usize = 20_000;

impl Thickness {
    /// Measures the thickness of the solid whose signed distance (voxels, inside positive) is
    /// `sd` (a goal's, `Goal::sd`) against `mesh`, the mesh it was voxelized from, with its
    /// distance query `query`; `seed` draws the surface points.
    pub fn measure(sd: &Volume<f32>, mesh: &Mesh, query: &MeshQuery, seed: u64) -> Thickness {
        let grid = sd.grid;
        let mut depths = medial_depths(sd, query);
        depths.sort_by(f64::total_cmp);
        let max_depth = depths.last().copied().unwrap_or(0.0);
        let low_depth = depths.get(depths.len() / 10).copied().unwrap_or(0.0);
        let points =
            crate::metrics::surface::sample(mesh, SURFACE_POINTS, seed).unwrap_or_default();
        let drawn = points.len().max(1);
        let thin: Vec<DVec3> =
            points.into_par_iter().filter(|&p| !has_deep_voxel(sd, grid.to_grid(p))).collect();
        let thin_surface = thin.len() as f64 / drawn as f64;
        let mut walls = walls(mesh, query, &grid, &thin);
        walls.sort_by(f64::total_cmp);
        let thin_wall = walls.get(walls.len() / 2).copied().unwrap_or(0.0);
        Thickness { max_depth, low_depth, thin_surface, thin_wall }
    }

    /// These figures in voxels `scale` times smaller: a goal's on the grid asked for, where
    /// the goal's voxels are `scale` of that grid's (`crate::fit::detail::goal_grid`).
    pub fn in_smaller_voxels(self, scale: f64) -> Thickness {
        Thickness {
            max_depth: self.max_depth * scale,
            low_depth: self.low_depth * scale,
            thin_wall: self.thin_wall * scale,
            ..self
        }
    }

    /// Whether the grid holds the solid: no more than `MAX_THIN` of its surface thin, or
    /// its thin walls at least `MIN_WALL` voxels thick.
    pub fn is_held(&self) -> bool {
        self.thin_surface <= MAX_THIN || self.thin_wall >= MIN_WALL
    }

    /// The refusal of a fit of `source` on a grid of `longest_axis` voxels along its longest
    /// axis where the grid does not hold the solid ([`Thickness::is_held`]), or `None`.
    pub fn refusal(&self, source: &str, longest_axis: usize) -> Option<Error> {
        (!self.is_held())
            .then(|| Error::Thin { context: source.into(), message: self.why(longest_axis) })
    }

    /// A warning (one line, no file name, settings backquoted as in errors) for a fit the grid
    /// holds with more than `THIN_WARNING` (a quarter) of its surface on walls under `MIN_WALL`
    /// (4.5) voxels,
    /// naming their thickness and what fits them better; or `None`.
    pub fn warning(&self, longest_axis: usize) -> Option<String> {
        let thin = self.thin_surface > THIN_WARNING && self.thin_wall < MIN_WALL;
        (thin && self.is_held()).then(|| {
            let measured = format!(
                "{:.0}% of the surface is on walls about {:.1} voxels thick, which the fit may \
                 not hold",
                100.0 * self.thin_surface,
                self.thin_wall
            );
            match self.resolution_holding(longest_axis) {
                Some(n) => format!("{measured}; a finer grid, `resolution={n}`, holds them"),
                None => format!("{measured}; `shell=2` fits the surface thickened instead"),
            }
        })
    }

    /// What is too thin and what would work, for a grid of `longest_axis` voxels.
    pub fn why(&self, longest_axis: usize) -> String {
        let measured = format!(
            "the solid is too thin to fit on this grid: {:.0}% of its surface is on walls about \
             {:.1} voxels thick (its deepest point {:.1} voxels inside)",
            100.0 * self.thin_surface,
            self.thin_wall,
            self.max_depth
        );
        match self.resolution_holding(longest_axis) {
            Some(n) => format!(
                "{measured}; fit it on a finer grid, `resolution={n}`, or as its surface \
                 thickened to 2 voxels, `shell=2`"
            ),
            None => format!(
                "{measured}: an open sheet; fit it as its surface thickened to 2 voxels, \
                 `shell=2`"
            ),
        }
    }

    /// The resolution at which the thin walls are [`HELD_WALL`] voxels thick, or `None` for
    /// sheets (walls under half a voxel) or past [`Grid::MAX_AXIS`].
    fn resolution_holding(&self, longest_axis: usize) -> Option<usize> {
        if self.thin_wall < 0.5 {
            return None;
        }
        let n = (longest_axis as f64 * HELD_WALL / self.thin_wall).ceil() as usize;
        (n <= Grid::MAX_AXIS).then_some(n.max(longest_axis + 1))
    }
}

/// Whether a voxel within [`REACH`] voxels of `p` (continuous voxel coordinates) along each
/// axis is more than [`DEEP`] voxels inside.
fn has_deep_voxel(sd: &Volume<f32>, p: DVec3) -> bool {
    let dims = sd.grid.dims;
    let range = |a: usize| {
        let centre = p[a].round().clamp(0.0, (dims[a] - 1) as f64) as usize;
        centre.saturating_sub(REACH)..=(centre + REACH).min(dims[a] - 1)
    };
    range(0).any(|i| range(1).any(|j| range(2).any(|k| *sd.get([i, j, k]) > DEEP)))
}

/// The exact inside distance (voxels) at the goal's medial voxels, at most [`MEDIAL_POINTS`]
/// of them.
fn medial_depths(sd: &Volume<f32>, query: &MeshQuery) -> Vec<f64> {
    let grid = sd.grid;
    let medial: Vec<usize> =
        (0..grid.len()).into_par_iter().filter(|&n| is_medial(sd, n)).collect();
    let stride = medial.len().div_ceil(MEDIAL_POINTS).max(1);
    let points: Vec<DVec3> =
        medial.iter().step_by(stride).map(|&n| grid.position(grid.voxel(n))).collect();
    query.distances(&points).iter().map(|d| d / grid.voxel_size).collect()
}

/// Whether voxel `n` is inside and none of its 26 neighbours has a larger signed distance.
fn is_medial(sd: &Volume<f32>, n: usize) -> bool {
    let value = sd.data[n];
    if !(value > 0.0 && value.is_finite()) {
        return false;
    }
    let dims = sd.grid.dims;
    let v = sd.grid.voxel(n);
    let range = |a: usize| v[a].saturating_sub(1)..=(v[a] + 1).min(dims[a] - 1);
    range(0).all(|i| range(1).all(|j| range(2).all(|k| *sd.get([i, j, k]) <= value)))
}

/// The thickness (voxels) of the wall at each of `points`, up to [`PROBE`] (see the module
/// doc).
fn walls(mesh: &Mesh, query: &MeshQuery, grid: &Grid, points: &[DVec3]) -> Vec<f64> {
    let h = PROBE * grid.voxel_size;
    let nearest = query.nearest_all(points);
    let probes: Vec<DVec3> = points
        .iter()
        .zip(&nearest)
        .flat_map(|(&p, n)| {
            let normal = triangle_normal(mesh, n.triangle);
            [p + normal * h, p - normal * h]
        })
        .collect();
    let distances = query.distances(&probes);
    distances
        .chunks(2)
        .map(|pair| ((h - pair[0].min(pair[1])) / grid.voxel_size).max(0.0))
        .collect()
}

/// The unit normal of `mesh`'s triangle `t` (zero for a degenerate one).
fn triangle_normal(mesh: &Mesh, t: usize) -> DVec3 {
    let [a, b, c] = mesh.triangles[t].map(|i| mesh.vertices[i as usize]);
    (b - a).cross(c - a).normalize_or_zero()
}
