"""The full state with ``Upsilon != 0`` on every algebra: a compiled adaptive Taylor flow.

The field (vier10/vier11, :meth:`refimpl.model.Model.omega_pidot`; docs/conventions.md)
    ``S(pi)_ab = pi_m f^m_ab - Theta_ab``, ``Psi = 1 + Upsilon S = Phi^T``, ``dK = I^-1 pi``,
    ``dV = -G_L Gamma`` (gravity, twee15), and

        Psi Omega = dK - Upsilon dV,      Phi pidot = -dV - S dK,
        Gammadot_mu = Omega^b f^a_{b mu} Gamma_a (twee17, sign corrected),
        dG/dt = G rho(Omega)   (G = rho(g) in the algebra's faithful representation).

    ``Omega`` and ``pidot`` are rational in ``pi`` (the solve by ``Phi``), so the field is no longer
    quadratic; the series recurrence of the quotient (Jorba and Zou 2005; :mod:`refimpl._compiled_rational`)
    matches the coefficients of ``Psi Omega = r``: ``Psi_0 Omega_k = r_k - Upsilon sum_{j>=1} S_j
    Omega_{k-j}``, likewise for ``pidot``, with one inverse of ``Psi_0`` per step serving every order.
    ``G`` then follows from the Cauchy products ``G_{k+1} = sum_a G_a M_{k-a} / (k+1)``,
    ``M_k = rho(Omega_k)``, exactly as in :mod:`refimpl._full_state` (no chart, no re-basing).

What is shared
    The layout ``(pi, [Gamma,] G entries, [s])``, the starting state, the two-run error control, the
    ``Ad(g)`` and ``x`` recovery (the project's logarithm and re-basing) are those of
    :func:`refimpl._full_state.full_state_flow`; only the kernel differs (its ``run`` argument).
    The kernel is generated per structure by :func:`refimpl.codegen.full_state_rational.
    full_state_rational_source` (the nonzero patterns of ``f``, ``I^-1``, ``Theta``, ``Upsilon``,
    ``G_L`` and of the ``E_b``; the numbers are array arguments).

One trajectory (the protocol call, issue 25)
    :func:`one_trajectory` (every algebra but su(2)) and :func:`one_trajectory_su2` (the quaternion
    state of :mod:`refimpl._compiled_rational`) are the runners of :func:`refimpl.flows._fast._flow_one`
    for ``Upsilon != 0``: the start read and checked in compiled code (:func:`start_check`), the first
    pair of the two-run control run and estimated without the control's Python, the control entered
    only from a pair that does not pass; the answers are those of the general route bit for bit.

The degenerate set (vier12)
    As the su(2) rational kernel, with the measure of docs/conventions.md: at every step the
    sensitivity of the solve ``||Psi_0^-1||_inf (1 + ||S_0||_inf ||Upsilon||_inf)`` (at least
    ``cond_inf(Psi_0)``; unlike it, it grows as ``Delta -> 0`` on 2-dimensional algebras too, where
    ``Phi = (1 - u s) 1``; a zero pivot gives ``inf``); above :data:`refimpl._compiled_rational.COND_MAX`
    the point is on ``Delta = det Phi = 0`` to float64 accuracy and :class:`refimpl._errors.DegeneratePointError` names
    the trajectory, the time reached and the condition number. A trajectory running into the set
    shows it first as a collapse of the Jorba-Zou step (the radius of convergence is the distance to
    the singularity): the same error, with the time reached.
"""

from __future__ import annotations

import math

import numpy as np

from . import _compiled_rational as _cr
from . import _compiled_taylor as _ct
from . import _fast_kernels as _fast
from . import _flow_compiled as _fc
from . import _full_state as _fs
from . import _full_state_kernel as _fsk
from . import _full_state_rational_kernel as _fk
from ._flow_checks import admitted, finite_one, load_point
from ._flow_compiled import PROP_MAX_D, _eps_b, entry_point, first_estimate, local_tolerances
from ._validate import MAX_MAGNITUDE
from .codegen import import_source
from .codegen.full_state_rational import full_state_rational_source

