//! Polygonization speed: the signed distance of a few tori and spheres on a 176 x 220 x 218
//! grid (the size of the bunny's volume), an analytic field sampled and refined, and a fitted
//! bunny (the 700 constraints of tests/data) at 256 voxels along its longest axis, polygonized
//! by surface following and by evaluating the whole grid.
//!
//! `cargo bench --bench polygonize` runs the criterion benchmarks. Two environment variables
//! turn the binary into the helper of `scripts/bench-polygonize.sh` instead:
//! - `POLYGONIZE_WRITE_SHAPES=out.npy` writes the shapes volume (float32, `[i, j, k]`) and exits;
//! - `POLYGONIZE_TIME=volume.npy` reads a float32 volume, times `polygonize` at level 0 (best of
//!   `POLYGONIZE_REPEAT`, default 5) and prints `seconds triangles vertices` on one line.

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use criterion::{Criterion, criterion_group};
use implicitize::grid::Values;
use implicitize::polygonize::polygonize_field_dense;
use implicitize::{
    DVec3, Field, grid::Grid, grid::Resolution, grid::Volume, polygonize::polygonize,
    polygonize::polygonize_field,
};
use implicitize_test_support::data::bunny;

/// The bunny volume's size in the paper-scale runs.
const DIMS: [usize; 3] = [176, 220, 218];

/// Signed distance (voxels, inside positive) to a few tori and spheres filling the grid.
fn shapes_distance(p: DVec3) -> f64 {
    // A torus around z, or around x when `around_x`.
    let torus = |c: DVec3, major: f64, minor: f64, around_x: bool| {
        let q = p - c;
        let q = if around_x { DVec3::new(q.y, q.z, q.x) } else { q };
        let a = (q.x * q.x + q.y * q.y).sqrt() - major;
        minor - (a * a + q.z * q.z).sqrt()
    };
    let sphere = |c: DVec3, r: f64, p: DVec3| r - (p - c).length();
    [
        torus(DVec3::new(88.0, 70.0, 109.0), 50.0, 18.0, false),
        torus(DVec3::new(88.0, 150.0, 109.0), 45.0, 12.0, true),
        sphere(DVec3::new(60.0, 110.0, 60.0), 35.0, p),
        sphere(DVec3::new(120.0, 110.0, 160.0), 40.0, p),
        sphere(DVec3::new(90.0, 180.0, 40.0), 20.0, p),
    ]
    .into_iter()
    .fold(f64::MIN, f64::max)
}

fn shapes_grid() -> Grid {
    Grid { dims: DIMS, origin: [0.0; 3], voxel_size: 1.0 }
}

fn shapes_volume() -> Volume<f32> {
    let grid = shapes_grid();
    let data =
        (0..grid.len()).map(|n| shapes_distance(grid.position(grid.voxel(n))) as f32).collect();
    Volume { grid, data }
}

/// The same shapes as a field, for `polygonize_field`.
struct Shapes;

impl Field for Shapes {
    fn value(&self, p: DVec3) -> f64 {
        shapes_distance(p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let h = 1e-4;
        let d = |e: DVec3| (shapes_distance(p + e * h) - shapes_distance(p - e * h)) / (2.0 * h);
        DVec3::new(d(DVec3::X), d(DVec3::Y), d(DVec3::Z))
    }
}

fn benches(c: &mut Criterion) {
    let volume = shapes_volume();
    let mut group = c.benchmark_group("polygonize");
    group.sample_size(10);
    group.bench_function("shapes 176x220x218", |b| b.iter(|| polygonize(black_box(&volume), 0.0)));
    let grid = shapes_grid();
    group.bench_function("field shapes 176x220x218", |b| {
        b.iter(|| polygonize_field(&Shapes, black_box(&grid)))
    });
    group.finish();
}

fn fitted(c: &mut Criterion) {
    // The bunny's 700 constraints solved, on a grid of 256 voxels along their longest axis.
    let (implicit, bounds) = bunny();
    let grid = Grid::around(&bounds, Resolution::LongestAxis(256)).expect("a grid");
    let [nx, ny, nz] = grid.dims;
    let mut group = c.benchmark_group("polygonize fitted bunny");
    group.sample_size(10);
    group.bench_function(format!("surface following {nx}x{ny}x{nz}"), |b| {
        b.iter(|| polygonize_field(&implicit, black_box(&grid)))
    });
    group.bench_function(format!("dense {nx}x{ny}x{nz}"), |b| {
        b.iter(|| polygonize_field_dense(&implicit, black_box(&grid)))
    });
    group.finish();
}

criterion_group!(polygonize_benches, benches, fitted);

fn read_volume(path: &Path) -> Volume<f32> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let shape: Vec<usize> = npy.shape().iter().map(|&d| d as usize).collect();
    let dims: [usize; 3] =
        shape.try_into().unwrap_or_else(|s| panic!("{}: shape {s:?} is not 3D", path.display()));
    let data =
        npy.into_vec::<f32>().unwrap_or_else(|e| panic!("{}: not float32: {e}", path.display()));
    Volume { grid: Grid { dims, origin: [0.0; 3], voxel_size: 1.0 }, data }
}

fn time_file(path: &Path) {
    let volume = read_volume(path);
    let repeat: usize =
        std::env::var("POLYGONIZE_REPEAT").ok().and_then(|r| r.parse().ok()).unwrap_or(5);
    let mut best = f64::INFINITY;
    let mut mesh = polygonize(&volume, 0.0);
    for _ in 0..repeat {
        let start = Instant::now();
        mesh = black_box(polygonize(&volume, 0.0));
        best = best.min(start.elapsed().as_secs_f64());
    }
    println!("{best} {} {}", mesh.triangles.len(), mesh.vertices.len());
}

fn main() {
    if let Some(path) = std::env::var_os("POLYGONIZE_WRITE_SHAPES") {
        shapes_volume()
            .save_npy(Path::new(&path), &Values::default())
            .expect("writing the shapes volume");
    } else if let Some(path) = std::env::var_os("POLYGONIZE_TIME") {
        time_file(Path::new(&path));
    } else {
        polygonize_benches();
        Criterion::default().configure_from_args().final_summary();
    }
}
