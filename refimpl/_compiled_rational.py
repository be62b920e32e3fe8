"""Compiled (numba) adaptive Taylor method for the rational body fields with ``Upsilon != 0``.

The field (vier10/vier11, the body system of :meth:`refimpl.model.Model.omega_pidot`)
    ``S(pi)_ab = pi_m f^m_ab - Theta_ab``, ``Psi = 1 + Upsilon S``, ``Phi = Psi^T`` (= ``1 + S Upsilon``
    for antisymmetric ``S`` and ``Upsilon``), ``dK = I^-1 pi``, ``dV = -G_L Gamma`` with
    ``(G_L)_bm = f^m_bc L_c`` (gravity, twee15), and

        Psi Omega = dK - Upsilon dV,        Phi pidot = -dV - S dK,
        Gammadot_mu = Omega^b f^a_{b mu} Gamma_a        (twee17, sign corrected).

The series recurrence (Jorba and Zou 2005; the quotient rule of automatic differentiation)
    With ``pi(t0 + s) = sum_k pi_k s^k`` (likewise ``Gamma``, ``Omega``, ``pidot``) the matrices are
    affine in ``pi``: ``S_0 = f.pi_0 - Theta`` and ``S_k = f.pi_k`` (``k >= 1``), so ``Psi_k = Upsilon S_k``.
    Matching the coefficients of ``s^k`` in ``Psi Omega = r`` gives

        Psi_0 Omega_k = r_k - Upsilon sum_{j=1..k} S_j Omega_{k-j},
        Phi_0 pidot_k = (G_L Gamma_k - sum_{j=0..k} S_j dK_{k-j} + Theta dK_k ... ) - sum_{j=1..k} S_j^T w_{k-j},

    with ``w_i = Upsilon^T pidot_i`` (``Phi_j = S_j^T Upsilon^T`` for ``j >= 1``), then
    ``pi_{k+1} = pidot_k / (k+1)`` and ``Gamma_{k+1} = (sum_{j=0..k} f.(Omega_j, Gamma_{k-j})) / (k+1)``.
    Every Cauchy sum is contracted with ``f`` through its nonzero entries only. One inverse of the
    ``n x n`` matrix ``Psi_0`` per step (Gauss-Jordan with partial pivoting) serves all orders; it is the
    exact recurrence (no truncation beyond the order ``P``).

The su(2)/so(3) full state (``RationalField(model, quat=True)``)
    appends the group element as the unit quaternion ``q`` (``g = q_0 - i q.sigma``, as
    :func:`refimpl._taylor.quadratic_field_su2_full`): ``dq/dt = q * (0, Omega/2)``, bilinear in ``q`` and
    ``Omega``, so ``q_{k+1} = (1/(k+1)) sum_j q_j * (0, Omega_{k-j}/2)`` from the ``Omega_k`` above. The
    state is ``(pi, [Gamma,] q)`` in the layout of the quadratic full state, and the two-run control of
    :mod:`refimpl._flow_compiled` runs it for the protocol's ``flow`` when ``Upsilon != 0``.

Step size and order: those of :mod:`refimpl._compiled_taylor` (Jorba-Zou, ``P = ceil(-ln(tol)/2 + 1)``,
``h`` from the last two coefficients of ``(pi, Gamma)``, a local error about ``tol * max(1, ||y||)``),
and the update is a compensated (Kahan) sum.

The degenerate set (vier12)
    At every step the kernel forms ``cond_inf(Psi_0) = ||Psi_0||_inf ||Psi_0^-1||_inf``. When a pivot is zero or
    ``cond_inf > cond_max`` (default :data:`COND_MAX`: the solve by ``Phi`` then loses more than
    ``log10(cond_max)`` of float64's 16 digits, and ``Delta = det Phi`` is zero within that accuracy), the
    trajectory is stopped and :func:`rational_taylor_body` raises
    :class:`refimpl._errors.DegeneratePointError` naming the trajectory, the time reached and the
    condition number. A trajectory that runs into the set in finite time (where ``Delta ~ (t* - t)`` and
    the field grows like ``1/Delta``) shows it first as a collapse of the Jorba-Zou step (the radius of
    convergence is the distance to the singularity): a step below ``STALL * t`` with a finite state
    raises the same error, with the time reached and the largest ``cond_inf`` seen. No value past that
    point is returned.

Compilation: per structure, never per model
    The kernel source is generated from the *structure* only -- the dimension, the nonzero pattern of
    ``f`` (its triplets), of ``I^-1``, ``Upsilon``, ``Theta``, ``G_L`` and ``Upsilon G_L``, and whether
    gravity is present; the numbers are array arguments and the order ``P`` is an argument (loops over
    the orders stay loops). The module is written under :func:`refimpl.codegen.cache_dir`
    named by its hash (:mod:`refimpl.codegen.rational`) and compiled with ``cache=True`` (a second process loads machine code). Without
    numba the same source runs as plain Python (``njit`` replaced by the identity).
"""

