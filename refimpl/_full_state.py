"""The full state of every model through the faithful representation: a compiled adaptive Taylor flow.

The state (``Upsilon = 0``)
    ``y = (pi, [Gamma,] G, [s])`` with ``G = rho(g)`` the group element in the algebra's faithful
    matrix representation (:func:`refimpl._representation.representation_for`, ``rho(e_a) = E_a``),
    complex entries split into real and imaginary parts. The left-trivialised kinematics
    ``g^-1 dg/dt = Omega`` (vier10) read ``dG/dt = G rho(Omega)``, ``Omega = I^-1 pi``: bilinear in
    ``(G, pi)``, so the whole state is a quadratic polynomial field and the Taylor recurrences of
    Jorba and Zou integrate it exactly as they do the body system -- no chart, no re-basing, no
    ``exp``/``log`` along the way. The body block is :func:`refimpl._taylor.quadratic_field`'s
    (Euler twee14/drie6, Euler-Poisson twee17 sign-corrected/twee18 with ``dV`` of twee16, Theta terms):

        pidot_a     = -f^m_ab pi_m Omega_b + Theta_ab Omega_b + (G_L)_am Gamma_m,
        Gammadot_mu = f^a_{b mu} Omega_b Gamma_a,
        dG_ij/dt    = sum_k G_ik M_kj,     M = rho(Omega) = Omega_b E_b.

    ``s = p(x)``, the abelian part of ``x`` on exponential algebras (:class:`refimpl.flows._common.
    _AbelianPart`: ``p`` is a homomorphism onto an abelian algebra, so ``ds/dt = P Omega``), rides along
    as a linear integral (used by the logarithm, never by the step control).

The recurrence
    ``Omega_k = I^-1 pi_k`` and ``M_k = rho(Omega_k)`` are linear in the coefficients (computed once per
    order, through the nonzero patterns of ``I^-1`` and of the ``E_b``), and every bilinear term is a
    Cauchy product ``sum_{a<=k} u_a v_{k-a}`` of two such series; a factor whose field vanishes
    identically (a constant entry of ``G``, e.g. the last row of an affine matrix) keeps its ``a = 0``
    term only. So a step costs ``(#products) P^2 / 2`` multiply-adds with ``#products`` counted on the
    sparsity of ``f`` and of ``rho`` (``r nnz(M)`` for ``G``, not ``r^2 n``).

What is compiled
    One module per *structure*: the source is generated from the dimension, the nonzero patterns of
    ``f``, ``I^-1``, ``Theta``, ``G_L``, ``E_b`` and which entries of ``G`` vary; the numbers are one
    array argument ``c`` (read once per call into locals), the order ``P`` an argument. Files live under
    :func:`refimpl._compiled_taylor.cache_dir`, named by the hash of the source, compiled with
    ``cache=True`` (3-7 s of CPU per structure the first time, :data:`GENERATED_MIN_WORK`). The kernel
    compiled once for every structure (:mod:`refimpl._full_state_kernel`, the same recurrence from
    sparse tables, about 2x slower per step) stays as ``FullState.run(generated=False)``.

The output
    ``Ad(g)`` from ``G``: ``G E_b G^-1 = Ad(g)_ab E_a`` (projected on the ``E_a``); ``x`` by the
    project's logarithm :meth:`refimpl._representation.Representation.log` of ``G`` (principal in
    ``rho``, else through ``Ad(g)`` and the centre; the choice the mpmath reference makes whenever its
    chart was re-based, and equal to the chart coordinate where it never was), on exponential algebras
    with its abelian part replaced by the integrated ``s`` (:class:`refimpl.flows._common._AbelianPart`).

Error control
    The two runs of :mod:`refimpl._flow_compiled` (a checking run ``A`` and the answer ``B``), the
    estimate measured where the user reads the result: ``max(|pi_A - pi_B|, |Ad_A - Ad_B|)`` per
    trajectory, through the same control function (:func:`refimpl._flow_compiled._control`) as the
    su(2) full state, with the full state's own constants (``Upsilon != 0`` keeps the su(2) ones,
    :data:`B_MAX_RATIONAL`):

    * ``A`` at :data:`A_LOOSE` = 1e-6 and ``B`` at :data:`B_MAX` = 2e-15 for ``tol >= 1e-10``; the
      proportional estimate ``30 (eps_B / eps_A) |A - B|`` (Shampine's two tolerances) is kept down to
      :data:`PROP_MIN_B` = 1e-15, so one pair passes wherever the flow amplifies its local errors at
      most ``tol / (30 eps_B)`` (1667) times -- a third run costs more than the tighter ``B``;
    * a trajectory over ``tol`` gets ``B`` alone tightened when the proportional estimate then passes,
      else ``A`` tightened (``B`` kept: never a held ``B`` as ``A``, whose pair would sit at the float64
      floor), and as a last resort, with ``A`` at its floor (or the observed amplification saying that a
      tighter ``A`` fails), the held ``B`` becomes ``A`` once;
    * every estimate gets the rounding floor that ``|A - B|`` cannot see, since both runs share it
      (:data:`ROUND_PER_STEP` per step, :data:`ROUND_AMPLIFIED` times the observed amplification), and,
      for every row inside the control (its ``floor`` hook, :class:`_Answer`: a retry sees it, in a
      batch as alone), the logarithm's measured error ``max |Ad(exp(x)) - Ad(g_B)|``: by the triangle
      inequality the estimate then bounds the error of the ``x`` and ``pi`` returned, checked against
      the mpmath reference in ``tests/test_full_state_estimate.py``. The estimate, ``G``, ``Ad(g)``,
      the logarithm and its residual of a pair are one compiled call
      (:func:`refimpl._full_state_kernel.pair_log`).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from . import _compiled_taylor as _ct
from . import _full_state_batch as _fsb
from . import _full_state_kernel as _fk
from ._flow_checks import admitted, finite_one, load_point
from ._flow_compiled import (
    A_LOOSE_FROM,
    PROP_MAX_D,
    REUSE_B,
    _control,
    _eps_b,
    entry_point,
    first_estimate,
    local_tolerances,
)
from ._validate import MAX_MAGNITUDE
from .codegen import import_source
from .codegen.full_state import full_state_source

__all__ = ["FullState", "applies", "full_state", "full_state_flow", "one_trajectory"]

EPS = np.finfo(float).eps
_EPS = float(EPS)
GENERATED_MIN_WORK = 0.0
"""``N |t|`` (trajectories times the time span) from which a flow runs the kernel generated for its
structure (:func:`refimpl.codegen.full_state.full_state_source`: every product unrolled, about 2x
faster per step) instead of the one compiled for every structure (:mod:`refimpl._full_state_kernel`,
kept for ``FullState.run(generated=False)``). 0: always the generated one -- its compilation, 3-7 s
of CPU per structure before the disk cache has it (su(3) the largest measured: 6.9 s; the Horner
update and the step norms are loops over index tables and the products run in chunks of
``PRODUCT_CHUNK``, which took su(3) down from 12 s), stays under the 10 s per structure of issue 25.
A function of the call's inputs, so a call's result never depends on what ran before it."""


GENERATED_MAX_PRODUCTS = 1000
"""Structures with more distinct Cauchy products than this run the generated kernel only from
``N |t| >= GENERATED_MIN_WORK_LARGE``; below it (the free so(5) and sp(4, R) tops in the adjoint
representation: 660 products; su(3): 140, se(3), so(4) fewer) always. Was 400, when the generated
kernel's first compilation cost so(5) 17 s of CPU (load 6); written as LLVM IR
(:mod:`refimpl.codegen._full_state_ir`, issue 25, session 7) it costs 2.15 s, and the one-trajectory
call of so(5) (the sweep's ``so5_free``, T = 1) runs 2.5x faster on it: 494 -> 197 us (one process
each, CPU, best of 7 x 20, load 3.7), its fully cold first call (empty TSTARG_CACHE_DIR and
NUMBA_CACHE_DIR) 7.80 -> 8.47 s, under issue 25's 10 s. 1000: the lane kernel's
:data:`refimpl._full_state_batch.MAX_GENERATED_TERMS` (every product written out up to it); larger
structures (none in the catalogue measured) keep the kernel compiled for every structure, about 2x
slower per step and nothing to compile. A function of the call's inputs and the structure."""

