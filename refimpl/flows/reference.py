"""Reference flows (mpmath, any precision): the full state (x, pi) and the reduced body systems.

Systems (docs/conventions.md; the paper's labels)

* Full state, vier10/vier11: ``Omega = Psi^-1 (dK - U dV)``,
  ``pidot = Phi^-1 (-dV - S dK)``, ``xdot = L(g, e) Omega`` with
  ``L(g, e) = phi1(-ad_x)^-1`` and ``dV_b = -Gamma_m f^m_bc L^c``,
  ``Gamma = Ad(g)^T gamma`` (twee16). With ``Upsilon = 0``, ``Theta = 0`` this
  is twee13/twee14; with ``Theta`` it is drie4/drie6.
* Reduced body system: ``dV`` depends on ``g`` only through ``Gamma``, which
  obeys ``dGamma_mu/dt = Omega^b f^a_{b mu} Gamma_a`` (twee17 with the sign
  corrected, docs/conventions.md / tests/test_vector_field.py); so ``(pi, Gamma)``
  is closed (Euler-Poisson, twee17/twee18), and ``pi`` alone is closed when
  ``V = 0`` (Euler, twee14, drie6).

Re-basing: the chart ``g = exp(x)`` fails where ``ad_x`` has an eigenvalue
``2 pi i k``. ``omega_L`` is left-invariant, so with ``g = g_ref exp(x)`` the
body equations keep their form; only the potential changes, through
``gamma -> Ad(g_ref)^T gamma``. After every step with ``||ad_x||_1 > REBASE``
the flow moves ``exp(x)`` into ``g_ref`` (kept as ``Ad(g_ref)`` and as a matrix
of the algebra's representation) and resets ``x = 0``.

Structure constants: re-basing relies on ``[ad_x, ad_y] = ad_[x,y]`` (Jacobi). Constants given in
float64 satisfy it only to ~1e-17, and then the flow depends on where it re-bases from about the
18th digit on; the flows therefore integrate the Lie algebra the numbers stand for
(:func:`lie_constants_mp`: the rationals the floats are roundings of, else the input when Jacobi
holds at the working precision, else the nearest Lie algebra). ``ReferenceTrajectory.notes`` names
the choice.

Integrator: Gragg-Bulirsch-Stoer extrapolation (:func:`refimpl._integrators.gbs_mp`)
at ``dps + GUARD`` digits with local tolerance ``10^-(dps + 5)``. The result is
certified by a ladder: :func:`reference_trajectory` with ``check=True`` repeats
the run at ``dps + 15`` digits and a tolerance 10^-10 smaller and reports the
digits on which both agree (``digits``).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field
from fractions import Fraction
from itertools import combinations

import mpmath
import numpy as np

from .._algebra import LieAlgebra
from .._errors import DegeneratePointError
from .._flow_checks import check_time
from .._integrators import gbs_mp
from .._phi import phi1_mp
from .._reference_core import MAX_DPS, _as_float, _to_mpf
from .._reference_core import ReferenceCore as Reference
from .._representation import Representation, representation_for
from .._validate import MAX_REFERENCE_FLOW_TIME, ProgressBudget, check_inertia, check_potential

__all__ = [
    "ModelMP",
    "ReferenceTrajectory",
    "reference_trajectory",
    "reference_flow",
    "euler_top_closed_form",
    "lie_constants_mp",
]

GUARD = 15
REBASE = mpmath.mpf(1)  # ||ad_x||_1 above which the chart is re-based (well inside |eig| < 2 pi)


def _jacobi_mp(F, n):
    """``J^m_abc = f^m_ad f^d_bc + f^m_bd f^d_ca + f^m_cd f^d_ab`` for ``a < b < c`` (mpmath list)."""
    out = []
    for a, b, c in combinations(range(n), 3):
        for m in range(n):
            out.append(
                mpmath.fsum(
                    F[m][a, d] * F[d][b, c] + F[m][b, d] * F[d][c, a] + F[m][c, d] * F[d][a, b]
                    for d in range(n)
                )
            )
    return out


def _jacobi_jacobian(u, n):
    """float64 derivative of :func:`_jacobi_mp` with respect to ``u = (f^m_ab)_{a < b}``."""
    pairs = list(combinations(range(n), 2))
    f = np.zeros((n, n, n))
    for k, (m, (a, b)) in enumerate((m, ab) for m in range(n) for ab in pairs):
        f[m, a, b], f[m, b, a] = u[k], -u[k]
    E = np.zeros((n * len(pairs), n, n, n))  # d f / d u
    for k, (m, (a, b)) in enumerate((m, ab) for m in range(n) for ab in pairs):
        E[k, m, a, b], E[k, m, b, a] = 1.0, -1.0
    rows = []
    for a, b, c in combinations(range(n), 3):
        # d/du of sum_d f[m,a,d] f[d,b,c] + cyclic, for every m: (n, K)
        blk = np.zeros((n, E.shape[0]))
        for x, y, z in ((a, b, c), (b, c, a), (c, a, b)):
            blk += np.einsum("kmd,d->mk", E[:, :, x, :], f[:, y, z])
            blk += np.einsum("md,kd->mk", f[:, x, :], E[:, :, y, z])
        rows.append(blk)
    return np.concatenate(rows, axis=0), pairs


_LIE_CACHE: OrderedDict = OrderedDict()  # bounded: _LIE_CACHE_MAX entries, oldest dropped
_LIE_CACHE_MAX = 64


def _remember(key, value) -> None:
    _LIE_CACHE[key] = value
    while len(_LIE_CACHE) > _LIE_CACHE_MAX:
        _LIE_CACHE.popitem(last=False)


def _rational_reading(ff):
    """The constants as rationals ``p/q`` (``q <= 10^6``) when every float is exactly the rounding of
    one and they satisfy Jacobi exactly (mpmath matrices at the working precision), else None."""
    n = ff.shape[0]
    fr = np.empty(ff.shape, dtype=object)
    for idx, v in np.ndenumerate(ff):
        q = Fraction(float(v)).limit_denominator(10**6)
        if float(q) != v:
            return None
        fr[idx] = q
    for a, b, c in combinations(range(n), 3):
        for m in range(n):
            if sum(
                fr[m, a, d] * fr[d, b, c] + fr[m, b, d] * fr[d, c, a] + fr[m, c, d] * fr[d, a, b]
                for d in range(n)
            ):
                return None
    return [
        mpmath.matrix(
            [
                [mpmath.mpf(fr[m, a, b].numerator) / fr[m, a, b].denominator for b in range(n)]
                for a in range(n)
            ]
        )
        for m in range(n)
    ]


def lie_constants_mp(f, Fm):
    """The structure constants the reference integrates: ``Fm`` (mpmath, from the input) when they satisfy
    the Jacobi identity at the working precision, else the Lie algebra the numbers stand for.

    Why: the flow on ``G`` exists only for a Lie algebra. Constants given in float64 (e.g. a change of
    basis by a float matrix) break Jacobi by ~1e-17; then the chart equations ``x' = A(x)^-1 Omega``
    and the re-based ones (``Gamma = (Ad_ref exp(ad_x))^T gamma``) describe different flows, and the
    result depends on *where* the flow re-bases at the ~1e-17 level (measured: 20.6 digits in pi at
    T = 1 between re-basing thresholds 1 and 0.4, 36.7 with the same algebra given exactly). The
    choice, in this order (``note`` names it):

    1. ``"rational"`` (float64 input only): every float is the rounding of a rational ``p/q`` with
       ``q <= 10^6`` (``Fraction.limit_denominator``, the same reading as
       :mod:`refimpl._representation`) and those rationals satisfy Jacobi exactly: the algebra the
       floats were rounded from;
    2. ``"as given"``: Jacobi holds to ``10^(10 - dps) max|f|^2`` at the working precision (exact
       input, or floats that happen to satisfy it);
    3. ``"projected"``: the nearest Lie algebra, by Gauss-Newton steps of minimum norm on the
       independent constants ``f^m_ab`` (``a < b``) until Jacobi holds at the working precision; the
       change is of the size of the input's rounding (``|delta f| ~ Jacobi residual / |f|``). The steps
       are computed in float64 from residuals evaluated at the working precision, so each step
       reduces the residual by ~1e-16 and the limit is the same at every precision (to far below
       the digits asked for).
    """
    n = len(Fm)
    scale = max(
        [mpmath.mpf(1)] + [abs(Fm[m][a, b]) for m in range(n) for a in range(n) for b in range(n)]
    )
    tol = mpmath.mpf(10) ** (10 - mpmath.mp.dps) * scale**2
    if n < 3:
        return Fm, "as given"
    if isinstance(f, LieAlgebra):
        float_input = not f.is_exact
    else:
        fo = np.asarray(f, dtype=object)
        float_input = all(isinstance(v, (float, np.floating)) for v in fo.flat)
    ff = np.asarray(f.f if isinstance(f, LieAlgebra) else _as_float(f, "f"), dtype=float)
    key = (ff.tobytes(), mpmath.mp.prec) if float_input else None  # exact inputs: no cache
    if key in _LIE_CACHE:
        F, note = _LIE_CACHE[key]
        return (Fm, note) if F is None else ([m.copy() for m in F], note)
    if float_input:
        F = _rational_reading(ff)
        if F is not None:
            _remember(key, (F, "rational"))  # float input: key is not None
            return [m.copy() for m in F], "rational"
    res = _jacobi_mp(Fm, n)
    if max((abs(v) for v in res), default=0) <= tol:
        if key is not None:
            _remember(key, (None, "as given"))
        return Fm, "as given"
    pairs = list(combinations(range(n), 2))
    u = [Fm[m][a, b] for m in range(n) for a, b in pairs]
    for _ in range(12):
        F = [mpmath.zeros(n, n) for _ in range(n)]
        for k, (m, (a, b)) in enumerate((m, ab) for m in range(n) for ab in pairs):
            F[m][a, b], F[m][b, a] = u[k], -u[k]
        r = _jacobi_mp(F, n)
        if max(abs(v) for v in r) <= tol:
            if key is not None:
                _remember(key, (F, "projected"))
            return [m.copy() for m in F], "projected"
        Jac, _ = _jacobi_jacobian(np.array([float(v) for v in u]), n)
        du, *_ = np.linalg.lstsq(Jac, -np.array([float(v) for v in r]), rcond=1e-10)
        u = [u[k] + mpmath.mpf(float(du[k])) for k in range(len(u))]
    raise ValueError(
        "structure constants f: no Lie algebra found near the given numbers (Gauss-Newton on the Jacobi "
        f"identity did not reach the working precision; residual {mpmath.nstr(max(abs(v) for v in r), 3)})"
    )


class ModelMP:
    """A model (f, Theta, Upsilon, inertia, potential) converted once to mpmath lists at the current precision."""

    def __init__(self, f, theta, upsilon, inertia, potential):
        ref = Reference(max(15, mpmath.mp.dps - GUARD))
        Fm, th, up = ref._model(f, theta, upsilon)
        n = len(Fm)
        check_inertia(_as_float(inertia, "inertia"), n)
        pot = check_potential(
            None
            if potential is None
            else {
                k: (_as_float(v, f"potential[{k!r}]") if k != "kind" else v)
                for k, v in potential.items()
            },
            n,
        )
        Fm, self.constants = lie_constants_mp(f, Fm)
        self.n = n
        self.algebra = f if isinstance(f, LieAlgebra) else None
        # the faithful representation g(t) is kept in (raises RepresentationError naming the condition)
        self.rep: Representation = representation_for(
            f if isinstance(f, LieAlgebra) else _as_float(f, "f")
        )
        self.Fm = Fm
        self.f = [[[Fm[m][a, b] for b in range(n)] for a in range(n)] for m in range(n)]
        self.f_nz = [
            (m, a, b, Fm[m][a, b])
            for m in range(n)
            for a in range(n)
            for b in range(n)
            if Fm[m][a, b] != 0
        ]
        self.theta = th
        self.theta_zero = all(th[i, j] == 0 for i in range(n) for j in range(n))
        self.upsilon = up
        self.upsilon_zero = all(up[i, j] == 0 for i in range(n) for j in range(n))
        I_mp = Reference._mat(inertia, n, "inertia")
        self.Iinv = mpmath.inverse(I_mp)
        self._Iinv_l = [[self.Iinv[a, b] for b in range(n)] for a in range(n)]
        self._Idiag = all(self.Iinv[a, b] == 0 for a in range(n) for b in range(n) if a != b)
        if pot is None:
            self.Lvec = self.gamma = None
        else:
            self.Lvec = Reference._vec(potential["L"], n, "potential['L']")
            self.gamma = Reference._vec(potential["gamma"], n, "potential['gamma']")
        self.ref = ref

    # -------------------------------------------------------------- pieces
    def ad(self, x):
        return Reference.ad(self.Fm, x)

    def S(self, pi):
        return Reference.S(self.Fm, self.theta, pi)

    def dV(self, Gamma):
        """``dV_b = -Gamma_m f^m_bc L^c`` (twee16)."""
        out = mpmath.zeros(self.n, 1)
        for m, b, c, v in self.f_nz:
            out[b] -= Gamma[m] * v * self.Lvec[c]
        return out

    def check_nondegenerate(self, pi):
        q = self.ref.phi_psi_delta(self.Fm, self.theta, self.upsilon, pi)
        self.ref._check_nondegenerate(q["Phi"], q["Delta"], pi)

    def omega_pidot(self, pi, Gamma):
        """``Omega`` (vier10) and ``pidot`` (vier11) from body quantities (mpmath column matrices)."""
        n = self.n
        if self.upsilon_zero:
            o, p = self.omega_pidot_list(list(pi), None if Gamma is None else list(Gamma))
            return mpmath.matrix(o), mpmath.matrix(p)
        dK = self.Iinv * pi
        S = self.S(pi)
        dV = None if Gamma is None else self.dV(Gamma)
        Psi = mpmath.eye(n) + self.upsilon * S
        rhs_o = dK if dV is None else dK - self.upsilon * dV
        rhs_p = -(S * dK) if dV is None else -dV - S * dK
        try:
            Omega = mpmath.lu_solve(Psi, rhs_o)
            pidot = mpmath.lu_solve(Psi.T, rhs_p)
        except ZeroDivisionError:
            raise DegeneratePointError(
                f"the trajectory reached the degenerate set Pi_1 (Delta = 0, vier12) at pi = "
                f"{[mpmath.nstr(v, 8) for v in pi]}"
            ) from None
        return Omega, pidot

    def omega_pidot_list(self, pi, Gamma):
        """The same for ``Upsilon = 0`` on plain lists (no Phi: ``Omega = dK``, ``pidot = -dV - S dK``)."""
        n = self.n
        Iinv = self._Iinv_l
        dK = (
            [mpmath.fsum(Iinv[a][b] * pi[b] for b in range(n)) for a in range(n)]
            if not self._Idiag
            else [Iinv[a][a] * pi[a] for a in range(n)]
        )
        out = [mpmath.mpf(0)] * n
        for m, a, b, v in self.f_nz:
            out[a] -= pi[m] * v * dK[b]
        if not self.theta_zero:
            th = self.theta
            for a in range(n):
                for b in range(n):
                    if th[a, b]:
                        out[a] += th[a, b] * dK[b]
        if Gamma is not None:
            Lv = self.Lvec
            for m, b, c, v in self.f_nz:
                out[b] += Gamma[m] * v * Lv[c]
        return dK, out

    def gamma_dot(self, Omega, Gamma):
        """``dGamma_mu/dt = Omega^b f^a_{b mu} Gamma_a`` (twee17, sign corrected)."""
        out = [mpmath.mpf(0)] * self.n
        for a, b, mu, v in self.f_nz:
            out[mu] += Omega[b] * v * Gamma[a]
        return mpmath.matrix(out) if isinstance(Omega, mpmath.matrix) else out

    def energy(self, pi, Gamma=None):
        K = (pi.T * self.Iinv * pi)[0] / 2
        if Gamma is None or self.gamma is None:
            return K
        return K - mpmath.fsum(Gamma[i] * self.Lvec[i] for i in range(self.n))

    def cocycle_term(self, x):
        """``A(x)^T Theta x`` with ``A = phi1(-ad_x)``: the cocycle correction of the momentum map."""
        if self.theta_zero:
            return mpmath.zeros(self.n, 1)
        A = phi1_mp(-self.ad(x))
        return A.T * (self.theta * x)

    # Not refimpl/_phi.py's phi1_mp: A and Ad fused in one loop over plain lists (the flow's hot path).
    def frames_series(self, x):
        """``A = phi1(-ad_x)`` and ``Ad = exp(ad_x)`` from one Taylor loop over the powers of ``M = -ad_x``:
        ``A = sum M^k/(k+1)!``, ``Ad = sum (-1)^k M^k/k!``, summed until a term's largest entry is below
        ``eps`` times ``max(1, ||M||)^2`` (plain lists: the hot path of the full-state flow)."""
        n = self.n
        ad = self.ad(x)
        M = [[-ad[i, j] for j in range(n)] for i in range(n)]
        P = [
            [mpmath.mpf(1) if i == j else mpmath.mpf(0) for j in range(n)] for i in range(n)
        ]  # M^k
        A = [row[:] for row in P]
        Ad = [row[:] for row in P]
        eps = mpmath.eps
        k = 0
        fact = mpmath.mpf(1)  # k!
        while True:
            k += 1
            P = [
                [mpmath.fdot([(P[i][l], M[l][j]) for l in range(n)]) for j in range(n)]
                for i in range(n)
            ]
            fact *= k
            ca, cd = 1 / (fact * (k + 1)), (1 if k % 2 == 0 else -1) / fact
            big = mpmath.mpf(0)
            for i in range(n):
                for j in range(n):
                    A[i][j] += ca * P[i][j]
                    Ad[i][j] += cd * P[i][j]
                    big = max(big, abs(P[i][j]))
            if big / fact <= eps and k > 2:
                break
        return mpmath.matrix(A), mpmath.matrix(Ad)

    def frame_L(self, x):
        A = phi1_mp(-self.ad(x))
        return A, mpmath.inverse(A)


@dataclass
class ReferenceTrajectory:
    """Samples of a reference trajectory (object arrays of mpf at ``dps + GUARD`` digits).

    ``pi``: (T, n); ``Gamma``: (T, n) or None; ``x``: (T, n) with NaN where
    the configuration lies outside the chart of exponential coordinates
    around ``e`` (or None for a body flow); ``J``: (T, n) momentum map of the
    left action (full flows; see :func:`refimpl.flows.momentum_map`); ``g``: (T, r, r) matrices of the
    algebra's representation (``rep``; the adjoint representation ``Ad(g)``
    when the algebra has none) or None; ``Ad``: (T, n, n); ``digits``: correct
    digits confirmed by the precision/tolerance ladder (None without check).
    """

    times: np.ndarray
    pi: np.ndarray
    Gamma: np.ndarray | None
    x: np.ndarray | None
    g: np.ndarray | None
    Ad: np.ndarray | None
    rebases: int
    steps: int
    dps: int
    system: str
    digits: float | None = None
    J: np.ndarray | None = None
    notes: list = field(default_factory=list)


def _col(v):
    return mpmath.matrix([mpmath.mpf(e) for e in v])


def _rep_exp(model: ModelMP, x):
    """``exp(x^a E_a)`` in the algebra's faithful representation (mpmath, complex allowed)."""
    return model.rep.mp_exp(x, model.Fm)


