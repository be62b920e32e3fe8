"""For every batched method: leading batch axes of rank 0 to 3 (sizes 1 included), given as arrays or
nested lists; each point equals the same point evaluated alone; shapes as the protocol says."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    C_CERT,
    conditioning,
    eps_impl,
    max_err,
)
from tstarg.refimpl import PROTOCOL

from .._common import (
    _call,
    _cheap_flow,
    _finite_array,
)
from ..check import Check, planted
from ..domain import _batched
from ..models import _BATCH_SHAPES, _inertias, _models, _potentials


def _batch(impl, dom, stats):
    """Every batched method: leading axes of rank 0..3 (sizes 1 included), arrays or nested lists;
    each point of the batch equals that point evaluated alone (same implementation)."""
    methods = [
        m
        for m in ("poisson_tensor", "hamiltonian_vector_field", "flow")
        if callable(getattr(impl, m, None))
    ]

    def body(ex):
        model, inertia, pot, shape, pts, as_list, t, big = ex
        out = [
            one_method(m, model, inertia, pot, shape, pts, as_list, t)
            for m in methods
            if m != "flow" or _cheap_flow(model[1:4], inertia, pot, pts, t)
        ]
        if not out or any(o is None for o in out):
            return None
        out += [large_batch(m, model, inertia, pot, *big) for m in methods if m != "flow"]
        return max(out), None

    def large_batch(method, model, inertia, pot, size, seed):
        """One long leading axis (``size`` up to 1025 points, past the small shapes above and past
        a 1024-point chunk): every point must come back in its place. The points are compared with
        single calls at the first three, the last three and 24 random indices (a dropped, shifted,
        stale or chunk-misaligned point changes at least one of them)."""
        _name, f, theta, ups, _, _ = model
        n = f.shape[0]
        rng = np.random.default_rng(seed)
        X = rng.uniform(-0.5, 0.5, (size, n))
        Pm = rng.uniform(-2.0, 2.0, (size, n))
        conds = np.empty(size)
        for k in range(size):  # redraw the (rare) points near the degenerate set: cond <= 1e6
            for _ in range(20):
                c, fr = conditioning(f, theta, ups, X[k], Pm[k])
                if math.isfinite(c) and c <= 1e6:
                    break
                Pm[k] = rng.uniform(-2.0, 2.0, n)
            else:
                return 0.0
            conds[k] = c * fr
        extra = () if method == "poisson_tensor" else (inertia, pot)
        out = _call(impl, method, f, theta, ups, *extra, X.copy(), Pm.copy())
        out = (out,) if method == "poisson_tensor" else out
        shapes = [(size, 2 * n, 2 * n)] if method == "poisson_tensor" else [(size, n)] * 2
        got = [
            _finite_array(o, s, f"batched {method} ({size} points on one axis)")
            for o, s in zip(out, shapes)
        ]
        idx = sorted({0, 1, 2, size - 3, size - 2, size - 1} | set(rng.integers(0, size, 24)))
        worst = 0.0
        for k in idx:
            one = _call(impl, method, f, theta, ups, *extra, X[k].copy(), Pm[k].copy())
            one = (one,) if method == "poisson_tensor" else one
            for g, o in zip(got, one):
                o = np.asarray(o, dtype=float)
                scale = max(1.0, float(np.max(np.abs(o))))
                # the batched point and the single call are the same computation up to rounding:
                # c n eps cond scale, cond of that point (conditioning of Phi times the frame's)
                tol = C_CERT * n * eps_impl(impl) * conds[k] * scale
                err = max_err(g[k], o)
                if err > tol:
                    raise AssertionError(
                        f"batched {method} with {size} points: point {k} differs from the same "
                        f"point evaluated alone by {err:.3g} (tolerance {tol:.3g})"
                    )
                worst = max(worst, err / tol)
        return worst

    def one_method(method, model, inertia, pot, shape, pts, as_list, t):
        _name, f, theta, ups, _, _ = model
        n = f.shape[0]
        X = np.array([p[0] for p in pts]).reshape(tuple(shape) + (n,))
        Pm = np.array([p[1] for p in pts]).reshape(tuple(shape) + (n,))
        conds = [conditioning(f, theta, ups, x, p) for x, p in pts]
        if any(not math.isfinite(c) or c > 1e6 for c, _ in conds):
            return None
        cond = max(c * fr for c, fr in conds)
        Xa, Pa = (X.tolist(), Pm.tolist()) if as_list else (X, Pm)
        extra = () if method == "poisson_tensor" else (inertia, pot)
        tail = (t,) if method == "flow" else ()

        def single(x, p):
            out = _call(impl, method, f, theta, ups, *extra, x, p, *tail)
            return (out,) if method == "poisson_tensor" else out

        try:
            out = single(Xa, Pa)
        except ValueError as exc:
            # a refusal is consistent only when some point of the batch is refused on its own too
            for x, p in pts:
                try:
                    single(x, p)
                except ValueError:
                    return None
            raise AssertionError(
                f"batched {method} raised ValueError ({exc}) though every point "
                "of the batch is accepted on its own"
            ) from None
        shapes = (
            [tuple(shape) + (2 * n, 2 * n)]
            if method == "poisson_tensor"
            else [tuple(shape) + (n,)] * 2
        )
        got = [
            _finite_array(o, s, f"batched {method} (batch shape {tuple(shape)}, lists={as_list})")
            for o, s in zip(out, shapes)
        ]
        flat = [g.reshape((-1,) + s[len(shape) :]) for g, s in zip(got, shapes)]
        worst = 0.0
        for k, (x, p) in enumerate(pts):
            one = [np.asarray(o, dtype=float) for o in single(x, p)]
            for g, o in zip(flat, one):
                scale = max(1.0, float(np.max(np.abs(o))))
                tol = C_CERT * n * eps_impl(impl) * cond * scale
                if method == "flow":
                    tol = max(tol, float(PROTOCOL.declared(impl, "flow_tolerance")) * scale)
                worst = max(worst, max_err(g[k], o) / tol)
        return worst

    @st.composite
    def strat(draw):
        model = draw(_models("generic", dom))
        alg_n = model[1].shape[0]
        shape = draw(_BATCH_SHAPES, label="batch shape")
        k = int(np.prod(shape)) if shape else 1
        pts = [
            (
                draw(st.lists(st.floats(-0.5, 0.5), min_size=alg_n, max_size=alg_n).map(np.array)),
                draw(st.lists(st.floats(-2, 2), min_size=alg_n, max_size=alg_n).map(np.array)),
            )
            for _ in range(k)
        ]
        return (
            model,
            draw(_inertias(alg_n)),
            draw(_potentials(alg_n, dom)),
            shape,
            pts,
            draw(st.booleans(), label="as lists"),
            0.05,
            (
                draw(st.sampled_from([9, 17, 1025]), label="large batch size"),
                draw(st.integers(0, 2**32 - 1), label="large batch seed"),
            ),
        )

    return body, strat()


def _applies(impl, dom):
    return None if _batched(impl) else "the implementation does not declare batched = True"


CHECK = Check(
    id="poisson_tensor.batch",
    needs=("poisson_tensor",),
    equations="(protocol)",
    build=_batch,
    order=40,
    budget=lambda k: max(3, k // 3),
    applies=_applies,
    mutants=planted("batch_flattened", "batch_tail_stale"),
)
