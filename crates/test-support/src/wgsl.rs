//! WGSL checked as a GPU driver would check it, by naga.

/// Parses and validates WGSL with naga, panicking with naga's diagnostics and the source when it
/// fails; returns the parsed module for further checks.
pub fn validate(source: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{}\n{source}", e.emit_to_string(source)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{}\n{source}", e.emit_to_string(source)));
    module
}