def _log_coordinates(model: ModelMP, Ad_total, g_rep):
    """``x`` with ``g = exp(x)``: :meth:`refimpl._representation.Representation.mp_log` (principal
    logarithm in the representation, else of ``Ad(g)`` corrected by the centre, the documented
    choice on the cut locus)."""
    return model.rep.mp_log(g_rep, Ad_total, model.Fm)


def _run(model: ModelMP, system: str, x0, pi0, times, tol, k, sign=1, budget=False):
    """Integrate to each of ``times`` (increasing, >= 0); ``sign = -1`` runs the flow backwards
    (``y' = -F(y)`` in the time ``s = -t``: the fields are autonomous)."""
    n = model.n
    pi0 = _col(pi0)
    x0 = _col(x0)
    model.check_nondegenerate(pi0)
    grav = model.gamma is not None
    out_pi, out_G, out_x, out_g, out_Ad = [], [], [], [], []
    state = {"Ad_ref": mpmath.eye(n), "g_ref": None, "rebases": 0, "c": mpmath.zeros(n, 1)}
    out_J = []
    if system == "full":
        g0 = _rep_exp(model, mpmath.zeros(n, 1))
        state["g_ref"] = g0

        def F(t, y):
            x, pi = _col(y[:n]), _col(y[n:])
            A, Ad = model.frames_series(x)
            Gamma = (state["Ad_ref"] * Ad).T * model.gamma if grav else None
            Omega, pidot = model.omega_pidot(pi, Gamma)
            return list(mpmath.lu_solve(A, Omega)) + list(
                pidot
            )  # xdot = L(g, e) Omega = A^-1 Omega

        def after(t, y):
            x = _col(y[:n])
            if not model.rep.nilpotent and mpmath.mnorm(model.ad(x), 1) > REBASE:
                state["c"] += mpmath.inverse(state["Ad_ref"]).T * model.cocycle_term(x)
                state["Ad_ref"] = state["Ad_ref"] * mpmath.expm(model.ad(x))
                if state["g_ref"] is not None:
                    state["g_ref"] = state["g_ref"] * _rep_exp(model, x)
                state["rebases"] += 1
                return [mpmath.mpf(0)] * n + list(y[n:])
            return y

        y = list(x0) + list(pi0)
    else:
        after = None
        if grav:
            Gamma0 = mpmath.expm(model.ad(x0)).T * model.gamma

            if model.upsilon_zero:

                def F(t, y):
                    Omega, pidot = model.omega_pidot_list(y[:n], y[n:])
                    return pidot + model.gamma_dot(Omega, y[n:])
            else:

                def F(t, y):
                    pi, G = _col(y[:n]), _col(y[n:])
                    Omega, pidot = model.omega_pidot(pi, G)
                    return list(pidot) + list(model.gamma_dot(Omega, G))

            y = list(pi0) + list(Gamma0)
        else:
            if model.upsilon_zero:

                def F(t, y):
                    return model.omega_pidot_list(y, None)[1]
            else:

                def F(t, y):
                    return list(model.omega_pidot(_col(y), None)[1])

            y = list(pi0)
    if sign < 0:
        F_fwd = F

        def F(t, y):
            return [-v for v in F_fwd(t, y)]

    t_prev = mpmath.mpf(0)
    steps = 0
    if budget and times:  # issue 30 hook: the time budget, extrapolated from the progress
        span = mpmath.nstr(sign * mpmath.mpf(times[-1]), 6)
        after = ProgressBudget("reference flow").watch(after, times[-1], f"the flow to t = {span}")
    for tk in times:
        tk = mpmath.mpf(tk)
        if tk > t_prev:
            res = gbs_mp(F, y, tk, tol=tol, k=k, t0=t_prev, after_step=after)
            y, steps = res.y, steps + res.steps
        t_prev = tk
        if system == "full":
            x, pi = _col(y[:n]), _col(y[n:])
            Ad = state["Ad_ref"] * mpmath.expm(model.ad(x))
            g = None if state["g_ref"] is None else state["g_ref"] * _rep_exp(model, x)
            out_pi.append(list(pi))
            out_G.append(list(Ad.T * model.gamma) if grav else None)
            if state["rebases"] == 0:
                out_x.append(
                    list(x)
                )  # never re-based: ||ad_x||_1 <= 1 (or nilpotent), the chart itself
            else:
                out_x.append(list(_log_coordinates(model, Ad, g)))
            out_g.append(g)
            out_Ad.append(Ad)
            Kx = mpmath.expm(-model.ad(x)).T
            J = mpmath.inverse(state["Ad_ref"]).T * (Kx * pi - model.cocycle_term(x)) - state["c"]
            out_J.append(list(J))
        else:
            out_pi.append(list(y[:n]))
            out_G.append(list(y[n:]) if grav else None)
    T = len(out_pi)
    mat = lambda ms: np.array(
        [[[m[i, j] for j in range(m.cols)] for i in range(m.rows)] for m in ms], dtype=object
    )
    return ReferenceTrajectory(
        times=np.array([sign * mpmath.mpf(t) for t in times], dtype=object),
        pi=np.array(out_pi, dtype=object).reshape(T, n),
        Gamma=np.array(out_G, dtype=object).reshape(T, n) if grav else None,
        x=np.array(out_x, dtype=object).reshape(T, n) if system == "full" else None,
        g=mat(out_g) if system == "full" else None,
        Ad=mat(out_Ad) if system == "full" else None,
        rebases=state["rebases"],
        steps=steps,
        dps=mpmath.mp.dps,
        system=system,
        J=np.array(out_J, dtype=object).reshape(T, n) if system == "full" else None,
        notes=[f"structure constants: {model.constants}"],
    )


