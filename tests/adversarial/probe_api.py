"""Adversarial probe of the Python API (issue 30): each input in its own process, with a hard timeout.

Not a test module (pytest does not collect it); run it by hand::

    python tests/adversarial/probe_api.py [--timeout 120] [--workers 2] [--only CATEGORY]

Every case is a short program run by ``python -c`` in a scratch folder. The child reports one of:

``clear error``  a ``ValueError``/``TypeError`` (the protocol's errors, their subclasses included)
                 whose message names the problem (not numba's dispatch, not a bare mpmath error);
``correct``      a result that passes the case's own check (written next to it, from an
                 independent route: a closed form, a symmetry, or the reference);
``silent``       a result that fails the check (non-finite, wrong), or a code string that ran;
``crash``        any other exception, a signal, or a traceback with a non-protocol error;
``mutated``      the caller's arrays changed;
``hang``         the hard timeout expired (the parent kills the child's process group);
``lost``         the child exited without reporting.

Prints the table ``| category | inputs | clear error | correct | silent | hang | crash | mutated |
lost |`` and one line per input that is not ``clear error`` or ``correct``. Progress goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor

PRELUDE = r"""
import hashlib, json, os, sys, traceback
import numpy as np
from tstarg.refimpl import su2, so4, se3, sl2r, heisenberg, abelian, fast, reference, LieAlgebra
from tstarg.refimpl.flows import fast_flow
F = su2().f; Z3 = np.zeros((3, 3)); I3 = np.eye(3)
X3 = np.array([0.1, 0.2, 0.3]); P3 = np.array([0.3, 0.2, -0.4])
TAU = np.array([0.25, -0.5, 0.5]); U = np.einsum("l,lmn->mn", TAU, F)
FAST = fast.implementation; REF = reference.Reference(20)
SENTINEL = os.path.abspath("pwned")
CODE = f"__import__('pathlib').Path({SENTINEL!r}).touch()"
def rigorous():
    from tstarg.refimpl import rigorous as _r
    return _r.implementation
def snap(*arrays):
    return [hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest() for a in arrays]
def finite(r):
    if isinstance(r, tuple):
        return all(finite(v) for v in r)
    return bool(np.all(np.isfinite(np.asarray(r, dtype=float))))
WATCH = []
CHECK = finite
"""

RUNNER = r"""
before = snap(*WATCH)
outcome, detail = None, ""
try:
    result = CASE()
    ok = CHECK(result)
    outcome, detail = ("correct", "") if ok else ("silent", "check failed: " + repr(result)[:200])
except (ValueError, TypeError) as exc:
    msg = str(exc)
    unclear = ("No matching definition" in msg or "matrix is numerically singular" == msg
               or len(msg) < 12)
    outcome, detail = ("crash" if unclear else "clear error"), type(exc).__name__ + ": " + msg[:200]
except BaseException as exc:
    outcome, detail = "crash", type(exc).__name__ + ": " + str(exc)[:200]
if os.path.exists(SENTINEL):
    outcome, detail = "silent", "a code string was executed"
if snap(*WATCH) != before:
    outcome, detail = "mutated", "the caller's arrays changed"
