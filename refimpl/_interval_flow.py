"""Rigorous body flows in compiled double-interval arithmetic (:mod:`refimpl._interval_kernel`).

The fast route to the enclosures of :func:`refimpl.rigorous.body_flow_enclosure`: the same systems
(Euler with Theta, Euler-Poisson; ``Upsilon = 0``), the same field (the ball coefficients of
:func:`refimpl._rigorous_flow.body_field`, enclosed outward in float64 intervals), the same method
(interval Taylor series, a-priori enclosure, Lagrange remainder, Lohner's QR wrapping), in float64
intervals with outward rounding, compiled by numba. Its radius floor is that of doubles (about
``1e-13`` relative at ``T = 10`` on the heavy top); below it use the Arb route at more bits.

Inputs pass exactly the checks of :func:`body_flow_enclosure` (it is called at ``t = 0``, which also
encloses ``Gamma(0) = Ad(exp x0)^T gamma`` in Arb balls, rounded outward to doubles here).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import platform
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from flint import arb, arb_mat

from . import _interval_kernel as K
from ._arb import float_view, workprec
from ._catalogue import su2
from ._rigorous_flow import body_field, body_flow_enclosure
from ._validate import MAX_FLOW_TIME

__all__ = [
    "IntervalEnclosure",
    "check_settings",
    "interval_body_enclosure",
    "interval_enclose",
    "interval_su2_full_enclosure",
    "interval_tables",
    "merged_terms",
    "su2_full_field",
    "su2_quaternion",
]

SETUP_BITS = (
    128  # precision of the Arb set-up (field coefficients, Gamma(0)) before rounding outward
)


def _bounds(b: arb) -> tuple[float, float]:
    """A float64 interval containing the ball ``b``: exact when ``b`` is an exact double."""
    m = float(b.mid())
    if b.rad() == 0 and arb(m) == b.mid():
        return m, m
    lo = math.nextafter(float(b.lower()), -math.inf)
    hi = math.nextafter(float(b.upper()), math.inf)
    return lo, hi


def merged_terms(F) -> tuple[dict, dict, dict]:
    """``(const, lin, quad)`` of ``F`` with the products ``y_j y_k`` and ``y_k y_j`` merged into one term
    ``(min(j, k), max(j, k))`` (ball sums, exact for the dyadic coefficients of the catalogue's fields):
    ``const[i]``, ``lin[i] = {j: ball}``, ``quad[i] = {(j, k): ball}``, zero balls dropped. Fewer terms
    mean fewer roundings and less interval dependency (``2 y1 y2 - y2 y1`` is ``y1 y2``)."""
    lin = {i: {} for i in range(F.d)}
    quad = {i: {} for i in range(F.d)}
    for i in range(F.d):
        for j, a in F.lin.get(i, ()):
            lin[i][j] = lin[i].get(j, arb(0)) + a
        for j, k, qv in F.quad.get(i, ()):
            key = (min(j, k), max(j, k))
            quad[i][key] = quad[i].get(key, arb(0)) + qv
    lin = {i: {j: a for j, a in row.items() if not a.is_zero()} for i, row in lin.items()}
    quad = {i: {jk: a for jk, a in row.items() if not a.is_zero()} for i, row in quad.items()}
    return dict(F.const), lin, quad


def interval_tables(F) -> tuple:
    """The kernel's sparse tables of a ball field ``F`` of :mod:`refimpl._rigorous_flow` (``F.d``,
    ``F.const``, ``F.lin``, ``F.quad``, as :func:`refimpl._rigorous_flow.body_field` returns; terms merged
    by :func:`merged_terms`), every coefficient an outward float64 interval: ``(clo, chi, lptr, lidx,
    llo, lhi, lex, qptr, qpair, qlo, qhi, qex, pj, pk)`` (constant terms; per row the linear terms; per
    row the quadratic terms, each naming a product ``y[pj[m]] y[pk[m]]``; ``lex``/``qex`` flag the point
    coefficients ``+-2^k``, ``k >= 0``, whose products are exact)."""
    d = F.d
    const, lin, quad = merged_terms(F)
    pairs = sorted({jk for row in quad.values() for jk in row})
    slot = {jk: m for m, jk in enumerate(pairs)}
    clo, chi = np.zeros(d), np.zeros(d)
    for i, v in const.items():
        clo[i], chi[i] = _bounds(v)
    lptr, lidx, llo, lhi = [0], [], [], []
    qptr, qpair, qlo, qhi = [0], [], [], []
    for i in range(d):
        for j, a in sorted(lin[i].items()):
            lo, hi = _bounds(a)
            lidx.append(j)
            llo.append(lo)
            lhi.append(hi)
        lptr.append(len(lidx))
        for jk, qv in sorted(quad[i].items()):
            lo, hi = _bounds(qv)
            qpair.append(slot[jk])
            qlo.append(lo)
            qhi.append(hi)
        qptr.append(len(qpair))
    i64 = np.int64

    def exact(lo, hi):  # a point +-2^k, k >= 0: multiplying by it is exact (kernel's _cmul)
        return np.array(
            [a == b and abs(a) >= 1 and math.frexp(abs(a))[0] == 0.5 for a, b in zip(lo, hi)],
            dtype=np.bool_,
        )

    return (
        clo,
        chi,
        np.array(lptr, dtype=i64),
        np.array(lidx, dtype=i64),
        np.array(llo, dtype=float),
        np.array(lhi, dtype=float),
        exact(llo, lhi),
        np.array(qptr, dtype=i64),
        np.array(qpair, dtype=i64),
        np.array(qlo, dtype=float),
        np.array(qhi, dtype=float),
        exact(qlo, qhi),
        np.array([j for j, _ in pairs], dtype=i64),
        np.array([k for _, k in pairs], dtype=i64),
    )


def default_order(tol: float) -> int:
    """The Taylor order for a per-step tolerance: ``ceil(-0.6 ln(tol)) + 6``, in ``[8, 40]``.

    Higher than Jorba-Zou's ``-ln(tol)/2 + 1`` (which keeps the step near ``rho e^-2`` at every
    tolerance): each step also pays for the Jacobian series, the a-priori enclosure and the Lohner
    update, so longer steps at a higher order are cheaper; at a looser ``tol`` the order falls and the
    steps lengthen (``h ~ rho tol^(1/P)``), so the time falls with the asked radius. Measured on the
    heavy top, the free se(3) body and su(2) with Theta at T = 10 (orders 12-32 against tolerances
    1e-6 .. 1e-16; ``tests/benchmarks/test_bench_capd.py`` prints the curve); above 40 the doubles'
    floor is reached long before the remainder matters."""
    return min(40, max(8, math.ceil(-0.6 * math.log(tol)) + 6))


def _libm():
    """The C library's ``fegetround``/``fesetround`` (ctypes), or None where they cannot be found."""
    try:
        name = ctypes.util.find_library("m") or ctypes.util.find_library("c")
        lib = ctypes.CDLL(name)
        lib.fegetround.restype = ctypes.c_int
        lib.fesetround.argtypes = [ctypes.c_int]
        return lib
    except (OSError, AttributeError, TypeError):  # pragma: no cover - platforms without them
        return None