GENERATED_MIN_WORK_LARGE = 1024.0
"""``N |t|`` from which a structure above :data:`GENERATED_MAX_PRODUCTS` runs its generated kernel
(as the rational path's ``GENERATED_MIN_WORK``)."""

MAX_STEPS = _fsb.MAX_STEPS
"""The kernels' step budget per trajectory (status -3 beyond it): :data:`refimpl._full_state_batch.MAX_STEPS`."""

B_MAX = 2e-15
"""``B``'s largest local tolerance on the full state (the su(2) quaternion state's is
:data:`refimpl._flow_compiled.B_MAX`, 1e-13). With ``A`` at :data:`A_LOOSE` (the default ``tol = 1e-10``) the
proportional estimate ``30 (eps_B / eps_A) |A - B|`` passes in one pair of runs while the global
error of ``A`` is at most ``tol / (30 eps_B) = 1667`` times its local tolerance (at 3e-14: 111).
Measured ratios global error / local tolerance: up to ~2500 (Bianchi VI0 with a cocycle, T = 10:
1200 for ``A`` at 1e-8, 770 at 1e-6), which took a third run with ``B`` at 3e-14; ``B`` costs 3-10 % more here than at 3e-14 (the
order rises by two, the steps barely), a third run 40-100 %. Kept at or above :data:`PROP_MIN_B`."""

PROP_MIN_B = 1e-15
"""``B``'s tightest local tolerance for the proportional estimate on the full state (the su(2) state's
is :data:`refimpl._flow_compiled.PROP_MIN_B`, 1e-14). Its reason there: below it the global error
stops scaling with ``eps`` (the rounding floor, about ``kappa 1e-14`` for a flow amplifying its
local errors ``kappa`` times), so ``30 kappa eps_B`` must stay above ``kappa 1e-14``: ``eps_B >=
3.3e-16``; the full state's update is compensated (Kahan) and :data:`ROUND_PER_STEP` charges the floor
explicitly."""

A_LOOSE = 1e-6
"""``A``'s local tolerance on the full state for ``tol >= A_LOOSE_FROM`` (the su(2) state's is
:data:`refimpl._flow_compiled.A_LOOSE`, 1e-8): the estimate is then the proportional one, whose pass
condition ``kappa_A <= tol / (30 eps_B)`` does not depend on ``eps_A``, and ``A`` costs 30-35 % less
than at 1e-8 (bench problems, T = 10: so(4) 26 vs 39 us, se(3) 45 vs 69, su(3) 23 vs 33, Bianchi VI0 10
vs 15). Measured ratios ``kappa = error / eps`` of ``A`` at 1e-6 and ``B`` at 2e-15 (generated kernels,
``ORDER_BIAS`` = 4 then; at 2: ``A`` se(3) 20, Bianchi VI0 450, ``B`` 37 and 270): se(3) 18 and 39, Bianchi VI0 770 and 910; so(4) and su(3) 0.05 and 1 with ``B`` at the
rounding floor (covered by :data:`ROUND_PER_STEP`): within the safety factor 30."""

ROUND_AMPLIFIED = 30.0
"""The rounding floor's amplified part: ``ROUND_AMPLIFIED eps kappa`` with ``kappa`` the largest
``|A - B| / eps_A`` seen (how much the flow amplifies local errors, per unit of local tolerance). Each
step's rounding is a local error of a few ``eps |y|`` while the Jorba-Zou step leaves a truncation of
0.05-1 ``eps_A |y|``: the shared rounding grows ``kappa eps`` times that ratio (1-80; 4-20 seen).
Measured: se(3), random inertia, T = 30: ``kappa`` 6600, error of ``B`` 5.5e-12 = 3.7 ``eps kappa``
(both runs near the floor differed by 1.75e-12 only: the rounding of the start and of the steps is
shared). Was 10, the middle of that range, which did not bound every error (issue 25, session 7):
over 748 answers of ``full_state_flow`` at ``tol = 1e-10`` (random SPD inertias with eigenvalues in
[0.5, 3], ``x0 = 0.3 N``, ``pi0 = N``, T = 1/3/10/30 on h(3), Bianchi III with a cocycle, V, VI0,
se(2), sl(2, R), se(3), so(4), su(3), seeds 25-30, 4 models each:
``tests/benchmarks/full_state_estimate_constants.py SEED 4 flow``), against heyoka in long double with
``Ad(exp x)`` at 40 digits, the factor that just covers the error, ``ROUND_AMPLIFIED + (err - estimate)
/ (eps kappa)``, was at most 17.3 (Bianchi III + cocycle, T = 30: the control's retry with ``A`` at
:data:`refimpl._flow_compiled.EPS_FLOOR` = 1e-14 next to ``B`` at 2e-15, where ``|A - B|`` is itself
mostly rounding; err/estimate 1.13 at 10), every other answer at most 10.5 once the logarithm's own
error is measured right (wt7/log's closed-form logarithms; on 58f381e's logarithm Bianchi VI0 answers
needed more through the logarithm's ``x``, not the runs). 30 covers 17.3 with a margin of 1.7. At the
default ``tol`` no first pair changes its verdict: with ``|A - B| <= PROP_MAX_D = 1e-3`` the
estimate ``(PROP eps_B + ROUND_AMPLIFIED eps) |A - B| / eps_A`` stays below 6.7e-11."""