from __future__ import annotations

import numpy as np

from . import _compiled_taylor as _ct
from ._errors import DegeneratePointError
from .codegen.rational import STALL, kernel_source

__all__ = [
    "COND_MAX",
    "PATH",
    "RationalField",
    "rational_field",
    "rational_kernel",
    "rational_taylor_adaptive",
    "rational_run",
    "rational_taylor_body",
]

PATH = _ct.PATH
COND_MAX = (
    1e12  # cond_inf(Psi_0) above this: the point is treated as on the degenerate set (vier12)
)


class RationalField:
    """The arrays of one model's rational body field (kernel arguments) and its structure.

    ``fv`` holds the nonzero ``f^m_ab`` in the order of ``trip`` (``(m, a, b)``); ``theta``, ``U``,
    ``Iinv``, ``GL``, ``UGL`` are dense ``(n, n)`` arrays whose zero patterns are part of the structure.
    """

    def __init__(self, model, quat: bool = False):
        n = model.n
        if quat and not model.su2:
            raise ValueError(
                "RationalField(quat=True): the quaternion kinematics are written for su(2)/so(3)"
            )
        self.quat = bool(quat)
        f = np.asarray(model.f, dtype=float)
        self.n = n
        self.gravity = bool(model.gravity)
        self.trip = [tuple(int(i) for i in t) for t in np.argwhere(f != 0.0)]
        self.trip_arr = np.array(self.trip, dtype=np.int64).reshape(-1, 3)
        self.gamma = None if not self.gravity else np.ascontiguousarray(model.gamma, dtype=float)
        self.fv = np.array([f[t] for t in self.trip], dtype=float)
        self.theta = np.ascontiguousarray(model.theta, dtype=float)
        self.U = np.ascontiguousarray(model.upsilon, dtype=float)
        self.Iinv = np.ascontiguousarray(model.Iinv, dtype=float)
        GL = model.G_L if self.gravity else np.zeros((n, n))
        self.GL = np.ascontiguousarray(GL, dtype=float)
        self.UGL = np.ascontiguousarray(self.U @ self.GL)
        self.d = (2 * n if self.gravity else n) + (4 if self.quat else 0)

    def args(self):
        return (self.fv, self.theta, self.U, self.Iinv, self.GL, self.UGL)


def rational_field(model) -> RationalField:
    return RationalField(model)


def rational_kernel(rf: RationalField):
    """The compiled module of the structure of ``rf`` (written and imported once per structure)."""
    mod = getattr(rf, "_mod", None)
    if mod is None:
        mod = rf._mod = _ct._import_kernel_module(kernel_source(rf))
    return mod


def rational_taylor_adaptive(
    rf: RationalField,
    y0,
    T: float,
    tol: float,
    order: int | None = None,
    max_steps: int = 10_000_000,
    cond_max: float = COND_MAX,
):
    """Adaptive Taylor over ``[0, T]`` for every row of ``y0`` (N, d) at the local tolerance ``tol``.

    Returns ``(y(T), steps, t_end, cond)`` with ``steps[i] = -1`` (non-finite state),
    ``-2`` (degenerate set: ``cond_inf(Psi_0) > cond_max`` or a zero pivot), ``-3`` (more than
    ``max_steps``) or ``-4`` (no step: the coefficients overflowed or the step fell below ``STALL * t``,
    a real singularity ahead); ``t_end`` the time reached and ``cond`` the largest ``cond_inf(Psi_0)`` seen."""
    P = _ct.adaptive_order(tol) if order is None else int(order)
    if P < 2:
        raise ValueError(f"order must be >= 2, got {P}")
    y = np.ascontiguousarray(y0, dtype=float)
    if y.ndim != 2 or y.shape[1] != rf.d:
        raise ValueError(f"y0 must have shape (N, {rf.d}), got {y.shape}")
    N = y.shape[0]
    out = np.empty_like(y)
    steps = np.zeros(N, dtype=np.int64)
    tend = np.zeros(N)
    conds = np.zeros(N)
    mod = rational_kernel(rf)
    mod.adaptive(
        y,
        float(T),
        float(tol),
        P,
        int(max_steps),
        *rf.args(),
        float(cond_max),
        out,
        steps,
        tend,
        conds,
    )
    return out, steps, tend, conds


