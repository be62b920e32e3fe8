"""Validation of the implementation protocol's inputs, shared by every implementation.

**The boundary** (issue 30), stated here once and applied by the fast, the reference and the
rigorous implementations alike (they call the checks below; nothing else decides what is accepted):

=============  ==============================================================================
magnitudes     every number of ``f``, ``theta``, ``upsilon``, ``inertia``, ``potential``, ``x`` and
               ``pi`` has ``|v| <= MAX_MAGNITUDE`` (1e300); results that still overflow float64
               are refused (:func:`check_finite_result`), never returned as inf or NaN
dimension      ``n <= MAX_DIMENSION`` (32) for float algebras, ``n <= MAX_EXACT_DIMENSION`` (16)
               for exact ones (their Jacobi check is symbolic), refused before any ``n^4`` work
memory         every batch's working set ``<= MAX_WORK_BYTES`` (2 GiB), estimated before it is
               allocated (:func:`check_batch_memory`); input arrays ``<= MAX_ELEMENTS`` numbers
precision      ``dps <= MAX_DPS`` (5000 digits) and ``prec_bits <= MAX_PREC_BITS`` (the same
               precision in bits) (:func:`check_precision_digits`, :func:`check_precision_bits`)
time           ``TIME_BUDGET_S`` (20 s of CPU) per flow call: the cost is estimated before each run
               and the run refused with the estimate (:class:`TimeBudget`, :class:`BudgetError`)
counts         ``|t| <= MAX_FLOW_TIME``, ``steps <= MAX_FLOW_STEPS``, ``tol >= MIN_FLOW_TOL``
               (:func:`check_flow_request`), and the rate budget of :func:`check_flow_rates`
chart          ``rho(x) < 2 pi`` (:func:`check_chart`); the degenerate set: ``Delta`` small
               relative to the scale of Phi (:func:`degenerate_relative`)
strings        numbers written as strings go through :func:`parse_number` only, never evaluated
=============  ==============================================================================

Every failure is a ``ValueError`` naming the input and the violated condition
(with the residual where there is one). Tolerances are error models in units
of float64 ``eps``, stated next to each check. Validated structure constants
and cocycles are cached by value, so a batch pays for the checks once.
"""

from __future__ import annotations

import math
import os
import re
import time
from fractions import Fraction
from functools import lru_cache
from typing import Any

import mpmath
import numpy as np
import sympy

from ._errors import ChartError

__all__ = [
    "parse_number",
    "exact_fraction",
    "exact_sympy",
    "MAX_NUMBER_CHARS",
    "MAX_DECIMAL_EXPONENT",
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
EPS = np.finfo(float).eps
"""float64 unit roundoff (refimpl._algebra takes it from here: this module imports no other module of
refimpl but the error classes, so every module can import it)."""


# ------------------------------------------------------------------ numbers given as strings
MAX_NUMBER_CHARS = 1000
"""A number string has at most this many characters."""
MAX_DECIMAL_EXPONENT = 10_000
"""A decimal exponent ``e+-k`` has ``|k|`` at most this (``Fraction("1e999999999")`` alone would
build a billion-digit integer; ``1e10000`` is already far beyond every magnitude budget)."""
_DECIMAL_RE = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE]([+-]?[0-9]+))?")
_RATIONAL_RE = re.compile(r"[+-]?[0-9]+/[0-9]+")


