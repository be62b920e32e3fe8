"""Flows by the compiled adaptive Taylor methods: body systems and the su(2) full state.

``Upsilon = 0``: the quadratic fields below (:mod:`refimpl._compiled_taylor`); ``Upsilon != 0``: the
rational fields of :mod:`refimpl._compiled_rational` (the solve by Phi as a series recurrence), with the
same state layout and the same two-run control (:func:`_runner` picks the kernel).

Systems
    ``body``: ``(pi)`` or ``(pi, Gamma)`` -- the quadratic field of :func:`refimpl._taylor.quadratic_field`
    (Euler twee14/drie6, Euler-Poisson twee17 sign-corrected/twee18, Theta terms).
    ``full`` (su(2)/so(3)): ``(pi, [Gamma,] q)`` with the group element as the unit quaternion ``q``
    (:func:`refimpl._taylor.quadratic_field_su2_full`, ``dq/dt = q * (0, Omega/2)``), still quadratic, so
    the configuration is integrated by the same Taylor recurrences without any chart or re-basing;
    the output ``x`` is the principal logarithm ``x = 2 atan2(|q|, q_0) q/|q|`` (as the splitting
    methods' :func:`quat_to_x`), equal to the chart coordinate of the re-basing
    methods wherever that never left ``||ad_x||_F <= 1``.

Error control (per trajectory, never shared)
    The kernel's Jorba-Zou control bounds the *local* remainder by ``eps * max(1, ||y||)`` per step. A
    global tolerance ``tol`` (max-norm over ``pi`` and ``Ad(g)``, the absolute error of what the user
    gets) is met by two runs (:func:`local_tolerances`): a checking run ``A`` and the answer ``B``, at
    least ``1/SAFETY = 3.3`` times tighter and near the float64 floor (``eps_B <= 1e-13``). The global
    error of the method scales with ``eps`` (the local remainders do), so ``d = |A - B|`` is about the
    error of ``A`` and exceeds that of ``B``: with ``r = eps_B/eps_A <= 1/2``,
    ``d >= (1 - r) err(A) = (1 - r)/r err(B) >= err(B)``; when ``B`` is far tighter than ``A`` (``eps_A >= 1e-12``), the same
    proportionality (Shampine 1985, global error estimation with two tolerances) gives the smaller
    estimate ``PROP (eps_B / eps_A) d`` with the safety factor ``PROP = 30`` (the ratio global error /
    ``eps`` varies by a factor 2-4 over ``eps`` = 1e-8 ... 1e-13 on the heavy and the asymmetric top).
    ``B`` is returned when the estimate is at most ``tol`` on that trajectory. The quadratic su(2) full
    state (:func:`compiled_taylor_flow`) starts ``A`` at :data:`A_LOOSE_FULL` (one trajectory: ``A``
    and ``B`` in one pass of the pair kernel). A trajectory over ``tol`` is run again with ``eps_A`` lowered by the observed excess (times 10), until it passes
    or ``eps_A`` reaches :data:`EPS_FLOOR` (then ``ValueError`` names it); when the ``B`` it holds is within
    :data:`REUSE_B` of that new ``eps_A``, that ``B`` becomes the new ``A`` and only a new ``B`` (at
    ``SAFETY`` times its tolerance) is run -- the pair still has ``r <= SAFETY``, all the estimate
    asks of it. The full state of every other algebra (:mod:`refimpl._full_state`) runs this same
    control with its own kernel, estimate and constants (``A`` at 1e-6, ``B`` at most 2e-15, the
    proportional estimate down to 1e-15, a rounding floor added through ``floor``). Not seen by ``d``: the rounding of the
    starting point (the same in both runs) amplified by the flow's sensitivity -- about 1e-13 on the
    heavy top over ``T = 100``, 1e-11 on the asymmetric top; tolerances near that floor are refused when
    ``d`` sees it, and are not certified by the two runs otherwise.
"""

from __future__ import annotations

import math

import numpy as np

from . import _compiled_rational as _cr
from . import _compiled_taylor as _ct
from . import _fast_kernels as _fast
from ._flow_checks import admitted, finite_one, point_max
from ._validate import MAX_MAGNITUDE

__all__ = [
    "PATH",
    "compiled_taylor_samples",
    "compiled_taylor_body",
    "compiled_taylor_flow",
    "quat_rotation",
    "quat_to_x",
    "supports_full",
    "x_to_quat",
]

