//! The model file: bit-for-bit round trips and clear errors for wrong or damaged files.

use std::path::{Path, PathBuf};

use implicitize::{
    Aabb, DVec3, Field, grid::Grid, model::Model, rbf::Constraint, rbf::Implicit, rbf::Kernel,
};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn sample_implicit(dim: usize, kernel: Kernel, seed: u64) -> Implicit {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Awkward numbers: far from the origin, full 53-bit mantissas.
    let constraints: Vec<Constraint> = (0..60)
        .map(|i| {
            let p: Vec<f64> = (0..dim).map(|_| 1234.5678 + 10.0 * rng.random::<f64>()).collect();
            Constraint::new(&p, [0.0, rng.random::<f64>(), -rng.random::<f64>()][i % 3])
        })
        .collect();
    Implicit::solve(dim, kernel, &constraints).unwrap()
}

fn sample_model(dim: usize, kernel: Kernel) -> Model {
    let bounds = Aabb { min: DVec3::splat(1234.5678), max: DVec3::splat(1244.5678) };
    let grid =
        Grid { dims: [30, 31, 32], origin: [1230.1, 1230.2, 1230.3], voxel_size: 0.123456789 };
    Model::from_implicit(sample_implicit(dim, kernel, dim as u64), bounds, Some(grid))
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn save_and_load_round_trip_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    for (dim, kernel) in [(3, Kernel::ThinPlate), (2, Kernel::Cubic), (4, Kernel::Linear)] {
        let mut model = sample_model(dim, kernel);
        model.set_report(serde_json::json!({"iterations": 7, "rms": 0.1}));
        let path = dir.path().join(format!("model{dim}.json"));
        model.save(&path).unwrap();
        let loaded = Model::load(&path).unwrap();
        let (a, b) = (model.implicit().unwrap(), loaded.implicit().unwrap());
        assert_eq!((b.dim(), b.kernel(), b.len()), (dim, kernel, 60));
        assert_eq!(bits(a.weights()), bits(b.weights()));
        assert_eq!(bits(a.polynomial()), bits(b.polynomial()));
        assert_eq!(a.normalization(), b.normalization());
        assert_eq!(a.constraints(), b.constraints());
        assert_eq!(a.residual().to_bits(), b.residual().to_bits());
        assert_eq!(loaded.bounds(), model.bounds());
        assert_eq!(loaded.grid(), model.grid());
        assert_eq!(loaded.report(), model.report());
        // The same function, bit for bit.
        let points: Vec<f64> = (0..50 * dim).map(|i| 1234.0 + 0.23 * i as f64).collect();
        assert_eq!(bits(&a.values_flat(&points)), bits(&b.values_flat(&points)));
        if dim == 3 {
            let p = DVec3::new(1238.0, 1239.0, 1240.0);
            assert_eq!(model.value(p).to_bits(), loaded.value(p).to_bits());
            assert_eq!(model.gradient(p), loaded.gradient(p));
            assert_eq!(model.values(&[p]), vec![a.value_at(&p.to_array())]);
        }
        // Saving again gives the same bytes.
        let again = dir.path().join("again.json");
        loaded.save(&again).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), std::fs::read(&again).unwrap());
    }
}

#[test]
fn the_file_states_format_version_sign_and_kernel() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.json");
    let mut model = sample_model(3, Kernel::ThinPlate);
    model.save(&path).unwrap();
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    assert_eq!(json["format"], "implicitize-model");
    assert_eq!(json["version"], 1);
    assert_eq!(json["sign"], "inside positive, outside negative");
    assert_eq!(json["shape"]["type"], "rbf");
    assert_eq!(json["shape"]["kernel"], "r2logr");
    assert_eq!(json["shape"]["dimension"], 3);
    assert_eq!(json["shape"]["centres"].as_array().unwrap().len(), 60);
    assert_eq!(json["shape"]["kinds"][0], "boundary");
    assert!(json["report"].is_null());
    model.set_report(serde_json::json!({"e": 1}));
    model.save(&path).unwrap();
    assert_eq!(Model::load(&path).unwrap().report().unwrap()["e"], 1);
}