__all__ = [
    "GENERATED_MAX_PRODUCTS",
    "GENERATED_ORDER_BIAS",
    "ORDER_BIAS",
    "RationalFullState",
    "applies",
    "one_trajectory",
    "one_trajectory_su2",
    "rational_full_state",
    "rational_full_state_flow",
    "use_generated",
]

ORDER_BIAS = 4
"""Above Jorba-Zou's order ``ceil(-ln(tol)/2 + 1)``: the per-step inverse of ``Psi_0`` is a fixed cost
that fewer, longer steps amortise (as :data:`refimpl._full_state.ORDER_BIAS`). Measured on the bench's
modified_su3 (T = 10, one protocol call, load 7): 594-610 us at 4 against 659-752 us at 2 and 744 us
at 0; the kernel compiled for every structure."""

GENERATED_ORDER_BIAS = 0
"""The same for the generated kernel (whose per-order cost is lower): a batch of 200 on modified_su3
cost 504-512 us per trajectory at 0 against 535-539 us at 4 (load 7)."""


GENERATED_MIN_WORK = 1024.0
"""``N |t|`` from which a flow runs the kernel generated for its structure (2-2.5x faster per step
than the one compiled for every structure: measured 63 us against 153 us for ``T = 2`` on su(3),
150 us against 380 us on se(3) with gravity) instead of :mod:`refimpl._full_state_rational_kernel`.
Its compilation costs 15-25 s of CPU per structure before the disk cache has it (su(3), se(3)),
repaid only by long batched flows; single protocol calls never pay it. A function of the call's
inputs (the trajectories of one kernel call and the time span)."""

GENERATED_MAX_PRODUCTS = 32
"""Structures with more distinct Cauchy products than this never run the generated kernel: its cold
compilation grows faster than its source (numba-warm, CPU, one run each, load 1.6-1.7: Bianchi III
with a cocycle, 18 products, 401 lines, 3.4 s; modified_su3, 140 products, 976 lines, 18.0 s; se(3)
with gravity 15-25 s at load 7), over issue 25's 10 s per structure. They run the kernel compiled
for every structure at any ``N |t|`` (2-2.5x per step). A function of the structure."""


def use_generated(rfs, N: int, t: float) -> bool:
    """Whether a run of ``N`` trajectories over ``t`` takes the generated kernel: a small structure
    (:data:`GENERATED_MAX_PRODUCTS`) and ``N |t| >=`` :data:`GENERATED_MIN_WORK`."""
    return rfs.fs.n_products <= GENERATED_MAX_PRODUCTS and N * abs(t) >= GENERATED_MIN_WORK


SENSITIVITY = "||Phi^-1|| (1 + ||S|| ||Upsilon||)"
"""The degeneracy measure of these kernels (inf-norms at the step's start; docs/conventions.md)."""


def applies(model) -> bool:
    """Every algebra but su(2)/so(3) (which carries the quaternion) with ``Upsilon != 0``, numba present."""
    return bool(_ct.HAVE_NUMBA and not model.upsilon_zero and not model.su2)


