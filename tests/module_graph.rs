//! No import circles between the crate's modules.
//!
//! A module here is a file under `src/`. Every path a file names through
//! `crate::`, `super::` or `self::` (in a `use` tree or inline in the code;
//! comments, doc links and string literals do not count) is resolved to the
//! file that holds it, by the longest prefix that names a file
//! (`a/b.rs` or `a/b/mod.rs`, `lib.rs` for the crate root), and becomes an
//! edge from the naming file to that file. Inline modules belong to their
//! file; a `#[cfg(test)]` module is not counted (a unit test may drive its
//! module through the whole command line).
//! The graph must be acyclic: a circle is printed file by file, and the fix is
//! to move the shared item to the module that owns its physics.
//!
//! Two more rules sit on the same graph. No two top-level modules (the
//! folders and files of `src/`) import each other, in either direction
//! through any of their files: a shared item goes down to where both see it.
//! And no command module of `cli` imports another: what two commands share
//! lives in the library (or in `cli::common`, `cli::args` or
//! `cli::messages`, which are not commands).
//!
//! `circle_is_found` runs the same parser and search on a small synthetic
//! crate with one circle and one two-way tie, so the checks themselves are
//! tested.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A token of the cleaned source: an identifier or keyword, `::`, or one
/// punctuation character.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Token {
    Ident(String),
    PathSep,
    Punct(char),
}

/// The source without comments, string and character literals (each replaced
/// by a space, so tokens on either side stay apart).
fn strip(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(c.len());
    let mut i = 0;
    while i < c.len() {
        match c[i] {
            '/' if c.get(i + 1) == Some(&'/') => {
                while i < c.len() && c[i] != '\n' {
                    i += 1;
                }
            }
            '/' if c.get(i + 1) == Some(&'*') => {
                let mut depth = 0;
                while i < c.len() {
                    if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                        depth += 1;
                        i += 2;
                    } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                        depth -= 1;
                        i += 2;
                        if depth == 0 {
                            break;
                        }
                    } else {
                        i += 1;
                    }
                }
                out.push(' ');
            }
            'r' if matches!(c.get(i + 1), Some('"') | Some('#'))
                && (i == 0 || !(c[i - 1].is_alphanumeric() || c[i - 1] == '_')) =>
            {
                // Raw string r"..", r#".."#: count the hashes.
                let mut j = i + 1;
                let mut hashes = 0;
                while c.get(j) == Some(&'#') {
                    hashes += 1;
                    j += 1;
                }
                if c.get(j) != Some(&'"') {
                    out.push(c[i]);
                    i += 1;
                    continue;
                }
                j += 1;
                loop {
                    if j >= c.len() {
                        break;
                    }
                    if c[j] == '"' && (0..hashes).all(|h| c.get(j + 1 + h) == Some(&'#')) {
                        j += 1 + hashes;
                        break;
                    }
                    j += 1;
                }
                i = j;
                out.push(' ');
            }
            '"' => {
                i += 1;
                while i < c.len() && c[i] != '"' {
                    if c[i] == '\\' {
                        i += 1;
                    }
                    i += 1;
                }
                i += 1;
                out.push(' ');
            }
            '\'' => {
                // A character literal ('x', '\n', '\u{..}') or a lifetime ('a).
                if c.get(i + 1) == Some(&'\\') {
                    i += 3;
                    while i < c.len() && c[i] != '\'' {
                        i += 1;
                    }
                    i += 1;
                    out.push(' ');
                } else if c.get(i + 2) == Some(&'\'') {
                    i += 3;
                    out.push(' ');
                } else {
                    out.push(' ');
                    i += 1;
                }
            }
            ch => {
                out.push(ch);
                i += 1;
            }
        }
    }
    out
}

fn tokens(text: &str) -> Vec<Token> {
    let c: Vec<char> = strip(text).chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        if ch.is_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push(Token::Ident(c[start..i].iter().collect()));
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            out.push(Token::PathSep);
            i += 2;
        } else if ch.is_whitespace() || ch.is_ascii_digit() {
            i += 1;
        } else {
            out.push(Token::Punct(ch));
            i += 1;
        }
    }
    out
}

fn ident(t: Option<&Token>) -> Option<&str> {
    match t {
        Some(Token::Ident(s)) => Some(s),
        _ => None,
    }
}

