//! A 2D goal shape from a picture (paper figure 2): the image is blurred, thresholded, and
//! turned into a density volume on a 2D grid (`nz = 1`) that the fit of [`crate::fit`] takes as
//! it takes a voxelized mesh.
//!
//! The paper's 2D goal was "obtained from blurring and thresholding the Graphics Interface
//! logo". Here:
//!
//! 1. `Luminance::read_png` reads a PNG (grey, grey + alpha, RGB, RGBA or palette, 1 to 16
//!    bits) as luminance in [0, 1], `0.2126 R + 0.7152 G + 0.0722 B` on the stored values,
//!    transparent pixels composited over white (so a logo on a transparent background reads as
//!    dark on white).
//! 2. `Luminance::blurred` applies an optional Gaussian blur (sigma in pixels, edges
//!    replicated), which rounds the corners of a sharp logo.
//! 3. `density` thresholds it: a pixel is inside where its luminance is below the threshold
//!    (dark inside), or above it with [`ImageOptions::invert`]. The densities are antialiased to
//!    sub-pixel precision: `clamp(1/2 + d, 0, 1)` where `d` is the first-order distance (in
//!    pixels, inside positive) from the pixel centre to the threshold contour,
//!    `(threshold - L) / |∇L|`. Densities therefore cross 1/2 on the blurred image's threshold
//!    contour, where the fit's boundary constraints go; a sharp black and white image gives
//!    densities of 0 and 1 and a contour halfway between pixel centres.
//!
//! ## Pixels and the grid
//! One voxel per pixel, of side 1: model units are pixels. Pixel `(x, y)` of the image (column
//! `x` from the left, row `y` from the top) is the point `(x, height - 1 - y)` in model units,
//! y pointing up. When the shape comes closer than [`Grid::MARGIN`] pixels to a side of the
//! picture, empty pixels are added on that side, so the grid's voxel `(i, j, 0)` is pixel
//! `(i - left, height - 1 - (j - bottom))` for the `left` and `bottom` margins added; the grid's
//! origin is `(-left, -bottom, 0)` so that model coordinates do not depend on the margins.
//!
//! Densities are f32 like every volume of the crate; the blur and the threshold are computed
//! in f32 too, far more precise than the 8 or 16 bits of the input.

use std::path::Path;

use crate::error::{Error, Result};
use crate::geometry::{Aabb, DVec3};
use crate::grid::{Grid, Volume};

/// A picture's luminance in [0, 1] (0 black, 1 white), rows from the top.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Luminance {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width * height` values, row by row from the top, pixels from the left.
    pub values: Vec<f32>,
}

/// How a picture becomes a goal shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageOptions {
    /// Luminance below which a pixel is inside (above which with `invert`), in [0, 1].
    pub threshold: f32,
    /// The standard deviation of the Gaussian blur applied before thresholding, in pixels;
    /// 0 for none.
    pub blur: f64,
    /// Light pixels are inside instead of dark ones.
    pub invert: bool,
}

impl Default for ImageOptions {
    /// Threshold 1/2, no blur, dark inside.
    fn default() -> Self {
        ImageOptions { threshold: 0.5, blur: 0.0, invert: false }
    }
}

/// The most bytes of pixels a PNG's bytes can decode to: deflate expands at most 1032 times;
/// a file that declares more cannot hold its pixels, and is refused before decoding.
pub(crate) const MAX_INFLATION: u64 = 1032;

/// The largest blur accepted, in pixels.
pub(crate) const MAX_BLUR: f64 = 100.0;