EPS = np.finfo(float).eps
PATH = _ct.PATH
SAFETY = (
    0.3  # B's local tolerance relative to A's, at most (B_MAX caps it further); any r <= 1/2 makes
)
# |A - B| >= err(B) under proportionality, and 0.3 keeps B's extra steps few where A is near the floor
B_MAX = (
    1e-13  # B's local tolerance is never above this: B is the answer, kept near the float64 floor
)
EPS_B_FLOOR = 1e-16  # the floor of B's local tolerance (the Jorba-Zou order 20)
EPS_FLOOR = 1e-14  # the floor of A's local tolerance when a trajectory is run again
A_START_MIN = (
    1e-13  # A's first local tolerance is never below this (global error of A ~ 1e-13 there)
)
A_LOOSE = (
    1e-8  # A's local tolerance for tol >= A_LOOSE_FROM: the cheapest Taylor run on the heavy top
)
# (order 11; looser tolerances lower the order and take more steps)
A_LOOSE_FROM = 1e-10  # from here on 30 kappa 1e-13 <= tol for amplifications kappa = err/eps <= 30
A_LOOSE_FULL = A_LOOSE
"""``A``'s local tolerance for ``tol >= A_LOOSE_FROM`` on the su(2) quaternion full state with
``Upsilon = 0`` (:func:`compiled_taylor_flow`), now :data:`A_LOOSE` (issue 25, session 6; it was 1e-6,
measured below). One trajectory runs ``A`` and ``B`` on the lanes of one vector while both go on (the
pair kernel, :func:`_first_pair`), where ``A`` costs little while it takes fewer steps than ``B``: its tolerance is
chosen for the estimate, and at 1e-8 the first pair fails far less often (2000 starts around each
problem, reports._bench_protocol.batch_initial, T = 100: the fraction whose first pair's estimate is
over the default ``tol = 1e-10``, A at 1e-6 / 1e-7 / 1e-8, B at Jorba-Zou's order 16 where
:data:`FAST_UNROLL_TERMS` allows): the heavy top 26 / 14 / 0 % (A 284 against B 646 steps), the heavy
top with the inertia [[1, 0.1, 0], [0.1, 1.3, -0.05], [0, -0.05, 0.6]] 88 / 75 / 20 % (order 13: 367
against 958 steps), the Lagrange top 0 / 0 / 0 %. A batch (the lane kernel, where ``A`` costs its own
steps), 2000 of those starts, us per trajectory with ``A`` at 1e-6 / 1e-8 (B's order as now, load 2.7):
heavy top 212.5 / 148.2, the off-diagonal inertia 286.1 / 183.8, Lagrange top 74.5 / 81.6. With ``A``
at :data:`A_LOOSE` from the start, the retry of ``A`` alone at :data:`A_LOOSE` that 1e-6 needed (below)
is gone. The coverage ``q`` of the estimate at 1e-8 (below; ``PROP = 30`` must exceed it): at most 2.2, and 2.02 on
seed 11's ten random models with the heavy, Lagrange and asymmetric tops
(``tests/benchmarks/su2_estimate_constants.py 11 10 1e-6,1e-8``).

At 1e-6 (the value before): ``A``'s local tolerance for ``tol >= A_LOOSE_FROM`` on the su(2) quaternion full state with
``Upsilon = 0`` (:func:`compiled_taylor_flow`; the rational path and the sampled flows keep
:data:`A_LOOSE`). ``A`` runs at ``B``'s order (:func:`_run_cf`), so at 1e-6 it takes 28 % fewer steps
than at 1e-8 (heavy top, T = 100: 205 against 285 steps, 98 against 135 us at load 1.5). Measured (the kernel at ``B``'s order, error of ``(pi, Ad(g))`` against heyoka in long
double at tol 1e-19) on the heavy top (I = diag(1, 1.3, 0.6), L = (0.2, 0.1, 1)), the Lagrange top
(diag(1, 1, 0.5), L = e3), the asymmetric top diag(1, 2, 3) at T = 10 and 100, and 26 random su(2)
models (random SPD inertia, half with Theta = -xi.f, two thirds with gravity, T = 10/30/100): the
coverage ``q = err(B) / ((eps_B / eps_A) |A - B|)`` that :data:`PROP` = 30 must exceed is at most 1.02
with ``A`` at 1e-6 (0.74 and 1.02 on two sets of ten random models; 2.2 at 1e-8, 0.47 at 1e-5), chaotic
trajectories included; the pass condition of one pair, ``kappa_A = err(A) / eps_A <= tol / (30
eps_B)`` (33 at the default ``tol``), holds as often as at 1e-8 (heavy top 16 vs 4.9, Lagrange 6.7 vs
7.2; the non-chaotic random models 0.02-110 either way, over 33 on the same two at both), but not
near the heavy top: on the 10^4 starts of its batch (reports._bench_protocol.batch_initial) 27 % fail
one pair at 1e-6, 0.04 % at 1e-8, hence, then, a retry of ``A`` alone at :data:`A_LOOSE` (a rerun of ``B`` at ~3e-14 costs 2.4 times as much): that batch then costs the same
with ``A`` at 1e-8, 1e-7 and 1e-6 (166.7, 166.7, 165.8 us per trajectory, one interleaved run, load
2.0), and one trajectory that passes saves 28 % of ``A``. Script:
``tests/benchmarks/su2_estimate_constants.py``. Seed 5's ten random models (issue 25): q at most 0.66
at 1e-6 where the estimate is used; two chaotic trajectories whose ``A`` saturates (``|A - B|`` 2.7 and
3.3) have q = 3.1 and 1.4e4 -- there the proportional form is no estimate at all, hence
:data:`PROP_MAX_D`."""
PROP_MIN_A = 1e-12  # the proportionality estimate only for A at this local tolerance or looser
PROP_MIN_B = 1e-14  # ... and B at this local tolerance or looser
PROP = 30.0  # safety factor of the proportionality estimate err(B) ~ (eps_B / eps_A) |A - B|
PROP_MAX_D = 1e-3
"""The proportional estimate only while ``|A - B| <= PROP_MAX_D`` (absolute, the units of ``tol``): its
premise, ``err(A) = kappa eps_A`` with the ``kappa`` of ``B``, holds while ``A``'s deviation stays small
enough for the error to grow linearly; a chaotic trajectory whose ``A`` has wandered off by ``O(1)``
(saturated) gives ``|A - B|`` unrelated to ``eps_A``, and ``(eps_B / eps_A) |A - B|`` then says nothing of
``B``. Seen (issue 25, ``tests/benchmarks/su2_estimate_constants.py 5 10``, model ``rand5_4``: random
inertia, Theta and gravity, T = 100): ``A`` at 1e-6 off by ``|A - B| = 3.3``, the proportional estimate
9.99e-6 passed ``tol = 1e-5`` while ``B``'s error against heyoka in long double was 4.62e-3 (its
amplification ``err / eps`` 4.6e10 at 1e-13). Past the threshold the estimate is ``|A - B|`` itself and
the control tightens ``A`` as for any failing pair. 1e-3: ``A``'s deviation a thousandth of the state's
unit scale, where the second-order term of the error's growth is that fraction of the first; the bench
tops sit at 1e-5 (heavy top, ``kappa`` 16 at 1e-6) and below."""
REUSE_B = 10.0  # a held B within this factor of A's next tolerance becomes that A (see _control)
FIRST = 1e-2  # A's first local tolerance relative to the global one (global/local error ~ 5-20
# over 10^2-10^3 steps, so one pair of runs usually suffices)
FAST_UNROLL_TERMS = 3700
"""B's order (Jorba-Zou's for its tolerance, 16 at 1e-13) is lowered while the unrolled kernel would
have more than this many Cauchy-product terms (monomials times ``P (P + 1) / 2``): below it every su(2)
full state runs Jorba-Zou's 16 at 1e-13 -- the heavy top with a diagonal inertia (21 monomials), the
Lagrange top (20), any inertia (27). Past about 4000 terms the kernel falls off a cliff (27 monomials
at order 17, 4131 terms: the pair kernel 681 against 386 us at 16, load 1.8). Measured (issue 25, T =
100, the pair kernel alone, B at 1e-13 and A at 1e-6, one interleaved run, load 1.8; errors of B
against heyoka in long double): the inertia [[1, 0.1, 0], [0.1, 1.3, -0.05], [0, -0.05, 0.6]] with
L = (0.2, 0.1, 1): orders 13/14/15/16 470/431/399/386 us, errors 1.3e-12/6.9e-13/4.3e-13/4.2e-13 (the
old cap, 2800 terms, held it at 13); the heavy top diag(1, 1.3, 0.6) 15/16/17/18 321/298/289/284 us,
errors 1.1/1.4/0.25/5.1e-13 (earlier 1.3/1.4/1.5/2.6e-13; the Lagrange top 16/17/18 gave 1.6e-13/
1.3e-12/1.9e-12: past Jorba-Zou's order the error at fixed ``eps`` may rise, the last two terms
bounding the remainder less well at longer steps, so the order is not raised past it). One protocol
call, mean over 300 starts around each (retries included, A at 1e-8, load 2.7), cap 2800 against
3700: heavy top 310.4 / 303.0 us (15 / 16), the off-diagonal inertia 598.0 / 404.8 (13 / 16),
Lagrange top 163.2 / 162.2 (16 / 16); batches: :data:`A_LOOSE_FULL`. Written as LLVM IR
(:mod:`refimpl.codegen._taylor_ir`) the kernels compile in about 1 s (single, pair) and 3-5 s (lane) at
these sizes; typed by numba's front end, order 15 took 8.3 s, which had set the old cap."""


def supports_full(model) -> bool:
    """The compiled full-state Taylor flow covers su(2)/so(3): the quadratic field for ``Upsilon = 0``,
    the rational one (:mod:`refimpl._compiled_rational` with the quaternion) otherwise."""
    return bool(model.su2)


