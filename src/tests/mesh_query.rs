//! Exact distances from points to a mesh, checked against brute force over every triangle:
//! near the surface and far from it, on degenerate triangles, on vertices and edges; the
//! closest point against its triangle and barycentric coordinates; the sign; bad meshes.

use crate::tests::support::hostile::open_box;
use crate::tests::support::meshes::{merge, point_triangle_distance, sphere, torus};
use crate::tests::support::points::random_points;
use implicitize::mesh::Mesh;
use implicitize::mesh_query::{MeshQuery, Nearest};
use implicitize::voxelize::{VoxelizeOptions, voxelize};
use implicitize::{Aabb, DVec3, grid::Grid, grid::Resolution};
use proptest::prelude::*;

/// The distance from `p` to the segment `ab`.
fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let d = b - a;
    let t = if d.length_squared() > 0.0 { (p - a).dot(d) / d.length_squared() } else { 0.0 };
    p.distance(a + d * t.clamp(0.0, 1.0))
}

/// The distance from `p` to a triangle. Ericson's region test (test support's) can pick the
/// wrong region of a triangle whose area is rounding noise, so those are also measured as
/// their three segments, and a segment or point only as them.
fn triangle_distance(p: DVec3, [a, b, c]: [DVec3; 3]) -> f64 {
    let segments = [(a, b), (b, c), (c, a)]
        .iter()
        .map(|&(s, e)| segment_distance(p, s, e))
        .fold(f64::MAX, f64::min);
    let (ab, ac) = (b - a, c - a);
    let area2 = ab.cross(ac).length_squared();
    if area2 == 0.0 {
        segments
    } else if area2 < 1e-6 * ab.length_squared() * ac.length_squared() {
        segments.min(point_triangle_distance(p, [a, b, c]))
    } else {
        point_triangle_distance(p, [a, b, c])
    }
}

/// The distance from `p` to the mesh, triangle by triangle.
fn brute_force(mesh: &Mesh, p: DVec3) -> f64 {
    (0..mesh.triangles.len())
        .map(|t| triangle_distance(p, mesh.corners(t)))
        .fold(f64::MAX, f64::min)
}

/// Checks `found` for `p` against brute force (relative error below 1e-12, absolute on a mesh
/// of size about 1) and that its point is on its triangle, where its barycentrics put it.
fn check(mesh: &Mesh, p: DVec3, found: &Nearest) {
    let expected = brute_force(mesh, p);
    assert!(
        (found.distance - expected).abs() <= 1e-12 * expected.max(1.0),
        "at {p}: {} against brute force {expected}",
        found.distance
    );
    assert!((p.distance(found.point) - found.distance).abs() <= 1e-12 * expected.max(1.0));
    let corners = mesh.corners(found.triangle);
    let b = found.barycentric;
    assert!(b.iter().all(|&w| (0.0..=1.0).contains(&w)), "barycentrics {b:?}");
    assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-12, "barycentrics {b:?}");
    let rebuilt = corners[0] * b[0] + corners[1] * b[1] + corners[2] * b[2];
    assert!(rebuilt.distance(found.point) < 1e-12, "{rebuilt} against {}", found.point);
}

#[test]
fn a_torus_matches_brute_force_near_and_far() {
    let mesh = torus(1.0, 0.3, 48, 24);
    let distance = MeshQuery::new(&mesh).unwrap();
    let bounds = mesh.bounds().unwrap();
    let mut points = random_points(&bounds, 0.1, 2000, 1);
    points.extend(random_points(&bounds, 50.0, 500, 2));
    points.extend([DVec3::new(1e6, -3e5, 2e7), DVec3::ZERO, DVec3::new(0.0, 0.0, 0.3)]);
    // Right next to the surface: the vertices nudged along random directions by 1e-6.
    let nudges =
        random_points(&Aabb { min: DVec3::splat(-1e-6), max: DVec3::splat(1e-6) }, 0.0, 500, 3);
    points.extend(mesh.vertices.iter().zip(&nudges).map(|(&v, &d)| v + d));
    let found = distance.nearest_all(&points);
    assert_eq!(found.len(), points.len());
    for (&p, found) in points.iter().zip(&found) {
        check(&mesh, p, found);
        // Searched in another order, from another first candidate: the same distance (the
        // triangle may differ where several are equally near).
        let alone = distance.nearest(p).distance;
        assert!((found.distance - alone).abs() <= 1e-12 * alone.max(1.0), "{found:?} {alone}");
    }
}