print("PROBE-RESULT " + json.dumps({"outcome": outcome, "detail": detail}), flush=True)
"""

# (category, label, body): the body defines CASE() and may set WATCH and CHECK
CASES: list[tuple[str, str, str]] = []


def case(category: str, label: str, body: str) -> None:
    CASES.append((category, label, textwrap.dedent(body)))


# ------------------------------------------------------------------ strings
for where, call in [
    ("su2_model xi", "gnh_examples.su2_model([CODE, 0, 0], 1, (1, 2, 3))"),
    ("su2_model t", "gnh_examples.su2_model([0, 0, 0], CODE, (1, 2, 3))"),
    ("su2_model inertia", "gnh_examples.su2_model([0, 0, 0], 1, (CODE, 2, 3))"),
    ("strategies._exact_matrix", "strategies._exact_matrix([[CODE, 0], [0, 1]])"),
    (
        "closed_forms.heavy_top_integrals",
        "closed_forms.heavy_top_integrals((CODE, 1, 1), (0, 0, 1))",
    ),
    ("su2_symbolic.eps", "su2_symbolic.eps(CODE, 1, 2)"),
    (
        "gnh.lie_poisson_model",
        "gnh.lie_poisson_model(F.tolist(), [[0, CODE, 0], [0, 0, 0], [0, 0, 0]], Z3.tolist(), I3.tolist())",
    ),
    ("LieAlgebra f", "LieAlgebra.from_structure_constants([[[CODE]]])"),
    ("LieAlgebra basis", "LieAlgebra.from_matrix_basis([[[CODE, 0], [0, 1]]], name='g')"),
    ("reference x", "REF.poisson_tensor(F, Z3, Z3, [CODE, 0, 0], P3)"),
    ("reference f", "REF.poisson_tensor([[[CODE]]], [[0]], [[0]], [0], [1])"),
    (
        "reference inertia",
        "REF.hamiltonian_vector_field(F, Z3, Z3, [[CODE, 0, 0], [0, 1, 0], [0, 0, 1]], None, X3, P3)",
    ),
    ("rigorous pi", "rigorous().poisson_tensor(F, Z3, Z3, [0, 0, 0], [CODE, 2, 3])"),
    ("fast pi", "FAST.poisson_tensor(F, Z3, Z3, X3, [CODE, 0, 0])"),
    ("identities._exact", "identities._exact(CODE)"),
    ("_arb.to_arb", "to_arb(CODE)"),
    ("huge exponent string", "REF.poisson_tensor(F, Z3, Z3, ['1e999999999', 0, 0], P3)"),
    ("fast_flow t string", "fast_flow(F, Z3, Z3, I3, None, X3, P3, CODE)"),
]:
    case(
        "strings",
        where,
        f"""
        from tstarg.oracles import gnh_examples, closed_forms, su2_symbolic
        from tstarg.properties import strategies, identities
        from tstarg.refimpl import gnh
        from tstarg.refimpl._arb import to_arb
        def CASE():
            return {call}
        CHECK = lambda r: False  # any result for a code string is wrong
        """,
    )

# ------------------------------------------------------------------ magnitudes
for label, call in [
    ("fast pi = 1.7e308", "FAST.poisson_tensor(F, Z3, Z3, X3, np.array([1, 2, 1.7e308]))"),
    ("fast pi = 1e301", "FAST.poisson_tensor(F, Z3, Z3, X3, np.array([1, 2, 1e301]))"),
    (
        "fast batch pi = 1.7e308",
        "FAST.poisson_batch(F, Z3, Z3, np.tile(X3, (5, 1)), np.tile([1, 2, 1.7e308], (5, 1)))",
    ),
    ("fast vf p3 * 1e300", "FAST.hamiltonian_vector_field(F, Z3, Z3, I3, None, X3, P3 * 1e300)"),
    (
        "fast vf p3 * 1e300, I = diag(1,2,3)",
        "FAST.hamiltonian_vector_field(F, Z3, Z3, np.diag([1., 2, 3]), None, X3, P3 * 1e300)",
    ),
    (
        "reference vf p3 * 1e300, I = diag(1,2,3)",
        "REF.hamiltonian_vector_field(F, Z3, Z3, np.diag([1., 2, 3]), None, X3, P3 * 1e300)",
    ),
    ("reference pi = 1.7e308", "REF.poisson_tensor(F, Z3, Z3, X3, np.array([1, 2, 1.7e308]))"),
    (
        "rigorous pi = 1.7e308",
        "rigorous().poisson_tensor(F, Z3, Z3, X3, np.array([1, 2, 1.7e308]))",
    ),
    ("fast f * 1e200", "FAST.poisson_tensor(F * 1e200, Z3, Z3, X3, P3)"),
    ("fast f * 1e200 at x = 0", "FAST.poisson_tensor(F * 1e200, Z3, Z3, np.zeros(3), P3)"),
    ("reference f * 1e200", "REF.poisson_tensor(F * 1e200, Z3, Z3, np.zeros(3), P3)"),
    ("fast upsilon * 1e305", "FAST.poisson_tensor(F, Z3, U * 1e305, X3, P3)"),
    (
        "fast theta 1e305",
        "FAST.poisson_tensor(F, np.array([[0, 1e305, 0], [-1e305, 0, 0], [0, 0, 0]]), Z3, X3, P3)",
    ),
    ("fast inertia 1e200", "FAST.hamiltonian_vector_field(F, Z3, Z3, I3 * 1e200, None, X3, P3)"),
    (
        "fast gravity L 1e305",
        "FAST.hamiltonian_vector_field(F, Z3, Z3, I3, {'kind': 'gravity', 'L': [0, 0, 1e305], 'gamma': [0, 0, 1]}, X3, P3)",
    ),
    ("fast_flow pi0 1.7e308", "fast_flow(F, Z3, Z3, I3, None, X3, np.array([1, 2, 1.7e308]), 1.0)"),
]:
    case(
        "magnitudes",
        label,
        f"""
        def CASE():
            return {call}
        """,
    )

# ------------------------------------------------------------------ dimension and memory
for label, call in [
    ("abelian(150)", "abelian(150)"),
    ("abelian(300)", "abelian(300)"),
    (
        "fast zeros n = 150",
        "FAST.poisson_tensor(np.zeros((150,) * 3), np.zeros((150, 150)), np.zeros((150, 150)), np.zeros(150), np.zeros(150))",
    ),
    (
        "fast zeros n = 300",
        "FAST.poisson_tensor(np.zeros((300,) * 3), np.zeros((300, 300)), np.zeros((300, 300)), np.zeros(300), np.zeros(300))",
    ),
    (
        "reference zeros n = 150",
        "REF.poisson_tensor(np.zeros((150,) * 3), np.zeros((150, 150)), np.zeros((150, 150)), np.zeros(150), np.zeros(150))",
    ),
    (
        "rigorous zeros n = 150",
        "rigorous().poisson_tensor(np.zeros((150,) * 3), np.zeros((150, 150)), np.zeros((150, 150)), np.zeros(150), np.zeros(150))",
    ),
    (
        "fast 1e8 points (broadcast)",
        "FAST.poisson_batch(F, Z3, Z3, np.broadcast_to(X3, (10**8, 3)), np.broadcast_to(P3, (10**8, 3)))",
    ),
    (
        "fast vf 1e8 points (broadcast)",
        "FAST.vector_field_batch(F, Z3, Z3, I3, None, np.broadcast_to(X3, (10**8, 3)), np.broadcast_to(P3, (10**8, 3)))",
    ),
    (
        "fast_flow 1e7 points",
        "fast_flow(F, Z3, Z3, I3, None, np.broadcast_to(X3, (10**7, 3)), np.broadcast_to(P3, (10**7, 3)), 1.0)",
    ),
    (
        "LieAlgebra exact n = 20",
        "LieAlgebra.from_structure_constants(np.zeros((20, 20, 20), dtype=int))",
    ),
]:
    case(
        "dimension/memory",
        label,
        f"""
        def CASE():
            return {call}
        CHECK = lambda r: True
        """,
    )
case(
    "dimension/memory",
    "fast n = 32 abelian (largest accepted)",
    """
    n = 32
    def CASE():
        return FAST.poisson_tensor(np.zeros((n,) * 3), np.zeros((n, n)), np.zeros((n, n)), np.zeros(n), np.ones(n))
    CHECK = lambda P: np.array_equal(P, np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]]))
    """,
)

# ------------------------------------------------------------------ flows and time
for label, call in [
    (
        "so4 Upsilon != 0, t = 1e4",
        "FAST.flow(so4().f, np.zeros((6, 6)), UP6, np.eye(6), None, np.full(6, 0.1), np.full(6, 0.2), 1e4)",
    ),
    (
        "se3 gravity, t = 1e3",
        "FAST.flow(se3().f, np.zeros((6, 6)), np.zeros((6, 6)), np.eye(6), {'kind': 'gravity', 'L': np.eye(6)[5], 'gamma': np.eye(6)[5]}, np.full(6, 0.1), np.full(6, 0.2), 1e3)",
    ),
    ("su2 t = 1e4, steps = 10**7", "fast_flow(F, Z3, Z3, I3, None, X3, P3, 1e4, steps=10**7)"),
    (
        "su2 t = 1e4, steps = 10**7, gauss6",
        "fast_flow(F, Z3, U, I3, None, X3, P3, 1e4, steps=10**7, method_name='gauss6')",
    ),
    ("su2 t = 1e5", "fast_flow(F, Z3, Z3, I3, None, X3, P3, 1e5)"),
    ("su2 t = nan", "fast_flow(F, Z3, Z3, I3, None, X3, P3, float('nan'))"),
    ("su2 steps = 0", "fast_flow(F, Z3, Z3, I3, None, X3, P3, 1.0, steps=0)"),
    ("su2 tol = 1e-20", "fast_flow(F, Z3, Z3, I3, None, X3, P3, 1.0, tol=1e-20)"),
    (
        "su2 1000 points t = 1e3 dop853",
        "fast_flow(F, Z3, Z3, I3, None, np.tile(X3, (1000, 1)), np.tile(P3, (1000, 1)), 1e3, method_name='dop853')",
    ),
    (
        "heisenberg pi 1e6, t = 1e4",
        "fast_flow(heisenberg(1).f, np.zeros((3, 3)), np.zeros((3, 3)), I3, None, X3, P3 * 1e6, 1e4)",
    ),
    ("reference flow t = 1e3", "REF.flow(F, Z3, Z3, np.diag([1., 2, 3]), None, X3, P3, 1e3)"),
]:
    case(
        "flows/time",
        label,
        f"""
        rng = np.random.default_rng(0)
        A = 0.1 * rng.standard_normal((6, 6)); UP6 = A - A.T
        def CASE():
            return {call}
        """,
    )
case(
    "flows/time",
    "su2 free top t = 10 (energy and |pi| conserved)",
    """
    I = np.diag([1., 2, 3])
    def CASE():
        return fast_flow(F, Z3, Z3, I, None, X3, P3, 10.0)
    def CHECK(r):
        x, p = r
        e0, e1 = 0.5 * P3 @ np.linalg.solve(I, P3), 0.5 * p @ np.linalg.solve(I, p)
        return finite(r) and abs(e1 - e0) < 1e-8 and abs(np.linalg.norm(p) - np.linalg.norm(P3)) < 1e-8
    """,
)

# ------------------------------------------------------------------ out= and aliasing
case(
    "out=/aliasing",
    "read-only out (compiled)",
    """
    x, p = np.zeros((4, 3)), np.ones((4, 3)); out = np.zeros((4, 6, 6)); out.flags.writeable = False
    WATCH = [x, p]
    def CASE():
        return FAST.poisson_batch(F, Z3, Z3, x, p, out=out, compiled=True)
    """,
)
case(
    "out=/aliasing",
    "read-only out (numpy)",
    """
    x, p = np.zeros((4, 3)), np.ones((4, 3)); out = np.zeros((4, 6, 6)); out.flags.writeable = False
    def CASE():
        return FAST.poisson_batch(F, Z3, Z3, x, p, out=out, compiled=False)
    """,
)
for target in ("x", "pi"):
    case(
        "out=/aliasing",
        f"out aliases {target}",
        f"""
        buf = np.zeros(4 * 36); x, p = np.full((4, 3), 0.1), np.ones((4, 3))
        view = buf[:12].reshape(4, 3)
        if {target!r} == "x":
            view[:] = x; x = view
        else:
            view[:] = p; p = view
        WATCH = [x, p]
        def CASE():
            return FAST.poisson_batch(F, Z3, Z3, x, p, out=buf.reshape(4, 6, 6))
        """,
    )
case(
    "out=/aliasing",
    "out of the wrong shape",
    """
    x, p = np.zeros((4, 3)), np.ones((4, 3))
    def CASE():
        return FAST.poisson_batch(F, Z3, Z3, x, p, out=np.zeros((4, 6, 5)))
    """,
)
case(
    "out=/aliasing",
    "separate out (result equals the fresh one)",
    """
    x, p = np.full((4, 3), 0.1), np.ones((4, 3)); out = np.empty((4, 6, 6))
    WATCH = [x, p]
    def CASE():
        return FAST.poisson_batch(F, Z3, Z3, x, p, out=out).P
    CHECK = lambda P: P is out and np.array_equal(P, FAST.poisson_batch(F, Z3, Z3, x, p).P)
    """,
)
for label, call in [
    ("fast poisson inputs unchanged", "FAST.poisson_tensor(F, XI, U, x, p)"),
    ("fast vf inputs unchanged", "FAST.hamiltonian_vector_field(F, XI, U, I3, None, x, p)"),
    ("fast_flow inputs unchanged", "fast_flow(F, XI, U, I3, None, x, p, 1.0)"),
    ("reference inputs unchanged", "REF.poisson_tensor(F, XI, U, x[0], p[0])"),
]:
    case(
        "out=/aliasing",
        label,
        f"""
        x, p = np.full((3, 3), 0.1), np.tile(P3, (3, 1)); XI = -np.einsum("k,kab->ab", [0.125, 0.25, -0.125], F)
        WATCH = [x, p, XI, U]
        def CASE():
            return {call}
        """,
    )

# ------------------------------------------------------------------ chart, degenerate, precision
for label, call, check in [
    ("fast x on the chart edge 2 pi", "FAST.poisson_tensor(F, Z3, U, [2 * np.pi, 0, 0], P3)", None),
    ("reference x on the chart edge", "REF.poisson_tensor(F, Z3, U, [2 * np.pi, 0, 0], P3)", None),
    (
        "rigorous x on the chart edge",
        "rigorous().poisson_tensor(F, Z3, U, [2 * np.pi, 0, 0], P3)",
        None,
    ),
    ("reference x = [0, 0, 1e17]", "REF.poisson_tensor(F, Z3, Z3, [0, 0, 1e17], P3)", None),
    ("reference sl2r 150 h", "REF.poisson_tensor(sl2r(), Z3, Z3, [150, 0, 0], P3)", None),
    ("fast sl2r 150 h", "FAST.poisson_tensor(sl2r().f, Z3, Z3, np.array([150., 0, 0]), P3)", None),
    (
        "reference degenerate point (C1 = 0)",
        "REF.poisson_tensor(F, Z3, U, X3, TAU / (TAU @ TAU))",
        None,
    ),
    (
        "fast degenerate point (C1 = 0)",
        "FAST.poisson_tensor(F, Z3, U, X3, TAU / (TAU @ TAU))",
        None,
    ),
    (
        "reference scaled s = 1e33 (cond Phi ~ 2e65)",
        "REF.poisson_tensor(F, Z3, U * 1e33, X3, P3 * 1e33)",
        None,
    ),
    ("Reference(10**7)", "reference.Reference(10**7)", "lambda r: False"),
    ("Reference(True)", "reference.Reference(True)", "lambda r: False"),
    (
        "Rigorous(10**9)",
        "__import__('tstarg.refimpl.rigorous', fromlist=['x']).Rigorous(10**9)",
        "lambda r: False",
    ),
    ("fast complex pi", "FAST.poisson_tensor(F, Z3, Z3, X3, P3 + 1j)", None),
    ("fast bool x", "FAST.poisson_tensor(F, Z3, Z3, np.array([True, False, True]), P3)", None),
    ("fast None pi", "FAST.poisson_tensor(F, Z3, Z3, X3, None)", None),
    ("fast ragged pi", "FAST.poisson_tensor(F, Z3, Z3, X3, [[1, 2], [3]])", None),
    (
        "fast su2 generic point (vs reference)",
        "FAST.poisson_tensor(F, Z3, U, X3, P3)",
        "lambda P: np.max(np.abs(P - REF.poisson_tensor(F, Z3, U, X3, P3))) < 1e-12",
    ),
]:
    case(
        "chart/degenerate/types",
        label,
        f"""
        def CASE():
            return {call}
        """
        + (f"CHECK = {check}\n" if check else ""),
    )


# ------------------------------------------------------------------ more inputs, each category
for category, label, call, check in [
    (
        "strings",
        "scene x0 code string",
        "__import__('tstarg.refimpl.scenes', fromlist=['x']).parse_scene({'name': 's', 'algebra': 'su2', 'x0': [CODE, 0, 0], 'pi0': [0.1, 0.2, 0.3], 't_end': 1.0})",
        "lambda r: False",
    ),
    (
        "strings",
        "reference theta string entry",
        "REF.poisson_tensor(F, [[0, CODE, 0], [0, 0, 0], [0, 0, 0]], Z3, X3, P3)",
        "lambda r: False",
    ),
    (
        "strings",
        "fast bytes pi",
        "FAST.poisson_tensor(F, Z3, Z3, X3, [b'1', b'2', b'3'])",
        "lambda r: False",
    ),
    (
        "strings",
        "rational string pi (reference, accepted)",
        "REF.poisson_tensor(F, Z3, Z3, ['1/10', '1/5', '3/10'], ['3/10', '1/5', '-2/5'])",
        "lambda P: np.max(np.abs(np.asarray(P, dtype=float) - FAST.poisson_tensor(F, Z3, Z3, X3, P3))) < 1e-13",
    ),
    (
        "magnitudes",
        "fast x = 1e300 (outside the chart)",
        "FAST.poisson_tensor(F, Z3, Z3, np.array([1e300, 0, 0]), P3)",
        None,
    ),
    (
        "magnitudes",
        "fast pi = -1.7e308",
        "FAST.poisson_tensor(F, Z3, Z3, X3, np.array([-1.7e308, 0, 0]))",
        None,
    ),
    (
        "magnitudes",
        "fast subnormal pi (exact: P_pp = [pi]_x)",
        "FAST.poisson_tensor(F, Z3, Z3, X3, np.array([5e-324, 0, 0]))",
        "lambda P: finite(P) and P[4, 5] in (-5e-324, 5e-324)",
    ),
    (
        "magnitudes",
        "reference x entries 1e300 (abelian: inside the chart)",
        "REF.poisson_tensor(np.zeros((2, 2, 2)), np.zeros((2, 2)), np.zeros((2, 2)), [1e300, 1e300], [1, 2])",
        "lambda P: np.array_equal(np.asarray(P, float), [[0, 0, 1, 0], [0, 0, 0, 1], [-1, 0, 0, 0], [0, -1, 0, 0]])",
    ),
    (
        "dimension/memory",
        "fast n = 33 (one over the budget)",
        "FAST.poisson_tensor(np.zeros((33,) * 3), np.zeros((33, 33)), np.zeros((33, 33)), np.zeros(33), np.zeros(33))",
        None,
    ),
    (
        "dimension/memory",
        "fast f of shape (3, 3, 2)",
        "FAST.poisson_tensor(np.zeros((3, 3, 2)), Z3, Z3, X3, P3)",
        None,
    ),
    (
        "dimension/memory",
        "fast f of shape (0, 0, 0)",
        "FAST.poisson_tensor(np.zeros((0, 0, 0)), Z3, Z3, X3, P3)",
        None,
    ),
    (
        "dimension/memory",
        "fast x with 1e9 entries (broadcast)",
        "FAST.poisson_tensor(F, Z3, Z3, np.broadcast_to(X3, (4 * 10**8, 3)), np.broadcast_to(P3, (4 * 10**8, 3)))",
        None,
    ),
    ("flows/time", "t = -1e5", "fast_flow(F, Z3, Z3, I3, None, X3, P3, -1e5)", None),
    ("flows/time", "steps = True", "fast_flow(F, Z3, Z3, I3, None, X3, P3, 1.0, steps=True)", None),
    (
        "flows/time",
        "steps = 10**8",
        "fast_flow(F, Z3, Z3, I3, None, X3, P3, 1.0, steps=10**8)",
        None,
    ),
    (
        "flows/time",
        "method 'nonexistent'",
        "fast_flow(F, Z3, Z3, I3, None, X3, P3, 1.0, method_name='nonexistent')",
        None,
    ),
    (
        "flows/time",
        "tol = nan",
        "fast_flow(F, Z3, Z3, I3, None, X3, P3, 1.0, tol=float('nan'))",
        None,
    ),
    (
        "flows/time",
        "t = 0 returns the start",
        "fast_flow(F, Z3, Z3, I3, None, X3, P3, 0.0)",
        "lambda r: np.array_equal(r[0], X3) and np.array_equal(r[1], P3)",
    ),
    (
        "out=/aliasing",
        "Fortran-ordered out",
        "FAST.poisson_batch(F, Z3, Z3, np.zeros((4, 3)), np.ones((4, 3)), out=np.asfortranarray(np.zeros((4, 6, 6))))",
        None,
    ),
    (
        "out=/aliasing",
        "float32 out",
        "FAST.poisson_batch(F, Z3, Z3, np.zeros((4, 3)), np.ones((4, 3)), out=np.zeros((4, 6, 6), np.float32))",
        None,
    ),
    (
        "out=/aliasing",
        "out a list",
        "FAST.poisson_batch(F, Z3, Z3, np.zeros((4, 3)), np.ones((4, 3)), out=[0.0] * 144)",
        None,
    ),
    (
        "out=/aliasing",
        "out aliases x in the components layout",
        "FAST.poisson_batch(F, Z3, Z3, BUF[:12].reshape(3, 4), BUF[:12].reshape(3, 4) * 0 + 1, layout='components', out=BUF.reshape(6, 6, 4))",
        None,
    ),
    (
        "chart/degenerate/types",
        "fast Fraction pi (matches float)",
        "FAST.poisson_tensor(F, Z3, Z3, X3, [__import__('fractions').Fraction(3, 10), 0.2, -0.4])",
        "lambda P: np.array_equal(P, FAST.poisson_tensor(F, Z3, Z3, X3, np.array([0.3, 0.2, -0.4])))",
    ),
    (
        "chart/degenerate/types",
        "fast mpmath pi",
        "FAST.poisson_tensor(F, Z3, Z3, X3, [__import__('mpmath').mpf('0.3'), 0.2, -0.4])",
        None,
    ),
    (
        "chart/degenerate/types",
        "fast x of the wrong length",
        "FAST.poisson_tensor(F, Z3, Z3, [0.1, 0.2], P3)",
        None,
    ),
    (
        "chart/degenerate/types",
        "fast non-antisymmetric upsilon",
        "FAST.poisson_tensor(F, Z3, np.eye(3), X3, P3)",
        None,
    ),
    (
        "chart/degenerate/types",
        "fast theta not a cocycle",
        "FAST.poisson_tensor(heisenberg(1).f, np.array([[0, 1., 0], [-1, 0, 0], [0, 0, 0]]) @ np.diag([1, 1, 0]) + np.array([[0, 0, 1.], [0, 0, 0], [-1, 0, 0]]), np.zeros((3, 3)), X3, P3)",
        None,
    ),
    (
        "chart/degenerate/types",
        "fast near the chart edge (inside)",
        "FAST.poisson_tensor(F, Z3, U, [np.nextafter(2 * np.pi, 0) * 0.999, 0, 0], P3)",
        "lambda P: np.max(np.abs(P - REF.poisson_tensor(F, Z3, U, [np.nextafter(2 * np.pi, 0) * 0.999, 0, 0], P3))) < 1e-6",
    ),
]:
    case(
        category,
        label,
        f"""
        BUF = np.zeros(144)
        def CASE():
            return {call}
        """
        + (f"CHECK = {check}\n" if check else ""),
    )


# ------------------------------------------------------------------ the runner
def run_case(category: str, label: str, body: str, timeout: float) -> dict:
    program = PRELUDE + body + RUNNER
    with tempfile.TemporaryDirectory(prefix="tstarg-probe-") as tmp:
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
        start = time.monotonic()
        proc = subprocess.Popen(
            [sys.executable, "-c", program],
            cwd=tmp,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            return {
                "category": category,
                "label": label,
                "outcome": "hang",
                "detail": f"> {timeout:g} s",
            }
        took = time.monotonic() - start
        for line in out.splitlines():
            if line.startswith("PROBE-RESULT "):
                res = json.loads(line[len("PROBE-RESULT ") :])
                res.update(category=category, label=label, seconds=round(took, 1))
                return res
        outcome = "crash" if proc.returncode else "lost"
        return {
            "category": category,
            "label": label,
            "outcome": outcome,
            "detail": f"exit {proc.returncode}: {err.strip().splitlines()[-1] if err.strip() else ''}"[
                :300
            ],
        }


COLUMNS = ["clear error", "correct", "silent", "hang", "crash", "mutated", "lost"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--timeout", type=float, default=120.0, help="hard wall-clock limit per input (s)"
    )
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--only", default=None, help="run one category")
    ap.add_argument("--json", default=None, help="also write every outcome to this file")
    args = ap.parse_args(argv)
    cases = [c for c in CASES if args.only is None or c[0] == args.only]
    results: list[dict] = []
    with ThreadPoolExecutor(max_workers=args.workers) as pool:
        futures = [pool.submit(run_case, *c, args.timeout) for c in cases]
        for k, fut in enumerate(futures, 1):
            res = fut.result()
            results.append(res)
            print(
                f"[{k}/{len(cases)}] {res['category']}: {res['label']}: {res['outcome']}",
                file=sys.stderr,
                flush=True,
            )
    cats = list(dict.fromkeys(c[0] for c in cases))
    print("| category | inputs | " + " | ".join(COLUMNS) + " |")
    print("|---" * (len(COLUMNS) + 2) + "|")
    for cat in cats + ["total"]:
        rows = [r for r in results if cat == "total" or r["category"] == cat]
        counts = [sum(r["outcome"] == c for r in rows) for c in COLUMNS]
        print(f"| {cat} | {len(rows)} | " + " | ".join(str(v) for v in counts) + " |")
    bad = [r for r in results if r["outcome"] not in ("clear error", "correct")]
    for r in bad:
        print(f"- {r['category']} / {r['label']}: {r['outcome']}: {r.get('detail', '')}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(results, fh, indent=1)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