/// Saves a sample model, edits its JSON with `edit`, and returns the file, the load error's
/// message and the temporary folder (removed when dropped).
fn load_error_after(
    edit: impl FnOnce(&mut serde_json::Value),
) -> (PathBuf, String, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("edited.json");
    sample_model(3, Kernel::ThinPlate).save(&path).unwrap();
    let mut json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    edit(&mut json);
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let message = Model::load(&path).unwrap_err().to_string();
    (path, message, dir)
}

fn assert_names_file(path: &Path, message: &str, want: &str) {
    assert!(message.contains(&path.display().to_string()), "{message}");
    assert!(message.contains(want), "expected {want:?} in {message}");
}

/// An edit of a model file's JSON.
type Edit = dyn FnOnce(&mut serde_json::Value);

#[test]
fn wrong_files_and_versions_are_named_errors() {
    let cases: Vec<(Box<Edit>, &str)> = vec![
        (Box::new(|j| j["version"] = 3.into()), "version 3 is not supported"),
        (Box::new(|j| j["format"] = "something".into()), "not an implicitize model"),
        (Box::new(|j| j["sign"] = "inside negative".into()), "sign convention"),
        (Box::new(|j| j["shape"]["kernel"] = "gauss".into()), "gauss"),
        (Box::new(|j| j["shape"]["type"] = "sphere".into()), "sphere"),
        (Box::new(|j| j["shape"]["weights"][3] = serde_json::Value::Null), "not a valid model"),
        (
            Box::new(|j| j["shape"]["weights"].as_array_mut().unwrap().pop().map(drop).unwrap()),
            "59 weights for 60",
        ),
        (Box::new(|j| j["shape"]["kinds"][0] = "interior".into()), "centre 1 has value 0"),
        (
            Box::new(|j| j["shape"]["centres"][5] = serde_json::json!([1.0, 2.0])),
            "constraint 6 has 2 coordinates",
        ),
        (Box::new(|j| j["shape"]["dimension"] = 7.into()), "dimension 7"),
        (Box::new(|j| j["shape"]["normalization"]["scale"] = 0.0.into()), "normalization"),
        (Box::new(|j| j["bounds"]["min"][0] = 1e9.into()), "bounds"),
    ];
    for (edit, want) in cases {
        let (path, message, _dir) = load_error_after(edit);
        assert_names_file(&path, &message, want);
    }
}

#[test]
fn damaged_and_missing_files_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.json");
    sample_model(3, Kernel::ThinPlate).save(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let truncated = dir.path().join("truncated.json");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let message = Model::load(&truncated).unwrap_err().to_string();
    assert_names_file(&truncated, &message, "line");
    let missing = dir.path().join("missing.json");
    assert_names_file(&missing, &Model::load(&missing).unwrap_err().to_string(), "");
    let text = dir.path().join("text.json");
    std::fs::write(&text, "hello").unwrap();
    assert_names_file(&text, &Model::load(&text).unwrap_err().to_string(), "not a model file");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Random bytes, and a valid file with random bytes overwritten, give an error, never a
    /// panic.
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400), at in 0usize..4000, junk in any::<u8>()) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("random.json");
        std::fs::write(&path, &bytes).unwrap();
        prop_assert!(Model::load(&path).is_err());
        sample_model(2, Kernel::ThinPlate).save(&path).unwrap();
        let mut valid = std::fs::read(&path).unwrap();
        let at = at % valid.len();
        valid[at] = junk;
        std::fs::write(&path, &valid).unwrap();
        let _ = Model::load(&path);
    }
}