def _runner(model, full: bool):
    """``(run, order_b)`` for the two-run control: ``run(y0, t, eps, order)`` -> ``(y, steps)`` (raises
    naming failed trajectories) and B's order for a local tolerance. Upsilon = 0: the quadratic
    kernels of :mod:`refimpl._compiled_taylor`; else the rational kernel (one ``Psi_0`` inverse per
    step; :class:`refimpl._errors.DegeneratePointError` on the degenerate set)."""
    if model.upsilon_zero:
        cf = _full_field(model) if full else _body_field(model)
        return (lambda y0, t, eps, order=None: _run_cf(cf, y0, t, eps, order)), (
            lambda e: _order_b(cf, e)
        )
    rf = _cr._field(model, quat=full)
    return (lambda y0, t, eps, order=None: _cr.rational_run(rf, y0, t, eps, order)), (
        _ct.adaptive_order
    )


def quat_to_x(q):
    """``x`` with ``exp(x^a E_a) = q0 - i qv.sigma``: ``x = 2 atan2(|qv|, q0) qv/|qv|`` (|x| <= 2 pi)."""
    s = np.sqrt(np.sum(q[1:] ** 2, axis=0))
    ang = 2 * np.arctan2(s, q[0])
    with np.errstate(invalid="ignore", divide="ignore"):
        fac = np.where(s > 0, ang / np.where(s > 0, s, 1), 2.0)
    return q[1:] * fac


def x_to_quat(x):
    """The unit quaternion ``(cos(|x|/2), sin(|x|/2) x/|x|)`` of ``exp(x^a E_a)``, x of shape (3, N)."""
    t = np.sqrt(np.sum(x**2, axis=0))
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(t > 0, np.sin(t / 2) / np.where(t > 0, t, 1), 0.5)
    return np.concatenate([np.cos(t / 2)[None], s * x])


def quat_rotation(q) -> np.ndarray:
    """``Ad(g)`` (N, 3, 3) of ``g = q_0 - i q.sigma`` (q of shape (4, N), unit): the rotation
    ``(q_0^2 - |q|^2) 1 + 2 q q^T + 2 q_0 [q]_x`` (= ``exp(ad_x)`` for ``q = (cos |x|/2, sin |x|/2 x/|x|)``)."""
    w, v = q[0], q[1:]
    R = np.einsum("aN,bN->Nab", 2 * v, v)
    R += (w * w - np.sum(v * v, axis=0))[:, None, None] * np.eye(3)[None]
    R[:, 0, 1] -= 2 * w * v[2]
    R[:, 1, 0] += 2 * w * v[2]
    R[:, 0, 2] += 2 * w * v[1]
    R[:, 2, 0] -= 2 * w * v[1]
    R[:, 1, 2] -= 2 * w * v[0]
    R[:, 2, 1] += 2 * w * v[0]
    return R


def _gamma0(model, x0):
    if not model.gravity:
        return None
    adx0 = np.einsum("aN,mab->Nmb", x0, model.f)
    Ad0 = _fast._expm_batch(adx0, su2=model.su2)
    return np.einsum("Nmb,m->bN", Ad0, model.gamma)


def compiled_taylor_body(
    model,
    x0,
    pi0,
    t: float,
    *,
    tol: float | None = None,
    order: int | None = None,
    nsteps: int | None = None,
) -> dict:
    """Body system of ``N`` trajectories (``x0``, ``pi0`` of shape (n, N)) to time ``t``: fixed steps
    (``order`` and ``nsteps``) or the adaptive kernel at the *local* tolerance ``tol``.

    Returns the fields of :class:`refimpl.flows.FlowResult` (``x`` None, ``steps`` (N,)) as a dict."""
    if not model.upsilon_zero:
        raise ValueError(
            "compiled Taylor: the body field is a quadratic polynomial only for Upsilon = 0 (vier6)"
        )
    n, N = pi0.shape
    if (
        model.su2 and model.gravity
    ):  # Gamma(0) from the unit quaternion of exp(x0) (compiled, no expm)
        buf = np.empty((N, 10))
        _start(np.ascontiguousarray(x0), np.ascontiguousarray(pi0), model.gamma, True, buf)
        y0, G0 = buf[:, :6], True
    else:
        G0 = _gamma0(model, x0)
        y0 = (pi0 if G0 is None else np.concatenate([pi0, G0])).T
    cf = _body_field(model)
    if nsteps is not None:
        y = _ct.taylor_fixed(cf, y0, t / nsteps, int(nsteps), int(order))
        steps = np.full(N, int(nsteps))
    else:
        y, steps = _ct.taylor_adaptive(cf, y0, t, float(tol), order)
    y = y.T
    return {
        "pi": y[:n],
        "Gamma": None if G0 is None else y[n:],
        "x": None,
        "Ad": None,
        "quat": None,
        "rebases": np.zeros(N, dtype=int),
        "steps": steps,
    }


# ---------------------------------------------------------------- per-call glue, compiled
# Starting state, error estimate and logarithm of the su(2) full state, one loop over the trajectories
# each (the numpy versions above cost ~10 us of call overhead apiece on one trajectory). Same formulas:
# x_to_quat, quat_rotation (Gamma(0) = Ad(exp x0)^T gamma), the |A - B| estimate, quat_to_x.
def _start_py(X, P, gamma, grav, y0):
    q = x_to_quat(X)
    y0[:, :3] = P.T
    if grav:
        y0[:, 3:6] = np.einsum("Nmb,m->Nb", quat_rotation(q), gamma)
    y0[:, -4:] = q.T


def _estimate_py(A, B, n, est):
    dpi = np.max(np.abs(A[:, :n] - B[:, :n]), axis=1)
    dAd = 2.0 * np.sqrt(np.sum((A[:, -4:] - B[:, -4:]) ** 2, axis=1))
    d = np.maximum(dpi, dAd)
    est[:] = np.where(np.isfinite(d), d, np.inf)


def _log_py(B, x):
    x[:] = quat_to_x(B[:, -4:].T)  # (3, N), as _log writes it


def _finish_py(A, B, n, est, x):
    _estimate_py(A, B, n, est)
    _log_py(B, x)


def _finish_one_py(A, B, n, est, x, pi, sA, sB, prop, tol):
    if sA[0] < 0 or sB[0] < 0:
        return 1
    x2 = np.empty((n, 1))
    _finish_py(A, B, n, est, x2)
    x[:] = x2[:, 0]
    pi[:] = B[0, :n]
    if not (np.all(np.isfinite(pi)) and np.all(np.isfinite(x))):
        return 2
    return 0 if _passes(est[0], prop, tol) else 3


def _passes(d, prop, tol):
    """:func:`first_estimate` ``<= tol`` of one pair's ``d = |A - B|``, its constants ``prop`` (the
    factor ``PROP eps_B / eps_A`` where the proportional form applies at these tolerances, else 0.0)
    looked up once per runner: the same operations, so the same verdict."""
    e = min(d, prop * d) if prop > 0.0 and d <= PROP_MAX_D else d
    return e <= tol


