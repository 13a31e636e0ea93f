//! Voxelization (4.1) and signed distance (4.2) on the built-in triceratops at the paper's
//! resolution (320 voxels along its longest axis). `scripts/bench-volume.sh` compares the
//! whole `implicitize sdf` process with the Python peer on the Stanford bunny.

use criterion::{Criterion, criterion_group, criterion_main};
use implicitize::edt::{inside, signed_distance};
use implicitize::voxelize::{VoxelizeOptions, voxelize};
use implicitize::{grid::Grid, grid::Resolution};
use implicitize_test_support::data::triceratops;

fn volume(c: &mut Criterion) {
    let (mesh, _) = implicitize::mesh::read(triceratops()).expect("the built-in triceratops");
    let grid = Grid::around(&mesh.bounds().unwrap(), Resolution::LongestAxis(320)).unwrap();
    let options = VoxelizeOptions::default();
    let mut group = c.benchmark_group("triceratops_320");
    group.sample_size(10);
    group.bench_function("voxelize", |b| {
        b.iter(|| voxelize(&mesh, &grid, &options).unwrap().density)
    });
    let solid = inside(&voxelize(&mesh, &grid, &options).unwrap().density);
    group.bench_function("signed_distance", |b| b.iter(|| signed_distance(&solid)));
    group.finish();
}

criterion_group!(benches, volume);
criterion_main!(benches);
