//! ARCHITECTURE.md names every source file and every top-level module, and
//! names them rightly.
//!
//! * Every file under `src/` appears in ARCHITECTURE.md, by its path
//!   (`src/cli/brdf.rs`) or by its module path (`cli::brdf`); a `mod.rs`
//!   counts as its folder (`src/export/rgl/mod.rs` is `export::rgl`).
//! * Every top-level module (`pub mod` in `src/lib.rs`) has its row in the
//!   module table (a line starting with "| `name` |").
//! * Every `src/...` path the text names exists, and every backticked module
//!   path (`a::b::c`, `a` a top-level module) resolves: its lower-case
//!   segments name a file or folder of `src/`, and what follows (a type, a
//!   function, `Type::method`) is defined in that module, its submodules, or
//!   re-exported there.
//!
//! `wrong_names_are_found` runs the same check on a small synthetic text, so
//! the check itself is tested.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`, as paths relative to the crate root
/// (`src/a/b.rs`).
fn sources(root: &Path) -> Vec<String> {
    fn walk(dir: &Path, root: &Path, out: &mut Vec<String>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, root, out);
            } else if p.extension().is_some_and(|e| e == "rs") {
                out.push(
                    p.strip_prefix(root)
                        .unwrap()
                        .to_string_lossy()
                        .replace('\\', "/"),
                );
            }
        }
    }
    let mut out = Vec::new();
    walk(&root.join("src"), root, &mut out);
    out
}

/// The module path of a source file: `src/a/b.rs` and `src/a/b/mod.rs` are
/// `a::b`; `src/lib.rs` and `src/main.rs` have none.
fn module_path(file: &str) -> Option<String> {
    let rel = file.strip_prefix("src/")?.strip_suffix(".rs")?;
    let rel = rel.strip_suffix("/mod").unwrap_or(rel);
    (rel != "lib" && rel != "main").then(|| rel.replace('/', "::"))
}

/// The texts between backticks.
fn backticked(text: &str) -> Vec<&str> {
    text.split('`').skip(1).step_by(2).collect()
}

/// The source files of module `segments` (its file, and every file of its
/// folder), or none if no such module exists.
fn module_files(root: &Path, segments: &[&str]) -> Vec<PathBuf> {
    let base = root.join("src").join(segments.join("/"));
    let mut files = Vec::new();
    let file = base.with_extension("rs");
    if file.is_file() {
        files.push(file);
    }
    if base.is_dir() {
        let mut stack = vec![base];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    files.push(p);
                }
            }
        }
    }
    files
}

/// Whether `name` is defined (fn, struct, enum, trait, type, const, static,
/// mod, macro, enum variant or field) or re-exported in one of `files`.
fn defined(files: &[PathBuf], name: &str) -> bool {
    let keywords = [
        "fn ",
        "struct ",
        "enum ",
        "trait ",
        "type ",
        "const ",
        "static ",
        "mod ",
        "macro_rules! ",
    ];
    files.iter().any(|f| {
        let text = std::fs::read_to_string(f).unwrap();
        text.lines().any(|line| {
            let l = line.trim_start();
            // any visibility: `pub`, `pub(crate)`, `pub(super)`, `pub(in ...)`
            let l = match l.strip_prefix("pub(") {
                Some(rest) => rest.split_once(") ").map_or(l, |(_, item)| item),
                None => l.strip_prefix("pub ").unwrap_or(l),
            };
            let word_at = |rest: &str| {
                rest.starts_with(name)
                    && !rest[name.len()..].starts_with(|c: char| c.is_alphanumeric() || c == '_')
            };
            keywords.iter().any(|k| l.strip_prefix(k).is_some_and(word_at))
                // an enum variant or a struct field
                || (word_at(l) && l[name.len()..].trim_start().starts_with([',', '(', '{', ':', '=']))
                // a re-export
                || (l.starts_with("use ") && line.trim_start().starts_with("pub") && l.contains(name))
        })
    })
}

