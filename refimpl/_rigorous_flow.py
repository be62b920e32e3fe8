"""Rigorous flows of the polynomial body systems: an interval Taylor method with Lohner's QR wrapping control.

Systems (docs/conventions.md; ``Upsilon = 0``, so ``Phi = 1`` and ``Omega = dK = I^-1 pi``):

* Euler with a cocycle (twee14, drie6): ``pidot = -dV - S dK`` with ``S = pi.f - Theta``,
  i.e. ``pidot_a = -f^m_ab pi_m Omega^b + Theta_ab Omega^b``;
* Euler-Poisson (twee17 *sign corrected*, twee18): with gravity ``V = -(gamma | Ad(g) L)``,
  ``dV_b = -Gamma_m f^m_bc L^c`` and ``dGamma_mu/dt = Gamma_a f^a_{b mu} Omega^b``, so
  ``pidot_a = ... + Gamma_m f^m_ac L^c``; the state is ``y = (pi, Gamma)`` with
  ``Gamma(0) = Ad(exp x0)^T gamma`` (enclosed by Arb's rigorous matrix exponential).

Both are quadratic: ``y' = F(y) = c + A y + Q(y, y)``, stored sparsely as ball coefficients.

One step from ``t`` to ``t + h`` (the set at ``t`` is ``Y = yhat + B r``, ``yhat`` a point,
``B`` a point matrix, ``r`` a ball vector; Lohner 1987, Nedialkov-Jackson):

1. *A-priori enclosure* (Picard / inflation): find a box ``E`` with
   ``Y + [0, h] F(E) subset E``; then every solution starting in ``Y`` stays in ``E`` on
   ``[0, h]`` (the Picard operator maps the box of continuous paths in ``E`` into itself).
   Failing after a few inflations, ``h`` is halved.
2. *Taylor coefficients in ball arithmetic* by the Cauchy-product recurrence
   ``y_{k+1} = (c [k = 0] + A y_k + sum_l Q(y_l, y_{k-l})) / (k + 1)``; the point value
   ``phi_h(yhat)`` is enclosed by ``sum_{k<=p} y_k(yhat) h^k + y_{p+1}(E) h^{p+1}``
   (Lagrange remainder: the ``(p+1)``-th coefficient function evaluated over ``E``, which
   contains ``y(xi)``). The step is accepted when the remainder is below the tolerance,
   else ``h`` is halved; after easy steps ``h`` grows.
3. *Jacobian of the step over the whole set*: ``C`` encloses ``D phi_h(y)`` for all
   ``y`` in ``Y`` from the variational equation ``J' = DF(y) J`` (again a Taylor series,
   order ``q``, ``J_{k+1} = (A J_k + sum_l D(y_l) J_{k-l})/(k+1)`` with ``D`` linear), with
   remainder ``J_{q+1}(E, E_J) h^{q+1}`` where ``E_J`` is an a-priori enclosure of ``J``
   on ``[0, h]`` (``I + [0, h] DF(E) E_J subset E_J``).
4. *Wrapping control (Lohner's QR method)*: by the mean-value theorem
   ``phi_h(Y) subset phi_h(yhat) + C B r``. With ``M = C B``, the new basis ``B'`` is the
   orthogonal factor of ``mid(M)`` (QR with the columns ordered by ``|M_col| rad(r_col)``,
   computed in float64: ``B'`` need not be exactly orthogonal, its inverse is enclosed by a
   ball inverse), ``yhat' = mid(phi_h(yhat))``, ``e = phi_h(yhat) - yhat'`` and
   ``r' = (B'^-1 M) r + B'^-1 e``. The set is thus carried in a moving orthogonal frame that
   follows the rotation of the flow, so the radius grows with the flow's true expansion
   rather than with ``exp(||DF|| t)`` (the wrapping of a box-only method).

The state at ``T`` is enclosed by ``yhat_N + B_N r_N``. All of it is ball arithmetic at
``prec_bits`` (python-flint); only the choice of ``B`` and of ``h`` uses floats, which
affects tightness, never validity.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from flint import arb, arb_mat

from ._arb import Balls, algebra_balls, exact_source, float_view, to_arb, upper, workprec
from ._errors import DegeneratePointError
from ._rigorous_core import MAX_PREC_BITS, check_magnitudes
from ._rigorous_core import fview as _fview
from ._rigorous_core import point_view as _point_view
from ._taylor import body_field_tables
from ._validate import (
    MAX_FLOW_TIME,
    check_inertia,
    check_potential,
    check_structure_constants,
    check_theta,
    check_upsilon,
)

__all__ = ["FlowEnclosure", "BallField", "body_field", "body_flow_enclosure"]


class BallField:
    """``y' = c + A y + Q(y, y)``: ``lin[i] = [(j, a_ij)]``, ``quad[i] = [(j, k, q_ijk)]`` (ball coefficients).

    The Arb evaluator of a quadratic field for the enclosures; the body field's tables are those of
    refimpl/_taylor.py (``body_field_tables``, the one definition), filled with balls by :func:`body_field`."""

    def __init__(self, d: int, const: dict, lin: dict, quad: dict):
        self.d = d
        self.const = {i: v for i, v in const.items() if not v.is_zero()}
        self.lin = {
            i: [(j, v) for j, v in row.items() if not v.is_zero()] for i, row in lin.items()
        }
        self.quad = {
            i: [(j, k, v) for (j, k), v in row.items() if not v.is_zero()]
            for i, row in quad.items()
        }
        self.pairs = sorted({(j, k) for row in self.quad.values() for j, k, _ in row})

    # ---------------------------------------------------------- evaluation
    def __call__(self, y: list) -> list:
        out = []
        for i in range(self.d):
            s = self.const.get(i, arb(0))
            for j, a in self.lin.get(i, ()):
                s += a * y[j]
            for j, k, q in self.quad.get(i, ()):
                s += q * (y[j] * y[k])
            out.append(s)
        return out

    def D(self, y: list) -> arb_mat:
        """``DF(y) - A``: the part of the Jacobian linear in ``y``."""
        M = [[arb(0)] * self.d for _ in range(self.d)]
        for i, row in self.quad.items():
            for j, k, q in row:
                M[i][j] += q * y[k]
                M[i][k] += q * y[j]
        return arb_mat(M)

    def DF(self, y: list) -> arb_mat:
        """A ball matrix containing the Jacobian ``DF`` over the box ``y``."""
        return self.A() + self.D(y)

    def A(self) -> arb_mat:
        M = [[arb(0)] * self.d for _ in range(self.d)]
        for i, row in self.lin.items():
            for j, a in row:
                M[i][j] += a
        return arb_mat(M)

    def taylor(self, y0: list, p: int) -> list:
        """Normalised Taylor coefficients ``y_0 .. y_p`` (``y_k = y^(k)(0)/k!``) by Cauchy products."""
        Y = [list(y0)]
        for k in range(p):
            conv = {}
            for j, kk in self.pairs:
                s = arb(0)
                for m in range(k + 1):
                    s += Y[m][j] * Y[k - m][kk]
                conv[(j, kk)] = s
            yk = Y[k]
            nxt = []
            for i in range(self.d):
                s = self.const.get(i, arb(0)) if k == 0 else arb(0)
                for j, a in self.lin.get(i, ()):
                    s += a * yk[j]
                for j, kk, q in self.quad.get(i, ()):
                    s += q * conv[(j, kk)]
                nxt.append(s / (k + 1))
            Y.append(nxt)
        return Y

    def jacobian_taylor(self, Y: list, J0: arb_mat, q: int) -> list:
        """Taylor coefficients ``J_0 .. J_q`` of ``J' = (A + D(y)) J`` along the coefficients ``Y``."""
        A = self.A()
        Ds = [self.D(Y[m]) for m in range(q)]
        J = [J0]
        for k in range(q):
            s = A * J[k]
            for m in range(k + 1):
                s += Ds[m] * J[k - m]
            J.append(s / (k + 1))
        return J