/// Expands the use tree starting at `tokens[*at]` under `prefix`, pushing
/// every leaf path; stops after the tree (at `,`, `}` or `;`).
fn use_tree(tokens: &[Token], at: &mut usize, prefix: Vec<String>, out: &mut Vec<Vec<String>>) {
    let mut path = prefix;
    loop {
        match tokens.get(*at) {
            Some(Token::Ident(s)) if s == "as" => {
                *at += 2;
            }
            Some(Token::Ident(s)) => {
                path.push(s.clone());
                *at += 1;
            }
            Some(Token::PathSep) => *at += 1,
            Some(Token::Punct('*')) => *at += 1,
            Some(Token::Punct('{')) => {
                *at += 1;
                loop {
                    match tokens.get(*at) {
                        Some(Token::Punct('}')) => {
                            *at += 1;
                            break;
                        }
                        Some(Token::Punct(',')) => *at += 1,
                        None => return,
                        _ => use_tree(tokens, at, path.clone(), out),
                    }
                }
                return;
            }
            _ => {
                out.push(path);
                return;
            }
        }
    }
}

/// The tokens of `#[cfg(test)]`.
fn cfg_test() -> [Token; 7] {
    [
        Token::Punct('#'),
        Token::Punct('['),
        Token::Ident("cfg".into()),
        Token::Punct('('),
        Token::Ident("test".into()),
        Token::Punct(')'),
        Token::Punct(']'),
    ]
}

/// Every path the file names, made absolute (segments below the crate root).
/// `module` is the file's own module path.
fn named_paths(text: &str, module: &[String]) -> Vec<Vec<String>> {
    let toks = tokens(text);
    // Module path at each token: inline `mod name {` blocks push a segment.
    let mut stack: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut raw: Vec<(Vec<String>, Vec<String>)> = Vec::new(); // (current module, path)
    let mut i = 0;
    while i < toks.len() {
        let current = || {
            let mut m = module.to_vec();
            m.extend(stack.iter().map(|(n, _)| n.clone()));
            m
        };
        match &toks[i] {
            Token::Punct('{') => {
                depth += 1;
                i += 1;
            }
            Token::Punct('}') => {
                if stack.last().is_some_and(|(_, d)| *d == depth) {
                    stack.pop();
                }
                depth = depth.saturating_sub(1);
                i += 1;
            }
            Token::Ident(k) if k == "mod" => {
                if let (Some(_), Some(Token::Punct('{'))) =
                    (ident(toks.get(i + 1)), toks.get(i + 2))
                    && i >= 7
                    && toks[i - 7..i] == cfg_test()
                {
                    // A test module: skip to its closing brace.
                    let mut open = 0usize;
                    i += 2;
                    while i < toks.len() {
                        match toks[i] {
                            Token::Punct('{') => open += 1,
                            Token::Punct('}') => open -= 1,
                            _ => {}
                        }
                        i += 1;
                        if open == 0 {
                            break;
                        }
                    }
                } else if let (Some(name), Some(Token::Punct('{'))) =
                    (ident(toks.get(i + 1)), toks.get(i + 2))
                {
                    depth += 1;
                    stack.push((name.to_string(), depth));
                    i += 3;
                } else {
                    i += 1;
                }
            }
            Token::Ident(k) if k == "use" => {
                let here = current();
                i += 1;
                let mut leaves = Vec::new();
                use_tree(&toks, &mut i, Vec::new(), &mut leaves);
                for leaf in leaves {
                    raw.push((here.clone(), leaf));
                }
            }
            Token::Ident(k)
                if (k == "crate" || k == "super" || k == "self")
                    && toks.get(i + 1) == Some(&Token::PathSep)
                    && !(i > 0 && toks[i - 1] == Token::Punct('$')) =>
            {
                let here = current();
                let mut path = vec![k.clone()];
                let mut j = i + 1;
                while toks.get(j) == Some(&Token::PathSep) {
                    match ident(toks.get(j + 1)) {
                        Some(s) => path.push(s.to_string()),
                        None => break,
                    }
                    j += 2;
                }
                raw.push((here, path));
                i = j;
            }
            _ => i += 1,
        }
    }
    let mut out = Vec::new();
    for (here, path) in raw {
        let mut base: Vec<String>;
        let mut rest = path.as_slice();
        match rest.first().map(String::as_str) {
            Some("crate") => {
                base = Vec::new();
                rest = &rest[1..];
            }
            Some("super") | Some("self") => {
                base = here.clone();
                while let Some(s) = rest.first() {
                    match s.as_str() {
                        "super" => {
                            base.pop();
                        }
                        "self" => {}
                        _ => break,
                    }
                    rest = &rest[1..];
                }
            }
            _ => continue, // an external crate or a local name
        }
        base.extend(rest.iter().cloned());
        out.push(base);
    }
    out
}

