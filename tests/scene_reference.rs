//! The scene reference (`docs/src/scene-reference.md`) cannot go stale: it
//! lists exactly the keys the scene loader accepts, micro and object scenes.
//!
//! The loader refuses unknown keys through serde's `deny_unknown_fields`
//! (every table of [`MicroSceneSpec`] and [`ObjectSceneSpec`]) and
//! externally tagged enums (`[quadrics]`), read through
//! [`roks::scene::parse_toml`]. Their error for an unknown key lists the
//! keys the table takes (`unknown field `x`, expected one of `a`, `b``), so
//! the test asks the loader itself: it offers a probe key at every table it
//! finds and collects the keys each refusal names, recursing into every key
//! whose value is a table, an array of tables or a table of named tables
//! (found the same way). That set must equal the keys the page's tables
//! list (first column, in backticks, under the headings "Micro scenes" and
//! "Object scenes"; `[]` marks the element of an array of tables and
//! `<...>` a name the user chooses). Every example in the page's example
//! column must load at its key, and an inline table given as an example must
//! refuse a key it does not have (the untagged values, such as
//! `{ linear = 30 }`, whose keys the probe cannot list).

use std::collections::BTreeSet;
use std::path::Path;

use roks::scene::micro::MicroSceneSpec;
use roks::scene::object::ObjectSceneSpec;
use roks::scene::{SceneFile, parse_toml};
use toml::{Table, Value};

const PAGE: &str = "docs/src/scene-reference.md";
const PROBE: &str = "zz_probe_key";
const NAME: &str = "zz_name";

/// One step of a key path: a key, the element of an array of tables
/// (`[]`), or an entry of a table of named things (`<name>`).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
enum Step {
    Key(String),
    Elem,
    Name,
}

/// The two scene kinds, each parsed by its own spec type.
#[derive(Debug, Clone, Copy)]
enum Kind {
    Micro,
    Object,
}

impl Kind {
    fn title(self) -> &'static str {
        match self {
            Self::Micro => "Micro scenes",
            Self::Object => "Object scenes",
        }
    }

    /// The loader's message for `doc`, or `None` when it loads.
    fn load(self, doc: &Table) -> Option<String> {
        let text = toml::to_string(doc).expect("probe documents serialise");
        let scene_file = SceneFile::from_path(Path::new("probe.toml"));
        let r = match self {
            Self::Micro => parse_toml::<MicroSceneSpec>(&scene_file, &text).map(|_| ()),
            Self::Object => parse_toml::<ObjectSceneSpec>(&scene_file, &text).map(|_| ()),
        };
        r.err().map(|e| e.to_string())
    }
}

/// The path as the page writes it (`bumps[].shape`, `materials.<>.n`,
/// any `<name>` read as `<>`).
fn render(path: &[Step]) -> String {
    spell(path, "[]", "<>")
}

/// The path as the loader's messages write it for a probe document
/// (`bumps[0].shape`, `materials.zz_name.n`).
fn render_message_key(path: &[Step]) -> String {
    spell(path, "[0]", NAME)
}

fn spell(path: &[Step], elem: &str, name: &str) -> String {
    let mut s = String::new();
    for step in path {
        match step {
            Step::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            Step::Elem => s.push_str(elem),
            Step::Name => {
                s.push('.');
                s.push_str(name);
            }
        }
    }
    s
}

/// A document holding `leaf` at `path` and nothing else.
fn nest(path: &[Step], leaf: Value) -> Table {
    let mut v = leaf;
    for step in path.iter().rev() {
        v = match step {
            Step::Key(k) => Value::Table(Table::from_iter([(k.clone(), v)])),
            Step::Elem => Value::Array(vec![v]),
            Step::Name => Value::Table(Table::from_iter([(NAME.to_string(), v)])),
        };
    }
    match v {
        Value::Table(t) => t,
        _ => unreachable!("paths start with a key"),
    }
}

/// The keys named in a refusal of the probe key, or `None` when the
/// message is not such a refusal. Two phrasings: serde's (`unknown field
/// `x`, expected one of `a`, `b``, also `expected `a` or `b`` and
/// `unknown variant`) and toml's for the fields of an enum's struct variant
/// (`unexpected keys in table: x, available keys: a, b`).
fn names_after_expected(message: &str) -> Option<Vec<String>> {
    if let Some(at) = message.find(&format!("unexpected keys in table: {PROBE}")) {
        let rest = &message[at..];
        let list = rest.split("available keys:").nth(1)?;
        let list = list.split(" (line").next().unwrap_or(list);
        return Some(
            list.split(',')
                .map(|k| k.trim().to_string())
                .filter(|k| !k.is_empty())
                .collect(),
        );
    }
    let at = message
        .find(&format!("unknown field `{PROBE}`"))
        .or_else(|| message.find(&format!("unknown variant `{PROBE}`")))?;
    let rest = &message[at..];
    let rest = &rest[rest.find("expected").unwrap_or(rest.len())..];
    if rest.contains("there are no fields") || rest.contains("there are no variants") {
        return Some(Vec::new());
    }
    Some(
        rest.split('`')
            .skip(1)
            .step_by(2)
            .map(str::to_string)
            .collect(),
    )
}