_LIBM = _libm()
# <fenv.h> values of (to nearest, upward, downward, toward zero), by machine
_FE = {
    "x86_64": (0, 0x800, 0x400, 0xC00),
    "AMD64": (0, 0x800, 0x400, 0xC00),
    "aarch64": (0, 0x400000, 0x800000, 0xC00000),
    "arm64": (0, 0x400000, 0x800000, 0xC00000),
}.get(platform.machine())


@contextmanager
def _round_to_nearest():
    """Run the block in round-to-nearest and give the caller's mode back after: a library such as CAPD
    switches the floating-point unit to directed rounding and leaves it so, which would void the
    outward-rounding model (and Dekker's and Knuth's exact transformations). The mode is read by a
    compiled probe (:func:`refimpl._interval_kernel.rounding_mode`: C's ``fegetround`` may read another
    register than the one compiled code uses) and set by C's ``fesetround``. Where either is missing,
    the kernel's own probe still refuses a wrong mode."""
    if _LIBM is None or _FE is None:  # pragma: no cover
        yield
        return
    old = K.rounding_mode(K.PROBE)
    if old != 0:
        _LIBM.fesetround(_FE[0])
    try:
        yield
    finally:
        if old != 0:
            _LIBM.fesetround(_FE[old])


def _run(tables, lo0, hi0, t, order, jac_order, tol, max_steps, rounding):
    return K.enclose(
        tables,
        lo0,
        hi0,
        float(t),
        int(order),
        int(jac_order),
        float(tol),
        1.0,
        int(max_steps),
        float(rounding[0]),
        float(rounding[1]),
        K.PROBE,
    )