if _ct.HAVE_NUMBA:
    import math

    from numba import njit

    @njit(cache=True, nogil=True, inline="always")
    def _start_row(x0, x1, x2, p0, p1, p2, gamma, grav, y0, j):  # pragma: no cover - compiled
        t = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        s = math.sin(t / 2) / t if t > 0 else 0.5
        w, a, b, c = math.cos(t / 2), s * x0, s * x1, s * x2
        y0[j, 0], y0[j, 1], y0[j, 2] = p0, p1, p2
        if grav:  # Gamma_b = sum_m R_mb gamma_m, R = (w^2 - |v|^2) 1 + 2 v v^T + 2 w [v]_x (quat_rotation)
            r = w * w - a * a - b * b - c * c
            g0, g1, g2 = gamma[0], gamma[1], gamma[2]
            y0[j, 3] = (
                g0 * (r + 2 * a * a) + g1 * (2 * b * a + 2 * w * c) + g2 * (2 * c * a - 2 * w * b)
            )
            y0[j, 4] = (
                g0 * (2 * a * b - 2 * w * c) + g1 * (r + 2 * b * b) + g2 * (2 * c * b + 2 * w * a)
            )
            y0[j, 5] = (
                g0 * (2 * a * c + 2 * w * b) + g1 * (2 * b * c - 2 * w * a) + g2 * (r + 2 * c * c)
            )
        k = y0.shape[1] - 4
        y0[j, k], y0[j, k + 1], y0[j, k + 2], y0[j, k + 3] = w, a, b, c

    @njit(cache=True, nogil=True)
    def _start(X, P, gamma, grav, y0):  # pragma: no cover - compiled; same as _start_py
        for j in range(X.shape[1]):
            _start_row(X[0, j], X[1, j], X[2, j], P[0, j], P[1, j], P[2, j], gamma, grav, y0, j)

    @njit(cache=True, nogil=True)
    def _load_start(x0, pi0, gamma, grav, y0, bound):  # pragma: no cover - compiled
        """One trajectory's start from the 1-D ``x0``, ``pi0``: :func:`refimpl._flow_checks.point_max`
        (``max |pi0|``, or -1.0 where an entry is not finite with ``|v| <= bound``) and, where that
        holds, the row of :func:`_start` in ``y0[0]``: one compiled call for both."""
        pmax = point_max(x0, pi0, bound)
        if pmax >= 0.0:
            _start_row(x0[0], x0[1], x0[2], pi0[0], pi0[1], pi0[2], gamma, grav, y0, 0)
        return pmax

    # _estimate and _log are inline="always": _finish, the one-trajectory path's single compiled call
    # after the pair, inlines their IR rather than compiling each as a library of its own on a cold
    # first call (called from Python, as the general path does, they still compile on their own)
    @njit(cache=True, nogil=True, inline="always")
    def _estimate(A, B, n, est):  # pragma: no cover - compiled; same as _estimate_py
        d = A.shape[1]
        for j in range(A.shape[0]):
            m = 0.0
            for c in range(n):
                m = max(m, abs(A[j, c] - B[j, c]))
            s = 0.0
            for c in range(d - 4, d):
                s += (A[j, c] - B[j, c]) ** 2
            m = max(m, 2.0 * math.sqrt(s))
            est[j] = m if math.isfinite(m) else np.inf

    @njit(cache=True, nogil=True, inline="always")
    def _log_fac(w, a, b, c):  # pragma: no cover - compiled
        """The factor of ``x = fac (a, b, c)`` of :func:`quat_to_x` for the quaternion ``(w, a, b, c)``."""
        s = math.sqrt(a * a + b * b + c * c)
        return 2.0 * math.atan2(s, w) / s if s > 0 else 2.0

    @njit(cache=True, nogil=True, inline="always")
    def _log(B, x):  # pragma: no cover - compiled; same as _log_py
        d = B.shape[1]
        for j in range(B.shape[0]):
            w, a, b, c = B[j, d - 4], B[j, d - 3], B[j, d - 2], B[j, d - 1]
            fac = _log_fac(w, a, b, c)
            x[0, j], x[1, j], x[2, j] = a * fac, b * fac, c * fac

    @njit(cache=True, nogil=True)
    def _finish(A, B, n, est, x):  # pragma: no cover - compiled
        _estimate(A, B, n, est)
        _log(B, x)

    @njit(cache=True, nogil=True)
    def _finish_one(A, B, n, est, x, pi, sA, sB, prop, tol):  # pragma: no cover - as _finish_one_py
        """:func:`_finish` of one trajectory's pair with the checks and the verdict around it, the
        answer written into the 1-D ``x`` (the logarithm) and ``pi`` (``B``'s): 1 where a run
        diverged (steps < 0; nothing computed), 2 where ``pi`` or ``x`` is not finite, 3 where the
        pair's estimate is over ``tol`` (:func:`_passes`), else 0."""
        if sA[0] < 0 or sB[0] < 0:
            return 1
        _estimate(A, B, n, est)
        d = B.shape[1]
        w, a, b, c = B[0, d - 4], B[0, d - 3], B[0, d - 2], B[0, d - 1]
        fac = _log_fac(w, a, b, c)
        x[0], x[1], x[2] = a * fac, b * fac, c * fac
        for k in range(n):
            pi[k] = B[0, k]
        for k in range(n):
            if not (math.isfinite(pi[k]) and math.isfinite(x[k])):
                return 2
        e = est[0]
        if prop > 0.0 and e <= PROP_MAX_D:  # _passes, compiled
            e = min(e, prop * e)
        return 0 if e <= tol else 3

else:  # pragma: no cover - exercised only where numba is missing
    _start, _estimate, _log = _start_py, _estimate_py, _log_py

    def _load_start(x0, pi0, gamma, grav, y0, bound):
        pmax = point_max(x0, pi0, bound)
        if pmax >= 0.0:
            _start_py(x0.reshape(3, 1), pi0.reshape(3, 1), gamma, grav, y0)
        return pmax

    def _finish(A, B, n, est, x):
        _estimate(A, B, n, est)
        _log(B, x)

    def _finish_one(A, B, n, est, x, pi, sA, sB, prop, tol):
        return _finish_one_py(A, B, n, est, x, pi, sA, sB, prop, tol)


def _full_field(model) -> _ct.CompiledField:
    """The compiled full-state field (a cached property of the model)."""
    return model.compiled_full_field


def local_tolerances(tol: float, a_loose: float = A_LOOSE) -> tuple[float, float]:
    """``(eps_A, eps_B)``: the first local tolerances of the checking run ``A`` and the returned run ``B``.

    ``B``, the answer, runs at ``SAFETY * eps_A`` but at most :data:`B_MAX` (always near the float64
    floor). ``A`` runs at ``a_loose`` (:data:`A_LOOSE`; :data:`A_LOOSE_FULL` on the quadratic full state)
    for ``tol >= A_LOOSE_FROM`` (the estimate is then the
    proportional one, ``PROP (eps_B/eps_A) |A - B|``, which does not depend on ``eps_A``), else at
    ``FIRST * tol`` (global error about ``tol / 5``: global/local ~ 5-20 over the ``10^2 - 10^3``
    steps of ``|t| ~ 100``, and ``|A - B| <= tol`` decides), not below :data:`A_START_MIN`. Costs
    (heavy top, T = 100, ``A`` at ``B``'s order 15): ``A`` at 1e-8 about 0.45 of ``B`` at 1e-13, at 1e-6 0.33."""
    if tol >= A_LOOSE_FROM:  # the proportionality estimate decides: A as cheap as possible
        return a_loose, _eps_b(a_loose)
    eps_a = max(FIRST * tol, A_START_MIN)
    return eps_a, _eps_b(eps_a)


