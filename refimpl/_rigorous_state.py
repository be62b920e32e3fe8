"""Rigorous enclosures of the whole state of a flow: ``pi``, ``Gamma``, ``rho(g)``, ``Ad(g)`` and ``x``.

With ``Upsilon = 0`` the body system is polynomial (:mod:`refimpl._rigorous_flow`) and so is the
reconstruction of the configuration through a faithful representation ``rho``
(:func:`refimpl._representation.representation_for`, with *exact* matrices, complex ones split into real
and imaginary parts): ``d/dt rho(g) = rho(g) rho(Omega)``, ``Omega = I^-1 pi`` (twee9/twee12 with
``Phi = 1``), i.e. ``G_r' = G_r R(Omega) - G_i J(Omega)``, ``G_i' = G_r J(Omega) + G_i R(Omega)`` with
``rho(e_b) = R_b + i J_b``, quadratic in ``(pi, G)``; likewise ``Ad(g)' = Ad(g) ad_Omega``. These rows are
appended to the body field and the whole state is carried by the same Lohner method (QR wrapping
control), from ``rho(g(0)) = exp(rho(x0))`` and ``Ad(g(0)) = exp(ad_x0)`` (Arb's rigorous matrix
exponential; a complex ``rho`` through the real embedding ``[[R, -J], [J, R]]``). ``g`` needs no chart, so
no re-basing is needed: the group element is carried as a matrix in balls.

``x`` (exponential coordinates, ``g = exp(x)``) is recovered rigorously by a chain of Krawczyk tests along
the steps. With ``F(x) = P vec(exp(rho(x)) - G)`` (``n`` of the real equations, chosen by a pivoted QR of
the float Jacobian) and ``D exp(rho(x)) = exp(rho(x)) rho(phi1(-ad_x) dx)`` (twee1),
``K(X) = xh - C F(xh) + (1 - C DF(X)) (X - xh)``: ``K(X)`` strictly inside ``X`` proves that for every
``G`` in the ball the equations have exactly one root in ``X``, and that it lies in ``K(X)``. For each
step ``[t0, t0 + h]`` the test is run with ``G`` ranging over the step's a-priori enclosure, on a box ``X``
containing the previous ``K``; ``phi1(-ad_X)`` is also proven invertible (``X`` is inside the chart).
Continuity then identifies the root with the flow's ``x(t)`` on the whole step: the set of ``t`` where
``x(t)`` equals the root is closed, open (the root lies in the interior ``K`` and ``x`` is continuous), and
contains ``t0`` (``x(t0)`` is in the previous ``K``, which ``X`` contains). A final test at ``G(T)`` gives
the tight box. Where a test fails (the logarithm is not unique or not isolated on a box of the step's
width, or ``x`` reaches the chart's edge) ``x`` is not given, and ``x_note`` says why by name.

``Upsilon != 0``: the body system is rational; :class:`refimpl._rigorous_rational.RationalField` carries
the same state by the ball Taylor recurrence of the solve by ``Phi`` (and its derivative for the wrapping),
whose ball inverse of ``Phi`` over each step's a-priori enclosure proves ``Delta = det Phi != 0`` along the
step; a start on (or within rounding of) the degenerate set, or a step that cannot be proven so, is refused
with :class:`DegeneratePointError`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import sympy
from flint import acb, acb_mat, arb, arb_mat

from ._arb import Balls, algebra_balls, exact_source, to_arb, upper, workprec
from ._errors import DegeneratePointError
from ._phi import expm
from ._representation import RepresentationError, representation_for
from ._rigorous_core import MAX_PREC_BITS, check_frames_budget, check_magnitudes, phi1_ball
from ._rigorous_core import fview as _fview
from ._rigorous_core import point_view as _point_view
from ._rigorous_flow import BallField, body_field, enclose_quadratic
from ._rigorous_rational import RationalField
from ._validate import (
    MAX_FLOW_TIME,
    check_inertia,
    check_potential,
    check_structure_constants,
    check_theta,
    check_upsilon,
)

__all__ = ["StateEnclosure", "full_state_enclosure"]


@dataclass
class StateEnclosure:
    """Balls containing the exact state at ``t`` (module docstring).

    ``pi``; ``Gamma`` (gravity only, ``Ad(g)^T gamma``); ``rho_g``, ``rho_g_imag`` (real and imaginary
    parts of ``rho(g)``, the latter None for a real representation); ``Ad_g`` (with ``want_ad``); ``x``
    (None, with the reason in ``x_note``, where it is not recovered); ``jacobian``: with ``jacobian=True``
    the ball matrix of ``d y(t) / d y(0)`` for the carried state ``y = (pi, Gamma, G_r, G_i, Ad)``
    (the order of ``layout``).
    """

    t: float
    pi: Balls
    Gamma: Balls | None
    rho_g: Balls
    rho_g_imag: Balls | None
    Ad_g: Balls | None
    x: Balls | None
    x_note: str
    steps: int
    rejected: int
    prec_bits: int
    seconds: float
    layout: dict = field(default_factory=dict)
    jacobian: Balls | None = None
    method: str = "Arb balls"

    def max_rad(self) -> float:
        parts = [self.pi, self.Gamma, self.rho_g, self.rho_g_imag, self.Ad_g, self.x]
        return max(p.max_rad() for p in parts if p is not None)


# ------------------------------------------------------------------ the representation in balls
def _rep_balls(rep) -> tuple[list, list | None]:
    """``(R_b, J_b)``: real and imaginary parts of ``rho(e_b)`` as ball matrices (J None when real)."""
    if rep.exact is None:
        raise RepresentationError(
            "the configuration needs a representation with exact matrices; this algebra's faithful "
            "representation is known in float64 only (irrational structure constants outside the catalogue)"
        )
    ex = rep.exact
    n, m = ex.shape[0], rep.dim
    R, J, cplx = [], [], False
    for b in range(n):
        rr, ii = [], []
        for i in range(m):
            for j in range(m):
                e = (
                    sympy.sympify(ex[b][i][j])
                    if not isinstance(ex[b][i][j], sympy.Basic)
                    else ex[b][i][j]
                )
                re, im = sympy.re(e), sympy.im(e)
                rr.append(to_arb(re, "representation"))
                ii.append(to_arb(im, "representation"))
                cplx = cplx or not im.is_zero
        R.append(arb_mat(m, m, rr))
        J.append(arb_mat(m, m, ii))
    return R, (J if cplx else None)


def _embed(Rm: arb_mat, Jm: arb_mat | None) -> arb_mat:
    """The real embedding ``[[R, -J], [J, R]]`` of ``R + i J`` (``R`` itself when ``J`` is None)."""
    if Jm is None:
        return Rm
    m = Rm.nrows()
    out = arb_mat(2 * m, 2 * m)
    for i in range(m):
        for j in range(m):
            out[i, j] = Rm[i, j]
            out[m + i, m + j] = Rm[i, j]
            out[i, m + j] = -Jm[i, j]
            out[m + i, j] = Jm[i, j]
    return out


def _comb(mats: list, w) -> arb_mat:
    out = mats[0] * w[0]
    for b in range(1, len(mats)):
        out += mats[b] * w[b]
    return out


# ------------------------------------------------------------------ the field of the whole state
def _state_field(body: BallField, n: int, Ii, R, J, Fad3, want_ad: bool) -> tuple:
    """The body field with the rows of ``G_r, G_i`` (and ``Ad``) appended; returns ``(field, layout)``."""
    m = R[0].nrows()
    d0 = body.d
    offs = {"G_r": d0}
    d = d0 + m * m
    if J is not None:
        offs["G_i"] = d
        d += m * m
    if want_ad:
        offs["Ad"] = d
        d += n * n
    const = dict(body.const)
    lin = {i: {} for i in range(d)}
    quad = {i: {} for i in range(d)}
    for i, row in body.lin.items():
        for j, v in row:
            lin[i][j] = v
    for i, row in body.quad.items():
        for j, k, v in row:
            quad[i][(j, k)] = v

    def add(i, key, v):
        if not v.is_zero():
            quad[i][key] = quad[i].get(key, arb(0)) + v

    # M_l = sum_b Iinv[b, l] rho(e_b): Omega^b = Iinv[b, l] pi_l
    MR = [_comb(R, [Ii[b, ll] for b in range(n)]) for ll in range(n)]
    MJ = [_comb(J, [Ii[b, ll] for b in range(n)]) for ll in range(n)] if J is not None else None
    gr = offs["G_r"]
    gi = offs.get("G_i")
    for i in range(m):
        for j in range(m):
            for k in range(m):
                for ll in range(n):
                    # G_r'[i, j] += G_r[i, k] MR_l[k, j] pi_l - G_i[i, k] MJ_l[k, j] pi_l
                    add(gr + i * m + j, (gr + i * m + k, ll), MR[ll][k, j])
                    if J is not None:
                        add(gr + i * m + j, (gi + i * m + k, ll), -MJ[ll][k, j])
                        # G_i'[i, j] += G_r[i, k] MJ_l[k, j] pi_l + G_i[i, k] MR_l[k, j] pi_l
                        add(gi + i * m + j, (gr + i * m + k, ll), MJ[ll][k, j])
                        add(gi + i * m + j, (gi + i * m + k, ll), MR[ll][k, j])
    if want_ad:
        ad0 = offs["Ad"]
        # ad_Omega[k, j] = Omega^a f[k, a, j] = sum_l (sum_a Iinv[a, l] f[k, a, j]) pi_l
        for ll in range(n):
            Al = [
                [sum((Ii[a, ll] * Fad3[k][a][j] for a in range(n)), arb(0)) for j in range(n)]
                for k in range(n)
            ]
            for i in range(n):
                for j in range(n):
                    for k in range(n):
                        add(ad0 + i * n + j, (ad0 + i * n + k, ll), Al[k][j])
    return BallField(d, const, lin, quad), offs, m


def _reversed(F: BallField) -> BallField:
    """The field ``-F`` (every coefficient negated, exactly): its flow at ``s`` is ``F``'s at ``-s``."""
    return BallField(
        F.d,
        {i: -v for i, v in F.const.items()},
        {i: {j: -a for j, a in row} for i, row in F.lin.items()},
        {i: {(j, k): -q for j, k, q in row} for i, row in F.quad.items()},
    )


