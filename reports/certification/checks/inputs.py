"""For every method: the caller's arrays are unchanged after the call; lists give the same result as
arrays; outputs are finite float64 arrays of the protocol's shapes; interleaved calls with
different models through the *same* caller buffers (refilled in place) each agree with the judges
(no stale caches keyed by object identity, dimension or call order)."""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    C_CERT,
    ad,
    compare_state,
    conditioning,
    eps_impl,
    flow_tol,
    max_err,
    phi1,
)

from .._common import (
    _REF,
    ALLOW_CHART_REFUSAL,
    _as_lists,
    _call,
    _catalogue_rep,
    _cheap_flow,
    _count,
    _judge_state,
    _odd_layout,
)
from ..check import ANY_METHOD, Check, planted
from ..models import Hamiltonian, _inertias, _models, _potentials


def _inputs(impl, dom, stats):
    """Caller's arrays unchanged; lists accepted; outputs finite float64 of the protocol's shapes;
    interleaved models through the same (refilled) caller buffers agree with independent judges."""
    methods = [
        m
        for m in ("poisson_tensor", "hamiltonian_vector_field", "flow")
        if callable(getattr(impl, m, None))
    ]

    def judge(method, f, theta, ups, inertia, pot, x, pi, t):
        if method == "poisson_tensor":
            return (_REF.poisson_tensor(f, theta, ups, x, pi),)
        if method == "hamiltonian_vector_field":
            return _REF.hamiltonian_vector_field(f, theta, ups, inertia, pot, x, pi)
        (jx, jp, jA), _ = _judge_state(f, theta, ups, inertia, pot, x, pi, t)
        return jx, jp, jA

    def call(method, bufs, t):
        f, theta, ups, inertia, pot, x, pi = bufs
        if method == "poisson_tensor":
            return (_call(impl, method, f, theta, ups, x, pi),)
        if method == "hamiltonian_vector_field":
            return tuple(_call(impl, method, f, theta, ups, inertia, pot, x, pi))
        return tuple(_call(impl, method, f, theta, ups, inertia, pot, x, pi, t))

    def check_out(method, out, n, what):
        shapes = [(2 * n, 2 * n)] if method == "poisson_tensor" else [(n,), (n,)]
        if len(out) != len(shapes):
            raise AssertionError(
                f"{method} ({what}): returned {len(out)} values, expected {len(shapes)}"
            )
        res = []
        for o, s in zip(out, shapes):
            if not isinstance(o, np.ndarray) or o.dtype != np.float64:
                got = type(o).__name__ if not isinstance(o, np.ndarray) else f"ndarray of {o.dtype}"
                raise AssertionError(
                    f"{method} ({what}): returned {got}; the protocol returns float64 numpy arrays"
                )
            if o.shape != s:
                raise AssertionError(f"{method} ({what}): result has shape {o.shape}, expected {s}")
            if not np.all(np.isfinite(o)):
                raise AssertionError(f"{method} ({what}): non-finite result at a regular point")
            res.append(o)
        return res

    def err_ratio(method, got, ref, f, tol_abs):
        if method == "flow":
            return compare_state(impl, f, got[0], got[1], ref[0], ref[1], ref[2], tol_abs)
        return max(max_err(g, r) / tol_abs for g, r in zip(got, ref))

    def body(ex):
        t, (A, IA, potA), (B, IB, potB) = ex
        out = [
            one_method(m, t, (A, IA, potA), (B, IB, potB))
            for m in methods
            if m != "flow"
            or all(
                _cheap_flow(M[1:4], II, pp, [M[4:6]], t)
                for M, II, pp in ((A, IA, potA), (B, IB, potB))
            )
        ]
        if not out or any(o is None for o in out):
            return None
        return max(out), None

    def one_method(method, t, first, second):
        (A, IA, potA), (B, IB, potB) = first, second
        worst = 0.0
        n = A[1].shape[0]
        for M, *_ in ((A,), (B,)):
            c, _fr = conditioning(M[1], M[2], M[3], M[4], M[5])
            if not math.isfinite(c) or c > 1e6:
                return None
        seqs = {"A": (A, IA, potA), "B": (B, IB, potB)}

        def data(key):
            (_name, f, theta, ups, x, pi), inertia, pot = seqs[key]
            return [f, theta, ups, inertia, pot, x, pi]

        def tol_for(key, ref):
            (_name, f, theta, ups, x, pi), _, _ = seqs[key]
            c, fr = conditioning(f, theta, ups, x, pi)
            scale = max(1.0, max(float(np.max(np.abs(r))) for r in ref if r is not None))
            tol = C_CERT * n * eps_impl(impl) * c * fr * scale
            if method == "hamiltonian_vector_field":
                tol *= max(1.0, float(np.max(np.abs(np.linalg.inv(phi1(-ad(f, x)))))))
            if method == "flow":
                tol = max(tol, flow_tol(impl, n, c, fr) * scale)
            return tol

        refs = {k: judge(method, *data(k), t) for k in seqs}
        # caller buffers: copies of A's data, refilled in place with B's and A's again
        bufs = [
            None
            if a is None
            else (
                {k: (v if k == "kind" else np.array(v, dtype=float)) for k, v in a.items()}
                if isinstance(a, dict)
                else np.array(a, dtype=float)
            )
            for a in data("A")
        ]
        for step, key in enumerate(("A", "B", "A")):
            src = data(key)
            for buf, val in zip(bufs, src):
                if isinstance(buf, dict):
                    for k in ("L", "gamma"):
                        buf[k][...] = val[k]
                elif buf is not None:
                    buf[...] = val
            pristine = [
                None
                if b is None
                else (
                    {k: (v if k == "kind" else v.copy()) for k, v in b.items()}
                    if isinstance(b, dict)
                    else b.copy()
                )
                for b in bufs
            ]
            try:
                out = check_out(
                    method,
                    call(method, bufs, t),
                    n,
                    f"model {key}, call {step + 1} of an interleaved sequence",
                )
            except ValueError as exc:
                if (
                    method == "flow"
                    and ALLOW_CHART_REFUSAL
                    and (refs[key][0] is None or not _catalogue_rep(src[0]))
                ):
                    _count(stats, "flow refused past the chart edge (ValueError)")
                    return None
                raise AssertionError(
                    f"{method} raised ValueError at a regular point (model {key}): {exc}"
                ) from None
            names = ["f", "theta", "upsilon", "inertia", "potential", "x", "pi"]
            for nm, b, p in zip(names, bufs, pristine):
                if b is None:
                    continue
                # bytes, not values: -0.0 written over 0.0 is a mutation too
                same = (
                    all(b[k].tobytes() == p[k].tobytes() for k in ("L", "gamma"))
                    if isinstance(b, dict)
                    else b.tobytes() == p.tobytes()
                )
                if not same:
                    raise AssertionError(
                        f"{method} mutated its input {nm!r} (the caller's array changed)"
                    )
            ratio = err_ratio(method, out, refs[key], src[0], tol_for(key, refs[key]))
            if ratio > 1:
                raise AssertionError(
                    f"{method}: interleaved call {step + 1} (model {key} after "
                    f"{'model A' if step else 'nothing'}) disagrees with the judge: ratio "
                    f"{ratio:.3g}{' (a stale cache?)' if step else ''}"
                )
            worst = max(worst, ratio)
            if step == 0:
                lst = call(method, [_as_lists(a) for a in data("A")], t)
                lst = check_out(
                    method,
                    tuple(np.asarray(v) if isinstance(v, list) else v for v in lst),
                    n,
                    "inputs given as nested lists",
                )
                worst = max(
                    worst, err_ratio(method, lst, refs["A"], src[0], tol_for("A", refs["A"]))
                )
                # other memory layouts, read-only: strided views (vectors), Fortran order
                # (matrices and f); a kernel that assumes C-contiguous data, or writes into its
                # inputs, fails here
                odd = call(method, [_odd_layout(a) for a in data("A")], t)
                odd = check_out(
                    method, odd, n, "inputs as read-only strided / Fortran-ordered arrays"
                )
                worst = max(
                    worst, err_ratio(method, odd, refs["A"], src[0], tol_for("A", refs["A"]))
                )
        return worst

    @st.composite
    def strat(draw):
        A = draw(_models("generic", dom), label="model A")
        n = A[1].shape[0]
        # model B: another model of the same dimension (another algebra where one exists)
        B = draw(_models("generic", dom).filter(lambda m: m[1].shape[0] == n), label="model B")
        pots = (draw(_potentials(n, dom)), draw(_potentials(n, dom)))
        if (pots[0] is None) != (pots[1] is None):
            pots = (pots[0], pots[0])
        return InputsExample(
            draw(st.sampled_from([0.1, 0.3]), label="t"),
            Hamiltonian(A, draw(_inertias(n)), pots[0]),
            Hamiltonian(B, draw(_inertias(n)), pots[1]),
        )

    return body, strat()


CHECK = Check(
    id="protocol.inputs",
    needs=ANY_METHOD,
    equations="(protocol), vier9, vier10, vier11",
    build=_inputs,
    order=50,
    budget=lambda k: max(3, k // 3),
    mutants=planted(
        "mutates_input", "stale_cache", "lists_rejected", "float32_output", "layout_assumed"
    ),
)


InputsExample = namedtuple("InputsExample", "t model_A model_B")
"""Two models of one dimension called in turn through the same caller buffers (A, B, A)."""
