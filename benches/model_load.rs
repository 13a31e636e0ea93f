//! Opening a model and evaluating its first point: the built-in triceratops fitted at 512
//! voxels to a target of 1 (detail levels, as `implicitize demo`), written as the binary and
//! the JSON model file, each read through `Model::load` (file system included) and evaluated
//! at the centre of its bounds. Issue target: under 50 ms for a 512 model.

use criterion::{Criterion, criterion_group, criterion_main};
use implicitize::{
    Field, grid::Resolution, model::Model, model::ModelFormat, pipeline, pipeline::MeshFitOptions,
};

fn load(c: &mut Criterion) {
    let triceratops = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/triceratops.obj");
    let mut options = MeshFitOptions::default();
    options.resolution = Resolution::LongestAxis(512);
    options.fit.target_error = 1.0;
    let model = pipeline::fit_file(&triceratops, &options).unwrap().model;
    let dir = tempfile::tempdir().unwrap();
    let mut group = c.benchmark_group("model_load");
    group.sample_size(20);
    for (name, format) in [("binary", ModelFormat::Binary), ("json", ModelFormat::Json)] {
        let path = dir.path().join(format!("triceratops-512.{name}"));
        model.save_as(&path, format).unwrap();
        let bytes = std::fs::metadata(&path).unwrap().len();
        group.bench_function(format!("{name} ({bytes} bytes), open and first value"), |b| {
            b.iter(|| {
                let read = Model::load(&path).unwrap();
                read.values(&[read.bounds().center()])
            })
        });
    }
    group.finish();
}

criterion_group!(benches, load);
criterion_main!(benches);
