//! `implicitize fit2d` (the paper's figure 2) on block letters drawn here, and the reading and
//! thresholding of images into 2D goal shapes.

use std::path::Path;
use std::process::{Command, Output};

use implicitize::goal2d::{self, ImageOptions};
use implicitize::{DVec3, Field, model::Model};
use implicitize_test_support::pictures::Picture;

fn implicitize() -> Command {
    Command::new(env!("CARGO_BIN_EXE_implicitize"))
}

/// The blocks of the letters "FIT", 14-pixel strokes on a 180 x 90 picture.
const FIT: [(usize, usize, usize, usize); 6] = [
    (15, 15, 14, 60),  // F stem
    (15, 15, 40, 14),  // F top
    (15, 45, 30, 12),  // F middle
    (70, 15, 14, 60),  // I
    (100, 15, 60, 14), // T top
    (123, 15, 14, 60), // T stem
];

fn letters() -> Picture {
    let mut picture = Picture::filled(180, 90, 255);
    for block in FIT {
        picture.block(block, 0);
    }
    picture
}

fn run(args: &[&std::ffi::OsStr]) -> Output {
    implicitize().arg("fit2d").arg("--quiet").args(args).output().unwrap()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn letters_are_fitted_within_two_pixels_and_figure_2_is_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let (image, model, report, figure) = (
        dir.path().join("fit.png"),
        dir.path().join("fit.json"),
        dir.path().join("report.json"),
        dir.path().join("figure.png"),
    );
    let picture = letters();
    picture.save(&image);
    let out = run(&[
        image.as_os_str(),
        "-o".as_ref(),
        model.as_os_str(),
        "--report".as_ref(),
        report.as_os_str(),
        "--figure".as_ref(),
        figure.as_os_str(),
        "--figure-scale".as_ref(),
        "2".as_ref(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    let report = json(&report);
    let e = report["max_error_voxels"].as_f64().unwrap();
    assert!(e <= 2.0, "E = {e} pixels");
    // E in voxels is written as an f32, E in model units as an f64: equal to f32 precision.
    let e_model = report["max_error"].as_f64().unwrap();
    assert!((e_model - e).abs() <= 1e-6 * e, "model units are pixels: {e_model} against {e}");
    assert_eq!(report["voxel_size"].as_f64().unwrap(), 1.0);
    // The letters are 15 pixels from every side: no margin is added.
    assert_eq!(report["dims"], serde_json::json!([180, 90, 1]));
    assert!(report["constraints"]["boundary"].as_u64().unwrap() >= 20);
    assert_eq!(
        report["per_iteration"].as_array().unwrap().len() as u64,
        report["iterations"].as_u64().unwrap()
    );

    // Pixel (x, y) is the point (x, height - 1 - y): the model is positive on the letters'
    // pixels and negative elsewhere, away from the edges.
    let model = Model::load(&model).unwrap();
    let mut wrong = 0;
    let mut checked = 0;
    for y in 0..picture.height {
        for x in 0..picture.width {
            let near_edge = (x.saturating_sub(3)..(x + 4).min(picture.width))
                .flat_map(|u| {
                    (y.saturating_sub(3)..(y + 4).min(picture.height)).map(move |v| (u, v))
                })
                .any(|(u, v)| picture.at(u, v) != picture.at(x, y));
            if near_edge {
                continue;
            }
            let value = model.value(DVec3::new(x as f64, (picture.height - 1 - y) as f64, 0.0));
            checked += 1;
            wrong += usize::from((value > 0.0) != (picture.at(x, y) == 0));
        }
    }
    assert!(checked > 10_000);
    assert_eq!(wrong, 0, "{wrong} of {checked} pixels three or more pixels from an edge");

    // Six panels of 360 x 180 with 6-pixel bands; panel (a) is black on the letters, white
    // off them (the F's stem at pixel (20, 40), the gap between F and I at (60, 60)).
    let mut reader =
        png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&figure).unwrap()))
            .read_info()
            .unwrap();
    let (width, height) = (reader.info().width as usize, reader.info().height as usize);
    assert_eq!((width, height), (3 * 360 + 4 * 6, 2 * 180 + 3 * 6));
    let mut rgba = vec![0; reader.output_buffer_size().unwrap()];
    reader.next_frame(&mut rgba).unwrap();
    // Image pixel (x, y) in panel n (a = 0 .. f = 5).
    let panel = |n: usize, x: usize, y: usize| {
        let (left, top) = (6 + (n % 3) * (360 + 6), 6 + (n / 3) * (180 + 6));
        let i = ((top + 2 * y) * width + left + 2 * x) * 4;
        [rgba[i], rgba[i + 1], rgba[i + 2]]
    };
    // On the F's stem at (21, 40), and off the letters between F and I at (60, 60): black and
    // white on the contour panels, red and blue on the signed distance panels.
    for n in [0, 1, 2, 5] {
        assert_eq!(panel(n, 21, 40), [0, 0, 0], "panel {n}");
        assert_eq!(panel(n, 60, 60), [255, 255, 255], "panel {n}");
    }
    for n in [3, 4] {
        let ([r, _, b], [r2, _, b2]) = (panel(n, 21, 40), panel(n, 60, 60));
        assert!(r > b && b2 > r2, "panel {n}");
    }
    // Panel (a) has magenta dots if boundary constraints were added between the iterations of
    // (b) and (c), and cyan dots if interior or exterior ones were.
    let iterations = report["per_iteration"].as_array().unwrap();
    assert!(iterations.len() >= 4, "the fit shows iterations 3 and 4");
    let added = |kind: &str| {
        iterations[3]["constraints"][kind].as_u64().unwrap()
            > iterations[2]["constraints"][kind].as_u64().unwrap()
    };
    let panel_a_has = |color: [u8; 3]| (0..180).any(|x| (0..90).any(|y| panel(0, x, y) == color));
    assert_eq!(panel_a_has([230, 0, 230]), added("boundary"));
    assert_eq!(panel_a_has([0, 200, 230]), added("interior") || added("exterior"));
}

