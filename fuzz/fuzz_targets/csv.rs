//! Fuzzes the CSV readers of points (`eval`) and constraints (`solve`): any bytes give rows
//! or an error, never a panic.
#![no_main]

use implicitize::rbf::{read_constraints_bytes, read_points_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let path = std::path::Path::new("fuzz.csv");
    let _ = read_points_bytes(bytes, path);
    let _ = read_constraints_bytes(bytes, path);
});