# ------------------------------------------------------------------ x by Krawczyk
class _Log:
    """The Krawczyk test for ``exp(rho(x)) = G`` (module docstring)."""

    def __init__(self, Fad, n, R, J, sel_from: np.ndarray):
        self.Fad, self.n, self.R, self.J = Fad, n, R, J
        self.m = R[0].nrows()
        self.Rf = np.array([[[float(e.mid()) for e in row] for row in M.tolist()] for M in R])
        self.Jf = (
            np.array([[[float(e.mid()) for e in row] for row in M.tolist()] for M in J])
            if J is not None
            else None
        )
        self.sel = None
        self._choose(sel_from)

    def _rho_f(self, x):
        M = np.einsum("b,bij->ij", x, self.Rf).astype(complex)
        if self.Jf is not None:
            M = M + 1j * np.einsum("b,bij->ij", x, self.Jf)
        return M

    def _jac_f(self, x) -> np.ndarray:
        """Float Jacobian (2 m^2 x n) of vec(Re, Im) exp(rho(x)), by the van Loan block exponential."""
        n, m = self.n, self.m
        Mx = self._rho_f(x)
        cols = []
        for a in range(n):
            Ea = self._rho_f(np.eye(n)[a])
            big = np.block([[Mx, Ea], [np.zeros_like(Mx), Mx]])
            D = expm(big)[:m, m:]
            cols.append(np.concatenate([D.real.ravel(), D.imag.ravel()]))
        return np.array(cols).T

    def _choose(self, x):
        Jf = self._jac_f(np.asarray(x, dtype=float))
        _, _, piv = scipy.linalg.qr(Jf.T, pivoting=True)
        self.sel = sorted(int(i) for i in piv[: self.n])

    def _exp(self, x: arb_mat) -> tuple:
        Rm = _comb(self.R, [x[b, 0] for b in range(self.n)])
        Jm = _comb(self.J, [x[b, 0] for b in range(self.n)]) if self.J is not None else None
        E = _embed(Rm, Jm).exp()
        m = self.m
        Er = arb_mat([[E[i, j] for j in range(m)] for i in range(m)])
        Ei = (
            arb_mat([[E[m + i, j] for j in range(m)] for i in range(m)]) if Jm is not None else None
        )
        return Er, Ei

    def _vec(self, Mr, Mi) -> list:
        m = self.m
        full = [Mr[i, j] for i in range(m) for j in range(m)]
        full += (
            [Mi[i, j] for i in range(m) for j in range(m)] if Mi is not None else [arb(0)] * (m * m)
        )
        return [full[k] for k in self.sel]

    def residual(self, x: arb_mat, Gr: arb_mat, Gi: arb_mat | None) -> arb_mat:
        Er, Ei = self._exp(x)
        Dr = Er - Gr
        Di = (Ei - Gi) if Ei is not None else None
        return arb_mat(self.n, 1, self._vec(Dr, Di))

    def jacobian(self, X: arb_mat, prec: int) -> arb_mat:

        n = self.n
        ad = arb_mat(n, n, (self.Fad * X).entries())
        A = phi1_ball(-ad, prec)
        Er, Ei = self._exp(X)
        cols = []
        for a in range(n):
            w = [A[b, a] for b in range(n)]
            Rw = _comb(self.R, w)
            if self.J is None:
                Dr, Di = Er * Rw, None
            else:
                Jw = _comb(self.J, w)
                Dr, Di = Er * Rw - Ei * Jw, Er * Jw + Ei * Rw
            cols.append(self._vec(Dr, Di))
        try:
            A.inv()
        except ZeroDivisionError:
            return None  # phi1(-ad_X) not provably invertible: X reaches the chart's edge
        return arb_mat([[cols[a][i] for a in range(n)] for i in range(n)])

    def krawczyk(self, X: arb_mat, Gr, Gi, prec: int):
        """``K(X)`` when it lies strictly inside ``X`` (a proof of one root per ``G`` in ``X``), else None."""
        n = self.n
        xh = arb_mat(n, 1, [X[i, 0].mid() for i in range(n)])
        DF = self.jacobian(X, prec)
        if DF is None:
            return None
        Cf = np.linalg.inv(np.array([[float(e.mid()) for e in row] for row in DF.tolist()]))
        if not np.all(np.isfinite(Cf)):
            return None
        C = arb_mat(Cf.tolist())
        I = arb_mat([[1 if i == j else 0 for j in range(n)] for i in range(n)])
        K = xh - C * self.residual(xh, Gr, Gi) + (I - C * DF) * (X - xh)
        if all(X[i, 0].contains_interior(K[i, 0]) for i in range(n)):
            return K
        self.last = K  # for the epsilon-inflation of the next try
        return None

    def newton_f(self, x: np.ndarray, Gr: np.ndarray, Gi: np.ndarray | None, iters=3) -> np.ndarray:
        """Float Newton steps toward the root near ``x`` (the centre of the next box)."""
        G = Gr.astype(complex) + (1j * Gi if Gi is not None else 0)
        for _ in range(iters):
            E = expm(self._rho_f(x)) - G
            res = np.concatenate([E.real.ravel(), E.imag.ravel()])[self.sel]
            Jf = self._jac_f(x)[self.sel]
            try:
                x = x - np.linalg.solve(Jf, res)
            except np.linalg.LinAlgError:
                break
        return x


