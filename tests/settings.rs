//! The fit's settings by their user-facing names (`implicitize::settings`): the struct and its
//! table agree, each setting reaches the library's options, and a settings file is read
//! through the same struct.

use implicitize::memory::MemoryLimit;
use implicitize::pipeline::{MeshFitOptions, Method};
use implicitize::settings::{FitSettings, fit_settings};
use implicitize::{Error, Resolution};

/// The table lists the struct's fields, in its order: a field added to one is added to both.
#[test]
fn the_table_lists_every_field_of_the_settings() {
    let json = serde_json::to_value(FitSettings::default()).unwrap();
    let fields: Vec<&str> = json.as_object().unwrap().keys().map(String::as_str).collect();
    let mut names: Vec<&str> = fit_settings().iter().map(|s| s.name).collect();
    let mut sorted = fields.clone();
    sorted.sort_unstable();
    names.sort_unstable();
    assert_eq!(sorted, names);
    for setting in fit_settings() {
        assert!(!setting.help.is_empty() && !setting.unit.is_empty(), "{setting:?}");
    }
}

/// Nothing given is the library's defaults; each setting given changes what it names.
#[test]
fn each_setting_reaches_the_options() {
    let defaults = FitSettings::default().options("options", MemoryLimit::default()).unwrap();
    assert_eq!(defaults, MeshFitOptions::default());
    let file = r#"
        resolution = 64
        target_error = 1.5
        seed = 7
        max_constraints = 900
        method = "iterative"
        max_iterations = 9
        subvoxel = true
        full_resolution = true
        levels = 0
        shell = "0.5u"
        max_bytes = 5000
    "#;
    let settings: FitSettings = toml::from_str(file).unwrap();
    let options = settings.options("options", MemoryLimit::default()).unwrap();
    assert_eq!(options.resolution, Resolution::LongestAxis(64));
    assert_eq!(options.method, Method::Iterative);
    assert_eq!(options.fit.target_error, 1.5);
    assert_eq!(options.fit.seed, 7);
    assert_eq!(options.fit.max_constraints, Some(900));
    assert_eq!(options.fit.max_iterations, 9);
    assert_eq!(options.fit.error_measure, implicitize::fit::ErrorMeasure::SubVoxel);
    assert!(!options.fit.coarse_start);
    assert_eq!(options.fit.levels.max_levels, 0);
    assert_eq!(options.shell, Some(implicitize::voxelize::shell::Shell::Mesh(0.5)));
    assert_eq!(options.max_bytes, Some(5000));
    let solid: FitSettings = toml::from_str("solid = true\ndims = [10, 20, 30]").unwrap();
    let options = solid.options("options", MemoryLimit::default()).unwrap();
    assert!(options.solid);
    assert_eq!(options.resolution, Resolution::Dims([10, 20, 30]));
}

/// Out of range is refused naming the setting, as every front end words it.
#[test]
fn a_setting_out_of_range_is_named() {
    let refused = |settings: FitSettings, expected: &str| {
        let error = settings.options("options", MemoryLimit::default()).unwrap_err();
        assert!(matches!(error, Error::Invalid { .. }), "{error}");
        assert!(error.to_string().contains(expected), "{error} lacks {expected}");
    };
    let mut both = FitSettings::default();
    (both.resolution, both.dims) = (Some(64), Some([8, 8, 8]));
    refused(both, "`resolution` or `dims`");
    let mut method = FitSettings::default();
    method.method = Some("fast".into());
    refused(method, "`method`");
    let mut iterations = FitSettings::default();
    iterations.max_iterations = Some(0);
    refused(iterations, "`max_iterations`");
    let mut shell = FitSettings::default();
    shell.shell = Some("thick".into());
    refused(shell, "`shell`");
    let mut both = FitSettings::default();
    (both.shell, both.solid) = (Some("2".into()), true);
    refused(both, "`shell` or `solid`");
    let mut bytes = FitSettings::default();
    bytes.max_bytes = Some(0);
    refused(bytes, "`max_bytes`");
}

/// A settings file is TOML (or JSON by its name); a key that is no setting is refused in one
/// line naming the key, the line and the file.
#[test]
fn a_settings_file_is_read_and_an_unknown_key_named() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("fit.toml");
    std::fs::write(&good, "target_error = 1.0\nlevels = 3\n").unwrap();
    let settings = FitSettings::read(&good).unwrap();
    assert_eq!((settings.target_error, settings.levels), (Some(1.0), Some(3)));
    let json = dir.path().join("fit.json");
    std::fs::write(&json, r#"{"seed": 4}"#).unwrap();
    assert_eq!(FitSettings::read(&json).unwrap().seed, Some(4));
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "target_error = 1.0\ntarget_eror = 2\n").unwrap();
    let error = FitSettings::read(&bad).unwrap_err().to_string();
    assert!(
        error.contains("bad.toml") && error.contains("target_eror") && error.contains("line 2"),
        "{error}"
    );
    assert_eq!(error.lines().count(), 1, "{error}");
    let wrong_type = dir.path().join("type.toml");
    std::fs::write(&wrong_type, "levels = \"many\"\n").unwrap();
    let error = FitSettings::read(&wrong_type).unwrap_err().to_string();
    assert!(error.contains("type.toml") && error.contains("line 1"), "{error}");
    // A value out of range is refused when the file is read, by its key as the file spells it.
    let range = dir.path().join("range.toml");
    std::fs::write(&range, "max_iterations = 0\n").unwrap();
    let error = FitSettings::read(&range).unwrap_err().to_string();
    assert!(error.starts_with(&range.display().to_string()), "{error}");
    assert!(error.contains("\"max_iterations\"") && !error.contains("options"), "{error}");
    let missing = FitSettings::read(&dir.path().join("none.toml")).unwrap_err().to_string();
    assert!(missing.contains("none.toml"), "{missing}");
}
