"""Issue 30, security: no caller string is ever evaluated as code.

Three layers:

* a static check (``ast`` over the four packages) forbids the calls that evaluate strings --
  ``sympify``, ``sympy.S``, ``parse_expr``, ``nsimplify``, ``lambdify``, ``eval``, ``exec``,
  ``compile``, ``__import__`` -- except at listed sites whose argument the code built itself;
* the number entry points that take exact numbers (the oracles' model builders, the strategies'
  exact matrices, the reference, the rigorous balls, the GNH models, the identities) refuse code
  strings with a clear ``ValueError`` naming the input, and the sentinel file those strings would
  create never appears;
* a walk (:mod:`tests.adversarial._string_walk`, in a child process) calls every function and
  method of the packages, private ones included, with code strings in each parameter.

Numbers written as strings have exactly one parser, :func:`refimpl._validate.parse_number`.
"""

from __future__ import annotations

import ast
import json
import os
import pathlib
import subprocess
import sys
from fractions import Fraction

import mpmath
import numpy as np
import pytest
import sympy

from tstarg.refimpl._validate import exact_fraction, exact_sympy, parse_number

ROOT = pathlib.Path(__file__).resolve().parents[2]
PACKAGES = ("refimpl", "properties", "oracles", "reports")

# ------------------------------------------------------------------ the static check
EVALUATING = {
    "sympify",
    "parse_expr",
    "nsimplify",
    "lambdify",
    "eval",
    "exec",
    "__import__",
}
"""Callees that evaluate strings as code (``sympy.S`` and the builtin ``compile`` are matched by
form below: ``sp.S(...)``/``sympy.S(...)`` and a bare ``compile(...)``)."""

ALLOWED = {
    # (file, enclosing function, callee): why the argument is built by the code itself
    ("refimpl/_algebra.py", "LieAlgebra.from_matrix_basis", "nsimplify"): (
        "coef[m] is a sympy number solved from the basis (never a string: the basis entries "
        "pass exact_sympy first)"
    ),
    (
        "refimpl/gnh.py",
        "_expr",
        "nsimplify",
    ): "sp.Float(fv, 17) of a finite float, built on the line",
    ("oracles/closed_forms.py", "integral_rates", "lambdify"): (
        "the gradient of an integral, a sympy expression built from HEAVY_TOPS' numbers"
    ),
    ("refimpl/_rigorous_state.py", "_rep_balls", "sympify"): (
        "entries of rep.exact, the faithful representation's exact matrices built by "
        "refimpl._representation (never a caller's string)"
    ),
}
ALLOWED_FOLDERS = ("refimpl/codegen/",)
"""Generated kernel source only: every ``exec``/``compile`` of the package lives there
(``refimpl.codegen.define`` and ``import_source`` take text the emitters wrote from numbers)."""