B_MAX_RATIONAL, PROP_MIN_B_RATIONAL = 3e-14, 1e-14
"""The same two for the ``Upsilon != 0`` kernel (:mod:`refimpl._full_state_rational`, its ``run``): its
steps cost more with the order (one ``Psi_0`` solve per order), so ``B`` at 2e-15 cost 9 % more on the
bench's modified su(3) for no third run saved."""

ROUND_PER_STEP = 4.0
"""The rounding floor added to every estimate: ``ROUND_PER_STEP eps (sqrt(steps) + n) max(1, |pi|, |Ad|)``
(float64 ``eps``; ``steps`` of the answer ``B``). Error model: each step's coefficients and the
compensated Horner update round to a few units ``eps |y|``, independently from step to step (a random
walk: ``sqrt(steps)``), and ``Ad(g)`` from ``G`` to about ``n eps |Ad|``; ``|A - B|`` cannot see the part
both runs share. Measured (free su(3), so(4), T = 10, ``B`` at 1e-15 and 2e-15): errors 16-26 ``eps``
at 9-15 steps, where the proportional estimate alone came out 0.2-0.7 of the error. The logarithm's
own error is measured, not modelled: ``max |Ad(exp(x)) - Ad(g_B)|`` is added to the estimate too."""


def applies(model) -> bool:
    """The compiled full state covers ``Upsilon = 0`` on every algebra whose representation exists."""
    return bool(_ct.HAVE_NUMBA and model.upsilon_zero and not model.su2)


class FullState:
    """One model's full-state field: variables, the generated kernel source and its numbers."""

    def __init__(self, model, rep, abelian_P=None):
        n = model.n
        self.n = n
        self.rep = rep
        mats = np.asarray(rep.mats)
        cplx = np.iscomplexobj(mats)
        self.cplx = cplx
        r = mats.shape[-1]
        self.r = r
        parts = [mats.real] + ([mats.imag] if cplx else [])
        Mpat = [np.any(p != 0, axis=0) for p in parts]  # (r, r) per part
        # reachable pattern of G = rho(g): closure of the identity under right multiplication by M
        Gp = [np.eye(r, dtype=bool)] + ([np.zeros((r, r), bool)] if cplx else [])
        while True:
            new = [g.copy() for g in Gp]
            for pa, g in enumerate(Gp):
                for pb, m in enumerate(Mpat):
                    prod = (g.astype(int) @ m.astype(int)) > 0
                    new[(pa + pb) % 2 if cplx else 0] |= prod
            if all(np.array_equal(a, b) for a, b in zip(new, Gp)):
                break
            Gp = new
        self.Gpat = Gp
        grav = bool(model.gravity)
        self.gravity = grav
        coef: list[float] = []

        def cidx(v) -> int:
            coef.append(float(v))
            return len(coef) - 1

        names: list[str] = []  # variable names, state first
        # state layout
        pi = [f"pi{a}" for a in range(n)]
        ga = [f"ga{a}" for a in range(n)] if grav else []
        gvars = []  # (part, i, j)
        for pa in range(len(Gp)):
            for i in range(r):
                for j in range(r):
                    if Gp[pa][i, j]:
                        gvars.append((pa, i, j))
        gname = {gv: f"g{gv[0]}_{gv[1]}_{gv[2]}" for gv in gvars}
        self.gvars = gvars
        ab = [] if abelian_P is None else [f"s{ell}" for ell in range(abelian_P.shape[0])]
        names = pi + ga + [gname[g] for g in gvars] + ab
        self.d = len(names)
        self.n_ab = len(ab)
        # derived (linear) variables: Omega, M entries
        Ii = model.Iinv
        om = {}  # b -> list of (coef index, pi name)
        for b in range(n):
            om[b] = [(cidx(Ii[b, c]), pi[c]) for c in range(n) if Ii[b, c] != 0]
        mv = {}  # (part, k, j) -> list of (coef index, b)
        for pa, part in enumerate(parts):
            for k in range(r):
                for j in range(r):
                    terms = [(cidx(part[b, k, j]), b) for b in range(n) if part[b, k, j] != 0]
                    if terms:
                        mv[(pa, k, j)] = terms
        # field: per state variable, linear terms (coef, var) and product terms (coef or sign, u, v)
        lin: dict[str, list] = {v: [] for v in names}
        quad: dict[str, list] = {v: [] for v in names}
        f = model.f
        for m, a, b in np.argwhere(f != 0):
            quad[pi[a]].append((cidx(-f[m, a, b]), pi[m], f"om{b}"))
        if not model.theta_zero:
            for a in range(n):
                for b in range(n):
                    if model.theta[a, b] != 0:
                        lin[pi[a]].append((cidx(model.theta[a, b]), f"om{b}"))
        if grav:
            GL = model.G_L
            for a in range(n):
                for m in range(n):
                    if GL[a, m] != 0:
                        lin[pi[a]].append((cidx(GL[a, m]), ga[m]))
            for a, b, mu in np.argwhere(f != 0):  # f^a_{b mu} Omega_b Gamma_a
                quad[ga[mu]].append((cidx(f[a, b, mu]), f"om{b}", ga[a]))
        # dG_ij = sum_k G_ik M_kj (complex: re = Gr Mr - Gi Mi, im = Gr Mi + Gi Mr)
        for pa, i, k in gvars:
            for (pb, kk, j), _ in mv.items():
                if kk != k:
                    continue
                tgt_part = (pa + pb) % 2 if cplx else 0
                sign = -1.0 if (pa == 1 and pb == 1) else 1.0
                tgt = (tgt_part, i, j)
                if tgt not in gname:  # cannot happen: the pattern is closed
                    raise AssertionError("full state: G pattern not closed")
                quad[gname[tgt]].append((sign, gname[(pa, i, k)], f"m{pb}_{kk}_{j}"))
        if abelian_P is not None:
            for ell in range(abelian_P.shape[0]):
                for b in range(n):
                    if abelian_P[ell, b] != 0:
                        lin[ab[ell]].append((cidx(abelian_P[ell, b]), f"om{b}"))
        # constant variables: state variables whose field vanishes identically (a state variable whose
        # field has terms is never constant, even when all their factors are)
        const = {v for v in names if not lin[v] and not quad[v]}
        self.names, self.const = names, const
        self.om, self.mv, self.lin, self.quad = om, mv, lin, quad
        self.coef = np.array(coef, dtype=float)
        self.step_vars = [v for v in pi + ga + [gname[g] for g in gvars] if v not in const]
        self.var = [v for v in names if v not in const]
        self.n_products = len({(u, w) for v in names for _, u, w in quad[v]})
        self.source = full_state_source(self)
        self._mod = None

    # ------------------------------------------------------------------ kernel
    def module(self):
        if self._mod is None:
            self._mod = import_source(self.source, "fullstate_")
        return self._mod

    def tables(self):
        """The sparse tables of :mod:`refimpl._full_state_kernel` (built once)."""
        tb = getattr(self, "_tables", None)
        if tb is not None:
            return tb
        n, names, const, coef = self.n, self.names, self.const, self.coef
        idx = {v: i for i, v in enumerate(names)}
        dnames = [f"om{b}" for b in range(n)] + [f"m{pa}_{k}_{j}" for (pa, k, j) in self.mv]
        for v in dnames:
            idx[v] = len(idx)
        dconst = {f"om{b}" for b in range(n) if all(p in const for _, p in self.om[b])}
        dconst |= {
            f"m{pa}_{k}_{j}"
            for (pa, k, j), t in self.mv.items()
            if all(f"om{b}" in dconst for _, b in t)
        }
        allc = const | dconst
        drow, dptr, didx, dcoef = [], [0], [], []
        for b in range(n):
            drow.append(idx[f"om{b}"])
            for ci, p in self.om[b]:
                didx.append(idx[p])
                dcoef.append(coef[ci])
            dptr.append(len(didx))
        for (pa, k, j), t in self.mv.items():
            drow.append(idx[f"m{pa}_{k}_{j}"])
            for ci, b in t:
                didx.append(idx[f"om{b}"])
                dcoef.append(coef[ci])
            dptr.append(len(didx))
        prods: dict = {}
        pu, pw, pcls = [], [], []
        for v in names:
            for _, u, w in self.quad[v]:
                if (u, w) in prods:
                    continue
                prods[(u, w)] = len(pu)
                pu.append(idx[u])
                pw.append(idx[w])
                cu, cw = u in allc, w in allc
                pcls.append(3 if cu and cw else 1 if cu else 2 if cw else 0)
        order = sorted(range(len(pu)), key=lambda p: pcls[p] != 0)  # general products first
        rank = {p: i for i, p in enumerate(order)}
        prods = {key: rank[p] for key, p in prods.items()}
        pu, pw, pcls = [pu[p] for p in order], [pw[p] for p in order], [pcls[p] for p in order]
        ng = sum(1 for c in pcls if c == 0)
        pad = (-ng) % 4  # groups of four general products; the padding multiplies the zero row
        zero = len(idx)
        pu[ng:ng] = [zero] * pad
        pw[ng:ng] = [zero] * pad
        pcls[ng:ng] = [5] * pad  # class 5: the zero product (never read by the state rows)
        prods = {key: (p + pad if p >= ng else p) for key, p in prods.items()}
        vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon = [], [0], [], [], [0], [], [], []
        for v in self.var:
            vrow.append(idx[v])
            for c, u, w in self.quad[v]:
                qprod.append(prods[(u, w)])
                qcoef.append(c if isinstance(c, float) else coef[c])
            qptr.append(len(qprod))
            for ci, u in self.lin[v]:
                lvar.append(idx[u])
                lcoef.append(coef[ci])
                lcon.append(u in allc)
            lptr.append(len(lvar))
        i64 = lambda a: np.array(a, dtype=np.int64)  # noqa: E731
        f64 = lambda a: np.array(a, dtype=float)  # noqa: E731
        srow = i64([idx[v] for v in self.step_vars])
        self._tables = tb = (
            len(idx),
            i64(drow),
            i64(dptr),
            i64(didx),
            f64(dcoef),
            i64(pu),
            i64(pw),
            i64(pcls),
            i64(vrow),
            i64(qptr),
            i64(qprod),
            f64(qcoef),
            i64(lptr),
            i64(lvar),
            f64(lcoef),
            np.array(lcon, dtype=np.bool_),
            srow,
        )
        return tb

    def run(
        self,
        y0,
        T: float,
        tol: float,
        order: int | None = None,
        max_steps: int = MAX_STEPS,
        generated: bool = False,
    ):
        """``(y(T), steps)`` for the rows of ``y0`` (N, d) at the local tolerance ``tol``."""
        P = default_order(tol) if order is None else int(order)
        y = np.ascontiguousarray(y0, dtype=float)
        out = np.empty_like(y)
        steps = np.zeros(y.shape[0], dtype=np.int64)
        # issue 25 batch hook: W trajectories at a time in SIMD lanes (refimpl._full_state_batch)
        if generated and y.shape[0] >= _fsb.LANES and _fsb.applies(self):
            return _fsb.run(self, y, T, tol, P, max_steps)
        if generated:
            self.module().adaptive(
                y, float(T), float(tol), P, int(max_steps), self.coef, out, steps
            )
        else:
            _fk.adaptive(y, float(T), float(tol), P, int(max_steps), *self.tables(), out, steps)
        return out, steps


