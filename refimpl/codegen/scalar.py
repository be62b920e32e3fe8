"""Generated Python and numpy code for the polynomial body systems (``Upsilon = 0``).

For one trajectory numpy's per-call overhead dominates (arrays of 6 numbers), so the reduced body
system with ``Upsilon = 0`` -- a quadratic polynomial (twee14/drie6, Euler-Poisson twee17
corrected/twee18) -- is written out as straight-line Python over floats: the polynomial of
:func:`refimpl._taylor.quadratic_field` (``w = I^-1 pi`` eliminated, equal monomials merged, zero
terms dropped) with its coefficients as literals. Emitters here take that
:class:`refimpl._taylor.QuadraticField` ``F`` (never a model) and return source text
(``*_source``) or the compiled function (through :func:`refimpl.codegen._loader.define`):

* :func:`scalar_rk` -- an explicit RK tableau unrolled around the field inside one loop (same method
  as :class:`refimpl._integrators.ExplicitRK`; rounding differs only in order);
* :func:`scalar_rhs`, :func:`numpy_body_rhs`, :func:`numpy_body_rhs_inplace` -- the field alone, over
  floats, numpy rows, or written into ``out`` by ufunc ``out=`` calls;
* :func:`scalar_taylor`, :func:`numpy_taylor_step` -- the Taylor recurrences of :mod:`refimpl._taylor`
  (Cauchy products) unrolled for one trajectory, or batched over rows.
"""

from __future__ import annotations

import numpy as np

from ._loader import define

__all__ = [
    "numpy_body_rhs",
    "numpy_body_rhs_inplace",
    "numpy_taylor_step",
    "numpy_taylor_step_source",
    "scalar_rhs",
    "scalar_rk",
    "scalar_rk_source",
    "scalar_taylor",
    "scalar_taylor_source",
]


def _lit(v: float) -> str:
    return repr(float(v))


def _term(sign_coef: float, *names: str) -> str:
    """``+ c*a*b`` with the factor dropped when ``c = +-1``."""
    prod = "*".join(names)
    if sign_coef == 1:
        return f"+ {prod}"
    if sign_coef == -1:
        return f"- {prod}"
    return f"+ {_lit(sign_coef)}*{prod}" if sign_coef > 0 else f"- {_lit(-sign_coef)}*{prod}"


def _sum_expr(terms) -> str:
    if not terms:
        return "0.0"
    parts = [_term(c, *fac) for c, fac in terms]
    return " ".join(parts).removeprefix("+ ")


def _field_lines(F, pfx: str, ys: list[str]) -> list[str]:
    """Statements ``{pfx}c = ...`` for the quadratic field ``F`` in the names ``ys`` (equal monomials
    merged -- e.g. ``2 p1 p2 - p2 p1 = p1 p2`` for a symmetric top -- zero coefficients dropped)."""
    lines = []
    for c in range(F.d):
        terms = [(q, (ys[i], ys[j])) for (i, j), q in F.quad[c].items()]
        terms += [(q, (ys[i],)) for i, q in F.lin[c].items()]
        lines.append(f"{pfx}{c} = " + _sum_expr(terms))
    return lines


def scalar_rk_source(F, tableau) -> str:
    """``run(yinit, h, nsteps, observe=None) -> list``: the explicit RK ``tableau = (A, b, c)``
    unrolled around the field ``F``."""
    A, b, c = tableau
    s = len(b)
    d = F.d
    y = [f"y{i}" for i in range(d)]
    src = ["def run(yinit, h, nsteps, observe=None):", "    " + ", ".join(y) + ", = yinit"]
    for i in range(s):
        for j in range(i):
            if A[i, j] != 0:
                src.append(f"    a{i}_{j} = h*{_lit(A[i, j])}")
    for j in range(s):
        if b[j] != 0:
            src.append(f"    b{j} = h*{_lit(b[j])}")
    src.append("    for step in range(nsteps):")
    ind = "        "
    for i in range(s):
        if i == 0:
            args = y
        else:
            args = []
            for comp in range(d):
                terms = [f"a{i}_{j}*k{j}_{comp}" for j in range(i) if A[i, j] != 0]
                src.append(f"{ind}z{comp} = y{comp} + " + (" + ".join(terms) if terms else "0.0"))
                args.append(f"z{comp}")
        src += [ind + line for line in _field_lines(F, f"k{i}_", args)]
    for comp in range(d):
        terms = [f"b{j}*k{j}_{comp}" for j in range(s) if b[j] != 0]
        src.append(f"{ind}y{comp} = y{comp} + " + " + ".join(terms))
    src.append(f"{ind}if observe is not None: observe(step + 1, [" + ", ".join(y) + "])")
    src.append("    return [" + ", ".join(y) + "]")
    return "\n".join(src)


def scalar_rk(F, tableau):
    """The compiled :func:`scalar_rk_source`."""
    return define(scalar_rk_source(F, tableau), "run", "<tstarg scalar rk>")