def parse_number(text: str, name: str = "value") -> Fraction:
    """The one parser of numbers written as strings: a decimal literal (``"-1.25e-3"``) or a
    rational literal (``"-1/3"``), ASCII digits, surrounding blanks ignored, nothing else.

    Strings are never evaluated (``sympify``, ``eval``, ``S(...)`` and ``nsimplify`` of a string
    run Python code); this regular-expression parser and :class:`fractions.Fraction` on the
    matched literal are the only route from a caller's string to a number in tstarg. Refused with
    ``ValueError`` naming ``name``: anything else (code, ``"nan"``, ``"inf"``, ``"0x1p3"``,
    underscores), strings over :data:`MAX_NUMBER_CHARS` characters, exponents beyond
    :data:`MAX_DECIMAL_EXPONENT`, and a zero denominator.

    >>> parse_number(" -1/3 "), parse_number("1.25e-3")
    (Fraction(-1, 3), Fraction(1, 800))
    >>> parse_number("__import__('os')", "theta[0, 1]")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: theta[0, 1] = "__import__('os')" is not a decimal or rational literal such as ...
    """
    if not isinstance(text, str):
        raise TypeError(f"{name}: parse_number takes a str, got {type(text).__name__}")
    if len(text) > MAX_NUMBER_CHARS:
        raise ValueError(
            f"{name} is a string of {len(text)} characters; a number string has at most "
            f"{MAX_NUMBER_CHARS} (strings are never evaluated)"
        )
    s = text.strip()
    m = _DECIMAL_RE.fullmatch(s)
    if m is not None:
        if m.group(1) is not None and abs(int(m.group(1))) > MAX_DECIMAL_EXPONENT:
            raise ValueError(
                f"{name} = {text!r:.60} has a decimal exponent beyond +-{MAX_DECIMAL_EXPONENT}"
            )
        return Fraction(s)
    if _RATIONAL_RE.fullmatch(s):
        num, den = s.split("/")
        if int(den) == 0:
            raise ValueError(f"{name} = {text!r:.60} has a zero denominator")
        return Fraction(int(num), int(den))
    raise ValueError(
        f"{name} = {text!r:.60} is not a decimal or rational literal such as '-1.5e-3' or '1/3' "
        f"(strings are parsed, never evaluated; give numbers or sympy expressions instead)"
    )


def exact_fraction(value: Any, name: str = "value") -> Fraction:
    """A caller's real number as the exact :class:`fractions.Fraction` it denotes.

    Accepted: ``int`` and numpy integers, ``Fraction``, finite floats (their exact binary value),
    strings through :func:`parse_number`, sympy ``Integer``/``Rational``/``Float``, mpmath ``mpf``.
    Refused by name (``ValueError``): booleans, complex numbers, NaN and infinities, and every other
    type (irrational sympy numbers have no exact fraction: use :func:`exact_sympy`).
    """
    if isinstance(value, (bool, np.bool_)) or value is None:
        raise ValueError(f"{name} is {value!r}; a real number is expected")
    if isinstance(value, (int, np.integer)):
        return Fraction(int(value))
    if isinstance(value, Fraction):
        return value
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(float(value)):
            raise ValueError(f"{name} is the non-finite number {value!r}")
        return Fraction(float(value))
    if isinstance(value, str):
        return parse_number(value, name)
    mod = type(value).__module__ or ""
    if mod.startswith("sympy"):
        if isinstance(value, sympy.Rational):  # Integer is a Rational
            return Fraction(int(value.p), int(value.q))
        if isinstance(value, sympy.Float):
            return _mpf_fraction(value._mpf_, name)
        raise ValueError(
            f"{name} = {value!s:.60} is not a rational or float sympy number (no exact fraction)"
        )
    if mod.startswith("mpmath"):
        if isinstance(value, mpmath.mpf):
            return _mpf_fraction(value._mpf_, name)
    raise ValueError(f"{name} has type {type(value).__name__}; a real number is expected")


def _mpf_fraction(mpf_tuple: tuple, name: str) -> Fraction:
    sign, man, exp, _bc = mpf_tuple
    if not man and exp:  # mpmath's special values (inf, -inf, nan) have man = 0, exp != 0
        raise ValueError(f"{name} is a non-finite number")
    if abs(exp) > 4 * MAX_DECIMAL_EXPONENT:
        raise ValueError(f"{name} has a binary exponent {exp} beyond every magnitude budget")
    q = Fraction(int(man)) * (Fraction(2) ** int(exp))
    return -q if sign else q


def exact_sympy(value: Any, name: str = "value"):
    """A caller's number as a sympy expression, with no string ever evaluated.

    sympy objects pass unchanged (symbols and radicals included: they were built by code, not
    parsed); every other number goes through :func:`exact_fraction` (strings through
    :func:`parse_number`) and becomes an exact ``sympy.Rational``.

    >>> exact_sympy("2/6"), exact_sympy(0.5)
    (1/3, 1/2)
    """

    if isinstance(value, sympy.Basic):
        return value
    q = exact_fraction(value, name)
    return sympy.Rational(q.numerator, q.denominator)


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