class RationalFullState:
    """One model's kernel: the rational body field, the full-state layout and the generated module."""

    def __init__(self, model, fs):
        self.rf = _cr.RationalField(model)
        self.fs = fs
        self.coef = np.ascontiguousarray(fs.coef, dtype=float)
        self._source = None
        self._mod = None
        self._tables = None

    @property
    def source(self) -> str:
        """The generated kernel's source (:mod:`refimpl.codegen.full_state_rational`)."""
        if self._source is None:
            self._source = full_state_rational_source(self.rf, self.fs)
        return self._source

    def module(self):
        if self._mod is None:
            self._mod = import_source(self.source, "fullrat_")
        return self._mod

    def tables(self) -> tuple:
        """The arguments of :func:`refimpl._full_state_rational_kernel.adaptive` between ``max_steps``
        and ``cond_max`` (built once)."""
        if self._tables is not None:
            return self._tables
        rf, fs = self.rf, self.fs
        i64 = lambda a: np.ascontiguousarray(np.array(a, dtype=np.int64).reshape(-1))  # noqa: E731
        trip = rf.trip

        def pairs(key):
            keys = sorted({key(*t) for t in trip})
            at = {k: i for i, k in enumerate(keys)}
            return (
                i64([k[0] for k in keys]),
                i64([k[1] for k in keys]),
                i64([at[key(*t)] for t in trip]),
            )

        svm, svb, sv_of = pairs(lambda m, a, b: (m, b))
        stm, sta, st_of = pairs(lambda m, a, b: (m, a))
        gpa, gpm, gp_of = pairs(lambda m, a, b: (a, m))
        gnames = [f"g{p}_{i}_{j}" for p, i, j in fs.gvars]
        gidx = {g: v for v, g in enumerate(gnames)}
        midx = {f"m{p}_{k}_{j}": e for e, (p, k, j) in enumerate(fs.mv)}
        mptr, mb, mc = [0], [], []
        for key in fs.mv:
            for ci, b in fs.mv[key]:
                mb.append(b)
                mc.append(fs.coef[ci])
            mptr.append(len(mb))
        gvary = [g for g in gnames if g not in fs.const]
        prods: dict = {}
        for g in gvary:
            for _, u, w in fs.quad[g]:
                prods.setdefault((u, w), len(prods))
        gptr, gprod, gsign = [0], [], []
        for g in gvary:
            for c, u, w in fs.quad[g]:
                gprod.append(prods[(u, w)])
                gsign.append(float(c))
            gptr.append(len(gprod))
        Pab = np.zeros((fs.n_ab, fs.n))
        for ell, s in enumerate(fs.names[fs.d - fs.n_ab :] if fs.n_ab else []):
            for ci, u in fs.lin[s]:
                Pab[ell, int(u[2:])] += fs.coef[ci]
        tarr = rf.trip_arr
        self._tables = (
            bool(rf.gravity), rf.theta, rf.U, rf.Iinv, rf.GL, rf.UGL,
            i64(tarr[:, 0]), i64(tarr[:, 1]), i64(tarr[:, 2]), np.ascontiguousarray(rf.fv),
            svm, svb, sv_of, stm, sta, st_of, gpa, gpm, gp_of,
            len(gnames), i64(mptr), i64(mb), np.array(mc, dtype=float),
            i64([gidx[u] for u, _ in prods]), i64([midx[w] for _, w in prods]),
            np.array([u in fs.const for u, _ in prods], dtype=np.bool_),
            i64([gidx[g] for g in gvary]), i64(gptr), i64(gprod), np.array(gsign, dtype=float),
            Pab,
        )  # fmt: skip
        return self._tables

    def run(
        self,
        y0,
        T: float,
        tol: float,
        order: int | None = None,
        max_steps: int = 10_000_000,
        generated: bool = False,
    ):
        """``(y(T), steps, t_end, cond)`` for the rows of ``y0`` (N, d) at the local tolerance ``tol``
        (``steps`` negative on failure, as :func:`refimpl._compiled_rational.rational_taylor_adaptive`):
        the kernel generated for the structure (``generated``) or the one compiled for every structure."""
        bias = GENERATED_ORDER_BIAS if generated else ORDER_BIAS
        P = _ct.adaptive_order(tol) + bias if order is None else int(order)
        y = np.ascontiguousarray(y0, dtype=float)
        if y.ndim != 2 or y.shape[1] != self.fs.d:
            raise ValueError(f"y0 must have shape (N, {self.fs.d}), got {y.shape}")
        N = y.shape[0]
        out = np.empty_like(y)
        steps = np.zeros(N, dtype=np.int64)
        tend = np.zeros(N)
        conds = np.zeros(N)
        cmax = float(_cr.COND_MAX)
        if generated:
            self.module().adaptive(
                y, float(T), float(tol), P, int(max_steps), *self.rf.args(), self.coef,
                cmax, out, steps, tend, conds,
            )  # fmt: skip
        else:
            _fk.adaptive(
                y, float(T), np.full(N, float(tol)), np.full(N, P, dtype=np.int64),
                int(max_steps), *self.tables(), cmax, out, steps, tend, conds,
            )  # fmt: skip
        return out, steps, tend, conds


