#!/usr/bin/env python3
"""Fails if the modules of a crate (or of training/) depend on each other in a cycle.

Rust: every file of `crates/*/src` is a module (`a/b.rs` and `a/b/mod.rs` are `a::b`); a reference
`crate::x::y::...` (in `use` or inline) or `super::...` from module M is an edge M -> the longest module
prefix it names. At every level of the module tree the edges between siblings (each standing for itself and
its descendants) must form no cycle; a parent using its own children, or a child its ancestors, is not
an edge (a `mod.rs` re-exporting what its files define is the normal shape). Python: `training/*.py`, an
edge for every `from .x import` / `from . import x` / `import training.x` (also inside functions).

    python3 .ci/module_cycles.py            # every crate and training/; prints the edges with --verbose
"""
from __future__ import annotations

import re
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def rust_modules(src: Path) -> dict[tuple[str, ...], Path]:
    mods = {}
    for f in src.rglob("*.rs"):
        parts = list(f.relative_to(src).with_suffix("").parts)
        if parts[-1] in ("mod", "lib", "main"):
            parts = parts[:-1]
        mods[tuple(parts)] = f
    return mods


def strip_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return "\n".join(line.split("//")[0] for line in text.splitlines())


def resolve(path: list[str], mods) -> tuple[str, ...] | None:
    for n in range(len(path), 0, -1):
        if tuple(path[:n]) in mods:
            return tuple(path[:n])
    return None


def rust_edges(src: Path) -> set[tuple[tuple[str, ...], tuple[str, ...]]]:
    mods = rust_modules(src)
    edges = set()
    for mod, f in mods.items():
        text = strip_comments(f.read_text())
        # `use crate::{a::b, c}` groups: expand one level of braces.
        targets = []
        for m in re.finditer(r"\bcrate::((?:\w+::)*)\{([^}]*)\}", text):
            prefix = [p for p in m.group(1).split("::") if p]
            for item in m.group(2).split(","):
                item = item.strip().split(" as ")[0]
                if item:
                    targets.append(prefix + [p for p in item.split("::") if p])
        targets += [m.group(1).split("::") for m in re.finditer(r"\bcrate::((?:\w+)(?:::\w+)*)", text)]
        for m in re.finditer(r"\b((?:super::)+)((?:\w+)(?:::\w+)*)", text):
            ups = m.group(1).count("super::")
            base = list(mod) if f.name in ("mod.rs",) or f.stem in ("lib", "main") else list(mod)
            # from a file module `a/b.rs` (= a::b), super is `a`; from `a/b/mod.rs` (= a::b) too
            targets.append(base[: len(base) - ups] + m.group(2).split("::"))
        for t in targets:
            to = resolve([p for p in t if p], mods)
            if to is not None and to != mod:
                edges.add((mod, to))
    return edges


def python_edges(pkg: Path) -> set[tuple[tuple[str, ...], tuple[str, ...]]]:
    names = {f.stem for f in pkg.glob("*.py")}
    edges = set()
    for f in pkg.glob("*.py"):
        text = f.read_text()
        found = re.findall(r"^\s*from \.(\w+) import", text, flags=re.M)
        for group in re.findall(r"^\s*from \. import ([\w, ()\n]+)", text, flags=re.M):
            found += [n.strip(" ()\n") for n in group.split(",")]
        found += re.findall(r"^\s*(?:from|import) training\.(\w+)", text, flags=re.M)
        for name in found:
            if name in names and name != f.stem:
                edges.add(((f.stem,), (name,)))
    return edges


def sibling_cycles(edges) -> list[list[tuple[str, ...]]]:
    """Cycles among siblings at every level (each sibling stands for its subtree)."""
    by_parent = defaultdict(set)
    for a, b in edges:
        n = 0
        while n < min(len(a), len(b)) and a[n] == b[n]:
            n += 1
        if n == len(a) or n == len(b):
            continue  # ancestor <-> descendant: not an edge between siblings
        by_parent[a[:n]].add((a[: n + 1], b[: n + 1]))
    cycles = []
    for parent, pairs in by_parent.items():
        graph = defaultdict(set)
        for a, b in pairs:
            graph[a].add(b)
        index, low, stack, on, counter = {}, {}, [], set(), [0]

        def strong(v):
            index[v] = low[v] = counter[0]
            counter[0] += 1
            stack.append(v)
            on.add(v)
            for w in graph[v]:
                if w not in index:
                    strong(w)
                    low[v] = min(low[v], low[w])
                elif w in on:
                    low[v] = min(low[v], index[w])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    cycles.append(sorted(comp))

        for v in list(graph):
            if v not in index:
                strong(v)
    return cycles


def main() -> int:
    verbose = "--verbose" in sys.argv
    failed = False
    units = [(p.parent.name, rust_edges(p)) for p in sorted((ROOT / "crates").glob("*/src"))]
    units.append(("training (Python)", python_edges(ROOT / "training")))
    for name, edges in units:
        cycles = sibling_cycles(edges)
        print(f"{name}: {len(edges)} module dependencies, {len(cycles)} cycles")
        if verbose:
            for a, b in sorted(edges):
                print(f"  {'::'.join(a) or '(root)'} -> {'::'.join(b)}")
        for c in cycles:
            failed = True
            print("  CYCLE: " + " <-> ".join("::".join(m) for m in c))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