def body_field(f, theta, inertia, potential) -> tuple[BallField, int]:
    """The quadratic field of the Euler (``potential=None``) or Euler-Poisson body system, in balls."""
    src = exact_source(f)
    n = src.shape[0]
    F = np.array([to_arb(v, "structure constants f") for v in src.flat], dtype=object).reshape(
        n, n, n
    )
    th = np.array(
        [to_arb(v, "theta") for v in np.asarray(theta, dtype=object).flat], dtype=object
    ).reshape(n, n)
    Iinv = arb_mat(
        [[to_arb(v, "inertia") for v in row] for row in np.asarray(inertia, dtype=object)]
    ).inv()
    Ii = np.array(Iinv.entries(), dtype=object).reshape(n, n)
    # the ball coefficients of the one table of the body field (refimpl/_taylor.py body_field_tables):
    # its contractions summed in balls over the nonzero entries
    zero = arb(0)
    fI = np.full((n, n, n), zero, dtype=object)  # sum_b f^m_ab (I^-1)_bj
    TI = np.full((n, n), zero, dtype=object)  # sum_b Theta_ab (I^-1)_bj
    nzf = [
        (m, a, b) for m in range(n) for a in range(n) for b in range(n) if not F[m, a, b].is_zero()
    ]
    nzI = [(b, j) for b in range(n) for j in range(n) if not Ii[b, j].is_zero()]
    for m, a, b in nzf:
        for bb, j in nzI:
            if bb == b:
                fI[m, a, j] += F[m, a, b] * Ii[b, j]
    for a in range(n):
        for b, j in nzI:
            if not th[a, b].is_zero():
                TI[a, j] += th[a, b] * Ii[b, j]
    fL = IF = None
    if potential is not None:
        Lv = [to_arb(v, "potential['L']") for v in np.asarray(potential["L"], dtype=object)]
        fL = np.full((n, n), zero, dtype=object)  # sum_c f^m_ac L^c, at [a, m]
        IF = np.full((n, n, n), zero, dtype=object)  # sum_b (I^-1)_bj f^a_{b mu}, at [mu, j, a]
        for m, a, c in nzf:
            fL[a, m] += F[m, a, c] * Lv[c]
        for a, b, mu in nzf:  # twee17 corrected
            for bb, j in nzI:
                if bb == b:
                    IF[mu, j, a] += F[a, b, mu] * Ii[b, j]
    d, lin, quad = body_field_tables(n, fI, TI, fL, IF)
    return BallField(d, {}, dict(enumerate(lin)), dict(enumerate(quad))), n


