//! Reading the test models: the built-in triceratops always, and the shared bunny and horse
//! when present (directory `$IMPLICITIZE_MODELS`, by default `../shared/models` beside the
//! crate). Each read goes through `mesh::read`, file system included.

use std::path::{Path, PathBuf};

use criterion::{Criterion, criterion_group, criterion_main};
use implicitize::mesh;

fn models() -> Vec<PathBuf> {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let shared = std::env::var_os("IMPLICITIZE_MODELS")
        .map_or_else(|| crate_dir.join("../shared/models"), PathBuf::from);
    let mut paths = vec![crate_dir.join("data/triceratops.obj")];
    for name in ["bunny.obj", "horse.ply"] {
        let path = shared.join(name);
        if path.exists() {
            paths.push(path);
        } else {
            eprintln!("skipping {}: not found", path.display());
        }
    }
    paths
}

fn read(c: &mut Criterion) {
    let mut group = c.benchmark_group("mesh_read");
    group.sample_size(20);
    for path in models() {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        group.bench_function(name, |b| b.iter(|| mesh::read(&path).unwrap()));
    }
    group.finish();
}

criterion_group!(benches, read);
criterion_main!(benches);
