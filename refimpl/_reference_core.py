"""Core of the mpmath reference (frames, S, Phi, Psi, the Poisson tensor by two routes, the vector
field); the mathematics is stated in :mod:`refimpl.reference`, the public face."""

from __future__ import annotations

from contextlib import contextmanager
from fractions import Fraction
from typing import Any, Callable

import mpmath
import numpy as np
import sympy

from ._algebra import LieAlgebra
from ._errors import ChartError, DegeneratePointError
from ._phi import phi1_mp, phi1_mp_vanloan
from ._validate import (
    MAX_DPS,
    TWO_PI,
    BudgetError,
    ad_chart_radius,
    check_dimension,
    check_finite_result,
    check_inertia,
    check_potential,
    check_precision_digits,
    check_structure_constants,
    check_theta,
    check_upsilon,
    degenerate_relative,
    parse_number,
)
from ._validate import MAX_MAGNITUDE as _MAX_MAGNITUDE_FLOAT
from ._version import __version__

__all__ = [
    "ReferenceCore",
    "DegeneratePointError",
    "ChartError",
    "GUARD_DIGITS",
    "MAX_DPS",
    "MAX_AD_NORM",
    "MAX_MAGNITUDE",
]

GUARD_DIGITS = 12
# the precision cap (5000 digits: a 6 x 6 inverse there costs about a second; the escalation ladder
# stops at 400 by default) and the magnitude boundary are stated once, in refimpl._validate
MAX_AD_NORM = 400.0
"""Work budget of the frames: ``||ad_x||_1 <= 400``. Summing ``phi1(-ad_x)`` costs ``~e ||ad_x||``
terms at ``||ad_x|| / ln 10`` extra digits (the cancellation of ``e^||ad_x||``); on algebras whose
``ad_x`` has real eigenvalues the chart alone does not bound ``x``."""
MAX_MAGNITUDE = mpmath.mpf(_MAX_MAGNITUDE_FLOAT)
"""Inputs are real numbers of magnitude at most 1e300 (:data:`refimpl._validate.MAX_MAGNITUDE`)."""


def _as_float(v: Any, name: str) -> np.ndarray:
    """Any accepted input (float, exact numbers, strings) as float64, for the float-side validation."""
    arr = np.asarray(v, dtype=object)
    try:
        with mpmath.workdps(30):
            return np.array([float(_to_mpf(e)) for e in arr.flat], dtype=float).reshape(arr.shape)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: {exc}") from None


def _is_exact_scalar(v: Any) -> bool:
    return isinstance(
        v, (int, np.integer, Fraction, str, sympy.Basic, mpmath.mpf)
    ) and not isinstance(v, bool)


def _to_mpf(v: Any) -> mpmath.mpf:
    """A finite real number of magnitude below :data:`MAX_MAGNITUDE` as an mpf; strings are parsed by
    :func:`refimpl._validate.parse_number` only (never evaluated)."""
    out = _to_mpf_raw(v)
    if not mpmath.isfinite(out):
        raise ValueError(f"non-finite number {v!r}")
    if abs(out) > MAX_MAGNITUDE:
        raise ValueError(f"number {v!r:.40} has magnitude beyond {mpmath.nstr(MAX_MAGNITUDE, 3)}")
    return out


def _to_mpf_raw(v: Any) -> mpmath.mpf:
    if isinstance(v, (bool, np.bool_)):
        raise TypeError("booleans are not numbers here")
    if isinstance(v, mpmath.mpf):
        return +v
    if isinstance(v, (int, np.integer)):
        return mpmath.mpf(int(v))
    if isinstance(v, Fraction):
        return mpmath.mpf(v.numerator) / v.denominator
    if isinstance(v, str):
        q = parse_number(v, "number")  # the one parser: never evaluated
        return mpmath.mpf(q.numerator) / q.denominator
    if isinstance(v, sympy.Basic):
        if not v.is_real:
            raise ValueError(f"{v} is not a real number")
        return mpmath.mpf(sympy.N(v, mpmath.mp.dps + 5)._to_mpmath(mpmath.mp.prec + 16))
    if isinstance(v, (float, np.floating)):
        if not np.isfinite(v):
            raise ValueError(f"non-finite number {v!r}")
        return mpmath.mpf(float(v))
    raise TypeError(f"cannot use {type(v).__name__} {v!r} as a real number")


