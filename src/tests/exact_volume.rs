//! The exact signed distance at the voxel centres (`sdf --exact`, [`VolumeKind::ExactSignedDistance`]):
//! values against brute force over every triangle and against the query's own answer, the
//! sign against the voxelization's inside, the band's clamping and that no voxel within the
//! band is missed, analytic boxes and spheres, and the options' and memory's refusals.

use crate::tests::support::hostile::{cube, open_box};
use crate::tests::support::meshes::{merge, point_triangle_distance, sphere, torus};
use implicitize::grid::Volume;
use implicitize::grid::{Grid, Resolution};
use implicitize::memory::{Estimate, MemoryLimit};
use implicitize::mesh::Mesh;
use implicitize::mesh_query::MeshQuery;
use implicitize::pipeline::{self, VolumeKind, VolumeOptions};
use implicitize::{DVec3, Error};

fn options(resolution: usize, band: Option<f64>) -> VolumeOptions {
    let mut options = VolumeOptions::default();
    options.resolution = Resolution::LongestAxis(resolution);
    options.band = band;
    options
}

fn volume(mesh: &Mesh, kind: VolumeKind, options: &VolumeOptions) -> Volume<f32> {
    pipeline::volume(mesh, "the mesh", kind, options).unwrap().0
}

fn exact(mesh: &Mesh, resolution: usize, band: Option<f64>) -> Volume<f32> {
    volume(mesh, VolumeKind::ExactSignedDistance, &options(resolution, band))
}

/// A torus and a sphere that pokes through it: two closed parts, overlapping.
fn torus_and_ball() -> Mesh {
    merge(&torus(1.0, 0.35, 24, 12), &sphere(DVec3::new(1.0, 0.0, 0.2), 0.4, 10, 16))
}

#[test]
fn every_voxel_is_the_brute_force_distance_rounded_to_f32() {
    let mesh = torus_and_ball();
    let sd = exact(&mesh, 28, None);
    let query = MeshQuery::new(&mesh).unwrap();
    for (index, &value) in sd.data.iter().enumerate() {
        let p = sd.grid.position(sd.grid.voxel(index));
        let brute = (0..mesh.triangles.len())
            .map(|t| point_triangle_distance(p, mesh.corners(t)))
            .fold(f64::MAX, f64::min);
        // Exact in f64 (relative 1e-12 against brute force), then rounded to f32 (half an ulp).
        let size = f64::from(value.abs());
        assert!(
            (size - brute).abs() <= brute * (1e-12 + f64::from(f32::EPSILON) / 2.0),
            "voxel {index} at {p}: {value} against brute force {brute}"
        );
        assert_eq!(value.abs(), query.nearest(p).distance as f32, "voxel {index}");
    }
}

#[test]
fn the_sign_is_the_voxelizations_inside() {
    let mesh =
        merge(&torus_and_ball(), &open_box(DVec3::splat(1.6), DVec3::splat(0.5), |f| f != 2));
    let options = options(32, None);
    let sd = volume(&mesh, VolumeKind::ExactSignedDistance, &options);
    let density = volume(&mesh, VolumeKind::Density, &options);
    let voxel_sd = volume(&mesh, VolumeKind::SignedDistance, &options);
    assert_eq!(sd.grid, density.grid);
    let inside = density.data.iter().filter(|&&d| d > 0.5).count();
    assert!(inside > 500, "{inside} voxels inside");
    for ((value, density), voxel) in sd.data.iter().zip(&density.data).zip(&voxel_sd.data) {
        assert_eq!(value.is_sign_positive(), *density > 0.5, "{value} at density {density}");
        assert_eq!(value.is_sign_positive(), *voxel > 0.0, "{value} against {voxel} voxels");
    }
}

#[test]
fn a_band_clamps_the_unbanded_volume_and_misses_no_voxel_within_it() {
    let mesh = torus_and_ball();
    let full = exact(&mesh, 36, None);
    let h = full.grid.voxel_size;
    for band in [0.3, 1.0, 2.5, 3.0] {
        let banded = exact(&mesh, 36, Some(band));
        assert_eq!(banded.grid, full.grid);
        let limit = (band * h) as f32;
        let (mut within, mut clamped) = (0, 0);
        for (index, (&b, &f)) in banded.data.iter().zip(&full.data).enumerate() {
            // Bit for bit: the exact value within the band, the band's edge with its sign beyond.
            assert_eq!(b.to_bits(), f.clamp(-limit, limit).to_bits(), "band {band}, voxel {index}");
            if f.abs() <= limit { within += 1 } else { clamped += 1 }
        }
        assert!(within > 100 && clamped > 1000, "band {band}: {within} within, {clamped} beyond");
    }
}