def rational_full_state(model, abelian=None) -> RationalFullState:
    """The kernel of ``model`` kept on the (cached, immutable) model, over the full state of
    :func:`refimpl._full_state.full_state` (``abelian`` as there)."""
    fs = _fs.full_state(model, abelian)
    rfs = model.__dict__.get("_rational_full_state")
    if rfs is None or rfs.fs is not fs:
        rfs = RationalFullState(model, fs)
        model.__dict__["_rational_full_state"] = rfs
    return rfs


def _runner(rfs: RationalFullState):
    """``run(fs, y0, t, eps, generated)`` for :func:`refimpl._full_state.full_state_flow`: raises
    :class:`refimpl._errors.DegeneratePointError` on the degenerate set and ``ValueError`` for a
    non-finite state or the step budget, naming the trajectories (no value past that point)."""

    def run(fs, y0, t, eps, generated=False):
        gen = use_generated(rfs, y0.shape[0], t)  # this module's rule, not the caller's
        y, steps, tend, conds = rfs.run(y0, t, eps, generated=gen)
        if steps.min() < 0:
            _cr._raise_failed(y, steps, tend, conds, t, _cr.COND_MAX, SENSITIVITY)
        return y, steps

    return run


def rational_full_state_flow(model, x0, pi0, t: float, tol: float, *, abelian=None) -> dict:
    """Full state ``(x, pi)`` of ``N`` trajectories (``x0``, ``pi0`` of shape (n, N)) at time ``t`` with
    the global tolerance ``tol`` (the two-run control of :func:`refimpl._full_state.full_state_flow`,
    whose result dict this returns)."""
    if not applies(model):
        raise ValueError(
            "rational full state: for Upsilon != 0 off su(2)/so(3) with numba "
            f"(Upsilon = 0: {model.upsilon_zero}, su(2): {model.su2}, numba: {_ct.HAVE_NUMBA})"
        )
    rfs = rational_full_state(model, abelian)
    return _fs.full_state_flow(model, x0, pi0, t, tol, abelian=abelian, run=_runner(rfs))


def start_check(model, fixed_types: bool = False):
    """``degenerate(p) -> bool`` for one start ``pi = p`` (1-D float64) of ``model`` (``Upsilon != 0``): the
    flows' start check (:func:`refimpl._fast_kernels.start_degenerate`, the rule of
    :func:`refimpl.flows._fast._check_start`) compiled for one point
    (:func:`refimpl._full_state_rational_kernel.start_degenerate`, its su(2) closed form
    :func:`refimpl._full_state_rational_kernel.start_degenerate_su2`), the model's arrays bound once.
    The refusal itself stays the caller's (its message, by the numpy rule). ``fixed_types``: every
    ``p`` has the type of the first (a runner's own work array), whose entry point is then taken
    (:func:`refimpl._flow_compiled.entry_point`, which does not check types); else numba dispatches."""
    n = model.n
    th = np.ascontiguousarray(model.theta, dtype=float)
    ups = np.ascontiguousarray(model.upsilon, dtype=float)
    if _fast._is_su2(np.asarray(model.f)):
        xi = _fast._su2_theta_to_xi(th)
        xi = np.zeros(3) if xi is None else np.ascontiguousarray(xi, dtype=float)
        tau = np.array(_fast._su2_upsilon_to_tau(ups), dtype=float)
        args = (xi, tau, 1.0 / (3 * _fast.C_P * _fast.EPS))
        kernel = _fk.start_degenerate_su2
    else:
        f = np.ascontiguousarray(model.f, dtype=float)
        args = (f, th, ups, math.sqrt(np.vdot(ups, ups)), n * _fast.C_P * _fast.EPS)
        kernel = _fk.start_degenerate
    fn = kernel

    def degenerate(p) -> bool:
        nonlocal fn
        out = fn(p, *args)
        if fn is kernel and fixed_types:  # the first call: the entry point of the types it used
            fn = entry_point(kernel, (p, *args))
        return out

    return degenerate


