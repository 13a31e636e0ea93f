//! Fuzzes the STL mesh reader: any bytes give a mesh or an error, never a panic.
#![no_main]

use implicitize::mesh::{self, Format};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = mesh::read_bytes(bytes, Format::Stl, std::path::Path::new("fuzz.stl"));
});
