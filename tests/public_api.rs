//! The library's public modules, constants and items, listed: a module, constant or item made
//! public, or made private, is a deliberate change of the API and changes these lists (the
//! items' list is tests/data/public-items.txt, which `IMPLICITIZE_BLESS=1 cargo test --test
//! public_api` writes). Internals (the fit's surface disks, the solver's and evaluator's parts
//! in `rbf`, the fit's tuning values) and the paper's figures (drawn by the command) are not
//! public.

use std::fs;
use std::path::{Path, PathBuf};

/// Every public module, by path from the crate root.
const PUBLIC_MODULES: &[&str] = &[
    "batch",
    "bound",
    "edt",
    "fit",
    "goal2d",
    "grid",
    "memory",
    "mesh",
    "model",
    "morph",
    "npy",
    "output",
    "pipeline",
    "pipeline::settings",
    "polygonize",
    "rbf",
    "render",
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

/// Every public constant at a file's top level, as `module::NAME` by the file it is defined in:
/// the limits, formats and defaults a user may read. The fit's tuning values are
/// `pub(crate)`; making one public is a decision that changes this list.
const PUBLIC_CONSTANTS: &[&str] = &[
    "batch::MANIFEST",
    "fit::report::REPORT_VERSION",
    "grid::VOLUME_HEADER_VERSION",
    "model::FORMAT",
    "model::VERSION",
    "model::binary::MAGIC",
    "model::binary::VERSION",
    "rbf::isa::ENV",
];

#[test]
fn the_public_constants_are_the_listed_ones() {
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut found = Vec::new();
    let mut folders = vec![src.clone()];
    while let Some(folder) = folders.pop() {
        for entry in fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                folders.push(path);
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let relative = path.strip_prefix(&src).unwrap().with_extension("");
            let mut module: Vec<String> =
                relative.iter().map(|p| p.to_string_lossy().into_owned()).collect();
            if module.last().is_some_and(|m| m == "mod" || m == "lib") {
                module.pop();
            }
            for line in fs::read_to_string(&path).unwrap().lines() {
                let Some(rest) = line.strip_prefix("pub const ") else { continue };
                let name: String =
                    rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                let mut item = module.clone();
                item.push(name);
                found.push(item.join("::"));
            }
        }
    }
    found.sort();
    assert_eq!(found, PUBLIC_CONSTANTS);
}

/// Every top-level public item of the crate's public modules and its root (functions, types,
/// traits, constants and statics by `module::name`; each name a re-export brings in as
/// `module::name = path`, so that a re-exported item counts where it can be named), one a
/// line in tests/data/public-items.txt: an item made public, or private, is a decision that
/// changes that file. `IMPLICITIZE_BLESS=1 cargo test --test public_api` writes it; the test
/// fails while it differs.
#[test]
fn the_public_items_are_the_listed_ones() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let src = root.join("src");
    let mut modules = Vec::new();
    public_modules(&src.join("lib.rs"), &src, "", &mut modules);
    let mut items = items_of(&src.join("lib.rs"), "");
    for module in &modules {
        let relative: PathBuf = module.split("::").collect();
        let flat = src.join(&relative).with_extension("rs");
        let file = if flat.is_file() { flat } else { src.join(&relative).join("mod.rs") };
        items.extend(items_of(&file, module));
    }
    items.sort();
    let listed = root.join("tests/data/public-items.txt");
    let text = items.iter().map(|item| format!("{item}\n")).collect::<String>();
    if std::env::var_os("IMPLICITIZE_BLESS").is_some() {
        fs::write(&listed, &text).unwrap();
    }
    let want = fs::read_to_string(&listed).unwrap_or_default();
    assert!(
        want == text,
        "the public items are not those of {} ({} now): IMPLICITIZE_BLESS=1 cargo test --test \
         public_api writes them",
        listed.display(),
        items.len()
    );
}

/// The top-level public items of `file` (module `module`), as the test above lists them.
fn items_of(file: &Path, module: &str) -> Vec<String> {
    let source = fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let prefix = if module.is_empty() { String::new() } else { format!("{module}::") };
    let mut items = Vec::new();
    let mut lines = source.lines();
    while let Some(line) = lines.next() {
        if let Some(rest) = line.strip_prefix("pub use ") {
            let mut path = rest.to_string();
            while !path.ends_with(';') {
                let Some(next) = lines.next() else { break };
                path.push(' ');
                path.push_str(next.trim());
            }
            let path = path.trim_end_matches(';').split_whitespace().collect::<Vec<_>>().join(" ");
            for (name, source) in reexported(&path) {
                items.push(format!("{prefix}{name} = {source}"));
            }
            continue;
        }
        let kinds = ["fn ", "struct ", "enum ", "trait ", "type ", "const ", "static "];
        let Some(rest) = line.strip_prefix("pub ") else { continue };
        let Some(rest) = kinds.iter().find_map(|k| rest.strip_prefix(k)) else { continue };
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        items.push(format!("{prefix}{name}"));
    }
    items
}

/// The names a `pub use` path brings in (`a::{B, c::D as E}` gives `B` and `E`), each with the
/// path it names.
fn reexported(path: &str) -> Vec<(String, String)> {
    let Some(open) = path.find('{') else {
        let (source, name) = match path.split_once(" as ") {
            Some((source, alias)) => (source.trim(), alias.trim()),
            None => (path.trim(), path.rsplit("::").next().unwrap_or(path).trim()),
        };
        return vec![(name.to_string(), source.to_string())];
    };
    let prefix = &path[..open];
    let inner = &path[open + 1..path.rfind('}').expect("a closing brace")];
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .into_iter()
        .map(str::trim)
        .filter(|part| !part.is_empty())
        .flat_map(|part| reexported(&format!("{prefix}{part}")))
        .collect()
}