/// Whether the loader's message `m` is about the key at `path` (or below).
fn is_at(m: &str, path: &[Step]) -> bool {
    let key = render_message_key(path);
    m.contains(&format!(": {key}:"))
        || m.contains(&format!(": {key}."))
        || m.contains(&format!(": {key}["))
}

/// The keys of the table at `path` (the probe offered there), or `None`
/// when the value at `path` is not a table that refuses unknown keys. An
/// enum of plain names (`shape = "cone"`) refuses the probe too, naming
/// its values: it is a value, not a table, when its first name loads as a
/// string.
fn keys_at(kind: Kind, path: &[Step]) -> Option<Vec<String>> {
    let probe = Value::Table(Table::from_iter([(PROBE.to_string(), Value::Integer(0))]));
    let names = names_after_expected(&kind.load(&nest(path, probe))?)?;
    if let (Some(first), false) = (names.first(), path.is_empty()) {
        let plain = kind.load(&nest(path, Value::String(first.clone())));
        if plain.is_none_or(|m| !is_at(&m, path)) {
            return None;
        }
    }
    Some(names)
}

/// Every key path the loader accepts under `path` (whose value is a table
/// with the keys `keys`), depth first.
fn walk(kind: Kind, path: &mut Vec<Step>, keys: &[String], out: &mut BTreeSet<String>) {
    for key in keys {
        path.push(Step::Key(key.clone()));
        out.insert(render(path));
        // A table, an array of tables, a table of named tables, or a table
        // of named plain values (`[walls]`): whichever the loader takes.
        let mut found = false;
        for shape in [vec![], vec![Step::Elem], vec![Step::Name]] {
            path.extend(shape.iter().cloned());
            if let Some(sub) = keys_at(kind, path) {
                walk(kind, path, &sub, out);
                found = true;
            }
            path.truncate(path.len() - shape.len());
            if found {
                break;
            }
        }
        if !found {
            let named = nest(
                path,
                Value::Table(Table::from_iter([(
                    NAME.to_string(),
                    Value::String("zz".into()),
                )])),
            );
            if kind.load(&named).is_none_or(|m| !is_at(&m, path)) {
                // `{ any_name = "..." }` loads (or fails only at other
                // keys): a table of named strings.
                path.push(Step::Name);
                out.insert(render(path));
                path.pop();
            }
        }
        path.pop();
    }
}

/// The keys the loader accepts for `kind`.
fn loader_keys(kind: Kind) -> BTreeSet<String> {
    let top = keys_at(kind, &[]).expect("the top level refuses unknown keys");
    let mut out = BTreeSet::new();
    walk(kind, &mut Vec::new(), &top, &mut out);
    out
}

/// One row of the page: its key as written, canonical path, example, line.
struct Row {
    key: String,
    path: Vec<Step>,
    example: Option<String>,
    line: usize,
}

fn parse_path(key: &str) -> Vec<Step> {
    let mut path = Vec::new();
    for part in key.split('.') {
        if part.starts_with('<') && part.ends_with('>') {
            path.push(Step::Name);
            continue;
        }
        let (name, elems) = match part.find("[]") {
            Some(i) => (&part[..i], part[i..].matches("[]").count()),
            None => (part, 0),
        };
        path.push(Step::Key(name.to_string()));
        path.extend(std::iter::repeat_n(Step::Elem, elems));
    }
    path
}

/// The cells of a markdown table row (`|` inside backticks is text).
fn cells(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut code = false;
    let mut chars = line.trim().trim_start_matches('|').chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '`' => {
                code = !code;
                cur.push(c);
            }
            '\\' if chars.peek() == Some(&'|') => {
                cur.push('|');
                chars.next();
            }
            '|' if !code => out.push(std::mem::take(&mut cur).trim().to_string()),
            _ => cur.push(c),
        }
    }
    if !cur.trim().is_empty() {
        out.push(cur.trim().to_string());
    }
    out
}

/// The rows of the page under the heading of `kind` (up to the next `## `).
fn page_rows(text: &str, kind: Kind) -> Vec<Row> {
    let mut rows = Vec::new();
    let mut inside = false;
    let mut example_col = None;
    for (i, line) in text.lines().enumerate() {
        if let Some(h) = line.strip_prefix("## ") {
            inside = h.trim() == kind.title();
            continue;
        }
        if !inside || !line.trim_start().starts_with('|') {
            continue;
        }
        let c = cells(line);
        if c.first().is_some_and(|h| h == "key") {
            example_col = c.iter().position(|h| h == "example");
            continue;
        }
        let Some(first) = c.first() else { continue };
        if !(first.starts_with('`') && first.ends_with('`') && first.len() > 2) {
            continue; // the header's rule line
        }
        let key = first.trim_matches('`').to_string();
        let example = example_col
            .and_then(|j| c.get(j))
            .map(|e| e.trim())
            .filter(|e| e.starts_with('`') && e.ends_with('`') && e.len() > 2)
            .map(|e| e.trim_matches('`').to_string());
        rows.push(Row {
            path: parse_path(&key),
            key,
            example,
            line: i + 1,
        });
    }
    rows
}