#[test]
fn vertices_and_edges_are_at_distance_zero() {
    let mesh = sphere(DVec3::new(3.0, -2.0, 1.0), 2.0, 12, 24);
    let distance = MeshQuery::new(&mesh).unwrap();
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(t);
        for p in [a, b, c, (a + b) * 0.5, (b + c) * 0.5, a * 0.25 + c * 0.75, (a + b + c) / 3.0] {
            let found = distance.nearest(p);
            assert!(found.distance < 1e-14, "{p}: {}", found.distance);
            check(&mesh, p, &found);
        }
    }
}

#[test]
fn a_single_triangle_has_every_region_right() {
    let mesh = Mesh {
        vertices: vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ],
        triangles: vec![[0, 1, 2]],
    };
    let distance = MeshQuery::new(&mesh).unwrap();
    let cases = [
        (DVec3::new(-1.0, -1.0, 0.0), DVec3::ZERO, [1.0, 0.0, 0.0]),
        (DVec3::new(3.0, 0.0, 1.0), DVec3::new(2.0, 0.0, 0.0), [0.0, 1.0, 0.0]),
        (DVec3::new(0.0, 2.0, -1.0), DVec3::new(0.0, 1.0, 0.0), [0.0, 0.0, 1.0]),
        (DVec3::new(1.0, -1.0, 0.0), DVec3::new(1.0, 0.0, 0.0), [0.5, 0.5, 0.0]),
        (DVec3::new(-1.0, 0.5, 0.0), DVec3::new(0.0, 0.5, 0.0), [0.5, 0.0, 0.5]),
        (DVec3::new(0.5, 0.25, 4.0), DVec3::new(0.5, 0.25, 0.0), [0.5, 0.25, 0.25]),
    ];
    for (p, point, barycentric) in cases {
        let found = distance.nearest(p);
        assert_eq!((found.point, found.triangle), (point, 0), "{p}");
        for (got, want) in found.barycentric.iter().zip(barycentric) {
            assert!((got - want).abs() < 1e-15, "{p}: {:?}", found.barycentric);
        }
        check(&mesh, p, &found);
    }
}

#[test]
fn degenerate_triangles_are_measured_as_segments_and_points() {
    let v = |x, y, z| DVec3::new(x, y, z);
    let mesh = Mesh {
        vertices: vec![
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(3.0, 0.0, 0.0),
            v(0.0, 2.0, 0.0),
            v(5.0, 5.0, 5.0),
            v(0.0, 0.0, 1.0),
            v(1.0, 1e-7, 1.0),
            v(2.0, 0.0, 1.0),
            v(4.0, 4.0, 4.0),
            v(4.0, 4.0, 4.0),
        ],
        triangles: vec![
            [0, 1, 2], // collinear, the middle corner first
            [1, 2, 0], // the same, turned
            [3, 3, 3], // a point
            [4, 4, 3], // a segment with a repeated corner
            [5, 6, 7], // a sliver
            [8, 9, 4], // duplicated vertices at one position
        ],
    };
    let distance = MeshQuery::new(&mesh).unwrap();
    let bounds = mesh.bounds().unwrap();
    let mut points = random_points(&bounds, 1.0, 3000, 4);
    points.extend(mesh.vertices.iter().copied());
    points.extend([v(2.0, 0.0, 0.0), v(1.0, 5e-8, 1.0), v(1.0, 5e-8, 1.5), v(2.0, 1.0, 0.0)]);
    for (&p, found) in points.iter().zip(&distance.nearest_all(&points)) {
        assert!(found.distance.is_finite());
        check(&mesh, p, found);
    }
}

