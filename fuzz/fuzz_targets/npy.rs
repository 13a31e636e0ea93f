//! Fuzzes the NumPy point reader of `eval`: any bytes give rows or an error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = implicitize::npy::read_rows_bytes(bytes, std::path::Path::new("fuzz.npy"));
});