def _eps_b(eps_a: float, b_max: float = B_MAX) -> float:
    return max(min(eps_a * SAFETY, b_max), EPS_B_FLOOR)


def _order_b(cf, eps_b: float) -> int:
    """B's order: Jorba-Zou's for ``eps_b``, capped where the unrolled kernel stays short (at least 12)."""
    P = _ct.adaptive_order(eps_b)
    m = max(len(cf.mons), 1)
    while P > 12 and m * P * (P + 1) // 2 > FAST_UNROLL_TERMS:
        P -= 1
    return P


_NO_GAMMA = np.zeros(3)


def _body_field(model) -> _ct.CompiledField:
    return model.compiled_body_field


def _run_cf(cf, y0, t, eps, order=None, batch=None):
    # the checking run A (order None) runs at the order of the B it is paired with (the answer's order
    # at B's tolerance _eps_b(eps)): one unrolled kernel per structure serves both runs (one compilation
    # instead of two, and at A's looser tolerance the higher order takes longer steps: heavy top T = 100,
    # eps_A = 1e-8, Jorba-Zou's order 11 507 steps 152 us, order 16 258 steps 133 us). Fixed order, the
    # step rule h ~ eps^(1/P): global error ~ eps^(1 - 1/P), so err(B)/err(A) = (eps_B/eps_A)^(1 - 1/P),
    # at most (eps_A/eps_B)^(1/P) ~ 2 (1e-8/1e-13, P = 16) above the proportional estimate's eps_B/eps_A:
    # inside its safety factor PROP = 30. A lower order for A would not pay either (issue 25, heavy top
    # T = 100, A at 1e-6, kernel alone, one run at load 3.7-4.1: orders 10/11/12/13/15 take 381/320/277/
    # 246/205 steps in 99/95/93/93/94 us; at 1e-5 76/72/76/78/80 us): A's cost follows eps, not the order.
    # ``batch``: as :func:`refimpl._compiled_taylor.taylor_adaptive`'s (None: by the row count)
    order = _order_b(cf, _eps_b(eps)) if order is None else order
    y, steps = _ct.taylor_adaptive(cf, y0, t, eps, order, batch=batch)
    if steps.min() < 0:
        _diverged(steps, t)
    return y, steps


def _batch_runner(cf):
    """:func:`_runner`'s pair for a batch of at least :data:`refimpl._compiled_taylor.BATCH_MIN` rows
    (``Upsilon = 0``): every run on the lane kernel, also the retried groups of fewer rows (a lane
    kernel partly idle costs at most ``BATCH_WIDTH`` times a row there, and those groups are a
    fraction of the batch), so that a batch's first call compiles the lane kernel alone, not the
    single-trajectory kernel too (heavy top: one order-15 kernel fewer to build)."""
    return (lambda y0, t, eps, order=None: _run_cf(cf, y0, t, eps, order, batch=True)), (
        lambda e: _order_b(cf, e)
    )


def _diverged(steps, t):
    raise ValueError(
        f"compiled Taylor flow: trajectories {np.flatnonzero(steps < 0)[:10].tolist()} became non-finite "
        f"before t = {t} (diverged); no point is dropped"
    )


MAX_STEPS = (
    10_000_000  # the kernels' step budget per trajectory (as _compiled_taylor.taylor_adaptive's)
)


def _pair_kernel(cf, eps_b: float):
    """The unrolled pair kernel of ``cf`` at ``B``'s order for ``eps_b`` (kept on ``cf``), or None where
    the kernel is not unrolled."""
    key = ("first", eps_b)
    pair = cf._kernels.get(key)
    if pair is None:
        pair = cf._kernels[key] = _ct.unrolled_pair(cf, _order_b(cf, eps_b))
    return pair


def _first_pair(model, y0, t, eps_a, eps_b, n, tol):
    """One trajectory, ``Upsilon = 0``: the first pair of :func:`_control` (``A`` at ``eps_a`` and ``B`` at
    ``eps_b``, both at ``B``'s order as :func:`_run_cf` runs them) in one call of the unrolled pair
    kernel (:func:`refimpl._compiled_taylor.unrolled_pair`: the two runs on the lanes of one vector
    while both go on, then the one left over alone, each run's result that of the single kernel at
    its tolerance, bit for bit), and its estimate and logarithm in
    one compiled call (``_finish``), with none of the per-call checks of the general path (about 25
    us of Python on the protocol call). Returns ``(B, steps of B, x,
    estimate)`` when the pair passes (the estimate of :func:`_control`'s first pair: ``|A - B|`` or its
    proportional form), ``(A, B, steps of B)`` for :func:`_control` to go on from when it does not,
    or None where the kernel is not unrolled (the general path runs). Raises as :func:`_run_cf`."""
    cf = model.compiled_full_field
    pair = _pair_kernel(cf, eps_b)
    if pair is None:
        return None
    return _pair_run(pair, cf.qcoef, cf.lcoef, y0, t, eps_a, eps_b, n, tol)


def _pair_run(pair, qcoef, lcoef, y0, t, eps_a, eps_b, n, tol):
    """:func:`_first_pair` on the pair kernel ``pair`` of the field arrays ``qcoef``, ``lcoef``."""
    empty = np.empty
    A, B = empty(y0.shape), empty(y0.shape)
    sA, sB = empty(1, dtype=np.int64), empty(1, dtype=np.int64)
    pair(y0, t, eps_a, eps_b, MAX_STEPS, qcoef, lcoef, A, B, sA, sB)
    if sA[0] < 0:
        _diverged(sA, t)
    if sB[0] < 0:
        _diverged(sB, t)
    est, x = empty(1), empty((n, 1))
    _finish(A, B, n, est, x)
    e = first_estimate(float(est[0]), eps_a, eps_b, PROP_MIN_B, PROP_MAX_D)  # as _control's
    if e <= tol:
        est[0] = e
        return B, sB, x, est
    return A, B, sB


