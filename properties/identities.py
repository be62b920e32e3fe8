"""The paper's identities as plain functions: each returns a :class:`Measurement` (worst error,
its tolerance, the ratio error/tolerance and the correct digits), usable outside pytest.

The functions take raw data (structure constants, Theta, Upsilon, a point) and do **not**
validate it on purpose: the negative controls feed them structure constants that break the
Jacobi identity or a Theta that is not a cocycle, and each identity must then fail. They build
what they need themselves (omega_L in holonomic coordinates, the frame ``A = phi1(-ad_x)``)
independently of :mod:`refimpl.reference`, whose Poisson tensor they judge.

Identities (the paper's labels):

closedness (vier2, zeven1)
    ``d omega_L = 0``: ``(d Omega)_ijk = d_i Omega_jk + d_j Omega_ki + d_k Omega_ij`` of the
    holonomic matrix ``Omega(x, pi) = diag(A, 1)^T W diag(A, 1)`` (vier3).
    *Exact* (:func:`closedness_exact`): sympy, with ``pi`` symbolic, at ``x = 0``, where
    ``A = 1 - ad_x / 2 + O(x^2)`` is exact to the first order that ``d`` needs; omega_L is
    left-invariant, so ``x = 0`` carries no loss of generality for a Lie algebra.
    *High precision* (:func:`closedness_mp`): at any ``x``, derivatives by ``mpmath.diff``.
antisymmetry (vier6, vier7)
    ``Psi = Phi^T``, ``Phi S = S Psi`` and ``Upsilon Phi = Psi Upsilon`` antisymmetric,
    ``Upsilon Phi^-1 = Psi^-1 Upsilon`` and ``Phi^-1 S = S Psi^-1`` antisymmetric,
    ``det Phi = det Psi`` (:func:`phi_psi_identities`, exact or mpmath), and the same
    relations read off an implementation's Poisson tensor (:func:`tensor_blocks`).
Jacobi (vier9)
    ``J_ijk = sum_l P_il d_l P_jk + cyclic(i, j, k) = 0`` for the holonomic Poisson tensor:
    exactly (:func:`jacobi_exact`, sympy at ``x = 0``, ``pi`` symbolic), at high precision for
    any tensor function (:func:`jacobi_mp`, ``mpmath.diff``) and for a float64 implementation
    (:func:`jacobi_float`, central differences with a Richardson error model).
Darboux (drie7-drie9)
    for ``Theta = -xi.f`` and ``Upsilon = 0``, ``(x, p')`` with ``p' = A(x)^T (pi + xi)``
    (``p'_mu = p_mu + xi_b L^b_mu(g^-1, g)``, drie9) are canonical: ``J P J^T = [[0, 1], [-1, 0]]``
    with ``J = d(x, p') / d(x, pi)`` (:func:`darboux_residual`).
Whitehead (zeven3)
    ``H^2 = 0`` for a semisimple algebra: every cocycle is ``-xi.f`` with ``xi`` found
    (:func:`whitehead`); ``dim H^2`` by an independent exact computation (:func:`h2_exact`).
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any, Callable

import mpmath
import numpy as np
import sympy

from tstarg.refimpl import LieAlgebra, parse_number
from tstarg.refimpl.accuracy import correct_digits as _digits
from tstarg.refimpl.accuracy import max_abs
from tstarg.refimpl.flows import reference_flow
from tstarg.refimpl.reference import Reference

__all__ = [
    "Measurement",
    "omega_holonomic",
    "frame_A",
    "closedness_mp",
    "closedness_exact",
    "phi_psi_identities",
    "tensor_blocks",
    "jacobi_mp",
    "jacobi_exact",
    "jacobi_float",
    "darboux_residual",
    "darboux_flow",
    "whitehead",
    "h2_exact",
    "EPS",
]

EPS = float(np.finfo(float).eps)


class Measurement:
    """Worst ``error`` against its ``tolerance``: ``ratio = error / tolerance`` (a pass is ``<= 1``).

    Iterating gives ``(ratio, digits)``, the shape :func:`properties.runner.run_property` expects.
    """

    __slots__ = ("error", "tolerance", "digits", "where")

    def __init__(
        self, error: float, tolerance: float, digits: float | None = None, where: str = ""
    ):
        self.error = float(error)
        self.tolerance = float(tolerance)
        self.digits = digits
        self.where = where

    @property
    def ratio(self) -> float:
        if self.error == 0:
            return 0.0
        return self.error / self.tolerance if self.tolerance > 0 else math.inf

    def __iter__(self):
        return iter((self.ratio, self.digits))

    def __repr__(self) -> str:
        return (
            f"Measurement(error={self.error:.3g}, tolerance={self.tolerance:.3g}, ratio={self.ratio:.3g}, "
            f"digits={self.digits}, where={self.where!r})"
        )


# ------------------------------------------------------------------ helpers
def _exact(v: Any) -> sympy.Expr:
    """An exact sympy number; floats are taken at their exact binary value.

    Strings are parsed as decimal or rational literals by :class:`fractions.Fraction` only, never
    by ``sympify`` (which evaluates them as Python code); anything else is refused by name.
    """
    if isinstance(v, (bool, np.bool_)):
        raise TypeError(f"booleans are not numbers here, got {v!r}")
    if isinstance(v, sympy.Basic):
        return v
    if isinstance(v, Fraction):
        return sympy.Rational(v.numerator, v.denominator)
    if isinstance(v, (float, np.floating)):
        if not np.isfinite(v):
            raise ValueError(f"non-finite number {v!r}")
        return sympy.Rational(float(v))
    if isinstance(v, (int, np.integer)):
        return sympy.Integer(int(v))
    if isinstance(v, mpmath.mpf):
        if not mpmath.isfinite(v):
            raise ValueError(f"non-finite number {v!r}")
        man, exp = v.man_exp
        return sympy.Integer(man) * sympy.Integer(2) ** exp
    if isinstance(v, str):
        q = parse_number(v)  # the one parser (refimpl._validate): never evaluated
        return sympy.Rational(q.numerator, q.denominator)
    raise TypeError(f"cannot use {type(v).__name__} {v!r:.60} as an exact real number")


def _mpf(v: Any) -> mpmath.mpf:
    """An mpf at the current precision (exact inputs evaluated there)."""
    if isinstance(v, (mpmath.mpf, float, int, np.floating, np.integer)):
        return mpmath.mpf(v)
    if isinstance(v, Fraction):
        return mpmath.mpf(v.numerator) / v.denominator
    e = _exact(v)
    return sympy.N(e, mpmath.mp.dps + 5)._to_mpmath(mpmath.mp.prec)


_ZERO_PROBE = sympy.Symbol("z")


def _exact_size(v: sympy.Expr) -> float:
    """``|v|`` of an exact number as a float, ``0.0`` exactly when ``v = 0``.

    Rational data stay rational. Structure constants such as VII_h's ``sqrt(h)`` make entries
    algebraic and, after an inverse, unsimplified: sympy can neither order them nor tell an
    unsimplified zero from a tiny number (``Abs(...) > 0`` raises). Zero is decided exactly by
    the minimal polynomial (``z`` iff ``v = 0``); a non-algebraic entry falls back to
    :meth:`sympy.Expr.equals`. A nonzero value is then evaluated to 30 digits: only its size
    matters (which identity is worst), never its sign.
    """
    if not isinstance(v, sympy.Basic):  # never sympify: a string would be evaluated as code
        raise TypeError(f"_exact_size: expects a sympy number, got {type(v).__name__}")
    v = sympy.expand(v)
    if v.is_Rational:
        return float(abs(v))
    try:
        zero = sympy.minimal_polynomial(v, _ZERO_PROBE) == _ZERO_PROBE
    except (NotImplementedError, sympy.polys.polyerrors.NotAlgebraic):
        zero = bool(v.equals(0))
    return 0.0 if zero else float(abs(sympy.N(v, 30)))


def _f_exact(f: Any) -> np.ndarray:

    if isinstance(f, LieAlgebra):
        if f.f_exact is None:
            raise ValueError(f"{f.name}: an exact check needs exact structure constants")
        return f.f_exact
    return np.vectorize(_exact, otypes=[object])(np.asarray(f, dtype=object))


def _f_raw(f: Any) -> np.ndarray:

    if isinstance(f, LieAlgebra):
        return f.f_exact if f.f_exact is not None else f.f
    return np.asarray(f, dtype=object)


def _max_abs(vals) -> mpmath.mpf:
    return max_abs(vals, dps=mpmath.mp.dps)


# ------------------------------------------------------- omega_L (vier3)
# Not refimpl/_phi.py's phi1: the properties judge refimpl, so their frame is computed apart.
def frame_A(F: list, x: list) -> mpmath.matrix:
    """``A = phi1(-ad_x) = L(g^-1, g)`` at the current precision, as the upper-right block of
    ``expm([[-ad_x, 1], [0, 0]])`` (Van Loan); ``F[m]`` are mpmath matrices ``f^m_ab``."""
    n = len(F)
    big = mpmath.zeros(2 * n, 2 * n)
    for m in range(n):
        for b in range(n):
            big[m, b] = -mpmath.fsum(x[a] * F[m][a, b] for a in range(n))
        big[m, n + m] = 1
    e = mpmath.expm(big)
    return mpmath.matrix([[e[i, n + j] for j in range(n)] for i in range(n)])


def _F_mp(f) -> list:
    raw = _f_raw(f)
    n = raw.shape[0]
    return [
        mpmath.matrix([[_mpf(raw[m, a, b]) for b in range(n)] for a in range(n)]) for m in range(n)
    ]


def _mat_mp(m, n) -> mpmath.matrix:
    arr = np.asarray(m, dtype=object)
    return mpmath.matrix([[_mpf(arr[i, j]) for j in range(n)] for i in range(n)])


def _diag_with_one(A: mpmath.matrix) -> mpmath.matrix:
    """``diag(A, 1)``: the ``2n x 2n`` change of frame acting by ``A`` on ``x`` and as 1 on ``pi``."""
    n = A.rows
    T = mpmath.zeros(2 * n, 2 * n)
    for i in range(n):
        for j in range(n):
            T[i, j] = A[i, j]
        T[n + i, n + i] = 1
    return T


def _S_mp(F: list, pi: list, theta: mpmath.matrix) -> mpmath.matrix:
    """``S_ab = pi_m f^m_ab - Theta_ab`` (vier3) at the current precision."""
    n = len(F)
    return mpmath.matrix(
        [
            [mpmath.fsum(pi[m] * F[m][a, b] for m in range(n)) - theta[a, b] for b in range(n)]
            for a in range(n)
        ]
    )


def omega_holonomic(
    F: list, theta: mpmath.matrix, upsilon: mpmath.matrix, z: list
) -> mpmath.matrix:
    """``Omega(x, pi) = diag(A, 1)^T [[S, 1], [-1, Upsilon]] diag(A, 1)`` (vier3) at the current precision."""
    n = len(F)
    x, pi = z[:n], z[n:]
    A = frame_A(F, x)
    W = mpmath.zeros(2 * n, 2 * n)
    for a in range(n):
        for b in range(n):
            W[a, b] = mpmath.fsum(pi[m] * F[m][a, b] for m in range(n)) - theta[a, b]
            W[n + a, n + b] = upsilon[a, b]
        W[a, n + a] = 1
        W[n + a, a] = -1
    T = _diag_with_one(A)
    return T.T * W * T


def _derivatives(fun: Callable[[list], mpmath.matrix], z: list) -> list:
    """``[d fun / d z_l]`` by ``mpmath.diff`` (central step at doubled precision); ``fun`` is
    evaluated once per step and shared by all entries (memoized)."""
    out = []
    for l in range(len(z)):
        cache: dict = {}

        def g(t, l=l, cache=cache):
            key = t._mpf_ if isinstance(t, mpmath.mpf) else t
            if key not in cache:
                zz = list(z)
                zz[l] = zz[l] + t
                cache[key] = fun(zz)
            return cache[key]

        m0 = fun(list(z))
        D = mpmath.zeros(m0.rows, m0.cols)
        for i in range(m0.rows):
            for j in range(m0.cols):
                D[i, j] = mpmath.diff(lambda t, i=i, j=j: g(t)[i, j], 0)
        out.append(D)
    return out


def closedness_mp(f, theta, upsilon, x, pi, *, dps: int = 25) -> Measurement:
    """``d omega_L = 0`` at ``(x, pi)`` with derivatives by ``mpmath.diff`` at ``dps`` digits.

    Error model: the derivatives are accurate to ``dps - 2`` digits relative to the size of
    Omega and its derivatives (mpmath.diff differences at doubled precision); the cyclic sum
    of three: tolerance ``3 * 10^-(dps-4) * scale``.
    """
    n = np.asarray(_f_raw(f)).shape[0]
    with mpmath.workdps(dps):
        F = _F_mp(f)
        th, up = _mat_mp(theta, n), _mat_mp(upsilon, n)
        z = [_mpf(v) for v in list(x) + list(pi)]
        D = _derivatives(lambda zz: omega_holonomic(F, th, up, zz), z)
        Om = omega_holonomic(F, th, up, z)
        worst, where = mpmath.mpf(0), ""
        N = 2 * n
        for i in range(N):
            for j in range(i + 1, N):
                for k in range(j + 1, N):
                    c = abs(D[i][j, k] + D[j][k, i] + D[k][i, j])
                    if c > worst:
                        worst, where = c, f"(d Omega)_{i}{j}{k}"
        scale = max([mpmath.mpf(1), _max_abs(Om)] + [_max_abs(d) for d in D])
        tol = 3 * mpmath.mpf(10) ** -(dps - 4) * scale
        return Measurement(worst, tol, _digits(worst, scale), where)


# ------------------------------------------------------------ exact routes
def _symbolic_model(f, theta, upsilon):
    fe = _f_exact(f)
    n = fe.shape[0]
    th = sympy.Matrix(n, n, lambda a, b: _exact(np.asarray(theta, dtype=object)[a, b]))
    up = sympy.Matrix(n, n, lambda a, b: _exact(np.asarray(upsilon, dtype=object)[a, b]))
    xs = sympy.symbols(f"x0:{n}")
    ps = sympy.symbols(f"p0:{n}")
    S = sympy.Matrix(
        n, n, lambda a, b: sum((ps[m] * fe[m, a, b] for m in range(n)), sympy.Integer(0)) - th[a, b]
    )
    adx = sympy.Matrix(
        n, n, lambda m, b: sum((xs[a] * fe[m, a, b] for a in range(n)), sympy.Integer(0))
    )
    A1 = sympy.eye(n) - adx / 2  # phi1(-ad_x) to first order in x
    return fe, n, th, up, xs, ps, S, A1


def closedness_exact(f, theta, upsilon) -> Measurement:
    """``d omega_L = 0`` exactly (sympy) at ``x = 0`` for every ``pi`` (symbolic); error is the
    largest |coefficient| of the cyclic sum (0 or a positive rational), tolerance 0 (ratio 0 or inf)."""
    fe, n, th, up, xs, ps, S, A1 = _symbolic_model(f, theta, upsilon)
    W = sympy.BlockMatrix([[S, sympy.eye(n)], [-sympy.eye(n), up]]).as_explicit()
    T = sympy.diag(A1, sympy.eye(n))
    Om = (T.T * W * T).applyfunc(sympy.expand)
    z = list(xs) + list(ps)
    at0 = {v: 0 for v in xs}
    D = [Om.diff(v).subs(at0) for v in z]
    return _exact_cyclic(
        lambda i, j, k: D[i][j, k] + D[j][k, i] + D[k][i, j], 2 * n, ps, "(d Omega)"
    )


def _exact_cyclic(entry, N, ps, label) -> Measurement:
    worst, where = 0.0, ""
    for i in range(N):
        for j in range(i + 1, N):
            for k in range(j + 1, N):
                e = sympy.expand(entry(i, j, k))
                if e == 0:
                    continue
                e = sympy.cancel(sympy.together(e))
                coeffs = sympy.Poly(sympy.numer(e), *ps).coeffs() if ps else [e]
                size = max((_exact_size(c) for c in coeffs), default=0.0)
                if size > worst:
                    worst, where = size, f"{label}_{i}{j}{k} = {e}"
    return Measurement(worst, 0.0, None if worst else math.inf, where[:300])


# ---------------------------------------------------- vier6, vier7
def phi_psi_identities(f, theta, upsilon, pi, *, exact: bool = True, dps: int = 30) -> Measurement:
    """The identities of vier6/vier7 at momenta ``pi``.

    ``exact=True``: sympy with rational data, tolerance 0. ``exact=False``: mpmath at ``dps``,
    tolerance ``n 10^-(dps-3) cond(Phi) scale^2`` (one inverse of Phi, products of size scale^2).
    Raises ``ValueError`` when ``Delta = 0`` (the inverse identities need Phi invertible, vier7).
    """
    n = np.asarray(_f_raw(f)).shape[0]
    if exact:
        fe = _f_exact(f)
        th = sympy.Matrix(n, n, lambda a, b: _exact(np.asarray(theta, dtype=object)[a, b]))
        up = sympy.Matrix(n, n, lambda a, b: _exact(np.asarray(upsilon, dtype=object)[a, b]))
        pv = [_exact(v) for v in pi]
        S = sympy.Matrix(
            n,
            n,
            lambda a, b: sum((pv[m] * fe[m, a, b] for m in range(n)), sympy.Integer(0)) - th[a, b],
        )
        Phi = sympy.eye(n) + S * up
        Psi = sympy.eye(n) + up * S
        det = Phi.det()
        if _exact_size(det) == 0:
            raise ValueError(f"Delta = det Phi = 0 at pi = {list(pi)} (vier7): Phi has no inverse")
        Pinv, Qinv = Phi.inv(), Psi.inv()
        res = _identity_residuals(Phi, Psi, S, up, Pinv, Qinv, det, Psi.det())
        size, where = max(
            ((max((_exact_size(v) for v in m), default=0.0), k) for k, m in res),
            key=lambda t: t[0],
        )
        return Measurement(size, 0.0, None if size else math.inf, where if size else "")
    with mpmath.workdps(dps + 10):
        F = _F_mp(f)
        th, up = _mat_mp(theta, n), _mat_mp(upsilon, n)
        pv = [_mpf(v) for v in pi]
        S = _S_mp(F, pv, th)
        Phi = mpmath.eye(n) + S * up
        Psi = mpmath.eye(n) + up * S
        Pinv, Qinv = mpmath.inverse(Phi), mpmath.inverse(Psi)
        res = _identity_residuals(Phi, Psi, S, up, Pinv, Qinv, mpmath.det(Phi), mpmath.det(Psi))
        worst, where = mpmath.mpf(0), ""
        for k, m in res:
            v = _max_abs(list(m))
            if v > worst:
                worst, where = v, k
        scale = max(mpmath.mpf(1), mpmath.mnorm(S, 1), mpmath.mnorm(up, 1), mpmath.mnorm(Phi, 1))
        cond = mpmath.mnorm(Phi, 1) * mpmath.mnorm(Pinv, 1)
        tol = n * mpmath.mpf(10) ** -(dps - 3) * cond * scale**n
        return Measurement(worst, tol, _digits(worst, scale), where)


def _identity_residuals(Phi, Psi, S, U, Pinv, Qinv, detPhi, detPsi):
    """Residual matrices of vier6/vier7 (each must vanish)."""

    def flat(m):
        return [m[i, j] for i in range(m.rows) for j in range(m.cols)]

    PS = Phi * S
    UP = U * Phi
    UPi = U * Pinv
    PiS = Pinv * S
    return [
        ("Psi - Phi^T (vier6)", flat(Psi - Phi.T)),
        ("Phi S - S Psi (vier6)", flat(PS - S * Psi)),
        ("Phi S + (Phi S)^T (vier6)", flat(PS + PS.T)),
        ("Upsilon Phi - Psi Upsilon (vier6)", flat(UP - Psi * U)),
        ("Upsilon Phi + (Upsilon Phi)^T (vier6)", flat(UP + UP.T)),
        ("Upsilon Phi^-1 - Psi^-1 Upsilon (vier7)", flat(UPi - Qinv * U)),
        ("Upsilon Phi^-1 + (Upsilon Phi^-1)^T (vier7)", flat(UPi + UPi.T)),
        ("Phi^-1 S - S Psi^-1 (vier7)", flat(PiS - S * Qinv)),
        ("Phi^-1 S + (Phi^-1 S)^T (vier7)", flat(PiS + PiS.T)),
        ("det Phi - det Psi (vier7)", [detPhi - detPsi]),
    ]


def tensor_blocks(P: np.ndarray, error_bound: float, f, theta, upsilon, x, pi) -> Measurement:
    """vier7/vier9 read off an implementation's holonomic Poisson tensor ``P`` (float64).

    ``B = diag(A, 1) P diag(A, 1)^T`` must be ``[[-U Phi^-1, Psi^-1], [-Phi^-1, -S Psi^-1]]``;
    residuals that need no inverse: ``B_xx + B_xx^T``, ``B_pp + B_pp^T``, ``B_px + B_xp^T``,
    ``Psi B_xp - 1``, ``Phi B_px + 1``, ``B_xx Phi + U``, ``B_pp Psi + S`` (A, Phi, S, U at 40
    digits). Error model: an entry error ``e`` of P (the implementation's ``error_bound``, or
    ``eps max|P|`` for a correctly rounded output) becomes ``2n ||A||^2 e`` in B; a residual
    adds ``||Phi|| e_B + n eps ||Phi|| ||B||``; tolerance ``8 n`` times that.
    """
    n = np.asarray(_f_raw(f)).shape[0]
    P = np.asarray(P, dtype=float)
    if not np.all(np.isfinite(P)):
        return Measurement(math.inf, 1.0, None, "non-finite entries in P")
    with mpmath.workdps(40):
        F = _F_mp(f)
        A = frame_A(F, [_mpf(v) for v in x])
        th, up = _mat_mp(theta, n), _mat_mp(upsilon, n)
        pv = [_mpf(v) for v in pi]
        S = _S_mp(F, pv, th)
        Phi = mpmath.eye(n) + S * up
        T = _diag_with_one(A)
        B = T * mpmath.matrix(P.tolist()) * T.T
        blk = {
            k: mpmath.matrix([[B[r0 + i, c0 + j] for j in range(n)] for i in range(n)])
            for k, (r0, c0) in {"xx": (0, 0), "xp": (0, n), "px": (n, 0), "pp": (n, n)}.items()
        }
        I = mpmath.eye(n)
        res = {
            "B_xx + B_xx^T (U Phi^-1 antisymmetric)": blk["xx"] + blk["xx"].T,
            "B_pp + B_pp^T (S Psi^-1 antisymmetric)": blk["pp"] + blk["pp"].T,
            "B_px + B_xp^T (Psi = Phi^T)": blk["px"] + blk["xp"].T,
            "Psi B_xp - 1": Phi.T * blk["xp"] - I,
            "Phi B_px + 1": Phi * blk["px"] + I,
            "B_xx Phi + U": blk["xx"] * Phi + up,
            "B_pp Psi + S": blk["pp"] * Phi.T + S,
        }
        worst, where = mpmath.mpf(0), ""
        for k, m in res.items():
            v = _max_abs([m[i, j] for i in range(n) for j in range(n)])
            if v > worst:
                worst, where = v, k
        normA = float(mpmath.mnorm(A, mpmath.inf))
        normPhi = float(max(mpmath.mnorm(Phi, mpmath.inf), mpmath.mnorm(Phi, 1), 1))
        normB = float(max(mpmath.mnorm(B, mpmath.inf), 1))
        e_P = max(float(error_bound), EPS * float(np.max(np.abs(P))))
        e_B = 2 * n * max(normA, 1.0) ** 2 * e_P
        tol = 8 * n * (normPhi * e_B + n * EPS * normPhi * normB)
        return Measurement(float(worst), tol, _digits(worst, normB), where)


# ------------------------------------------------------------------ Jacobi (vier9)
def _jacobiator(P, D, N):
    """``J_ijk = sum_l (P_il D_l[j,k] + P_jl D_l[k,i] + P_kl D_l[i,j])`` for i < j < k."""
    out = {}
    for i in range(N):
        for j in range(i + 1, N):
            for k in range(j + 1, N):
                out[(i, j, k)] = sum(
                    P[i, l] * D[l][j, k] + P[j, l] * D[l][k, i] + P[k, l] * D[l][i, j]
                    for l in range(N)
                )
    return out


def jacobi_mp(tensor: Callable[[list], mpmath.matrix], z: list, *, dps: int = 20) -> Measurement:
    """Jacobi identity of the bivector ``tensor(z)`` at ``z``; derivatives by ``mpmath.diff``.

    ``tensor`` must evaluate at the current mpmath precision (mpmath.diff calls it at about
    ``2 dps + 12`` digits). Error model: P and dP to ``dps - 2`` digits relative to their
    size; ``J`` sums ``3 N`` products: tolerance ``3 N 10^-(dps-4) max|P| max|dP|``.
    """
    with mpmath.workdps(dps):
        zz = [_mpf(v) for v in z]
        N = len(zz)
        P = tensor(zz)
        D = _derivatives(tensor, zz)
        J = _jacobiator(P, D, N)
        worst, where = mpmath.mpf(0), ""
        for key, v in J.items():
            if abs(v) > worst:
                worst, where = abs(v), f"J_{key}"
        sP = max(mpmath.mpf(1), _max_abs(P))
        sD = max([mpmath.mpf(1)] + [_max_abs(d) for d in D])
        tol = 3 * N * mpmath.mpf(10) ** -(dps - 4) * sP * sD
        return Measurement(worst, tol, _digits(worst, sP * sD), where)


def reference_tensor(f, theta, upsilon, *, dps: int = 20) -> Callable[[list], mpmath.matrix]:
    """``z -> P(z)`` from :class:`refimpl.reference.Reference` at enough digits for ``mpmath.diff``."""

    ref = Reference(2 * dps + 20)
    n = np.asarray(_f_raw(f)).shape[0]
    ff = f

    def P(z):
        return ref.poisson_tensor_mp(ff, theta, upsilon, z[:n], z[n:])

    return P


def closed_form_tensor(f, theta, upsilon) -> Callable[[list], mpmath.matrix]:
    """``z -> T (-W^-1) T^T`` (vier9), unvalidated, at the current precision: lets the negative
    controls evaluate the paper's formula on structure constants that break Jacobi."""
    n = np.asarray(_f_raw(f)).shape[0]

    def P(z):
        F = _F_mp(f)
        th, up = _mat_mp(theta, n), _mat_mp(upsilon, n)
        x, pi = z[:n], z[n:]
        A = frame_A(F, x)
        L = mpmath.inverse(A)
        S = _S_mp(F, pi, th)
        Phi = mpmath.eye(n) + S * up
        Pi = mpmath.inverse(Phi)
        Qi = Pi.T
        blocks = [[-up * Pi, Qi], [-Pi, -S * Qi]]
        B = mpmath.zeros(2 * n, 2 * n)
        for bi in range(2):
            for bj in range(2):
                for i in range(n):
                    for j in range(n):
                        B[bi * n + i, bj * n + j] = blocks[bi][bj][i, j]
        T = _diag_with_one(L)
        return T * B * T.T

    return P


