//! Grey pictures drawn from rectangles, the images of the 2D fit's tests (`goal2d` and
//! `implicitize fit2d`), and their writing as PNG.

use std::path::Path;

/// A grey picture, luminance 0..=255, rows from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Picture {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// Each pixel's grey, row after row from the top.
    pub grey: Vec<u8>,
}

impl Picture {
    /// A picture of one grey.
    pub fn filled(width: usize, height: usize, grey: u8) -> Picture {
        Picture { width, height, grey: vec![grey; width * height] }
    }

    /// Fills the rectangle at (left, top) of size w x h.
    pub fn block(&mut self, (left, top, w, h): (usize, usize, usize, usize), grey: u8) {
        for y in top..top + h {
            self.grey[y * self.width + left..y * self.width + left + w].fill(grey);
        }
    }

    /// The grey at column `x` of row `y` (from the top).
    pub fn at(&self, x: usize, y: usize) -> u8 {
        self.grey[y * self.width + x]
    }

    /// The picture with each grey `g` made `255 - g`.
    pub fn inverted(&self) -> Picture {
        Picture { grey: self.grey.iter().map(|g| 255 - g).collect(), ..*self }
    }

    /// The greys as luminance in [0, 1].
    pub fn luminance(&self) -> Vec<f32> {
        self.grey.iter().map(|&g| f32::from(g) / 255.0).collect()
    }

    /// Writes the picture as an 8-bit grey PNG.
    pub fn save(&self, path: &Path) {
        let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
        let mut encoder = png::Encoder::new(file, self.width as u32, self.height as u32);
        encoder.set_color(png::ColorType::Grayscale);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(&self.grey).unwrap();
        writer.finish().unwrap();
    }
}