def one_trajectory(model, tol: float, abelian=None, limits=(math.inf, None), refuse=None):
    """``run(x0, pi0, t) -> (x, pi)`` at ``tol`` on ``model`` (``Upsilon != 0``, :func:`applies`):
    :func:`rational_full_state_flow` of one trajectory (``x0``, ``pi0`` 1-D float64 of shape (n,),
    ``t`` a float; ``x``, ``pi`` fresh arrays of shape (n,), finite: else refused by name,
    :func:`refimpl._flow_checks.finite_one`), the same computation with the constants of the call
    looked up once, when the runner is built (issue 25: the Python around one protocol call; as
    :func:`refimpl._full_state.one_trajectory` for ``Upsilon = 0``).

    The start is read by :func:`refimpl._flow_checks.load_point` (``run`` returns None where an entry
    is not finite with ``|v| <= MAX_MAGNITUDE``; ``rates(pi0, t, max |pi0|)`` of ``limits = (free,
    rates)`` where ``max |pi0| > free``), then checked off the degenerate set by :func:`start_check`;
    on that set ``refuse(P)`` (``P`` the start as a column) raises the caller's refusal. The first pair
    of :func:`refimpl._flow_compiled._control` (``A`` at ``local_tolerances(tol)[0]``, ``B`` at
    :data:`refimpl._full_state.B_MAX_RATIONAL` or tighter, each at its kernel order) runs as the two
    rows of one call of :func:`refimpl._full_state_rational_kernel.adaptive` (each row's run that of the
    kernel alone; a separate compiled function calling it twice cost 1.5-2.5 s more on modified
    su(3)'s fully cold first call: numba re-optimises the callee inside it), a failed run raises as
    :func:`_runner`'s, and the pair is estimated as the control's
    first pair (:func:`first_estimate` with :data:`refimpl._full_state.PROP_MIN_B_RATIONAL`, plus the
    rounding floor and the logarithm's residual of :func:`refimpl._full_state._floor_one`, measured by
    one compiled call as :class:`refimpl._full_state._Answer` does). Only when it does not pass does
    the call enter the control (:func:`refimpl._full_state._go_on` from that pair). Work arrays are
    kept between calls in a pool (concurrent calls never share them; never returned). A call whose
    ``N |t|`` takes the generated kernel (:func:`use_generated`) runs :func:`rational_full_state_flow`."""
    rfs = rational_full_state(model, abelian)
    fs = rfs.fs
    n, consts, start = fs.n, fs.start_consts, _fsk.start
    eps_a = local_tolerances(tol)[0]
    eps_b = _eps_b(eps_a, _fs.B_MAX_RATIONAL)
    tols = np.array([eps_a, eps_b])
    orders = np.array([_ct.adaptive_order(e) + ORDER_BIAS for e in (eps_a, eps_b)], dtype=np.int64)
    tables, cmax, kernel = rfs.tables(), float(_cr.COND_MAX), _fk.adaptive
    degenerate = start_check(model, fixed_types=True)  # P[:, 0] of the pool's (n, 1) arrays
    log = fs.log_pair  # as _Answer.measure calls it
    pmin, floor_one, max_steps = _fs.PROP_MIN_B_RATIONAL, _fs._floor_one, _fs.MAX_STEPS
    pool = []
    kernel_, log_, start_ = kernel, log, start
    gen_from = GENERATED_MIN_WORK if fs.n_products <= GENERATED_MAX_PRODUCTS else math.inf

    def run(x0, pi0, t):
        nonlocal kernel_, log_, start_
        t = float(t)  # the entry points take the types of the first call
        try:
            s, X, P, ends = pool.pop()
        except IndexError:  # none free (the first call, or one running in another thread)
            s, X, P = _fs._scratch(fs), np.empty((n, 1)), np.empty((n, 1))
            ends = (np.empty(2), np.empty(2))  # the time reached and the sensitivity of A and B
        if not admitted(load_point(x0, pi0, X, P, MAX_MAGNITUDE), pi0, t, limits):
            pool.append((s, X, P, ends))
            return None
        if degenerate(P[:, 0]) and refuse is not None:
            refuse(P)  # raises: the start on the degenerate set, named as the general route does
        if abs(t) >= gen_from:  # the generated kernel's span (use_generated): the general route
            out = rational_full_state_flow(model, X, P, t, tol, abelian=abelian)
            pool.append((s, X, P, ends))
            return finite_one(out["x"][:, 0], out["pi"][:, 0], t)
        y0, B, sB = s[0], s[2], s[4]
        G, Ad, est, size, xs, ok, resid = s[5:12]
        start_(X, P, *consts, y0)
        AB, steps, (te, co) = s[12], s[13], ends
        kargs = (y0, t, tols, orders, max_steps, *tables, cmax, AB, steps, te, co)
        kernel_(*kargs)  # A and B, each row as adaptive runs it alone
        for i in (0, 1):
            if steps[i] < 0:  # A first, as the control names it
                j = slice(i, i + 1)
                _cr._raise_failed(AB[j], steps[j], te[j], co[j], t, _cr.COND_MAX, SENSITIVITY)
        if not log_(*s[14]):  # the scratch's whole argument tuple (refimpl._full_state._scratch)
            _fs._log_complete(fs, B, G, Ad, xs, ok, resid)
        if kernel_ is kernel:  # the first call: the entry points of the types it used
            start_ = entry_point(start, (X, P, *consts, y0))
            kernel_ = entry_point(kernel, kargs)
            log_ = entry_point(log, s[14])
        dv = est.item()
        e = first_estimate(dv, eps_a, eps_b, pmin, PROP_MAX_D)
        if e + floor_one(sB.item(), n, size.item(), dv / eps_a, resid.item()) <= tol:
            x, pi = xs[0].copy(), B[0, :n].copy()
            pool.append((s, X, P, ends))
            return finite_one(x, pi, t)
        # the control from this pair (s stays with this call's results)
        res, _, _, ans = _fs._go_on(fs, model, y0, t, tol, s, _runner(rfs))
        return finite_one(ans.all[2][0].copy(), res[0, :n].copy(), t)

    return run


