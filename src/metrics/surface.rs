//! How far apart two triangle surfaces are, each way: points spread over one surface by area,
//! and each point's exact distance to the other ([`crate::mesh_query`]), summed up as the
//! largest, the 99.9th percentile and the mean.
//!
//! A fit measures its model this way against the mesh it was fitted to
//! ([`crate::pipeline::Prepared::fit`]): the mesh against the model's polygonized zero set, the
//! surface `implicitize fit --mesh-out` writes, so that the report's figures are what an outside
//! check of the two files measures.
//!
//! # Sampling
//! `SAMPLES` points a surface, spread by area and stratified ([`spread`]): the triangles are
//! taken in the order of their distance hierarchy, which keeps neighbours together, and laid
//! end to end by area; the points sit at equal steps of area along them, from an offset drawn
//! from the seed (systematic sampling), each uniform on its triangle. Every triangle, and so
//! every run of neighbouring triangles, gets its share of the points to within one, where
//! independent draws give it a share that varies by its square root: the percentile moves far
//! less from one seed to the next (measured in `docs/results.md`, "The report's own measure
//! against libigl"). The mesh's points
//! are spread with the seed, the model's with the next; the same surfaces and seed give the
//! same figures on any number of threads. The mean and the 99.9th percentile are those of the
//! samples, the percentile interpolated between the two nearest ranks (as numpy's default).
//! The largest distance of the samples is a lower bound of the true largest, which sits at a
//! point the samples may miss.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::geometry::DVec3;
use crate::mesh::Mesh;
use crate::mesh::area::{BLOCK, ByArea, on_triangle};
use crate::mesh_query::MeshQuery;

/// Points sampled on each surface.
pub(crate) const SAMPLES: usize = 100_000;

/// Distances from points sampled on one surface to another, in voxels of a grid.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DistanceSummary {
    /// The largest distance of the samples.
    pub max: f64,
    /// The 99.9th percentile of the distances.
    #[serde(rename = "p99.9")]
    pub p99_9: f64,
    /// The 99.99th percentile of the distances (the tenth largest of `SAMPLES`).
    #[serde(rename = "p99.99", default)]
    pub p99_99: f64,
    /// The mean distance.
    pub mean: f64,
    /// The sample at the largest distance, mesh units: where the surfaces are farthest apart.
    #[serde(default)]
    pub farthest: [f64; 3],
}

impl DistanceSummary {
    /// The summary of `distances` (at least one) from `points`, each divided by `unit`.
    pub fn of(distances: &[f64], points: &[DVec3], unit: f64) -> DistanceSummary {
        let farthest = distances
            .iter()
            .zip(points)
            .max_by(|a, b| a.0.total_cmp(b.0))
            .map_or([f64::NAN; 3], |(_, p)| p.to_array());
        let mut scaled: Vec<f64> = distances.iter().map(|d| d / unit).collect();
        DistanceSummary {
            max: scaled.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            mean: scaled.iter().sum::<f64>() / scaled.len() as f64,
            p99_9: super::percentile(&mut scaled, 0.999),
            p99_99: super::percentile(&mut scaled, 0.9999),
            farthest,
        }
    }
}

/// A fitted model's surface against its mesh, both ways, in voxels of the fit's grid.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MeshDistances {
    /// From points on the mesh to the model's polygonized surface.
    pub mesh_to_model: DistanceSummary,
    /// From points on the model's polygonized surface to the mesh.
    pub model_to_mesh: DistanceSummary,
    /// The share of the mesh's surface inside its own solid ([`interior`]): faces with the
    /// solid on both sides (overlapping parts, walls inside walls), which no solid's surface
    /// holds.
    #[serde(default)]
    pub interior: f64,
    /// From the points on the mesh that bound its solid (the interior ones left out) to the
    /// model's surface; absent unless `interior` is above `INTERIOR_NOTABLE` (it is then
    /// `mesh_to_model` to within the few samples that sharp creases can put inside).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounding_to_model: Option<DistanceSummary>,
    /// From `SAMPLES` points drawn by area on `solid` of [`between`], the surface of the solid an
    /// open mesh's winding number defines (the goal's densities polygonized at 1/2), to the
    /// model's surface: where an open mesh's faces hang in space or its holes are capped, that
    /// surface, not the faces, is what a model of the solid can hold.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solid_to_model: Option<DistanceSummary>,
    /// From the model's surface to that solid's surface, the same points as `model_to_mesh`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_to_solid: Option<DistanceSummary>,
}