def jacobi_exact(f, theta, upsilon, pi) -> Measurement:
    """Jacobi identity of the holonomic Poisson tensor exactly (sympy rationals) at ``x = 0``
    and rational momenta ``pi``. With ``P_b = -W^-1`` (vier9) and ``T = diag(A^-1, 1)``:

    * ``d P / d pi_m = P_b (d W / d pi_m) P_b`` with ``d W / d pi_m = [[f^m, 0], [0, 0]]``;
    * ``d P / d x^l = E_l P_b + P_b E_l^T`` at ``x = 0``, ``E_l = diag(ad_{e_l} / 2, 0)``
      (``A^-1 = 1 + ad_x / 2 + O(x^2)``).

    The bivector is left-invariant, so ``x = 0`` covers the whole group. Tolerance 0.
    """
    fe = _f_exact(f)
    n = fe.shape[0]
    th = sympy.Matrix(n, n, lambda a, b: _exact(np.asarray(theta, dtype=object)[a, b]))
    up = sympy.Matrix(n, n, lambda a, b: _exact(np.asarray(upsilon, dtype=object)[a, b]))
    pv = [_exact(v) for v in pi]
    fm = [sympy.Matrix(n, n, lambda a, b, m=m: fe[m, a, b]) for m in range(n)]
    S = sum((pv[m] * fm[m] for m in range(n)), sympy.zeros(n, n)) - th
    W = sympy.BlockMatrix([[S, sympy.eye(n)], [-sympy.eye(n), up]]).as_explicit()
    if _exact_size((sympy.eye(n) + S * up).det()) == 0:
        raise ValueError(f"Delta = det Phi = 0 at pi = {list(pi)} (vier7): no Poisson tensor")
    Pb = -W.inv()
    N = 2 * n
    D = []
    for l in range(n):  # d/dx^l at x = 0
        E = sympy.zeros(N, N)
        E[:n, :n] = sympy.Matrix(n, n, lambda m, b, l=l: fe[m, l, b]) / 2
        D.append(E * Pb + Pb * E.T)
    for m in range(n):  # d/dpi_m
        dW = sympy.zeros(N, N)
        dW[:n, :n] = fm[m]
        D.append(Pb * dW * Pb)
    worst, where = 0.0, ""
    for key, v in _jacobiator(Pb, D, N).items():
        size = _exact_size(v)
        if size > worst:
            worst, where = size, f"J_{key} = {v}"
    return Measurement(worst, 0.0, None if worst else math.inf, where)