ORDER_BIAS = 2
"""Orders above Jorba-Zou's that the full state runs (``A`` at 1e-6: order 10, ``B`` at 2e-15: 20). At a
fixed local tolerance the global error *rises* with the order: the last two coefficients bound the
remainder less well at the longer steps of a higher order. Measured (generated kernel alone, ``B`` at
2e-15, error of ``pi`` and ``Ad(g)`` against heyoka in long double at tol 1e-19, load 2; orders JZ+0 / +2 /
+4 / +6): Bianchi VI0 with a cocycle 1.7e-13 / 5.4e-13 / 2.8e-12 / 1.1e-11 at 35.7 / 33.8 / 33.3 / 33.4 us;
Kirchhoff se(3) 6.6e-14 / 7.4e-14 / 1.2e-13 / 1.4e-13 at 172 / 168 / 167 / 165 us; so(4), su(3) flat at
1-3e-15. Through the protocol against heyoka at equal error (one run each, load 2): bias 4 / 2 / 0 gave
Bianchi 1.63 / 1.52 / 1.60 and se(3) 0.37 / 0.25 / 0.26 (heyoka then needs tol 1.8e-17 to match the
smaller error). +2 keeps the cost of +4 (within 5 %) at up to 5 times its accuracy. The earlier +4 was
chosen on time alone (se(3): 0.95x at 1e-8, 0.94x at 1e-13)."""


@functools.lru_cache(maxsize=256)
def default_order(tol: float) -> int:
    return _ct.adaptive_order(tol) + ORDER_BIAS


