//! The modules of every crate of the workspace form layers: in every module that has children
//! (the library itself, `rbf`, `fit`, `rbf::kernel`, ..., the command and its `cli`, the
//! Python extension), no child refers to a sibling that refers back to it, directly or through
//! others. So a stage never imports the front door that chains it. (The Python package's own
//! modules are held to the same by python/tests/test_layers.py.)
//!
//! The children of a module are its files and folders: a file `x.rs` and the folder `x/` count
//! as one child `x`. The module's own file (`lib.rs` or `main.rs` for a crate, `mod.rs`, or `x.rs` beside
//! a folder `x/`) is the facade above them: it defines shared types and re-exports items of
//! its children; using a type it defines is no edge, using an item it re-exports is an edge
//! to the child that defines it.
//!
//! An edge `x -> y` is a path in `x`'s source, test modules included, that names `y`:
//! `super::y`, `super::super::y`, `crate::<module>::y` or an item of `y` re-exported by the
//! facade, in a `use` or in code. Method calls are not paths, so a call through a method of a
//! facade type is no edge; glob imports of the facade (`use super::*` from a child) name
//! nothing and are no edge either. Doc links are comments and name nothing.
//!
//! Not followed (neither occurs in `src`): paths through the crate's re-exports from inside a
//! nested module (`crate::Implicit` in a child of `fit`), and groups that open at the crate
//! (`crate::{fit::x, rbf::y}`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module's dependencies: the other modules it names.
type Graph = BTreeMap<String, BTreeSet<String>>;

/// A module with children: its crate's source folder, its path from the crate (empty for the
/// crate) and its folder.
struct Parent {
    krate: &'static str,
    path: Vec<String>,
    folder: PathBuf,
}

/// The source folders of the workspace's crates: the library, the command, the Python
/// extension and the tests' shared data.
const CRATES: [&str; 4] =
    ["src", "crates/implicitize-cli/src", "python/src", "crates/test-support/src"];

#[test]
fn no_module_has_children_in_an_import_cycle() {
    let parents = parents();
    assert!(parents.len() >= 14, "too few modules with children: {}", parents.len());
    for parent in &parents {
        let graph = graph_of(&read_folder(&parent.folder), &parent.path);
        if let Some(cycle) = find_cycle(&graph) {
            panic!(
                "the children of `crate{}` ({}) refer to each other in a cycle: {}",
                parent.path.iter().map(|p| format!("::{p}")).collect::<String>(),
                parent.krate,
                cycle.join(" -> ")
            );
        }
    }
}

/// No stage names the front door: outside `pipeline` itself, only the crate's facade and
/// `batch` (a front door over many fits) name `crate::pipeline` in code.
#[test]
fn only_the_front_doors_name_the_pipeline() {
    let files = read_folder(&src());
    assert!(files.len() > 30, "too few files: {}", files.len());
    for (path, text) in &files {
        let front_door = path.starts_with("pipeline")
            || ["lib.rs", "batch.rs"].contains(&path.to_str().unwrap());
        let tokens = tokens(text);
        let names = tokens.windows(3).any(|w| {
            (w[0] == "crate" || (w[0] == "super" && path.components().count() == 1))
                && w[1] == "::"
                && w[2] == "pipeline"
        });
        assert!(front_door || !names, "{} names crate::pipeline", path.display());
    }
}

/// The check sees the layers the module docs describe, so that it is not vacuous: in `rbf`,
/// the loops under the treecode, evaluation and the solves, the dense factorization under both
/// solves; in the crate, the front door above the stages it chains.
#[test]
fn the_graph_has_the_layers_of_the_module_docs() {
    let rbf = graph_of(&read_folder(&src().join("rbf")), &["rbf".to_string()]);
    for (from, to) in [
        ("kernel", "isa"),
        ("treecode", "kernel"),
        ("evaluate", "treecode"),
        ("evaluate", "kernel"),
        ("dense", "kernel"),
        ("schwarz", "dense"),
        ("iterative", "schwarz"),
        ("iterative", "gmres"),
        ("solve", "dense"),
        ("solve", "iterative"),
    ] {
        assert!(rbf[from].contains(to), "no edge rbf::{from} -> {to} in {rbf:?}");
    }
    let krate = graph_of(&read_folder(&src()), &[]);
    for (from, to) in [
        ("pipeline", "fit"),
        ("pipeline", "sample"),
        ("pipeline", "memory"),
        ("pipeline", "voxelize"),
        ("batch", "pipeline"),
        ("fit", "rbf"),
        ("model", "shape"),
    ] {
        assert!(krate[from].contains(to), "no edge {from} -> {to} in {krate:?}");
    }
}