def jacobi_float(
    batch: Callable[[np.ndarray, np.ndarray], tuple], z: np.ndarray, n: int
) -> Measurement:
    """Jacobi identity of a float64 implementation by central differences.

    ``batch(x, pi) -> (P, error_bound)`` over a leading batch axis. Steps ``h_l`` and ``2h_l``
    per coordinate, ``h_l = eps^(1/3) max(1, |z_l|)`` (one step for all coordinates, scaled by
    the largest, would step a unit-size x by ~1e5 when a central x or a momentum is ~1e10 and
    cross the chart boundary). Error model per derivative: truncation ``|D_h - D_2h| / 3``
    (Richardson) plus rounding ``e / h_l`` (``e`` the entry error bound of P); ``J`` sums ``3N``
    products: tolerance ``4 * 3N (max|P| dP_err + max|dP| e)``.
    """
    z = np.asarray(z, dtype=float)
    N = 2 * n
    hs = EPS ** (1 / 3) * np.maximum(1.0, np.abs(z))
    pts = [z]
    for l in range(N):
        h = float(hs[l])
        for s in (h, -h, 2 * h, -2 * h):
            zz = z.copy()
            zz[l] += s
            pts.append(zz)
    Z = np.array(pts)
    P, bound = batch(Z[:, :n], Z[:, n:])
    if not np.all(np.isfinite(P)):
        return Measurement(math.inf, 1.0, None, "non-finite P near the point")
    e = float(np.max(bound))
    P0 = P[0]
    D, Derr = [], 0.0
    for l in range(N):
        h = float(hs[l])
        p1, m1, p2, m2 = P[1 + 4 * l : 5 + 4 * l]
        Dh = (p1 - m1) / (2 * h)
        D2h = (p2 - m2) / (4 * h)
        D.append(Dh)
        Derr = max(Derr, float(np.max(np.abs(Dh - D2h))) / 3 + e / h)
    J = _jacobiator(P0, D, N)
    if not J:  # 2n = 2: no triple of distinct indices, every bivector on a 2-manifold is Poisson
        return Measurement(0.0, 0.0, math.inf, "vacuous: 2n = 2 coordinates, no triple i < j < k")
    worst_key = max(J, key=lambda k: abs(J[k]))
    worst = abs(float(J[worst_key]))
    sP = max(1.0, float(np.max(np.abs(P0))))
    sD = max(1.0, max(float(np.max(np.abs(d))) for d in D))
    tol = 4 * 3 * N * (sP * Derr + sD * e)
    return Measurement(
        worst, tol, -math.log10(worst / (sP * sD)) if worst else math.inf, f"J_{worst_key}"
    )


