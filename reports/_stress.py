"""Numerical stability sweeps behind ``tstarg stress`` (issue 7, deliverable 2).

A *sweep* is a list of points along which one parameter drives the fast
implementation toward a hard regime:

``degenerate-*``
    toward the degenerate set ``Pi_1 = {Delta = det Phi = 0}`` (vier12): for
    su(2) with ``Upsilon = tau.eps`` along ``C1 = 1 - pi'.tau = delta``
    (section cinq, ``Delta = C1^2``), for other algebras along
    ``pi = s* (1 - delta) v`` where ``-1/s*`` is a real eigenvalue of
    ``S(v) Upsilon`` (so ``Phi(s* v)`` is singular), ``delta = 10^-1 .. 10^-15``;
    the su(2) sweep ends on a point with ``C1 = 0`` exactly.
``momenta-*``
    ``|pi| = 1 .. 1e12`` along a fixed direction.
``basis-su2``
    su(2) in the basis ``e'_a = C^b_a e_b`` (:meth:`LieAlgebra.change_basis`,
    exact rational ``C`` with ``det C = 2 eps``, ``cond(C) = 1 .. 5e10``); Theta,
    Upsilon, x and pi transformed with it (``Theta' = C^T Theta C``,
    ``Upsilon' = C^-1 Upsilon C^-T``, ``x' = C^-1 x``, ``pi' = C^T pi``).
``basis-su2-upsilon0``, ``field-basis-su2``
    the same with ``Upsilon = 0``; for the vector field ``I' = C^T I C`` (so
    ``K = 1/2 pi'.I'^-1 pi'`` is the same function) and no potential.
``upsilon-*``
    ``Upsilon`` scaled by ``1 .. 1e8``.
``field-degenerate-su2``
    the Hamiltonian vector field (vier10, vier11) of the heavy top along the
    su(2) degenerate sweep.
``brouwer``
    a long integration: the energy error of DOP853 at a fixed step where the
    truncation error is far below round-off, RMS over an ensemble of
    trajectories, fitted by ``c t^p``; Brouwer's law (rounding errors as a
    random walk) predicts ``p = 1/2``.

Every point is judged against the mpmath reference (the judge) at
``judge_dps`` and ``judge_dps + 20`` digits, on the same float64 inputs taken
as exact binary numbers; the two rungs must agree to ``JUDGE_MIN_DIGITS``.
Per point: ``digits lost = D64 - digits obtained`` with
``D64 = -log10(eps/2) = 15.95`` and ``digits obtained = -log10(err / max(1,
max|ref|))`` (docs/conventions.md), the error model's prediction (the same with the
fast ``error_bound``), and the outcome of :mod:`refimpl.escalate` at the
requested tolerance:

* ``ok``: not flagged, not escalated, error <= tol * max(1, max|ref|);
* ``escalated``: recomputed in mpmath and then within the tolerance;
* ``flagged``: marked as not within the tolerance (never dropped);
* ``SILENT FAILURE``: returned as within the tolerance but the error exceeds it.

``bound held`` records ``err <= error_bound`` for the fast value (where it is
finite) and for the value returned after escalation.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import mpmath
import numpy as np

from ._imports import resolve

EPS = float(np.finfo(float).eps)
D64 = -math.log10(EPS / 2)  # digits float64 can give: 15.95
JUDGE_MIN_DIGITS = 25  # the judge's two rungs must agree to this many digits
OUTCOMES = ("ok", "escalated", "flagged", "SILENT FAILURE")


@dataclass
class Sweep:
    """One sweep: ``points`` are dicts of float64 inputs plus ``param`` (the swept quantity)."""

    name: str
    title: str
    kind: str  # "poisson" or "field"
    algebra: str
    param: str  # label of the swept parameter
    description: str
    points: list = field(default_factory=list)


# ---------------------------------------------------------------- building
def _antisym(A: np.ndarray) -> np.ndarray:
    return A - A.T  # exactly antisymmetric in float64 (a - b = -(b - a))


def _tau_matrix(tau) -> np.ndarray:
    """``Upsilon^mn = tau_l eps_lmn`` (docs/conventions.md, section cinq)."""
    t0, t1, t2 = (float(v) for v in tau)
    return np.array([[0.0, t2, -t1], [-t2, 0.0, t0], [t1, -t0, 0.0]])


def _xi_theta(xi) -> np.ndarray:
    """``Theta_ab = -xi_k eps_kab`` (a coboundary, zeven3)."""
    x0, x1, x2 = (float(v) for v in xi)
    return -np.array([[0.0, x2, -x1], [-x2, 0.0, x0], [x1, -x0, 0.0]])


SU2_TAU = np.array([0.25, -0.5, 0.5])  # dyadic, so that C1 = 0 can be hit exactly
SU2_XI = np.array([0.125, 0.25, -0.125])
SU2_X = np.array([0.3, -0.2, 0.5])
HEAVY_TOP = {
    "inertia": np.diag([1.0, 2.0, 3.0]),
    "potential": {"kind": "gravity", "L": [0.0, 0.0, 1.0], "gamma": [0.1, 0.2, 0.97]},
}


def _su2_degenerate_points(ks) -> list[dict]:
    """``pi' = pi + xi`` with ``pi'.tau = 1 - delta`` plus a part orthogonal to tau; ``Delta = C1^2``."""
    from tstarg.refimpl import su2

    f = su2().f
    d = SU2_TAU / (SU2_TAU @ SU2_TAU)
    w = np.array([0.2, 0.3, 0.0])
    w = w - (w @ SU2_TAU) * d
    pts = []
    for k in ks:
        delta = 10.0**-k
        pi = (1 - delta) * d - SU2_XI + w
        pts.append(
            {
                "f": f,
                "theta": _xi_theta(SU2_XI),
                "upsilon": _tau_matrix(SU2_TAU),
                "x": SU2_X.copy(),
                "pi": pi,
                "param": 1.0 / delta,
                "label": f"C1 = 1e-{k}",
            }
        )
    # C1 = 0 exactly: pi' = (0, 0, 2), pi'.tau = 1 in binary arithmetic
    pts.append(
        {
            "f": f,
            "theta": _xi_theta(SU2_XI),
            "upsilon": _tau_matrix(SU2_TAU),
            "x": SU2_X.copy(),
            "pi": np.array([0.0, 0.0, 2.0]) - SU2_XI,
            "param": math.inf,
            "label": "C1 = 0 exactly",
        }
    )
    return pts


def _singular_direction(alg, seed: int):
    """``(Upsilon, v, s*)`` with ``Phi(s* v) = 1 + s* S(v) Upsilon`` singular (theta = 0).

    ``-1/s*`` is the real eigenvalue of ``S(v) Upsilon`` of largest modulus,
    found at 50 digits by mpmath; seeds are tried in order until one exists.
    """
    n = alg.dim
    for s in range(seed, seed + 50):
        rng = np.random.default_rng(s)
        U = _antisym(rng.standard_normal((n, n)) / 2)
        v = rng.standard_normal(n)
        S = np.einsum("m,mab->ab", v, alg.f)
        with mpmath.workdps(50):
            M = mpmath.matrix(S.tolist()) * mpmath.matrix(U.tolist())
            ev = mpmath.eig(M, left=False, right=False)
            real = [
                mpmath.re(e)
                for e in ev
                if abs(mpmath.im(e)) < mpmath.mpf(10) ** -20 and abs(e) > 1e-3
            ]
            if real:
                lam = max(real, key=abs)
                return U, v, -1 / lam, rng
    raise RuntimeError(
        f"no real eigenvalue of S(v) Upsilon found for {alg.name}"
    )  # pragma: no cover


def _generic_degenerate_points(name: str, ks, seed: int = 0) -> list[dict]:
    from tstarg.refimpl import catalogue

    alg = catalogue(name)
    n = alg.dim
    U, v, sstar, rng = _singular_direction(alg, seed)
    x = 0.3 * rng.standard_normal(n)
    pts = []
    for k in ks:
        delta = mpmath.mpf(10) ** -k
        with mpmath.workdps(50):
            s = float(sstar * (1 - delta))
        pts.append(
            {
                "f": alg.f,
                "theta": np.zeros((n, n)),
                "upsilon": U,
                "x": x,
                "pi": s * v,
                "param": 10.0**k,
                "label": f"delta = 1e-{k}",
            }
        )
    return pts


def _momenta_points(name: str, ks) -> list[dict]:
    from tstarg.refimpl import catalogue

    alg = catalogue(name)
    n = alg.dim
    rng = np.random.default_rng(11)
    if name == "su(2)":
        U, theta, x = _tau_matrix(0.1 * SU2_TAU), _xi_theta(SU2_XI), SU2_X.copy()
    else:
        U, theta, x = (
            _antisym(0.05 * rng.standard_normal((n, n))),
            np.zeros((n, n)),
            0.3 * rng.standard_normal(n),
        )
    u = rng.standard_normal(n)
    u /= np.linalg.norm(u)
    return [
        {
            "f": alg.f,
            "theta": theta,
            "upsilon": U,
            "x": x,
            "pi": 10.0**k * u,
            "param": 10.0**k,
            "label": f"|pi| = 1e{k}",
        }
        for k in ks
    ]


def _upsilon_points(name: str, ks) -> list[dict]:
    from tstarg.refimpl import catalogue

    alg = catalogue(name)
    n = alg.dim
    rng = np.random.default_rng(12)
    if name == "su(2)":
        U0, theta, x, pi = (
            _tau_matrix(SU2_TAU / 0.75),
            _xi_theta(SU2_XI),
            SU2_X.copy(),
            np.array([0.3, 0.2, -0.4]),
        )
    else:
        U0, theta = _antisym(rng.standard_normal((n, n)) / 2), np.zeros((n, n))
        x, pi = 0.3 * rng.standard_normal(n), rng.standard_normal(n)
    return [
        {
            "f": alg.f,
            "theta": theta,
            "upsilon": 10.0**k * U0,
            "x": x,
            "pi": pi,
            "param": 10.0**k,
            "label": f"|Upsilon| x 1e{k}",
        }
        for k in ks
    ]


def _basis_points(ks, upsilon: bool = True, kind: str = "poisson") -> list[dict]:
    """su(2) in an ill-conditioned exact rational basis (det C = 2 eps); Upsilon = 0 when not ``upsilon``."""
    import sympy

    from tstarg.refimpl import su2

    base = su2()
    theta0, U0 = _xi_theta(SU2_XI), _tau_matrix(SU2_TAU)
    pts = []
    for k in ks:
        e = sympy.Rational(1, 10**k)
        C = sympy.Matrix([[1, 1, 1], [1, 1 + e, 1], [0, 1, 2]]) if k > 0 else sympy.eye(3)
        alg = base.change_basis(np.array(C.tolist(), dtype=object))
        Ci = C.inv()
        th = np.array((C.T * sympy.Matrix(_rat(theta0)) * C).tolist(), dtype=float)
        up = np.array((Ci * sympy.Matrix(_rat(U0)) * Ci.T).tolist(), dtype=float)
        Cf = np.array(C.tolist(), dtype=float)
        # x' along C^-1 x, scaled to ||ad_x'||_F = 1/2: inside the chart and cheap for the reference's series
        u = np.array((Ci * sympy.Matrix(_rat(SU2_X))).tolist(), dtype=float).ravel()
        x = 0.5 * u / np.linalg.norm(np.einsum("a,mab->mb", u, alg.f))
        pi = Cf.T @ np.array([0.3, 0.2, -0.4])
        pts.append(
            {
                "f": alg.f,
                "theta": th,
                "upsilon": up if upsilon else np.zeros((3, 3)),
                "x": x,
                "pi": pi,
                "param": float(np.linalg.cond(Cf)),
                "label": f"eps = 1e-{k}",
            }
        )
        if kind == "field":
            pts[-1]["inertia"] = np.array(
                (C.T * sympy.Matrix(_rat(HEAVY_TOP["inertia"])) * C).tolist(), dtype=float
            )
            pts[-1]["potential"] = None
    return pts


def _rat(a):
    import sympy

    a = np.asarray(a, dtype=float)
    return (
        [[sympy.Rational(float(v)) for v in row] for row in a]
        if a.ndim == 2
        else [[sympy.Rational(float(v))] for v in a]
    )


def _field_points(ks) -> list[dict]:
    pts = _su2_degenerate_points(ks)
    for p in pts:
        p["inertia"] = HEAVY_TOP["inertia"]
        p["potential"] = HEAVY_TOP["potential"]
    return pts


CHART_EDGE_FRACTIONS = (0.5, 0.9, 0.99, 1 - 1e-4, 1 - 1e-6, 1 - 1e-8)
"""Points inside the chart, as fractions of the edge rho(x) = 2 pi."""
CHART_OUTSIDE = (1 + 1e-9, 1.5, 2 - 1e-10, 2.0, 3.0, 1e5, 1e300)
"""Points past the edge, as multiples of 2 pi (rho(x) / 2 pi): every one must be flagged (the
reference refuses them; su(2) between 2 pi and 4 pi is where the fast bound used to fail). The
edge itself is left out: within float64 rounding of it the judge's two rungs may disagree on
whether the point is inside (the fast implementation flags it; tests/test_hardening_api.py)."""


def _chart_points(name: str, quick: bool) -> list[dict]:
    """``x = s u`` with ``rho(u) = max |Im eig ad_u| = 1`` and ``s = 2 pi c``, ``c`` from
    :data:`CHART_EDGE_FRACTIONS` (inside) and :data:`CHART_OUTSIDE` (at or past the edge); Upsilon and
    Theta nonzero, so the whole formula (vier9) is exercised."""
    from tstarg.refimpl import catalogue

    alg = catalogue(name)
    n = alg.dim
    rng = np.random.default_rng(13)
    if name == "su(2)":
        U, theta, u, pi = (
            _tau_matrix(SU2_TAU),
            _xi_theta(SU2_XI),
            SU2_X.copy(),
            np.array([0.3, 0.2, -0.4]),
        )
    else:
        U, theta = _antisym(0.3 * rng.standard_normal((n, n))), np.zeros((n, n))
        u, pi = rng.standard_normal(n), 0.5 * rng.standard_normal(n)
    rho = float(np.max(np.abs(np.linalg.eigvals(np.einsum("a,mab->mb", u, alg.f)).imag)))
    u = u / rho
    cs = (CHART_EDGE_FRACTIONS[::2] + (1 - 1e-8,) if quick else CHART_EDGE_FRACTIONS) + (
        (1 + 1e-9, 1.5, 2 - 1e-10, 1e300) if quick else CHART_OUTSIDE
    )
    out = []
    for c in cs:
        with np.errstate(over="ignore"):
            x = (2 * np.pi * c) * u
        if not np.all(np.isfinite(x)) or np.max(np.abs(x)) > 1e300:  # the magnitude boundary
            x = np.clip(np.where(np.isfinite(x), x, np.sign(u) * 1e300), -1e300, 1e300)
        # the 1e300 point is drawn at the plot's edge (a log axis overflows there): param inf
        out.append(
            {
                "f": alg.f,
                "theta": theta,
                "upsilon": U,
                "x": x,
                "pi": pi,
                "param": c if c < 1e100 else math.inf,
                "label": f"rho(x) = 2 pi x {c:.12g}",
            }
        )
    return out


def build_sweeps(quick: bool = False, only: list[str] | None = None) -> list[Sweep]:
    """The sweeps of a run (``quick``: a few points each, no su(3))."""
    ks_deg = [2, 6, 10, 14] if quick else list(range(1, 16))
    ks_mom = [0, 6, 12] if quick else list(range(13))
    ks_basis = [0, 5, 10] if quick else list(range(11))
    ks_ups = [0, 4, 8] if quick else list(range(9))
    ks_basis_field = [0, 2, 4] if quick else list(range(7))
    sweeps = [
        Sweep(
            "degenerate-su2",
            "su(2), Upsilon = tau.eps: toward C1 = 1 - pi'.tau = 0",
            "poisson",
            "su(2)",
            "1/C1",
            "Delta = C1^2 -> 0 (section cinq); the last point has C1 = 0 exactly",
            _su2_degenerate_points(ks_deg),
        ),
        Sweep(
            "degenerate-bianchi-vi",
            "Bianchi VI_h (h = -1/4, class B): toward Delta = 0",
            "poisson",
            "Bianchi VI_h(h=-1/4)",
            "1/delta",
            "pi = s*(1 - delta) v with Phi(s* v) singular",
            _generic_degenerate_points("Bianchi VI_h(h=-1/4)", ks_deg),
        ),
        Sweep(
            "momenta-su2",
            "su(2), large momenta",
            "poisson",
            "su(2)",
            "|pi|",
            "|pi| = 1 .. 1e12",
            _momenta_points("su(2)", ks_mom),
        ),
        Sweep(
            "momenta-se3",
            "se(3) (generic path), large momenta",
            "poisson",
            "se(3)",
            "|pi|",
            "|pi| = 1 .. 1e12",
            _momenta_points("se(3)", ks_mom),
        ),
        Sweep(
            "basis-su2",
            "su(2) in an ill-conditioned basis",
            "poisson",
            "su(2)[basis changed]",
            "cond(C)",
            "LieAlgebra.change_basis(C), cond(C) = 1 .. 5e10",
            _basis_points(ks_basis),
        ),
        Sweep(
            "basis-su2-upsilon0",
            "su(2) in an ill-conditioned basis, Upsilon = 0",
            "poisson",
            "su(2)[basis changed]",
            "cond(C)",
            "LieAlgebra.change_basis(C), cond(C) = 1 .. 5e10, Upsilon = 0",
            _basis_points(ks_basis, upsilon=False),
        ),
        Sweep(
            "upsilon-su2",
            "su(2), large Upsilon",
            "poisson",
            "su(2)",
            "scale of Upsilon",
            "Upsilon = s tau.eps, s = 1 .. 1e8",
            _upsilon_points("su(2)", ks_ups),
        ),
        Sweep(
            "upsilon-so4",
            "so(4) (generic path), large Upsilon",
            "poisson",
            "so(4)",
            "scale of Upsilon",
            "Upsilon = s U0, s = 1 .. 1e8",
            _upsilon_points("so(4)", ks_ups),
        ),
        Sweep(
            "field-basis-su2",
            "heavy-top-free field of su(2) in an ill-conditioned basis, Upsilon = 0",
            "field",
            "su(2)[basis changed]",
            "cond(C)",
            "vier10/vier11 with I' = C^T diag(1, 2, 3) C, V = 0; cond(C) = 1 .. 5e6 (I' stays positive definite "
            "in float64)",
            _basis_points(ks_basis_field, upsilon=False, kind="field"),
        ),
        Sweep(
            "field-degenerate-su2",
            "heavy top vector field (vier10, vier11) toward C1 = 0",
            "field",
            "su(2)",
            "1/C1",
            "I = diag(1, 2, 3), gravity L = e3",
            _field_points(ks_deg),
        ),
        Sweep(
            "chart-su2",
            "su(2) (closed form), Upsilon != 0: up to and past the chart edge |x| = 2 pi",
            "poisson",
            "su(2)",
            "rho(x) / 2 pi",
            "x = s u, rho = |x|; past the edge every point must be flagged",
            _chart_points("su(2)", quick),
        ),
        Sweep(
            "chart-so4",
            "so(4) (generic path), Upsilon != 0: up to and past the chart edge",
            "poisson",
            "so(4)",
            "rho(x) / 2 pi",
            "x = s u, rho = max |Im eig ad_x|; past the edge every point must be flagged",
            _chart_points("so(4)", quick),
        ),
    ]
    if not quick:
        sweeps.insert(
            2,
            Sweep(
                "degenerate-su3",
                "su(3) (8-dim, generic path): toward Delta = 0",
                "poisson",
                "su(3)",
                "1/delta",
                "pi = s*(1 - delta) v with Phi(s* v) singular",
                _generic_degenerate_points("su(3)", list(range(1, 16, 2))),
            ),
        )
    if only:
        known = {s.name for s in sweeps} | {"brouwer"}
        bad = [o for o in only if o not in known]
        if bad:
            raise ValueError(f"unknown sweep(s) {bad}; known: {sorted(known)}")
        sweeps = [s for s in sweeps if s.name in only]
    return sweeps


# ------------------------------------------------------------------ tasks
def load_implementation(spec: str):
    """``module:object`` -> the object (it must provide ``poisson_batch`` / ``vector_field_batch``)."""
    if not isinstance(spec, str) or ":" not in spec:
        raise ValueError(f"implementation must be given as 'module:object', got {spec!r}")
    return resolve(spec, what="implementation")


def _judge(item: dict, dps: int):
    """The reference values (flat list of mpf) at ``dps`` digits, or None on the degenerate set / off chart."""
    from tstarg.refimpl.reference import DegeneratePointError, Reference

    ref = Reference(dps)
    try:
        if item["kind"] == "poisson":
            M = ref.poisson_tensor_mp(
                item["f"], item["theta"], item["upsilon"], item["x"], item["pi"]
            )
            return [M[i, j] for i in range(M.rows) for j in range(M.cols)], ""
        xd, pd = ref.hamiltonian_vector_field_mp(
            item["f"],
            item["theta"],
            item["upsilon"],
            item["inertia"],
            item["potential"],
            item["x"],
            item["pi"],
        )
        return [xd[i] for i in range(xd.rows)] + [pd[i] for i in range(pd.rows)], ""
    except DegeneratePointError:
        return None, "degenerate"
    except ValueError as exc:
        return None, f"refused: {exc}"
    except TypeError as exc:
        # mpmath 1.3 det/LU raise TypeError on a matrix with an exactly zero pivot column
        # (mpmath issue #542, fixed after 1.3.0): Phi is exactly singular there.
        if "NoneType" in str(exc):
            return None, "degenerate (mpmath #542: det of an exactly singular Phi raised TypeError)"
        raise


def _phi_condition(item: dict, dps: int) -> tuple[float, float]:
    """``(cond_2(Phi), |Delta|)`` of the float64 inputs, at ``dps`` digits (singular values by mpmath)."""
    f, th, up, pi = (np.asarray(item[k], dtype=float) for k in ("f", "theta", "upsilon", "pi"))
    n = f.shape[0]
    with mpmath.workdps(dps):
        S = mpmath.matrix(n, n)
        for a in range(n):
            for b in range(n):
                S[a, b] = mpmath.fsum(
                    mpmath.mpf(float(pi[m])) * mpmath.mpf(float(f[m, a, b])) for m in range(n)
                ) - mpmath.mpf(float(th[a, b]))
        Phi = mpmath.eye(n) + S * mpmath.matrix(up.tolist())
        sv = mpmath.svd_r(Phi, compute_uv=False)
        smax, smin = max(sv), min(sv)
        cond = math.inf if smin == 0 else float(smax / smin)
        try:
            delta = float(abs(mpmath.det(Phi)))
        except TypeError:  # mpmath #542: exactly singular with a zero pivot column
            delta = 0.0
        return cond, delta


def _err(values, ref, dps: int) -> tuple[float, float]:
    """``(max |values - ref|, max(1, max|ref|))``; the error is NaN if any value is not finite."""
    with mpmath.workdps(dps):
        scale = max([mpmath.mpf(1)] + [abs(r) for r in ref])
        if not all(math.isfinite(float(v)) for v in values):
            return math.nan, float(scale)
        err = max(abs(mpmath.mpf(float(v)) - r) for v, r in zip(values, ref))
        return float(err), float(scale)


def _lost(err: float, scale: float) -> float:
    """Digits lost: ``D64 - digits obtained`` (clipped at 0); all of them for a NaN answer."""
    if not math.isfinite(err):
        return D64
    if err == 0:
        return 0.0
    return max(0.0, D64 + math.log10(err / scale))


def point_task(item: dict) -> dict:
    """Run one sweep point: escalate.py at the requested tolerance, then judge it. Deterministic in ``item``."""
    from tstarg.refimpl.escalate import poisson_within, vector_field_within

    t0 = time.perf_counter()
    impl = load_implementation(item["implementation"])
    tol, esc = item["tol"], item["escalate"]
    x, pi = np.asarray(item["x"])[None], np.asarray(item["pi"])[None]
    with np.errstate(all="ignore"):
        if item["kind"] == "poisson":
            w = poisson_within(
                item["f"], item["theta"], item["upsilon"], x, pi, tol, escalate=esc, fast=impl
            )
            fast_vals = np.asarray(w.fast.P, dtype=float)[0].ravel()
            final = w.P[0].ravel()
        else:
            w = vector_field_within(
                item["f"],
                item["theta"],
                item["upsilon"],
                item["inertia"],
                item["potential"],
                x,
                pi,
                tol,
                escalate=esc,
                fast=impl,
            )
            fast_vals = np.concatenate(
                [np.asarray(w.fast.xdot, dtype=float)[0], np.asarray(w.fast.pidot, dtype=float)[0]]
            )
            final = np.concatenate([w.xdot[0], w.pidot[0]])
    jd = item["judge_dps"]
    ref, _ = _judge(item, jd)
    ref2, why2 = _judge(item, jd + 20)
    row = {
        "sweep": item["sweep"],
        "index": item["index"],
        "label": item["label"],
        "param": item["param"],
        "fast_cond_phi": float(np.asarray(w.fast.cond_phi).ravel()[0]),
        "fast_cond_data": float(np.asarray(w.fast.cond_data).ravel()[0]),
        "fast_degenerate": bool(np.asarray(w.fast.degenerate).ravel()[0]),
        "bound_fast": float(np.asarray(w.fast.error_bound, dtype=float).ravel()[0]),
        "bound_final": float(w.error_bound[0]),
        "flagged": bool(w.flagged[0]),
        "escalated": bool(w.escalated[0]),
        "escalation_dps": int(w.dps[0]),
        "reason": str(w.reason[0]),
        "tol": tol,
    }
    row["cond_phi_true"], row["delta_abs"] = _phi_condition(item, jd + 20)
    judge_ok = (ref is None) == (ref2 is None)
    if ref is not None and ref2 is not None:
        d12, _ = _judge_agreement(ref, ref2, jd + 40)
        row["judge_digits"] = d12
        judge_ok = d12 >= JUDGE_MIN_DIGITS
    else:
        row["judge_digits"] = None
    row["judge_ok"] = bool(judge_ok)
    row["judge_degenerate"] = ref2 is None
    row["judge_note"] = why2
    if ref2 is None:
        # no Poisson tensor / vector field exists at the point: the only right answer is a flag
        row.update(
            err_fast=math.nan,
            err_final=math.nan,
            scale=math.nan,
            allowed=math.nan,
            lost_fast=D64,
            lost_predicted=D64,
            lost_final=D64,
            bound_held_fast=True,
            bound_held_final=True,
        )
        returned_finite = bool(np.all(np.isfinite(final)))
        row["outcome"] = (
            "flagged" if row["flagged"] else ("SILENT FAILURE" if returned_finite else "flagged")
        )
        if not row["flagged"]:
            row["reason"] = "judge: degenerate, but the point was not flagged"
    else:
        e_fast, scale = _err(fast_vals, ref2, jd + 40)
        e_final, _ = _err(final, ref2, jd + 40)
        allowed = tol * scale
        bf, bfin = row["bound_fast"], row["bound_final"]
        row.update(
            err_fast=e_fast,
            err_final=e_final,
            scale=scale,
            allowed=allowed,
            lost_fast=_lost(e_fast, scale),
            lost_predicted=(
                D64
                if not math.isfinite(bf)
                else max(0.0, D64 + math.log10(max(bf, 1e-300) / scale))
            ),
            lost_final=_lost(e_final, scale),
        )
        # the fast error model must hold wherever it claims a finite bound
        row["bound_held_fast"] = (not math.isfinite(bf)) or (math.isfinite(e_fast) and e_fast <= bf)
        row["bound_held_final"] = row["flagged"] or (math.isfinite(e_final) and e_final <= bfin)
        if row["flagged"]:
            row["outcome"] = "flagged"
        elif math.isfinite(e_final) and e_final <= allowed:
            row["outcome"] = "escalated" if row["escalated"] else "ok"
        else:
            row["outcome"] = "SILENT FAILURE"
    row["seconds"] = time.perf_counter() - t0
    return row


def _judge_agreement(a, b, dps: int) -> tuple[float, float]:
    """Digits of agreement of the judge's two rungs, ``-log10(max|a - b| / max(1, max|b|))``."""
    with mpmath.workdps(dps):
        scale = max([mpmath.mpf(1)] + [abs(v) for v in b])
        d = max(abs(x - y) for x, y in zip(a, b))
        return (math.inf if d == 0 else float(-mpmath.log10(d / scale))), float(scale)