def _box(center: np.ndarray, rad: np.ndarray) -> arb_mat:
    return arb_mat(len(center), 1, [arb(float(c), float(r)) for c, r in zip(center, rad)])


def _hull(a: arb_mat, b: arb_mat) -> arb_mat:
    return arb_mat(a.nrows(), 1, [a[i, 0].union(b[i, 0]) for i in range(a.nrows())])


def _inflate(X: arb_mat, rel: float, absolute: float) -> arb_mat:
    return arb_mat(
        X.nrows(),
        1,
        [X[i, 0] + arb(0, rel * upper(X[i, 0].rad()) + absolute) for i in range(X.nrows())],
    )


def _krawczyk_box(log: _Log, Kprev: arb_mat, Gr, Gi, prec: int, tries: int = 6):
    """A box ``K`` proven to hold the unique root for every ``G`` in ``(Gr, Gi)``, inside a box containing
    ``Kprev`` (so that it continues the chain), or None."""
    n = log.n
    cen = np.array([float(Kprev[i, 0].mid()) for i in range(n)])
    Grf = np.array([[float(e.mid()) for e in row] for row in Gr.tolist()])
    Gif = (
        np.array([[float(e.mid()) for e in row] for row in Gi.tolist()]) if Gi is not None else None
    )
    log._choose(
        cen
    )  # the best-conditioned n equations where x is now (any true logarithm solves all)
    new = log.newton_f(cen, Grf, Gif)
    if not np.all(np.isfinite(new)):
        return None
    # the linearised range of the root over the G balls: |C| rad(G_sel), C = (d F_sel / dx)^-1 (float)
    m = log.m
    rads = [upper(Gr[i, j].rad()) for i in range(m) for j in range(m)]
    rads += (
        [upper(Gi[i, j].rad()) for i in range(m) for j in range(m)]
        if Gi is not None
        else [0.0] * (m * m)
    )
    try:
        Cf = np.linalg.inv(log._jac_f(new)[log.sel])
    except np.linalg.LinAlgError:
        return None
    rx = 2.0 * np.abs(Cf) @ np.array([rads[k] for k in log.sel]) + 1e-30
    X = _hull(Kprev, _box(new, rx))
    X = _inflate(X, 0.1, 1e-30)
    for _ in range(tries):
        log.last = None
        K = log.krawczyk(X, Gr, Gi, prec)
        if K is not None:
            return K
        if log.last is None:
            return None
        # epsilon-inflation (Rump) of the last K, kept around the previous box (the chain needs it)
        X = _inflate(_hull(Kprev, log.last), 0.25, 1e-25)
    return None


