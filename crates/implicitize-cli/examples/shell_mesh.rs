//! Writes a generated thin-walled or open mesh (see `implicitize_test_support::shells`) for
//! `scripts/bench-shell.sh`:
//! `cargo run --release -p implicitize-cli --example shell_mesh -- KIND OUT TRIANGLES [WALL]`
//! where KIND is `bust` (a bumpy hollow ball open at the bottom, its wall WALL voxels thick at
//! the default grid, 1 if not given), `ball` (the same, round and closed), `hemisphere` (an
//! open hemisphere) or `car` (a car body's open shell, TRIANGLES ignored).

use std::path::Path;

use implicitize::grid::{Grid, Resolution};
use implicitize::mesh;
use implicitize_test_support::{hostile, shells};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (kind, out, triangles, wall) = match args.as_slice() {
        [kind, out, triangles] => (kind, out, triangles, 1.0),
        [kind, out, triangles, wall] => (kind, out, triangles, wall.parse()?),
        _ => return Err("usage: shell_mesh bust|ball|hemisphere|car OUT TRIANGLES [WALL]".into()),
    };
    let triangles: usize = triangles.parse()?;
    // About 2 * rings * segments triangles a face, with segments = 2 * rings.
    let faces = if kind == "hemisphere" { 0.5 } else { 2.0 };
    let rings = ((triangles as f64 / faces / 4.0).sqrt().round() as usize).max(4);
    let segments = 2 * rings;
    let (bump, opening) = match kind.as_str() {
        "bust" => (0.04, 0.6),
        _ => (0.0, 0.0),
    };
    let mesh = match kind.as_str() {
        "bust" | "ball" => {
            let probe = shells::hollow_ball(1.0, 0.1, bump, opening, rings, segments);
            let bounds = probe.bounds().ok_or("the probe has no triangles")?;
            let voxel = Grid::around(&bounds, Resolution::default())?.voxel_size;
            shells::hollow_ball(1.0, wall * voxel, bump, opening, rings, segments)
        }
        "hemisphere" => shells::open_hemisphere(1.0, rings, segments),
        "car" => hostile::car_body(),
        other => return Err(format!("unknown kind {other:?}").into()),
    };
    mesh::write(Path::new(out), &mesh)?;
    eprintln!("wrote {out}: {} triangles", mesh.triangles.len());
    Ok(())
}