def one_trajectory(model, tol: float, limits=(math.inf, None)):
    """``run(x0, pi0, t) -> (x, pi)`` (each of shape (n,), fresh arrays) for one su(2) trajectory
    (``x0``, ``pi0`` 1-D float64 of shape (n,), ``t`` a float), ``Upsilon = 0``, at ``tol``:
    :func:`compiled_taylor_flow` of that trajectory, the same computation (:func:`_first_pair`'s pair,
    estimate and logarithm; :func:`_control` from that pair when it does not pass), with the constants
    of the call (tolerances, kernel, field arrays) looked up once, when the runner is built (issue 25:
    the Python around the protocol call; :func:`refimpl.flows._fast._flow_one` keeps it per model and
    ``tol``). The start is checked as it is read (:func:`_load_start`): ``run`` returns None where an
    entry is not finite with ``|v| <= MAX_MAGNITUDE``, and calls ``rates(pi0, t, max |pi0|)`` of
    ``limits = (free, rates)`` where ``max |pi0| > free`` (the caller's rates check; default never).
    None where the pair kernel is not unrolled or the state is not this one (the caller then calls
    :func:`compiled_taylor_flow`)."""
    if not (model.upsilon_zero and supports_full(model)):  # e.g. the rational state
        return None
    cf = model.compiled_full_field
    eps_a, eps_b = local_tolerances(tol, A_LOOSE_FULL)
    pair = _pair_kernel(cf, eps_b)
    if pair is None:
        return None
    return _one_runner(model, tol, eps_a, eps_b, pair, cf.qcoef, cf.lcoef, limits)


def _one_runner(model, tol, eps_a, eps_b, pair, qcoef, lcoef, limits):
    """:func:`one_trajectory`'s runner: :func:`_pair_run`'s computation into work arrays kept between
    calls (``y0``, ``A``, ``B``, their steps and the estimate; taken from a pool, so concurrent calls
    never share them, and never returned: ``pi`` is a copy, ``x`` fresh); after the first call, the
    compiled functions whose argument types it fixes through their entry points
    (:func:`entry_point`; not :func:`_load_start`, which reads the caller's arrays)."""
    n = model.n
    grav = model.gravity
    gamma = model.gamma if grav else _NO_GAMMA
    d = n + (n if grav else 0) + 4
    pool = []
    empty, i64 = np.empty, np.int64
    pair_, finish = pair, _finish_one
    # first_estimate's constants at these tolerances (_passes): its factor where it scales d
    prop = PROP * (eps_b / eps_a) if eps_a >= PROP_MIN_A and eps_b >= PROP_MIN_B else 0.0

    def run(x0, pi0, t):
        nonlocal pair_, finish
        t = float(t)  # the entry points take the types of the first call
        try:
            s = pool.pop()
        except IndexError:  # none free (the first call, or one running in another thread)
            s = (
                empty((1, d)),
                empty((1, d)),
                empty((1, d)),
                empty(1, i64),
                empty(1, i64),
                empty(1),
            )
        y0, A, B, sA, sB, est = s
        if not admitted(_load_start(x0, pi0, gamma, grav, y0, MAX_MAGNITUDE), pi0, t, limits):
            pool.append(s)
            return None
        pair_(y0, t, eps_a, eps_b, MAX_STEPS, qcoef, lcoef, A, B, sA, sB)
        x, pi = empty(n), empty(n)
        status = finish(A, B, n, est, x, pi, sA, sB, prop, tol)
        if finish is _finish_one:  # the first call: the entry points of the types it used
            pair_ = entry_point(pair, (y0, t, eps_a, eps_b, MAX_STEPS, qcoef, lcoef, A, B, sA, sB))
            finish = entry_point(_finish_one, (A, B, n, est, x, pi, sA, sB, prop, tol))
        if status == 0:  # the pair passes (first_estimate <= tol, as _pair_run)
            pool.append(s)
            return x, pi  # finite (_finish_one)
        if status == 1:  # a run diverged: named
            _diverged(sA if sA[0] < 0 else sB, t)
        if status == 2:  # B's pi or x not finite: refused by name
            finite_one(x, pi, t)
        out = _go_on(model, y0, t, eps_a, n, tol, (A, B, sB), True)  # s stays with this call
        return finite_one(out["x"][:, 0], out["pi"][:, 0], t)

    return run


def entry_point(fn, args):
    """The compiled entry point of the numba dispatcher ``fn`` for exactly the types of ``args`` (a
    call just made with them): the same call without numba's dispatch, which types every argument and
    looks the overload up on each call (0.1-0.35 us per call of one trajectory, issue 25). ``fn``
    itself where there is none (no numba, or no overload of exactly those types). The entry point does
    not check the types it is given: only for calls whose argument types are fixed by their caller
    (arrays it allocates, Python floats, ints and bools)."""
    try:
        from numba import typeof

        return fn.overloads[tuple(typeof(a) for a in args)].entry_point
    except (ImportError, AttributeError, KeyError, TypeError, ValueError):
        return fn


GRID = (
    8  # retried tolerances are rounded down onto 10^(-k/GRID): rows of a batch share kernel calls
)


def _grid_down(e: float) -> float:
    """``e`` rounded down (tighter) onto the grid ``10^(-k/GRID)``, so that the retried rows of a batch
    fall into few tolerance groups (one kernel call each; measured on a 10^4 se(3) batch: 564 rows in
    546 calls before) at most ``10^(1/GRID)`` = 1.33 times tighter than asked."""
    if not e > 0.0:
        return e
    return 10.0 ** (math.floor(GRID * math.log10(e) + 1e-9) / GRID)


def first_estimate(d: float, eps_a: float, eps_b: float, prop_min_b: float, prop_max_d) -> float:
    """The estimate of a pair of one trajectory from ``d = |A - B|``, before any floor: its
    proportional form ``PROP (eps_B / eps_A) d`` where :func:`_control` takes it (``A`` at
    :data:`PROP_MIN_A` or looser, ``B`` at ``prop_min_b`` or looser, ``d <= prop_max_d``; None: no
    limit), else ``d``. The one rule of the two-run estimate: :func:`prop_estimates` is the same on
    arrays; the callers that run the first pair themselves (:func:`_first_pair`,
    :func:`refimpl._full_state._pair_of`) and :func:`_control`'s first pair take this form."""
    if eps_a >= PROP_MIN_A and eps_b >= prop_min_b and (prop_max_d is None or d <= prop_max_d):
        return min(d, PROP * (eps_b / eps_a) * d)
    return d


def prop_estimates(d, eps_a, eps_b, prop_min_b: float, prop_max_d):
    """:func:`first_estimate` on arrays (``d``, and ``eps_a``, ``eps_b`` per row or scalars)."""
    prop = (eps_a >= PROP_MIN_A) & (eps_b >= prop_min_b)
    if prop_max_d is not None:  # a saturated |A - B| is no proportional estimate
        prop = prop & (d <= prop_max_d)
    return np.where(prop, np.minimum(d, PROP * (eps_b / eps_a) * d), d)