/// What is wrong with the text `doc` against the crate at `root`, one line each.
fn problems(root: &Path, doc: &str) -> Vec<String> {
    let mut found = Vec::new();
    let lib = std::fs::read_to_string(root.join("src/lib.rs")).unwrap();
    let top: BTreeSet<String> = lib
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod "))
        .map(|l| l.trim_end_matches(';').to_string())
        .collect();
    let ticked = backticked(doc);
    let ticked_set: BTreeSet<&str> = ticked.iter().copied().collect();
    for file in sources(root) {
        let by_module = module_path(&file).is_some_and(|m| {
            ticked
                .iter()
                .any(|t| *t == m || t.starts_with(&format!("{m}::")))
        });
        if !doc.contains(&file) && !by_module {
            found.push(format!(
                "{file} is not named (neither its path nor its module path)"
            ));
        }
    }
    for m in &top {
        if !doc.lines().any(|l| l.starts_with(&format!("| `{m}` |"))) {
            found.push(format!(
                "top-level module `{m}` has no row in the module table"
            ));
        }
    }
    for t in ticked_set {
        let t = t.split('(').next().unwrap();
        if t.contains("NAME") || t.contains('<') {
            continue; // a placeholder (`src/cli/NAME.rs`)
        }
        if let Some(p) = t.strip_prefix("src/") {
            let p = p.split([':', ' ']).next().unwrap();
            if !root.join("src").join(p).exists() {
                found.push(format!("`{t}`: no such file"));
            }
            continue;
        }
        let segments: Vec<&str> = t.split("::").collect();
        if segments.len() == 2 && segments[0].starts_with(|c: char| c.is_uppercase()) {
            // `Type::member`: both defined somewhere in the crate
            let all = module_files(root, &[]);
            for item in &segments {
                if !item.is_empty() && !defined(&all, item) {
                    found.push(format!("`{t}`: `{item}` is not defined in the crate"));
                    break;
                }
            }
            continue;
        }
        if segments.len() < 2 || !top.contains(segments[0]) {
            continue;
        }
        if segments
            .iter()
            .any(|s| s.is_empty() || !s.chars().all(|c| c.is_alphanumeric() || c == '_'))
        {
            continue;
        }
        let modules = segments
            .iter()
            .take_while(|s| s.chars().next().is_some_and(|c| c.is_lowercase()))
            .count();
        // the longest prefix that is a module
        let mut depth = modules;
        while depth > 0 && module_files(root, &segments[..depth]).is_empty() {
            depth -= 1;
        }
        if depth == 0 {
            found.push(format!("`{t}`: no module {}", segments[0]));
            continue;
        }
        let files = module_files(root, &segments[..depth]);
        // the first item after the module must be defined there; a method
        // (`Type::method`) anywhere in the same module
        for item in &segments[depth..] {
            if !defined(&files, item) {
                found.push(format!(
                    "`{t}`: `{item}` is not defined in {}",
                    segments[..depth].join("::")
                ));
                break;
            }
        }
    }
    found
}

#[test]
fn architecture_names_every_file_rightly() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(root.join("ARCHITECTURE.md")).unwrap();
    let found = problems(root, &doc);
    assert!(
        found.is_empty(),
        "ARCHITECTURE.md is out of date:\n{}",
        found.join("\n")
    );
}

#[test]
fn wrong_names_are_found() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = "| `cli` | x |\n`src/no_such_file.rs`, `cli::no_such_module`, `tally::accumulator::NoSuchType`, `src/lib.rs`, `BrdfRun::no_such_method`\n";
    let found = problems(root, doc);
    for wanted in [
        "`src/no_such_file.rs`: no such file",
        "`cli::no_such_module`: `no_such_module` is not defined in cli",
        "`tally::accumulator::NoSuchType`: `NoSuchType` is not defined in tally::accumulator",
        "src/main.rs is not named",
        "`BrdfRun::no_such_method`: `no_such_method` is not defined in the crate",
        "top-level module `geometry` has no row in the module table",
    ] {
        assert!(
            found.iter().any(|f| f.starts_with(wanted)),
            "not found: {wanted}\n{}",
            found.join("\n")
        );
    }
    // and nothing is reported for a right name
    let right = problems(root, "`tally::accumulator` `src/lib.rs`");
    assert!(
        !right
            .iter()
            .any(|f| f.contains("tally::accumulator") || f.contains("src/lib.rs:"))
    );
}