def _is_lie_algebra(value: Any) -> bool:
    """A :class:`refimpl.LieAlgebra` (recognised by its validated float constants ``f`` and its
    exact ones ``f_exact``; this module cannot import refimpl._algebra, which imports it)."""
    return (
        type(value).__name__ == "LieAlgebra"
        and isinstance(getattr(value, "f", None), np.ndarray)
        and hasattr(value, "f_exact")
    )


def as_float_array(value: Any, name: str) -> np.ndarray:
    """``value`` as float64; a clear error for input that is not an array of real numbers.

    Accepted kinds: float and integer arrays, and nested sequences / object arrays of real numbers
    (``int``, ``float``, ``Fraction``, mpmath and sympy reals). Refused, naming the input: complex
    numbers (never silently truncated to their real part), booleans, strings, arrays of more than
    :data:`MAX_ELEMENTS` numbers, and values that overflow float64.
    """
    if _is_lie_algebra(value):
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
    """Every entry finite and within the magnitude boundary (:data:`MAX_MAGNITUDE`)."""
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        raise ValueError(
            f"{name} contains NaN or infinity at {len(bad)} entr{'y' if len(bad) == 1 else 'ies'}, "
            f"first at index {tuple(int(i) for i in bad[0])}"
        )
    check_magnitude(arr, name)