/// A cycle through a re-exported item, a nested file and a test module is found and named.
#[test]
fn a_cycle_is_found_and_named() {
    let files = [
        ("mod.rs", "mod a; mod b; pub use a::{Thing as Alias, Other};"),
        ("a.rs", "use super::b::helper; pub struct Thing;"),
        ("b/mod.rs", "mod inner; fn helper() {}"),
        ("b/inner.rs", "#[cfg(test)] mod tests { use super::super::super::Alias; }"),
    ];
    let files: Vec<(PathBuf, String)> =
        files.iter().map(|(p, s)| (PathBuf::from(p), s.to_string())).collect();
    let rbf = ["rbf".to_string()];
    let graph = graph_of(&files, &rbf);
    assert_eq!(find_cycle(&graph), Some(vec!["a".into(), "b".into(), "a".into()]));
    let acyclic = &files[..3];
    assert_eq!(find_cycle(&graph_of(acyclic, &rbf)), None);
}

/// At the crate's top, `crate::y` names a child and `lib.rs` is the facade; inside a nested
/// module, `crate::` paths name a child only through the module's whole path.
#[test]
fn crate_paths_are_resolved_from_the_module_they_name() {
    let top = [
        ("lib.rs", "pub mod a; pub mod b; pub use b::Thing;"),
        ("a.rs", "use crate::Thing;"),
        ("b.rs", "pub struct Thing; fn f() { crate::a::g(); }"),
    ];
    let top: Vec<(PathBuf, String)> =
        top.iter().map(|(p, s)| (PathBuf::from(p), s.to_string())).collect();
    assert_eq!(find_cycle(&graph_of(&top, &[])), Some(vec!["a".into(), "b".into(), "a".into()]));
    let nested = [
        ("x.rs", "use crate::m::n::y::f; use crate::m::y::g; use crate::y::h;"),
        ("y.rs", "pub fn f() {}"),
    ];
    let nested: Vec<(PathBuf, String)> =
        nested.iter().map(|(p, s)| (PathBuf::from(p), s.to_string())).collect();
    let graph = graph_of(&nested, &["m".to_string(), "n".to_string()]);
    assert_eq!(graph["x"], BTreeSet::from(["y".to_string()]));
}

/// The library's `src` folder.
fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every crate of the workspace and every module of it that is a folder, with its path from
/// its crate.
fn parents() -> Vec<Parent> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut parents: Vec<Parent> = CRATES
        .iter()
        .map(|&krate| Parent { krate, path: Vec::new(), folder: root.join(krate) })
        .collect();
    let mut i = 0;
    while i < parents.len() {
        let mut children: Vec<PathBuf> = std::fs::read_dir(&parents[i].folder)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_dir())
            .collect();
        children.sort();
        for folder in children {
            let mut path = parents[i].path.clone();
            path.push(folder.file_name().unwrap().to_string_lossy().into_owned());
            parents.push(Parent { krate: parents[i].krate, path, folder });
        }
        i += 1;
    }
    parents
}

/// Every `.rs` file under `root`, by its path relative to `root`, with a facade beside the
/// folder (`root.rs` for `root/`) as `mod.rs`.
fn read_folder(root: &Path) -> Vec<(PathBuf, String)> {
    let root = root.to_path_buf();
    let mut files = Vec::new();
    let beside = root.with_extension("rs");
    if beside.is_file() {
        files.push((PathBuf::from("mod.rs"), std::fs::read_to_string(&beside).unwrap()));
    }
    let mut folders = vec![root.clone()];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                folders.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                files.push((path.strip_prefix(&root).unwrap().to_path_buf(), text));
            }
        }
    }
    files.sort();
    files
}