def _endpoint(log: _Log, Kpiece: arb_mat, Gr, Gi, prec: int):
    """A tight box for the root at a point time whose ``G`` balls are ``(Gr, Gi)``, given that the root is
    unique in ``Kpiece`` (the piece's box, whose test covered these ``G``): a small box ``X`` around the
    float Newton root, inside ``Kpiece``, passing the Krawczyk test. Its root is then the root. None
    when the test fails (the caller keeps ``Kpiece``)."""
    n = log.n
    cen = np.array([float(Kpiece[i, 0].mid()) for i in range(n)])
    Grf = np.array([[float(e.mid()) for e in row] for row in Gr.tolist()])
    Gif = (
        np.array([[float(e.mid()) for e in row] for row in Gi.tolist()]) if Gi is not None else None
    )
    new = log.newton_f(cen, Grf, Gif)
    if not np.all(np.isfinite(new)):
        return None
    m = log.m
    rads = [upper(Gr[i, j].rad()) for i in range(m) for j in range(m)]
    rads += (
        [upper(Gi[i, j].rad()) for i in range(m) for j in range(m)]
        if Gi is not None
        else [0.0] * (m * m)
    )
    try:
        Cf = np.linalg.inv(log._jac_f(new)[log.sel])
    except np.linalg.LinAlgError:
        return None
    rx = 4.0 * np.abs(Cf) @ np.array([rads[k] for k in log.sel]) + 1e-12 * (1 + np.abs(new))
    X = _box(new, rx)
    if not all(Kpiece[i, 0].contains(X[i, 0]) for i in range(n)):
        return None
    return log.krawczyk(X, Gr, Gi, prec)