impl Luminance {
    /// Reads a PNG file as luminance.
    ///
    /// Fails with the file's name when it cannot be read, is not a PNG, or is larger than
    /// [`Grid::MAX_AXIS`] pixels along a side.
    pub fn read_png(path: &Path) -> Result<Luminance> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Luminance::read_png_bytes(&bytes, path)
    }

    /// Reads the bytes of a PNG file as luminance; `path` names it in messages.
    ///
    /// Fails as `Luminance::read_png`, and also, before decoding, when the pixels its header
    /// declares could not come from so few bytes (more than 1,032 times the file, the most deflate can inflate).
    pub fn read_png_bytes(bytes: &[u8], path: &Path) -> Result<Luminance> {
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::EXPAND);
        let fail = |e: png::DecodingError| match e {
            png::DecodingError::IoError(io) if io.kind() != std::io::ErrorKind::UnexpectedEof => {
                Error::io(path, io)
            }
            png::DecodingError::IoError(_) => {
                Error::parse(path, None, "not a PNG image, or a truncated one")
            }
            other => Error::parse(path, None, format!("not a readable PNG image: {other}")),
        };
        let mut reader = decoder.read_info().map_err(fail)?;
        let (width, height) = {
            let info = reader.info();
            (info.width as usize, info.height as usize)
        };
        if width > Grid::MAX_AXIS || height > Grid::MAX_AXIS {
            return Err(Error::invalid(
                path.display().to_string(),
                format!(
                    "a {width} x {height} image is larger than {} pixels along a side",
                    Grid::MAX_AXIS
                ),
            ));
        }
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| Error::parse(path, None, "the image is too large to decode"))?;
        if size as u64 > MAX_INFLATION.saturating_mul(bytes.len() as u64) {
            return Err(Error::parse(
                path,
                None,
                format!(
                    "the header declares {width} x {height} pixels ({size} bytes decoded), more \
                     than its {} bytes can hold",
                    bytes.len()
                ),
            ));
        }
        let mut buffer = vec![0u8; size];
        let frame = reader.next_frame(&mut buffer).map_err(fail)?;
        let values = luminance_of(&buffer[..frame.buffer_size()], &frame)
            .ok_or_else(|| Error::parse(path, None, "unsupported PNG pixel format"))?;
        Ok(Luminance { width, height, values })
    }

    /// The luminance at column `x`, row `y` (from the top).
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.values[y * self.width + x]
    }

    /// The picture blurred by a Gaussian of standard deviation `sigma` pixels (edges
    /// replicated), or a copy for `sigma = 0`.
    pub fn blurred(&self, sigma: f64) -> Luminance {
        if sigma <= 0.0 || self.values.is_empty() {
            return self.clone();
        }
        let kernel = gaussian_kernel(sigma);
        let (w, h) = (self.width, self.height);
        let mut rows = vec![0.0f32; w * h];
        for y in 0..h {
            let line = &self.values[y * w..(y + 1) * w];
            convolve(&kernel, w, |x| line[x], |x, v| rows[y * w + x] = v);
        }
        let mut out = vec![0.0f32; w * h];
        for x in 0..w {
            convolve(&kernel, h, |y| rows[y * w + x], |y, v| out[y * w + x] = v);
        }
        Luminance { width: w, height: h, values: out }
    }
}

/// The luminance of every pixel of a decoded 8- or 16-bit frame, alpha composited over white.
fn luminance_of(buffer: &[u8], frame: &png::OutputInfo) -> Option<Vec<f32>> {
    use png::ColorType;
    let channels = match frame.color_type {
        ColorType::Grayscale => 1,
        ColorType::GrayscaleAlpha => 2,
        ColorType::Rgb => 3,
        ColorType::Rgba => 4,
        ColorType::Indexed => return None,
    };
    let samples: Vec<f32> = match frame.bit_depth {
        png::BitDepth::Eight => buffer.iter().map(|&b| f32::from(b) / 255.0).collect(),
        png::BitDepth::Sixteen => buffer
            .chunks_exact(2)
            .map(|b| f32::from(u16::from_be_bytes([b[0], b[1]])) / 65535.0)
            .collect(),
        _ => return None,
    };
    let (width, height) = (frame.width as usize, frame.height as usize);
    let row = width * channels;
    let stride = samples.len() / height.max(1);
    if stride < row {
        return None;
    }
    let pixel = |p: &[f32]| -> f32 {
        let (l, alpha) = match p.len() {
            1 => (p[0], 1.0),
            2 => (p[0], p[1]),
            3 => (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2], 1.0),
            _ => (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2], p[3]),
        };
        alpha * l + (1.0 - alpha)
    };
    Some(
        samples
            .chunks_exact(stride)
            .take(height)
            .flat_map(|r| r[..row].chunks_exact(channels).map(pixel))
            .collect(),
    )
}

/// A normalized Gaussian of standard deviation `sigma`, out to 3 sigma.
fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let radius = (3.0 * sigma).ceil() as isize;
    let weights: Vec<f64> =
        (-radius..=radius).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp()).collect();
    let sum: f64 = weights.iter().sum();
    weights.iter().map(|w| (w / sum) as f32).collect()
}

