//! Samples of a mesh's signed distance (`pipeline::sample`): counts, the spread of the near
//! points, the uniform box, signs, DeepSDF's layout, determinism and refusals.

use crate::tests::support::hostile::{cube, open_box};
use crate::tests::support::meshes::{merge, sphere};
use implicitize::memory::MemoryLimit;
use implicitize::mesh_query::MeshQuery;
use implicitize::pipeline::{self, SampleOptions};
use implicitize::sample::{self, Samples};
use implicitize::{DVec3, Error, mesh::Mesh};

fn options(near_surface: &[f64], uniform: f64, seed: u64) -> SampleOptions {
    let mut options = SampleOptions::default();
    options.near_surface = near_surface.to_vec();
    options.uniform = uniform;
    options.seed = seed;
    options
}

fn draw(mesh: &Mesh, n: usize, options: &SampleOptions) -> Samples {
    pipeline::sample(mesh, "test mesh", n, options).unwrap()
}

fn diagonal(mesh: &Mesh) -> f64 {
    let bounds = mesh.bounds().unwrap();
    (bounds.max - bounds.min).length()
}

/// A triangle of side `size` with a corner at `at` and twice the area for `double`.
fn tiny_triangle(at: DVec3, size: f64, double: bool) -> Mesh {
    let stretch = if double { 2.0 } else { 1.0 };
    Mesh {
        vertices: vec![at, at + DVec3::X * size * stretch, at + DVec3::Y * size],
        triangles: vec![[0, 1, 2]],
    }
}

#[test]
fn the_counts_are_exact() {
    let mesh = sphere(DVec3::ZERO, 1.0, 12, 24);
    for (n, near, uniform, expected_near, expected_uniform) in [
        (1000, vec![0.005, 0.0005], 0.2, vec![400, 400], 200),
        (1001, vec![0.005, 0.0005], 0.2, vec![401, 400], 200),
        (7, vec![0.01, 0.02, 0.03], 0.5, vec![1, 1, 1], 4),
        (10, vec![0.01], 0.0, vec![10], 0),
        (10, vec![0.01], 1.0, vec![0], 10),
        (3, vec![], 1.0, vec![], 3),
    ] {
        let options = options(&near, uniform, 1);
        assert_eq!(sample::counts(n, &options), (expected_near.clone(), expected_uniform));
        let samples = draw(&mesh, n, &options);
        assert_eq!((samples.points.len(), samples.sdf.len()), (n, n));
        assert_eq!((samples.near, samples.uniform), (expected_near, expected_uniform));
    }
}

/// Two triangles of side 3e-5, the second twice the area of the first, 2.3 apart: each near
/// point is its triangle's corner plus the noise, within the triangles' size, so the noise is
/// measured in each coordinate. With m = 25,000 points a standard deviation, the measured standard deviation
/// of a coordinate is within 5 standard errors (sigma / sqrt(2 m), 0.45%) of sigma, so 2.5%;
/// its mean within 5 sigma / sqrt(m) of 0; the share of the larger triangle within 5 binomial
/// standard errors (0.3%) of 2/3.
#[test]
fn the_near_points_spread_as_asked_in_every_direction() {
    let size = 3e-5;
    let far = DVec3::new(1.0, 2.0, 0.5);
    let mesh = merge(&tiny_triangle(DVec3::ZERO, size, false), &tiny_triangle(far, size, true));
    let sigmas = [0.01, 0.002];
    let m = 25_000;
    let samples = draw(&mesh, 2 * m, &options(&sigmas, 0.0, 3));
    let diagonal = diagonal(&mesh);
    let mut on_larger = 0;
    for (group, &sigma) in sigmas.iter().enumerate() {
        let points = &samples.points[group * m..(group + 1) * m];
        let displacements: Vec<DVec3> = points
            .iter()
            .map(|&p| {
                let larger = p.distance(far) < p.length();
                on_larger += usize::from(larger);
                p - if larger { far } else { DVec3::ZERO }
            })
            .collect();
        let expected = sigma * diagonal;
        for axis in 0..3 {
            let values: Vec<f64> = displacements.iter().map(|d| d[axis]).collect();
            let mean = values.iter().sum::<f64>() / m as f64;
            let std = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m as f64).sqrt();
            assert!((std / expected - 1.0).abs() < 0.025, "sigma {sigma}, axis {axis}: {std}");
            assert!(mean.abs() < 5.0 * expected / (m as f64).sqrt(), "axis {axis}: {mean}");
        }
    }
    let share = on_larger as f64 / (2 * m) as f64;
    assert!((share - 2.0 / 3.0).abs() < 0.01, "share of the larger triangle: {share}");
    // Open triangles enclose nothing: every point is outside, at its distance from them.
    for (p, &s) in samples.points.iter().zip(&samples.sdf) {
        let from = if p.distance(far) < p.length() { p.distance(far) } else { p.length() };
        assert!(s < 0.0 && (-s - from).abs() <= 3.0 * size, "{p}: {s} against {from}");
    }
}

