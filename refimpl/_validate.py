"""Validation of the implementation protocol's inputs, shared by both implementations.

Every failure is a ``ValueError`` naming the input and the violated condition
(with the residual where there is one). Tolerances are error models in units
of float64 ``eps``, stated next to each check. Validated structure constants
and cocycles are cached by value, so a batch pays for the checks once.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from ._algebra import EPS, LieAlgebra, jacobi_residual
from ._errors import ChartError

__all__ = [
    "check_structure_constants",
    "check_theta",
    "check_upsilon",
    "check_inertia",
    "check_potential",
    "check_points",
    "as_float_array",
    "chart_radius",
    "outside_chart",
    "check_chart",
    "check_flow_request",
    "TWO_PI",
    "MAX_ELEMENTS",
    "INERTIA_RANGE",
    "INERTIA_MAX_COND",
    "MAX_FLOW_STEPS",
    "MAX_FLOW_TIME",
    "MIN_FLOW_TOL",
    "MAX_REFERENCE_FLOW_TIME",
    "ad_chart_radius",
    "check_flow_rates",
]

TWO_PI = 2 * np.pi
MAX_ELEMENTS = 10**8
"""Budget: at most this many numbers in one input array (800 MB of float64)."""
INERTIA_RANGE = (1e-100, 1e100)
"""The eigenvalues of an inertia tensor must lie in this range (``I^-1 pi`` neither overflows nor
comes from subnormal numbers)."""
INERTIA_MAX_COND = 1e12
"""Largest accepted condition number ``lambda_max / lambda_min`` of the inertia tensor: beyond it
``I^-1 pi`` has fewer than 4 correct digits in float64 and the flows stiffen without bound."""
MAX_FLOW_STEPS = 10**7
"""Budget of a fixed-step flow: at most this many steps (``steps=``)."""
MAX_FLOW_TIME = 1e4
"""Budget of a flow: time spans ``|t|`` up to this (the step count grows linearly with ``t``; at
``t = 1e4`` the first rung of the step doubling already takes 40 000 steps)."""
MAX_REFERENCE_FLOW_TIME = 1e3
"""Budget of a reference (mpmath) flow: times up to this (about a second of CPU per unit time at
20 digits for su(2); the cost grows with the digits)."""
MIN_FLOW_TOL = 1e-14
"""Smallest flow tolerance: below ~50 eps the rounding of the steps alone exceeds it, so no step
count can meet it (the step doubling would only run to its limit)."""

_REAL_KINDS = "fiu"


def _element_kind_error(value: Any, name: str) -> str | None:
    """Why ``value`` (an object-array element) is not a real number, or None."""
    if value is None:
        return f"{name} contains None; real numbers are expected"
    if isinstance(value, (bool, np.bool_)):
        return f"{name} contains a boolean ({value!r}); real numbers are expected"
    if isinstance(value, (complex, np.complexfloating)):
        return f"{name} contains the complex number {value!r}; real numbers are expected"
    if isinstance(value, (str, bytes)):
        return f"{name} contains the string {value!r}; real numbers are expected (float arrays)"
    return None


def as_float_array(value: Any, name: str) -> np.ndarray:
    """``value`` as float64; a clear error for input that is not an array of real numbers.

    Accepted kinds: float and integer arrays, and nested sequences / object arrays of real numbers
    (``int``, ``float``, ``Fraction``, mpmath and sympy reals). Refused, naming the input: complex
    numbers (never silently truncated to their real part), booleans, strings, arrays of more than
    :data:`MAX_ELEMENTS` numbers, and values that overflow float64.
    """
    if isinstance(value, LieAlgebra):
        return value.f
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} is not a numeric array: {exc}") from None
    if raw.size > MAX_ELEMENTS:
        raise ValueError(
            f"{name} has {raw.size} numbers, over the budget of {MAX_ELEMENTS} per input array"
        )
    if raw.dtype.kind == "c":
        raise ValueError(
            f"{name} is complex (dtype {raw.dtype}); real numbers are expected, "
            f"the imaginary part is not dropped silently"
        )
    if raw.dtype.kind == "b":
        raise ValueError(f"{name} is a boolean array; real numbers are expected")
    if raw.dtype.kind in "USV":
        raise ValueError(
            f"{name} is an array of {raw.dtype} (strings or bytes); real numbers are expected"
        )
    if raw.dtype.kind == "O":
        for e in raw.flat:
            why = _element_kind_error(e, name)
            if why:
                raise ValueError(why)
    elif raw.dtype.kind not in _REAL_KINDS:
        raise ValueError(f"{name} has dtype {raw.dtype}; real numbers are expected")
    try:
        with np.errstate(over="raise"):
            arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError, ArithmeticError, OverflowError) as exc:
        raise ValueError(
            f"{name} is not an array of real numbers representable in float64: {exc}"
        ) from None
    return arr


def _finite(arr: np.ndarray, name: str) -> None:
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        raise ValueError(
            f"{name} contains NaN or infinity at {len(bad)} entr{'y' if len(bad) == 1 else 'ies'}, "
            f"first at index {tuple(int(i) for i in bad[0])}"
        )


@lru_cache(maxsize=64)
def _check_f_cached(data: bytes, n: int) -> None:
    f = np.frombuffer(data, dtype=float).reshape(n, n, n)
    scale = max(1.0, float(np.max(np.abs(f)))) if f.size else 1.0
    asym = np.abs(f + f.transpose(0, 2, 1))
    # Stored antisymmetric numbers may differ by rounding only: 4 eps max|f|.
    if asym.size and asym.max() > 4 * EPS * scale:
        idx = np.unravel_index(int(np.argmax(asym)), asym.shape)
        raise ValueError(
            f"structure constants f are not antisymmetric in (a, b): |f[m,a,b] + f[m,b,a]| = "
            f"{asym.max():.3g} at (m, a, b) = {tuple(int(i) for i in idx)}"
        )
    jac = np.abs(jacobi_residual(f))
    # Each Jacobi entry sums 3n rounded products of size <= max|f|^2: 3 n eps max|f|^2, x4 slack.
    tol = 12 * n * EPS * scale**2
    if jac.size and jac.max() > tol:
        idx = np.unravel_index(int(np.argmax(jac)), jac.shape)
        raise ValueError(
            f"structure constants f break the Jacobi identity: worst residual {jac.max():.3g} at "
            f"(m, a, b, c) = {tuple(int(i) for i in idx)} (tolerance 12 n eps max|f|^2 = {tol:.3g})"
        )


def check_structure_constants(f: Any) -> np.ndarray:
    arr = as_float_array(f, "structure constants f")
    if arr.ndim != 3 or not (arr.shape[0] == arr.shape[1] == arr.shape[2]) or arr.shape[0] == 0:
        raise ValueError(
            f"structure constants f must have shape (n, n, n) with n >= 1, got {arr.shape}"
        )
    _finite(arr, "structure constants f")
    arr = np.ascontiguousarray(arr)
    _check_f_cached(arr.tobytes(), arr.shape[0])
    return arr


def _check_square_antisym(value: Any, n: int, name: str) -> np.ndarray:
    arr = as_float_array(value, name)
    if arr.shape != (n, n):
        raise ValueError(f"{name} must have shape ({n}, {n}) to match f, got {arr.shape}")
    _finite(arr, name)
    asym = np.abs(arr + arr.T)
    # Antisymmetry up to the rounding of the stored entries: 4 eps max|entry|.
    if asym.max() > 4 * EPS * max(float(np.max(np.abs(arr))), np.finfo(float).tiny):
        i, j = np.unravel_index(int(np.argmax(asym)), asym.shape)
        raise ValueError(
            f"{name} is not antisymmetric: |{name}[{i},{j}] + {name}[{j},{i}]| = {asym.max():.3g}"
        )
    return arr


@lru_cache(maxsize=64)
def _check_theta_cached(fdata: bytes, tdata: bytes, n: int) -> None:
    f = np.frombuffer(fdata, dtype=float).reshape(n, n, n)
    t = np.frombuffer(tdata, dtype=float).reshape(n, n)
    res = (
        -np.einsum("kc,kab->abc", t, f)
        + np.einsum("kb,kac->abc", t, f)
        - np.einsum("ka,kbc->abc", t, f)
    )
    worst = float(np.max(np.abs(res)))
    # delta_2 Theta sums 3n products: 3 n eps max|f| max|Theta|, x8 slack.
    tol = 24 * n * EPS * max(1.0, float(np.max(np.abs(f)))) * max(1.0, float(np.max(np.abs(t))))
    if worst > tol:
        idx = np.unravel_index(int(np.argmax(np.abs(res))), res.shape)
        raise ValueError(
            f"theta is not a 2-cocycle (zeven1): max |delta_2 theta| = {worst:.3g} at (a, b, c) = "
            f"{tuple(int(i) for i in idx)} > tolerance 24 n eps max|f| max|theta| = {tol:.3g}"
        )


def check_theta(theta: Any, f: np.ndarray) -> np.ndarray:
    n = f.shape[0]
    arr = _check_square_antisym(theta, n, "theta")
    arr = np.ascontiguousarray(0.5 * (arr - arr.T))
    _check_theta_cached(np.ascontiguousarray(f).tobytes(), arr.tobytes(), n)
    return arr


def check_upsilon(upsilon: Any, n: int) -> np.ndarray:
    arr = _check_square_antisym(upsilon, n, "upsilon")
    return np.ascontiguousarray(0.5 * (arr - arr.T))


def check_inertia(inertia: Any, n: int) -> np.ndarray:
    """Symmetric positive definite inertia tensor ``I``; returns it as float64."""
    arr = as_float_array(inertia, "inertia")
    if arr.shape != (n, n):
        raise ValueError(f"inertia must have shape ({n}, {n}) to match f, got {arr.shape}")
    _finite(arr, "inertia")
    scale = float(np.max(np.abs(arr)))
    if scale > INERTIA_RANGE[1]:
        raise ValueError(
            f"inertia has an entry of magnitude {scale:.3g}, outside the accepted range "
            f"[{INERTIA_RANGE[0]:g}, {INERTIA_RANGE[1]:g}]"
        )
    asym = float(np.max(np.abs(arr - arr.T)))
    if asym > 4 * EPS * scale:
        raise ValueError(f"inertia is not symmetric: max |I - I^T| = {asym:.3g}")
    w = np.linalg.eigvalsh(0.5 * (arr + arr.T))
    # Positive definite with a margin: the smallest eigenvalue must exceed the
    # eigenvalue error of a symmetric solver, n eps ||I||.
    if scale == 0 or w[0] <= 8 * n * EPS * scale:
        raise ValueError(
            f"inertia is not positive definite: smallest eigenvalue {w[0]:.3g} "
            f"(largest {w[-1]:.3g})"
        )
    lo, hi = INERTIA_RANGE
    if w[0] < lo or w[-1] > hi:
        raise ValueError(
            f"inertia has eigenvalues in [{w[0]:.3g}, {w[-1]:.3g}], outside the accepted range [{lo:g}, {hi:g}] "
            f"(subnormal or overflowing I^-1 pi)"
        )
    if w[-1] / w[0] > INERTIA_MAX_COND:
        raise ValueError(
            f"inertia is ill-conditioned: lambda_max / lambda_min = {w[-1] / w[0]:.3g} > {INERTIA_MAX_COND:g} "
            f"(I^-1 pi would keep fewer than 4 correct digits)"
        )
    return arr


def check_potential(potential: Any, n: int) -> dict | None:
    if potential is None:
        return None
    if not isinstance(potential, dict):
        raise ValueError(
            f"potential must be None or a dict {{'kind': 'gravity', 'L': ({n},), 'gamma': ({n},)}}, "
            f"got {type(potential).__name__} {potential!r:.60}"
        )
    kind = potential.get("kind")
    if kind != "gravity":
        raise ValueError(f"potential kind {kind!r} is not supported (expected 'gravity', twee15)")
    unknown = set(potential) - {"kind", "L", "gamma"}
    if unknown:
        raise ValueError(f"potential has unknown keys {sorted(unknown)} (expected kind, L, gamma)")
    out = {"kind": "gravity"}
    for key in ("L", "gamma"):
        if key not in potential:
            raise ValueError(f"gravity potential needs {key!r} of shape ({n},)")
        arr = as_float_array(potential[key], f"potential[{key!r}]")
        if arr.shape != (n,):
            raise ValueError(f"potential[{key!r}] must have shape ({n},), got {arr.shape}")
        _finite(arr, f"potential[{key!r}]")
        out[key] = arr
    return out


def check_points(x: Any, pi: Any, n: int, *, batched: bool) -> tuple[np.ndarray, np.ndarray]:
    """``x`` and ``pi`` with matching shape ``(..., n)``; every point finite."""
    xa = as_float_array(x, "x")
    pa = as_float_array(pi, "pi")
    if xa.shape[-1:] != (n,) or pa.shape[-1:] != (n,):
        raise ValueError(
            f"x and pi must have last axis {n} to match f, got {xa.shape} and {pa.shape}"
        )
    if xa.shape != pa.shape:
        raise ValueError(f"x and pi must have the same shape, got {xa.shape} and {pa.shape}")
    if not batched and xa.ndim != 1:
        raise ValueError(
            f"x and pi must have shape ({n},) for an unbatched implementation, got {xa.shape}"
        )
    for arr, name in ((xa, "x"), (pa, "pi")):
        ok = np.all(np.isfinite(arr), axis=-1)
        if not np.all(ok):
            bad = np.argwhere(~ok)
            where = ", ".join(str(tuple(int(i) for i in b)) for b in bad[:5])
            more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
            raise ValueError(f"{name} contains NaN or infinity at point(s) {where or '()'}{more}")
    return xa, pa


# ------------------------------------------------------------------ the chart
def _su2_like(f: np.ndarray) -> bool:
    if f.shape != (3, 3, 3):
        return False
    e = np.zeros((3, 3, 3))
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        e[a, b, c], e[a, c, b] = 1.0, -1.0
    return bool(np.array_equal(f, e))


def chart_radius(f: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``rho(x) = max |Im lambda|`` over the eigenvalues ``lambda`` of ``ad_x``, and its rounding error.

    The frame ``phi1(-ad_x)`` of twee1 is singular exactly where an eigenvalue of ``ad_x`` is
    ``2 pi i k``, ``k != 0``; along the ray ``s x`` the first singularity is met at
    ``rho(s x) = 2 pi``. The chart of exponential coordinates (the star-shaped domain the
    implementations accept) is therefore ``{x : rho(x) < 2 pi}``; for su(2)
    (``ad_x = [x]_x``, eigenvalues ``0, +-i|x|``) it is the ball ``|x| < 2 pi``.

    ``x``: ``(N, n)`` float64. Returns ``(rho, err)`` of shape ``(N,)``; ``err`` is the
    eigenvalue error model ``16 n eps ||ad_x||_F`` (normal matrices; for non-normal ``ad_x``
    the implementations' frame factor is the norm bound anyway). Non-finite ``ad_x`` gives
    ``rho = inf``. Eigenvalues are computed only where ``||ad_x||_2 >= 2 pi`` could hold
    (``||ad_x||_2 >= rho``; bounded by ``min(||.||_F, sqrt(||.||_1 ||.||_inf))``).
    """
    N, n = x.shape
    with np.errstate(all="ignore"):
        if _su2_like(f):
            rho = np.sqrt(np.sum(x * x, axis=1))
            rho = np.where(np.isfinite(rho), rho, np.inf)
            return rho, 16 * 3 * EPS * rho
        A = (x @ f.transpose(1, 0, 2).reshape(n, n * n)).reshape(N, n, n)
    return ad_chart_radius(A)


