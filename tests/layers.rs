//! The library's imports run one way: no module reaches, through `crate::` paths, a module that
//! reaches it back (docs/ARCHITECTURE.md draws the layers). Within a folder, no file reaches a
//! sibling that reaches it back through `super::` paths either, and a folder's `mod.rs` only names
//! and re-exports its files. A cycle here means a layer leans on one above it. And no source
//! file is longer than 450 lines (a shader 600).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The code of a file, without comments and without its inline test module.
fn code(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(at) => &text[..at],
        None => &text[..],
    };
    text.lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Names that follow `prefix` in `code`: `crate::a::x` gives `a`; `use crate::{a, b::c}` gives
/// `a` and `b`.
fn referenced(code: &str, prefix: &str) -> BTreeSet<String> {
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let mut out = BTreeSet::new();
    for (at, _) in code.match_indices(prefix) {
        let rest = &code[at + prefix.len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let mut depth = 0;
            let mut start = 0;
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        out.insert(ident(group[start..].trim_start()));
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.insert(ident(group[start..].trim_start()));
                        start = i + 1;
                    }
                    _ => {}
                }
            }
        } else {
            out.insert(ident(rest));
        }
    }
    out.remove("");
    out
}

/// `code` with the `super::` paths of its inline modules (`mod name { … }`) seen from the file:
/// inside d inline modules, a path's first d `super::` stay within the file and are dropped (a
/// path that goes no further is dropped whole), so that `super::` names a sibling file only where
/// it does.
fn seen_from_file(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    // Brace depth now, and the depth inside each open inline module.
    let mut depth = 0usize;
    let mut modules: Vec<usize> = Vec::new();
    let mut rest = code;
    while let Some(c) = rest.chars().next() {
        if let Some(after) = rest.strip_prefix("super::") {
            let mut chain = 1;
            let mut tail = after;
            while let Some(t) = tail.strip_prefix("super::") {
                chain += 1;
                tail = t;
            }
            if chain > modules.len() {
                out.push_str(&"super::".repeat(chain - modules.len()));
            } else {
                out.push_str("self::");
            }
            rest = tail;
            continue;
        }
        let word_start = !out.ends_with(|c: char| c.is_ascii_alphanumeric() || c == '_');
        if word_start
            && let Some(after) = rest.strip_prefix("mod ")
            && let Some((name, body)) = after.split_once('{')
            && !name.trim().is_empty()
            && name
                .trim()
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            out.push_str("mod ");
            out.push_str(name);
            out.push('{');
            depth += 1;
            modules.push(depth);
            rest = body;
            continue;
        }
        match c {
            '{' => depth += 1,
            '}' => {
                if modules.last() == Some(&depth) {
                    modules.pop();
                }
                depth = depth.saturating_sub(1);
            }
            _ => {}
        }
        out.push(c);
        rest = &rest[c.len_utf8()..];
    }
    out
}

/// A cycle in `graph`, if there is one, as the path around it.
fn cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(at) = path.iter().position(|n| n == node) {
            let mut c = path[at..].to_vec();
            c.push(node.to_owned());
            return Some(c);
        }
        if !done.insert(node.to_owned()) {
            return None;
        }
        path.push(node.to_owned());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(c) = visit(next, graph, path, done) {
                return Some(c);
            }
        }
        path.pop();
        None
    }
    let mut done = BTreeSet::new();
    graph
        .keys()
        .find_map(|n| visit(n, graph, &mut Vec::new(), &mut done))
}

fn rust_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.unwrap_or_else(|e| panic!("{e}")).path();
        if path.is_dir() {
            out.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out
}

/// The top-level module a file of `src/` belongs to (`src/gpu/context.rs` is in `gpu`).
fn top_module(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap_or(file);
    let first = rel
        .components()
        .next()
        .map(|c| c.as_os_str().to_string_lossy().into_owned());
    first.unwrap_or_default().trim_end_matches(".rs").to_owned()
}

/// Each top-level module of the library with the top-level modules it reaches through `crate::`.
fn module_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    // The binary's own files use the library as `hooke::`, from above.
    let binary = ["lib", "main", "cli"];
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in rust_files(src) {
        let module = top_module(src, &file);
        if binary.contains(&module.as_str()) {
            continue;
        }
        let uses = referenced(&code(&file), "crate::");
        let entry = graph.entry(module.clone()).or_default();
        entry.extend(uses.into_iter().filter(|u| *u != module));
    }
    graph
}