impl MeshDistances {
    /// The side from the mesh to the model that a fit is judged by: the surface of the solid
    /// an open mesh's winding number defines, else the faces that bound the solid where some
    /// lie inside it, else the whole mesh.
    pub fn judged_to_model(&self) -> &DistanceSummary {
        self.solid_to_model
            .as_ref()
            .or(self.bounding_to_model.as_ref())
            .unwrap_or(&self.mesh_to_model)
    }

    /// The side from the model to the mesh that a fit is judged by: to the surface of the
    /// solid an open mesh's winding number defines, else to the mesh.
    pub fn judged_from_model(&self) -> &DistanceSummary {
        self.model_to_solid.as_ref().unwrap_or(&self.model_to_mesh)
    }
}

/// How far `model` (a fitted model's polygonized surface) and the surface of `mesh_query` are
/// apart, each way, from `SAMPLES` points spread over each with `seed`, in units of
/// `voxel_size` (see the module doc). `None` where either surface has no area.
///
/// # Errors
/// A model surface whose distance query cannot be built (see [`MeshQuery::new`]).
pub fn between(
    mesh_query: &MeshQuery,
    model: &Mesh,
    solid: Option<&Mesh>,
    voxel_size: f64,
    seed: u64,
) -> Result<Option<MeshDistances>> {
    let model_query = MeshQuery::new(model)?;
    let (Some(on_mesh), Some(on_model)) =
        (spread_on(mesh_query, SAMPLES, seed), spread(&model_query, SAMPLES, seed.wrapping_add(1)))
    else {
        return Ok(None);
    };
    let inner = interior(mesh_query, &on_mesh, voxel_size * INTERIOR_STEP);
    let on_mesh: Vec<DVec3> = on_mesh.into_iter().map(|(p, _)| p).collect();
    let to_model = model_query.distances(&on_mesh);
    let interior_points = inner.iter().filter(|&&i| i).count();
    let interior_share = interior_points as f64 / on_mesh.len() as f64;
    let bounding_to_model = (interior_share > INTERIOR_NOTABLE && interior_points < on_mesh.len())
        .then(|| {
            let (distances, points): (Vec<f64>, Vec<DVec3>) = to_model
                .iter()
                .zip(&on_mesh)
                .zip(&inner)
                .filter(|(_, inner)| !**inner)
                .map(|((&d, &p), _)| (d, p))
                .unzip();
            DistanceSummary::of(&distances, &points, voxel_size)
        });
    let model_to_mesh =
        DistanceSummary::of(&mesh_query.distances(&on_model), &on_model, voxel_size);
    // The solid's points are measured to the model before the model's query is freed, and the
    // solid's query built after: one query at a time.
    let on_solid = solid.and_then(|solid| sample(solid, SAMPLES, seed.wrapping_add(2)));
    let solid_to_model =
        on_solid.as_ref().map(|on| DistanceSummary::of(&model_query.distances(on), on, voxel_size));
    drop(model_query);
    let model_to_solid = match solid {
        Some(solid) if on_solid.is_some() => {
            let distances = MeshQuery::new(solid)?.distances(&on_model);
            Some(DistanceSummary::of(&distances, &on_model, voxel_size))
        }
        _ => None,
    };
    Ok(Some(MeshDistances {
        mesh_to_model: DistanceSummary::of(&to_model, &on_mesh, voxel_size),
        model_to_mesh,
        interior: interior_share,
        bounding_to_model,
        solid_to_model,
        model_to_solid,
    }))
}

/// The share of a mesh's surface inside its own solid above which [`MeshDistances`] measures
/// the rest apart: a tenth of a percent, more than rounding puts there on a closed mesh's sharp
/// creases (the bunny: 0.002%).
pub(crate) const INTERIOR_NOTABLE: f64 = 0.001;

/// How far off a face [`interior`] looks at each side of it, in voxels: far enough that
/// rounding cannot put both points on the face, near enough that a wall a voxel thick has its
/// outside within reach.
const INTERIOR_STEP: f64 = 0.25;