# ------------------------------------------------------------ Brouwer's law
def brouwer_model():
    """The free rigid body on su(2) (Upsilon = 0, Theta = 0, I = diag(1, 2, 3)): energy is conserved."""
    from tstarg.refimpl import su2

    return su2().f, np.zeros((3, 3)), np.zeros((3, 3)), np.diag([1.0, 2.0, 3.0])


def _energy_exact(pi: np.ndarray, inertia: np.ndarray, dps: int = 40) -> list:
    """``H = 1/2 pi.I^-1 pi`` of float64 states, evaluated exactly enough (``dps`` digits) per column."""
    d = np.diag(inertia)
    with mpmath.workdps(dps):
        return [
            mpmath.fsum(
                mpmath.mpf(float(pi[a, j])) ** 2 / (2 * mpmath.mpf(float(d[a])))
                for a in range(pi.shape[0])
            )
            for j in range(pi.shape[1])
        ]


def brouwer_task(item: dict) -> dict:
    """One chunk of trajectories: energy errors at the sample steps (exact evaluation of the float states)."""
    from tstarg.refimpl.flows import METHODS, NumpyModel, integrate_fast

    f, th, up, inertia = brouwer_model()
    model = NumpyModel(f, th, up, inertia, None)
    rng = np.random.default_rng(item["seed"])
    N = item["trajectories"]
    pi0 = rng.standard_normal((3, N))
    pi0 /= np.linalg.norm(pi0, axis=0)
    x0 = np.zeros((3, N))
    nsteps, T = item["nsteps"], item["T"]
    samples = {int(k) for k in item["sample_steps"]}
    rec: dict[int, np.ndarray] = {}

    def observe(k, pi, G, x):
        if k in samples:
            rec[k] = pi.copy()

    t0 = time.perf_counter()
    integrate_fast(
        model, METHODS[item["method"]], x0, pi0, T, nsteps, system="body", observe=observe
    )
    seconds = time.perf_counter() - t0
    E0 = _energy_exact(pi0, inertia)
    steps = sorted(rec)
    errs = []
    for k in steps:
        E = _energy_exact(rec[k], inertia)
        with mpmath.workdps(40):
            errs.append([float(E[j] - E0[j]) for j in range(N)])
    return {
        "steps": steps,
        "errors": errs,
        "seconds": seconds,
        "chunk": item["chunk"],
        "h": T / nsteps,
        "tag": item["tag"],
    }


