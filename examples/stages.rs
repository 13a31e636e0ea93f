//! Times each stage of the pipeline on one mesh and grid and prints JSON, the counterpart of
//! `peers.py stages` for `scripts/bench-stages.sh`.
//!
//! Usage: `stages MESH NX NY NZ`

use std::time::Instant;

use anyhow::Context;
use implicitize::rbf::{Constraint, Implicit, Kernel};
use implicitize::{DVec3, edt, grid::Grid, grid::Resolution, mesh, polygonize, voxelize};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let [_, path, nx, ny, nz] = args.as_slice() else {
        anyhow::bail!("usage: stages MESH NX NY NZ");
    };
    let dims = [nx.parse()?, ny.parse()?, nz.parse()?];
    let (mesh, _) = mesh::read(path.as_ref())?;
    let grid = Grid::around(&mesh.bounds().context("empty mesh")?, Resolution::Dims(dims))?;

    let t = Instant::now();
    let density = voxelize::voxelize(&mesh, &grid, &Default::default())?.density;
    let voxelize_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let sd = edt::signed_distance(&edt::inside(&density));
    let signed_distance_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let surface = polygonize::polygonize(&sd, 0.0);
    let polygonize_s = t.elapsed().as_secs_f64();

    // As peers.py: 500 surface points and 200 of them moved 4 voxels out along the face normal.
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let samples = sample_surface(&mesh, 500, &mut rng);
    let mut constraints: Vec<Constraint> =
        samples.iter().map(|(p, _)| Constraint::new(&p.to_array(), 0.0)).collect();
    let offset = 4.0 * grid.voxel_size;
    for (p, n) in &samples[..200] {
        constraints.push(Constraint::new(&(*p + *n * offset).to_array(), -offset));
    }
    let t = Instant::now();
    let implicit = Implicit::solve(3, Kernel::ThinPlate, &constraints)?;
    let rbf_fit_700_s = t.elapsed().as_secs_f64();
    let points: Vec<[f64; 3]> = (0..500_000)
        .map(|_| grid.position([0, 1, 2].map(|a| rng.random_range(0..grid.dims[a]))).to_array())
        .collect();
    let t = Instant::now();
    let values = implicit.values3(&points);
    let rbf_eval_700_at_500k_s = t.elapsed().as_secs_f64();
    anyhow::ensure!(values.len() == points.len());

    let out = serde_json::json!({
        "grid": dims,
        "voxel_size": grid.voxel_size,
        "voxelize_s": voxelize_s,
        "signed_distance_s": signed_distance_s,
        "polygonize_s": polygonize_s,
        "polygonize_triangles": surface.triangles.len(),
        "rbf_fit_700_s": rbf_fit_700_s,
        "rbf_eval_700_at_500k_s": rbf_eval_700_at_500k_s,
    });
    println!("{}", serde_json::to_string_pretty(&out)?);
    Ok(())
}

/// `n` points spread uniformly over the surface by area, each with its face's unit normal.
fn sample_surface(
    mesh: &implicitize::mesh::Mesh,
    n: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<(DVec3, DVec3)> {
    let mut cumulative = Vec::with_capacity(mesh.triangles.len());
    let mut total = 0.0;
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(t);
        total += (b - a).cross(c - a).length();
        cumulative.push(total);
    }
    (0..n)
        .map(|_| {
            let r = rng.random_range(0.0..total);
            let t = cumulative.partition_point(|&c| c < r).min(mesh.triangles.len() - 1);
            let [a, b, c] = mesh.corners(t);
            let (mut u, mut v) = (rng.random::<f64>(), rng.random::<f64>());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            (a + (b - a) * u + (c - a) * v, (b - a).cross(c - a).normalize_or_zero())
        })
        .collect()
}