/// Whether each of `samples` (a point and its triangle in `query.triangles()`) lies inside the
/// mesh's own solid: the points `step` (mesh units) off its triangle on both sides are both
/// inside, as [`MeshQuery::inside`] decides (ray votes, the winding number where they
/// disagree). A face that bounds the solid has its outside on one side; an interior face (the
/// spout's wall inside a teapot's body, a part pushed into another) has the solid on both.
/// A degenerate triangle (no normal) is not interior.
pub fn interior(query: &MeshQuery, samples: &[(DVec3, usize)], step: f64) -> Vec<bool> {
    let triangles = query.triangles();
    let offsets: Vec<DVec3> = samples
        .par_iter()
        .map(|&(_, t)| {
            let [a, b, c] = triangles[t];
            (b - a).cross(c - a).normalize_or_zero() * step
        })
        .collect();
    let front: Vec<DVec3> = samples.iter().zip(&offsets).map(|(&(p, _), &o)| p + o).collect();
    let back: Vec<DVec3> = samples.iter().zip(&offsets).map(|(&(p, _), &o)| p - o).collect();
    let (front, back) = (query.inside(&front), query.inside(&back));
    front.iter().zip(&back).zip(&offsets).map(|((&f, &b), o)| f && b && *o != DVec3::ZERO).collect()
}

/// Triangles whose points [`spread`] draws from one random stream.
pub(crate) const SPREAD_CHUNK: usize = 1 << 14;

/// `n` points spread by area over `query`'s triangles in its hierarchy's order, stratified:
/// the triangles laid end to end by area, a point at each of the areas `(offset + k) * A / n`
/// for `k` below `n`, where `A` is the whole area and `offset` is drawn uniform in [0, 1) from
/// `seed`, each point uniform on the triangle it falls in; the triangles' points in their
/// order. Each chunk of `SPREAD_CHUNK` triangles draws from its own stream of `seed`, so the
/// points do not depend on the number of threads. `None` where the triangles have no area, or
/// their area is not finite.
pub fn spread(query: &MeshQuery, n: usize, seed: u64) -> Option<Vec<DVec3>> {
    Some(spread_on(query, n, seed)?.into_iter().map(|(p, _)| p).collect())
}

/// [`spread`]'s points, each with the index of its triangle in `query.triangles()`.
fn spread_on(query: &MeshQuery, n: usize, seed: u64) -> Option<Vec<(DVec3, usize)>> {
    let triangles = query.triangles();
    // The area of the triangles before each one, and last the whole.
    let mut before = Vec::with_capacity(triangles.len() + 1);
    let mut whole = 0.0;
    before.push(whole);
    for &[a, b, c] in triangles {
        whole += (b - a).cross(c - a).length() / 2.0;
        before.push(whole);
    }
    if !(whole > 0.0 && whole.is_finite()) {
        return None;
    }
    let offset: f64 = ChaCha8Rng::seed_from_u64(seed).random();
    // The number of points before the area `a` (all n before the whole: whole / whole is 1).
    let points_before = |a: f64| ((a / whole * n as f64 - offset).ceil().max(0.0) as usize).min(n);
    let points =
        triangles.par_chunks(SPREAD_CHUNK).enumerate().flat_map_iter(|(chunk, corners)| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(chunk as u64 + 1);
            let mut points = Vec::new();
            for (t, corners) in (chunk * SPREAD_CHUNK..).zip(corners) {
                for _ in points_before(before[t])..points_before(before[t + 1]) {
                    points.push((on_triangle(corners, &mut rng), t));
                }
            }
            points
        });
    Some(points.collect())
}

/// `n` points on `mesh`'s triangles, each on a triangle drawn with probability proportional to
/// its area and uniform on it, in parallel blocks of 2^14 points, each
/// drawn from its own stream of `seed`; `None` where the triangles have no area (or their
/// indices are out of range, which the distance query refuses).
pub fn sample(mesh: &Mesh, n: usize, seed: u64) -> Option<Vec<DVec3>> {
    Some(sample_with_normals(mesh, n, seed)?.into_iter().map(|(p, _)| p).collect())
}