/// Every kind of function in the binary file (stored raw: these were not made on a lattice)
/// reads back bit for bit, whatever the file's name; the format is told by the first bytes.
#[test]
fn binary_files_round_trip_bit_for_bit_whatever_their_name() {
    let dir = tempfile::tempdir().unwrap();
    for (dim, kernel) in [(3, Kernel::ThinPlate), (2, Kernel::Cubic), (4, Kernel::Linear)] {
        let model = sample_model(dim, kernel);
        let path = dir.path().join(format!("model{dim}.imp"));
        model.save(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.starts_with(implicitize::model::BINARY_MAGIC));
        assert_eq!(bytes, model.to_bytes());
        let named_json = dir.path().join("binary-inside.json");
        std::fs::write(&named_json, &bytes).unwrap();
        for loaded in [Model::load(&path).unwrap(), Model::load(&named_json).unwrap()] {
            let (a, b) = (model.implicit().unwrap(), loaded.implicit().unwrap());
            assert_eq!(bits(a.weights()), bits(b.weights()));
            assert_eq!(bits(a.polynomial()), bits(b.polynomial()));
            assert_eq!(a.normalization(), b.normalization());
            assert_eq!(a.constraints(), b.constraints());
            assert_eq!(loaded.bounds(), model.bounds());
            assert_eq!(loaded.grid(), model.grid());
            assert!(loaded.report().is_none(), "the binary file stores no report");
            let points: Vec<f64> = (0..50 * dim).map(|i| 1234.0 + 0.23 * i as f64).collect();
            assert_eq!(bits(&a.values_flat(&points)), bits(&b.values_flat(&points)));
            assert_eq!(loaded.to_bytes(), bytes, "written again, the same bytes");
        }
        // `save_as` writes either format under any name.
        let json_named_imp = dir.path().join("json.imp");
        model.save_as(&json_named_imp, implicitize::model::ModelFormat::Json).unwrap();
        assert_eq!(std::fs::read(&json_named_imp).unwrap()[0], b'{');
        assert!(Model::load(&json_named_imp).is_ok());
    }
}

/// A version 1 binary file (its octrees' occupancy stored as bytes, written by the build before
/// the occupancy was arithmetic-coded: the triceratops with two detail levels, `fit
/// --max-bytes 8000`) still reads; written again it is version 2, smaller, and reads back to
/// a model with the same values bit for bit.
#[test]
fn version_1_binary_files_still_read() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/triceratops-levels-v1.imp");
    let old_bytes = std::fs::read(&path).unwrap();
    assert_eq!(old_bytes[4], 1, "the fixture is version 1");
    let old = Model::load(&path).unwrap();
    match old.shape() {
        implicitize::shape::Shape::Levels(levels) => assert_eq!(levels.levels().len(), 2),
        _ => panic!("the fixture holds detail levels"),
    }
    let new_bytes = old.to_bytes();
    assert_eq!(new_bytes[4], implicitize::model::BINARY_VERSION);
    assert!(new_bytes.len() < old_bytes.len(), "{} >= {}", new_bytes.len(), old_bytes.len());
    let new = Model::from_file_bytes(&new_bytes, Path::new("again.imp")).unwrap();
    let b = old.bounds();
    let points: Vec<DVec3> = (0..2000)
        .map(|i| {
            let t = DVec3::new(
                i as f64 / 2000.0,
                (i * 7 % 2000) as f64 / 2000.0,
                (i * 13 % 2000) as f64 / 2000.0,
            );
            b.min + (b.max - b.min) * t
        })
        .collect();
    assert_eq!(bits(&old.values(&points)), bits(&new.values(&points)));
}

/// A binary file cut anywhere, or with any byte changed, is refused in one line naming the
/// file, or (a changed number) read as another model; never a panic.
#[test]
fn damaged_binary_files_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.imp");
    let bytes = sample_model(3, Kernel::ThinPlate).to_bytes();
    for cut in 0..bytes.len() {
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let message = Model::load(&path).unwrap_err().to_string();
        assert!(message.contains(&path.display().to_string()), "{message}");
        assert!(!message.contains('\n'), "{message}");
    }
    for at in 0..bytes.len() {
        let mut damaged = bytes.clone();
        damaged[at] ^= 0x5a;
        std::fs::write(&path, &damaged).unwrap();
        if let Err(e) = Model::load(&path) {
            assert!(e.to_string().contains(&path.display().to_string()), "{e}");
        }
    }
    let mut newer = bytes.clone();
    newer[4] = 9;
    std::fs::write(&path, &newer).unwrap();
    let message = Model::load(&path).unwrap_err().to_string();
    assert!(message.contains("binary model format version 9 is not supported"), "{message}");
}