/// The module path of a file under the source root: `a/b.rs` and
/// `a/b/mod.rs` are `[a, b]`, `lib.rs` and `main.rs` are `[]`.
fn module_of(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap();
    match last.as_str() {
        "mod.rs" | "lib.rs" | "main.rs" => {}
        f => parts.push(f.trim_end_matches(".rs").to_string()),
    }
    parts
}

/// The file-level import graph of the crate whose files are `files`
/// (relative path -> text): edges from each file to the files it names.
fn graph(files: &BTreeMap<PathBuf, String>) -> BTreeMap<PathBuf, BTreeSet<PathBuf>> {
    let by_module: BTreeMap<Vec<String>, PathBuf> = files
        .keys()
        .filter(|p| p.as_os_str() != "main.rs")
        .map(|p| (module_of(p), p.clone()))
        .collect();
    let mut edges = BTreeMap::new();
    for (file, text) in files {
        let module = module_of(file);
        let mut to = BTreeSet::new();
        if file.as_os_str() != "main.rs" {
            for path in named_paths(text, &module) {
                let target = (0..=path.len())
                    .rev()
                    .find_map(|k| by_module.get(&path[..k]))
                    .expect("the crate root resolves every path");
                if target != file {
                    to.insert(target.clone());
                }
            }
        }
        edges.insert(file.clone(), to);
    }
    edges
}

/// One circle of the graph, as the files along it (first file repeated at
/// the end), or None when the graph is acyclic.
fn find_circle(edges: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Option<Vec<PathBuf>> {
    // Depth-first search with colours; the grey stack is the current path.
    #[derive(Clone, Copy, PartialEq)]
    enum Colour {
        White,
        Grey,
        Black,
    }
    let mut colour: BTreeMap<&PathBuf, Colour> = edges.keys().map(|k| (k, Colour::White)).collect();
    fn visit<'a>(
        node: &'a PathBuf,
        edges: &'a BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        colour: &mut BTreeMap<&'a PathBuf, Colour>,
        stack: &mut Vec<&'a PathBuf>,
    ) -> Option<Vec<PathBuf>> {
        colour.insert(node, Colour::Grey);
        stack.push(node);
        for next in &edges[node] {
            match colour[next] {
                Colour::Grey => {
                    let from = stack.iter().position(|n| *n == next).unwrap();
                    let mut circle: Vec<PathBuf> =
                        stack[from..].iter().map(|p| (*p).clone()).collect();
                    circle.push(next.clone());
                    return Some(circle);
                }
                Colour::White => {
                    if let Some(c) = visit(next, edges, colour, stack) {
                        return Some(c);
                    }
                }
                Colour::Black => {}
            }
        }
        stack.pop();
        colour.insert(node, Colour::Black);
        None
    }
    for node in edges.keys() {
        if colour[node] == Colour::White {
            let mut stack = Vec::new();
            if let Some(c) = visit(node, edges, &mut colour, &mut stack) {
                return Some(c);
            }
        }
    }
    None
}

/// The top-level module a file belongs to (`transport/brdf.rs` ->
/// `transport`); the crate root and `main.rs` belong to none.
fn top_level(file: &Path) -> Option<String> {
    let first = file.components().next()?.as_os_str().to_string_lossy();
    let name = first.strip_suffix(".rs").unwrap_or(&first);
    (name != "lib" && name != "main").then(|| name.to_string())
}

/// Every pair of top-level modules that import each other, with one file
/// edge for each direction (`a -> b` as `a/x.rs -> b/y.rs`).
fn two_way_ties(edges: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Vec<String> {
    let mut one_way: BTreeMap<(String, String), String> = BTreeMap::new();
    for (from, tos) in edges {
        for to in tos {
            if let (Some(a), Some(b)) = (top_level(from), top_level(to))
                && a != b
            {
                one_way
                    .entry((a, b))
                    .or_insert_with(|| format!("{} -> {}", from.display(), to.display()));
            }
        }
    }
    one_way
        .iter()
        .filter(|((a, b), _)| a < b)
        .filter_map(|((a, b), there)| {
            let back = one_way.get(&(b.clone(), a.clone()))?;
            Some(format!("{a} <-> {b}: {there}, and {back}"))
        })
        .collect()
}

/// The files of `cli` that are commands (not the shared parts).
fn is_command(file: &Path) -> bool {
    file.starts_with("cli")
        && ![
            "cli/mod.rs",
            "cli/args.rs",
            "cli/common.rs",
            "cli/messages.rs",
        ]
        .iter()
        .any(|shared| file == Path::new(shared))
}

fn read_tree(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            read_tree(root, &path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let text = std::fs::read_to_string(&path).unwrap();
            out.insert(path.strip_prefix(root).unwrap().to_path_buf(), text);
        }
    }
}