class ReferenceCore:
    """The reference implementation (protocol methods ``poisson_tensor``, ``hamiltonian_vector_field``).

    ``Reference(dps=50)`` works at ``dps`` significant digits (plus guard
    digits internally). Inputs may be float64 arrays, or exact numbers (int,
    ``Fraction``, decimal strings, mpmath or sympy numbers) in nested lists
    or object arrays, or a :class:`LieAlgebra` for ``f``. Protocol methods
    return float64 when every input is float64 and object arrays of mpmath
    numbers otherwise; the ``*_mp`` methods always return mpmath matrices.
    """

    name = "tstarg-reference"
    version = __version__  # the package's (pyproject.toml)
    batched = False

    def __init__(self, dps: int = 50):
        self.dps = check_precision_digits(dps)  # the boundary's precision cap

    def __repr__(self) -> str:
        return f"Reference(dps={self.dps})"

    @contextmanager
    def _prec(self):
        with mpmath.workdps(self.dps + GUARD_DIGITS):
            yield

    # -------------------------------------------------------------- inputs
    def _algebra_mp(self, f: Any) -> list[mpmath.matrix]:
        """Structure constants as ``n`` mpmath matrices ``F[m][a, b] = f^m_ab`` (validated)."""
        if isinstance(f, LieAlgebra):
            arr = f.f_exact if f.is_exact else f.f
            check_structure_constants(f.f)
        else:
            arr = np.asarray(f, dtype=object)
            check_structure_constants(_as_float(arr, "structure constants f"))
        n = arr.shape[0]
        return [
            mpmath.matrix([[_to_mpf(arr[m, a, b]) for b in range(n)] for a in range(n)])
            for m in range(n)
        ]

    @staticmethod
    def _vec(v: Any, n: int, name: str) -> mpmath.matrix:
        arr = np.asarray(v, dtype=object)
        if arr.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},), got {arr.shape}")
        try:
            return mpmath.matrix([_to_mpf(e) for e in arr])
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}: {exc}") from None

    @staticmethod
    def _mat(v: Any, n: int, name: str) -> mpmath.matrix:
        arr = np.asarray(v, dtype=object)
        if arr.shape != (n, n):
            raise ValueError(f"{name} must have shape ({n}, {n}), got {arr.shape}")
        try:
            return mpmath.matrix([[_to_mpf(arr[i, j]) for j in range(n)] for i in range(n)])
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}: {exc}") from None

    def _model(self, f, theta, upsilon):
        """Validate (in float64, with error models) and convert to mpmath."""
        shape = np.shape(f.f if isinstance(f, LieAlgebra) else f)
        if len(shape) == 3 and shape[0] == shape[1] == shape[2]:
            check_dimension(shape[0])  # the budget before n^3 conversions to mpf
        ff = f.f if isinstance(f, LieAlgebra) else _as_float(f, "structure constants f")
        ff = check_structure_constants(ff)
        n = ff.shape[0]
        check_theta(_as_float(theta, "theta"), ff)
        check_upsilon(_as_float(upsilon, "upsilon"), n)
        F = self._algebra_mp(f)
        th = self._mat(theta, n, "theta")
        up = self._mat(upsilon, n, "upsilon")
        for m_, nm in ((th, "theta"), (up, "upsilon")):
            if mpmath.mnorm(m_ + m_.T, 1) != 0:
                raise ValueError(f"{nm} is not antisymmetric at working precision")
        return F, th, up

    # --------------------------------------------------------- the algebra
    @staticmethod
    def ad(F: list, x: mpmath.matrix) -> mpmath.matrix:
        """``ad_x[m, b] = x^a f^m_ab``."""
        n = len(F)
        return mpmath.matrix(
            [[mpmath.fsum(x[a] * F[m][a, b] for a in range(n)) for b in range(n)] for m in range(n)]
        )

    @staticmethod
    def S(F: list, theta: mpmath.matrix, pi: mpmath.matrix) -> mpmath.matrix:
        """``S_ab = pi_m f^m_ab - Theta_ab`` (vier3)."""
        n = len(F)
        return mpmath.matrix(
            [
                [mpmath.fsum(pi[m] * F[m][a, b] for m in range(n)) - theta[a, b] for b in range(n)]
                for a in range(n)
            ]
        )

    # -------------------------------------------------------------- frames
    def frames_mp(self, F: list, x: mpmath.matrix, route: str = "series") -> dict:
        """``A = L(g^-1, g) = phi1(-ad_x)``, ``L = L(g, e) = A^-1``, ``Ad = exp(ad_x)``, ``K = Ad^-T``.

        ``route="series"`` sums the Taylor series; ``route="vanloan"`` uses
        the block exponential. Raises ``ValueError`` outside the chart (``A``
        singular: an eigenvalue of ``ad_x`` at ``2 pi i k``, ``k != 0``).
        """
        adx = self.ad(F, x)
        self._check_chart(adx, x)
        norm = mpmath.mnorm(adx, 1)
        extra = int(mpmath.ceil(norm / mpmath.log(10))) + 5  # cancellation in the series ~ e^||ad||
        with mpmath.extradps(extra):
            if route == "series":
                A = phi1_mp(-adx)
            elif route == "vanloan":
                A = phi1_mp_vanloan(-adx)
            else:
                raise ValueError(f"unknown frame route {route!r} (series or vanloan)")
            det = mpmath.det(A)
            if abs(det) <= mpmath.mpf(10) ** (-(self.dps // 2)):
                raise ChartError(
                    f"x = {[mpmath.nstr(v, 8) for v in x]} is outside the chart of exponential coordinates: "
                    f"det phi1(-ad_x) = {mpmath.nstr(det, 5)} (an eigenvalue of ad_x is near 2 pi i k)"
                )
            try:
                L = mpmath.inverse(A)
                Ad = mpmath.expm(adx)
                K = mpmath.inverse(Ad).T
            except ZeroDivisionError:  # mpmath's LU: a pivot below ||.|| eps at this precision
                raise ValueError(
                    f"x = {[mpmath.nstr(v, 8) for v in x]}: the frame phi1(-ad_x) or Ad = exp(ad_x) is "
                    f"numerically singular at {self.dps} digits (||ad_x||_1 = {mpmath.nstr(norm, 5)}: "
                    f"real eigenvalues of ad_x spread the frame over e^||ad_x||); the point is beyond "
                    f"the reference's working range at this precision (raise dps or bring x closer to 0)"
                ) from None
        return {"A": A, "L": L, "Ad": Ad, "K": K, "ad": adx}

    @staticmethod
    def _check_chart(adx: mpmath.matrix, x) -> None:
        """Before any series or extra digits: refuse ``x`` clearly outside the chart (``max |Im
        eigenvalue of ad_x| > 2 pi``, :func:`refimpl._validate.chart_radius`) with
        :class:`ChartError`, and ``||ad_x||_1 > MAX_AD_NORM`` (the work budget). Points within
        float64 rounding of the edge are left to the determinant test of :meth:`frames_mp`."""
        n = adx.rows
        xs = [mpmath.nstr(v, 8) for v in x]
        norm = mpmath.mnorm(adx, 1)
        with np.errstate(all="ignore"):
            A = np.array([[float(adx[i, j]) for j in range(n)] for i in range(n)], dtype=float)
        rho, err = ad_chart_radius(A[None])
        with np.errstate(all="ignore"):
            outside = not rho[0] - err[0] <= TWO_PI
        if outside:
            raise ChartError(
                f"x = {xs} is outside the chart of exponential coordinates: max |Im eigenvalue of ad_x| = "
                f"{float(rho[0]):.6g} > 2 pi (the frame phi1(-ad_x) of twee1 is singular at 2 pi; su(2): |x| < 2 pi)"
            )
        if norm > MAX_AD_NORM:
            raise ValueError(
                f"x = {xs}: ||ad_x||_1 = {mpmath.nstr(norm, 5)} exceeds the reference's work budget "
                f"{MAX_AD_NORM:g} (the frame series needs ~||ad_x||/ln 10 extra digits)"
            )

    # -------------------------------------------------- Phi, Psi, Delta
    def phi_psi_delta(self, F, theta, upsilon, pi) -> dict:
        """``S``, ``Phi = 1 + S U``, ``Psi = 1 + U S``, ``Delta = det Phi`` (vier6, vier7)."""
        n = len(F)
        S = self.S(F, theta, pi)
        Phi = mpmath.eye(n) + S * upsilon
        Psi = mpmath.eye(n) + upsilon * S
        try:
            delta = mpmath.det(Phi)
        except (
            TypeError
        ):  # mpmath 1.3 (#542): its LU meets an exactly zero pivot column, Phi is singular
            delta = mpmath.mpf(0)
        return {"S": S, "Phi": Phi, "Psi": Psi, "Delta": delta}

    def _check_nondegenerate(self, Phi: mpmath.matrix, Delta, pi) -> None:
        """Degenerate means Delta is zero to working precision: below the rounding noise
        ``n eps_work ||Phi||^n`` of a determinant computed with ``dps + GUARD_DIGITS`` digits."""
        n = Phi.rows
        scale = max(mpmath.mpf(1), mpmath.mnorm(Phi, 1)) ** n
        if degenerate_relative(
            abs(Delta), max(mpmath.mpf(1), mpmath.mnorm(Phi, 1)), n, mpmath.eps
        ):  # relative to ||Phi||^n (Hadamard), not absolute
            what = (
                f"Delta = det Phi is zero to working precision relative to the scale of Phi: "
                f"|Delta| = {mpmath.nstr(abs(Delta), 5)} <= 16 n eps ||Phi||_1^n = "
                f"{mpmath.nstr(16 * n * mpmath.eps * scale, 3)} at {mpmath.mp.dps} working digits"
                + (" (mpmath's LU met a pivot below ||Phi|| eps)" if Delta == 0 else "")
            )
            raise DegeneratePointError(
                f"point with pi = {[mpmath.nstr(v, 10) for v in pi]} is on the degenerate set Pi_1 "
                f"(vier12) to working precision: {what}; omega_L has no inverse there"
            )

    def _phi_decided(self, F, theta, upsilon, pi) -> tuple[dict, int]:
        """``(phi_psi_delta at d digits, d)``: the working digits ``d`` at which Delta is decided
        nonzero *and* inverting Phi still keeps the current digits.

        Whether Delta is zero is judged relative to the scale of Phi (Hadamard: ``|Delta| <=
        ||Phi||^n``), never absolutely, and never from one precision alone: while ``|Delta| <=
        16 n eps ||Phi||_1^n`` the digits are doubled up to the cap ``MAX_DPS + GUARD_DIGITS``
        (Phi ~ 1e66 with Delta ~ 1e198 is far from singular). Once decided, the inverse of Phi loses
        at most ``log10(||Phi||_1^n / |Delta|)`` digits (that ratio bounds ``cond(Phi)`` from above),
        so ``d`` adds them. A point still undecided at the cap is degenerate to that precision
        (:class:`DegeneratePointError`); one decided but needing more than the cap is a
        :class:`refimpl._validate.BudgetError`. Float and integer inputs are exact at every ``d``;
        rationals were rounded once at the instance's digits.
        """
        base = mpmath.mp.dps
        cap = MAX_DPS + GUARD_DIGITS
        d = base
        while True:
            with mpmath.workdps(d):
                q = self.phi_psi_delta(F, theta, upsilon, pi)
                n = q["Phi"].rows
                scale = max(mpmath.mpf(1), mpmath.mnorm(q["Phi"], 1)) ** n
                norm = max(mpmath.mpf(1), mpmath.mnorm(q["Phi"], 1))
                decided = not degenerate_relative(abs(q["Delta"]), norm, n, mpmath.eps)
                if decided:
                    lost = int(mpmath.ceil(mpmath.log10(scale / abs(q["Delta"]))))
                    need = base + max(lost, 0)
                    if need <= d:
                        return q, d
                    if need > cap:
                        raise BudgetError(
                            f"point with pi = {[mpmath.nstr(v, 10) for v in pi]}: Phi is so ill-conditioned "
                            f"(||Phi||_1^n / |Delta| = 10^{lost}) that inverting it needs {need} digits, "
                            f"over the precision cap {MAX_DPS}"
                        )
                    d = need
                    continue
            if d >= cap:
                with mpmath.workdps(d):
                    self._check_nondegenerate(
                        q["Phi"], q["Delta"], pi
                    )  # raises: degenerate at the cap
            d = min(2 * d, cap)

    # ------------------------------------------------------ Poisson tensor
    def body_tensor_mp(self, F, theta, upsilon, pi, route: str = "closed") -> mpmath.matrix:
        """``-W^-1``: the Poisson tensor in the body frame ``(eps_L, dpi)`` (vier9)."""
        q, d = self._phi_decided(F, theta, upsilon, pi)
        with mpmath.workdps(d):
            return self._body_tensor_at(F, theta, upsilon, pi, q, route)

    def _body_tensor_at(self, F, theta, upsilon, pi, q, route):
        n = len(F)
        if route == "closed":
            Phi_inv = mpmath.inverse(q["Phi"])
            Psi_inv = mpmath.inverse(q["Psi"])
            blocks = [[-upsilon * Phi_inv, Psi_inv], [-Phi_inv, -q["S"] * Psi_inv]]
            out = mpmath.zeros(2 * n, 2 * n)
            for bi in range(2):
                for bj in range(2):
                    for i in range(n):
                        for j in range(n):
                            out[bi * n + i, bj * n + j] = blocks[bi][bj][i, j]
            return out
        if route == "first_principles":
            return -mpmath.inverse(self.omega_body_mp(F, theta, upsilon, pi))
        raise ValueError(f"unknown route {route!r} (closed or first_principles)")

    def omega_body_mp(self, F, theta, upsilon, pi) -> mpmath.matrix:
        """``W = [[S, 1], [-1, Upsilon]]``: omega_L in the frame ``(eps_L, dpi)`` (vier3)."""
        n = len(F)
        S = self.S(F, theta, pi)
        W = mpmath.zeros(2 * n, 2 * n)
        for i in range(n):
            for j in range(n):
                W[i, j] = S[i, j]
                W[n + i, n + j] = upsilon[i, j]
            W[i, n + i] = 1
            W[n + i, i] = -1
        return W

    def omega_holonomic_mp(self, F, theta, upsilon, x, pi) -> mpmath.matrix:
        """omega_L on ``z = (x, pi)``: ``diag(A, 1)^T W diag(A, 1)``, A from the Van Loan route."""
        n = len(F)
        A = self.frames_mp(F, x, route="vanloan")["A"]
        T = mpmath.zeros(2 * n, 2 * n)
        for i in range(n):
            for j in range(n):
                T[i, j] = A[i, j]
            T[n + i, n + i] = 1
        return T.T * self.omega_body_mp(F, theta, upsilon, pi) * T

    def poisson_tensor_mp(
        self, f, theta, upsilon, x, pi, *, route: str = "closed", frame: str = "holonomic"
    ) -> mpmath.matrix:
        """``P[i, j] = {z_i, z_j}`` at working precision (mpmath matrix, ``2n x 2n``).

        ``frame="holonomic"``: ``z = (x, pi)``; ``frame="body"``: components on
        the frame ``(e^L_a, d/dpi_m)``, i.e. ``-W^-1``.
        """
        with self._prec():
            F, th, up = self._model(f, theta, upsilon)
            n = len(F)
            xv, pv = self._vec(x, n, "x"), self._vec(pi, n, "pi")
            if frame == "body":
                return self.body_tensor_mp(F, th, up, pv, route)
            if frame != "holonomic":
                raise ValueError(f"unknown frame {frame!r} (holonomic or body)")
            if route == "closed":
                L = self.frames_mp(F, xv, route="series")["L"]
                body = self.body_tensor_mp(F, th, up, pv, "closed")
                T = mpmath.zeros(2 * n, 2 * n)
                for i in range(n):
                    for j in range(n):
                        T[i, j] = L[i, j]
                    T[n + i, n + i] = 1
                return T * body * T.T
            if route == "first_principles":
                _q, d = self._phi_decided(F, th, up, pv)
                with mpmath.workdps(d):
                    return -mpmath.inverse(self.omega_holonomic_mp(F, th, up, xv, pv))
            raise ValueError(f"unknown route {route!r} (closed or first_principles)")

    # --------------------------------------------------------- the bracket
    def bracket_mp(self, A: Callable, B: Callable, f, theta, upsilon, x, pi) -> mpmath.mpf:
        """``{A, B}`` of two functions ``A(x, pi)``, ``B(x, pi)`` (mpmath vectors in, mpf out).

        Generalises twee8 and drie2 to Upsilon != 0:
        ``{A,B} = a^T(-U Phi^-1)b + a^T Psi^-1 B_pi - A_pi^T Phi^-1 b - A_pi^T S Psi^-1 B_pi``
        with ``a_c = <dA|e^L_c> = (L^T dA/dx)_c``. Gradients by ``mpmath.diff``.
        """
        with self._prec():
            F, th, up = self._model(f, theta, upsilon)
            n = len(F)
            xv, pv = self._vec(x, n, "x"), self._vec(pi, n, "pi")
            L = self.frames_mp(F, xv)["L"]
            q, d = self._phi_decided(F, th, up, pv)
            with mpmath.workdps(d):
                Phi_inv, Psi_inv = mpmath.inverse(q["Phi"]), mpmath.inverse(q["Psi"])

            def grad(fun):
                z0 = list(xv) + list(pv)

                def g(*z):
                    return fun(mpmath.matrix(z[:n]), mpmath.matrix(z[n:]))

                parts = [
                    mpmath.diff(g, z0, tuple(1 if k == i else 0 for k in range(2 * n)))
                    for i in range(2 * n)
                ]
                return mpmath.matrix(parts[:n]), mpmath.matrix(parts[n:])

            ax, ap = grad(A)
            bx, bp = grad(B)
            a, b = L.T * ax, L.T * bx
            val = (
                a.T * (-up * Phi_inv) * b
                + a.T * Psi_inv * bp
                - ap.T * Phi_inv * b
                - ap.T * q["S"] * Psi_inv * bp
            )[0]
            return +val

    # ---------------------------------------------------- vector fields
    def _hamiltonian(self, F, inertia, potential):
        n = len(F)
        I_mp = self._mat(inertia, n, "inertia")
        Iinv = mpmath.inverse(I_mp)
        if potential is None:
            return Iinv, None
        return Iinv, (
            self._vec(potential["L"], n, "potential['L']"),
            self._vec(potential["gamma"], n, "potential['gamma']"),
        )

    def gravity_frame_gradient(self, F, Ad, Lvec, gamma) -> mpmath.matrix:
        """``<dV|e^L_b> = -Gamma_m f^m_bc L^c`` with ``Gamma = K(g^-1) gamma = Ad(g)^T gamma`` (twee16)."""
        n = len(F)
        Gamma = Ad.T * gamma
        return mpmath.matrix(
            [
                -mpmath.fsum(Gamma[m] * F[m][b, c] * Lvec[c] for m in range(n) for c in range(n))
                for b in range(n)
            ]
        )

    def hamiltonian_vector_field_mp(
        self, f, theta, upsilon, inertia, potential, x, pi, *, route: str = "closed"
    ):
        """``(xdot, pidot)`` for ``H = 1/2 pi.I^-1 pi + V`` (vier10, vier11); mpmath vectors."""
        with self._prec():
            F, th, up = self._model(f, theta, upsilon)
            n = len(F)
            check_inertia(_as_float(inertia, "inertia"), n)
            if potential is not None and not isinstance(potential, dict):
                check_potential(potential, n)  # raises, naming the input
            pot = check_potential(
                None
                if potential is None
                else {
                    k: (_as_float(v, f"potential[{k!r}]") if k != "kind" else v)
                    for k, v in potential.items()
                },
                n,
            )
            if pot is not None:
                pot = {"kind": "gravity", "L": potential["L"], "gamma": potential["gamma"]}
            xv, pv = self._vec(x, n, "x"), self._vec(pi, n, "pi")
            Iinv, grav = self._hamiltonian(F, inertia, pot)
            dK = Iinv * pv
            if route == "closed":
                fr = self.frames_mp(F, xv)
                q, d = self._phi_decided(F, th, up, pv)
                dV = (
                    mpmath.zeros(n, 1)
                    if grav is None
                    else self.gravity_frame_gradient(F, fr["Ad"], *grav)
                )
                # Row-vector forms of vier10 / vier11, written as columns:
                # Omega = Psi^-1 (dK - U dV), pidot = Phi^-1 (-dV - S dK).
                with mpmath.workdps(d):  # the digits at which Phi is decided and inverted
                    Omega = mpmath.lu_solve(q["Psi"], dK - up * dV)
                    pidot = mpmath.lu_solve(q["Phi"], -dV - q["S"] * dK)
                xdot = fr["L"] * Omega
                return xdot, pidot
            if route == "first_principles":
                P = self.poisson_tensor_mp(f, theta, upsilon, x, pi, route="first_principles")
                if grav is None:
                    dVdx = mpmath.zeros(n, 1)
                else:
                    Lvec, gamma = grav

                    def V(*xs):
                        Ad = mpmath.expm(self.ad(F, mpmath.matrix(xs)))
                        return -(gamma.T * Ad * Lvec)[0]

                    dVdx = mpmath.matrix(
                        [
                            mpmath.diff(V, list(xv), tuple(1 if k == i else 0 for k in range(n)))
                            for i in range(n)
                        ]
                    )
                grad = mpmath.matrix(list(dVdx) + list(dK))
                zdot = P * grad
                return mpmath.matrix(list(zdot)[:n]), mpmath.matrix(list(zdot)[n:])
            raise ValueError(f"unknown route {route!r} (closed or first_principles)")

    # ------------------------------------------------------ the protocol
    @staticmethod
    def _wants_exact(*values) -> bool:
        for v in values:
            if v is None:
                continue
            if isinstance(v, LieAlgebra):
                return True
            if isinstance(v, dict):
                if ReferenceCore._wants_exact(*[v.get(k) for k in ("L", "gamma")]):
                    return True
                continue
            arr = np.asarray(v, dtype=object)
            if any(_is_exact_scalar(e) for e in arr.flat):
                return True
        return False

    @staticmethod
    def _out(m: mpmath.matrix, shape, exact: bool):
        vals = (
            [m[i] for i in range(len(m))]
            if m.cols == 1
            else [m[i, j] for i in range(m.rows) for j in range(m.cols)]
        )
        arr = np.array(vals, dtype=object).reshape(shape)
        if exact:
            return arr
        out = np.array([float(v) for v in arr.flat]).reshape(shape)
        check_finite_result("reference", {"the float64 result": out})  # the boundary: no silent inf
        return out

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        """Protocol method 1: ``P`` of shape ``(2n, 2n)`` in holonomic coordinates (closed route)."""
        exact = self._wants_exact(f, theta, upsilon, x, pi)
        P = self.poisson_tensor_mp(f, theta, upsilon, x, pi, route="closed")
        return self._out(P, (P.rows, P.cols), exact)

    def hamiltonian_vector_field(self, f, theta, upsilon, inertia, potential, x, pi):
        """Protocol method 2: ``(xdot, pidot)``, each of shape ``(n,)`` (closed route)."""
        exact = self._wants_exact(f, theta, upsilon, inertia, potential, x, pi)
        xd, pd = self.hamiltonian_vector_field_mp(f, theta, upsilon, inertia, potential, x, pi)
        return self._out(xd, (xd.rows,), exact), self._out(pd, (pd.rows,), exact)