/// Convolves a line of `n` values read by `get` with `kernel` (odd length, centred), edges
/// replicated, and hands each result to `set`.
fn convolve(kernel: &[f32], n: usize, get: impl Fn(usize) -> f32, mut set: impl FnMut(usize, f32)) {
    let radius = (kernel.len() / 2) as isize;
    for x in 0..n {
        let value = kernel
            .iter()
            .enumerate()
            .map(|(t, w)| {
                w * get((x as isize + t as isize - radius).clamp(0, n as isize - 1) as usize)
            })
            .sum();
        set(x, value);
    }
}

/// The antialiased inside densities of `image` thresholded as `options` say, row by row from
/// the top like the image (see the module documentation).
pub(crate) fn threshold(image: &Luminance, options: &ImageOptions) -> Vec<f32> {
    let (w, h) = (image.width, image.height);
    let sign = if options.invert { -1.0 } else { 1.0 };
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let s = sign * (options.threshold - image.at(x, y));
            let gx = derivative(w, x, |x| image.at(x, y));
            let gy = derivative(h, y, |y| image.at(x, y));
            let g = (gx * gx + gy * gy).sqrt();
            let density = if g > 1e-6 {
                (0.5 + s / g).clamp(0.0, 1.0)
            } else if s > 0.0 {
                1.0
            } else {
                0.0
            };
            out.push(density);
        }
    }
    out
}

/// The central difference of a line of `n` values at `x` (one-sided at the ends, 0 for one
/// value).
fn derivative(n: usize, x: usize, get: impl Fn(usize) -> f32) -> f32 {
    match (x.checked_sub(1), (x + 1 < n).then_some(x + 1)) {
        (Some(a), Some(b)) => 0.5 * (get(b) - get(a)),
        (Some(a), None) => get(x) - get(a),
        (None, Some(b)) => get(b) - get(x),
        (None, None) => 0.0,
    }
}

/// The goal shape of an image as a density volume on a 2D grid (one voxel per pixel, margins
/// added where the shape comes near the picture's sides), with its bounds in model units
/// (pixels, y up; see the module documentation).
///
/// `source` names the image in errors. Fails when the options are out of range, or when no
/// pixel or every pixel is inside.
pub(crate) fn density(
    image: &Luminance,
    options: &ImageOptions,
    source: &Path,
) -> Result<(Volume<f32>, Aabb)> {
    let name = source.display().to_string();
    check_options(options)?;
    let densities = threshold(&image.blurred(options.blur), options);
    let inside = densities.iter().filter(|&&d| d > 0.5).count();
    let side = if options.invert { "light" } else { "dark" };
    if inside == 0 {
        return Err(Error::invalid(
            name,
            format!(
                "no pixel is inside ({side} pixels are, at threshold {}); try `invert` or another `threshold`",
                options.threshold
            ),
        ));
    }
    if inside == densities.len() {
        return Err(Error::invalid(
            name,
            format!(
                "every pixel is inside ({side} pixels are, at threshold {}); try `invert` or another `threshold`",
                options.threshold
            ),
        ));
    }
    let (w, h) = (image.width, image.height);
    let occupied = |x: usize, y: usize| densities[y * w + x] > 0.0;
    let margins = Margins::around(w, h, occupied);
    let dims = [w + margins.left + margins.right, h + margins.bottom + margins.top, 1];
    if dims[0] > Grid::MAX_AXIS || dims[1] > Grid::MAX_AXIS {
        return Err(Error::invalid(name, "the image with its margins is too large"));
    }
    let grid = Grid {
        dims,
        origin: [0.0 - margins.left as f64, 0.0 - margins.bottom as f64, 0.0],
        voxel_size: 1.0,
    };
    let mut volume = Volume::filled(grid, 0.0f32);
    let mut corners: Vec<DVec3> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let d = densities[y * w + x];
            let (px, py) = (x as f64, (h - 1 - y) as f64);
            let (i, j) = (x + margins.left, h - 1 - y + margins.bottom);
            volume.data[grid.index([i, j, 0])] = d;
            if d > 0.5 {
                corners.push(DVec3::new(px - 0.5, py - 0.5, 0.0));
                corners.push(DVec3::new(px + 0.5, py + 0.5, 0.0));
            }
        }
    }
    let bounds = Aabb::of_points(&corners).expect("at least one pixel is inside");
    Ok((volume, bounds))
}

