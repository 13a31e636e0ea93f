//! Property tests for the binary model reader: valid files cut short, with bytes changed, and
//! with bytes changed inside their decompressed streams (recompressed, so that the decoder
//! behind zstd's checks sees them) give a model or an error naming the file in one line,
//! never a panic; a model that reads evaluates to finite values or NaN, never a panic.

use std::path::Path;
use std::sync::LazyLock;

use crate::tests::support::data::triceratops;
use crate::tests::support::shells::open_hemisphere;
use implicitize::shape::csg::{Child, Composite, Operation};
use implicitize::voxelize::shell::Shell;
use implicitize::{
    DVec3, Field, grid::Resolution, model::Model, pipeline, pipeline::MeshFitOptions,
};
use proptest::prelude::*;

/// Valid binary files: a thin-plate model on its lattice, a model with detail levels (a
/// shell), a CSG composite of the two, and a version 1 file with detail levels (its occupancy
/// stored as bytes, tests/data).
static VALID: LazyLock<Vec<Vec<u8>>> = LazyLock::new(|| {
    let mut options = MeshFitOptions::default();
    options.resolution = Resolution::LongestAxis(40);
    let hemisphere = open_hemisphere(1.0, 16, 32);
    options.shell = Some(Shell::Voxels(2.0));
    let levels = pipeline::fit_mesh(&hemisphere, &options).unwrap().model;
    let coarse = coarse_triceratops();
    let children = vec![Child::from(coarse.clone()), Child::from(levels.clone())];
    let csg =
        Model::from_composite(Composite::new("fuzz", Operation::Union, 0.1, children).unwrap())
            .unwrap();
    let mut files: Vec<Vec<u8>> = [coarse, levels, csg].iter().map(Model::to_bytes).collect();
    let version_1 = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/triceratops-levels-v1.imp");
    files.push(std::fs::read(version_1).unwrap());
    files
});

/// The triceratops fitted by the paper's loop on a coarse grid, its function on its lattice.
fn coarse_triceratops() -> Model {
    let mut options = MeshFitOptions::default();
    options.resolution = Resolution::LongestAxis(48);
    options.fit.max_iterations = 3;
    let model = pipeline::fit_file(triceratops(), &options).unwrap().model;
    assert!(model.implicit().unwrap().lattice().is_some());
    model
}

/// Reads `bytes`; an error must name the file in one line. A model read is evaluated.
fn read_checked(bytes: &[u8]) -> Result<(), TestCaseError> {
    let path = Path::new("dir/fuzz.imp");
    match Model::from_file_bytes(bytes, path) {
        Ok(model) => {
            let b = model.bounds();
            let _ = model.values(&[b.center(), b.max, DVec3::new(1e300, 0.0, 0.0)]);
        }
        Err(e) => {
            let message = e.to_string();
            prop_assert!(message.starts_with(&path.display().to_string()), "{}", message);
            prop_assert!(!message.contains('\n'), "not one line: {}", message);
        }
    }
    Ok(())
}

/// The three decompressed streams of a binary file and the bytes before them.
fn streams(bytes: &[u8]) -> (Vec<u8>, Vec<Vec<u8>>) {
    let head = bytes[..5].to_vec();
    let mut rest = &bytes[5..];
    let mut out = Vec::new();
    for _ in 0..3 {
        let (mut length, mut shift, mut used) = (0usize, 0, 0);
        loop {
            let b = rest[used];
            used += 1;
            length |= usize::from(b & 0x7f) << shift;
            shift += 7;
            if b < 0x80 {
                break;
            }
        }
        out.push(zstd::decode_all(&rest[used..used + length]).unwrap());
        rest = &rest[used + length..];
    }
    (head, out)
}

/// A binary file of `head` and `streams`, compressed again.
fn file(head: &[u8], streams: &[Vec<u8>]) -> Vec<u8> {
    let mut bytes = head.to_vec();
    for stream in streams {
        let frame = zstd::bulk::compress(stream, 1).unwrap();
        let mut n = frame.len();
        loop {
            let low = (n & 0x7f) as u8;
            n >>= 7;
            if n == 0 {
                bytes.push(low);
                break;
            }
            bytes.push(low | 0x80);
        }
        bytes.extend(frame);
    }
    bytes
}

proptest! {
    #[test]
    fn random_bytes_after_the_magic_are_an_error(
        tail in proptest::collection::vec(any::<u8>(), 0..1024),
    ) {
        let mut bytes = implicitize::model::BINARY_MAGIC.to_vec();
        bytes.push(implicitize::model::BINARY_VERSION);
        bytes.extend(tail);
        read_checked(&bytes)?;
    }

    #[test]
    fn changed_file_bytes_never_panic(
        file in 0..4usize,
        changes in proptest::collection::vec((0.0..1.0f64, any::<u8>()), 1..8),
    ) {
        let mut bytes = VALID[file].clone();
        for (at, byte) in changes {
            let i = (at * bytes.len() as f64) as usize;
            bytes[i] = byte;
        }
        read_checked(&bytes)?;
    }

    #[test]
    fn changed_stream_bytes_never_panic(
        which in 0..4usize,
        stream in 0..3usize,
        changes in proptest::collection::vec((0.0..1.0f64, any::<u8>()), 1..6),
        keep in 0.5..1.0f64,
    ) {
        let (head, mut parts) = streams(&VALID[which]);
        let part = &mut parts[stream];
        if !part.is_empty() {
            for (at, byte) in changes {
                let i = (at * part.len() as f64) as usize;
                part[i] = byte;
            }
        }
        read_checked(&file(&head, &parts))?;
        let cut = (keep * parts[stream].len() as f64) as usize;
        parts[stream].truncate(cut);
        read_checked(&file(&head, &parts))?;
    }
}

#[test]
fn valid_files_read_back_and_every_truncation_is_an_error() {
    for bytes in VALID.iter() {
        let (head, parts) = streams(bytes);
        let again = Model::from_file_bytes(&file(&head, &parts), Path::new("again.imp")).unwrap();
        let model = Model::from_file_bytes(bytes, Path::new("valid.imp")).unwrap();
        let b = model.bounds();
        let points = [b.center(), b.min, b.max];
        assert_eq!(model.values(&points), again.values(&points));
        for cut in 0..bytes.len() {
            let e = Model::from_file_bytes(&bytes[..cut], Path::new("cut.imp")).unwrap_err();
            assert!(e.to_string().starts_with("cut.imp"), "{e}");
        }
    }
}
