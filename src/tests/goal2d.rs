//! The reading of images into 2D goal shapes (`goal2d`, the paper's figure 2): luminance of
//! every PNG colour type, the threshold and the blur. The command's own tests of `fit2d`
//! (crates/implicitize-cli/tests/cli_fit2d.rs) run the whole fit on pictures.

use std::path::Path;

use implicitize::goal2d::{self, ImageOptions, Luminance};

use crate::tests::support::pictures::Picture;

fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    color: png::ColorType,
    data: &[u8],
    configure: impl FnOnce(&mut png::Encoder<std::io::BufWriter<std::fs::File>>),
) {
    write_png_depth(path, width, height, color, png::BitDepth::Eight, data, configure)
}

fn write_png_depth(
    path: &Path,
    width: usize,
    height: usize,
    color: png::ColorType,
    depth: png::BitDepth,
    data: &[u8],
    configure: impl FnOnce(&mut png::Encoder<std::io::BufWriter<std::fs::File>>),
) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut encoder = png::Encoder::new(file, width as u32, height as u32);
    encoder.set_color(color);
    encoder.set_depth(depth);
    configure(&mut encoder);
    let mut writer = encoder.write_header().unwrap();
    writer.write_image_data(data).unwrap();
    writer.finish().unwrap();
}

#[test]
fn the_threshold_decides_which_greys_are_inside() {
    // White picture with a 0.3 grey block on the left and a 0.7 grey block on the right.
    let mut picture = Picture::filled(60, 30, 255);
    picture.block((5, 5, 20, 20), 77);
    picture.block((35, 5, 20, 20), 179);
    let image =
        Luminance { width: picture.width, height: picture.height, values: picture.luminance() };
    let inside_columns = |threshold: f32| {
        let options = ImageOptions { threshold, ..ImageOptions::default() };
        let (density, _) = goal2d::density(&image, &options, Path::new("grey.png")).unwrap();
        (0..60).filter(|&i| *density.get([i, 15, 0]) > 0.5).count()
    };
    assert_eq!(inside_columns(0.5), 20);
    assert_eq!(inside_columns(0.8), 40);
    let none = ImageOptions { threshold: 0.2, ..ImageOptions::default() };
    let message = goal2d::density(&image, &none, Path::new("grey.png")).unwrap_err().to_string();
    assert!(message.contains("grey.png") && message.contains("no pixel is inside"), "{message}");
}

#[test]
fn the_blur_rounds_corners_and_antialiases_the_densities() {
    let mut picture = Picture::filled(60, 60, 255);
    picture.block((15, 15, 30, 30), 0);
    let image = Luminance { width: 60, height: 60, values: picture.luminance() };
    let path = Path::new("square.png");
    let (sharp, _) = goal2d::density(&image, &ImageOptions::default(), path).unwrap();
    let blur = ImageOptions { blur: 3.0, ..ImageOptions::default() };
    let (soft, _) = goal2d::density(&image, &blur, path).unwrap();
    // Pixel (15, 15) from the top is grid voxel (15, 60 - 1 - 15): the square's corner.
    let corner = [15, 44, 0];
    let edge_middle = [15, 30, 0];
    assert_eq!(*sharp.get(corner), 1.0);
    assert!(*soft.get(corner) < 0.5, "the blurred corner is cut: {}", soft.get(corner));
    assert!(*soft.get(edge_middle) > 0.5, "the middle of an edge stays: {}", soft.get(edge_middle));
    assert!(sharp.data.iter().all(|&d| d == 0.0 || d == 1.0));
    let fractional = soft.data.iter().filter(|&&d| d > 0.0 && d < 1.0).count();
    assert!(fractional >= 60, "{fractional} fractional densities");
}

#[test]
fn every_png_colour_type_reads_as_the_same_luminance() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (4, 2);
    let grey: Vec<u8> = vec![0, 64, 128, 255, 255, 200, 30, 0];
    let expected: Vec<f32> = grey.iter().map(|&g| f32::from(g) / 255.0).collect();
    let close = |path: &Path| {
        let read = Luminance::read_png(path).unwrap();
        assert_eq!((read.width, read.height), (w, h));
        for (a, b) in read.values.iter().zip(&expected) {
            assert!((a - b).abs() < 2e-3, "{}: {:?}", path.display(), read.values);
        }
    };
    let path = dir.path().join("grey.png");
    write_png(&path, w, h, png::ColorType::Grayscale, &grey, |_| {});
    close(&path);

    let rgb: Vec<u8> = grey.iter().flat_map(|&g| [g, g, g]).collect();
    let path = dir.path().join("rgb.png");
    write_png(&path, w, h, png::ColorType::Rgb, &rgb, |_| {});
    close(&path);

    // Black at varying opacity over white: luminance 1 - alpha.
    let rgba: Vec<u8> = grey.iter().flat_map(|&g| [0, 0, 0, 255 - g]).collect();
    let path = dir.path().join("rgba.png");
    write_png(&path, w, h, png::ColorType::Rgba, &rgba, |_| {});
    close(&path);

    let grey16: Vec<u8> = grey.iter().flat_map(|&g| (u16::from(g) * 257).to_be_bytes()).collect();
    let path = dir.path().join("grey16.png");
    write_png_depth(
        &path,
        w,
        h,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &grey16,
        |_| {},
    );
    close(&path);

    let palette: Vec<u8> = grey.iter().flat_map(|&g| [g, g, g]).collect();
    let indices: Vec<u8> = (0..grey.len() as u8).collect();
    let path = dir.path().join("palette.png");
    write_png(&path, w, h, png::ColorType::Indexed, &indices, |e| e.set_palette(palette));
    close(&path);
}
