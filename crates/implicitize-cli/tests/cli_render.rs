//! `implicitize render`, `fit --snapshots`, `mesh` and `demo`'s picture through the command line,
//! on a fit of the vendored triceratops.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use implicitize_test_support::data::triceratops;

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

/// A fit of the triceratops on a coarse grid, made once for every test of this process: the
/// folder holding `model.json`, `report.json` and the snapshots in `snapshots/`. Each process
/// has its own (nextest runs every test in a process of its own, several at once).
fn fitted() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join(format!("cli_render-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let _ = std::fs::remove_dir_all(dir.join("snapshots"));
        run(implicitize()
            .arg("fit")
            .arg(triceratops())
            .args(["--resolution", "48", "--quiet", "-o"])
            .arg(dir.join("model.json"))
            .arg("--report")
            .arg(dir.join("report.json"))
            .arg("--snapshots")
            .arg(dir.join("snapshots")));
        dir
    })
}

/// A PNG's width, height and RGBA pixels.
fn read_png(path: &Path) -> (usize, usize, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    buf.truncate(info.buffer_size());
    (info.width as usize, info.height as usize, buf)
}

/// Which pixels of columns `columns` show a surface (are opaque), row by row.
fn silhouette(
    (width, height, rgba): &(usize, usize, Vec<u8>),
    columns: std::ops::Range<usize>,
) -> Vec<bool> {
    let mut mask = Vec::new();
    for y in 0..*height {
        for x in columns.clone() {
            let alpha = rgba[(y * width + x) * 4 + 3];
            assert!(alpha == 0 || alpha == 255, "pixels are transparent or opaque");
            mask.push(alpha == 255);
        }
    }
    mask
}

fn covered(mask: &[bool]) -> f64 {
    mask.iter().filter(|&&c| c).count() as f64 / mask.len() as f64
}

/// The intersection over the union of two silhouettes.
fn iou(a: &[bool], b: &[bool]) -> f64 {
    let both = a.iter().zip(b).filter(|&(&x, &y)| x && y).count();
    let either = a.iter().zip(b).filter(|&(&x, &y)| x || y).count();
    both as f64 / either as f64
}

#[test]
fn a_model_and_a_mesh_are_drawn_framed_and_lit() {
    let dir = tempfile::tempdir().unwrap();
    for (input, name) in
        [(fitted().join("model.json"), "model.png"), (triceratops().into(), "mesh.png")]
    {
        let out = dir.path().join(name);
        run(implicitize()
            .arg("render")
            .arg(&input)
            .args(["--size", "200", "150", "--quiet", "-o"])
            .arg(&out));
        let image = read_png(&out);
        assert_eq!((image.0, image.1), (200, 150), "{name}");
        let mask = silhouette(&image, 0..200);
        let fraction = covered(&mask);
        assert!((0.1..0.7).contains(&fraction), "{name}: {fraction} of the picture covered");
        // Framed: nothing touches the picture's border.
        for y in 0..150 {
            assert!(!mask[y * 200] && !mask[y * 200 + 199], "{name}: clipped at row {y}");
        }
        assert!(!mask[..200].iter().any(|&c| c) && !mask[149 * 200..].iter().any(|&c| c));
        // Lit: the shading varies over the surface.
        let greys: Vec<u8> =
            image.2.chunks_exact(4).filter(|p| p[3] == 255).map(|p| p[0]).collect();
        let (lo, hi) = (greys.iter().min().unwrap(), greys.iter().max().unwrap());
        assert!(hi - lo > 100, "{name}: shading from {lo} to {hi}");
    }
}

#[test]
fn a_rendered_model_and_its_polygonized_mesh_share_their_silhouette() {
    let dir = tempfile::tempdir().unwrap();
    let surface = dir.path().join("surface.ply");
    let model = fitted().join("model.json");
    run(implicitize()
        .arg("mesh")
        .arg(&model)
        .args(["--resolution", "120", "--quiet", "-o"])
        .arg(&surface));
    let out = dir.path().join("compare.png");
    run(implicitize()
        .arg("render")
        .arg(&model)
        .arg("--compare")
        .arg(&surface)
        .args(["--size", "320", "240", "--view", "-40", "15", "--quiet", "-o"])
        .arg(&out));
    let image = read_png(&out);
    assert_eq!((image.0, image.1), (640, 240), "--compare puts two pictures side by side");
    let (mesh, field) = (silhouette(&image, 0..320), silhouette(&image, 320..640));
    assert!(covered(&field) > 0.1);
    let agreement = iou(&mesh, &field);
    assert!(agreement >= 0.98, "the silhouettes agree on {agreement} of the union");
}