@dataclass
class FlowEnclosure:
    """The enclosure of the body state at ``t``: ``pi`` (and ``Gamma`` for Euler-Poisson) as :class:`Balls`."""

    t: float
    pi: Balls
    Gamma: Balls | None
    steps: int
    rejected: int
    prec_bits: int
    order: int
    notes: list = field(default_factory=list)

    def max_rad(self) -> float:
        return max(self.pi.max_rad(), self.Gamma.max_rad() if self.Gamma is not None else 0.0)


def _hull0(h: arb) -> arb:
    """The ball enclosing ``[0, h]``."""
    return arb(0).union(h)


def _inflate(e: arb, factor: float = 0.25) -> arb:
    return e + arb(0, factor * upper(e.rad()) + 1e-40 * (1 + upper(e)))


def _enclosure(F: BallField, Y: list, H: arb, tries: int = 12):
    """A box ``E`` with ``Y + H F(E) subset E`` (``H`` encloses ``[0, h]``), or None.

    Picard iteration with inflation: ``E <- inflate(Y + H F(E))`` until the image lies inside.
    """
    E = [_inflate(y + H * fy, 1.0) for y, fy in zip(Y, F(Y))]
    for _ in range(tries):
        new = [y + H * fy for y, fy in zip(Y, F(E))]
        if all(a.contains(b) for a, b in zip(E, new)):
            return new
        E = [_inflate(b) for b in new]
    return None