#[test]
fn a_box_and_a_sphere_give_their_analytic_distances() {
    let (min, size) = (DVec3::new(-0.3, 0.2, 1.0), 1.7);
    let sd = exact(&cube(min, size), 30, None);
    let centre = min + DVec3::splat(size / 2.0);
    let h = sd.grid.voxel_size;
    for (index, &value) in sd.data.iter().enumerate() {
        let q = (sd.grid.position(sd.grid.voxel(index)) - centre).abs() - DVec3::splat(size / 2.0);
        let outside = q.max(DVec3::ZERO).length();
        let analytic = if outside > 0.0 { -outside } else { -q.max_element() };
        let error = (f64::from(value).abs() - analytic.abs()).abs();
        assert!(
            error <= 1e-12 + analytic.abs() * 1e-7,
            "voxel {index}: {value} against {analytic}"
        );
        if analytic.abs() >= h {
            assert_eq!(value.is_sign_positive(), analytic > 0.0, "voxel {index}");
        }
    }

    // A UV sphere of radius r lies between r and its faces' inscribed distance r cos(θ/2)
    // (θ the largest angle between adjacent vertices), so the distance to it is within
    // r (1 - cos(θ/2)) of the round sphere's.
    let (c, r, rings, segments) = (DVec3::new(2.0, -1.0, 0.5), 0.8, 48, 96);
    let sd = exact(&sphere(c, r, rings, segments), 32, None);
    let theta = std::f64::consts::PI / f64::from(rings);
    let sagitta = r * (1.0 - (theta / 2.0).cos()) * 2.0;
    let h = sd.grid.voxel_size;
    for (index, &value) in sd.data.iter().enumerate() {
        let analytic = r - sd.grid.position(sd.grid.voxel(index)).distance(c);
        let error = (f64::from(value) - analytic).abs();
        if analytic.abs() >= h {
            assert!(error <= sagitta + 1e-6, "voxel {index}: {value} against {analytic}");
        } else {
            assert!((f64::from(value).abs() - analytic.abs()).abs() <= sagitta + 1e-6);
        }
    }
}

#[test]
fn bad_bands_and_a_small_memory_limit_are_refused() {
    let mesh = torus_and_ball();
    let refusal = |kind, options: &VolumeOptions| {
        pipeline::volume(&mesh, "ring.obj", kind, options).unwrap_err()
    };
    for band in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let message =
            refusal(VolumeKind::ExactSignedDistance, &options(20, Some(band))).to_string();
        assert!(message.starts_with("ring.obj") && message.contains("`band` must be a positive"));
    }
    for kind in [VolumeKind::Density, VolumeKind::SignedDistance] {
        let message = refusal(kind, &options(20, Some(2.0))).to_string();
        assert!(message.contains("`band` applies only to the exact"), "{message}");
    }
    // The query's bytes per triangle join the volume's estimate, checked before any work.
    let triangles = mesh.triangles.len();
    let grid = Grid::around(&mesh.bounds().unwrap(), Resolution::LongestAxis(200)).unwrap();
    let need = Estimate::exact_volume(grid.dims, triangles);
    let query_bytes = need.bytes - Estimate::volume(grid.dims, triangles).bytes;
    assert!(query_bytes > 0 && query_bytes.is_multiple_of(triangles as u64), "{query_bytes}");
    let mut small = options(200, None);
    small.memory_limit = MemoryLimit::Bytes(need.bytes - 1);
    let error = refusal(VolumeKind::ExactSignedDistance, &small);
    assert!(matches!(error, Error::Memory { .. }), "{error}");
    assert!(error.to_string().contains("a grid of 200 x"), "{error}");
}

#[test]
fn degenerate_and_duplicated_triangles_give_the_querys_own_distances() {
    let mut mesh = crate::tests::support::hostile::duplicated_and_zero_area();
    // A sliver: a triangle whose area is lost to rounding against its edges' lengths.
    let n = mesh.vertices.len() as u32;
    mesh.vertices.extend([
        DVec3::new(0.2, 0.5, 1.3),
        DVec3::new(0.9, 0.5, 1.3),
        DVec3::new(0.55, 0.5 + 1e-9, 1.3),
    ]);
    mesh.triangles.push([n, n + 1, n + 2]);
    let query = MeshQuery::new(&mesh).unwrap();
    for band in [None, Some(2.0)] {
        let sd = exact(&mesh, 24, band);
        let limit = band.map_or(f64::INFINITY, |k| k * sd.grid.voxel_size);
        for (index, &value) in sd.data.iter().enumerate() {
            let p = sd.grid.position(sd.grid.voxel(index));
            let expected = query.nearest(p).distance.min(limit) as f32;
            assert_eq!(value.abs(), expected, "voxel {index}, band {band:?}");
        }
    }
}