/// On a sphere of radius 1, the distances of the near points spread as their noise does along
/// the normal: their standard deviation is sigma times the diagonal, to the curvature's
/// (sigma / radius)^2 and 5 standard errors (sigma / sqrt(2 m), 0.7% for 10,000 points), so
/// 4%; and about half are inside (within the curvature's bias, 0.4 sigma / radius, and 5
/// binomial standard errors: 0.05).
#[test]
fn near_points_on_a_sphere_straddle_its_surface() {
    let mesh = sphere(DVec3::ZERO, 1.0, 64, 128);
    let sigmas = [0.005, 0.001];
    let m = 10_000;
    let samples = draw(&mesh, 2 * m, &options(&sigmas, 0.0, 5));
    for (group, &sigma) in sigmas.iter().enumerate() {
        let sdf = &samples.sdf[group * m..(group + 1) * m];
        let rms = (sdf.iter().map(|s| s * s).sum::<f64>() / m as f64).sqrt();
        let expected = sigma * diagonal(&mesh);
        assert!((rms / expected - 1.0).abs() < 0.04, "sigma {sigma}: {rms} against {expected}");
        let inside = sdf.iter().filter(|&&s| s > 0.0).count() as f64 / m as f64;
        assert!((inside - 0.5).abs() < 0.05, "sigma {sigma}: {inside} inside");
    }
}

/// The uniform points fill the box grown by 10% on every side: all in it, reaching within 1%
/// of each face, and the share inside the mesh's own box (1 / 1.2^3 = 0.579) within 5
/// binomial standard errors (1.7% for 20,000 points).
#[test]
fn uniform_points_fill_the_padded_box() {
    let mesh = open_box(DVec3::new(-1.0, 0.0, 2.0), DVec3::new(2.0, 1.0, 0.5), |f| f != 0);
    let samples = draw(&mesh, 20_000, &options(&[0.01], 1.0, 9));
    let bounds = mesh.bounds().unwrap();
    let room = sample::padded(&bounds);
    let size = bounds.max - bounds.min;
    assert_eq!(room.min, bounds.min - size * 0.1);
    assert_eq!(room.max, bounds.max + size * 0.1);
    let mut low = DVec3::INFINITY;
    let mut high = DVec3::NEG_INFINITY;
    let mut within = 0;
    for &p in &samples.points {
        assert!(p.cmpge(room.min).all() && p.cmple(room.max).all(), "{p} outside the box");
        (low, high) = (low.min(p), high.max(p));
        within += usize::from(p.cmpge(bounds.min).all() && p.cmple(bounds.max).all());
    }
    assert!((low - room.min).max_element() < 0.01 * size.max_element());
    assert!((room.max - high).max_element() < 0.01 * size.max_element());
    let share = within as f64 / samples.points.len() as f64;
    assert!((share - 1.0 / 1.2f64.powi(3)).abs() < 0.017, "{share} inside the mesh's box");
}