# ---------------------------------------------------------------- Darboux (drie9)
def darboux_map_jacobian(f, xi, x, pi, *, dps: int = 30) -> mpmath.matrix:
    """``J = d(x, p') / d(x, pi)`` for ``p' = A(x)^T (pi + xi)`` (drie9), ``d p'/dx`` by ``mpmath.diff``."""
    n = np.asarray(_f_raw(f)).shape[0]
    with mpmath.workdps(dps):
        F = _F_mp(f)
        xv = [_mpf(v) for v in x]
        q = mpmath.matrix([_mpf(p) + _mpf(s) for p, s in zip(pi, xi)])

        def pprime(xx):
            return frame_A(F, xx).T * q

        J = mpmath.zeros(2 * n, 2 * n)
        A = frame_A(F, xv)
        for l, D in enumerate(_derivatives(pprime, xv)):
            for i in range(n):
                J[n + i, l] = D[i, 0]
        for i in range(n):
            J[i, i] = 1
            for j in range(n):
                J[n + i, n + j] = A[j, i]
        return J


def darboux_residual(
    P, J: mpmath.matrix, error_bound: float | None = None, *, dps: int = 30
) -> Measurement:
    """``max |J P J^T - [[0, 1], [-1, 0]]|`` (drie9: the bracket is canonical in ``(x, p')``).

    ``P`` an mpmath matrix (reference; tolerance ``10^-(dps-4) ||J||^2 max(1, max|P|)``) or a
    float64 array with its entry error bound (tolerance ``4 (rowsum|J|)^2 (e + 2n eps max|P|)``).
    """
    N = J.rows
    n = N // 2
    with mpmath.workdps(max(dps, 40)):
        Pm = (
            P
            if isinstance(P, mpmath.matrix)
            else mpmath.matrix(np.asarray(P, dtype=float).tolist())
        )
        R = J * Pm * J.T
        for i in range(n):
            R[i, n + i] -= 1
            R[n + i, i] += 1
        worst, where = mpmath.mpf(0), ""
        for i in range(N):
            for j in range(N):
                if abs(R[i, j]) > worst:
                    worst, where = abs(R[i, j]), f"({i},{j})"
        rowsum = max(mpmath.fsum(abs(J[i, j]) for j in range(N)) for i in range(N))
        sP = max(mpmath.mpf(1), _max_abs(Pm))
        if isinstance(P, mpmath.matrix):
            tol = mpmath.mpf(10) ** -(dps - 4) * rowsum**2 * sP
        else:
            e = float(error_bound if error_bound is not None else 0.0)
            tol = 4 * rowsum**2 * (e + N * EPS * sP)
        return Measurement(worst, tol, _digits(worst, rowsum**2 * sP), where)