# ---------------------------------------------------------------------- the flow
def full_state(model, abelian=None) -> FullState:
    """The full-state field of ``model``, kept on the (cached, immutable) model. ``abelian``: the class
    :class:`refimpl.flows._common._AbelianPart` (passed in by the flows, which own it), used on
    exponential algebras."""
    fs = model.__dict__.get("_full_state")
    if fs is None or (fs.abelian is None and abelian is not None and fs.rep.exponential):
        rep = model.representation
        ab = abelian.of(model.f, 1) if (rep.exponential and abelian is not None) else None
        fs = FullState(model, rep, None if ab is None else ab.P)
        fs.abelian = ab
        if ab is not None:  # the tables of the compiled refine (_fk.abelian_batch)
            D = np.ascontiguousarray(ab.D, dtype=float)
            fs.abelian_tables = (
                np.ascontiguousarray(ab.P, dtype=float),
                np.ascontiguousarray(np.linalg.pinv(ab.P)),
                D,
                np.ascontiguousarray(np.einsum("ak,aij->kij", D, np.asarray(rep.mats).real)),
            )
        fs.mats = np.ascontiguousarray(rep.mats, dtype=complex if fs.cplx else float)
        fs.proj = np.ascontiguousarray(_projector(rep.mats))
        gv = np.array(fs.gvars, dtype=np.int64).reshape(-1, 3)
        fs.unit = 1j if fs.cplx else 0.0
        fs.gidx = (
            np.ascontiguousarray(gv[:, 0]),
            np.ascontiguousarray(gv[:, 1]),
            np.ascontiguousarray(gv[:, 2]),
            fs.n * (2 if fs.gravity else 1),
        )
        # the arguments of the compiled start (_fk.start) and logarithm (_fk.log_state*), built once
        fs.gamma = np.ascontiguousarray(model.gamma if fs.gravity else np.zeros(fs.n), dtype=float)
        fs.Pab = np.ascontiguousarray(np.zeros((0, fs.n)) if ab is None else ab.P, dtype=float)
        fs.refine = ab is not None and not fs.cplx
        # the abelian step of the compiled logarithm (_fk.log_state): 0 none, 1 compiled
        # (_fk.log_state_refined), 2 by the caller (_log_complete)
        fs.ab_mode = 0 if ab is None else (1 if fs.refine else 2)
        # the compiled pair and logarithm of this representation (_fk.pair_log_for; _Answer.measure)
        fs.log_pair = _fk.pair_log_for(
            fs.mats, fs.cplx, fs.abelian_tables[3] if fs.refine else None
        )
        # _fk.start's arguments after (x0, pi0) and before its output
        # (Ad(g) over the nonzero entries of rho and of proj: _fk.ad_table, _fk.ad_sparse)
        fs.adt, fs.adc = _fk.ad_table(fs.mats, fs.proj)
        fs.start_consts = (fs.mats, fs.adt, fs.adc, *fs.gidx, fs.gamma, fs.gravity, fs.Pab)
        # fs.log_pair's arguments between (A, B) and its outputs
        if fs.refine:
            fs.log_args = (fs.n, *fs.gidx, fs.mats, fs.proj, fs.adt, fs.adc, *fs.abelian_tables, ABELIAN_RTOL)  # fmt: skip
        else:
            fs.log_args = (fs.n, *fs.gidx, fs.unit, fs.mats, fs.proj, fs.adt, fs.adc, fs.cplx, fs.ab_mode)  # fmt: skip
        model.__dict__["_full_state"] = fs
    return fs


def _projector(mats) -> np.ndarray:
    """``Pinv`` (n, r^2 or 2 r^2) with ``x = Pinv vec(rho(x))`` (real and imaginary parts stacked)."""
    mats = np.asarray(mats)
    B = mats.real.reshape(mats.shape[0], -1)
    if np.iscomplexobj(mats):
        B = np.concatenate([B, mats.imag.reshape(mats.shape[0], -1)], axis=1)
    return np.linalg.pinv(B.T)


def _pack(fs: FullState, pi, Gamma, G, s) -> np.ndarray:
    """Rows ``(pi, [Gamma,] G entries, [s])`` (N, d) from pi (n, N), Gamma (n, N), G (N, r, r), s (k, N)."""
    N = pi.shape[1]
    y = np.empty((N, fs.d))
    n = fs.n
    y[:, :n] = pi.T
    if fs.gravity:
        y[:, n : 2 * n] = Gamma.T
    _fk.pack_G(G, *fs.gidx, y)
    if fs.n_ab:
        y[:, fs.d - fs.n_ab :] = s.T
    return y


def _unpack_G(fs: FullState, y) -> np.ndarray:
    G = np.empty((y.shape[0], fs.r, fs.r), dtype=fs.mats.dtype)
    _fk.unpack_G(y, *fs.gidx, G, fs.unit)
    return G


def _ad_of(fs: FullState, G) -> np.ndarray:
    """``Ad(g)`` (N, n, n) from ``G = rho(g)``: ``G E_b G^-1 = Ad_ab E_a`` projected on the ``E_a``."""
    out = np.empty((G.shape[0], fs.n, fs.n))
    _fk.ad_sparse(np.ascontiguousarray(G, dtype=fs.mats.dtype), fs.adt, fs.adc, out)
    return out


ABELIAN_RTOL = 1e-13
"""The log's abelian part is kept when it matches the integrated one this closely (relative) and, in
the compiled logarithm (:func:`refimpl._full_state_kernel.log_state_refined`), ``exp(rho(x))`` meets
``G`` to :data:`refimpl._full_state_kernel.LOG_REFINE_FLOOR`; else the row is refined from ``s``."""


def _check_steps(steps, t) -> None:
    if (steps[0] < 0) if steps.shape[0] == 1 else (steps.min() < 0):
        raise ValueError(
            f"compiled Taylor flow: trajectories {np.flatnonzero(steps < 0)[:10].tolist()} became "
            f"non-finite before t = {t} (diverged); no point is dropped"
        )


def _run(fs: FullState, y0, t, eps, generated=False, order=None):
    y, steps = fs.run(y0, t, eps, order=order, generated=generated)
    _check_steps(steps, t)
    return y, steps