/// The dependency graph of the children of the module at `parent` (its path from the crate)
/// given its files (paths relative to its folder).
fn graph_of(files: &[(PathBuf, String)], parent: &[String]) -> Graph {
    let modules: BTreeSet<String> =
        files.iter().filter_map(|(path, _)| module_path(path).first().cloned()).collect();
    let facade = files.iter().find(|(path, _)| module_path(path).is_empty());
    let reexports = facade.map(|(_, text)| reexports(&tokens(text), &modules)).unwrap_or_default();
    let mut graph: Graph = modules.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    for (path, text) in files {
        let base = module_path(path);
        let Some(module) = base.first() else { continue };
        for named in named_items(&tokens(text), &base, parent) {
            let target =
                if modules.contains(&named) { Some(&named) } else { reexports.get(&named) };
            if let Some(target) = target.filter(|t| *t != module) {
                graph.get_mut(module).unwrap().insert(target.clone());
            }
        }
    }
    graph
}

/// The module path of a file below the parent's folder: `x.rs` and `x/mod.rs` are `[x]`,
/// `x/y.rs` is `[x, y]`, the facade `mod.rs` (a crate's `lib.rs` or `main.rs`) is `[]`.
fn module_path(path: &Path) -> Vec<String> {
    if path == Path::new("lib.rs") || path == Path::new("main.rs") {
        return Vec::new();
    }
    let mut parts: Vec<String> =
        path.iter().map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string()).collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// The tokens of Rust source that paths are made of: identifiers, `::` and the punctuation
/// `{ } , ; *`; comments, strings and characters dropped.
fn tokens(text: &str) -> Vec<String> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            i += 2;
            while i + 1 < chars.len() && !(chars[i] == '*' && chars[i + 1] == '/') {
                i += 1;
            }
            i += 2;
        } else if c == '"' {
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                i += if chars[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
        } else if c == '\'' && chars.get(i + 2) == Some(&'\'') {
            i += 3;
        } else if c == '\'' && next == Some('\\') {
            i += 2;
            while i < chars.len() && chars[i] != '\'' {
                i += 1;
            }
            i += 1;
        } else if c.is_alphanumeric() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push(chars[start..i].iter().collect());
        } else if c == ':' && next == Some(':') {
            out.push("::".into());
            i += 2;
        } else {
            if "{},;*".contains(c) {
                out.push(c.to_string());
            }
            i += 1;
        }
    }
    out
}

/// The names of the parent's children, and of the facade's re-exports, that the paths in a
/// file of module `base` (a path from the parent) name: each path is resolved from the module
/// it is written in (the file's, or an inline module's inside it) to a path from the parent,
/// whose first segment is the name. `parent` is the parent's path from the crate.
fn named_items(tokens: &[String], base: &[String], parent: &[String]) -> Vec<String> {
    let mut names = Vec::new();
    // The inline modules around the current token, with the brace depth each one opened at.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0;
    let mut i = 0;
    while i < tokens.len() {
        let t = tokens[i].as_str();
        let after_separator = i > 0 && tokens[i - 1] == "::";
        if t == "{" {
            depth += 1;
        } else if t == "}" {
            depth -= 1;
            if inline.last().is_some_and(|(_, d)| *d == depth) {
                inline.pop();
            }
        } else if t == "mod" && tokens.get(i + 2).is_some_and(|s| s == "{") {
            inline.push((tokens[i + 1].clone(), depth));
        } else if !after_separator && (t == "super" || t == "crate") {
            let mut here: Vec<String> = base.to_vec();
            here.extend(inline.iter().map(|(m, _)| m.clone()));
            let (resolved, next) = resolve(tokens, i, here, parent);
            match resolved {
                // At the parent itself: what follows names a child or an item of the facade.
                Some(here) if here.is_empty() => names.extend(first_segments(tokens, next)),
                // Inside a child of the parent: that child is named, whatever follows.
                Some(mut here) => names.push(here.swap_remove(0)),
                None => {}
            }
            i = next.max(i + 1);
            continue;
        }
        i += 1;
    }
    names
}