def _order_for(dps: int) -> int:
    """Extrapolation depth ``k`` (order 2k): about one order per 2.5 digits, between 6 and 18."""
    return int(min(18, max(6, round(dps / 2.5))))


def reference_trajectory(
    f,
    theta,
    upsilon,
    inertia,
    potential,
    x0,
    pi0,
    times,
    *,
    dps: int = 50,
    system: str = "full",
    check: bool = False,
    time_budget: bool = False,
) -> ReferenceTrajectory:
    """The reference trajectory sampled at ``times`` (increasing and >= 0, or decreasing and <= 0 for
    the flow backwards). ``x`` always exists (the logarithm of ``g``, :mod:`refimpl._representation`);
    ``g`` holds ``g(t)`` in the algebra's faithful representation.

    ``system="full"``: the state ``(x, pi)`` of vier10/vier11 with re-basing;
    ``system="body"``: the reduced body system (Euler or Euler-Poisson).
    ``check=True`` repeats the run at ``dps + 15`` digits with a 10^-10
    smaller tolerance and stores the digits of agreement in ``digits``.
    ``time_budget=True`` (the protocol's :func:`reference_flow`) refuses a run whose CPU time,
    extrapolated from its progress, would exceed :data:`refimpl._validate.TIME_BUDGET_S`.
    """
    if not isinstance(dps, int) or dps < 15:
        raise ValueError(f"dps must be an int >= 15, got {dps!r}")
    if system not in ("full", "body"):
        raise ValueError(f"system must be 'full' or 'body', got {system!r}")
    tl = [
        check_time(t, "times", allow_negative=True)
        for t in np.atleast_1d(np.asarray(times, dtype=object))
    ]
    if dps > MAX_DPS or (
        tl and max(abs(v) for v in tl) > MAX_REFERENCE_FLOW_TIME
    ):  # the stated budget
        raise ValueError(
            f"reference flow budget: dps <= {MAX_DPS} and |times| <= {MAX_REFERENCE_FLOW_TIME:g}, "
            f"got dps = {dps} and t = {max(abs(v) for v in tl) if tl else 0:g}"
        )
    sign = -1 if any(v < 0 for v in tl) else 1
    if sign < 0 and any(v > 0 for v in tl):
        raise ValueError("times must be all >= 0 (a forward flow) or all <= 0 (a backward flow)")
    if any(sign * b < sign * a for a, b in zip(tl, tl[1:])):
        raise ValueError("times must be increasing (decreasing for a backward flow)")
    times_exact = list(np.atleast_1d(np.asarray(times, dtype=object)))

    def once(d, tol_digits):
        with mpmath.workdps(d + GUARD):
            model = ModelMP(f, theta, upsilon, inertia, potential)
            n = model.n
            xv = Reference._vec(x0, n, "x0")
            pv = Reference._vec(pi0, n, "pi0")
            tms = [sign * _to_mpf(t) for t in times_exact]
            tol = mpmath.mpf(10) ** (-tol_digits)
            return _run(model, system, xv, pv, tms, tol, _order_for(d), sign, time_budget)

    tr = once(dps, dps + 5)
    if check:
        tr2 = once(dps + 15, dps + 15)
        with mpmath.workdps(dps + 30):
            arrs = (
                [(tr.pi, tr2.pi)]
                + ([(tr.Gamma, tr2.Gamma)] if tr.Gamma is not None else [])
                + ([(tr.Ad, tr2.Ad)] if tr.Ad is not None else [])
            )
            worst = mpmath.mpf(0)
            for a, b in arrs:
                for u, v in zip(a.ravel(), b.ravel()):
                    worst = max(worst, abs(u - v) / max(1, abs(v)))
            tr.digits = float("inf") if worst == 0 else float(-mpmath.log10(worst))
    return tr


