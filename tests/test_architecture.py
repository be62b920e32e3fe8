"""The house: dependencies point one way (reports -> oracles -> properties -> refimpl), refimpl
imports none of the others, no module imports another in a circle, and no package reaches into
another package's private parts (any import statement, module-level or inside a function, counts).

Private means a dotted segment starting with one underscore: a module (``refimpl._taylor``) or a
name (``from tstarg.refimpl.fast import _helper``). A module of one of the four packages may import
only the public face of another package; inside its own package (subpackages included) it may
import private modules and names freely. The tests are outside the packages: white-box tests may
reach the private modules of the package they test, so the rule does not apply to ``tests/``.
``ALLOWED_PRIVATE`` lists the exceptions, each with its reason."""

from __future__ import annotations

import ast
import subprocess
import sys
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


def _imported(m: str, f: Path) -> list[tuple[str, str | None]]:
    """Every ``(module, name)`` that module ``m`` (file ``f``) imports, ``tstarg.`` dropped and
    relative imports resolved; ``name`` is None for ``import a.b``."""
    pkg = m if f.name == "__init__.py" else m.rsplit(".", 1)[0]
    out: list[tuple[str, str | None]] = []
    for node in ast.walk(ast.parse(f.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")
                base = base[: len(base) - (node.level - 1)]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = (node.module or "").removeprefix("tstarg.")
            out += [(name, a.name) for a in node.names]
        elif isinstance(node, ast.Import):
            out += [(a.name.removeprefix("tstarg."), None) for a in node.names]
    return out


def _graph(mods: dict[str, Path]) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for m, f in mods.items():
        for name, attr in _imported(m, f):
            sub = f"{name}.{attr}" if attr else None
            graph[m].add(sub if sub in mods else name)
        graph[m] = {t for t in graph[m] if t in mods and t != m}
    return graph


def _is_private(segment: str) -> bool:
    return segment.startswith("_") and not segment.startswith("__")


ALLOWED_PRIVATE: dict[tuple[str, str], str] = {}
"""``(importing module, imported dotted name)`` -> why it may cross the line."""


def _private_crossings(imports: dict[str, list[tuple[str, str | None]]]) -> list[tuple[str, str]]:
    """``(module, dotted name)`` for every import of another package's private module or name."""
    out = []
    for m, items in imports.items():
        for name, attr in items:
            top = name.split(".")[0]
            if top not in RANK or top == m.split(".")[0]:
                continue
            dotted = f"{name}.{attr}" if attr else name
            if any(_is_private(s) for s in dotted.split(".")[1:]):
                out.append((m, dotted))
    return sorted(set(out))


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


def test_no_private_import_across_packages():
    mods = _modules()
    found = _private_crossings({m: _imported(m, f) for m, f in mods.items()})
    crossing = [c for c in found if c not in ALLOWED_PRIVATE]
    assert crossing == [], f"imports of another package's private module or name: {crossing}"
    stale = sorted(set(ALLOWED_PRIVATE) - set(found))
    assert stale == [], f"ALLOWED_PRIVATE lists imports that no longer exist: {stale}"


def _private_attributes(m: str, source: str) -> list[tuple[str, str]]:
    """``(module, dotted name)`` for every ``alias._name`` in ``source`` (module ``m``) where
    ``alias`` was imported from another package: a private name reached through an attribute."""
    tree = ast.parse(source)
    own = m.split(".")[0]
    aliases: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and not node.level and node.module:
            name = node.module.removeprefix("tstarg.")
            if name.split(".")[0] in RANK and name.split(".")[0] != own:
                aliases |= {a.asname or a.name: f"{name}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            for a in node.names:
                name = a.name.removeprefix("tstarg.")
                if name.split(".")[0] in RANK and name.split(".")[0] != own and a.asname:
                    aliases[a.asname] = name
    return sorted(
        {
            (m, f"{aliases[node.value.id]}.{node.attr}")
            for node in ast.walk(tree)
            if isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and _is_private(node.attr)
        }
    )


def test_no_private_attribute_across_packages():
    """``from tstarg.properties import runner`` then ``runner._report(...)`` crosses the line too."""
    found = [x for m, f in _modules().items() for x in _private_attributes(m, f.read_text())]
    assert found == [], f"private names of another package reached as attributes: {found}"


def test_the_checker_sees_a_planted_private_attribute():
    src = "from tstarg.properties import runner as r\nfrom . import _own\nr._report(); r.note(); _own._x\n"
    assert _private_attributes("reports.x", src) == [("reports.x", "properties.runner._report")]
    assert _private_attributes("properties.y", src) == []


def test_the_checker_sees_a_planted_private_import():
    """Negative control: another package's private module and private name are found, the own
    package's private parts and the public face are not."""
    planted = {
        "reports.x": [("refimpl._taylor", "quadratic_field"), ("refimpl", "catalogue")],
        "oracles.y": [("refimpl.fast", "_helper"), ("oracles._own", "thing")],
        "refimpl.flows.z": [("refimpl._taylor", None), ("refimpl", "_compiled_taylor")],
    }
    assert _private_crossings(planted) == [
        ("oracles.y", "refimpl.fast._helper"),
        ("reports.x", "refimpl._taylor.quadratic_field"),
    ]


def test_the_checker_sees_a_planted_cycle():
    """Negative control: a two-module cycle and an upward import are found."""
    graph = {"refimpl.a": {"refimpl.b"}, "refimpl.b": {"refimpl.a"}, "refimpl.c": set()}
    assert _cycles(graph) == [["refimpl.a", "refimpl.b"]]
    assert _cycles({"refimpl.a": {"refimpl.c"}, "refimpl.c": set()}) == []


HEAVY = ("numpy", "scipy", "sympy", "mpmath", "numba", "llvmlite", "flint", "matplotlib")
HEAVY += ("heyoka", "qutip", "dask", "distributed", "jsonschema", "rich")
_PROBE = """
import contextlib, io, sys
sys.argv = ["tstarg", *{argv!r}]
{run}
print(" ".join(sorted({{m.split(".")[0] for m in sys.modules}})))
"""
_HELP = """
from tstarg.reports.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    try:
        main()
    except SystemExit:
        pass
"""


def _loaded_after(run: str, argv=()) -> set[str]:
    """The top-level modules loaded by a fresh interpreter after ``run``."""
    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(argv=list(argv), run=run)],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    return set(out.stdout.split())


def test_help_loads_no_heavy_module():
    """``tstarg --help`` (and a subcommand's ``--help``) builds every subcommand's parser from the
    ``cmd_*`` modules alone: none of the numerical stack is imported (each costs 0.1-1 s of CPU;
    before the split ``tstarg --help`` loaded numba, sympy, mpmath, flint, scipy and numpy, 1.0 s
    of CPU against 0.2 s after, on the same machine). The workers are imported by each ``main``."""
    for argv in (["--help"], ["verify", "--help"], ["stress", "--help"]):
        loaded = _loaded_after(_HELP, argv)
        assert "tstarg" in loaded and "argparse" in loaded, loaded  # the probe ran the parser
        assert sorted(loaded & set(HEAVY)) == [], argv


def test_the_help_probe_sees_a_heavy_import():
    """Negative control: the same probe sees numpy after importing a worker."""
    assert "numpy" in _loaded_after("import tstarg.reports._stress_run")
