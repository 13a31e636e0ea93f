//! Writes a logo-like test picture for `implicitize fit2d`: the letters "GI" as thick black
//! blocks on white, 320 x 220 pixels, 8-bit grey PNG. The figure 2 of docs/cli.md comes from it:
//!
//! ```text
//! cargo run --release --example gi_logo -- docs/images/gi.png
//! implicitize fit2d docs/images/gi.png --blur 4 -o gi.json --figure docs/images/figure2.png
//! ```

use std::fs::File;
use std::io::BufWriter;

/// Picture size, pixels.
const WIDTH: usize = 160 * SCALE;
const HEIGHT: usize = 110 * SCALE;

/// Picture pixels per unit of the blocks below.
const SCALE: usize = 2;

/// The letters' blocks as (left, top, width, height), in units of `SCALE` pixels.
const BLOCKS: [(usize, usize, usize, usize); 8] = [
    // G: top, left, bottom, right leg below the middle, inward bar.
    (15, 15, 70, 16),
    (15, 15, 16, 80),
    (15, 79, 70, 16),
    (69, 53, 16, 42),
    (50, 53, 35, 14),
    // I: stem, top and bottom serifs.
    (113, 15, 16, 80),
    (99, 15, 44, 14),
    (99, 81, 44, 14),
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: gi_logo OUTPUT.png")?;
    let mut pixels = vec![255u8; WIDTH * HEIGHT];
    for block in BLOCKS {
        let (left, top, w, h) =
            (block.0 * SCALE, block.1 * SCALE, block.2 * SCALE, block.3 * SCALE);
        for y in top..top + h {
            pixels[y * WIDTH + left..y * WIDTH + left + w].fill(0);
        }
    }
    let mut encoder =
        png::Encoder::new(BufWriter::new(File::create(&path)?), WIDTH as u32, HEIGHT as u32);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header()?.write_image_data(&pixels)?;
    Ok(())
}