#[test]
fn inverting_the_picture_and_the_threshold_gives_the_same_goal() {
    let picture = letters();
    let dir = tempfile::tempdir().unwrap();
    let (dark, light) = (dir.path().join("dark.png"), dir.path().join("light.png"));
    picture.save(&dark);
    picture.inverted().save(&light);
    let options = ImageOptions { blur: 1.5, ..ImageOptions::default() };
    let (a, bounds_a) = goal2d::read_density(&dark, &options).unwrap();
    let inverted = ImageOptions { invert: true, ..options };
    let (b, bounds_b) = goal2d::read_density(&light, &inverted).unwrap();
    // Equal up to the rounding of 1 - g / 255 against (255 - g) / 255.
    assert_eq!(a.grid, b.grid);
    let largest = a.data.iter().zip(&b.data).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max);
    assert!(largest < 1e-4, "densities differ by {largest}");
    assert!(a.data.iter().zip(&b.data).all(|(x, y)| (*x > 0.5) == (*y > 0.5)));
    assert!(a.data.iter().any(|&d| d > 0.0 && d < 1.0), "the blur antialiases");
    assert_eq!(bounds_a, bounds_b);
    // The letters' bounds in pixels, y up: the F's stem starts at x = 15, the T ends at 159,
    // the letters span rows 15..=74 from the top, so y from 90 - 1 - 74 = 15 to 74.
    assert_eq!(bounds_a.min, DVec3::new(14.5, 14.5, 0.0));
    assert_eq!(bounds_a.max, DVec3::new(159.5, 74.5, 0.0));

    // Without --invert the light picture's shape is the dark frame around the letters, which
    // touches every side: three empty pixels are added on each.
    let (frame, _) = goal2d::read_density(&light, &options).unwrap();
    assert_eq!(frame.grid.dims, [186, 96, 1]);
    assert_eq!(frame.grid.origin, [-3.0, -3.0, 0.0]);
    assert_eq!(*frame.get([0, 0, 0]), 0.0);
    assert_eq!(*frame.get([3, 3, 0]), 1.0);
}

/// Runs fit2d on `image` and returns its one line of error.
fn error_of(image: &Path, extra: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("m.json");
    let mut args = vec![image.as_os_str(), "-o".as_ref(), model.as_os_str()];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    let out = run(&args);
    assert!(!out.status.success());
    assert!(!model.exists());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    stderr
}

#[test]
fn bad_images_fail_with_one_line_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.png");
    assert!(error_of(&missing, &[]).contains("missing.png"));

    let text = dir.path().join("text.png");
    std::fs::write(&text, "not a picture\n").unwrap();
    let message = error_of(&text, &[]);
    assert!(message.contains("text.png") && message.contains("PNG"), "{message}");

    let tiny = dir.path().join("tiny.png");
    std::fs::write(&tiny, "hi").unwrap();
    let message = error_of(&tiny, &[]);
    assert!(message.contains("tiny.png") && message.contains("PNG"), "{message}");

    let truncated = dir.path().join("truncated.png");
    letters().save(&truncated);
    let bytes = std::fs::read(&truncated).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    assert!(error_of(&truncated, &[]).contains("truncated.png"));

    let white = dir.path().join("white.png");
    Picture::filled(40, 30, 255).save(&white);
    let message = error_of(&white, &[]);
    assert!(message.contains("white.png") && message.contains("no pixel is inside"), "{message}");
    let message = error_of(&white, &["--invert"]);
    assert!(
        message.contains("white.png") && message.contains("every pixel is inside"),
        "{message}"
    );

    let fit = dir.path().join("fit.png");
    letters().save(&fit);
    assert!(error_of(&fit, &["--threshold", "1.5"]).contains("--threshold"));
    assert!(error_of(&fit, &["--blur=-1"]).contains("--blur"));
    let figure = dir.path().join("figure.png");
    let figure_arg = figure.to_str().unwrap();
    let message = error_of(&fit, &["--figure", figure_arg, "--figure-scale", "0"]);
    assert!(message.contains("--figure-scale"), "{message}");
    assert!(!figure.exists());
}