class _NoLog(Exception):
    """x could not be proven to be the principal logarithm (the reason is the message)."""


def _float_log(log: _Log, Gr: arb_mat, Gi: arb_mat | None) -> np.ndarray:
    Grf = np.array([[float(e.mid()) for e in row] for row in Gr.tolist()])
    Gif = (
        np.array([[float(e.mid()) for e in row] for row in Gi.tolist()]) if Gi is not None else None
    )
    G = Grf.astype(complex) + (1j * Gif if Gif is not None else 0)
    with np.errstate(all="ignore"):
        L = scipy.linalg.logm(G)
    if not np.all(np.isfinite(L)):
        raise _NoLog(
            "rho(g) has no principal logarithm in float64 (an eigenvalue on the negative axis)"
        )
    mats = log.Rf.astype(complex) + (1j * log.Jf if log.Jf is not None else 0)
    B = np.concatenate([mats.real.reshape(log.n, -1), mats.imag.reshape(log.n, -1)], axis=1).T
    rhs = np.concatenate([L.real.ravel(), L.imag.ravel()])
    x, *_ = np.linalg.lstsq(B, rhs, rcond=None)
    log._choose(x)
    return log.newton_f(x, Grf, Gif)


def _strip_bound(log: _Log, X: arb_mat) -> bool:
    """Proof that every eigenvalue of ``rho(x)``, ``x`` in ``X``, has ``|Im| < pi`` (Bendixson: the imaginary
    parts lie in the spectrum of the Hermitian ``H = (M - M^*) / 2i``; bounded by Gershgorin's discs, else
    else by Gershgorin's discs of ``(Q D)^-1 rho(X) (Q D)`` (``Q`` a float Schur basis, ``D`` a diagonal
    scaling: any similarity keeps the spectrum), else by Arb's eigenvalue enclosures of ``H``)."""

    n, m = log.n, log.m
    Rm = _comb(log.R, [X[b, 0] for b in range(n)])
    Jm = _comb(log.J, [X[b, 0] for b in range(n)]) if log.J is not None else arb_mat(m, m)
    # M = R + iJ; H = (M - M^*)/(2i) = (J + J^T)/2 - i (R - R^T)/2
    H = acb_mat(
        [
            [acb((Jm[i, j] + Jm[j, i]) / 2, -(Rm[i, j] - Rm[j, i]) / 2) for j in range(m)]
            for i in range(m)
        ]
    )
    pi_ = arb.pi()
    gersh = max(sum((abs(H[i, j]) for j in range(m)), arb(0)) for i in range(m))
    if gersh < pi_:
        return True
    # Gershgorin on a similar matrix: the float Schur basis Q of rho(mid X), scaled by D = diag(delta^i)
    # (eigenvalues are similarity invariant; Q^-1 is a ball inverse, so nothing assumes Q unitary)
    M = acb_mat([[acb(Rm[i, j], Jm[i, j]) for j in range(m)] for i in range(m)])
    Mf = np.array(
        [
            [complex(float(M[i, j].real.mid()), float(M[i, j].imag.mid())) for j in range(m)]
            for i in range(m)
        ]
    )
    _, Qf = scipy.linalg.schur(Mf, output="complex")
    delta = 1e-3
    D = np.diag([delta**i for i in range(m)])
    Pf = Qf @ D
    P = acb_mat(
        [[acb(float(Pf[i, j].real), float(Pf[i, j].imag)) for j in range(m)] for i in range(m)]
    )
    try:
        T = P.inv() * M * P
    except ZeroDivisionError:
        return False
    for i in range(m):
        rad = sum((abs(T[i, j]) for j in range(m) if j != i), arb(0))
        if not abs(T[i, i].imag) + rad < pi_:
            break
    else:
        return True
    try:  # Arb's rigorous eigenvalue enclosures of H (Bendixson) as a last resort
        ev = H.eig(multiple=True)
    except (ValueError, ZeroDivisionError):
        return False
    return all(abs(e.real) < pi_ for e in ev)