#[test]
fn mesh_follows_the_surface_to_the_same_file_as_dense_evaluation() {
    let dir = tempfile::tempdir().unwrap();
    let model = fitted().join("model.json");
    let mesh = |name: &str, extra: &[&str]| {
        let path = dir.path().join(name);
        run(implicitize()
            .arg("mesh")
            .arg(&model)
            .args(["--resolution", "90", "--quiet", "-o"])
            .arg(&path)
            .args(extra));
        std::fs::read(path).unwrap()
    };
    let followed = mesh("followed.ply", &[]);
    assert!(followed.len() > 10_000, "{} bytes", followed.len());
    assert!(followed == mesh("dense.ply", &["--dense"]), "the files differ");
}

#[test]
fn rreg_colours_the_goal_surface_red_where_thin_and_green_where_thick() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rreg.png");
    run(implicitize()
        .arg("render")
        .arg(triceratops())
        .args(["--color", "rreg", "--resolution", "64", "--size", "240", "180", "--quiet", "-o"])
        .arg(&out));
    let (width, height, rgba) = read_png(&out);
    assert_eq!((width, height), (240, 180));
    let surface: Vec<&[u8]> = rgba.chunks_exact(4).filter(|p| p[3] == 255).collect();
    let red = surface.iter().filter(|p| p[0] > 2 * p[1] && p[0] > 60).count();
    let green = surface.iter().filter(|p| p[1] > 2 * p[0] && p[1] > 60).count();
    let grey = surface.iter().filter(|p| p[0] == p[1] && p[1] == p[2]).count();
    let n = surface.len();
    // The horns and the tail are thin, the body is thick.
    assert!(red > n / 50, "{red} red pixels of {n}");
    assert!(green > n / 5, "{green} green pixels of {n}");
    assert!(grey < n / 100, "{grey} vertices without a radius among {n} pixels");
}

#[test]
fn rreg_on_a_model_is_an_error_saying_it_needs_a_mesh() {
    let model = fitted().join("model.json");
    let stderr = failure(implicitize().arg("render").arg(&model).args([
        "--color",
        "rreg",
        "-o",
        "/dev/null",
    ]));
    assert!(stderr.contains("model.json") && stderr.contains("needs a mesh"), "{stderr}");
}

#[test]
fn bad_sizes_views_and_inputs_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let render = |args: &[&str]| {
        let mut command = implicitize();
        command.arg("render").args(args).args(["--quiet", "-o"]).arg(&out);
        failure(&mut command)
    };
    let mesh = triceratops().to_str().unwrap();
    let stderr = render(&[mesh, "--size", "0", "100"]);
    assert!(stderr.contains("--size 0 100"), "{stderr}");
    let stderr = render(&[mesh, "--size", "9000", "100"]);
    assert!(stderr.contains("--size 9000 100"), "{stderr}");
    let stderr = render(&[mesh, "--view", "NaN", "10"]);
    assert!(stderr.contains("--view") && stderr.contains("finite"), "{stderr}");
    let stderr = render(&["no-such-model.json"]);
    assert!(stderr.contains("no-such-model.json"), "{stderr}");
    let stderr = render(&["no-such-mesh.ply"]);
    assert!(stderr.contains("no-such-mesh.ply"), "{stderr}");
    let stderr = render(&[mesh, "--compare", "missing.obj"]);
    assert!(stderr.contains("missing.obj"), "{stderr}");
    let text = dir.path().join("notes.txt");
    std::fs::write(&text, "hello").unwrap();
    let stderr = render(&[text.to_str().unwrap()]);
    assert!(stderr.contains("notes.txt") && stderr.contains("not a model file"), "{stderr}");
    let broken = dir.path().join("broken.json");
    std::fs::write(&broken, "{\"format\": ").unwrap();
    let stderr = render(&[broken.to_str().unwrap()]);
    assert!(stderr.contains("broken.json"), "{stderr}");
    assert!(!out.exists(), "no picture is written on failure");
}