def reference_flow(
    f, theta, upsilon, inertia, potential, x0, pi0, t, dps: int = 50, *, return_group: bool = False
):
    """Protocol method 3 (docs/design.md): the state ``(x, pi)`` at time ``t`` from ``(x0, pi0)`` at 0.

    Full state of vier10/vier11, integrated at ``dps`` digits (see the module
    docstring), re-based through the algebra's faithful representation; ``x`` is the logarithm of
    ``g(t)`` chosen in :mod:`refimpl._representation` (principal where it exists). ``t`` may be
    negative. Returns float64 arrays, or object arrays of mpf when any input is exact (as
    :class:`refimpl.reference.Reference` does); ``return_group=True`` adds ``g(t)`` as an ``(r, r)``
    object array of mpmath numbers in that representation. Raises ``ValueError`` for a non-finite or
    non-real ``t``, a start on (or a trajectory reaching) the degenerate set, or an algebra whose
    representation cannot be built (:class:`refimpl._representation.RepresentationError`).
    """
    check_time(t, allow_negative=True)
    exact = Reference._wants_exact(f, theta, upsilon, inertia, potential, x0, pi0, t)
    tr = reference_trajectory(
        f,
        theta,
        upsilon,
        inertia,
        potential,
        x0,
        pi0,
        [t],
        dps=dps,
        system="full",
        time_budget=True,
    )
    x, pi = tr.x[-1], tr.pi[-1]
    if exact:
        out = (np.array(list(x), dtype=object), np.array(list(pi), dtype=object))
    else:
        out = (np.array([float(v) for v in x]), np.array([float(v) for v in pi]))
    return out + (tr.g[-1],) if return_group else out


