//! The library's public modules, listed: a module made public, or one made private, is a
//! deliberate change of the API and changes this list. Internals (the fit's surface disks, the
//! solver's and evaluator's parts in `rbf`) and the paper's figures (drawn by the command) are
//! not public.

use std::fs;
use std::path::{Path, PathBuf};

/// Every public module, by path from the crate root.
const PUBLIC_MODULES: &[&str] = &[
    "batch",
    "bound",
    "edt",
    "error",
    "field",
    "fit",
    "fit::detail",
    "fit::naive",
    "geometry",
    "goal2d",
    "grid",
    "memory",
    "mesh",
    "mesh_query",
    "mesh_query::grid",
    "metrics",
    "metrics::surface",
    "model",
    "morph",
    "npy",
    "output",
    "pipeline",
    "polygonize",
    "rbf",
    "render",
    "sample",
    "shader",
    "shape",
    "shape::csg",
    "voxelize",
    "voxelize::shell",
];

/// The `pub mod NAME;` declarations of the module in `file`, whose submodules' files are in
/// `dir`, and recursively theirs, as paths under `prefix`. Restricted visibilities (`pub(crate)`)
/// are not public and do not match.
fn public_modules(file: &Path, dir: &Path, prefix: &str, found: &mut Vec<String>) {
    let source = fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    for line in source.lines() {
        let Some(rest) = line.trim().strip_prefix("pub mod ") else { continue };
        let name = rest
            .strip_suffix(';')
            .unwrap_or_else(|| panic!("{}: an inline public module: {line}", file.display()));
        let path = if prefix.is_empty() { name.to_string() } else { format!("{prefix}::{name}") };
        let flat = dir.join(format!("{name}.rs"));
        let child = if flat.is_file() { flat } else { dir.join(name).join("mod.rs") };
        public_modules(&child, &dir.join(name), &path, found);
        found.push(path);
    }
}

#[test]
fn the_public_modules_are_the_listed_ones() {
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut found = Vec::new();
    public_modules(&src.join("lib.rs"), &src, "", &mut found);
    found.sort();
    assert_eq!(found, PUBLIC_MODULES);
}