def _control(
    model,
    y0,
    t,
    eps_a0,
    n,
    tol,
    *,
    runner=None,
    estimate=None,
    b_max=B_MAX,
    prop_min_b=PROP_MIN_B,
    prop_max_d=PROP_MAX_D,
    reuse_b=REUSE_B,
    floor=None,
    reuse_last=False,
    first=None,
):
    """The two-run control of the module docstring on the rows of ``y0``: ``(B, estimate, steps of B)``.

    Trajectories are grouped by their local tolerances (one tolerance per kernel call); a trajectory
    run again keeps its ``B`` when ``B``'s tolerance does not change (only ``A`` is run again).
    ``runner``: ``(run, order_b)`` as :func:`_runner` gives them, and ``estimate(A, B, n, out)`` the
    per-row ``|A - B|`` (default: the su(2) quaternion state's; :mod:`refimpl._full_state` passes
    its own for ``G = rho(g)``); ``b_max``: B's largest local tolerance (:data:`B_MAX`);
    ``prop_min_b``: B's tightest local tolerance for the proportional estimate (:data:`PROP_MIN_B`);
    ``prop_max_d``: the largest ``|A - B|`` for the proportional estimate (:data:`PROP_MAX_D`, for
    every caller: the premise is the same on any algebra; past it the estimate is ``|A - B|`` and no
    B-only retry is taken; None: no limit);
    ``reuse_b``: :data:`REUSE_B` (0: a held ``B`` never becomes ``A``); ``floor(B, steps, kappa, rows)``:
    per row, a term added to every estimate (the rounding floor both runs share, unseen by ``|A - B|``;
    a retry then aims at ``tol`` minus it; ``kappa``: per row the largest ``|A - B| / eps_A`` seen;
    ``rows``: the indices of ``B``'s rows in ``y0``, None for the first pair of one trajectory; ``B`` is
    the array just given to ``estimate``), default none; ``reuse_last``: when ``A`` cannot be tightened further
    (at :data:`EPS_FLOOR`), its held ``B`` becomes ``A`` once as a last resort (with ``reuse_b = 0``);
    ``first``: ``(A, B, steps of B)`` of the first pair already run (one trajectory; default: run here).

    A trajectory whose ``A`` must be tightened to ``new`` while it holds a ``B`` at a tolerance
    ``eps_B <= REUSE_B * new`` takes that ``B`` as its new ``A`` (one run, the new ``B`` at
    ``SAFETY eps_B``, instead of two): the estimate asks of the pair only that ``B`` be at least
    ``1/SAFETY`` times tighter than ``A``, which holds; ``new`` only guesses what will pass, and a pair
    that does not is run again as any other."""
    N = len(y0)

    def eps_b_of(e):
        return _eps_b(e, b_max)

    run, order_b = _runner(model, True) if runner is None else runner
    _estimate_ = _estimate if estimate is None else estimate
    if N == 1:  # one trajectory, first pair: scalars only (the common protocol call)
        eb0 = eps_b_of(eps_a0)
        if first is None:
            A, _ = run(y0, t, eps_a0)
            B, sB = run(y0, t, eb0, order_b(eb0))
        else:  # su2 hook: the pair of _first_pair
            A, B, sB = first
        d1 = np.empty(1)
        _estimate_(A, B, n, d1)
        e1 = float(d1[0])
        kap1 = e1 / eps_a0
        e1 = first_estimate(e1, eps_a0, eb0, prop_min_b, prop_max_d)
        if floor is not None:
            e1 += float(floor(B, sB, np.array([kap1]), None)[0])
        if e1 <= tol:
            return B, np.array([e1]), sB
        first = (A, B, sB)  # kept: the loop below starts from this pair
    else:
        first = None
    eps_a = np.full(N, eps_a0)
    eps_b = np.full(N, eps_b_of(eps_a0))
    have_a = np.full(N, -1.0)  # the local tolerances of the A and B held (-1: none yet)
    have_b = np.full(N, -1.0)
    Ares = np.empty_like(y0)
    res = np.empty_like(y0)
    est = np.full(N, np.inf)
    steps = np.zeros(N, dtype=np.int64)
    d = np.empty(N)
    fl = np.zeros(N)
    kap = np.zeros(
        N
    )  # the largest |A - B| / eps_A seen per row (the flow's amplification of local errors)
    todo = np.arange(N)
    if first is not None:
        Ares[:], res[:], steps[:] = first
        kap[:] = kap1
        have_a[:], have_b[:] = eps_a0, eps_b_of(eps_a0)
    for _ in range(8):
        for X, have, out, ep, kind in (
            (Ares, have_a, None, eps_a, "A"),
            (res, have_b, steps, eps_b, "B"),
        ):
            need = todo[have[todo] != ep[todo]]
            for e in np.unique(ep[need]) if need.size > 1 else ep[need]:
                idx = need if need.size == 1 else need[ep[need] == e]
                order = order_b(float(e)) if kind == "B" else None
                y, st = run(y0 if N == 1 else y0[idx], t, float(e), order)
                X[idx], have[idx] = y, e
                if out is not None:
                    out[idx] = st
        di = np.empty(todo.size)
        # one array to both hooks (the floor may reuse what the estimate measured of it)
        Bt = res if N == 1 else res[todo]
        _estimate_(Ares if N == 1 else Ares[todo], Bt, n, di)
        d[todo] = di
        # B is at least 1/SAFETY times tighter than A: |A - B| ~ err(A) > err(B); with a much tighter B the
        # tolerance proportionality of the global error (Shampine 1985) gives the smaller estimate
        # gives the smaller estimate -- only while both runs stay clear of the rounding floor, where the
        # global error stops scaling with eps (A at 1e-12 or looser, B at 1e-14 or looser: the estimate
        # 30 kappa eps_B then exceeds the floor, about kappa 1e-14 on the heavy and the asymmetric top)
        kap[todo] = np.maximum(kap[todo], di / eps_a[todo])
        if floor is not None:
            fl[todo] = floor(Bt, steps[todo], kap[todo], todo)
        est[todo] = prop_estimates(di, eps_a[todo], eps_b[todo], prop_min_b, prop_max_d) + fl[todo]
        over = todo[est[todo] > tol]
        if over.size == 0:
            break
        # run again: a tighter B alone when the proportional estimate then passes with a margin of 2 (A
        # is kept: one run), else a tighter A (and B with it) by the observed excess, times 10
        moved = False
        for k in over.tolist():
            # Python floats: no numpy floating-point error state (an inf floor or |A - B| takes no
            # B-only retry: eb_req 0)
            fk_, dk = float(fl[k]), float(d[k])
            eb_req = (
                _grid_down((tol - fk_) * float(eps_a[k]) / (PROP * max(dk, 1e-300)) / 2)
                if fk_ < tol and dk < math.inf
                else 0.0
            )
            if (
                eps_a[k] >= PROP_MIN_A
                and prop_min_b <= eb_req < eps_b[k]
                and (prop_max_d is None or d[k] <= prop_max_d)
            ):
                eps_b[k] = eb_req
                moved = True
                continue
            new = max(_grid_down(eps_a[k] * min(tol / max(d[k], tol) / 10, 0.1)), EPS_FLOOR)
            if new < eps_a[k]:
                eb_held = eps_b[k]
                # reuse_last: a tighter A that the observed amplification already says fails
                # (kappa new > tol / 2) is skipped for the last resort
                hopeless = reuse_last and new == EPS_FLOOR and kap[k] * new > tol / 2
                if (
                    have_b[k] == eb_held
                    and (eb_held <= reuse_b * new or hopeless)
                    and eps_b_of(eb_held) < eb_held
                ):
                    Ares[k], have_a[k] = res[k], eb_held  # the held B becomes A
                    eps_a[k], eps_b[k] = eb_held, eps_b_of(eb_held)
                else:
                    eps_a[k], eps_b[k] = new, eps_b_of(new)
                moved = True
        if not moved and reuse_last:  # A at its floor: the held B becomes A, once
            for k in over.tolist():
                eb_held = eps_b[k]
                if have_b[k] == eb_held and eps_a[k] >= EPS_FLOOR and eps_b_of(eb_held) < eb_held:
                    Ares[k], have_a[k] = res[k], eb_held
                    eps_a[k], eps_b[k] = eb_held, eps_b_of(eb_held)
                    moved = True
        if not moved:
            break
        todo = over
    return res, est, steps