#[test]
fn modules_import_one_way() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut graph = module_graph(&src);
    for (module, uses) in &graph {
        for u in uses {
            assert!(
                graph.contains_key(u) || ["Error", "Result"].contains(&u.as_str()),
                "{module} uses crate::{u}, which is no module of src/"
            );
        }
    }
    // `crate::Error` and `crate::Result` are the error module's, re-exported at the root.
    for uses in graph.values_mut() {
        if uses.remove("Error") | uses.remove("Result") {
            uses.insert("error".to_owned());
        }
    }
    if let Some(c) = cycle(&graph) {
        panic!("imports run in a circle: {}", c.join(" -> "));
    }
}

/// `code` with each chain of exactly `depth` `super::` marked `§::` and every other chain cut,
/// so that `referenced(…, "§::")` names what those chains reach.
fn chains_of(code: &str, depth: usize) -> String {
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(at) = rest.find("super::") {
        out.push_str(&rest[..at]);
        let mut tail = &rest[at..];
        let mut chain = 0;
        while let Some(t) = tail.strip_prefix("super::") {
            chain += 1;
            tail = t;
        }
        if chain == depth {
            out.push_str("§::");
        }
        rest = tail;
    }
    out.push_str(rest);
    out
}

/// The files (by stem) and folders (by name) of `folder`, each with what it reaches among its
/// siblings: a file through `super::`, a folder's files through `super::super::` (its mod.rs
/// through `super::`).
fn units(folder: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut out = BTreeMap::new();
    for path in std::fs::read_dir(folder)
        .unwrap_or_else(|e| panic!("{e}"))
        .filter_map(|e| e.ok().map(|e| e.path()))
    {
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if path.extension().is_some_and(|e| e == "rs") {
            let uses = referenced(&chains_of(&seen_from_file(&code(&path)), 1), "§::");
            out.insert(name, uses);
        } else if path.join("mod.rs").is_file() {
            let mut uses = BTreeSet::new();
            for file in rust_files(&path) {
                let depth = if file.ends_with("mod.rs") { 1 } else { 2 };
                let seen = seen_from_file(&code(&file));
                uses.extend(referenced(&chains_of(&seen, depth), "§::"));
            }
            out.insert(name, uses);
        }
    }
    out
}

/// Every folder of `src/` with a mod.rs, nested ones included.
fn folders(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for path in std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{e}"))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("mod.rs").is_file())
    {
        out.extend(folders(&path));
        out.push(path);
    }
    out
}

#[test]
fn files_of_a_folder_import_one_way() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let all = folders(&src);
    assert!(
        all.iter().any(|f| f.ends_with("gpu/implicit")),
        "nested folders are checked too"
    );
    for folder in all {
        let units = units(&folder);
        let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (name, uses) in &units {
            let uses = if name == "mod" {
                units.keys().filter(|f| *f != "mod").cloned().collect()
            } else {
                // `super::Item` names an item of mod.rs itself.
                uses.iter()
                    .map(|u| {
                        if units.contains_key(u) {
                            u.clone()
                        } else {
                            "mod".to_owned()
                        }
                    })
                    .filter(|u| u != name)
                    .collect()
            };
            graph.insert(name.clone(), uses);
        }
        if let Some(c) = cycle(&graph) {
            panic!(
                "files of {} import each other in a circle: {}",
                folder.display(),
                c.join(" -> ")
            );
        }
    }
}

/// The two backends compute from the same physics core (`src/physics/`) and neither imports the
/// other: what both need lives below them, and the check that every GPU kernel has a CPU
/// namesake (`src/conformance/twins.rs`) sits above both.
#[test]
fn backends_import_nothing_from_each_other() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    for (backend, other) in [("gpu", "cpu"), ("cpu", "gpu")] {
        for file in rust_files(&src.join(backend)) {
            let uses = referenced(&code(&file), "crate::");
            assert!(
                !uses.contains(other),
                "{} uses crate::{other}: move what both backends need to src/physics/",
                file.display()
            );
        }
    }
}