def _evaluating_calls(path: pathlib.Path) -> list[tuple[str, str, int]]:
    """``(enclosing function, callee, line)`` of every string-evaluating call in ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found: list[tuple[str, str, int]] = []
    stack: list[str] = []

    class Visitor(ast.NodeVisitor):
        def _scope(self, node):
            stack.append(node.name)
            self.generic_visit(node)
            stack.pop()

        visit_FunctionDef = visit_AsyncFunctionDef = visit_ClassDef = _scope

        def visit_Call(self, node: ast.Call) -> None:
            f = node.func
            callee = None
            if isinstance(f, ast.Name) and (f.id in EVALUATING or f.id == "compile"):
                callee = f.id
            elif isinstance(f, ast.Attribute):
                if f.attr in EVALUATING:
                    callee = f.attr
                elif (
                    f.attr == "S"
                    and isinstance(f.value, ast.Name)
                    and f.value.id in ("sp", "sympy")
                ):
                    callee = "S"
            if callee is not None:
                found.append((".".join(stack), callee, node.lineno))
            self.generic_visit(node)

    Visitor().visit(tree)
    return found


def test_no_string_evaluating_call_outside_the_allow_list():
    bad = []
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel.startswith(ALLOWED_FOLDERS):
                continue
            for scope, callee, line in _evaluating_calls(path):
                if (rel, scope, callee) not in ALLOWED:
                    bad.append(f"{rel}:{line} {scope or '<module>'} calls {callee}")
    assert not bad, (
        "calls that evaluate strings as code on values the code did not build (convert caller "
        "numbers with refimpl._validate.exact_sympy / parse_number, or allow-list the site with "
        "the reason):\n" + "\n".join(bad)
    )


def test_every_allowed_site_still_exists():
    """The allow-list stays honest: an entry whose call is gone is removed, not kept."""
    live = set()
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            live |= {(rel, scope, callee) for scope, callee, _ in _evaluating_calls(path)}
    assert sorted(set(ALLOWED) - live) == []


def test_the_static_check_sees_each_form(tmp_path):
    """The checker itself: every forbidden form is found, the harmless look-alikes are not."""
    src = tmp_path / "m.py"
    src.write_text(
        "import sympy as sp, re\n"
        "def a(v):\n    return sp.sympify(v)\n"
        "def b(v):\n    return sp.S(v)\n"
        "def c(v):\n    eval(v); exec(v); compile(v, 'x', 'exec')\n"
        "def d(v):\n    return sp.nsimplify(v), sp.parse_expr(v), __import__(v)\n"
        "class K:\n    def e(self, v):\n        return self.S(v), re.compile(v)\n"
    )
    got = sorted((scope, callee) for scope, callee, _ in _evaluating_calls(src))
    assert got == sorted(
        [
            ("a", "sympify"),
            ("b", "S"),
            ("c", "eval"),
            ("c", "exec"),
            ("c", "compile"),
            ("d", "nsimplify"),
            ("d", "parse_expr"),
            ("d", "__import__"),
        ]
    )


# ------------------------------------------------------------------ the one parser
@pytest.mark.parametrize(
    "text, value",
    [
        ("1/3", Fraction(1, 3)),
        (" -1.5e-3 ", Fraction(-3, 2000)),
        (".5", Fraction(1, 2)),
        ("7", Fraction(7)),
        ("-12/8", Fraction(-3, 2)),
        ("2.5E+2", Fraction(250)),
    ],
)
def test_parse_number_reads_decimal_and_rational_literals(text, value):
    assert parse_number(text) == value


@pytest.mark.parametrize(
    "text, why",
    [
        ("__import__('os').system('true')", "not a decimal or rational literal"),
        ("1+1", "not a decimal or rational literal"),
        ("nan", "not a decimal or rational literal"),
        ("inf", "not a decimal or rational literal"),
        ("0x10", "not a decimal or rational literal"),
        ("1_000", "not a decimal or rational literal"),
        ("\u0661\u0662", "not a decimal or rational literal"),  # Arabic-Indic digits
        ("", "not a decimal or rational literal"),
        ("1/0", "zero denominator"),
        ("1e999999999", "exponent beyond"),  # Fraction alone would build a 1e9-digit integer
        ("1" * 1001, "at most 1000"),
    ],
)
def test_parse_number_refuses_everything_else_by_name(text, why):
    with pytest.raises(ValueError, match=why) as info:
        parse_number(text, "xi[0]")
    assert "xi[0]" in str(info.value)


def test_exact_conversions_keep_every_kind_exact():
    assert exact_fraction(0.1) == Fraction(3602879701896397, 36028797018963968)  # the binary value
    assert exact_fraction(sympy.Rational(2, 6)) == Fraction(1, 3)
    assert exact_fraction(sympy.Float(0.5)) == Fraction(1, 2)
    assert exact_fraction(mpmath.mpf("0.25")) == Fraction(1, 4)
    assert exact_fraction(np.int64(-4)) == -4
    assert exact_sympy("2/4") == sympy.Rational(1, 2)
    a = sympy.Symbol("a")
    assert exact_sympy(a) is a  # sympy objects were built by code: they pass
    for bad in (True, None, 1j, float("nan"), mpmath.mpf("inf"), sympy.sqrt(2), object()):
        with pytest.raises(ValueError):
            exact_fraction(bad, "v")


# ------------------------------------------------------------------ the entry points
def _payload(path: pathlib.Path) -> str:
    return f"__import__('pathlib').Path({str(path)!r}).touch()"


def _entry_points():
    """``(label, call(code_string))`` of every function that takes exact numbers from a caller."""
    from tstarg.oracles import closed_forms, gnh_examples, su2_symbolic
    from tstarg.properties import identities, strategies
    from tstarg.refimpl import LieAlgebra, gnh, rigorous, su2
    from tstarg.refimpl._algebra import to_exact
    from tstarg.refimpl._arb import to_arb
    from tstarg.refimpl._arb import to_exact as arb_exact
    from tstarg.refimpl.reference import Reference

    f = su2().f
    z = [[0] * 3 for _ in range(3)]
    eye = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    ref = Reference(20)

    def in_matrix(s):
        return [[s, 0, 0], [0, 1, 0], [0, 0, 1]]

    return [
        ("gnh_examples.su2_model xi", lambda s: gnh_examples.su2_model([s, 0, 0], 1, (1, 2, 3))),
        ("gnh_examples.su2_model t", lambda s: gnh_examples.su2_model([0, 0, 0], s, (1, 2, 3))),
        (
            "gnh_examples.su2_model inertia",
            lambda s: gnh_examples.su2_model([0, 0, 0], 1, (s, 2, 3)),
        ),
        ("strategies._exact_matrix", lambda s: strategies._exact_matrix(in_matrix(s))),
        (
            "strategies._in_span",
            lambda s: strategies._in_span([np.array([[0, s, 0], [0, 0, 0], [0, 0, 0]])], np.eye(3)),
        ),
        (
            "closed_forms.heavy_top_integrals",
            lambda s: closed_forms.heavy_top_integrals((s, 1, 1), (0, 0, 1)),
        ),
        ("su2_symbolic.eps", lambda s: su2_symbolic.eps(s, 1, 2)),
        ("su2_symbolic._zero", lambda s: su2_symbolic._zero(s)),
        (
            "gnh.lie_poisson_model",
            lambda s: gnh.lie_poisson_model(f.tolist(), in_matrix(s), z, eye),
        ),
        ("gnh._clean", lambda s: gnh._clean(s)),
        ("identities._exact", lambda s: identities._exact(s)),
        ("refimpl._algebra.to_exact", lambda s: to_exact(s)),
        ("refimpl._arb.to_arb", lambda s: to_arb(s)),
        ("refimpl._arb.to_exact", lambda s: arb_exact(s)),
        (
            "LieAlgebra.from_structure_constants",
            lambda s: LieAlgebra.from_structure_constants([[[s]]]),
        ),
        (
            "LieAlgebra.from_matrix_basis",
            lambda s: LieAlgebra.from_matrix_basis([in_matrix(s)], name="g"),
        ),
        ("Reference.poisson_tensor x", lambda s: ref.poisson_tensor(f, z, z, [s, 0, 0], [1, 2, 3])),
        (
            "Reference.poisson_tensor f",
            lambda s: ref.poisson_tensor([[[s]]], [[0]], [[0]], [0], [1]),
        ),
        (
            "Rigorous.poisson_tensor pi",
            lambda s: rigorous.implementation.poisson_tensor(f, z, z, [0, 0, 0], [s, 2, 3]),
        ),
    ]


@pytest.mark.parametrize(
    "label, call", _entry_points(), ids=lambda v: v if isinstance(v, str) else ""
)
def test_code_strings_are_refused_by_every_number_entry_point(label, call, tmp_path):
    """The reproducer of issue 30 (``su2_model([code], 1, (1, 2, 3))`` created its file) and its
    kin: each raises a clear error, and the file the string would create does not appear."""
    sentinel = tmp_path / "pwned"
    for code in (_payload(sentinel), f"__import__('os').system('touch {sentinel}')"):
        with pytest.raises((ValueError, TypeError)) as info:
            call(code)
        assert not sentinel.exists(), f"{label} evaluated a caller's string"
        msg = str(info.value)
        assert "string" in msg or "literal" in msg or "number" in msg or "integer" in msg, msg


# ------------------------------------------------------------------ the walk over every function
WALK = pathlib.Path(__file__).with_name("_string_walk.py")
SAMPLE = (
    "tstarg.oracles.gnh_examples",
    "tstarg.oracles.su2_symbolic",
    "tstarg.oracles.closed_forms",
    "tstarg.properties.strategies",
    "tstarg.refimpl._validate",
    "tstarg.refimpl._algebra",
    "tstarg.refimpl._arb",
    "tstarg.refimpl.gnh",
)
"""The modules of issue 30's findings and of every number parser: walked in the default run."""