fn check_options(options: &ImageOptions) -> Result<()> {
    if !(0.0..=1.0).contains(&options.threshold) {
        return Err(Error::invalid(
            "options",
            format!("`threshold` {} is outside [0, 1]", options.threshold),
        ));
    }
    if !(0.0..=MAX_BLUR).contains(&options.blur) {
        return Err(Error::invalid(
            "options",
            format!("`blur` {} is outside [0, {MAX_BLUR}] pixels", options.blur),
        ));
    }
    Ok(())
}

/// Empty pixels to add on each side so that the shape is at least [`Grid::MARGIN`] pixels from
/// every side of the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Margins {
    left: usize,
    right: usize,
    bottom: usize,
    top: usize,
}

impl Margins {
    /// The margins for a `w x h` picture whose pixel `(x, y)` (row from the top) holds some of
    /// the shape when `occupied(x, y)`.
    fn around(w: usize, h: usize, occupied: impl Fn(usize, usize) -> bool) -> Margins {
        let (mut x0, mut x1, mut y0, mut y1) = (w, 0, h, 0);
        for y in 0..h {
            for x in 0..w {
                if occupied(x, y) {
                    (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
                }
            }
        }
        let need = |gap: usize| Grid::MARGIN.saturating_sub(gap);
        Margins {
            left: need(x0),
            right: need(w - 1 - x1.min(w - 1)),
            top: need(y0),
            bottom: need(h - 1 - y1.min(h - 1)),
        }
    }
}

/// Reads a PNG and makes its goal density volume and bounds (see `density`).
pub fn read_density(path: &Path, options: &ImageOptions) -> Result<(Volume<f32>, Aabb)> {
    density(&Luminance::read_png(path)?, options, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: usize, height: usize, f: impl Fn(usize, usize) -> f32) -> Luminance {
        let values = (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).collect::<Vec<_>>();
        Luminance { width, height, values: values.into_iter().map(|(x, y)| f(x, y)).collect() }
    }

    #[test]
    fn a_blurred_edge_moves_with_the_threshold_to_sub_pixel_precision() {
        // Black up to pixel 9, white from 10: the edge is at x = 9.5.
        let edge = image(20, 4, |x, _| if x < 10 { 0.0 } else { 1.0 });
        let sharp = threshold(&edge, &ImageOptions::default());
        assert_eq!(&sharp[..20], &[[1.0; 10], [0.0; 10]].concat()[..]);
        // Blurred by sigma = 2, the luminance is Phi((x - 9.5) / 2): it crosses 0.45 at
        // x = 9.5 - 2 * 0.1257 = 9.249, a quarter pixel right of pixel 9's centre.
        let options = ImageOptions { threshold: 0.45, ..ImageOptions::default() };
        let soft = threshold(&edge.blurred(2.0), &options);
        assert_eq!((soft[8], soft[10]), (1.0, 0.0), "{:?}", &soft[..20]);
        let crossing = 9.0 + (soft[9] - 0.5);
        assert!((crossing - 9.249).abs() < 0.03, "{crossing}: {:?}", &soft[..20]);
    }

    #[test]
    fn a_grey_ramp_places_the_contour_to_sub_pixel_precision() {
        // Luminance 0.1 per pixel: the 0.5 level is at x = 5.25 for threshold 0.525.
        let ramp = image(12, 3, |x, _| 0.1 * x as f32);
        let d = threshold(&ramp, &ImageOptions { threshold: 0.525, ..Default::default() });
        assert!((d[5] - 0.75).abs() < 1e-5 && (d[6] - 0.0).abs() < 1e-5, "{:?}", &d[..12]);
    }

    #[test]
    fn margins_are_added_only_where_the_shape_is_near_a_side() {
        let m = Margins::around(10, 10, |x, y| x <= 2 && (4..=6).contains(&y));
        assert_eq!(m, Margins { left: 3, right: 0, bottom: 0, top: 0 });
        let m = Margins::around(10, 10, |x, y| x >= 5 && y >= 8);
        assert_eq!(m, Margins { left: 0, right: 3, bottom: 3, top: 0 });
    }
}
