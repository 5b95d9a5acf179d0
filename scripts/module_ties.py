#!/usr/bin/env python3
"""Folder-level import graph of src/: which top-level modules name which.

For every .rs file under src/ (tests included, comments and doc comments
excluded), the top-level module it belongs to (`src/tally/polar.rs` ->
`tally`, `src/shard.rs` -> `shard`) and every `crate::X` it names, in
`use` lines and in paths inside the code. Prints the edges `A -> B (files)`
and then every two-way tie `A <-> B`. Unit tests (`#[cfg(test)] mod`)
are left out unless `--tests` is given. Exit status 1 if there is a tie
not listed in the arguments as `A-B` (an allowed tie), else 0.

    python3 scripts/module_ties.py              # graph and ties, library code
    python3 scripts/module_ties.py --tests      # unit tests too
    python3 scripts/module_ties.py output-plot  # one tie allowed
"""
import pathlib
import re
import sys
from collections import defaultdict

SRC = pathlib.Path(__file__).resolve().parent.parent / "src"
CRATE = re.compile(r"\bcrate::(\w+)")
# `use crate::{a::X, b::Y}` spreads over several lines.
GROUP = re.compile(r"use\s+crate::\{(.*?)\};", re.S)


def top(path: pathlib.Path) -> str:
    rel = path.relative_to(SRC)
    return rel.parts[0].removesuffix(".rs")


def code(text: str) -> str:
    """The text without `//` comments (doc comments included)."""
    return "\n".join(re.sub(r"//.*", "", line) for line in text.splitlines())


def without_tests(text: str) -> str:
    """The code without its `#[cfg(test)] mod ... { }` blocks (braces
    matched; strings holding braces are rare enough here)."""
    out, at = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]\s*(pub(\(\w+\))?\s+)?mod\s+\w+\s*\{", text):
        if m.start() < at:
            continue
        out.append(text[at : m.start()])
        depth, i = 1, m.end()
        while depth and i < len(text):
            depth += {"{": 1, "}": -1}.get(text[i], 0)
            i += 1
        at = i
    out.append(text[at:])
    return "".join(out)


def main() -> int:
    tests = "--tests" in sys.argv
    args = [a for a in sys.argv[1:] if a != "--tests"]
    edges = defaultdict(set)
    for path in sorted(SRC.rglob("*.rs")):
        a = top(path)
        if a in ("lib", "main", "test_streams"):
            continue
        text = code(path.read_text())
        if not tests:
            text = without_tests(text)
        names = set(CRATE.findall(text))
        for group in GROUP.findall(text):
            names |= {m.split("::")[0].strip() for m in group.split(",") if m.strip()}
        for b in names:
            is_module = (SRC / b).is_dir() or (SRC / f"{b}.rs").exists()
            if b != a and is_module:
                edges[(a, b)].add(str(path.relative_to(SRC)))
    for (a, b), files in sorted(edges.items()):
        print(f"{a} -> {b}: {', '.join(sorted(files))}")
    allowed = {tuple(sorted(t.split("-"))) for t in args}
    ties = sorted({tuple(sorted(e)) for e in edges if (e[1], e[0]) in edges})
    print("\ntwo-way ties:")
    bad = 0
    for a, b in ties:
        note = " (allowed)" if (a, b) in allowed else ""
        bad += not note
        print(f"  {a} <-> {b}{note}")
        print(f"    {a} -> {b}: {', '.join(sorted(edges[(a, b)]))}")
        print(f"    {b} -> {a}: {', '.join(sorted(edges[(b, a)]))}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
