//! Random constraints on and beside a mesh's surface, for benchmarking `implicitize solve`
//! against other RBF solvers on the same input (`scripts/bench-solve-20k.sh`).
//!
//! Usage: `sample_constraints MESH COUNT OUT.csv [--seed S] [--offset F] [--points M POINTS.npy]`
//!
//! Writes COUNT constraints as CSV `x,y,z,value` (the format `implicitize solve` reads): a third
//! boundary constraints (value 0) at points drawn uniformly by area on the surface, a third
//! interior ones at `p - d * n` with value `+d` and a third exterior ones at `p + d * n` with
//! value `-d`, each third from its own surface points; `n` is the unit normal of the sampled
//! face (the mesh's outward normal when its triangles are counter-clockwise seen from outside)
//! and `d` is F times the diagonal of the mesh's bounding box. Faces whose normal cannot be
//! computed are never sampled. With `--points`, also writes M points drawn uniformly from the
//! bounding box grown by 5% of its size on every side, as an M x 3 float64 `.npy` for
//! `implicitize eval`. The same arguments give the same files byte for byte.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, bail, ensure};
use clap::Parser;
use implicitize::{DVec3, mesh, mesh::Mesh, npy};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Samples constraints (and optionally evaluation points) from a mesh.
#[derive(Debug, Parser)]
#[command(name = "sample_constraints")]
struct Args {
    /// The mesh: .obj, .ply, .stl or .off.
    mesh: PathBuf,
    /// How many constraints to write (a third each boundary, interior, exterior).
    count: usize,
    /// The CSV file to write: `x,y,z,value`.
    output: PathBuf,
    /// Seed of the random generator.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The offset of interior and exterior constraints, as a fraction of the bounding box
    /// diagonal.
    #[arg(long, default_value_t = 0.005, allow_negative_numbers = true)]
    offset: f64,
    /// Also write M random points in the (slightly enlarged) bounding box to POINTS.npy.
    #[arg(long, num_args = 2, value_names = ["M", "POINTS.npy"])]
    points: Option<Vec<String>>,
}

/// The margin added to every side of the bounding box for `--points`, as a fraction of its size.
const POINTS_MARGIN: f64 = 0.05;

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    ensure!(args.count > 0, "COUNT must be at least 1");
    ensure!(
        args.offset.is_finite() && args.offset > 0.0,
        "--offset must be a positive number, found {}",
        args.offset
    );
    let points = match args.points.as_deref() {
        None => None,
        Some([m, path]) => {
            let m: usize =
                m.parse().with_context(|| format!("--points: M is not a count: {m:?}"))?;
            Some((m, PathBuf::from(path)))
        }
        Some(_) => bail!("--points takes two values: M POINTS.npy"),
    };

    let (mesh, _) = mesh::read(&args.mesh)?;
    let bounds = mesh.bounds().with_context(|| format!("{}: no triangles", args.mesh.display()))?;
    let sampler = SurfaceSampler::new(&mesh)
        .with_context(|| format!("{}: no triangle with a usable normal", args.mesh.display()))?;
    let offset = args.offset * bounds.diagonal();

    let mut rng = ChaCha8Rng::seed_from_u64(args.seed);
    let boundary = args.count.div_ceil(3);
    let interior = (args.count - boundary).div_ceil(2);
    let exterior = args.count - boundary - interior;
    let mut rows: Vec<(DVec3, f64)> = Vec::with_capacity(args.count);
    for _ in 0..boundary {
        rows.push((sampler.sample(&mesh, &mut rng).0, 0.0));
    }
    for _ in 0..interior {
        let (p, n) = sampler.sample(&mesh, &mut rng);
        rows.push((p - n * offset, offset));
    }
    for _ in 0..exterior {
        let (p, n) = sampler.sample(&mesh, &mut rng);
        rows.push((p + n * offset, -offset));
    }
    write_csv(&args.output, &rows)?;
    eprintln!(
        "wrote {} constraints ({boundary} boundary, {interior} interior, {exterior} exterior, \
         offset {offset:e}) to {}",
        rows.len(),
        args.output.display()
    );

    if let Some((m, path)) = points {
        // Its own stream, so the points do not depend on COUNT.
        let mut rng = ChaCha8Rng::seed_from_u64(args.seed);
        rng.set_stream(1);
        let margin = bounds.size() * POINTS_MARGIN;
        let (lo, hi) = (bounds.min - margin, bounds.max + margin);
        let mut data = Vec::with_capacity(3 * m);
        for _ in 0..m {
            for axis in 0..3 {
                data.push(rng.random_range(lo[axis]..hi[axis]));
            }
        }
        npy::write(&path, &[m as u64, 3], &data)?;
        eprintln!("wrote {m} points to {}", path.display());
    }
    Ok(())
}

/// Draws points uniformly by area from a mesh's triangles.
struct SurfaceSampler {
    /// Running sums of the areas (times two) of the usable triangles.
    cumulative: Vec<f64>,
    /// The usable triangles' indices and unit normals, in the order of `cumulative`.
    faces: Vec<(usize, DVec3)>,
}

impl SurfaceSampler {
    /// `None` when no triangle has a finite, non-zero area and a unit normal.
    fn new(mesh: &Mesh) -> Option<SurfaceSampler> {
        let mut cumulative = Vec::with_capacity(mesh.triangles.len());
        let mut faces = Vec::with_capacity(mesh.triangles.len());
        let mut total = 0.0;
        for t in 0..mesh.triangles.len() {
            let [a, b, c] = mesh.corners(t);
            let cross = (b - a).cross(c - a);
            let area = cross.length();
            let normal = cross.normalize_or_zero();
            if !(area.is_finite() && area > 0.0) || normal == DVec3::ZERO {
                continue; // degenerate: skipped
            }
            total += area;
            cumulative.push(total);
            faces.push((t, normal));
        }
        (total > 0.0 && total.is_finite()).then_some(SurfaceSampler { cumulative, faces })
    }

    /// A point drawn uniformly by area and its face's unit normal.
    fn sample(&self, mesh: &Mesh, rng: &mut ChaCha8Rng) -> (DVec3, DVec3) {
        let total = self.cumulative[self.cumulative.len() - 1];
        let r = rng.random_range(0.0..total);
        let i = self.cumulative.partition_point(|&c| c <= r).min(self.faces.len() - 1);
        let (t, normal) = self.faces[i];
        let [a, b, c] = mesh.corners(t);
        let (mut u, mut v) = (rng.random::<f64>(), rng.random::<f64>());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        (a + (b - a) * u + (c - a) * v, normal)
    }
}

/// Writes `x,y,z,value` rows with a header; numbers in Rust's shortest round-trip form.
fn write_csv(path: &Path, rows: &[(DVec3, f64)]) -> anyhow::Result<()> {
    let context = || format!("writing {}", path.display());
    let mut out = BufWriter::new(File::create(path).with_context(context)?);
    writeln!(out, "x,y,z,value").with_context(context)?;
    for (p, value) in rows {
        writeln!(out, "{},{},{},{}", p.x, p.y, p.z, value).with_context(context)?;
    }
    out.flush().with_context(context)
}
