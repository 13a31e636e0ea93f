//! The fit's settings by their user-facing names (`implicitize::pipeline::settings`): the struct and its
//! table agree, each setting reaches the library's options, a settings file is read through
//! the same struct, values read by each setting's kind become it, and the docs' table and
//! Python's stub are made from the table.

use std::path::Path;

use implicitize::memory::MemoryLimit;
use implicitize::pipeline::settings::{FitSettings, Kind};
use implicitize::pipeline::{MeshFitOptions, Method};
use implicitize::{Error, grid::Resolution};
use serde_json::json;

/// The table lists the struct's fields, in its order: a field added to one is added to both.
#[test]
fn the_table_lists_every_field_of_the_settings() {
    let json = serde_json::to_value(FitSettings::default()).unwrap();
    let fields: Vec<&str> = json.as_object().unwrap().keys().map(String::as_str).collect();
    let mut names: Vec<&str> = FitSettings::table().iter().map(|s| s.name).collect();
    let mut sorted = fields.clone();
    sorted.sort_unstable();
    names.sort_unstable();
    assert_eq!(sorted, names);
    for setting in FitSettings::table() {
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
    // A shell in voxels may be a number, as Python's `shell=2`.
    let shell = dir.path().join("shell.toml");
    std::fs::write(&shell, "shell = 2\n").unwrap();
    assert_eq!(FitSettings::read(&shell).unwrap().shell.as_deref(), Some("2"));
    let missing = FitSettings::read(&dir.path().join("none.toml")).unwrap_err().to_string();
    assert!(missing.contains("none.toml"), "{missing}");
}

/// Values by setting name, as the command line and Python read them, become the struct: each
/// setting takes a value of its kind (so a kind names its field's type), text takes a number
/// as its text, and a name that is no setting or a value of another kind is refused, named.
#[test]
fn values_of_each_kind_become_the_settings() {
    let sample = |kind: Kind| -> serde_json::Value {
        match kind {
            Kind::Count => json!(3),
            Kind::Number => json!(1.5),
            Kind::Counts3 => json!([4, 5, 6]),
            Kind::Switch => json!(true),
            Kind::Choice(words) => json!(words[words.len() - 1]),
            Kind::Text => json!("2"),
        }
    };
    let unset = serde_json::to_value(FitSettings::default()).unwrap();
    for setting in FitSettings::table() {
        let value = sample(setting.kind);
        let values = serde_json::Map::from_iter([(setting.name.to_string(), value.clone())]);
        let settings =
            FitSettings::from_values(values, "options").unwrap_or_else(|e| panic!("{e}"));
        let read = &serde_json::to_value(&settings).unwrap()[setting.name];
        assert!(read != &unset[setting.name], "{}: {read}", setting.name);
        assert_eq!(read, &value, "{}", setting.name);
    }
    let shell = serde_json::Map::from_iter([("shell".to_string(), json!(2))]);
    assert_eq!(FitSettings::from_values(shell, "options").unwrap().shell.as_deref(), Some("2"));
    let unknown = serde_json::Map::from_iter([("resolutoin".to_string(), json!(3))]);
    let e = FitSettings::from_values(unknown, "options").unwrap_err().to_string();
    assert!(e.contains("`resolutoin` is not a fit setting"), "{e}");
    let negative = serde_json::Map::from_iter([("levels".to_string(), json!(-1))]);
    let e = FitSettings::from_values(negative, "options").unwrap_err().to_string();
    assert!(e.contains("`levels` takes a whole number of 0 or more, not -1"), "{e}");
    let null = serde_json::Map::from_iter([("seed".to_string(), serde_json::Value::Null)]);
    assert_eq!(FitSettings::from_values(null, "options").unwrap(), FitSettings::default());
}

/// The table of the fit's settings in docs/cli.md is the one the library's table makes, and
/// the fit's declaration in Python's stub (python/implicitize/__init__.pyi) too: both are made
/// here, so a setting added to the library reaches them by `IMPLICITIZE_BLESS=1 cargo test
/// --test settings`, which writes them, and this test fails until then.
#[test]
fn the_docs_table_and_the_python_stub_are_made_from_the_table() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    made_between(
        &root.join("docs/cli.md"),
        "<!-- the fit's settings",
        "<!-- end of the fit's settings -->",
        &docs_table(),
    );
    made_between(
        &root.join("python/implicitize/__init__.pyi"),
        "# the fit's settings",
        "# end of the fit's settings",
        &python_stub(),
    );
}

/// The docs' table: each setting's flag and keyword, unit, default and help.
fn docs_table() -> String {
    let mut table = String::from(
        "| flag (Python keyword, settings-file key) | value | default | what it does |\n\
         |---|---|---|---|\n",
    );
    for setting in FitSettings::table() {
        let flag = match setting.value_name {
            "" => setting.flag(),
            value => format!("{} {value}", setting.flag()),
        };
        let default = setting.default.as_deref().unwrap_or("");
        table.push_str(&format!(
            "| `{flag}` (`{}`) | {} | {default} | {} |\n",
            setting.name, setting.unit, setting.help
        ));
    }
    table
}

/// The declaration of `implicitize.fit` in Python's stub: each setting a keyword of the type
/// its kind reads.
fn python_stub() -> String {
    let mut stub = String::from("def fit(\n    mesh: Any,\n    *,\n");
    for setting in FitSettings::table() {
        let typed = match setting.kind {
            Kind::Count => "Optional[int] = None",
            Kind::Number => "Optional[float] = None",
            Kind::Counts3 => "Optional[Sequence[int]] = None",
            Kind::Switch => "bool = False",
            Kind::Choice(_) => "Optional[str] = None",
            Kind::Text => "Union[float, str, None] = None",
        };
        stub.push_str(&format!("    {}: {typed},\n", setting.name));
    }
    stub.push_str(
        "    progress: bool = False,\n    memory_limit: _Memory = None,\n) -> Model:\n    \
         \"\"\"Fits a variational implicit surface to ``mesh``, as ``implicitize fit``; None is \
         the\n    library's default (FIT_SETTINGS), MemoryError beyond ``memory_limit``.\"\"\"\n",
    );
    stub
}

/// Checks that the lines of `path` after the line starting with `begin` and before the one
/// starting with `end` are `text`; writes them where `IMPLICITIZE_BLESS` is set.
fn made_between(path: &Path, begin: &str, end: &str, text: &str) {
    let source = std::fs::read_to_string(path).unwrap();
    let start = source.find(begin).unwrap_or_else(|| panic!("{}: no {begin}", path.display()));
    let start = start + source[start..].find('\n').unwrap() + 1;
    let stop = start + source[start..].find(end).unwrap_or_else(|| panic!("no {end}"));
    if source[start..stop] == *text {
        return;
    }
    if std::env::var_os("IMPLICITIZE_BLESS").is_some() {
        std::fs::write(path, format!("{}{text}{}", &source[..start], &source[stop..])).unwrap();
        return;
    }
    panic!(
        "{} is not what the settings' table makes: IMPLICITIZE_BLESS=1 cargo test --test \
         settings writes it",
        path.display()
    );
}
