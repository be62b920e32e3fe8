"""The house: dependencies point one way (reports -> oracles -> properties -> refimpl), refimpl
imports none of the others, and no module imports another in a circle (any import statement,
module-level or inside a function, counts)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("refimpl", "properties", "oracles", "reports")
RANK = {"refimpl": 0, "properties": 1, "oracles": 2, "reports": 3}


def _modules() -> dict[str, Path]:
    mods = {}
    for p in PACKAGES:
        for f in (ROOT / p).rglob("*.py"):
            parts = list(f.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join(parts)] = f
    return mods


def _graph(mods: dict[str, Path]) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for m, f in mods.items():
        pkg = m if f.name == "__init__.py" else m.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(f.read_text())):
            targets: list[str] = []
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg.split(".")
                    base = base[: len(base) - (node.level - 1)]
                    name = ".".join(base + ([node.module] if node.module else []))
                else:
                    name = (node.module or "").removeprefix("tstarg.")
                subs = [f"{name}.{a.name}" for a in node.names if f"{name}.{a.name}" in mods]
                targets = subs + ([name] if len(subs) < len(node.names) else [])
            elif isinstance(node, ast.Import):
                targets = [a.name.removeprefix("tstarg.") for a in node.names]
            graph[m] |= {t for t in targets if t in mods and t != m}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
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
                out.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle():
    assert _cycles(_graph(_modules())) == []


def test_dependencies_point_one_way():
    graph = _graph(_modules())
    upward = sorted(
        (a, b) for a in graph for b in graph[a] if RANK[b.split(".")[0]] > RANK[a.split(".")[0]]
    )
    assert upward == [], (
        f"imports against the layering reports -> oracles -> properties -> refimpl: {upward}"
    )


def test_the_checker_sees_a_planted_cycle():
    """Negative control: a two-module cycle and an upward import are found."""
    graph = {"refimpl.a": {"refimpl.b"}, "refimpl.b": {"refimpl.a"}, "refimpl.c": set()}
    assert _cycles(graph) == [["refimpl.a", "refimpl.b"]]
    assert _cycles({"refimpl.a": {"refimpl.c"}, "refimpl.c": set()}) == []