def _jac_enclosure(F: BallField, E: list, H: arb, tries: int = 12):
    """A ball matrix ``E_J`` with ``I + H DF(E) E_J subset E_J``, or None (Picard iteration with inflation)."""
    d = F.d
    DF = F.DF(E)
    I = arb_mat([[1 if i == j else 0 for j in range(d)] for i in range(d)])
    EJ = arb_mat(d, d, [_inflate(e, 1.0) for e in (I + H * DF).entries()])
    for _ in range(tries):
        new = I + H * (DF * EJ)
        if all(a.contains(b) for a, b in zip(EJ.entries(), new.entries())):
            return new
        EJ = arb_mat(d, d, [_inflate(b) for b in new.entries()])
    return None


def _horner(coeffs: list, h: arb) -> list:
    out = list(coeffs[-1])
    for c in reversed(coeffs[:-1]):
        out = [ci + h * oi for ci, oi in zip(c, out)]
    return out


def _lohner_step(F, yhat, B, r, h, p, q, tol):
    """One step; returns ``(yhat', B', r', rem)`` or None when the enclosure fails or the remainder is too
    big. A field that cannot be evaluated over a box (``ZeroDivisionError``: the rational field's ``Phi``
    not provably invertible there) fails the step; ``F.singular`` then records it."""
    try:
        return _lohner_step_(F, yhat, B, r, h, p, q, tol)
    except ZeroDivisionError:
        F.singular = True
        return None


def _lohner_step_(F, yhat, B, r, h, p, q, tol):
    d = F.d
    H = _hull0(h)
    Br = B * r
    # the set, as a box; it contains yhat (r contains 0), made explicit for the mean-value segment
    Y = [(yhat[i] + Br[i, 0]).union(yhat[i]) for i in range(d)]
    E = _enclosure(F, Y, H)
    if E is None:
        return None
    rem_c = F.taylor(E, p + 1)[p + 1]
    hp = h ** (p + 1)
    rem = [c * hp for c in rem_c]
    remmax = max(upper(v) for v in rem)
    if remmax > tol:
        return ("big", remmax)
    coeffs = F.taylor(yhat, p)
    phi = [a + b for a, b in zip(_horner(coeffs, h), rem)]
    # Jacobian over the set
    EJ = _jac_enclosure(F, E, H)
    if EJ is None:
        return None
    I = arb_mat([[1 if i == j else 0 for j in range(d)] for i in range(d)])
    Ys = F.taylor(Y, q)
    Js = F.jacobian_taylor(Ys, I, q)
    Yr = F.taylor(E, q + 1)
    Jr = F.jacobian_taylor(Yr, EJ, q + 1)[q + 1]
    acc = Js[q]  # Horner in h: sum_{k<=q} J_k h^k, then the remainder term
    for k in range(q - 1, -1, -1):
        acc = Js[k] + acc * h
    C = acc + Jr * h ** (q + 1)
    M = C * B
    # QR of mid(M), columns ordered by |M_col| rad(r_col) (Lohner)
    Mm = np.array([[float(e.mid()) for e in row] for row in M.tolist()])
    rr = np.array([upper(r[i, 0].rad()) + 1e-300 for i in range(d)])
    order = np.argsort(-(np.linalg.norm(Mm, axis=0) * rr))
    Qf, _ = np.linalg.qr(Mm[:, order])
    Bn = arb_mat(Qf.tolist())
    Bn_inv = Bn.inv()
    yhat_n = [v.mid() for v in phi]
    e = arb_mat(d, 1, [v - m for v, m in zip(phi, yhat_n)])
    rn = (Bn_inv * M) * r + Bn_inv * e
    return yhat_n, Bn, rn, remmax, E, C, (Ys, Yr[q + 1])