def fit_exponent(t, err) -> tuple[float, float]:
    """Least-squares fit ``log err = log c + p log t``; returns ``(p, c)``. Points with err <= 0 are refused."""
    t = np.asarray(t, dtype=float)
    err = np.asarray(err, dtype=float)
    if t.shape != err.shape or t.ndim != 1 or t.size < 3:
        raise ValueError(
            f"fit_exponent needs two 1-d arrays of equal length >= 3, got {t.shape} and {err.shape}"
        )
    if not (
        np.all(t > 0) and np.all(err > 0) and np.all(np.isfinite(t)) and np.all(np.isfinite(err))
    ):
        raise ValueError("fit_exponent needs finite, positive times and errors")
    p, logc = np.polyfit(np.log(t), np.log(err), 1)
    return float(p), float(np.exp(logc))


def brouwer_items(
    quick: bool,
    T: float | None,
    trajectories: int | None,
    h: float = 0.05,
    chunk: int = 32,
    method: str = "dop853",
) -> list[dict]:
    """Chunks of the ensemble at step ``h``, plus one chunk at ``2h`` (the truncation check)."""
    T = float(T if T is not None else (100.0 if quick else 10000.0))
    N = int(trajectories if trajectories is not None else (16 if quick else 128))
    if not (T > 0 and math.isfinite(T)):
        raise ValueError(f"brouwer time must be a finite number > 0, got {T}")
    if N < 1:
        raise ValueError(f"brouwer trajectories must be >= 1, got {N}")
    items = []
    for tag, hh in (("h", h), ("2h", 2 * h)):
        nsteps = max(10, round(T / hh))
        sample_steps = sorted(
            set(np.unique(np.round(np.logspace(1, math.log10(nsteps), 40)).astype(int)).tolist())
        )
        nchunks = math.ceil(N / chunk) if tag == "h" else 1
        for c in range(nchunks):
            size = min(chunk, N - c * chunk)
            items.append(
                {
                    "task": "brouwer",
                    "tag": tag,
                    "chunk": c,
                    "seed": 1000 + c,
                    "trajectories": size,
                    "T": T,
                    "nsteps": nsteps,
                    "sample_steps": sample_steps,
                    "method": method,
                }
            )
    return items