fn page_text() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(PAGE);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The page and the loader agree on the key set of `kind`.
fn same_keys(kind: Kind) {
    let text = page_text();
    let rows = page_rows(&text, kind);
    assert!(
        !rows.is_empty(),
        "{PAGE}: no key rows under `## {}`",
        kind.title()
    );
    let page: BTreeSet<String> = rows.iter().map(|r| render(&r.path)).collect();
    let loader = loader_keys(kind);
    let unlisted: Vec<_> = loader.difference(&page).collect();
    let refused: Vec<_> = page.difference(&loader).collect();
    assert!(
        unlisted.is_empty() && refused.is_empty(),
        "{PAGE}, {}: the loader accepts keys the page does not list: {unlisted:?}; \
         the page lists keys the loader refuses: {refused:?}",
        kind.title()
    );
    let mut seen = BTreeSet::new();
    for r in &rows {
        assert!(
            seen.insert(render(&r.path)),
            "{PAGE}:{}: `{}` is listed twice",
            r.line,
            r.key
        );
    }
}

/// Known loader gaps, each with the issue that closes it: the example's
/// inline table accepts an unknown key. The test fails when a gap closes,
/// so that its entry is removed here.
const ACCEPTS_UNKNOWN: [&str; 0] = [];

/// Every example loads at its key; an inline-table example refuses a key it
/// does not have.
fn examples_load(kind: Kind) {
    let text = page_text();
    let mut checked = 0;
    for r in page_rows(&text, kind) {
        let Some(example) = &r.example else { continue };
        let value: Value = match toml::from_str::<Table>(&format!("v = {example}")) {
            Ok(mut t) => t.remove("v").expect("the key just parsed"),
            Err(e) => panic!(
                "{PAGE}:{}: the example of `{}` is not a TOML value: {e}",
                r.line, r.key
            ),
        };
        let doc = nest(&r.path, value.clone());
        // Only the key's own problems count: the probe document lacks the
        // keys the scene requires elsewhere (`[surface]`, ...).
        if let Some(m) = kind.load(&doc) {
            assert!(
                !is_at(&m, &r.path),
                "{PAGE}:{}: the example `{example}` of `{}` does not load: {m}",
                r.line,
                r.key
            );
        }
        if let Value::Table(mut t) = value {
            t.insert(PROBE.into(), Value::Integer(0));
            let refused = kind
                .load(&nest(&r.path, Value::Table(t)))
                .is_some_and(|m| is_at(&m, &r.path));
            let known = ACCEPTS_UNKNOWN.contains(&render(&r.path).as_str());
            assert!(
                refused || known,
                "{PAGE}:{}: `{}` accepts an unknown key `{PROBE}` beside its example `{example}`",
                r.line,
                r.key
            );
            assert!(
                !(refused && known),
                "{PAGE}:{}: `{}` now refuses unknown keys: remove it from ACCEPTS_UNKNOWN",
                r.line,
                r.key
            );
        }
        checked += 1;
    }
    assert!(checked > 10, "{PAGE}: only {checked} examples");
}

#[test]
fn micro_keys_match_the_page() {
    same_keys(Kind::Micro);
}

#[test]
fn object_keys_match_the_page() {
    same_keys(Kind::Object);
}

#[test]
fn micro_examples_load() {
    examples_load(Kind::Micro);
}

#[test]
fn object_examples_load() {
    examples_load(Kind::Object);
}

/// The probe sees the loader: a key a table refuses is not found, one it
/// takes is, and the message parser reads serde's three phrasings.
#[test]
fn probe_reads_the_loader() {
    let micro = loader_keys(Kind::Micro);
    for key in [
        "surface.size",
        "bumps[].shape",
        "materials.<>.nk",
        "quadrics.<>.sphere.r",
        "surface.heightfield.gaussian.tau",
    ] {
        assert!(micro.contains(key), "{key} not found in {micro:?}");
    }
    assert!(!micro.contains("surface.colour"));
    let object = loader_keys(Kind::Object);
    for key in ["walls.<>", "sources[].sweep.steps", "cells[].fill"] {
        assert!(object.contains(key), "{key} not found in {object:?}");
    }
    let m = |s: &str| names_after_expected(&format!("unknown field `{PROBE}`, {s}"));
    assert_eq!(m("expected `a`"), Some(vec!["a".into()]));
    assert_eq!(m("expected `a` or `b`"), Some(vec!["a".into(), "b".into()]));
    assert_eq!(
        m("expected one of `a`, `b`, `c`"),
        Some(vec!["a".into(), "b".into(), "c".into()])
    );
    assert_eq!(names_after_expected("invalid type: integer"), None);
}