def _principal_log(log: _Log, Gr: arb_mat, Gi: arb_mat | None, prec: int) -> arb_mat:
    """A box containing the principal logarithm ``x`` of ``rho(g)`` for every ``g`` in the balls (the
    documented choice (a) of :meth:`Representation.log`): the Krawczyk test proves one root of
    ``exp(rho(x)) = G`` in a box, and Bendixson's bound proves the spectrum of ``rho(x)`` in the strip
    ``|Im| < pi`` there, where the logarithm is unique; so that root is the principal logarithm."""
    n = log.n
    xf = _float_log(log, Gr, Gi)
    if not np.all(np.isfinite(xf)):
        raise _NoLog("Newton's method for exp(rho(x)) = G did not converge")
    m = log.m
    rads = [upper(Gr[i, j].rad()) for i in range(m) for j in range(m)]
    rads += (
        [upper(Gi[i, j].rad()) for i in range(m) for j in range(m)]
        if Gi is not None
        else [0.0] * (m * m)
    )
    try:
        Cf = np.linalg.inv(log._jac_f(xf)[log.sel])
    except np.linalg.LinAlgError:
        raise _NoLog("the logarithm is not isolated (singular Jacobian of exp)") from None
    rx = 4.0 * np.abs(Cf) @ np.array([rads[k] for k in log.sel]) + 1e-13 * (1 + np.abs(xf))
    X = _box(xf, rx)
    K = None
    for _ in range(8):
        log.last = None
        K = log.krawczyk(X, Gr, Gi, prec)
        if K is not None:
            break
        if log.last is None:
            raise _NoLog("phi1(-ad_x) is not provably invertible near x (x at the chart's edge)")
        X = _inflate(_hull(X, log.last), 0.25, 1e-25)
    if K is None:
        raise _NoLog(
            "no box passed the Krawczyk test (the logarithm is not isolated at this precision)"
        )
    for _ in range(3):  # tighten: any box inside the proven one with a root holds the same root
        X2 = _inflate(K, 0.01, 0.0)
        if not all(X[i, 0].contains(X2[i, 0]) for i in range(n)):
            break
        K2 = log.krawczyk(X2, Gr, Gi, prec)
        if K2 is None:
            break
        X, K = X2, K2
    if not _strip_bound(log, X):
        raise _NoLog(
            "the spectrum of rho(x) is not provably inside |Im| < pi (near the cut of the principal "
            "logarithm): the documented choice of x is not decided"
        )
    return K


# ------------------------------------------------------------------ the entry point
@dataclass
class _Setup:
    """What both routes of the whole state share (:func:`_setup`): the checked inputs, the field of the
    whole state (``fld``, for ``sign * t >= 0``: reversed for ``t < 0``), its start ``y0`` in balls, the
    layout (``offs``: where ``G_r``, ``G_i``, ``Ad`` start), ``m = dim rho`` and the logarithm's prover."""

    fld: object
    y0: list
    offs: dict
    m: int
    n: int
    tv: float
    pot: dict | None
    cplx: bool
    log: _Log | None
    rational: bool

    def layout(self) -> dict:
        n = self.n
        out = {"pi": (0, n)}
        if self.pot is not None:
            out["Gamma"] = (n, 2 * n)
        for k, o in self.offs.items():
            out[k] = (o, o + (n * n if k == "Ad" else self.m * self.m))
        return out

    def G_of(self, y) -> tuple:
        m, o = self.m, self.offs
        Gr = arb_mat(m, m, y[o["G_r"] : o["G_r"] + m * m])
        Gi = arb_mat(m, m, y[o["G_i"] : o["G_i"] + m * m]) if self.cplx else None
        return Gr, Gi