def _log_complete(fs: FullState, B, G, Ad, xs, ok, resid) -> None:
    """Completes, in place, what :func:`refimpl._full_state_kernel.log_state` left. The answer's ``x``
    (N, n) with ``exp(x) = g``: the principal logarithm of ``G`` when the compiled one accepts it
    (:func:`refimpl._full_state_kernel.log_batch`), else :meth:`Representation.log` (rows not ``ok``);
    on exponential algebras the abelian part from the integrated ``s`` when the log's differs from it
    (:class:`refimpl.flows._common._AbelianPart`; compiled for a real representation,
    :func:`refimpl._full_state_kernel.abelian_batch`); then ``resid = max |Ad(exp(x)) - Ad(g_B)|``
    (0 where no logarithm was found, ``x`` not finite: :func:`refimpl.flows._fast.fast_flow` names
    those rows; inf where ``x`` is finite but the residual is not, e.g. ``Ad(g_B)`` not finite)."""
    s = None if fs.abelian is None else B[:, fs.d - fs.n_ab :].T
    for j in np.flatnonzero(~ok):
        xs[j] = fs.rep.log(G[j], Ad[j])
    if fs.abelian is not None:
        if not fs.cplx:
            _fk.abelian_batch(
                G, xs, np.ascontiguousarray(s), *fs.abelian_tables, fs.mats, ABELIAN_RTOL
            )
        else:
            for j in range(B.shape[0]):
                sj = s[:, j]
                dev = np.max(np.abs(fs.abelian.P @ xs[j] - sj))
                if dev > ABELIAN_RTOL * max(1.0, float(np.max(np.abs(sj)))):
                    xs[j] = fs.abelian.refine(fs.rep, G[j], xs[j], sj)
    _fk.log_residual(xs, fs.mats, fs.adt, fs.adc, Ad, resid)
    bad = ~np.isfinite(resid)
    if bad.any():
        xbad = ~np.all(np.isfinite(xs), axis=1)
        resid[bad & xbad] = 0.0  # no logarithm (x not finite): refused by name after the control
        resid[bad & ~xbad] = np.inf  # a finite x whose residual is unknown: no estimate passes


def _floor_one(steps: int, n: int, size: float, kappa: float, resid: float) -> float:
    """The floor of :meth:`_Answer.floor` for one trajectory, in Python floats: the rounding floor
    (:data:`ROUND_PER_STEP` per step, :data:`ROUND_AMPLIFIED` times ``kappa``) of an answer of ``steps``
    steps and size ``max(1, |pi|, |Ad|) <= max(1, size)``, plus its logarithm's residual ``resid``;
    inf where ``size`` is not finite (Python's ``max(1.0, nan)`` is 1.0: no such size may pass)."""
    if not size < math.inf:
        return math.inf
    per_step = ROUND_PER_STEP * (math.sqrt(steps) + n) * max(1.0, size)
    return _EPS * (per_step + ROUND_AMPLIFIED * kappa) + resid


class _Answer:
    """What the control's ``estimate`` hook measured of the ``B`` it was given, and what its ``floor``
    hook keeps of it per row: one compiled call per estimate (:func:`refimpl._full_state_kernel.pair_log`:
    ``|A - B|``, ``G``, ``Ad(g)`` and the size of ``B``, the logarithm ``x`` of ``B`` and its residual
    ``max |Ad(exp x) - Ad(g_B)|``), so that the floor adds that residual for every row -- a retry sees it,
    for one trajectory and for batches alike -- and the answer's ``x`` is the one already measured."""

    __slots__ = ("B", "G", "Ad", "size", "xs", "resid", "fs", "n", "N", "rows", "all")

    def __init__(self, fs: FullState, N: int):
        self.fs, self.n, self.N, self.B, self.all = fs, fs.n, N, None, None

    def measure(self, A, B, est) -> None:
        fs, M = self.fs, B.shape[0]
        G = np.empty((M, fs.r, fs.r), dtype=fs.mats.dtype)
        Ad = np.empty((M, fs.n, fs.n))
        size, xs, ok, resid = np.empty(M), np.empty((M, fs.n)), np.empty(M, np.bool_), np.empty(M)
        done = fs.log_pair(A, B, *fs.log_args, G, Ad, est, size, xs, ok, resid)
        if not done:
            _log_complete(fs, B, G, Ad, xs, ok, resid)
        self.B, self.G, self.Ad, self.size, self.xs, self.resid = B, G, Ad, size, xs, resid

    def estimate(self, A, B, n_, out) -> None:
        self.measure(A, B, out)

    def floor(self, B, steps, kappa, rows=None):
        """The rounding floor of the answer ``B`` and its logarithm's residual (:data:`ROUND_PER_STEP`,
        :data:`ROUND_AMPLIFIED`), per row; keeps ``G``, ``Ad``, ``x`` of those ``rows`` of the answer."""
        if self.B is not B:  # not the B just estimated (not reached by the control): measure it
            self.measure(B, B, np.empty(B.shape[0]))
        if self.N == 1:  # Python floats (numpy scalar arithmetic costs more)
            self.all = (self.G, self.Ad, self.xs, self.resid)
            return (
                _floor_one(
                    int(steps[0]),
                    self.n,
                    float(self.size[0]),
                    float(kappa[0]),
                    float(self.resid[0]),
                ),
            )
        if self.all is None:
            fs, N = self.fs, self.N
            self.all = (
                np.empty((N, fs.r, fs.r), dtype=fs.mats.dtype),
                np.empty((N, fs.n, fs.n)),
                np.empty((N, fs.n)),
                np.empty(N),
            )
        for full, part in zip(self.all, (self.G, self.Ad, self.xs, self.resid)):
            full[rows] = part
        per_step = ROUND_PER_STEP * (np.sqrt(steps) + self.n) * np.maximum(1.0, self.size)
        return EPS * (per_step + ROUND_AMPLIFIED * kappa) + self.resid


def full_state_flow(model, x0, pi0, t: float, tol: float, *, abelian=None, run=None) -> dict:
    """Full state ``(x, pi)`` of ``N`` trajectories (``x0``, ``pi0`` of shape (n, N)) at time ``t`` with
    the global tolerance ``tol`` (max-norm over ``pi`` and ``Ad(g)`` per trajectory, two runs).

    Returns ``pi``, ``Gamma``, ``x``, ``g`` (``rho(g)``, (N, r, r)), ``Ad``, ``rebases`` (zeros: no
    chart), ``steps``, ``error_estimate`` and ``path``. ``run``: the kernel, ``run(fs, y0, t, eps,
    generated) -> (y, steps)`` (default :func:`_run`; :mod:`refimpl._full_state_rational` passes the
    ``Upsilon != 0`` one; each kernel picks its own order for ``eps``). The estimate includes the
    logarithm's residual for every row inside the control (:class:`_Answer`), so a row over ``tol`` is
    retried by the control itself, in a batch as alone."""
    fs = full_state(model, abelian)
    n, N = pi0.shape
    y0 = _start(fs, np.ascontiguousarray(x0, dtype=float), np.ascontiguousarray(pi0, dtype=float))
    res, est, steps, ans = _solve(fs, model, y0, t, tol, run)
    G, Adres, xs, _ = (
        ans.all
    )  # of the final B of every row: its last floor (the control's last pass)
    return {
        "pi": res[:, :n].T.copy(),
        "Gamma": res[:, n : 2 * n].T.copy() if fs.gravity else None,
        "x": xs.T.copy(),
        "g": G,
        "Ad": Adres,
        "quat": None,
        "rebases": np.zeros(N, dtype=int),
        "steps": steps,
        "error_estimate": est,
        "path": _ct.PATH,
    }