/// The distances are the distance query's, signs included, on a closed cube and on a box
/// without its floor (where the winding number closes the hole).
#[test]
fn the_signs_are_the_distance_querys() {
    let open = open_box(DVec3::ZERO, DVec3::new(1.0, 2.0, 1.5), |f| f != 0);
    for mesh in [cube(DVec3::splat(-1.0), 2.0), open] {
        let samples = draw(&mesh, 5000, &SampleOptions::default());
        let query = MeshQuery::new(&mesh).unwrap();
        assert_eq!(samples.sdf, query.signed(&samples.points));
        let inside = samples.sdf.iter().filter(|&&s| s > 0.0).count();
        assert!(inside > 1000 && inside < 4000, "{inside} inside");
    }
}

/// `pos` holds the points outside (DeepSDF's value above 0), `neg` the rest, with DeepSDF's
/// sign: the negated distance, as float32.
#[test]
fn deepsdfs_layout_is_split_by_its_sign() {
    let mesh = sphere(DVec3::ZERO, 1.0, 12, 24);
    let samples = draw(&mesh, 3000, &SampleOptions::default());
    let (pos, neg) = samples.deepsdf();
    let outside = samples.sdf.iter().filter(|&&s| (-s as f32) > 0.0).count();
    assert_eq!((pos.len(), neg.len()), (outside, 3000 - outside));
    assert!(pos.iter().all(|r| r[3] > 0.0) && neg.iter().all(|r| r[3] <= 0.0));
    let (mut p, mut q) = (pos.iter(), neg.iter());
    for (point, &s) in samples.points.iter().zip(&samples.sdf) {
        let row = if (-s as f32) > 0.0 { p.next() } else { q.next() }.unwrap();
        assert_eq!(*row, [point.x as f32, point.y as f32, point.z as f32, -s as f32]);
    }
}

#[test]
fn the_same_seed_gives_the_same_samples_on_any_number_of_threads() {
    let mesh = sphere(DVec3::ZERO, 1.0, 12, 24);
    // Three blocks of 2^14 points (each its own random stream) and a part of a fourth.
    let n = 3 * (1 << 14) + 17;
    let first = draw(&mesh, n, &options(&[0.01, 0.001], 0.3, 11));
    let one_thread = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let again = one_thread.install(|| draw(&mesh, n, &options(&[0.01, 0.001], 0.3, 11)));
    assert_eq!(first, again);
    let other = draw(&mesh, n, &options(&[0.01, 0.001], 0.3, 12));
    let same = first.points.iter().zip(&other.points).filter(|(a, b)| a == b).count();
    assert_eq!(same, 0, "another seed draws other points");
}

#[test]
fn bad_options_are_refused_naming_them() {
    let mesh = sphere(DVec3::ZERO, 1.0, 8, 8);
    for (near, uniform, said) in [
        (vec![-0.01], 0.2, "near_surface"),
        (vec![0.0], 0.2, "near_surface"),
        (vec![f64::NAN], 0.2, "near_surface"),
        (vec![0.01, f64::INFINITY], 0.2, "near_surface"),
        (vec![0.01], -0.1, "uniform"),
        (vec![0.01], 1.5, "uniform"),
        (vec![0.01], f64::NAN, "uniform"),
        (vec![], 0.5, "near_surface"),
    ] {
        let options = options(&near, uniform, 1);
        let error = pipeline::sample(&mesh, "m.obj", 100, &options).unwrap_err().to_string();
        assert!(error.contains(said), "{near:?}, {uniform}: {error}");
        assert!(options.check().is_err());
    }
    let error = pipeline::sample(&mesh, "m.obj", 0, &SampleOptions::default()).unwrap_err();
    assert!(error.to_string().contains("number of points must be at least 1"), "{error}");
    let flat =
        Mesh { vertices: vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0], triangles: vec![[0, 1, 2]] };
    let error = pipeline::sample(&flat, "line.obj", 10, &SampleOptions::default()).unwrap_err();
    let error = error.to_string();
    assert!(error.contains("line.obj") && error.contains("no area"), "{error}");
    let mut small = SampleOptions::default();
    small.memory_limit = MemoryLimit::Bytes(1 << 20);
    let refused = pipeline::sample(&mesh, "m.obj", 1_000_000, &small).unwrap_err();
    assert!(matches!(refused, Error::Memory { .. }), "{refused}");
}