def ad_chart_radius(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`chart_radius` from a batch of ``ad_x`` matrices ``(N, n, n)``.

    Eigenvalues scale with the matrix, so each ``ad_x`` is divided by its largest entry first
    (no overflow for entries up to the float64 limit); the results may be ``inf``."""
    N, n = A.shape[0], A.shape[-1]
    rho = np.full(N, np.inf)
    err = np.zeros(N)
    if N == 0 or n == 0:
        return np.zeros(N), err
    with np.errstate(all="ignore"):
        finite = np.all(np.isfinite(A), axis=(-2, -1))
        s = np.where(finite, np.max(np.abs(A), axis=(-2, -1)), 1.0)
        s = np.where(s > 0, s, 1.0)
        An = np.where(finite[:, None, None], A, 0.0) / s[:, None, None]
        fro = np.sqrt(np.sum(An * An, axis=(-2, -1)))
        n1 = np.max(np.sum(np.abs(An), axis=-2), axis=-1)
        ninf = np.max(np.sum(np.abs(An), axis=-1), axis=-1)
        bound = s * np.minimum(fro, np.sqrt(n1 * ninf))
        err = np.where(finite, 16 * n * EPS * s * fro, 0.0)
        need = finite & ~(bound < TWO_PI * (1 - 1e-3))
        # points whose norm bound is below 2 pi: rho <= bound < 2 pi, the bound stands in for rho
        inside = finite & ~need
        rho[inside] = bound[inside]
        if need.any():
            lam = np.linalg.eigvals(An[need])
            r = s[need] * np.max(np.abs(lam.imag), axis=-1)
            rho[need] = np.where(np.isfinite(r), r, np.inf)
    return rho, err


def outside_chart(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Boolean mask ``(N,)``: points at or beyond the chart edge ``rho(x) >= 2 pi`` to float64
    accuracy (``rho + err >= 2 pi``), including every point whose ``ad_x`` overflows."""
    rho, err = chart_radius(f, x)
    with np.errstate(all="ignore"):
        return ~(rho + err < TWO_PI)


def check_chart(f: np.ndarray, x: np.ndarray, *, name: str = "x", strict: bool = True) -> None:
    """Raise :class:`ChartError` naming the points of ``x`` (``(N, n)``) outside the chart.

    ``strict=True`` (the fast implementation): outside to float64 accuracy, ``rho + err >= 2 pi``.
    ``strict=False`` (the reference, which resolves the edge itself in mpmath): only points
    clearly outside, ``rho - err > 2 pi``.
    """
    rho, err = chart_radius(f, x)
    with np.errstate(all="ignore"):
        bad = ~(rho + err < TWO_PI) if strict else ~(rho - err <= TWO_PI)
    if bad.any():
        idx = np.flatnonzero(bad)
        k = int(idx[0])
        where = (
            ""
            if x.shape[0] == 1
            else f" at batch index {k}" + (f" and {len(idx) - 1} more" if len(idx) > 1 else "")
        )
        raise ChartError(
            f"{name} = {np.array2string(x[k], precision=6)}{where} is outside the chart of exponential "
            f"coordinates: max |Im eigenvalue of ad_x| = {rho[k]:.6g} >= 2 pi (the frame phi1(-ad_x) "
            f"of twee1 is singular at 2 pi; for su(2) the chart is |x| < 2 pi)"
        )


# ------------------------------------------------------------------ flow budgets
def check_flow_request(t: float, tol: float, steps: Any, method_name: Any, known: Any) -> None:
    """The stated budget of a flow, checked before any work.

    ``|t| <= MAX_FLOW_TIME``; ``tol >= MIN_FLOW_TOL``; ``steps`` ``None`` or an int in
    ``[1, MAX_FLOW_STEPS]``; ``method_name`` ``None`` or a key of ``known``.
    """
    if method_name is not None and (not isinstance(method_name, str) or method_name not in known):
        raise ValueError(
            f"method_name {method_name!r} is not a flow method; known: {sorted(known)}"
        )
    if not abs(t) <= MAX_FLOW_TIME:
        raise ValueError(
            f"t = {t!r} exceeds the flow budget |t| <= {MAX_FLOW_TIME:g} (split the span, or rescale time)"
        )
    if not tol >= MIN_FLOW_TOL:
        raise ValueError(
            f"tol = {tol!r} is below {MIN_FLOW_TOL:g}: float64 rounding of the steps alone exceeds it"
        )
    if steps is not None:
        if isinstance(steps, (bool, np.bool_)) or not isinstance(steps, (int, np.integer)):
            raise ValueError(f"steps must be None or a positive int, got {steps!r}")
        if not 1 <= steps <= MAX_FLOW_STEPS:
            raise ValueError(f"steps = {steps} is outside the budget [1, {MAX_FLOW_STEPS}]")


def check_flow_rates(
    f: np.ndarray, inertia: np.ndarray, pi: np.ndarray, t: float, *, name: str = "pi0"
) -> None:
    """Refuse starting points whose rotation is too fast for the step budget, naming them.

    The body angular velocity is ``I^-1 pi``; the rate of the flow is estimated by
    ``rate_k = ||I^-1||_2 max(1, |pi_k|) max(1, max|f|)`` (radians per unit time). Any integrator
    needs a few steps per radian, and the step doubling of the flows reaches at most
    ``~2^15 (8 + 4|t|)`` steps; a point with ``|t| rate_k > 2^14 (2 + |t|)`` cannot be resolved
    within that budget and would only slow the whole batch down.
    """
    if t == 0:
        return
    pts = np.asarray(pi, dtype=float).reshape(-1, f.shape[0])
    inv_norm = 1.0 / float(np.linalg.eigvalsh(0.5 * (inertia + inertia.T))[0])
    fmax = max(1.0, float(np.max(np.abs(f)))) if f.size else 1.0
    with np.errstate(over="ignore"):
        size = (
            np.max(np.abs(pts), axis=1) * np.sqrt(pts.shape[1])
            if pts.size
            else np.zeros(pts.shape[0])
        )
        rate = inv_norm * np.maximum(1.0, size) * fmax
    limit = 2.0**14 * (2 + abs(t))
    bad = np.flatnonzero(~(abs(t) * rate <= limit))
    if bad.size:
        k = int(bad[0])
        raise ValueError(
            f"{name} at batch index {k} (|pi| <= {size[k]:.3g}) rotates too fast for the flow budget: "
            f"|t| * ||I^-1|| |pi| = {abs(t) * rate[k]:.3g} rad > {limit:.3g} (2^14 (2 + |t|))"
            + (f"; {bad.size - 1} more point(s) likewise" if bad.size > 1 else "")
        )
