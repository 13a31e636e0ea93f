//! Fuzzes the PNG goal reader of `fit2d`: any bytes give a picture's luminance or an error,
//! never a panic.
#![no_main]

use implicitize::goal2d::Luminance;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = Luminance::read_png_bytes(bytes, std::path::Path::new("fuzz.png"));
});