def summarize_brouwer(results: list[dict], fit_from_steps: int = 100) -> dict:
    """Ensemble RMS energy error against t, the fitted exponent and the truncation check."""
    main = [r for r in results if r["tag"] == "h"]
    h = main[0]["h"]
    steps = main[0]["steps"]
    errs = np.concatenate(
        [np.asarray(r["errors"]) for r in main], axis=1
    )  # (samples, trajectories)
    rms = np.sqrt(np.mean(errs**2, axis=1))
    t = np.asarray(steps, dtype=float) * h
    fit_from_steps = min(
        fit_from_steps, max(1, steps[-1] // 10)
    )  # short runs: fit their last decade
    sel = (np.asarray(steps) >= fit_from_steps) & (rms > 0)
    p, c = fit_exponent(t[sel], rms[sel])
    check = next(r for r in results if r["tag"] == "2h")
    same = errs[:, : np.asarray(check["errors"]).shape[1]]
    rms_h_end = float(np.sqrt(np.mean(same[-1] ** 2)))
    rms_2h_end = float(np.sqrt(np.mean(np.asarray(check["errors"])[-1] ** 2)))
    return {
        "h": h,
        "T": float(t[-1]),
        "trajectories": int(errs.shape[1]),
        "t": t.tolist(),
        "rms": rms.tolist(),
        "fit_from_t": float(fit_from_steps * h),
        "exponent": p,
        "coefficient": c,
        "brouwer_exponent": 0.5,
        "consistent_with_brouwer": bool(0.35 <= p <= 0.65),
        "truncation_check": {
            "rms_h": rms_h_end,
            "rms_2h": rms_2h_end,
            "ratio_2h_over_h": (rms_2h_end / rms_h_end) if rms_h_end > 0 else math.inf,
            "round_off_predicts": 2**-0.5,
            "truncation_predicts": 2.0**8,
        },
        "seconds": float(sum(r["seconds"] for r in results)),
    }


def task(item: dict):
    """The one task function of the sweep (a point or a Brouwer chunk); deterministic in ``item``."""
    if item.get("task") == "brouwer":
        return brouwer_task(item)
    return point_task(item)


def point_items(
    sweeps: list[Sweep], tol: float, escalate: bool, judge_dps: int, implementation: str
) -> list[dict]:
    items = []
    for sw in sweeps:
        for i, p in enumerate(sw.points):
            it = {
                k: (
                    np.asarray(v, dtype=float)
                    if k in ("f", "theta", "upsilon", "x", "pi", "inertia")
                    else v
                )
                for k, v in p.items()
            }
            it.update(
                task="point",
                sweep=sw.name,
                index=i,
                kind=sw.kind,
                tol=tol,
                escalate=escalate,
                judge_dps=judge_dps,
                implementation=implementation,
            )
            items.append(it)
    return items


def summarize_points(rows: list[dict]) -> dict:
    counts = {o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES}
    return {
        "points": len(rows),
        "outcomes": counts,
        "silent_failures": counts["SILENT FAILURE"],
        "bound_violations_fast": sum(not r["bound_held_fast"] for r in rows),
        "bound_violations_final": sum(not r["bound_held_final"] for r in rows),
        "judge_problems": sum(not r["judge_ok"] for r in rows),
    }