def enclose_quadratic(
    F: BallField,
    y0: list,
    T: arb,
    *,
    order: int = 40,
    jac_order: int = 8,
    tol: float = 2.0**-184,
    h0: float = 0.05,
    max_steps: int = 100000,
    on_step=None,
    jacobian: bool = False,
    max_seconds: float | None = None,
) -> tuple:
    """Enclose ``y(T)`` for ``y' = F(y)``, ``y(0) in y0`` (balls), at the current precision (module docstring).

    Returns ``(balls of y(T), accepted steps, rejected steps)``, and with ``jacobian=True`` a fourth item:
    a ball matrix containing ``D phi_T(y)`` for every ``y`` in ``y0`` (the chain rule over the steps'
    Jacobians ``C_k``, each valid over a set containing the trajectories). ``on_step(t0, h, E, series)``,
    if given, is called after each accepted step with its start ``t0``, length ``h`` (balls), a-priori
    enclosure ``E`` (boxes containing every solution on ``[t0, t0 + h]``) and ``series = (Ys, R)``: every
    solution from the step's set satisfies ``y(t0 + s) in sum_k Ys[k] s^k + R s^(q+1)`` for ``s`` in
    ``[0, h]`` (Taylor coefficients over the set, Lagrange remainder over ``E``). Raises ``ValueError`` when
    the step size underflows (no enclosure or remainder small enough), after ``max_steps`` steps, or
    when the time the run needs, estimated from the steps done, exceeds ``max_seconds`` (a budget).
    """
    d = F.d
    I = arb_mat([[1 if i == j else 0 for j in range(d)] for i in range(d)])
    if T.is_zero():
        return (list(y0), 0, 0, I) if jacobian else (list(y0), 0, 0)
    yhat = [v.mid() for v in y0]
    B = I
    r = arb_mat(d, 1, [v - m for v, m in zip(y0, yhat)])
    Jtot = I
    tnow = arb(0)  # exact: a sum of dyadic steps
    h = h0
    steps = rejected = 0
    Tf = float(T.mid())
    start = time.process_time()
    while True:
        left = T - tnow
        if not (left > 0):
            break
        last = h >= float(left.upper())
        hb = left if last else arb(h)
        res = _lohner_step(F, yhat, B, r, hb, order, jac_order, tol)
        if res is None or res[0] == "big":
            rejected += 1
            h = (float(left.mid()) if last else h) / 2
            if h < 1e-12 or rejected > max_steps:
                if getattr(F, "singular", False):
                    raise DegeneratePointError(
                        f"rigorous flow: Delta = det Phi is not provably away from 0 along the step at "
                        f"t = {float(tnow.mid())} (the trajectory meets or nears the degenerate set)"
                    )
                raise ValueError(
                    f"rigorous flow: step size underflow at t = {float(tnow.mid())} "
                    "(the enclosure or the remainder cannot be made small enough)"
                )
            continue
        yhat, B, r, remmax, E, C, series = res
        F.singular = False
        steps += 1
        if jacobian:
            Jtot = C * Jtot
        if on_step is not None:
            on_step(tnow, hb, E, series)
        if last:
            break
        tnow += hb
        if max_seconds is not None and steps % 4 == 0:
            spent = time.process_time() - start
            need = spent * Tf / max(float(tnow.mid()), 1e-300)
            if need > max_seconds:
                raise ValueError(
                    f"rigorous flow: the run would take about {need:.3g} s of CPU (estimated from "
                    f"{steps} steps to t = {float(tnow.mid()):.3g} of {Tf:g}), over the budget "
                    f"max_seconds = {max_seconds:g}"
                )
        if remmax < tol * 1e-6:
            h = h * 1.25
        if steps > max_steps:
            raise ValueError(f"rigorous flow: more than max_steps = {max_steps} steps")
    Br = B * r
    out = [yhat[i] + Br[i, 0] for i in range(d)]
    return (out, steps, rejected, Jtot) if jacobian else (out, steps, rejected)