def scalar_rhs(F):
    """The body right-hand side alone, ``rhs(t, y) -> list`` (for baselines such as solve_ivp).

    An ndarray ``y`` is converted to Python floats first (``tolist``): arithmetic on numpy scalars
    costs several times that on floats."""
    y = [f"y{i}" for i in range(F.d)]
    src = [
        "def rhs(t, y):",
        "    if type(y) is not list: y = y.tolist()",
        "    " + ", ".join(y) + ", = y",
    ]
    src += ["    " + line for line in _field_lines(F, "k", y)]
    src.append("    return [" + ", ".join(f"k{i}" for i in range(F.d)) + "]")
    return define("\n".join(src), "rhs", "<tstarg scalar rhs>")


def numpy_body_rhs(F):
    """The same straight-line body right-hand side over numpy rows: ``rhs(y) -> array`` of y's shape.

    Used by the batched integrators when ``Upsilon = 0``: zero structure constants, inertia and
    ``L`` entries cost nothing, and no (n, n, N) intermediate is formed."""
    y = [f"y{i}" for i in range(F.d)]
    src = ["def rhs(y):", "    " + ", ".join(y) + ", = y", "    out = _np.empty_like(y)"]
    for line in _field_lines(F, "k", y):
        name, expr = line.split(" = ", 1)
        src.append(f"    out[{name[1:]}] = {expr}")
    src.append("    return out")
    return define("\n".join(src), "rhs", "<tstarg numpy rhs>", {"_np": np})


def numpy_body_rhs_inplace(F):
    """``rhs(y, out)`` writing the body field into ``out`` with ufunc ``out=`` calls only (no temporaries
    beyond two preallocated rows): the batched integrators' hot path when ``Upsilon = 0``."""
    d = F.d
    y = [f"y[{i}]" for i in range(d)]
    outs = {
        c: [(q, (y[i], y[j])) for (i, j), q in F.quad[c].items()]
        + [(q, (y[i],)) for i, q in F.lin[c].items()]
        for c in range(d)
    }
    src = ["def rhs(y, out):", "    t = _buf(y.shape[1:])"]
    for k, terms in outs.items():
        o = f"out[{k}]"
        if not terms:
            src.append(f"    {o}[...] = 0.0")
            continue
        # a positive product first (written straight into out), then one pass per further term:
        # +-1 coefficients fold into += / -=, linear +-1 terms add the row itself
        terms = sorted(terms, key=lambda cf: (len(cf[1]) < 2, cf[0] < 0))
        c0, f0 = terms[0]
        if len(f0) == 1:
            src.append(f"    _np.multiply({f0[0]}, {_lit(c0)}, out={o})")
        else:
            src.append(f"    _np.multiply({f0[0]}, {f0[1]}, out={o})")
            if c0 != 1.0:
                src.append(f"    {o} *= {_lit(c0)}")
        for c, fac in terms[1:]:
            op = "+=" if c > 0 else "-="
            if len(fac) == 1 and abs(c) == 1.0:
                src.append(f"    {o} {op} {fac[0]}")
                continue
            if len(fac) == 1:
                src.append(f"    _np.multiply({fac[0]}, {_lit(abs(c))}, out=t)")
            else:
                src.append(f"    _np.multiply({fac[0]}, {fac[1]}, out=t)")
                if abs(c) != 1.0:
                    src.append(f"    t *= {_lit(abs(c))}")
            src.append(f"    {o} {op} t")
    src.append("    return out")
    cache: dict = {}  # one scratch row per batch shape, owned by this function

    def _buf(shape):
        key = ("t", shape)
        if key not in cache:
            if len(cache) >= 8:
                cache.clear()
            cache[key] = np.empty(shape)
        return cache[key]

    return define("\n".join(src), "rhs", "<tstarg numpy rhs in place>", {"_np": np, "_buf": _buf})


def _linear(terms) -> str:
    """``c1*a1 + c2*a2 ...`` with unit coefficients written as signs."""
    out = []
    for c, name in terms:
        if c == 1.0:
            out.append(f"+ {name}")
        elif c == -1.0:
            out.append(f"- {name}")
        elif c > 0:
            out.append(f"+ {_lit(c)}*{name}")
        else:
            out.append(f"- {_lit(-c)}*{name}")
    return " ".join(out).removeprefix("+ ")