# ---------------------------------------------------------------- cohomology (zeven1, zeven3)
def _delta2_rows(fe: np.ndarray) -> tuple[sympy.Matrix, list]:
    """The linear map ``Theta -> (delta_2 Theta)_abc = Theta([a,b],c) + cyclic`` on the
    ``n(n-1)/2`` independent entries ``Theta_ab``, ``a < b`` (exact)."""
    n = fe.shape[0]
    pairs = [(a, b) for a in range(n) for b in range(a + 1, n)]
    idx = {p: t for t, p in enumerate(pairs)}

    def coef(m, c):  # Theta_mc as a vector over pairs
        v = [sympy.Integer(0)] * len(pairs)
        if m < c:
            v[idx[(m, c)]] = sympy.Integer(1)
        elif m > c:
            v[idx[(c, m)]] = sympy.Integer(-1)
        return v

    rows = []
    for a in range(n):
        for b in range(a + 1, n):
            for c in range(b + 1, n):
                row = [sympy.Integer(0)] * len(pairs)
                for p, q, r in ((a, b, c), (b, c, a), (c, a, b)):
                    for m in range(n):
                        if fe[m, p, q] != 0:
                            v = coef(m, r)
                            row = [x + fe[m, p, q] * y for x, y in zip(row, v)]
                rows.append(row)
    return (sympy.Matrix(rows) if rows else sympy.zeros(0, len(pairs))), pairs