#[test]
fn fit_snapshots_draw_every_iteration_and_a_strip_of_them() {
    let dir = fitted();
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap();
    let iterations = report["iterations"].as_u64().unwrap() as usize;
    assert!(iterations >= 2);
    let snapshots = dir.join("snapshots");
    let mut coverage = Vec::new();
    for i in 1..=iterations {
        let image = read_png(&snapshots.join(format!("iteration-{i:02}.png")));
        assert_eq!((image.0, image.1), (240, 180));
        let mask = silhouette(&image, 0..240);
        coverage.push(covered(&mask));
    }
    assert!(!snapshots.join(format!("iteration-{:02}.png", iterations + 1)).exists());
    assert!(coverage.iter().all(|&c| c > 0.05), "{coverage:?}");
    let strip = read_png(&snapshots.join("strip.png"));
    assert_eq!((strip.0, strip.1), (240 * iterations, 180));
    // The strip is the pictures in order: its last tile is the last iteration's picture.
    let last = read_png(&snapshots.join(format!("iteration-{iterations:02}.png")));
    let tile = silhouette(&strip, 240 * (iterations - 1)..240 * iterations);
    assert_eq!(tile, silhouette(&last, 0..240));
}

#[test]
fn snapshots_need_the_iterative_method() {
    let dir = tempfile::tempdir().unwrap();
    let stderr = failure(
        implicitize()
            .arg("fit")
            .arg(triceratops())
            .args(["--method", "naive", "--resolution", "32", "--quiet", "-o"])
            .arg(dir.path().join("m.json"))
            .arg("--snapshots")
            .arg(dir.path().join("s")),
    );
    assert!(stderr.contains("--snapshots"), "{stderr}");
}

#[test]
fn demo_draws_the_mesh_beside_its_implicit_surface() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("demo");
    run(implicitize().args(["demo", "--resolution", "40", "--quiet", "-o"]).arg(&folder));
    let image = read_png(&folder.join("compare.png"));
    assert_eq!((image.0, image.1), (1600, 600));
    let (mesh, field) = (silhouette(&image, 0..800), silhouette(&image, 800..1600));
    assert!(covered(&mesh) > 0.1 && covered(&field) > 0.1);
    // A coarse fit still covers most of the mesh's silhouette through the same camera.
    let agreement = iou(&mesh, &field);
    assert!(agreement > 0.6, "mesh and implicit agree on {agreement}");
}

#[test]
fn a_solved_model_without_a_fit_grid_is_drawn_whole() {
    // A ball of radius 1 at (2, 0, 0) through 120 points on its surface (value 0), its centre
    // (value 1) and 40 points at radius 1.25 (value -0.25). A solved model has no fit grid,
    // so it is marched through its bounds (the constraints') padded.
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("x,y,z,value\n");
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let point = |i: usize, n: usize, r: f64| {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let s = (1.0 - z * z).sqrt();
        let a = golden * i as f64;
        [2.0 + r * s * a.cos(), r * s * a.sin(), r * z]
    };
    for i in 0..120 {
        let [x, y, z] = point(i, 120, 1.0);
        csv += &format!("{x},{y},{z},0\n");
    }
    csv += "2,0,0,1\n";
    for i in 0..40 {
        let [x, y, z] = point(i, 40, 1.25);
        csv += &format!("{x},{y},{z},-0.25\n");
    }
    let (constraints, model) = (dir.path().join("ball.csv"), dir.path().join("ball.json"));
    std::fs::write(&constraints, csv).unwrap();
    run(implicitize().arg("solve").arg(&constraints).arg("--quiet").arg("-o").arg(&model));
    let surface = dir.path().join("ball.obj");
    run(implicitize()
        .arg("mesh")
        .arg(&model)
        .args(["--resolution", "80", "--quiet", "-o"])
        .arg(&surface));
    let out = dir.path().join("ball.png");
    run(implicitize()
        .arg("render")
        .arg(&model)
        .arg("--compare")
        .arg(&surface)
        .args(["--size", "160", "160", "--quiet", "-o"])
        .arg(&out));
    let image = read_png(&out);
    assert_eq!((image.0, image.1), (320, 160));
    let (mesh, field) = (silhouette(&image, 0..160), silhouette(&image, 160..320));
    let agreement = iou(&mesh, &field);
    assert!(agreement >= 0.98, "the silhouettes agree on {agreement} of the union");
    // The ball's outline is round: as wide as it is tall, within a pixel or two.
    let rows: Vec<usize> =
        (0..160).filter(|&y| field[y * 160..(y + 1) * 160].contains(&true)).collect();
    let cols: Vec<usize> = (0..160).filter(|&x| (0..160).any(|y| field[y * 160 + x])).collect();
    let (h, w) = (rows.len() as i64, cols.len() as i64);
    assert!((h - w).abs() <= 2 && h > 40, "the ball is {w} x {h} pixels");
}