def scalar_taylor_source(F, P: int) -> str:
    """``run(yinit, h, nsteps, observe=None) -> list``: ``nsteps`` Taylor steps of order ``P``, the
    whole step unrolled (:mod:`refimpl._taylor`). A component whose field is identically zero is
    constant, so its coefficients ``Y_{k>=1}`` and every Cauchy-product term containing them are
    dropped. Only ``+ - * /`` and float literals: it also runs on ``mpmath.mpf``."""
    d = F.d
    const = F.constant_components()
    mons = F.monomials()

    def zero(c, k):
        return k >= 1 and c in const

    src = [
        "def run(yinit, h, nsteps, observe=None):",
        "    " + "".join(f"y{c}_0, " for c in range(d)) + "= yinit",
    ]
    for k in range(P):
        src.append(f"    r{k} = h / {float(k + 1)!r}")
    src.append("    for step in range(nsteps):")
    ind = "        "
    for k in range(P):
        # Cauchy products (coefficient k of y_i y_j); squares summed over half the terms
        for i, j in mons:
            if i == j:
                terms = [
                    f"y{i}_{a}*y{i}_{k - a}"
                    for a in range((k + 1) // 2)
                    if not zero(i, a) and not zero(i, k - a)
                ]
                expr = f"2.0*({' + '.join(terms)})" if terms else ""
                if k % 2 == 0 and not zero(i, k // 2):
                    expr = (expr + " + " if expr else "") + f"y{i}_{k // 2}*y{i}_{k // 2}"
            else:
                terms = [
                    f"y{i}_{a}*y{j}_{k - a}"
                    for a in range(k + 1)
                    if not zero(i, a) and not zero(j, k - a)
                ]
                expr = " + ".join(terms)
            src.append(f"{ind}m{i}_{j} = {expr or '0.0'}")
        for c in range(d):
            if c in const:
                continue
            terms = [(q, f"m{i}_{j}") for (i, j), q in F.quad[c].items()]
            terms += [(q, f"y{i}_{k}") for i, q in F.lin[c].items() if not zero(i, k)]
            src.append(f"{ind}y{c}_{k + 1} = r{k}*({_linear(terms) if terms else '0.0'})")
    for c in range(d):
        if c in const:
            continue
        # sum from the smallest terms up: Y_P + Y_{P-1} + ... + Y_0 (left to right)
        src.append(f"{ind}y{c}_0 = " + " + ".join(f"y{c}_{k}" for k in range(P, -1, -1)))
    state = "[" + ", ".join(f"y{c}_0" for c in range(d)) + "]"
    src.append(f"{ind}if observe is not None: observe(step + 1, {state})")
    src.append(f"    return {state}")
    return "\n".join(src)


def scalar_taylor(F, P: int):
    """The compiled :func:`scalar_taylor_source`."""
    return define(scalar_taylor_source(F, P), "run", f"<tstarg taylor{P} scalar>")


def numpy_taylor_step_source(F, P: int) -> str:
    """``step(Y, pr, tmp, ones, flat, h)``: one batched Taylor step of order ``P`` on the coefficient
    array ``Y`` (``(P + 1, d, N)``): per order one two-operand ``einsum`` per monomial over strided
    views (a constant factor keeps its ``a = 0`` term only), then ``y(t + h) = sum_k Y_k`` as one
    matrix-vector product (constant components have ``Y_{k>=1} = 0`` and come out unchanged)."""
    d = F.d
    const = F.constant_components()
    mons = F.monomials()
    slot = {ij: r for r, ij in enumerate(mons)}
    src = ["def step(Y, pr, tmp, ones, flat, h):"]
    ind = "    "
    for k in range(P):
        src.append(f"{ind}r = h / {float(k + 1)!r}")
        for (i, j), s in slot.items():
            if i in const and j in const:
                src.append(f"{ind}pr[{s}] = " + (f"Y[0, {i}] * Y[0, {j}]" if k == 0 else "0.0"))
            elif i in const or j in const:
                u, v = (i, j) if i in const else (j, i)  # u constant: only Y_{0,u} Y_{k,v}
                src.append(f"{ind}_np.multiply(Y[0, {u}], Y[{k}, {v}], out=pr[{s}])")
            elif k == 0:
                src.append(f"{ind}_np.multiply(Y[0, {i}], Y[0, {j}], out=pr[{s}])")
            else:
                src.append(
                    f"{ind}_np.einsum('an,an->n', Y[:{k + 1}, {i}], Y[{k}::-1, {j}], out=pr[{s}])"
                )
        for c in range(d):
            if c in const:
                continue
            terms = [(q, f"pr[{slot[ij]}]") for ij, q in F.quad[c].items()]
            terms += [
                (q, f"Y[{k}, {i}]") for i, q in F.lin[c].items() if not (k >= 1 and i in const)
            ]
            o = f"Y[{k + 1}, {c}]"
            if not terms:
                src.append(f"{ind}{o} = 0.0")
                continue
            q0, a0 = terms[0]
            src.append(f"{ind}_np.multiply({a0}, {_lit(q0)} * r, out={o})")
            for q, a in terms[1:]:
                src.append(f"{ind}_np.multiply({a}, {_lit(q)} * r, out=tmp)")
                src.append(f"{ind}{o} += tmp")
    src.append(f"{ind}_np.dot(ones, Y.reshape({P + 1}, -1), out=flat)")
    src.append(f"{ind}Y[0] = flat.reshape(Y.shape[1:])")
    return "\n".join(src)


def numpy_taylor_step(F, P: int):
    """The compiled :func:`numpy_taylor_step_source`."""
    return define(numpy_taylor_step_source(F, P), "step", f"<tstarg taylor{P} numpy>", {"_np": np})
