//! `implicitize view` and `implicitize export` through the command line: the page is one
//! offline file holding the model, the exported GLSL compiles with glslangValidator (Debian's
//! glslang-tools, installed by scripts/test.sh) and the WGSL validates with naga; bad input
//! gives one line naming the file. (The page in a browser: python/tests/test_viewer.py.)

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use implicitize::DVec3;
use implicitize::model::Model;
use implicitize::rbf::DetailLevel;
use implicitize::rbf::MultiScale;
use implicitize::shape::csg::{Child, Composite, Operation};
use implicitize_test_support::models::{ball, disc_2d, sphere_directions};
use implicitize_test_support::wgsl;

fn implicitize() -> Command {
    Command::new(env!("CARGO_BIN_EXE_implicitize"))
}

fn run(command: &mut Command) -> Output {
    let out = command.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    out
}

/// The stderr of a command that must fail, checked to be one line.
fn failure(command: &mut Command) -> String {
    let out = command.output().unwrap();
    assert!(!out.status.success(), "the command succeeded");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    stderr
}

/// A ball, a blended difference of two balls, the ball with a detail level of bumps, a 2D disc, a cube mesh and a file that is not a
/// model, in a temporary folder.
struct Inputs {
    dir: tempfile::TempDir,
}

impl Inputs {
    fn new() -> Inputs {
        let dir = tempfile::tempdir().unwrap();
        let a = ball(DVec3::ZERO, 1.0, 1.0);
        let b = ball(DVec3::new(0.9, 0.2, 0.0), 0.6, 2.0);
        a.save(&dir.path().join("ball.json")).unwrap();
        let base = a.shape().implicit().unwrap().clone();
        let centres: Vec<DVec3> = sphere_directions(30);
        let weights = (0..30).map(|i| 0.1 + 0.02 * f64::from(i % 5)).collect();
        let level = DetailLevel::new("bumps", 0.3, centres, weights).unwrap();
        let levels = MultiScale::new("bumps", base, vec![level]).unwrap();
        Model::from_levels(levels, a.bounds(), None).save(&dir.path().join("levels.json")).unwrap();
        let children = vec![Child::from(a), Child::from(b)];
        let composite = Composite::new("test", Operation::Difference, 0.1, children).unwrap();
        Model::from_composite(composite).unwrap().save(&dir.path().join("csg.json")).unwrap();
        disc_2d().save(&dir.path().join("disc.json")).unwrap();
        std::fs::write(dir.path().join("cube.obj"), CUBE).unwrap();
        std::fs::write(dir.path().join("broken.json"), "{ \"format\": ").unwrap();
        Inputs { dir }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
}

/// A unit cube as 12 triangles.
const CUBE: &str = "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\n\
v -1 1 1\nf 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\n\
f 3 8 7\nf 4 1 5\nf 4 5 8\n";

/// The JSON data the page carries.
fn page_data(page: &str) -> serde_json::Value {
    let start = "<script type=\"application/json\" id=\"implicitize-data\">";
    let from = page.find(start).expect("the page has its data") + start.len();
    let to = from + page[from..].find("</script>").unwrap();
    serde_json::from_str(&page[from..to]).unwrap()
}

#[test]
fn view_writes_one_offline_page_with_the_model_and_the_mesh() {
    let inputs = Inputs::new();
    let page_path = inputs.path("ball.html");
    run(implicitize()
        .args(["--quiet", "view"])
        .arg(inputs.path("ball.json"))
        .arg("-o")
        .arg(&page_path)
        .arg("--mesh")
        .arg(inputs.path("cube.obj")));
    let page = std::fs::read_to_string(&page_path).unwrap();
    for remote in ["http://", "https://", "<script src", "<link", "@import"] {
        assert!(!page.contains(remote), "the page must not load anything: it has {remote:?}");
    }
    let data = page_data(&page);
    assert_eq!(data["name"], "ball.json");
    assert!(data["glsl"].as_str().unwrap().contains("float implicitize_value(vec3 p)"));
    assert_eq!(data["model"]["centres"], 101);
    assert_eq!(data["texture"]["width"], 1024);
    assert_eq!(data["mesh"]["triangles"], 12);
    // The frame holds the ball (radius 1) and the cube (half side 1): the same box.
    assert_eq!(data["frame"]["min"], serde_json::json!([-1.0, -1.0, -1.0]));
}

#[test]
fn view_shows_a_given_fit_report() {
    let inputs = Inputs::new();
    let report = inputs.path("report.json");
    std::fs::write(&report, r#"{"iterations": 7, "timings_s": {"total": 1.5}}"#).unwrap();
    let page_path = inputs.path("csg.html");
    run(implicitize()
        .args(["--quiet", "view"])
        .arg(inputs.path("csg.json"))
        .arg("-o")
        .arg(&page_path)
        .arg("--report")
        .arg(&report));
    let data = page_data(&std::fs::read_to_string(&page_path).unwrap());
    assert_eq!(data["report"]["timings_s"]["total"], 1.5);
    assert_eq!(data["model"]["centres"], 202);
    assert!(data["glsl"].as_str().unwrap().contains("implicitize_combine"));
}

/// Compiles `source` inside a fragment shader that calls both functions, as GLSL ES 3.00 and
/// as GLSL 3.30, with glslangValidator.
fn compile_glsl(source: &str, dir: &Path) {
    let main = "out vec4 color;\nvoid main() {\n    vec3 p = gl_FragCoord.xyz * 0.01;\n    \
                color = vec4(implicitize_gradient(p), implicitize_value(p));\n}\n";
    for (name, version) in
        [("es.frag", "#version 300 es\nprecision highp float;\n"), ("330.frag", "#version 330\n")]
    {
        let path = dir.join(name);
        std::fs::write(&path, format!("{version}{source}{main}")).unwrap();
        let out = Command::new("glslangValidator").arg(&path).output().unwrap_or_else(|e| {
            panic!("glslangValidator ({e}): install glslang-tools (scripts/test.sh does)")
        });
        assert!(
            out.status.success(),
            "{name}:\n{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[test]
fn exported_glsl_compiles_and_wgsl_validates() {
    let inputs = Inputs::new();
    for model in ["ball", "csg", "levels"] {
        for format in ["glsl", "wgsl"] {
            let out = inputs.path(&format!("{model}.{format}"));
            run(implicitize()
                .args(["--quiet", "export"])
                .arg(inputs.path(&format!("{model}.json")))
                .args(["--format", format, "-o"])
                .arg(&out));
            let source = std::fs::read_to_string(&out).unwrap();
            assert!(
                source.starts_with(&format!(
                    "// {}",
                    inputs.path(&format!("{model}.json")).display()
                ))
            );
            match format {
                "glsl" => compile_glsl(&source, inputs.dir.path()),
                _ => {
                    wgsl::validate(&source);
                }
            }
        }
    }
}

#[test]
fn a_file_that_is_not_a_model_is_named_and_nothing_is_written() {
    let inputs = Inputs::new();
    let broken = inputs.path("broken.json");
    for (command, out) in [("view", "page.html"), ("export", "out.glsl")] {
        let mut cmd = implicitize();
        cmd.arg(command).arg(&broken).arg("-o").arg(inputs.path(out));
        if command == "export" {
            cmd.args(["--format", "glsl"]);
        }
        let error = failure(&mut cmd);
        assert!(error.contains(&broken.display().to_string()), "{error}");
        assert!(!inputs.path(out).exists());
    }
}

#[test]
fn a_2d_model_is_refused() {
    let inputs = Inputs::new();
    let error = failure(
        implicitize()
            .arg("view")
            .arg(inputs.path("disc.json"))
            .arg("-o")
            .arg(inputs.path("disc.html")),
    );
    assert!(error.contains("disc.json") && error.contains("2D"), "{error}");
}

#[test]
fn an_unknown_format_is_refused_by_name() {
    let inputs = Inputs::new();
    let out = implicitize()
        .arg("export")
        .arg(inputs.path("ball.json"))
        .args(["--format", "hlsl", "-o"])
        .arg(inputs.path("ball.hlsl"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("'hlsl'") && stderr.contains("glsl") && stderr.contains("wgsl"),
        "{stderr}"
    );
}

#[test]
fn a_missing_destination_folder_is_named_before_any_work() {
    let inputs = Inputs::new();
    let page = inputs.path("missing/page.html");
    // The model is broken too: the destination is checked first.
    let error =
        failure(implicitize().arg("view").arg(inputs.path("broken.json")).arg("-o").arg(&page));
    assert!(error.contains(&inputs.path("missing").display().to_string()), "{error}");
    assert!(error.contains("does not exist"), "{error}");
    let source = inputs.path("missing/ball.wgsl");
    let error = failure(
        implicitize()
            .arg("export")
            .arg(inputs.path("ball.json"))
            .args(["--format", "wgsl", "-o"])
            .arg(&source),
    );
    assert!(error.contains("does not exist"), "{error}");
}

#[test]
fn a_bad_mesh_or_report_is_named() {
    let inputs = Inputs::new();
    let not_a_mesh = inputs.path("broken.obj");
    std::fs::write(&not_a_mesh, "v 0 0\nf 1 2 3\n").unwrap();
    let error = failure(
        implicitize()
            .args(["--quiet", "view"])
            .arg(inputs.path("ball.json"))
            .arg("-o")
            .arg(inputs.path("a.html"))
            .arg("--mesh")
            .arg(&not_a_mesh),
    );
    assert!(error.contains("broken.obj"), "{error}");
    let error = failure(
        implicitize()
            .args(["--quiet", "view"])
            .arg(inputs.path("ball.json"))
            .arg("-o")
            .arg(inputs.path("a.html"))
            .arg("--report")
            .arg(inputs.path("broken.json")),
    );
    assert!(error.contains("broken.json") && error.contains("report"), "{error}");
    assert!(!inputs.path("a.html").exists());
}
