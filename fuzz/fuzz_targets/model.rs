//! Fuzzes the model file reader (binary and JSON, single models and CSG composites): any bytes
//! give a model or an error, never a panic; a model that loads is evaluated at its bounds'
//! centre and corner.
#![no_main]

use implicitize::{Field, Model};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    if let Ok(model) = Model::from_file_bytes(bytes, std::path::Path::new("fuzz.imp")) {
        let bounds = model.bounds();
        let _ = model.values(&[bounds.center(), bounds.max]);
    }
});
