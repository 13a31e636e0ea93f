//! RGBA pictures: writing PNG, strips of pictures side by side, coverage masks.

use std::path::Path;

use crate::error::{Error, Result};

/// An 8-bit RGBA picture, rows from the top, pixels from the left.
///
/// Background pixels (where no surface is) are fully transparent, `[0, 0, 0, 0]`; every pixel
/// that shows a surface is opaque.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width * height` pixels of 4 bytes (red, green, blue, alpha), row by row.
    pub rgba: Vec<u8>,
}

impl Image {
    /// A transparent picture.
    pub fn empty(width: usize, height: usize) -> Image {
        Image { width, height, rgba: vec![0; width * height * 4] }
    }

    /// The pixel at column `x`, row `y`, or `None` outside the picture (or past the end of a
    /// `rgba` shorter than its size says).
    pub fn pixel(&self, x: usize, y: usize) -> Option<[u8; 4]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y * self.width + x) * 4;
        Some([self.rgba[i], self.rgba[i + 1], self.rgba[i + 2], self.rgba[i + 3]])
    }

    /// Which pixels show a surface (the silhouette mask), row by row.
    pub fn coverage(&self) -> Vec<bool> {
        self.rgba.chunks_exact(4).map(|p| p[3] != 0).collect()
    }

    /// The pictures placed left to right, top-aligned, on a transparent strip as tall as the
    /// tallest; an empty list gives a 0 x 0 picture. Used for a fit's iteration snapshots
    /// (the paper's figure 1) and for a mesh beside its implicit surface (figures 4 and 5).
    pub fn side_by_side(images: &[Image]) -> Image {
        let width = images.iter().map(|im| im.width).sum();
        let height = images.iter().map(|im| im.height).max().unwrap_or(0);
        let mut out = Image::empty(width, height);
        let mut left = 0;
        for im in images.iter().filter(|im| im.width > 0) {
            for (y, row) in im.rgba.chunks_exact(im.width * 4).take(im.height).enumerate() {
                let start = (y * width + left) * 4;
                out.rgba[start..start + row.len()].copy_from_slice(row);
            }
            left += im.width;
        }
        out
    }

    /// Writes the picture as an 8-bit RGBA PNG, atomically ([`crate::output`]).
    ///
    /// Fails when the file cannot be written or the picture has no pixels.
    pub fn save_png(&self, path: &Path) -> Result<()> {
        if self.width == 0 || self.height == 0 || self.rgba.len() != self.width * self.height * 4 {
            return Err(Error::invalid(
                path.display().to_string(),
                format!("cannot write a {} x {} picture", self.width, self.height),
            ));
        }
        let (width, height) = match (u32::try_from(self.width), u32::try_from(self.height)) {
            (Ok(w), Ok(h)) => (w, h),
            _ => {
                return Err(Error::invalid(path.display().to_string(), "the picture is too large"));
            }
        };
        let fail = |e: png::EncodingError| match e {
            png::EncodingError::IoError(io) => Error::io(path, io),
            other => Error::invalid(path.display().to_string(), other.to_string()),
        };
        crate::output::write_with(path, |out| {
            let mut encoder = png::Encoder::new(out, width, height);
            encoder.set_color(png::ColorType::Rgba);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header().map_err(fail)?;
            writer.write_image_data(&self.rgba).map_err(fail)?;
            writer.finish().map_err(fail)
        })
    }
}