def _walk(tmp_path, modules: tuple[str, ...], timeout: float) -> dict:
    sentinel = tmp_path / "pwned"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    res = subprocess.run(
        [sys.executable, str(WALK), str(sentinel), *modules],
        cwd=tmp_path,
        env=env,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    lines = [json.loads(line) for line in res.stdout.splitlines() if line.startswith("{")]
    assert lines and lines[-1].get("done"), (
        f"the walk stopped early (exit {res.returncode}): {res.stdout[-2000:]} {res.stderr[-2000:]}"
    )
    summary = lines[-1]
    assert not sentinel.exists()
    return summary


def test_walk_of_the_number_modules_evaluates_no_string(tmp_path):
    summary = _walk(tmp_path, SAMPLE, timeout=600)
    assert summary["functions"] >= 150 and summary["calls"] >= 1000, summary
    assert summary["executed"] == [], (
        f"functions that evaluated a code string: {summary['executed']}"
    )


@pytest.mark.slow
def test_walk_of_every_function_evaluates_no_string(tmp_path):
    """Every function and method of the four packages (see ``_string_walk.py`` for the few left
    out and why), each parameter in turn a code string, a list and a 3 x 3 list of them."""
    summary = _walk(tmp_path, (), timeout=3600)
    assert summary["functions"] >= 1000, summary
    assert summary["executed"] == [], (
        f"functions that evaluated a code string: {summary['executed']}"
    )