def one_trajectory(model, tol: float, abelian=None, limits=(math.inf, None)):
    """``run(x0, pi0, t) -> (x, pi)`` at ``tol`` on ``model``: :func:`full_state_flow` of one trajectory
    (``x0``, ``pi0`` 1-D float64 of shape (n,), ``t`` a float; ``x``, ``pi`` fresh arrays of shape
    (n,), finite: else refused by name, :func:`refimpl._flow_checks.finite_one`), the same computation,
    without its dictionary and with the constants of the call looked up once, when the runner is built (issue 25: the Python around one trajectory;
    :func:`refimpl.flows._fast._flow_one` keeps it per model and ``tol``). The start is checked as it
    is read (:func:`refimpl._flow_checks.load_point`): ``run`` returns None where an entry is not
    finite with ``|v| <= MAX_MAGNITUDE``, and calls ``rates(pi0, t, max |pi0|)`` of ``limits = (free,
    rates)`` where ``max |pi0| > free`` (the caller's rates check; default never). Where :func:`_solve`
    runs a first pair (:func:`_protocol_pair`), the runner runs it into work arrays it keeps between
    calls (:func:`_scratch`; taken from a pool, so concurrent calls never share them, and never
    returned: ``x`` and ``pi`` are copies) and enters the control only when that pair does not pass;
    elsewhere it calls :func:`_solve`."""
    fs = full_state(model, abelian)
    n, d, consts, start = fs.n, fs.d, fs.start_consts, _fk.start

    if not _protocol_pair(fs, tol):

        def run(x0, pi0, t):
            X, P = np.empty((n, 1)), np.empty((n, 1))
            if not admitted(load_point(x0, pi0, X, P, MAX_MAGNITUDE), pi0, t, limits):
                return None
            y0 = np.empty((1, d))
            start(X, P, *consts, y0)
            B, _, _, ans = _solve(fs, model, y0, t, tol, None)
            return finite_one(ans.all[2][0], B[0, :n].copy(), t)

        return run

    pair, pool = _pair_of(fs), []

    def run(x0, pi0, t):
        nonlocal start
        t = float(t)  # the entry points take the types of the first call
        try:
            w = pool.pop()
        except IndexError:  # none free (the first call, or one running in another thread)
            s, X, P = _scratch(fs), np.empty((n, 1)), np.empty((n, 1))
            # with the views of x and pi of B, and start's whole argument tuple (built once)
            w = (s, X, P, s[9][0], s[2][0, :n], (X, P, *consts, s[0]))
        s, X, P, xv, pv, args = w
        if not admitted(load_point(x0, pi0, X, P, MAX_MAGNITUDE), pi0, t, limits):
            pool.append(w)
            return None
        start(*args)
        if start is _fk.start:  # the first call: the entry point of the types it used
            start = entry_point(_fk.start, args)
        y0 = s[0]
        e, final = pair(y0, t, s)
        if e <= tol:
            x, pi = xv.copy(), pv.copy()
            pool.append(w)
            # final: the compiled log accepted x (finite) and e <= tol says pi is (the estimate is inf
            # where B is not finite); else _log_complete's x may be NaN, refused by name here
            return (x, pi) if final else finite_one(x, pi, t)
        B, _, _, ans = _go_on(fs, model, y0, t, tol, s)  # s stays with this call's results
        return finite_one(ans.all[2][0], B[0, :n].copy(), t)

    return run


EPS_B_FIRST = _eps_b(A_LOOSE, B_MAX)
"""``B``'s first local tolerance at ``A``'s :data:`A_LOOSE` (as :func:`_control` derives it)."""
_FIRST_ORDERS = (default_order(A_LOOSE), default_order(EPS_B_FIRST))  # the runner's orders for them


def _protocol_pair(fs: FullState, tol: float, t: float = 0.0) -> bool:
    """Whether :func:`_solve` runs one trajectory's first pair itself (:func:`_pair_of`) for a call
    at ``tol`` to ``t``: ``A`` at :data:`A_LOOSE` (``tol >= A_LOOSE_FROM``) on the generated kernel
    (``|t| >= _generated_min_work(fs)``; ``t = 0``: at every ``t``)."""
    return tol >= A_LOOSE_FROM and abs(t) >= _generated_min_work(fs)


def _scratch(fs: FullState):
    """The arrays of one trajectory's first pair (:func:`_pair_of`): ``(y0, A, B, steps of A, steps
    of B, G, Ad(g), |A - B|, size, x, ok, residual, (A; B), (steps of A; of B), the log's arguments)``,
    as the pair kernel and :func:`refimpl._full_state_kernel.pair_log` fill them (``A``, ``B`` and
    their steps: the rows of ``(A; B)`` and of its steps; the last, ``fs.log_pair``'s whole argument
    tuple on these arrays, built once: a call spelled out with ``*fs.log_args`` in it builds its 20
    arguments again every time, 0.14 us)."""
    n, d, r = fs.n, fs.d, fs.r
    AB, steps = np.empty((2, d)), np.empty(2, dtype=np.int64)
    outs = (
        np.empty((1, r, r), dtype=fs.mats.dtype),
        np.empty((1, n, n)),
        np.empty(1),
        np.empty(1),
        np.empty((1, n)),
        np.empty(1, dtype=np.bool_),
        np.empty(1),
    )
    A, B = AB[:1], AB[1:]
    return (
        np.empty((1, d)),
        A,
        B,
        steps[:1],
        steps[1:],
        *outs,
        AB,
        steps,
        (A, B, *fs.log_args, *outs),
    )


