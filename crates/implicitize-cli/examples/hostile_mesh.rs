//! Writes a generated hostile mesh (see `implicitize_test_support::hostile`) for the benchmarks:
//! `cargo run --release -p implicitize-cli --example hostile_mesh -- hollow OUT.ply 2600000`
//! writes a bumpy sphere with an inward-facing sphere inside (a hollow solid) of about that
//! many triangles; `sphere` writes the bumpy sphere alone.

use std::path::Path;

use implicitize::{DVec3, mesh};
use implicitize_test_support::hostile;
use implicitize_test_support::meshes::merge;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [kind, out, triangles] = args.as_slice() else {
        return Err("usage: hostile_mesh sphere|hollow OUT.(ply|obj|stl|off) TRIANGLES".into());
    };
    let triangles: usize = triangles.parse()?;
    let shells = if kind == "hollow" { 2 } else { 1 };
    // 2 * segments * (rings - 1) triangles a shell, with rings = segments / 2 + 1.
    let segments = ((triangles / shells) as f64).sqrt().round().max(8.0) as usize;
    let rings = segments / 2 + 1;
    let outer = hostile::bumpy_sphere(DVec3::ZERO, 1.0, 0.05, rings, segments, false);
    let mesh = match kind.as_str() {
        "sphere" => outer,
        "hollow" => {
            let inner = hostile::bumpy_sphere(DVec3::ZERO, 0.6, 0.0, rings, segments, true);
            merge(&outer, &inner)
        }
        other => return Err(format!("unknown kind {other:?}: sphere or hollow").into()),
    };
    mesh::write(Path::new(out), &mesh)?;
    eprintln!("wrote {out}: {} triangles", mesh.triangles.len());
    Ok(())
}