def interval_enclose(
    tables: tuple,
    y0lo,
    y0hi,
    t: float,
    *,
    order: int,
    jac_order: int,
    tol: float,
    max_steps: int = 100000,
    rounding: tuple[float, float] = (K.U, K.ETA),
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """``(lo, hi, steps, rejected)``: a box containing ``y(t)`` for every ``y(0)`` in ``[y0lo, y0hi]``.

    ``rounding = (u, eta)`` is the outward widening (:mod:`refimpl._interval_kernel`); anything else
    than the default is for the planted-mutant test only. Raises ``ValueError`` naming the failure.
    """
    lo0 = np.array(y0lo, dtype=float)
    hi0 = np.array(y0hi, dtype=float)
    with _round_to_nearest():
        lo, hi, steps, rejected, status = _run(
            tables, lo0, hi0, t, order, jac_order, tol, max_steps, rounding
        )
    if status == K.NOT_NEAREST:
        raise ValueError(
            "interval flow: the floating-point rounding mode is not round-to-nearest (another library "
            "left it directed) and could not be reset; the outward rounding assumes it"
        )
    if status == K.UNDERFLOW:
        raise ValueError(
            f"interval flow: step size underflow after {steps} steps (no a-priori enclosure, or no "
            f"remainder below tol = {tol:g}, or the terms above jac_order = {jac_order} wider than "
            f"{K.JTOL:g} times the set: raise jac_order)"
        )
    if status == K.NONFINITE:
        raise ValueError(f"interval flow: the enclosure overflowed float64 after {steps} steps")
    if status == K.MAXSTEPS:
        raise ValueError(f"interval flow: more than max_steps = {max_steps} steps")
    return lo, hi, int(steps), int(rejected)


@dataclass
class IntervalEnclosure:
    """The box ``[lo, hi]`` (float64 bounds) containing the body state at ``t``: ``pi`` then ``Gamma``."""

    t: float
    lo: np.ndarray
    hi: np.ndarray
    n: int
    steps: int
    rejected: int
    order: int
    jac_order: int
    tol: float

    @property
    def mid(self) -> np.ndarray:
        return 0.5 * self.lo + 0.5 * self.hi

    @property
    def rad(self) -> np.ndarray:
        """Half-widths, rounded up: ``[mid - rad, mid + rad]`` contains ``[lo, hi]``."""
        m = self.mid
        return np.nextafter(np.maximum(self.hi - m, m - self.lo), np.inf)

    def max_rad(self) -> float:
        return float(np.max(self.rad))

    @property
    def gravity(self) -> bool:
        return self.lo.shape[0] == 2 * self.n

    def contains(self, values) -> np.ndarray:
        """Per entry: ``lo <= value <= hi`` decided exactly (mpmath / Fraction / float values)."""
        vals = list(np.asarray(values, dtype=object).reshape(-1))
        if len(vals) != self.lo.shape[0]:
            raise ValueError(f"values must have {self.lo.shape[0]} entries, got {len(vals)}")
        return np.array(
            [float(a) <= v <= float(b) for a, b, v in zip(self.lo, self.hi, vals)], dtype=bool
        )


def check_settings(tol, order, jac_order, max_steps) -> tuple[float, int]:
    """``(tol, order)`` after checking the interval route's settings (``order`` None: the default of
    ``tol``); a ``ValueError`` naming the setting and its range otherwise."""
    if (
        not isinstance(tol, (float, int))
        or isinstance(tol, bool)
        or not math.isfinite(tol)
        or not 1e-300 < tol < 1.0
    ):
        raise ValueError(f"tol must be a float in (1e-300, 1), got {tol!r}")
    order = default_order(float(tol)) if order is None else order
    if not isinstance(order, int) or isinstance(order, bool) or not 2 <= order <= 200:
        raise ValueError(f"order must be an int in [2, 200], got {order!r}")
    if not isinstance(jac_order, int) or isinstance(jac_order, bool) or not 1 <= jac_order <= order:
        raise ValueError(f"jac_order must be an int in [1, order = {order}], got {jac_order!r}")
    if not isinstance(max_steps, int) or isinstance(max_steps, bool) or max_steps < 1:
        raise ValueError(f"max_steps must be an int >= 1, got {max_steps!r}")
    return float(tol), order


def interval_body_enclosure(
    f,
    theta,
    upsilon,
    inertia,
    potential,
    x0,
    pi0,
    t,
    *,
    tol: float = 1e-16,
    order: int | None = None,
    jac_order: int = 6,
    max_steps: int = 100000,
) -> IntervalEnclosure:
    """Enclose the body state at ``t`` (the arguments of :func:`body_flow_enclosure`) in float64 intervals.

    ``tol``: the largest Lagrange remainder accepted per step (the radius falls with it down to the
    double floor); ``order``: the Taylor order (default :func:`default_order` of ``tol``);
    ``jac_order``: of the Jacobian series (at most ``order``).
    """
    order = check_settings(tol, order, jac_order, max_steps)[1]
    # the checks (and the Arb initial state) of the ball route, at t = 0; then t by the same rule
    e0 = body_flow_enclosure(
        f, theta, upsilon, inertia, potential, x0, pi0, 0.0, prec_bits=SETUP_BITS
    )

    tv = float(float_view(t, "t"))
    if not math.isfinite(tv) or not 0 <= tv <= MAX_FLOW_TIME:
        raise ValueError(
            f"t must be a finite number in [0, {MAX_FLOW_TIME:g}] (the flow budget), got {t!r}"
        )
    n = e0.pi.shape[0]
    balls = list(e0.pi.balls) + (list(e0.Gamma.balls) if e0.Gamma is not None else [])
    b = [_bounds(v) for v in balls]
    with workprec(SETUP_BITS):
        F, _ = body_field(f, theta, inertia, potential)
        tables = interval_tables(F)
    lo, hi, steps, rejected = interval_enclose(
        tables,
        [x for x, _ in b],
        [y for _, y in b],
        tv,
        order=order,
        jac_order=jac_order,
        tol=float(tol),
        max_steps=max_steps,
    )
    return IntervalEnclosure(tv, lo, hi, n, steps, rejected, order, jac_order, float(tol))


@dataclass
class _Field:
    """A ball field in the layout of :mod:`refimpl._rigorous_flow` (``lin[i] = [(j, ball)]``,
    ``quad[i] = [(j, k, ball)]``), for the su(2) full state below."""

    d: int
    const: dict
    lin: dict
    quad: dict


_EPS = {(0, 1, 2): 1, (1, 2, 0): 1, (2, 0, 1): 1, (0, 2, 1): -1, (2, 1, 0): -1, (1, 0, 2): -1}


def su2_full_field(theta, inertia, potential) -> tuple[_Field, int]:
    """The su(2) body field extended by the group element as a unit quaternion, in balls: state
    ``(pi, [Gamma,] q)`` with ``g = q_0 - i q.sigma`` (``exp(x^a E_a)``, ``E_a = -(i/2) sigma_a``); the
    kinematics ``g^-1 dg/dt = Omega^a E_a`` (vier10 with ``Upsilon = 0``: ``Omega = I^-1 pi``) read
    ``dq_0/dt = -1/2 q.Omega``, ``dq/dt = 1/2 (q_0 Omega + q x Omega)`` -- the rows of
    :func:`refimpl._taylor.quadratic_field_su2_full`, here with the ball ``I^-1``."""

    F, n = body_field(su2(), theta, inertia, potential)
    Ii = arb_mat([[arb(v) for v in row] for row in np.asarray(inertia, dtype=float)]).inv()
    d = F.d + 4
    q0 = F.d
    lin = {i: list(F.lin.get(i, ())) for i in range(d)}
    quad = {i: list(F.quad.get(i, ())) for i in range(d)}
    half = arb(1) / 2
    for c in range(n):  # Omega_b = sum_c Ii[b, c] pi_c
        for b in range(n):
            w = Ii[b, c]
            if w.is_zero():
                continue
            quad[q0].append((q0 + 1 + b, c, -half * w))  # -1/2 q_b Omega_b
            quad[q0 + 1 + b].append((q0, c, half * w))  # 1/2 q_0 Omega_b
            for a in range(n):
                for e in range(n):  # (q x Omega)_a = eps_aeb q_e Omega_b
                    sgn = _EPS.get((a, e, b), 0)
                    if sgn:
                        quad[q0 + 1 + a].append((q0 + 1 + e, c, sgn * half * w))
    return _Field(d, dict(F.const), lin, quad), n


def su2_quaternion(x0) -> list:
    """The balls of ``q`` with ``exp(x0^a E_a) = q_0 - i q.sigma``: ``q_0 = cos(|x0|/2)``,
    ``q = sin(|x0|/2) x0/|x0|`` (written ``x0/2 sinc(|x0|/2)``, continuous at 0)."""
    xs = [arb(float(v)) for v in np.asarray(x0, dtype=float)]
    r = sum((v * v for v in xs), arb(0)).sqrt()
    return [(r / 2).cos()] + [v / 2 * (r / 2).sinc() for v in xs]


def interval_su2_full_enclosure(
    theta,
    upsilon,
    inertia,
    potential,
    x0,
    pi0,
    t,
    *,
    tol: float = 1e-16,
    order: int | None = None,
    jac_order: int = 6,
    max_steps: int = 100000,
) -> IntervalEnclosure:
    """The full state of an su(2) model (``Upsilon = 0``) at ``t`` in float64 intervals: the box of
    ``(pi, [Gamma,] q)`` with ``g(t) = q_0 - i q.sigma`` (:func:`su2_full_field`). Arguments and checks
    as :func:`interval_body_enclosure` with ``f = su(2)``."""

    e = interval_body_enclosure(
        su2(), theta, upsilon, inertia, potential, x0, pi0, 0.0, tol=tol, order=order,
        jac_order=jac_order, max_steps=max_steps,
    )  # fmt: skip
    tv = float(float_view(t, "t"))

    if not math.isfinite(tv) or not 0 <= tv <= MAX_FLOW_TIME:
        raise ValueError(
            f"t must be a finite number in [0, {MAX_FLOW_TIME:g}] (the flow budget), got {t!r}"
        )
    with workprec(SETUP_BITS):
        F, n = su2_full_field(theta, inertia, potential)
        tables = interval_tables(F)
        b = [_bounds(v) for v in su2_quaternion(x0)]
    lo0 = list(e.lo) + [x for x, _ in b]
    hi0 = list(e.hi) + [y for _, y in b]
    lo, hi, steps, rejected = interval_enclose(
        tables,
        lo0,
        hi0,
        tv,
        order=e.order,
        jac_order=jac_order,
        tol=float(tol),
        max_steps=max_steps,
    )
    return IntervalEnclosure(tv, lo, hi, n, steps, rejected, e.order, jac_order, float(tol))
