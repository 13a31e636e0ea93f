//! Samples of a mesh's signed distance for learning shapes, as DeepSDF (Park et al. 2019,
//! "DeepSDF: Learning Continuous Signed Distance Functions for Shape Representation") makes
//! them: points near the surface, drawn by displacing random points of the surface with
//! Gaussian noise, and points uniform in a box around the mesh, each with the mesh's exact
//! signed distance.
//!
//! # Conventions
//! * **Counts:** of `n` points, `round(uniform * n)` are uniform and the rest near the surface,
//!   split evenly among the standard deviations (when they do not divide evenly, the first ones
//!   take one more each). [`Samples::points`] lists the near points of the first standard
//!   deviation, then of the second..., then the uniform points.
//! * **Near the surface:** a triangle chosen with probability proportional to its area, a point
//!   uniform on it, plus isotropic Gaussian noise of standard deviation `sigma` times the
//!   diagonal of the mesh's bounding box in each coordinate.
//! * **Uniform:** in the mesh's bounding box grown on every side by 10% of its size along that
//!   axis (`PADDING`).
//! * **Distance:** exact, to the triangles ([`crate::mesh_query`]), f64 in the mesh's units,
//!   positive inside as the voxelizer decides it (rays along the three axes, the generalized
//!   winding number where they disagree), as [`MeshQuery::signed`] gives it.
//! * **Deterministic:** the same mesh, `n` and options give the same samples bit for bit, on
//!   any number of threads: each block of 2^14 points draws from its own ChaCha8 stream
//!   of the seed.
//! * **DeepSDF's layout** ([`Samples::deepsdf`]): float32 rows `x, y, z, sdf` with DeepSDF's
//!   sign, negative inside; `pos` holds the rows whose DeepSDF value is above 0 (outside) and
//!   `neg` the rest, as DeepSDF's `writeSDFToNPZ` splits them.
//!
//! DeepSDF's own preprocessing draws 47 of every 50 points near the surface of a mesh scaled
//! into the unit sphere, with noise whose *variances* are 0.005 and 0.0005 (standard deviations
//! 0.071 and 0.022 of the unit sphere's radius); here the defaults of
//! [`SampleOptions`] are standard deviations, as fractions of the box's
//! diagonal, and a fifth of the points uniform.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::geometry::{Aabb, DVec3};
use crate::memory::MemoryLimit;
use crate::mesh::Mesh;
use crate::mesh::area::ByArea;
use crate::mesh_query::MeshQuery;

/// What sampling a mesh's signed distance ([`crate::pipeline::sample`]) needs besides the mesh and the number
/// of points ([`crate::pipeline::sample`] says how the points are drawn).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct SampleOptions {
    /// The standard deviations of the Gaussian noise that moves surface points off the surface,
    /// as fractions of the diagonal of the mesh's bounding box; the near points are split
    /// evenly among them (default 0.005 and 0.0005). Empty: every point uniform.
    pub near_surface: Vec<f64>,
    /// The fraction of the points uniform in the mesh's box padded by 10% of its size, in
    /// [0, 1] (default 0.2).
    pub uniform: f64,
    /// The seed of the random choices (default: the fit's, 1).
    pub seed: u64,
    /// The memory the job may use.
    pub memory_limit: MemoryLimit,
}

impl Default for SampleOptions {
    fn default() -> Self {
        SampleOptions {
            near_surface: vec![0.005, 0.0005],
            uniform: 0.2,
            seed: 1,
            memory_limit: MemoryLimit::default(),
        }
    }
}

impl SampleOptions {
    /// Checks every setting: the standard deviations finite and positive, the uniform fraction
    /// in [0, 1], and some near points' standard deviation unless every point is uniform.
    ///
    /// # Errors
    /// The first setting out of its range, named.
    pub fn check(&self) -> Result<()> {
        if let Some(sigma) = self.near_surface.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
            return Err(Error::invalid(
                "options",
                format!(
                    "`near_surface` standard deviations must be finite and above 0, not {sigma}"
                ),
            ));
        }
        if !(0.0..=1.0).contains(&self.uniform) {
            return Err(Error::invalid(
                "options",
                format!("`uniform` must be a fraction in [0, 1], not {}", self.uniform),
            ));
        }
        if self.near_surface.is_empty() && self.uniform < 1.0 {
            return Err(Error::invalid(
                "options",
                "`near_surface` names no standard deviation for the points near the surface \
                 (give one, or make `uniform` 1)",
            ));
        }
        Ok(())
    }
}

/// The uniform points' box: the mesh's box grown on every side by this fraction of its size
/// along each axis.
pub(crate) const PADDING: f64 = 0.1;

pub(crate) use crate::mesh::area::BLOCK;

/// Points around a mesh and its signed distance at each.
#[derive(Debug, Clone, PartialEq)]
pub struct Samples {
    /// The points, mesh units: the near points of each standard deviation in turn, then the
    /// uniform points.
    pub points: Vec<DVec3>,
    /// The exact signed distance at each point, mesh units, positive inside.
    pub sdf: Vec<f64>,
    /// How many near points each standard deviation got, in the order of the options.
    pub near: Vec<usize>,
    /// How many points are uniform in the padded box (the last ones).
    pub uniform: usize,
}