def check_jacobi(f: np.ndarray, label: str = "structure constants f") -> None:
    """The Jacobi identity of float64 ``f`` to rounding, in ``n^3`` memory (one ``m`` at a time) and
    without overflow (``f`` is divided by ``sigma = max(1, max|f|)`` first; the identity is
    quadratic, so the residual and its tolerance scale by ``sigma^2`` alike)."""
    n = f.shape[0]
    check_dimension(n, what=label)
    if not f.size:
        return
    sigma = max(1.0, float(np.max(np.abs(f))))
    g = f / sigma
    # Each Jacobi entry sums 3n rounded products of size <= max|g|^2 <= 1: 3 n eps, x4 slack.
    tol = 12 * n * float(EPS)
    flat = g.reshape(n, n * n)
    worst, where = 0.0, None
    for m in range(n):
        t = (g[m] @ flat).reshape(n, n, n)  # t[a, b, c] = g^m_ak g^k_bc
        jac = np.abs(t + t.transpose(1, 2, 0) + t.transpose(2, 0, 1))
        w = float(jac.max())
        if w > worst:
            worst, where = (
                w,
                (m,) + tuple(int(i) for i in np.unravel_index(int(np.argmax(jac)), jac.shape)),
            )
    if worst > tol:
        raise ValueError(
            f"{label} break the Jacobi identity: worst residual {worst * sigma * sigma:.3g} at "
            f"(m, a, b, c) = {where} (tolerance 12 n eps max(1, max|f|)^2 = {tol * sigma * sigma:.3g})"
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
    check_jacobi(f)


def check_structure_constants(f: Any) -> np.ndarray:
    arr = as_float_array(f, "structure constants f")
    if arr.ndim != 3 or not (arr.shape[0] == arr.shape[1] == arr.shape[2]) or arr.shape[0] == 0:
        raise ValueError(
            f"structure constants f must have shape (n, n, n) with n >= 1, got {arr.shape}"
        )
    check_dimension(arr.shape[0])
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
    # the check is bilinear in (f, theta): both are divided by max(1, max|.|) first (no overflow for
    # entries up to MAX_MAGNITUDE); the tolerance below is then stated for the scaled arrays
    sf = max(1.0, float(np.max(np.abs(f))))
    st = max(1.0, float(np.max(np.abs(t))))
    f, t = f / sf, t / st
    res = (
        -np.einsum("kc,kab->abc", t, f)
        + np.einsum("kb,kac->abc", t, f)
        - np.einsum("ka,kbc->abc", t, f)
    )
    worst = float(np.max(np.abs(res)))
    # delta_2 Theta sums 3n products: 3 n eps max|f| max|Theta|, x8 slack.
    tol = (
        24
        * n
        * float(EPS)
        * max(1.0, float(np.max(np.abs(f))))
        * max(1.0, float(np.max(np.abs(t))))
    )
    if worst > tol:  # compared scaled; reported at the caller's scale
        worst, tol = worst * sf * st, tol * sf * st
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
        check_magnitude(arr, name)
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


# ------------------------------------------------------------------ the boundary: budgets
MAX_MAGNITUDE = 1e300
"""Every input number has ``|v| <= MAX_MAGNITUDE`` (the float64 range, with room for products)."""
MAX_DIMENSION = 32
"""Largest algebra dimension ``n``: the Jacobi check costs ``n^5`` multiply-adds, a Poisson tensor
``(2n)^3`` per point in float64 and about ``30 n^3`` multiprecision operations per point in the
reference (about 10 s at n = 32)."""
MAX_EXACT_DIMENSION = 16
"""Largest dimension of an exact (symbolic) algebra: its validation simplifies ``n^4`` Jacobi
entries with sympy (about 0.2 s at n = 10, growing as ``n^4``)."""
MAX_WORK_BYTES = 2 * 2**30
"""Largest working set of one batched call, estimated before the work (2 GiB)."""
MAX_DPS = 5000
"""Precision cap: 5000 significant digits (``Reference(dps)``)."""
MAX_PREC_BITS = int(MAX_DPS * 3.3219280948873626) + 1
"""The same cap in bits (``Rigorous(prec_bits)``): 16610 bits."""
TIME_BUDGET_S = float(os.environ.get("TSTARG_TIME_BUDGET_S", "20"))
"""CPU seconds one flow call may spend: estimated before each run, refused with the estimate
(20 s; the environment variable ``TSTARG_TIME_BUDGET_S`` sets another value for long benchmark runs)."""


class BudgetError(ValueError):
    """A request beyond a stated budget (dimension, memory, precision, time), refused before the
    work with the budget's name and the estimate."""


def check_magnitude(arr: np.ndarray, name: str) -> None:
    """Refuse entries with ``|v| > MAX_MAGNITUDE`` (``arr`` float64, already finite), naming the
    first such entry."""
    with np.errstate(invalid="ignore"):
        big = np.abs(arr) > MAX_MAGNITUDE
    if big.any():
        idx = tuple(int(i) for i in np.argwhere(big)[0])
        raise ValueError(
            f"{name} has an entry of magnitude {float(np.abs(arr[idx])):.3g} at index {idx}, beyond "
            f"the boundary |v| <= {MAX_MAGNITUDE:g} of every implementation"
        )


def within_boundary(arr: np.ndarray) -> bool:
    """Fast test for a float64 array: every entry finite with ``|v| <= MAX_MAGNITUDE`` (NaN fails).
    For the shortcut paths; on False the full check (:func:`check_points`) names the entry."""
    if arr.size == 0:
        return True
    return bool(np.max(arr) <= MAX_MAGNITUDE and np.min(arr) >= -MAX_MAGNITUDE)


def check_dimension(n: int, *, exact: bool = False, what: str = "structure constants f") -> None:
    """Refuse algebras beyond :data:`MAX_DIMENSION` (:data:`MAX_EXACT_DIMENSION` when exact) before
    any work, with the estimate of what the work would cost."""
    limit = MAX_EXACT_DIMENSION if exact else MAX_DIMENSION
    if n > limit:
        kind = "exact (symbolic) " if exact else ""
        raise BudgetError(
            f"{what}: dimension n = {n} exceeds the dimension budget n <= {limit} of {kind}algebras: "
            f"its Jacobi check alone needs n^5 = {float(n) ** 5:.3g} multiply-adds over "
            f"n^4 = {float(n) ** 4:.3g} entries ({8 * float(n) ** 4 / 2**30:.3g} GiB as float64"
            + (", each simplified by sympy" if exact else "")
            + ")"
        )


def check_batch_memory(points: int, n: int, *, what: str, per_point_matrices: float = 6.0) -> None:
    """Refuse a batch whose working set ``8 * points * per_point_matrices * n^2`` bytes exceeds
    :data:`MAX_WORK_BYTES` (the Poisson tensor alone is ``(2n)^2 = 4 n^2`` numbers per point; inputs,
    diagnostics and the chunked kernels' temporaries add about ``2 n^2`` more)."""
    need = 8.0 * float(points) * per_point_matrices * float(n) ** 2
    if need > MAX_WORK_BYTES:
        raise BudgetError(
            f"{what}: {points} points of dimension {n} need about {need / 2**30:.3g} GiB of working "
            f"memory, over the budget of {MAX_WORK_BYTES / 2**30:g} GiB per call (split the batch)"
        )


def check_precision_digits(dps: Any, *, what: str = "dps", low: int = 15) -> int:
    """``dps`` an int in ``[low, MAX_DPS]`` (the precision cap), returned as int."""
    if isinstance(dps, (bool, np.bool_)) or not isinstance(dps, (int, np.integer)):
        raise ValueError(
            f"{what} must be an int in [{low}, {MAX_DPS}] (the precision cap), got {dps!r}"
        )
    if not low <= int(dps) <= MAX_DPS:
        raise BudgetError(
            f"{what} must be an int in [{low}, {MAX_DPS}] (the precision cap), got {dps!r}"
        )
    return int(dps)


def check_precision_bits(bits: Any, *, what: str = "prec_bits", low: int = 53) -> int:
    """``bits`` an int in ``[low, MAX_PREC_BITS]`` (the precision cap of :data:`MAX_DPS` digits)."""
    if isinstance(bits, (bool, np.bool_)) or not isinstance(bits, (int, np.integer)):
        raise ValueError(
            f"{what} must be an int in [{low}, {MAX_PREC_BITS}] (the precision cap), got {bits!r}"
        )
    if not low <= int(bits) <= MAX_PREC_BITS:
        raise BudgetError(
            f"{what} must be an int in [{low}, {MAX_PREC_BITS}] (the precision cap of {MAX_DPS} "
            f"digits), got {bits!r}"
        )
    return int(bits)


def check_finite_result(what: str, arrays: dict, *, flagged: np.ndarray | None = None) -> None:
    """Refuse a result with entries that are not finite at points not already flagged (degenerate or
    outside the chart): the inputs were within the boundary but the result overflows float64.

    ``arrays``: ``{name: array}``, each with the batch axes first; ``flagged``: boolean mask of the
    batch axes (or None)."""
    for name, arr in arrays.items():
        a = np.asarray(arr)
        batch = a.shape[: flagged.ndim] if flagged is not None else a.shape[:0]
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(a).reshape(batch + (-1,)).all(axis=-1)
        if flagged is not None:
            ok = ok | flagged
        if not np.all(ok):
            bad = np.argwhere(~np.asarray(ok))
            where = (
                f" at batch indices {[tuple(int(i) for i in b) for b in bad[:5]]}"
                if bad.size
                else ""
            )
            raise ValueError(
                f"{what}: {name} overflows float64{where}: the inputs are within the magnitude "
                f"boundary (|v| <= {MAX_MAGNITUDE:g}) but the result is not representable; scale "
                f"the momenta or the structure constants down"
            )


class TimeBudget:
    """The time budget of one call: :data:`TIME_BUDGET_S` CPU seconds (``time.process_time``, so a
    loaded machine does not shrink it) from construction.

    ``refuse_if(estimate_s, doing)`` raises :class:`BudgetError` *before* a piece of work whose
    estimated cost would cross the budget, stating the estimate; ``spent()`` is the CPU time used.
    """

    def __init__(self, what: str, seconds: float | None = None):
        self.what = what
        self.seconds = float(TIME_BUDGET_S if seconds is None else seconds)
        self.start = time.process_time()

    def spent(self) -> float:
        return time.process_time() - self.start

    def refuse_if(self, estimate_s: float, doing: str) -> None:
        spent = self.spent()
        if not spent + estimate_s <= self.seconds:
            raise BudgetError(
                f"{self.what}: {doing} would take about {estimate_s:.3g} s of CPU (estimated before "
                f"the work, {spent:.3g} s already spent), over the time budget of {self.seconds:g} s "
                f"per call (refimpl._validate.TIME_BUDGET_S); shorten t, loosen tol or split the batch"
            )


def degenerate_relative(delta_abs, phi_norm, n: int, eps) -> bool:
    """Delta = det Phi is zero to working precision when ``|Delta| <= 16 n eps ||Phi||^n`` --
    relative to the scale of Phi (Hadamard: ``|det Phi| <= ||Phi||^n``), never absolute:
    ``Phi = 1 + S Upsilon`` of size 1e66 has a determinant of size 1e198 that is far from 0.
    Works on floats and on mpmath numbers (the reference passes ``max(1, ||Phi||_1)`` and its eps,
    and escalates the digits while this holds before calling a point degenerate)."""
    return bool(delta_abs <= 16 * n * eps * phi_norm**n)


def check_out_buffer(out: Any, *inputs: tuple[str, Any]) -> None:
    """An ``out=`` buffer must be a writable numpy array that shares no memory with any input
    (``inputs``: ``(name, array)`` pairs); refused by name otherwise. Shape, dtype and layout are
    the caller's checks."""
    if out is None:
        return
    if not isinstance(out, np.ndarray):
        raise ValueError(f"out must be a numpy array or None, got {type(out).__name__}")
    if not out.flags.writeable:
        raise ValueError("out is a read-only array: results cannot be written into it")
    for name, arr in inputs:
        if isinstance(arr, np.ndarray) and np.may_share_memory(out, arr):
            if np.shares_memory(out, arr, max_work=10**6):
                raise ValueError(
                    f"out overlaps the input {name}: writing the result would overwrite the "
                    f"caller's {name} (pass a separate buffer)"
                )


def refuse_overflow(what: str, arrays: dict, degenerate: np.ndarray, upsilon_zero: bool) -> None:
    """The protocol methods' last step before returning a float64 result (inputs inside the chart):
    entries that are not finite at points not flagged degenerate mean the result overflowed float64,
    refused as such (:func:`check_finite_result`). With ``Upsilon = 0`` no point is degenerate
    (``Phi = 1``), so a point flagged there overflowed too and is refused as overflow, never as
    "degenerate"."""
    degenerate = np.asarray(degenerate, dtype=bool)
    check_finite_result(
        what, arrays, flagged=np.zeros_like(degenerate) if upsilon_zero else degenerate
    )


class StepBudget(TimeBudget):
    """:class:`TimeBudget` for fixed-step integrations: the CPU cost of one step is measured on the
    work itself (a short probe run with the same step size and batch, :meth:`calibrate`), and every
    run of ``N`` steps is estimated as ``N`` times that cost *before* it starts (:meth:`before`);
    each finished run refines the cost (:meth:`after`). A count budget (``steps``, ``|t|``) thus holds
    in time too: ``steps = 10**7`` within :data:`MAX_FLOW_STEPS` is still refused when its estimate
    exceeds :data:`TIME_BUDGET_S`.
    """

    per_step: float = 0.0

    def calibrate(self, probe, steps: int) -> None:
        """Time ``probe(steps)`` twice and keep the faster (the first may pay one-time costs: a
        kernel compiled, a model cached); errors in the probe are left to the real run."""
        costs = []
        for _ in range(2):
            start = time.process_time()
            try:
                probe(steps)
            except Exception:  # noqa: BLE001 - only the time is wanted here
                pass
            costs.append((time.process_time() - start) / max(steps, 1))
        self.per_step = max(min(costs), self.per_step)

    def before(self, steps: int, doing: str) -> float:
        """Refuse a run of ``steps`` steps whose estimate would cross the budget; returns the start time."""
        self.refuse_if(
            self.per_step * steps, f"{doing} ({steps} steps at ~{self.per_step:.2g} s each)"
        )
        return time.process_time()

    def after(self, steps: int, started: float) -> None:
        took = time.process_time() - started
        if steps > 0 and took > 0:
            self.per_step = took / steps


class ProgressBudget(TimeBudget):
    """:class:`TimeBudget` for integrations whose step count is not known in advance (the adaptive
    reference flow): after each step the total cost is extrapolated from the fraction of the span
    done, and the run is refused -- with the estimate -- as soon as that extrapolation crosses the
    budget (after :attr:`grace` seconds, so that the first steps' noise does not decide)."""

    grace: float = 1.0

    def progress(self, fraction: float, doing: str) -> None:
        spent = self.spent()
        if spent < min(self.grace, self.seconds) or not fraction > 0:
            if spent > self.seconds:
                self.refuse_if(0.0, doing)
            return
        total = spent / min(fraction, 1.0)
        if total > self.seconds:
            raise BudgetError(
                f"{self.what}: {doing} would take about {total:.3g} s of CPU (extrapolated after "
                f"{100 * fraction:.3g}% of the span in {spent:.3g} s), over the time budget of "
                f"{self.seconds:g} s per call (refimpl._validate.TIME_BUDGET_S); shorten t or lower dps"
            )

    def watch(self, after, t_end, doing: str):
        """``after_step(t, y)`` of an integrator, wrapped to report progress ``t / t_end`` first."""
        end = float(abs(t_end)) or 1.0

        def step(t, y):
            self.progress(float(abs(t)) / end, doing)
            return y if after is None else after(t, y)

        return step