def body_flow_enclosure(
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
    order: int = 40,
    jac_order: int = 8,
    tol: float | None = None,
    h0: float = 0.05,
    max_steps: int = 100000,
    max_seconds: float | None = 600.0,
) -> FlowEnclosure:
    """Enclose the body state at time ``t`` of the Euler / Euler-Poisson system (module docstring).

    ``Upsilon`` must be exactly 0 (the body systems are then polynomial). ``potential=None``:
    Euler (twee14, drie6 with ``Theta``), state ``pi``; gravity: Euler-Poisson (twee17 sign
    corrected, twee18), state ``(pi, Gamma)`` with ``Gamma(0) = Ad(exp x0)^T gamma``.
    ``order``: Taylor order of the point series; ``jac_order``: of the Jacobian series;
    ``tol``: the largest accepted remainder per step (default ``2^-(prec_bits - 16)``).
    The inputs pass the rigorous boundary (magnitudes <= 1e300, precision cap, ``t <= MAX_FLOW_TIME``);
    ``max_seconds`` bounds the CPU time, estimated from the first steps and refused with the estimate.
    Returns a :class:`FlowEnclosure` whose balls provably contain the exact state at ``t``.
    """

    def view(v, name):
        return check_magnitudes(_fview(v, name), name)

    ff = check_structure_constants(view(f, "structure constants f"))
    n = ff.shape[0]
    check_theta(view(theta, "theta"), ff)
    check_upsilon(view(upsilon, "upsilon"), n)
    check_inertia(view(inertia, "inertia"), n)
    pot = (
        None
        if potential is None
        else check_potential(
            {k: (view(v, f"potential[{k!r}]") if k != "kind" else v) for k, v in potential.items()},
            n,
        )
    )
    _point_view(pi0, n, "pi0")
    if pot is not None:
        _point_view(x0, n, "x0")
    if (
        not isinstance(prec_bits, int)
        or isinstance(prec_bits, bool)
        or not 53 <= prec_bits <= MAX_PREC_BITS
    ):
        raise ValueError(f"prec_bits must be an int in [53, {MAX_PREC_BITS}], got {prec_bits!r}")
    if not (
        isinstance(order, int) and order >= 2 and isinstance(jac_order, int) and jac_order >= 1
    ):
        raise ValueError(
            f"order must be an int >= 2 and jac_order an int >= 1, got {order!r}, {jac_order!r}"
        )
    tv = float(float_view(t, "t"))
    if not math.isfinite(tv) or not 0 <= tv <= MAX_FLOW_TIME:
        raise ValueError(
            f"t must be a finite number in [0, {MAX_FLOW_TIME:g}] (the flow budget), got {t!r}"
        )
    tol = 2.0 ** -(prec_bits - 16) if tol is None else float(tol)
    if not tol > 0:
        raise ValueError(f"tol must be > 0, got {tol!r}")
    with workprec(prec_bits):
        ups = [to_arb(v, "upsilon") for v in np.asarray(upsilon, dtype=object).flat]
        if not all(u.is_zero() for u in ups):
            raise ValueError(
                "rigorous flows need upsilon = 0 exactly (the body system is then polynomial)"
            )
        F, n = body_field(f, theta, inertia, None if pot is None else potential)
        pi_b = [to_arb(v, "pi0") for v in np.asarray(pi0, dtype=object).reshape(-1)]
        if len(pi_b) != n:
            raise ValueError(
                f"pi0 must have shape ({n},), got {np.asarray(pi0, dtype=object).shape}"
            )
        y0 = list(pi_b)
        if pot is not None:
            Fad, _, _ = algebra_balls(f, prec_bits)
            xv = arb_mat(n, 1, [to_arb(v, "x0") for v in np.asarray(x0, dtype=object).reshape(-1)])
            if xv.nrows() != n:
                raise ValueError(f"x0 must have shape ({n},)")
            Ad = arb_mat(n, n, (Fad * xv).entries()).exp()
            gam = arb_mat(
                n,
                1,
                [
                    to_arb(v, "potential['gamma']")
                    for v in np.asarray(potential["gamma"], dtype=object)
                ],
            )
            y0 += (Ad.transpose() * gam).entries()
        y, steps, rejected = enclose_quadratic(
            F,
            y0,
            to_arb(t, "t"),
            order=order,
            jac_order=jac_order,
            tol=tol,
            h0=h0,
            max_steps=max_steps,
            max_seconds=max_seconds,
        )
    Gam = Balls(np.array(y[n:], dtype=object), prec_bits) if pot is not None else None
    return FlowEnclosure(
        t=tv,
        pi=Balls(np.array(y[:n], dtype=object), prec_bits),
        Gamma=Gam,
        steps=steps,
        rejected=rejected,
        prec_bits=prec_bits,
        order=order,
    )