def h2_exact(f) -> int:
    """``dim H^2 = dim Z^2 - dim B^2`` by exact ranks: ``Z^2`` the kernel of delta_2 (zeven1),
    ``B^2`` the image of ``xi -> -xi.f`` (zeven3). Independent of :mod:`refimpl._cohomology`."""
    fe = _f_exact(f)
    n = fe.shape[0]
    M, pairs = _delta2_rows(fe)
    z2 = len(pairs) - (M.rank() if M.rows else 0)
    Bm = (
        sympy.Matrix([[-fe[m, a, b] for m in range(n)] for a, b in pairs])
        if pairs
        else sympy.zeros(0, n)
    )
    b2 = Bm.rank() if Bm.rows else 0
    return z2 - b2


def whitehead(f) -> Measurement:
    """Whitehead's second lemma (zeven3): every 2-cocycle of a semisimple algebra is ``-xi.f``.

    For each vector of an exact basis of ``Z^2`` solve ``Theta = -xi.f`` exactly (sympy) and
    verify it; the error is the number of cocycles left without ``xi`` (tolerance 0).
    """
    fe = _f_exact(f)
    n = fe.shape[0]
    M, pairs = _delta2_rows(fe)
    basis = (
        M.nullspace()
        if M.rows
        else [
            sympy.Matrix([1 if i == t else 0 for i in range(len(pairs))]) for t in range(len(pairs))
        ]
    )
    Bm = sympy.Matrix([[-fe[m, a, b] for m in range(n)] for a, b in pairs])
    missing = 0
    where = ""
    xs = sympy.symbols(f"xi0:{n}")
    for v in basis:
        sol = sympy.linsolve((Bm, v), *xs)
        if not sol:
            missing += 1
            where = f"cocycle {list(v)} is not -xi.f"
            continue
        xi = [e.subs({s: 0 for s in xs}) for e in next(iter(sol))]
        if sympy.simplify(Bm * sympy.Matrix(xi) - v) != sympy.zeros(len(pairs), 1):
            missing += 1
            where = f"xi {xi} does not reproduce cocycle {list(v)}"
    return Measurement(missing, 0.0, None if missing else math.inf, where)