def _setup(f, theta, upsilon, inertia, potential, x0, pi0, t, prec_bits, want_x, want_ad) -> _Setup:
    """Check the inputs (module docstring of :mod:`refimpl.rigorous`: magnitudes, chart and work budget
    at ``x0``; ``|t| <= MAX_FLOW_TIME``) and build the whole state's field and its start in balls at
    ``prec_bits`` (the caller's :func:`workprec`)."""
    ff = check_structure_constants(
        check_magnitudes(_fview(f, "structure constants f"), "structure constants f")
    )
    n = ff.shape[0]
    check_theta(check_magnitudes(_fview(theta, "theta"), "theta"), ff)
    check_upsilon(check_magnitudes(_fview(upsilon, "upsilon"), "upsilon"), n)
    check_inertia(check_magnitudes(_fview(inertia, "inertia"), "inertia"), n)
    pot = None
    if potential is not None:
        pot = check_potential(
            {
                k: (
                    check_magnitudes(_fview(v, f"potential[{k!r}]"), f"potential[{k!r}]")
                    if k != "kind"
                    else v
                )
                for k, v in potential.items()
            },
            n,
        )
    xf = _point_view(x0, n, "x0")
    _point_view(pi0, n, "pi0")
    check_frames_budget(ff, xf)
    tv = float(check_magnitudes(_fview(t, "t"), "t"))
    if not abs(tv) <= MAX_FLOW_TIME:
        raise ValueError(
            f"t must be in [-{MAX_FLOW_TIME:g}, {MAX_FLOW_TIME:g}] (the flow budget), got {t!r}"
        )
    rep = representation_for(f)
    Ub = [to_arb(v, "upsilon") for v in np.asarray(upsilon, dtype=object).flat]
    Ii_m = arb_mat(
        [[to_arb(v, "inertia") for v in row] for row in np.asarray(inertia, dtype=object)]
    ).inv()
    Ii = np.array(Ii_m.entries(), dtype=object).reshape(n, n)
    src = exact_source(f)
    F3 = [[[to_arb(src[k, a, j], "f") for j in range(n)] for a in range(n)] for k in range(n)]
    R, J = _rep_balls(rep)
    rational = not all(u.is_zero() for u in Ub)
    if not rational:
        body, _ = body_field(f, theta, inertia, None if pot is None else potential)
        field_, offs, m = _state_field(body, n, Ii, R, J, F3, want_ad)
        if tv < 0:  # y(t) for t < 0 is the state at |t| of the time-reversed field y' = -F(y)
            field_ = _reversed(field_)
    else:  # the rational field: the solve by Phi as a ball Taylor recurrence
        th = arb_mat(n, n, [to_arb(v, "theta") for v in np.asarray(theta, dtype=object).flat])
        Lb = (
            None
            if pot is None
            else [to_arb(v, "potential['L']") for v in np.asarray(potential["L"], dtype=object)]
        )
        field_ = RationalField(
            F3, th, arb_mat(n, n, Ub), Ii_m, Lb, R, J, want_ad, sign=-1 if tv < 0 else 1
        )
        offs = {k: v for k, v in field_.offs.items() if k in ("G_r", "G_i", "Ad")}
        m = field_.m
        pi_b = arb_mat(n, 1, [to_arb(v, "pi0") for v in np.asarray(pi0, dtype=object).flat])
        Phi0 = field_.eye_n + (field_._comb(field_.Fm, pi_b) - th) * field_.U
        try:
            Phi0.inv()
        except ZeroDivisionError:
            raise DegeneratePointError(
                "full_state_enclosure: Delta = det Phi(pi0) is not provably nonzero at the start "
                "(pi0 on or within rounding of the degenerate set Pi_1, vier12)"
            ) from None
    Fad, _, _ = algebra_balls(f, prec_bits)
    xv = arb_mat(n, 1, [to_arb(v, "x0") for v in np.asarray(x0, dtype=object).reshape(-1)])
    adx = arb_mat(n, n, (Fad * xv).entries())
    Ad0 = adx.exp()
    y0 = [to_arb(v, "pi0") for v in np.asarray(pi0, dtype=object).reshape(-1)]
    if pot is not None:
        gam = arb_mat(
            n,
            1,
            [to_arb(v, "potential['gamma']") for v in np.asarray(potential["gamma"], dtype=object)],
        )
        y0 += (Ad0.transpose() * gam).entries()
    Rx = _comb(R, [xv[b, 0] for b in range(n)])
    Jx = _comb(J, [xv[b, 0] for b in range(n)]) if J is not None else None
    E0 = _embed(Rx, Jx).exp()
    y0 += [E0[i, j] for i in range(m) for j in range(m)]
    if J is not None:
        y0 += [E0[m + i, j] for i in range(m) for j in range(m)]
    if want_ad:
        y0 += Ad0.entries()
    log = _Log(Fad, n, R, J, xf) if want_x else None
    return _Setup(field_, y0, offs, m, n, tv, pot, J is not None, log, rational)


