//! Speed of the solve and of evaluation (paper 3.1 and 5.2).
//!
//! * `solve/N`: the dense solve for N constraints on a sphere (2/3 boundary, 1/3 exterior).
//! * `eval_700_at_500k`: the bunny's 700 constraints (tests/data) evaluated at 500,000 random
//!   points in its bounding box; scripts/bench-rbf.sh compares it with scipy's
//!   RBFInterpolator on the same constraints.
//! * `treecode/{direct,tree}/N/M`: the direct sum against the treecode (src/rbf/treecode.rs) for
//!   N thin-plate centres on a torus at M points around it.
//! * `grid_200/N`: coarse-to-fine evaluation over a 200^3 grid of a sphere model with N
//!   constraints, with the goal shell, as the fit runs it every iteration.

use criterion::{Criterion, criterion_group, criterion_main};
use implicitize::rbf::Normalization;
use implicitize::rbf::evaluate_on_grid;
use implicitize::{
    Aabb, DVec3, grid::Grid, grid::Resolution, grid::Volume, rbf::Constraint, rbf::Implicit,
    rbf::Kernel,
};
use implicitize_test_support::data::bunny;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `n` constraints on the unit sphere (Fibonacci lattice): two thirds on it (value 0), one
/// third 0.1 outside it (value -0.1). scripts/bench-rbf.sh builds the same set for scipy.
fn sphere_constraints(n: usize) -> Vec<Constraint> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let (r, phi) = ((1.0 - z * z).sqrt(), i as f64 * 2.399_963_229_728_653);
            let (scale, value) = if i % 3 == 2 { (1.1, -0.1) } else { (1.0, 0.0) };
            Constraint::new(&[scale * r * phi.cos(), scale * r * phi.sin(), scale * z], value)
        })
        .collect()
}

fn solve(c: &mut Criterion) {
    let mut group = c.benchmark_group("solve");
    group.sample_size(10);
    for n in [500, 1500, 2000, 5000] {
        let constraints = sphere_constraints(n);
        group.bench_function(n.to_string(), |b| {
            b.iter(|| Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap())
        });
    }
    group.finish();
}

fn eval(c: &mut Criterion) {
    let (implicit, bounds) = bunny();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let points: Vec<[f64; 3]> = (0..500_000)
        .map(|_| {
            let t = DVec3::new(rng.random(), rng.random(), rng.random());
            (bounds.min + t * bounds.size()).to_array()
        })
        .collect();
    let mut group = c.benchmark_group("eval");
    group.sample_size(10);
    group.bench_function("eval_700_at_500k", |b| b.iter(|| implicit.values3(&points)));
    group.finish();
}

fn grid(c: &mut Criterion) {
    let mut group = c.benchmark_group("grid_200");
    group.sample_size(10);
    let bounds = Aabb { min: DVec3::splat(-1.1), max: DVec3::splat(1.1) };
    let grid = Grid::around(&bounds, Resolution::LongestAxis(200)).unwrap();
    let goal = Volume {
        grid,
        data: (0..grid.len())
            .map(|v| ((1.0 - grid.position(grid.voxel(v)).length()) / grid.voxel_size) as f32)
            .collect(),
    };
    for n in [700, 1500] {
        let implicit = Implicit::solve(3, Kernel::ThinPlate, &sphere_constraints(n)).unwrap();
        group.bench_function(n.to_string(), |b| {
            b.iter(|| evaluate_on_grid(&implicit, &grid, Some(&goal)))
        });
    }
    group.finish();
}

/// A function of `n` centres on a torus (radii 1 and 0.4, a third on it and a third 0.05 inside
/// and outside), symmetric about the origin, with random weights that meet the side conditions:
/// equal on each symmetric pair, less their mean. Solving for 20,000 constraints would take
/// minutes; the cost of evaluation does not depend on the weights.
fn random_torus(n: usize) -> Implicit {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut constraints = Vec::with_capacity(n);
    let mut weights = Vec::with_capacity(n);
    for i in 0..n / 2 {
        let u = i as f64 * 2.399_963_229_728_653;
        let v = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / (n / 2) as f64 * 7.0;
        let (offset, value) = [(0.0, 0.0), (-0.05, 0.05), (0.05, -0.05)][i % 3];
        let r = 0.4 + offset;
        let ring = 1.0 + r * v.cos();
        let p = [ring * u.cos(), ring * u.sin(), r * v.sin()];
        constraints.push(Constraint::new(&p, value));
        constraints.push(Constraint::new(&p.map(|x| -x), value));
        let w = rng.random::<f64>() - 0.5;
        weights.extend([w, w]);
    }
    let mean = weights.iter().sum::<f64>() / weights.len() as f64;
    weights.iter_mut().for_each(|w| *w -= mean);
    let normalization = Normalization { translate: vec![0.0; 3], scale: 2.8 };
    let polynomial = vec![0.0; 4];
    Implicit::from_parts(
        "bench",
        3,
        Kernel::ThinPlate,
        constraints,
        normalization,
        weights,
        polynomial,
        0.0,
    )
    .unwrap()
}

/// Direct sum (`values3_exact`) against the treecode (`values3`, which picks it from 5,000
/// centres and 200,000 points) for a thin-plate torus of N centres at M random points in its
/// box grown by a fifth: `treecode/{direct,tree}/N/M`.
fn treecode(c: &mut Criterion) {
    let mut group = c.benchmark_group("treecode");
    group.sample_size(10);
    for n in [5_000, 20_000] {
        let implicit = random_torus(n);
        for m in [200_000, 1_000_000] {
            let mut rng = ChaCha8Rng::seed_from_u64(2);
            let points: Vec<[f64; 3]> = (0..m)
                .map(|_| [1.7, 1.7, 0.7].map(|h| h * (2.0 * rng.random::<f64>() - 1.0)))
                .collect();
            let id = format!("{n}/{m}");
            group.bench_function(format!("direct/{id}"), |b| {
                b.iter(|| implicit.values3_exact(&points))
            });
            group.bench_function(format!("tree/{id}"), |b| b.iter(|| implicit.values3(&points)));
        }
    }
    group.finish();
}

criterion_group!(benches, solve, eval, grid, treecode);
criterion_main!(benches);