#[test]
fn signs_are_positive_inside_and_negative_outside() {
    let ball = sphere(DVec3::new(1.0, 2.0, 3.0), 2.0, 24, 48);
    let distance = MeshQuery::new(&ball).unwrap();
    let points = [
        DVec3::new(1.0, 2.0, 3.0),
        DVec3::new(2.0, 2.5, 3.0),
        DVec3::new(4.0, 2.0, 3.0),
        DVec3::new(-9.0, 0.0, 0.0),
    ];
    let signed = distance.signed(&points);
    assert!(signed[0] > 1.9 && signed[1] > 0.5, "{signed:?}");
    assert!(signed[2] < -0.9 && signed[3] < -8.0, "{signed:?}");
    for (s, &p) in signed.iter().zip(&points) {
        assert_eq!(s.abs(), distance.nearest(p).distance);
    }

    // Flipped, wholly or in part, the sphere keeps its inside: the winding number reads the
    // triangles re-oriented as the voxelizer re-orients them.
    let mut flipped = ball.clone();
    for t in flipped.triangles.iter_mut().step_by(3) {
        t.swap(1, 2);
    }
    let mut inverted = ball.clone();
    inverted.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    for mesh in [flipped, inverted] {
        let again = MeshQuery::new(&mesh).unwrap().signed(&points);
        for (a, b) in again.iter().zip(&signed) {
            assert!((a - b).abs() < 1e-12, "{again:?} against {signed:?}");
        }
    }

    let ring = torus(1.0, 0.3, 48, 24);
    let distance = MeshQuery::new(&ring).unwrap();
    let signed = distance.signed(&[
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, -1.1, 0.1),
        DVec3::ZERO,
        DVec3::new(0.0, 1.0, 0.5),
    ]);
    assert!(signed[0] > 0.25 && signed[1] > 0.1, "{signed:?}");
    assert!(signed[2] < -0.6 && signed[3] < -0.1, "{signed:?}");
}

#[test]
fn an_open_hemisphere_gives_finite_distances() {
    let mut bowl = sphere(DVec3::ZERO, 1.0, 16, 32);
    bowl.triangles.retain(|t| t.iter().all(|&i| bowl.vertices[i as usize].z <= 1e-9));
    let distance = MeshQuery::new(&bowl).unwrap();
    let points = random_points(&bowl.bounds().unwrap(), 0.5, 500, 5);
    let signed = distance.signed(&points);
    for ((&p, s), found) in points.iter().zip(&signed).zip(distance.nearest_all(&points)) {
        assert!(s.is_finite());
        assert_eq!(s.abs(), found.distance);
        check(&bowl, p, &found);
    }
    // Deep in the bowl the soap film over its rim closes it; above the rim is outside.
    let signed = distance.signed(&[DVec3::new(0.0, 0.0, -0.5), DVec3::new(0.0, 0.0, 0.5)]);
    assert!(signed[0] > 0.0 && signed[1] < 0.0, "{signed:?}");
}

/// The inside is the voxelizer's at its voxel centres (rays along the three axes, the winding
/// number where they disagree), on a mesh of closed, overlapping, partly flipped and open parts.
#[test]
fn the_inside_is_the_voxelizers_at_voxel_centres() {
    let mut ring = torus(1.0, 0.35, 24, 12);
    for t in ring.triangles.iter_mut().step_by(5) {
        t.swap(1, 2);
    }
    let parts = merge(&ring, &sphere(DVec3::new(1.0, 0.0, 0.2), 0.4, 10, 16));
    let mut bowl = sphere(DVec3::new(-1.2, 0.9, 0.1), 0.6, 12, 24);
    bowl.triangles.retain(|t| t.iter().all(|&i| bowl.vertices[i as usize].z <= 0.35));
    let lidless = open_box(DVec3::new(1.1, 1.0, -0.4), DVec3::new(0.5, 0.6, 0.7), |f| f != 5);
    let mesh = merge(&merge(&parts, &bowl), &lidless);
    let grid = Grid::around(&mesh.bounds().unwrap(), Resolution::LongestAxis(40)).unwrap();
    let options = VoxelizeOptions::default().with_supersampling(1);
    let voxelized = voxelize(&mesh, &grid, &options).unwrap();
    assert!(voxelized.inside.winding_decided > 0.0, "the winding number decided nothing");
    let centres: Vec<DVec3> = (0..grid.len()).map(|i| grid.position(grid.voxel(i))).collect();
    let inside = MeshQuery::new(&mesh).unwrap().inside(&centres);
    let differ =
        (inside.iter().zip(&voxelized.density.data)).filter(|&(&i, &d)| i != (d > 0.5)).count();
    let count = inside.iter().filter(|&&i| i).count();
    assert!(count > grid.len() / 20, "{count} of {} voxels inside", grid.len());
    assert_eq!(differ, 0, "{differ} of {} voxel centres differ from the voxelizer", grid.len());
}