def _finish(S: _Setup, y, prec_bits, steps, rejected, t_start, want_x, jac=None) -> StateEnclosure:
    """The :class:`StateEnclosure` of the carried state ``y`` (balls) at ``S.tv``, with ``x`` proven
    from its ``rho(g)`` balls by :func:`_principal_log` (at ``prec_bits``, the caller's precision)."""
    xb, note = None, "x not asked for (want_x=False)"
    if want_x:
        Gr, Gi = S.G_of(y)
        try:
            xb = Balls(
                np.array(_principal_log(S.log, Gr, Gi, prec_bits).entries(), dtype=object),
                prec_bits,
            )
            note = ""
        except _NoLog as exc:
            note = f"x not recovered: {exc}"
    layout = S.layout()
    n, m = S.n, S.m

    def part(k, shape):
        a, b = layout[k]
        return Balls(np.array(y[a:b], dtype=object).reshape(shape), prec_bits)

    return StateEnclosure(
        t=S.tv,
        pi=part("pi", (n,)),
        Gamma=part("Gamma", (n,)) if S.pot is not None else None,
        rho_g=part("G_r", (m, m)),
        rho_g_imag=part("G_i", (m, m)) if S.cplx else None,
        Ad_g=part("Ad", (n, n)) if "Ad" in S.offs else None,
        x=xb,
        x_note=note,
        steps=steps,
        rejected=rejected,
        prec_bits=prec_bits,
        seconds=time.process_time() - t_start,
        layout=layout,
        jacobian=None
        if jac is None
        else Balls(np.array(jac.entries(), dtype=object).reshape(S.fld.d, S.fld.d), prec_bits),
    )


def _check_prec(prec_bits) -> None:
    if (
        not isinstance(prec_bits, int)
        or isinstance(prec_bits, bool)
        or not 53 <= prec_bits <= MAX_PREC_BITS
    ):
        raise ValueError(f"prec_bits must be an int in [53, {MAX_PREC_BITS}], got {prec_bits!r}")


def full_state_enclosure(
    f,
    theta,
    upsilon,
    inertia,
    potential,
    x0,
    pi0,
    t,
    *,
    prec_bits: int = 200,
    order: int | None = None,
    jac_order: int | None = None,
    tol: float | None = None,
    want_x: bool = True,
    want_ad: bool = False,
    jacobian: bool = False,
    max_seconds: float = 120.0,
) -> StateEnclosure:
    """Enclose the whole state at ``t`` (module docstring): ``pi``, ``Gamma``, ``rho(g)``, ``Ad(g)``, ``x``.

    ``Upsilon != 0`` by the rational field (module docstring; ``DegeneratePointError`` where ``Delta``
    is not proven away from 0). The inputs pass the rigorous
    implementation's boundary (:mod:`refimpl.rigorous`: magnitudes, chart and work budget at ``x0``,
    precision cap) and the flow budget ``|t| <= MAX_FLOW_TIME``; ``max_seconds`` bounds the CPU time,
    estimated from the first steps. ``t < 0``: the flow backwards in time (the field reversed).
    ``order`` defaults to ``max(12, prec_bits // 5)``; ``jac_order``
    (the Taylor order of the variational equation) to 8, or ``3/4 order`` with ``jacobian=True`` (the
    Jacobian's radius then matches the state's; at 8 it is ~1e-12).
    """

    t_start = time.process_time()
    _check_prec(prec_bits)
    if order is None:
        order = max(12, prec_bits // 5)
    if (
        jac_order is None
    ):  # the Lohner wrapping needs little; the C^1 enclosure is asked at full precision
        jac_order = max(8, order * 3 // 4) if jacobian else 8
    tol = 2.0 ** -(prec_bits - 16) if tol is None else float(tol)
    if not tol > 0:
        raise ValueError(f"tol must be > 0, got {tol!r}")
    with workprec(prec_bits):
        S = _setup(f, theta, upsilon, inertia, potential, x0, pi0, t, prec_bits, want_x, want_ad)
        res = enclose_quadratic(
            S.fld,
            S.y0,
            abs(to_arb(t, "t")),
            order=order,
            jac_order=jac_order,
            tol=tol,
            max_steps=100000,
            jacobian=jacobian,
            max_seconds=max_seconds,
        )
        y, steps, rejected = res[:3]
        return _finish(
            S, y, prec_bits, steps, rejected, t_start, want_x, res[3] if jacobian else None
        )