def euler_top_closed_form(I, pi0, t):
    """The free rigid body ``dpi/dt = pi x Omega``, ``Omega = pi / I`` (twee14, V = 0), in closed form.

    For ``I1 < I2 < I3`` and ``M^2 = |pi|^2 > 2 E I2`` (rotation about the
    ``I3`` axis), Euler's equations ``I1 W1' = (I2 - I3) W2 W3`` (cyclic) are
    solved by ``W = (A cn u, s B sn u, s C dn u)``, ``u = u0 + w t``, with
    ``A^2 = (2E I3 - M^2)/(I1 (I3 - I1))``, ``B^2 = (2E I3 - M^2)/(I2 (I3 - I2))``,
    ``C^2 = (M^2 - 2E I1)/(I3 (I3 - I1))``, ``w^2 = (I3 - I2)(M^2 - 2E I1)/(I1 I2 I3)``,
    modulus ``m = k^2 = (I2 - I1)(2E I3 - M^2)/((I3 - I2)(M^2 - 2E I1))``.
    (Check: ``cn' = -sn dn``, so ``A w I1 = (I3 - I2) B C``, which the
    amplitudes satisfy.) ``s = sign W3(0)``: the equations are invariant under
    ``(W2, W3) -> (-W2, -W3)``. ``u0`` is the incomplete elliptic integral
    ``F(phi0 | m)`` with ``phi0 = atan2(s W2(0)/B, W1(0)/A)`` (the amplitude).
    Computed at the current mpmath precision with ``mpmath.ellipfun``.
    """
    I1, I2, I3 = (mpmath.mpf(v) for v in I)
    if not (I1 < I2 < I3):
        raise ValueError("the closed form needs I1 < I2 < I3")
    p = [mpmath.mpf(v) for v in pi0]
    M2 = mpmath.fsum(v * v for v in p)
    E2 = p[0] ** 2 / I1 + p[1] ** 2 / I2 + p[2] ** 2 / I3  # 2E
    if not M2 > E2 * I2:
        raise ValueError("the closed form here covers M^2 > 2 E I2 (rotation about the I3 axis)")
    A = mpmath.sqrt((E2 * I3 - M2) / (I1 * (I3 - I1)))
    B = mpmath.sqrt((E2 * I3 - M2) / (I2 * (I3 - I2)))
    C = mpmath.sqrt((M2 - E2 * I1) / (I3 * (I3 - I1)))
    w = mpmath.sqrt((I3 - I2) * (M2 - E2 * I1) / (I1 * I2 * I3))
    m = (I2 - I1) * (E2 * I3 - M2) / ((I3 - I2) * (M2 - E2 * I1))
    W0 = [p[0] / I1, p[1] / I2, p[2] / I3]
    s = 1 if W0[2] > 0 else -1
    phi0 = mpmath.atan2(s * W0[1] / B, W0[0] / A)
    u = mpmath.ellipf(phi0, m) + w * mpmath.mpf(t)
    sn, cn, dn = (mpmath.ellipfun(kind, u, m=m) for kind in ("sn", "cn", "dn"))
    return [I1 * A * cn, I2 * s * B * sn, I3 * s * C * dn]