def one_trajectory_su2(model, tol: float, limits=(math.inf, None), refuse=None):
    """``run(x0, pi0, t) -> (x, pi)`` at ``tol`` for one su(2)/so(3) trajectory with ``Upsilon != 0``
    (``x0``, ``pi0`` 1-D float64 of shape (3,), ``t`` a float; ``x``, ``pi`` fresh arrays, finite: else
    refused by name): :func:`refimpl._flow_compiled.compiled_taylor_flow` of that trajectory, the same
    computation with the constants of the call looked up once (issue 25: the Python around the
    protocol call; the ``Upsilon = 0`` runner is :func:`refimpl._flow_compiled.one_trajectory`).

    The start is read and checked as that runner reads it (``_load_start``: None where an entry is not
    finite with ``|v| <= MAX_MAGNITUDE``; ``rates(pi0, t, max |pi0|)`` of ``limits = (free, rates)``
    where ``max |pi0| > free``), then off the degenerate set
    (:func:`start_check`; on it ``refuse(P)``, ``P`` the start as a column,
    raises the caller's refusal). The first pair of :func:`refimpl._flow_compiled._control` (``A`` at
    ``local_tolerances(tol)[0]``, ``B`` at its ``eps_B``, each at Jorba-Zou's order, as
    :func:`rational_run` runs them) on the structure's kernel, failed runs raised as there, then the
    estimate and logarithm in one compiled call (``_finish``) and the control's first estimate
    (:func:`refimpl._flow_compiled.first_estimate`); only a pair that does not pass enters the control
    (``_go_on`` from that pair). Work arrays are kept between calls in a pool (never returned)."""
    if not (model.su2 and not model.upsilon_zero):
        raise ValueError("compiled rational one_trajectory: for su(2)/so(3) with Upsilon != 0")
    rf = _cr._field(model, quat=True)
    kernel = _cr.rational_kernel(rf).adaptive
    n, d, grav = model.n, rf.d, bool(model.gravity)
    gamma = model.gamma if grav else _fc._NO_GAMMA
    eps_a, eps_b = _fc.local_tolerances(tol)
    pa, pb = _ct.adaptive_order(eps_a), _ct.adaptive_order(eps_b)
    fargs, cmax, max_steps = (
        rf.args(),
        float(_cr.COND_MAX),
        10_000_000,
    )  # rational_taylor_adaptive's
    pmin, pmax_d = _fc.PROP_MIN_B, _fc.PROP_MAX_D  # _control's defaults (compiled_taylor_flow)
    degenerate = start_check(model, fixed_types=True)  # y0[0, :n] of the pool's (1, d) arrays
    load, finish = _fc._load_start, _fc._finish  # |A - B| and the logarithm, one compiled call
    pool = []
    empty, i64 = np.empty, np.int64
    kernel_, finish_ = kernel, finish

    def run(x0, pi0, t):
        nonlocal kernel_, finish_
        t = float(t)  # the entry points take the types of the first call
        try:
            s = pool.pop()
        except IndexError:  # none free (the first call, or one running in another thread)
            s = (empty((1, d)), empty((1, d)), empty((1, d)), empty(1, i64), empty(1, i64))
            s += tuple(empty(1) for _ in range(5))
        y0, A, B, sA, sB, tA, cA, tB, cB, est = s
        if not admitted(load(x0, pi0, gamma, grav, y0, MAX_MAGNITUDE), pi0, t, limits):
            pool.append(s)
            return None
        if degenerate(y0[0, :n]) and refuse is not None:  # y0's pi is pi0 (read by _load_start)
            refuse(y0[0, :n].reshape(n, 1).copy())  # raises, named as the general route does
        kernel_(y0, t, eps_a, pa, max_steps, *fargs, cmax, A, sA, tA, cA)
        kernel_(y0, t, eps_b, pb, max_steps, *fargs, cmax, B, sB, tB, cB)
        for Y, st, te, co in ((A, sA, tA, cA), (B, sB, tB, cB)):
            if st[0] < 0:
                _cr._raise_failed(Y, st, te, co, t, _cr.COND_MAX)
        x = empty((n, 1))
        finish_(A, B, n, est, x)
        if kernel_ is kernel:  # the first call: the entry points of the types it used
            kernel_ = entry_point(
                kernel, (y0, t, eps_a, pa, max_steps, *fargs, cmax, A, sA, tA, cA)
            )
            finish_ = entry_point(finish, (A, B, n, est, x))
        if first_estimate(est.item(), eps_a, eps_b, pmin, pmax_d) <= tol:
            pi = B[0, :n].copy()
            pool.append(s)
            return finite_one(x[:, 0], pi, t)  # B's pi or x not finite: refused by name
        out = _fc._go_on(model, y0, t, eps_a, n, tol, (A, B, sB), False)  # s stays with this call
        return finite_one(out["x"][:, 0], out["pi"][:, 0], t)

    return run