# ----------------------------------------------------- Darboux flows (drie10-drie12)
def darboux_flow(f, xi, inertia, x0, pi0, t, *, dps: int = 18, shift=None) -> Measurement:
    """The flow of ``H = 1/2 pi I^-1 pi`` under ``omega_I`` with ``Theta = -xi.f`` (drie4, drie5;
    from :func:`refimpl.flows.reference_flow`) equals the flow of the Darboux system drie10-drie12,
    ``A(x) xdot = I^-1 (pi' - xi)``, ``dpi'_mu/dt = Omega^a pi'_k f^k_{a mu}``, integrated here
    independently by ``mpmath.odefun`` (Taylor series) at ``dps`` digits, with ``pi = pi' - xi``.

    Error model: the reference flow is returned in float64 (correctly rounded from 20 digits)
    and the Taylor integration is good to ``dps - 2`` digits: tolerance ``4 eps max(1, |state|)``.
    ``shift`` (default ``xi``) is the xi used in the Darboux system: a different one is the
    negative control. Raises ``ModuleNotFoundError`` when :mod:`refimpl.flows` is absent.
    """

    raw = np.asarray(_f_raw(f))
    n = raw.shape[0]
    fe = _f_exact(f)
    theta = np.array(
        [
            [
                -sum((_exact(xi[m]) * fe[m, a, b] for m in range(n)), sympy.Integer(0))
                for b in range(n)
            ]
            for a in range(n)
        ],
        dtype=object,
    )
    I = np.asarray(inertia, dtype=float)
    xr, pr = reference_flow(
        np.array(raw, dtype=float),
        np.array(theta, dtype=float),
        np.zeros((n, n)),
        I,
        None,
        np.asarray(x0, dtype=float),
        np.asarray(pi0, dtype=float),
        float(t),
        dps=20,
    )
    with mpmath.workdps(dps):
        F = _F_mp(f)
        Iinv = mpmath.inverse(mpmath.matrix(I.tolist()))
        xim = [_mpf(v) for v in (xi if shift is None else shift)]

        def rhs(_, y):
            x, pp = y[:n], y[n:]
            Om = Iinv * mpmath.matrix([pp[i] - xim[i] for i in range(n)])
            xd = mpmath.lu_solve(frame_A(F, x), Om)
            pd = [
                mpmath.fsum(Om[a] * pp[k] * F[k][a, m] for a in range(n) for k in range(n))
                for m in range(n)
            ]
            return [xd[i] for i in range(n)] + pd

        y0 = [_mpf(v) for v in x0] + [_mpf(p) + s for p, s in zip(pi0, xim)]
        yT = mpmath.odefun(rhs, 0, y0)(_mpf(t))
        ours = [yT[i] for i in range(n)] + [yT[n + i] - xim[i] for i in range(n)]
        theirs = list(xr) + list(pr)
        diffs = [abs(a - _mpf(b)) for a, b in zip(ours, theirs)]
        k = int(np.argmax([float(d) for d in diffs]))
        scale = max([mpmath.mpf(1)] + [abs(v) for v in ours])
        tol = 4 * EPS * scale
        return Measurement(
            diffs[k], tol, _digits(diffs[k], scale), f"{'x' if k < n else 'pi'}[{k % n}]"
        )