def _field(model, quat: bool = False) -> RationalField:
    """The rational field of ``model`` (the body system, or with ``quat`` the su(2) full state
    ``(pi, [Gamma,] q)``): cached properties of the :class:`refimpl.model.Model`."""
    return model.rational_full_field if quat else model.rational_body_field


def rational_run(rf: RationalField, y0, t: float, tol: float, order: int | None = None):
    """``(y(t), steps)`` for the rows of ``y0`` at the local tolerance ``tol``; raises as
    :func:`rational_taylor_body` does (:class:`refimpl._errors.DegeneratePointError` on the degenerate
    set, ``ValueError`` for a non-finite state or the step budget), naming the trajectories."""
    y, steps, tend, conds = rational_taylor_adaptive(rf, y0, t, tol, order)
    if steps.min() < 0:
        _raise_failed(y, steps, tend, conds, t, COND_MAX)
    return y, steps


def rational_taylor_body(
    model,
    x0,
    pi0,
    t: float,
    *,
    tol: float,
    order: int | None = None,
    cond_max: float = COND_MAX,
) -> dict:
    """Body system of ``N`` trajectories (``x0``, ``pi0`` of shape (n, N)) to time ``t`` by the compiled
    rational Taylor method at the *local* tolerance ``tol`` (any ``Upsilon``; ``Upsilon = 0`` works too).

    Returns the fields of :class:`refimpl.flows.FlowResult` as a dict (``x`` None) with ``steps`` (N,) and
    ``cond_phi`` (the largest ``cond_inf(Phi)`` met per trajectory). Raises
    :class:`refimpl._errors.DegeneratePointError` when a trajectory reaches the degenerate set and
    ``ValueError`` when it becomes non-finite or exceeds the step budget (naming the trajectories)."""
    n, N = pi0.shape
    rf = _field(model)
    if rf.gravity:  # Gamma0 = Ad(exp x0)^T gamma (twee16), compiled beside the kernel
        y0 = np.empty((N, 2 * n))
        y0[:, :n] = pi0.T
        G0 = np.empty((N, n))
        rational_kernel(rf).gamma0(
            np.ascontiguousarray(x0.T, dtype=float), rf.trip_arr, rf.fv, rf.gamma, G0
        )
        y0[:, n:] = G0
    else:
        y0 = pi0.T
        G0 = None
    y, steps, tend, conds = rational_taylor_adaptive(rf, y0, t, tol, order, cond_max=cond_max)
    if steps.min() < 0:
        _raise_failed(y, steps, tend, conds, t, cond_max)
    y = y.T
    return {
        "pi": y[:n],
        "Gamma": None if G0 is None else y[n:],
        "x": None,
        "Ad": None,
        "quat": None,
        "rebases": np.zeros(N, dtype=int),
        "steps": steps,
        "cond_phi": conds,
    }


def _raise_failed(y, steps, tend, conds, t, cond_max, measure="cond_inf(Phi)"):
    """Raise for the failed rows (``measure``: the name of the degeneracy measure in ``conds``)."""
    deg = np.flatnonzero(steps == -2)
    if deg.size:
        raise DegeneratePointError(
            f"rational Taylor flow: trajectories {deg[:10].tolist()} reached the degenerate set Pi_1 "
            f"(vier12) at t = {tend[deg[:3]].tolist()}: {measure} = {conds[deg[:3]].tolist()} > "
            f"{cond_max:g} (Delta = det Phi = 0 to float64 accuracy); no value past that point is returned"
        )
    stall = np.flatnonzero((steps == -4) & np.all(np.isfinite(y), axis=1))
    if stall.size:
        raise DegeneratePointError(
            f"rational Taylor flow: trajectories {stall[:10].tolist()} reach the degenerate set Pi_1 (vier12) "
            f"at about t = {tend[stall[:3]].tolist()}: the step size collapsed (below {STALL:.2g} t, or the Taylor "
            "coefficients overflowed) while the "
            f"state stayed finite and {measure} grew to {conds[stall[:3]].tolist()} (the field's only "
            "real singularities are the zeros of Delta = det Phi); no value past that point is returned"
        )
    bad = np.flatnonzero(steps < 0)
    if bad.size:
        raise ValueError(
            f"rational Taylor flow: trajectories {bad[:10].tolist()} became non-finite or exceeded the step "
            f"budget before t = {t} (stopped at t = {tend[bad[:3]].tolist()}); no point is dropped"
        )
