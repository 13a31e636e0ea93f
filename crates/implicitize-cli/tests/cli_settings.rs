//! The fit's settings on the command line: every setting of the library's table
//! (`implicitize::pipeline::settings::FitSettings::table`) is a flag of `fit`, `demo` and `batch`, with the
//! table's default but in the demo, and `--config` reads a settings file under the flags given.

use std::process::Command;

use implicitize::pipeline::settings::FitSettings;
use implicitize_test_support::data::triceratops;

fn implicitize() -> Command {
    Command::new(env!("CARGO_BIN_EXE_implicitize"))
}

/// `--help` of `command`, with each flag's paragraph.
fn help(command: &str) -> String {
    let out = implicitize().args([command, "--help"]).output().unwrap();
    assert!(out.status.success());
    String::from_utf8(out.stdout).unwrap()
}

/// The paragraph of `flag` in `help`: from its line to the next flag's.
fn paragraph<'a>(help: &'a str, flag: &str) -> Option<&'a str> {
    let start =
        help.find(&format!("      {flag} ")).or_else(|| help.find(&format!("      {flag}\n")))?;
    let rest = &help[start + flag.len() + 6..];
    let end = rest.find("\n  -").unwrap_or(rest.len());
    Some(&rest[..end])
}

#[test]
fn every_setting_is_a_flag_with_the_library_default() {
    for command in ["fit", "demo", "batch"] {
        let help = help(command);
        for setting in FitSettings::table() {
            let flag = setting.flag();
            let text = paragraph(&help, &flag)
                .unwrap_or_else(|| panic!("`{command} --help` has no {flag}:\n{help}"));
            // The demo fits its triceratops at a resolution and target of its own.
            let own = command == "demo";
            if let Some(default) = setting.default.as_ref().filter(|_| !own) {
                assert!(
                    text.contains(&format!("[default: {default}")),
                    "`{command} --help`: {flag} does not say its default {default}:{text}"
                );
            }
        }
    }
}

#[test]
fn a_settings_file_is_read_under_the_flags_given() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("fit.toml");
    std::fs::write(&config, "resolution = 500\nmax_iterations = 2\nlevels = 0\nseed = 3\n")
        .unwrap();
    let (model, report) = (dir.path().join("t.imp"), dir.path().join("r.json"));
    let out = implicitize()
        .arg("fit")
        .arg(triceratops())
        .args(["--quiet", "--resolution", "48", "--config"])
        .arg(&config)
        .arg("-o")
        .arg(&model)
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    // The flag's resolution over the file's; the file's iterations.
    let dims: Vec<u64> =
        report["dims"].as_array().unwrap().iter().filter_map(|d| d.as_u64()).collect();
    assert_eq!(dims.iter().max(), Some(&48), "{dims:?}");
    assert!(report["iterations"].as_u64().unwrap() <= 2, "{}", report["iterations"]);

    // The file's dims replace the command line's default resolution.
    let grid = dir.path().join("grid.toml");
    std::fs::write(&grid, "dims = [56, 30, 26]\nmax_iterations = 1\nlevels = 0\n").unwrap();
    let out = implicitize()
        .arg("fit")
        .arg(triceratops())
        .args(["--quiet", "--config"])
        .arg(&grid)
        .arg("-o")
        .arg(&model)
        .arg("--report")
        .arg(dir.path().join("grid.json"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("grid.json")).unwrap()).unwrap();
    assert_eq!(report["dims"], serde_json::json!([56, 30, 26]));

    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "max_iteration = 2\n").unwrap();
    let out = implicitize()
        .arg("fit")
        .arg(triceratops())
        .args(["--quiet", "--config"])
        .arg(&bad)
        .arg("-o")
        .arg(&model)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("bad.toml")
            && stderr.contains("max_iteration")
            && stderr.lines().count() == 1,
        "{stderr}"
    );
}