/// Follows the path starting at token `i` (`super::...` or `crate::...`) from the module
/// `here` (a path from the parent) for as long as it climbs (`super`) or enters the parent
/// (`crate::` and the parent's path): the module reached, as a path from the parent (`None`
/// outside the parent), and the index of the first token after the climb and its `::`.
fn resolve(
    tokens: &[String],
    mut i: usize,
    mut here: Vec<String>,
    parent: &[String],
) -> (Option<Vec<String>>, usize) {
    let separator = |k: usize| tokens.get(k).is_some_and(|t| t == "::");
    if tokens[i] == "crate" {
        if !separator(i + 1) {
            return (None, i + 1);
        }
        i += 2;
        for segment in parent {
            if !(tokens.get(i) == Some(segment) && separator(i + 1)) {
                return (None, i);
            }
            i += 2;
        }
        here.clear();
    }
    while tokens.get(i).is_some_and(|t| t == "super") && separator(i + 1) {
        if here.pop().is_none() {
            return (None, i + 2);
        }
        i += 2;
    }
    (Some(here), i)
}

/// The first segment of the path at token `i`, or of each path of the group `{ ... }` there;
/// `self` and globs name nothing.
fn first_segments(tokens: &[String], i: usize) -> Vec<String> {
    let Some(first) = tokens.get(i) else { return Vec::new() };
    if first != "{" {
        return [first.clone()].into_iter().filter(|t| t != "self" && t != "*").collect();
    }
    let mut names = Vec::new();
    let mut depth = 0;
    let mut starting = true;
    for t in &tokens[i..] {
        match t.as_str() {
            "{" => {
                depth += 1;
                starting = depth == 1;
            }
            "}" => {
                depth -= 1;
                if depth == 0 {
                    break;
                }
            }
            "," if depth == 1 => starting = true,
            name if starting && depth == 1 => {
                if name != "self" && name != "*" {
                    names.push(name.to_string());
                }
                starting = false;
            }
            _ => {}
        }
    }
    names
}

/// The facade's `use` items from its children (`pub use x::{A, B as C}`): each name it makes
/// visible, with the child it comes from.
fn reexports(tokens: &[String], modules: &BTreeSet<String>) -> BTreeMap<String, String> {
    let mut map = BTreeMap::new();
    for (i, t) in tokens.iter().enumerate() {
        if t != "use" || !tokens.get(i + 1).is_some_and(|m| modules.contains(m)) {
            continue;
        }
        let module = &tokens[i + 1];
        let end = tokens[i..].iter().position(|t| t == ";").map_or(tokens.len(), |k| i + k);
        // The name an item is visible by: the last identifier before each `,`, `}` or `;`.
        let mut last: Option<&String> = None;
        for t in &tokens[i + 2..=end.min(tokens.len() - 1)] {
            match t.as_str() {
                "," | "}" | ";" => {
                    if let Some(name) = last.take() {
                        map.insert(name.clone(), module.clone());
                    }
                }
                "{" | "::" | "as" | "*" | "self" => {}
                _ => last = Some(t),
            }
        }
    }
    map
}

/// A cycle of `graph`, as the modules along it with the first repeated at the end, if any.
fn find_cycle(graph: &Graph) -> Option<Vec<String>> {
    #[derive(Clone, Copy, PartialEq)]
    enum State {
        New,
        Open,
        Done,
    }
    fn visit(
        graph: &Graph,
        node: &str,
        state: &mut BTreeMap<String, State>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(node.to_string(), State::Open);
        path.push(node.to_string());
        for next in graph.get(node).into_iter().flatten() {
            match state.get(next).copied().unwrap_or(State::New) {
                State::Open => {
                    let start = path.iter().position(|m| m == next).unwrap();
                    let mut cycle = path[start..].to_vec();
                    cycle.push(next.clone());
                    return Some(cycle);
                }
                State::New => {
                    if let Some(cycle) = visit(graph, next, state, path) {
                        return Some(cycle);
                    }
                }
                State::Done => {}
            }
        }
        path.pop();
        state.insert(node.to_string(), State::Done);
        None
    }
    let mut state = BTreeMap::new();
    for node in graph.keys() {
        if state.get(node).copied().unwrap_or(State::New) == State::New
            && let Some(cycle) = visit(graph, node, &mut state, &mut Vec::new())
        {
            return Some(cycle);
        }
    }
    None
}