/// [`sample`]'s points (the same draws), each with its triangle's unit normal by the
/// right-hand rule of its corners (zero for a triangle without a normal).
pub(crate) fn sample_with_normals(mesh: &Mesh, n: usize, seed: u64) -> Option<Vec<(DVec3, DVec3)>> {
    let surface = ByArea::of(mesh)?;
    let blocks = n.div_ceil(BLOCK);
    let points = (0..blocks).into_par_iter().flat_map_iter(|block| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(block as u64);
        let count = BLOCK.min(n - block * BLOCK);
        (0..count).map(|_| surface.point_and_normal(&mut rng)).collect::<Vec<_>>()
    });
    Some(points.collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The percentile is interpolated between ranks as numpy's default: of 0..=1000 the
    /// 99.9th percentile is 999, of 0..=10 it is 9.99; the farthest sample is the one at the
    /// largest distance, wherever it stands.
    #[test]
    fn the_percentile_interpolates_between_ranks() {
        let mut values: Vec<f64> = (0..=1000).map(f64::from).collect();
        values.swap(0, 1000);
        let points: Vec<DVec3> = (0..=1000).map(|i| DVec3::new(f64::from(i), 0.0, 0.0)).collect();
        let s = DistanceSummary::of(&values, &points, 1.0);
        assert_eq!((s.max, s.p99_9, s.mean), (1000.0, 999.0, 500.0));
        assert_eq!(s.farthest, [0.0, 0.0, 0.0]);
        let values: Vec<f64> = (0..=10).map(f64::from).collect();
        let s = DistanceSummary::of(&values, &points[..11], 2.0);
        assert_eq!(s.farthest, [10.0, 0.0, 0.0]);
        assert!((s.p99_9 - 9.99 / 2.0).abs() < 1e-12, "{}", s.p99_9);
        assert_eq!(s.max, 5.0);
    }

    /// Two triangles of a unit square, one of area 1/2 as the other three times larger: the
    /// samples fall on each in proportion to its area, and on its plane inside its corners.
    #[test]
    fn samples_spread_by_area() {
        let mesh = Mesh {
            vertices: vec![
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                DVec3::new(0.0, 0.0, 5.0),
                DVec3::new(3.0, 0.0, 5.0),
                DVec3::new(0.0, 1.0, 5.0),
            ],
            triangles: vec![[0, 1, 2], [3, 4, 5]],
        };
        let points = sample(&mesh, 40_000, 7).unwrap();
        assert_eq!(points, sample(&mesh, 40_000, 7).unwrap(), "the same seed, the same points");
        let on_upper = |p: &&DVec3| (p.z - 5.0).abs() < 1e-12;
        let upper = points.iter().filter(on_upper).count();
        assert_eq!(points.iter().filter(|p| p.z == 0.0).count() + upper, points.len());
        let fraction = upper as f64 / points.len() as f64;
        assert!((fraction - 0.75).abs() < 0.01, "{fraction}");
        let outside = points.iter().filter(|p| {
            let scale = if on_upper(p) { 3.0 } else { 1.0 };
            p.x < 0.0 || p.y < 0.0 || p.x / scale + p.y > 1.0 + 1e-12
        });
        assert_eq!(outside.count(), 0);
        let degenerate = Mesh { vertices: vec![DVec3::ZERO, DVec3::X], triangles: vec![[0, 1, 1]] };
        assert!(sample(&degenerate, 10, 7).is_none());
    }

    /// A strip of triangles of areas 1 to 4 in turn: spread points land on each triangle its
    /// expected number of times to within one (where independent draws vary by the square
    /// root), uniform on it; all `n` of them, the same for the same seed, and none on a
    /// surface without area.
    #[test]
    fn spread_points_give_each_triangle_its_share() {
        let strips = 3000;
        let mut mesh = Mesh::default();
        for i in 0..strips {
            let (x, width) = (10.0 * i as f64, 1.0 + (i % 4) as f64);
            let base = mesh.vertices.len() as u32;
            let corners = [DVec3::new(x, 0.0, 0.0), DVec3::new(x + width, 0.0, 0.0)];
            mesh.vertices.extend(corners.into_iter().chain([DVec3::new(x, 2.0, 0.0)]));
            mesh.triangles.push([base, base + 1, base + 2]);
        }
        let query = MeshQuery::new(&mesh).unwrap();
        let whole: f64 = (0..strips).map(|i| 1.0 + (i % 4) as f64).sum();
        for (n, seed) in [(100_000, 1), (7_777, 2), (1_000, 3)] {
            let points = spread(&query, n, seed).unwrap();
            assert_eq!(points.len(), n);
            assert_eq!(points, spread(&query, n, seed).unwrap(), "the same seed, the same points");
            let mut counts = vec![0usize; strips];
            for p in &points {
                let i = (p.x / 10.0).floor() as usize;
                let width = 1.0 + (i % 4) as f64;
                let (u, v) = ((p.x - 10.0 * i as f64) / width, p.y / 2.0);
                assert!(p.z == 0.0 && u >= -1e-12 && v >= -1e-12 && u + v <= 1.0 + 1e-12, "{p}");
                counts[i] += 1;
            }
            for (i, &count) in counts.iter().enumerate() {
                let expected = n as f64 * (1.0 + (i % 4) as f64) / whole;
                assert!((count as f64 - expected).abs() < 1.0, "{count} for {expected}");
            }
        }
        let flat = Mesh { vertices: vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0], ..mesh };
        let flat = Mesh { triangles: vec![[0, 1, 2]], ..flat };
        assert!(spread(&MeshQuery::new(&flat).unwrap(), 10, 1).is_none());
    }
}