/// How many of `n` points go to each standard deviation of `near_surface` and how many are
/// uniform (see the module doc).
pub fn counts(n: usize, options: &SampleOptions) -> (Vec<usize>, usize) {
    let uniform = ((n as f64 * options.uniform).round() as usize).min(n);
    let near = n - uniform;
    let k = options.near_surface.len();
    if k == 0 {
        return (Vec::new(), n);
    }
    let per = (0..k).map(|i| near / k + usize::from(i < near % k)).collect();
    (per, uniform)
}

/// The uniform points' box around `bounds` (see `PADDING`).
pub fn padded(bounds: &Aabb) -> Aabb {
    let pad = (bounds.max - bounds.min) * PADDING;
    Aabb { min: bounds.min - pad, max: bounds.max + pad }
}

/// Draws `n` samples of `mesh` as `options` say (checked by the caller) and measures them with
/// `query`, the distance query of the same mesh (whose building checked its indices and
/// coordinates).
///
/// # Errors
/// Near points asked of a mesh whose triangles have no area; `source` names it.
pub(crate) fn sample(
    mesh: &Mesh,
    query: &MeshQuery,
    source: &str,
    n: usize,
    options: &SampleOptions,
) -> Result<Samples> {
    let bounds =
        mesh.bounds().ok_or_else(|| Error::invalid(source, "the mesh has no triangles"))?;
    let (near, uniform) = counts(n, options);
    let surface = surface_to_draw_near(mesh, near.iter().sum(), source)?;
    let diagonal = (bounds.max - bounds.min).length();
    // Each point's kind: the standard deviation of its noise, or `None` for uniform.
    let kinds: Vec<Option<f64>> = near
        .iter()
        .zip(&options.near_surface)
        .flat_map(|(&count, &sigma)| std::iter::repeat_n(Some(sigma * diagonal), count))
        .chain(std::iter::repeat_n(None, uniform))
        .collect();
    let room = padded(&bounds);
    let points: Vec<DVec3> = kinds
        .par_chunks(BLOCK)
        .enumerate()
        .flat_map_iter(|(block, kinds)| {
            let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
            rng.set_stream(block as u64);
            kinds
                .iter()
                .map(|kind| match kind {
                    Some(sigma) => {
                        let surface = surface.as_ref().expect("near points have a surface");
                        surface.point(&mut rng) + gaussian(&mut rng) * *sigma
                    }
                    None => uniform_in(&room, &mut rng),
                })
                .collect::<Vec<_>>()
        })
        .collect();
    let sdf = query.signed(&points);
    Ok(Samples { points, sdf, near, uniform })
}

/// The surface of `mesh` by area, to draw `near` points near it from (none: no surface is
/// needed, and a mesh without area is fine).
///
/// # Errors
/// Near points asked of a mesh whose triangles have no area; `source` names it.
fn surface_to_draw_near(mesh: &Mesh, near: usize, source: &str) -> Result<Option<ByArea>> {
    if near == 0 {
        return Ok(None);
    }
    let surface = ByArea::of(mesh).ok_or_else(|| {
        Error::invalid(source, "the triangles have no area to draw points near the surface from")
    })?;
    Ok(Some(surface))
}

/// A point uniform in `room`.
fn uniform_in(room: &Aabb, rng: &mut ChaCha8Rng) -> DVec3 {
    let u = DVec3::new(rng.random(), rng.random(), rng.random());
    room.min + (room.max - room.min) * u
}

/// Three independent standard normal values.
fn gaussian(rng: &mut ChaCha8Rng) -> DVec3 {
    DVec3::from_array(std::array::from_fn(|_| rng.sample(StandardNormal)))
}

impl Samples {
    /// DeepSDF's layout (see the module doc): the `pos` and `neg` rows `x, y, z, sdf`, float32,
    /// with DeepSDF's sign (negative inside).
    pub fn deepsdf(&self) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
        self.deepsdf_rows().partition(is_pos)
    }

    /// The rows of [`Samples::deepsdf`], in the points' order.
    fn deepsdf_rows(&self) -> impl Iterator<Item = [f32; 4]> + '_ {
        self.points.iter().zip(&self.sdf).map(|(p, &s)| {
            let deepsdf = -s as f32;
            [p.x as f32, p.y as f32, p.z as f32, deepsdf]
        })
    }

    /// Writes the samples as a NumPy `.npz` archive, atomically: `points` (N x 3 float64),
    /// `sdf` (N float64, mesh units, inside positive), and DeepSDF's `pos` and `neg`
    /// ([`Samples::deepsdf`]), each array's bytes made straight from the samples.
    ///
    /// # Errors
    /// The file cannot be written, or an array passes 4 GB (the archive is not ZIP64).
    pub fn save_npz(&self, path: &std::path::Path) -> Result<()> {
        let n = self.points.len() as u64;
        let pos = self.deepsdf_rows().filter(is_pos).count() as u64;
        let rows = |keep: bool| {
            let rows = self.deepsdf_rows().filter(move |row| is_pos(row) == keep);
            rows.flatten()
        };
        let arrays = [
            (
                "points",
                crate::npy::to_bytes(&[n, 3], self.points.iter().flat_map(|p| p.to_array())),
            ),
            ("sdf", crate::npy::to_bytes(&[n], self.sdf.iter().copied())),
            ("pos", crate::npy::to_bytes(&[pos, 4], rows(true))),
            ("neg", crate::npy::to_bytes(&[n - pos, 4], rows(false))),
        ];
        crate::npy::write_npz(path, &arrays)
    }
}

/// Whether a row of DeepSDF's layout goes to `pos`: its value (DeepSDF's sign) is above 0.
fn is_pos(row: &[f32; 4]) -> bool {
    row[3] > 0.0
}