def compiled_taylor_samples(
    model, x0, pi0, times, tol: float, *, full: bool, progress=None
) -> dict:
    """``N`` trajectories sampled at ``times`` (increasing from 0, or decreasing) with the two-run
    control of the module docstring over the whole span: ``A`` and ``B`` each carry their own state
    from sample to sample (never restarted from the other), and the estimate is the largest ``|A - B|``
    (or its proportional form) over the samples, per trajectory; a trajectory over ``tol`` is run again
    with a tighter ``A`` (and ``B``), at most three times, else ``ValueError`` names it.

    ``full``: the su(2) state ``(pi, [Gamma,] q)``; else the body system ``(pi, [Gamma])``. Returns
    ``pi``, ``Gamma`` (or None), ``quat`` (or None) as arrays ``(samples, d_part, N)``, ``error_estimate``
    (N,), ``path``."""
    n, N = pi0.shape
    if full and not supports_full(model):
        raise ValueError("compiled Taylor full state: written for su(2)/so(3)")
    grav = bool(model.gravity)
    if model.su2 and (full or grav):
        d = n + (n if grav else 0) + 4
        buf = np.empty((N, d))
        _start(
            np.ascontiguousarray(x0),
            np.ascontiguousarray(pi0),
            model.gamma if grav else _NO_GAMMA,
            grav,
            buf,
        )
        y0 = buf if full else np.ascontiguousarray(buf[:, : d - 4])
    else:
        G0 = _gamma0(model, x0)
        y0 = np.ascontiguousarray((pi0 if G0 is None else np.concatenate([pi0, G0])).T)
    run, order_b = _runner(model, full)
    times = np.asarray(times, dtype=float)
    eps_a, eps_b = local_tolerances(tol)
    todo = np.arange(N)
    Ys = np.empty((len(times), y0.shape[1], N))
    Ys[0] = y0.T
    est = np.full(N, np.inf)
    for _ in range(4):
        A, B = y0[todo].copy(), y0[todo].copy()
        d = np.zeros(todo.size)
        for k in range(1, len(times)):
            dt = times[k] - times[k - 1]
            A, sA = run(A, dt, eps_a)
            B, sB = run(B, dt, eps_b, order_b(eps_b))
            dk = np.empty(todo.size)
            if full:
                _estimate(A, B, n, dk)
            else:
                dk = np.max(np.abs(A - B), axis=1)
            d = np.maximum(d, dk)
            Ys[k][:, todo] = B.T
            if progress is not None:
                progress(k, len(times) - 1)
        est[todo] = prop_estimates(d, eps_a, eps_b, PROP_MIN_B, PROP_MAX_D)
        over = todo[est[todo] > tol]
        if over.size == 0:
            break
        new = max(eps_a * min(tol / float(np.max(est[over])) / 10, 0.1), EPS_FLOOR)
        if new >= eps_a:
            break
        eps_a, eps_b, todo = new, _eps_b(new), over
    over = np.flatnonzero(est > tol)
    if over.size:
        raise ValueError(
            f"compiled Taylor: tolerance {tol} not reached on trajectories {over[:10].tolist()} (estimated "
            f"errors {est[over][:3].tolist()}) at the float64 floor of the local tolerance"
        )
    nb = n + (n if grav else 0)
    return {
        "pi": Ys[:, :n],
        "Gamma": Ys[:, n:nb] if grav else None,
        "quat": Ys[:, nb:] if full else None,
        "error_estimate": est,
        "path": PATH,
    }


def compiled_taylor_flow(model, x0, pi0, t: float, tol: float) -> dict:
    """Full state ``(x, pi)`` of ``N`` su(2) trajectories at time ``t`` with the global tolerance ``tol``
    (max-norm over ``pi`` and ``Ad(g)`` per trajectory; the two-run control of the module docstring).

    Returns ``pi``, ``Gamma``, ``x``, ``quat`` (``Ad(g) = quat_rotation(quat)``), ``Ad`` (None), ``rebases`` (zeros: no chart is used), ``steps``
    (of the returned run), ``error_estimate`` (per trajectory: ``|A - B|`` or its proportional form,
    see the module docstring; an estimate of the returned run's error from above, blind to the
    rounding floor of the starting point) and ``path`` (``numba`` or ``python``)."""
    if not supports_full(model):
        raise ValueError("compiled Taylor full state: written for su(2)/so(3)")
    n, N = pi0.shape
    grav = model.gravity
    d = n + (n if grav else 0) + 4
    y0 = np.empty((N, d))
    _start(x0, pi0, model.gamma if grav else _NO_GAMMA, grav, y0)
    uz = model.upsilon_zero
    eps_a, eps_b = local_tolerances(tol, A_LOOSE_FULL if uz else A_LOOSE)
    first = _first_pair(model, y0, t, eps_a, eps_b, n, tol) if N == 1 and uz else None
    if first is not None and len(first) == 4:  # the common protocol call: one pair passed
        res, steps, x, est = first
        return _answer(res, n, N, grav, x, steps, est)
    return _go_on(model, y0, t, eps_a, n, tol, first, uz)


def _go_on(model, y0, t, eps_a, n, tol, first, uz):
    """:func:`compiled_taylor_flow` after the first pair (``first``: ``(A, B, steps of B)`` of one
    trajectory that did not pass, or None): the two-run control, its refusal and the logarithm."""
    N = y0.shape[0]
    runner = None
    if uz and N >= _ct.BATCH_MIN:  # a batch: every run on the lane kernel, retried groups too
        runner = _batch_runner(_full_field(model))
    res, est, steps = _control(
        model,
        y0,
        t,
        eps_a,
        n,
        tol,
        first=first,
        runner=runner,
    )
    over = np.flatnonzero(est > tol)
    if over.size:
        raise ValueError(
            f"compiled Taylor flow: tolerance {tol} not reached on trajectories {over[:10].tolist()} "
            f"(estimated errors {est[over][:3].tolist()}) at the float64 floor of the local tolerance"
        )
    x = np.empty((n, N))
    _log(res, x)
    return _answer(res, n, N, model.gravity, x, steps, est)


def _answer(res, n, N, grav, x, steps, est) -> dict:
    res = res.T
    return {
        "pi": res[:n],
        "Gamma": res[n : 2 * n] if grav else None,
        "quat": res[-4:],
        "x": x,
        "Ad": None,
        "rebases": np.zeros(N, dtype=int),
        "steps": steps,
        "error_estimate": est,
        "path": PATH,
    }