fn show(circle: &[PathBuf]) -> String {
    circle
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(" -> ")
}

#[test]
fn no_import_circles() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = BTreeMap::new();
    read_tree(&root, &root, &mut files);
    assert!(
        files.len() > 50,
        "found only {} files under src/",
        files.len()
    );
    let edges = graph(&files);
    // The parser sees the crate's known structure: the scene builds on
    // the geometry, the CLI on the library API, the API on everything.
    assert!(edges[Path::new("geometry/body.rs")].contains(Path::new("geometry/quadric.rs")));
    assert!(edges[Path::new("cli/brdf.rs")].contains(Path::new("api.rs")));
    assert!(edges[Path::new("api/micro.rs")].contains(Path::new("transport/brdf/mod.rs")));
    // Every circle: report one, cut its closing edge, look again.
    let mut left = edges.clone();
    let mut circles = Vec::new();
    while let Some(circle) = find_circle(&left) {
        let n = circle.len();
        left.get_mut(&circle[n - 2]).unwrap().remove(&circle[n - 1]);
        circles.push(show(&circle));
    }
    assert!(
        circles.is_empty(),
        "import circles:\n{}",
        circles.join("\n")
    );
}

#[test]
fn top_level_modules_import_one_way() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = BTreeMap::new();
    read_tree(&root, &root, &mut files);
    let ties = two_way_ties(&graph(&files));
    assert!(
        ties.is_empty(),
        "top-level modules that import each other:\n{}",
        ties.join("\n")
    );
}

#[test]
fn no_command_imports_another() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = BTreeMap::new();
    read_tree(&root, &root, &mut files);
    let edges = graph(&files);
    assert!(is_command(Path::new("cli/brdf.rs")) && !is_command(Path::new("cli/common.rs")));
    let crossing: Vec<String> = edges
        .iter()
        .filter(|(from, _)| is_command(from))
        .flat_map(|(from, tos)| {
            tos.iter()
                .filter(|to| is_command(to))
                .map(move |to| format!("{} -> {}", from.display(), to.display()))
        })
        .collect();
    assert!(
        crossing.is_empty(),
        "command modules that import each other:\n{}",
        crossing.join("\n")
    );
}

#[test]
fn circle_is_found() {
    let files: BTreeMap<PathBuf, String> = [
        ("lib.rs", "pub mod a;\npub mod b;\n/// [`crate::b`]\nmod c;"),
        ("a/mod.rs", "pub mod x;\npub mod y;"),
        // x -> y through a grouped use; the test module's uses are no edges.
        (
            "a/x.rs",
            "use super::{y::Thing, x as _};\n#[cfg(test)]\nmod tests { use super::*; use crate::c; }",
        ),
        // y -> b inline, b -> x through `crate::` in a nested group.
        ("a/y.rs", "pub struct Thing; fn f() { let s = \"crate::a::x\"; crate::b::g(); }"),
        ("b.rs", "use crate::{a::{x::*}};\npub fn g() {}"),
        ("c.rs", "// use crate::a::x;\nfn h() {}"),
    ]
    .into_iter()
    .map(|(p, t)| (PathBuf::from(p), t.to_string()))
    .collect();
    let edges = graph(&files);
    assert_eq!(
        edges[Path::new("a/x.rs")],
        BTreeSet::from([PathBuf::from("a/y.rs")])
    );
    assert_eq!(
        edges[Path::new("a/y.rs")],
        BTreeSet::from([PathBuf::from("b.rs")])
    );
    assert_eq!(
        edges[Path::new("b.rs")],
        BTreeSet::from([PathBuf::from("a/x.rs")])
    );
    assert!(edges[Path::new("c.rs")].is_empty());
    assert!(edges[Path::new("lib.rs")].is_empty());
    // a -> b (y -> b) and b -> a (b -> x): one two-way tie; c and the root none.
    assert_eq!(
        two_way_ties(&edges),
        vec!["a <-> b: a/y.rs -> b.rs, and b.rs -> a/x.rs".to_string()]
    );
    let circle = find_circle(&edges).expect("the circle x -> y -> b -> x");
    assert_eq!(circle.len(), 4, "{}", show(&circle));
    assert_eq!(circle.first(), circle.last());
    // Cut one edge: no circle left.
    let mut cut = files.clone();
    cut.insert(PathBuf::from("b.rs"), "pub fn g() {}".to_string());
    assert_eq!(find_circle(&graph(&cut)), None);
    assert!(two_way_ties(&graph(&cut)).is_empty());
}