def _pair_of(fs: FullState):
    """``pair(y0, t, s) -> (estimate, final)``: one trajectory's first pair, ``A`` at :data:`A_LOOSE` and ``B``
    at :data:`EPS_B_FIRST` (orders :data:`_FIRST_ORDERS`), on the two lanes of the generated module's
    pair kernel (:func:`refimpl._full_state_batch.pair_first`: each lane bit for bit the generated
    single kernel's run at its tolerance and order, for about the cost of the longer one), into the
    arrays ``s`` of :func:`_scratch`, estimated as :func:`_control`'s first pair
    (:func:`first_estimate` of ``|A - B|`` plus :class:`_Answer`'s floor, :func:`_floor_one`), with
    ``G``, ``Ad(g)``, ``x`` and the residual of ``B`` in ``s`` (:class:`_Answer`'s ``measure``: one
    compiled call; ``final``: whether that call completed ``x`` and the residual itself, so that ``x``
    is finite, else :func:`_log_complete` did). Without the general route's per-call Python (issue
    25); built once per structure
    (kept on ``fs``). Measured (A/B of the protocol call, single kernel twice against the pair, see
    the commit): Bianchi VI0 + cocycle, se(3), so(4), su(3), se(2)."""
    pair = fs.__dict__.get("_pair")
    if pair is not None:
        return pair
    kernel, coef, n = fs.module().pair, fs.coef, fs.n
    order_a, order_b = _FIRST_ORDERS
    log = fs.log_pair  # this representation's pair and logarithm (as _Answer.measure calls it)

    kernel_, log_ = kernel, log

    def pair(y0, t, s):
        nonlocal kernel_, log_
        _, _, B, sA, sB, G, Ad, est, size, xs, ok, resid, AB, steps, log_args = s
        kernel_(y0, t, A_LOOSE, EPS_B_FIRST, order_a, order_b, MAX_STEPS, coef, AB, steps)
        steps_a, steps_b = steps.tolist()
        if steps_a < 0:
            _check_steps(sA, t)
        if steps_b < 0:
            _check_steps(sB, t)
        final = log_(*log_args)
        if not final:
            _log_complete(fs, B, G, Ad, xs, ok, resid)
        if kernel_ is kernel:  # the first call: the entry points of the types it used
            kernel_ = entry_point(
                kernel, (y0, t, A_LOOSE, EPS_B_FIRST, order_a, order_b, MAX_STEPS, coef, AB, steps)
            )
            log_ = entry_point(log, log_args)
        d = est.item()
        e = first_estimate(d, A_LOOSE, EPS_B_FIRST, PROP_MIN_B, PROP_MAX_D)
        return e + _floor_one(steps_b, n, size.item(), d / A_LOOSE, resid.item()), final

    fs._pair = pair
    return pair


def _measured(fs: FullState, s) -> _Answer:
    """The :class:`_Answer` of one trajectory whose first pair ran into ``s`` (:func:`_pair_of`): its
    ``B``, ``G``, ``Ad(g)``, size, ``x`` and residual, as its ``measure`` and ``floor`` leave them."""
    ans = _Answer(fs, 1)
    ans.B, ans.G, ans.Ad, ans.size, ans.xs, ans.resid = s[2], s[5], s[6], s[8], s[9], s[11]
    ans.all = (s[5], s[6], s[9], s[11])
    return ans


def _runner(fs: FullState, run, gen: bool, N: int):
    """``run_(y, t, eps, order=None) -> (y(t), steps)`` for :func:`_control`: the caller's ``run`` (e.g.
    ``Upsilon != 0``), else the generated kernel called directly (``FullState.run``'s body), else
    :func:`_run` (batches in SIMD lanes, the kernel compiled for every structure)."""
    if run is not None:

        def run_(y, tt, eps, order=None):  # order None: the kernel's own for eps
            return run(fs, y, tt, eps, gen)

    elif gen and (N < _fsb.LANES or not _fsb.applies(fs)):
        kernel = fs.module().adaptive

        def run_(y, tt, eps, order=None):
            out = np.empty_like(y)
            steps = np.empty(y.shape[0], dtype=np.int64)
            kernel(y, float(tt), float(eps), default_order(eps), MAX_STEPS, fs.coef, out, steps)
            _check_steps(steps, tt)
            return out, steps

    else:

        def run_(y, tt, eps, order=None):
            return _run(fs, y, tt, eps, gen)

    return run_


def _start(fs: FullState, x0, pi0) -> np.ndarray:
    """The rows ``(pi, [Gamma,] G, [s])`` (N, d) at ``t = 0`` (:func:`_pack` of ``exp(rho(x0))``,
    compiled) from ``x0``, ``pi0`` (n, N), C-contiguous float64."""
    y0 = np.empty((pi0.shape[1], fs.d))
    _fk.start(x0, pi0, *fs.start_consts, y0)
    return y0


def _generated_min_work(fs: FullState) -> float:
    """``N |t|`` from which ``fs``'s flows run its generated kernel (:data:`GENERATED_MIN_WORK`,
    :data:`GENERATED_MIN_WORK_LARGE` above :data:`GENERATED_MAX_PRODUCTS`)."""
    return (
        GENERATED_MIN_WORK if fs.n_products <= GENERATED_MAX_PRODUCTS else GENERATED_MIN_WORK_LARGE
    )


def _solve(fs: FullState, model, y0, t, tol: float, run):
    """The two-run control and the refusal of :func:`full_state_flow` from the rows ``y0``: ``(B,
    estimate, steps of B, the _Answer holding G, Ad(g), x of the final B)``. One trajectory on the
    generated kernel runs its first pair through :func:`_pair_of` and enters the control only when
    that pair does not pass (:func:`_go_on`: the control then goes on from it)."""
    N = y0.shape[0]
    if N == 1 and run is None and _protocol_pair(fs, tol, t):
        t = float(t)
        s = (y0, *_scratch(fs)[1:])  # the log's arguments do not hold y0
        e, _ = _pair_of(fs)(y0, t, s)
        if e <= tol:
            return s[2], np.array([e]), s[4], _measured(fs, s)
        return _go_on(fs, model, y0, t, tol, s)
    return _go_on(fs, model, y0, t, tol, None, run)


def _go_on(fs: FullState, model, y0, t, tol: float, s, run=None):
    """:func:`_solve` from the start, or, one trajectory, from the first pair in ``s`` (the arrays of
    :func:`_pair_of`, whose estimate is over ``tol``): the two-run control and its refusal."""
    N, n = y0.shape[0], fs.n
    eps_a = local_tolerances(tol)[0] if run is not None or tol < A_LOOSE_FROM else A_LOOSE
    gen = N * abs(t) >= _generated_min_work(fs)
    if s is None:
        ans, first = _Answer(fs, N), None
    else:
        ans, first = _measured(fs, s), (s[1], s[2], s[4])
    res, est, steps = _control(
        model,
        y0,
        t,
        eps_a,
        n,
        tol,
        runner=(_runner(fs, run, gen, N), _no_order),
        estimate=ans.estimate,
        b_max=B_MAX if run is None else B_MAX_RATIONAL,
        prop_min_b=PROP_MIN_B if run is None else PROP_MIN_B_RATIONAL,
        reuse_b=0.0 if run is None else REUSE_B,
        floor=ans.floor,
        reuse_last=run is None,
        first=first,
    )
    if not (est[0] <= tol if N == 1 else np.all(est <= tol)):
        over = np.flatnonzero(~(est <= tol))
        raise ValueError(
            f"compiled Taylor flow: tolerance {tol} not reached on trajectories {over[:10].tolist()} "
            f"(estimated errors {est[over][:3].tolist()}, with the logarithm's) at the float64 floor"
        )
    return res, est, steps, ans


def _no_order(eps):
    return None