#[test]
fn bad_meshes_are_refused() {
    let triangle = |vertices: Vec<DVec3>, triangles: Vec<[u32; 3]>| Mesh { vertices, triangles };
    let message = |mesh: Mesh| MeshQuery::new(&mesh).unwrap_err().to_string();
    let corners = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
    assert_eq!(
        message(triangle(corners.clone(), vec![])),
        "mesh: no triangles to measure a distance to"
    );
    assert_eq!(
        message(triangle(corners.clone(), vec![[0, 1, 3]])),
        "mesh: triangle 0 uses vertex 3, out of range for 3 vertices"
    );
    let mut nan = corners.clone();
    nan[2].y = f64::NAN;
    assert!(
        message(triangle(nan, vec![[0, 1, 2]]))
            .starts_with("mesh: vertex 2 (of triangle 0) has a non-finite coordinate")
    );
    // An unused vertex may be anything.
    let mut unused = corners;
    unused.push(DVec3::INFINITY);
    assert!(MeshQuery::new(&triangle(unused, vec![[0, 1, 2]])).is_ok());
}

#[test]
fn a_non_finite_query_gives_nan_not_a_panic() {
    let distance = MeshQuery::new(&torus(1.0, 0.3, 12, 8)).unwrap();
    assert!(distance.nearest(DVec3::new(f64::NAN, 0.0, 0.0)).distance.is_nan());
    assert!(
        distance.signed(&[DVec3::INFINITY])[0].is_nan()
            || distance.signed(&[DVec3::INFINITY])[0].is_infinite()
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Random triangle soups (some corners shared, so degenerate triangles come up) and random
    /// queries: the hierarchy's answer is brute force's.
    #[test]
    fn random_soups_match_brute_force(
        vertices in proptest::collection::vec((-4i32..4, -4i32..4, -4i32..4), 1..12),
        triangles in proptest::collection::vec((0u32..12, 0u32..12, 0u32..12), 1..40),
        queries in proptest::collection::vec((-20.0f64..20.0, -20.0f64..20.0, -20.0f64..20.0), 1..20),
    ) {
        let vertices: Vec<DVec3> =
            vertices.iter().map(|&(x, y, z)| DVec3::new(x as f64, y as f64, z as f64) * 0.5).collect();
        let n = vertices.len() as u32;
        let triangles = triangles.iter().map(|&(a, b, c)| [a % n, b % n, c % n]).collect();
        let mesh = Mesh { vertices, triangles };
        let distance = MeshQuery::new(&mesh).unwrap();
        for (x, y, z) in queries {
            let p = DVec3::new(x, y, z);
            check(&mesh, p, &distance.nearest(p));
        }
    }
}

#[test]
fn the_distance_job_signs_checks_points_and_memory() {
    use implicitize::memory::MemoryLimit;
    use implicitize::pipeline::{self, DistanceOptions};

    let ball = sphere(DVec3::ZERO, 1.0, 32, 64);
    let points = [DVec3::ZERO, DVec3::new(0.0, 0.0, 3.0), DVec3::new(-2.0, 0.0, 0.0)];
    let mut options = DistanceOptions::default();
    let found = pipeline::distance(&ball, "ball.obj", &points, &options).unwrap();
    let distance = MeshQuery::new(&ball).unwrap();
    assert_eq!(found.values, distance.signed(&points));
    assert_eq!(found.nearest, distance.nearest_all(&points));
    // A pole is a vertex: exactly 2 away. The centre is within the tessellation's sag of 1.
    assert_eq!(found.values[1], -2.0);
    assert!(found.values[0] > 0.99 && found.values[0] <= 1.0, "{:?}", found.values);
    assert!(found.values[2] <= -1.0 && found.values[2] > -1.01, "{:?}", found.values);

    options.signed = false;
    let unsigned = pipeline::distance(&ball, "ball.obj", &points, &options).unwrap();
    assert_eq!(unsigned.values, found.values.iter().map(|v| v.abs()).collect::<Vec<_>>());

    let nan = pipeline::distance(&ball, "ball.obj", &[DVec3::new(0.0, f64::NAN, 0.0)], &options);
    assert_eq!(
        nan.unwrap_err().to_string(),
        "ball.obj: point 0 has a non-finite coordinate: [0, NaN, 0]"
    );
    options.memory_limit = MemoryLimit::Bytes(1 << 20);
    let refused = pipeline::distance(&ball, "ball.obj", &points, &options).unwrap_err().to_string();
    assert!(refused.contains("exceeds the memory limit of 1.0 MB"), "{refused}");
    let empty = Mesh { vertices: ball.vertices.clone(), triangles: vec![] };
    let refused = pipeline::distance(&empty, "empty.obj", &points, &DistanceOptions::default());
    assert_eq!(
        refused.unwrap_err().to_string(),
        "empty.obj: mesh: no triangles to measure a distance to"
    );
}