/// No file of the library grows past 450 lines, and no shader past 600: a longer one holds more
/// than one concern and should be split by what it holds.
#[test]
fn no_source_file_exceeds_its_length() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let shaders = std::fs::read_dir(root.join("shaders"))
        .unwrap_or_else(|e| panic!("shaders: {e}"))
        .map(|e| e.unwrap_or_else(|e| panic!("{e}")).path());
    let files = rust_files(&root.join("src"))
        .into_iter()
        .map(|f| (f, 450))
        .chain(shaders.map(|f| (f, 600)));
    for (file, most) in files {
        let text = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{e}"));
        let lines = text.lines().count();
        assert!(
            lines <= most,
            "{} has {lines} lines, more than {most}: split it by what it holds",
            file.display()
        );
    }
}

/// `src/lib.rs` names the library's modules in layer order, bottom first: each reaches only
/// modules named before it, so the list reads as docs/ARCHITECTURE.md's layers do.
#[test]
fn lib_lists_modules_in_layer_order() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = std::fs::read_to_string(root.join("src/lib.rs")).unwrap_or_else(|e| panic!("{e}"));
    let order: Vec<&str> = lib
        .lines()
        .filter_map(|l| {
            l.strip_prefix("pub mod ")
                .or_else(|| l.strip_prefix("mod "))
        })
        .map(|l| l.trim_end_matches(';'))
        .collect();
    let graph = module_graph(&root.join("src"));
    let mut listed: Vec<&String> = graph.keys().collect();
    listed.retain(|m| !order.contains(&m.as_str()));
    assert!(listed.is_empty(), "src/lib.rs does not name {listed:?}");
    for (at, module) in order.iter().enumerate() {
        for used in graph.get(*module).into_iter().flatten() {
            let used = if used == "Error" || used == "Result" {
                "error"
            } else {
                used.as_str()
            };
            let later = order[at + 1..].contains(&used);
            assert!(
                !later,
                "src/lib.rs names {module} before {used}, which it imports: move {used} up"
            );
        }
    }
}

/// Every file of `tests/` is a module of the one test binary (`tests/suite.rs`): one that is
/// not would compile into nothing and never run.
#[test]
fn every_test_file_is_in_the_suite() {
    let tests = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let suite = std::fs::read_to_string(tests.join("suite.rs")).unwrap_or_else(|e| panic!("{e}"));
    for entry in std::fs::read_dir(&tests).unwrap_or_else(|e| panic!("{e}")) {
        let path = entry.unwrap_or_else(|e| panic!("{e}")).path();
        let Some(stem) = path.file_stem().map(|s| s.to_string_lossy().into_owned()) else {
            continue;
        };
        let module = path.extension().is_some_and(|e| e == "rs") || path.join("mod.rs").is_file();
        if module && stem != "suite" {
            assert!(
                suite.lines().any(|l| l == format!("mod {stem};")),
                "tests/suite.rs does not name `mod {stem};`, so {} never runs",
                path.display()
            );
        }
    }
}

/// The integrators are a table (`src/integrator/`): outside it, only the backends' code tables
/// name a variant (the CPU's step; the GPU's passes and fused steps). Everything else asks the
/// scheme's row, so a new scheme touches the places docs/ARCHITECTURE.md lists, and no more.
#[test]
fn integrator_variants_are_named_only_in_the_table_and_the_backends_steps() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let variants = [
        "Euler",
        "SemiImplicit",
        "Rk2",
        "Rk4",
        "Verlet",
        "Implicit",
        "Xpbd",
        "Vbd",
        "Bdf2",
    ];
    let mut naming = BTreeSet::new();
    for file in rust_files(&src) {
        let rel = file.strip_prefix(&src).unwrap_or(&file).to_owned();
        if rel.starts_with("integrator") {
            continue;
        }
        let code = code(&file);
        let names = variants.iter().any(|v| {
            code.match_indices(&format!("Integrator::{v}"))
                .any(|(at, m)| {
                    !code[at + m.len()..].starts_with(|c: char| c.is_ascii_alphanumeric())
                })
        });
        if names {
            naming.insert(rel.to_string_lossy().into_owned());
        }
    }
    let allowed: BTreeSet<String> = ["cpu/integrate.rs", "gpu/plan.rs", "gpu/fused_plan.rs"]
        .into_iter()
        .map(String::from)
        .collect();
    let extra: Vec<_> = naming.difference(&allowed).collect();
    assert!(
        extra.is_empty(),
        "{extra:?} name integrator variants: ask `Integrator::scheme()` instead"
    );
}
