"""Compiled (numba) rigorous double-interval Taylor method with Lohner's QR wrapping, for quadratic fields.

The same method as :mod:`refimpl._rigorous_flow` (read its docstring for the mathematics: an a-priori
enclosure (here the high-order test below), Taylor coefficients by Cauchy products, Lagrange remainder over the
a-priori box, the Jacobian of the step over the set from the variational equation with its own
remainder, Lohner's moving orthogonal frame), run in float64 intervals ``[lo, hi]`` instead of Arb
balls, with the whole step loop compiled. The field is given as sparse tables (arguments, never
literals), so numba compiles this module once in total and ``cache=True`` keeps the machine code.

Rounding model (outward rounding under IEEE 754 round-to-nearest-even, no directed rounding needed)
    Every interval operation computes its bounds ``s`` in float64 round-to-nearest, then widens them:
    ``down(s) = fl(s - fl(fl(phi |s|) + eta))``, ``up(s)`` symmetrically, with ``phi = u (1 + 2 u)``,
    ``u = 2^-53`` (:data:`U`) and ``eta = 2^-1074`` (:data:`ETA`, the smallest subnormal). Why
    ``down(s)`` lies below the exact value ``r`` whose rounding is ``s``: let ``g`` be the gap from
    ``s`` down to its neighbour ``pred(s)``; round-to-nearest puts ``r >= s - g/2``, so
    ``pred(s) < r``. For normal ``s = m 2^e`` (``1 <= |m| < 2``) the gap is at most ``2^(e-52)``, so
    ``g/2 <= u 2^e <= u |s|``. While ``u |s|`` is normal (``|s| >= 2^-968``), ``fl(phi |s|) > u |s|``
    strictly (``u |s|`` is a float and ``phi |s|`` exceeds it by more than half its ulp), so the
    subtracted amount ``d`` exceeds ``g/2``; below that, ``g/2 <= 2^-1022`` lies on the subnormal grid,
    so ``fl(phi |s|) >= g/2`` and adding ``eta`` (exactly, there) makes ``d > g/2``; for subnormal ``s``,
    ``eta`` is the gap itself. Hence the real ``s - d`` lies below
    the midpoint of ``[pred(s), s]``, rounds to ``pred(s)`` or lower, and ``down(s) <= pred(s) < r``.
    Symmetrically for ``up``. This is the predecessor of Rump, Zimmermann, Boldo and Melquiond
    ("Computing predecessor and successor in rounding to nearest", BIT 49 (2009) 419-431).
    Requirements: no fused multiply-add contraction and no fast-math (neither is enabled here), and
    finite results -- an overflow gives ``inf``/``nan``, which the kernel detects (every step checks
    that its new set is finite) and reports as a failure, never as a box.
    ``down`` is non-decreasing, so it also bounds a minimum of rounded results (interval products take
    the min/max of the four bound products) from below; sums add bounds. Two operations
    are exact and not widened: adding to an exact 0, and multiplying by a coefficient ``+-2^k``,
    ``k >= 0``, or by a step power ``h^k`` or ``1/k`` that is a power of two (scalings, exact while
    the result is normal; flagged per coefficient by the caller). The new centre ``yhat'`` of each step is
    ``fl(yhat + m)`` with its rounding error taken exactly by Knuth's TwoSum, and the dominant term of
    the point series, ``F(yhat)``, is computed with Dekker's exact products and TwoSum
    (:func:`_point_field`), about one rounding wide: the radius at ``T`` is mostly the sum of these
    per-step widths carried by the flow. The input
    coefficients are enclosed outward from Arb balls by the caller.

A-priori enclosure (high order, Nedialkov, Jackson and Corliss 1999)
    ``E`` with ``sum_{k<=P} F_k(Y) [0, h]^k + F_{P+1}(E) [0, h]^(P+1)`` strictly inside ``E``
    (:func:`_enclosure`); unlike the first-order (Picard) box of :mod:`refimpl._rigorous_flow` this
    does not limit ``h`` to about ``1/||DF||``. (:func:`_jac_enclosure` does the same for the
    Jacobian, for callers that enclose the flow's Jacobian; the step below does not need it.)

The step (a C^0 Lohner step)
    For ``y0`` in the set ``Y`` (the box of ``yhat + B r``) and ``T_k`` the normalised Taylor
    coefficients, ``phi_h(y0) = sum_{k<=P} T_k(y0) h^k + R`` with ``R`` in ``T_{P+1}(E) h^(P+1)``, and
    ``sum_{k<=P} T_k(y0) h^k = sum_{k<=P} T_k(yhat) h^k + C (y0 - yhat) + D``:
    ``C = sum_{k<=q} J_k(Y) h^k`` by the mean-value theorem (``J_k = D_y T_k``, the variational
    series with ``J_0 = I`` evaluated over ``Y``: it contains ``D_y T_k`` at every point of ``Y``), and
    ``D`` in ``sum_{q<k<=P} (T_k(Y) - T_k(yhat)) h^k`` (bounded symmetrically) -- the terms above the
    Jacobian order ``q`` by plain interval evaluation over ``Y``. ``R`` and ``D`` join the error box
    of the Lohner update, ``C B`` its linear part. No a-priori enclosure of the Jacobian is needed
    (no Jacobian remainder); ``D`` is small when ``q`` is large enough for the step: it is held at
    most ``JTOL`` times the set's width plus ``tol``.

Steps
    The step ``h`` comes from the point series at the set's centre (Jorba-Zou: the last two terms
    about ``tol``, times a factor learnt from rejections) and from the size of ``D`` at the last
    step (``D ~ h^(q+1)``), rounded down to :data:`STEP_BITS` significant bits (a power of two times
    1, 1.25, 1.5 or 1.75: a finer grid than powers of two; ``h^k`` is then outward, not exact); it is accepted when the
    enclosure exists, the Lagrange remainder over ``E`` is at most ``tol`` and ``D`` at most
    ``JTOL`` times the set's width plus ``tol``, else it shrinks (:data:`SHRINK`). Times are
    float64: the step from ``t`` to ``t' = fl(t + h)`` is ``t' - t``, a point when TwoSum shows it
    exact, else that difference enclosed outward (every solution operator of length in the interval
    is enclosed), and the last step ends on
    ``T`` exactly, so the set at the end encloses ``y(T)``.

Status codes returned by :func:`enclose`: 0 done, 1 step-size underflow (no a-priori box or no
remainder below ``tol``), 2 a non-finite set (overflow), 3 more than ``max_steps`` steps, 4 the
rounding mode is not round-to-nearest (probed by :func:`_nearest` before anything is computed; the
caller sets round-to-nearest around the call, :func:`refimpl._interval_flow.interval_enclose`).
"""

from __future__ import annotations

import math

import numpy as np

try:
    from numba import njit
except ImportError:  # pragma: no cover - the plain-Python path (very slow, same arithmetic)

    def njit(*a, **kw):
        return (lambda fn: fn) if not a else a[0]


U = 2.0**-53 + 2.0**-105  # the relative widening u (1 + 2 u), u = 2^-53 (module docstring)
ETA = 5e-324  # 2^-1074, the smallest subnormal: >= every gap

OK, UNDERFLOW, NONFINITE, MAXSTEPS, NOT_NEAREST = 0, 1, 2, 3, 4
STEP_BITS = 3  # significant bits of the step h (module docstring, Steps)
SHRINK = 0.75  # a rejected step and the learnt factor shrink by this
JTOL = 1e-4  # the largest accepted D per step, relative to the set's width (module docstring)


@njit(cache=True)
def _dn(x, u, eta):
    return x - (abs(x) * u + eta)


@njit(cache=True)
def _up(x, u, eta):
    return x + (abs(x) * u + eta)


@njit(cache=True)
def _mul(alo, ahi, blo, bhi, u, eta):
    if (alo == 0.0 and ahi == 0.0) or (blo == 0.0 and bhi == 0.0):
        return 0.0, 0.0  # exact (and no subnormal widening: those are slow on x86)
    p1 = alo * blo
    p2 = alo * bhi
    p3 = ahi * blo
    p4 = ahi * bhi
    lo = min(min(p1, p2), min(p3, p4))
    hi = max(max(p1, p2), max(p3, p4))
    return _dn(lo, u, eta), _up(hi, u, eta)


@njit(cache=True)
def _cmul(clo, chi, exact, xlo, xhi, u, eta):
    """``[clo, chi] * [xlo, xhi]``; ``exact``: the coefficient is a point ``+-2^k``, ``k >= 0``, so the
    bound products are exact (a scaling by a power of two; an overflow shows as ``inf`` and fails)."""
    if exact:
        a = clo * xlo
        b = clo * xhi
        return min(a, b), max(a, b)
    return _mul(clo, chi, xlo, xhi, u, eta)


@njit(cache=True)
def _addlo(s, p, u, eta):
    """Lower bound of ``s + p``: ``down`` of the rounded sum, except for the exact cases, not widened
    (nor into the slow subnormals): ``s = 0``, and a sum rounding to 0 (only ``s = -p`` does)."""
    if s == 0.0:
        return p
    r = s + p
    return 0.0 if r == 0.0 else r - (abs(r) * u + eta)


@njit(cache=True)
def _addhi(s, p, u, eta):
    if s == 0.0:
        return p
    r = s + p
    return 0.0 if r == 0.0 else r + (abs(r) * u + eta)


# the smallest normal float: a scaling by a power of two is exact when the result is normal
TINY = 2.0**-1022


@njit(cache=True)
def _pow2(x):
    """``x`` is a power of two (``x > 0``)."""
    return x > 0.0 and math.frexp(x)[0] == 0.5


@njit(cache=True)
def _scale(lo, hi, s, u, eta):
    """``[lo, hi] * s`` for a point ``s``: exact (not widened) when ``s`` is a power of two and both
    results are normal or exact zeros, else the outward product."""
    a = lo * s
    b = hi * s
    if _pow2(abs(s)) and (lo == 0.0 or abs(a) >= TINY) and (hi == 0.0 or abs(b) >= TINY):
        return (a, b) if s > 0.0 else (b, a)
    return _mul(lo, hi, s, s, u, eta)


@njit(cache=True)
def _divk(slo, shi, k, u, eta):
    """``[slo, shi] / k`` for an integer ``k >= 1`` (exact for a power of two ``k`` when the results are
    normal, 0 stays an exact 0)."""
    if _pow2(float(k)):
        return _scale(slo, shi, 1.0 / k, u, eta)
    lo = 0.0 if slo == 0.0 else _dn(slo / k, u, eta)
    hi = 0.0 if shi == 0.0 else _up(shi / k, u, eta)
    return lo, hi


@njit(cache=True)
def _taylor(Tlo, Thi, P, tab, conv, u, eta, k0=0):
    """Rows ``k0+1..P`` of the normalised Taylor coefficients ``Tlo/Thi[k, :]`` from rows ``0..k0``."""
    clo, chi, lptr, lidx, llo, lhi, lex, qptr, qpair, qlo, qhi, qex, pj, pk = tab
    d = Tlo.shape[1]
    npair = pj.shape[0]
    for k in range(k0, P):
        for m in range(npair):
            j = pj[m]
            kk = pk[m]
            slo = 0.0
            shi = 0.0
            for a in range(k + 1):
                plo, phi = _mul(Tlo[a, j], Thi[a, j], Tlo[k - a, kk], Thi[k - a, kk], u, eta)
                slo = _addlo(slo, plo, u, eta)
                shi = _addhi(shi, phi, u, eta)
            conv[0, m] = slo
            conv[1, m] = shi
        for i in range(d):
            slo = clo[i] if k == 0 else 0.0
            shi = chi[i] if k == 0 else 0.0
            for t in range(lptr[i], lptr[i + 1]):
                plo, phi = _cmul(llo[t], lhi[t], lex[t], Tlo[k, lidx[t]], Thi[k, lidx[t]], u, eta)
                slo = _addlo(slo, plo, u, eta)
                shi = _addhi(shi, phi, u, eta)
            for t in range(qptr[i], qptr[i + 1]):
                m = qpair[t]
                plo, phi = _cmul(qlo[t], qhi[t], qex[t], conv[0, m], conv[1, m], u, eta)
                slo = _addlo(slo, plo, u, eta)
                shi = _addhi(shi, phi, u, eta)
            Tlo[k + 1, i], Thi[k + 1, i] = _divk(slo, shi, k + 1, u, eta)


@njit(cache=True)
def _two_prod(a, b):
    """Dekker's product (Veltkamp splitting): ``a b = p + e`` exactly, with ``ok`` False outside the
    range where that is guaranteed (no overflow in the split, no underflow of the error term)."""
    p = a * b
    if p == 0.0 or not (1e-280 < abs(p) < 1e280 and abs(a) < 1e150 and abs(b) < 1e150):
        return p, 0.0, p == 0.0 and (a == 0.0 or b == 0.0)
    c = 134217729.0 * a  # 2^27 + 1
    ah = c - (c - a)
    al = a - ah
    c = 134217729.0 * b
    bh = c - (c - b)
    bl = b - bh
    e = ((ah * bh - p) + ah * bl + al * bh) + al * bl
    return p, e, True


@njit(cache=True)
def _two_sum(a, b):
    """Knuth's TwoSum: ``a + b = s + e`` exactly."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@njit(cache=True)
def _point_field(y, tab, outlo, outhi, u, eta):
    """``F(y)`` at a point ``y``, nearly exactly: each product ``y_j y_k`` split exactly (Dekker), scaled
    exactly by a ``+-2^k`` coefficient, the leading parts summed by TwoSum with every rounding error and
    every low part collected in an interval; the result is then about one rounding wide instead of
    the ulps of every product and sum. Other terms take the interval route."""
    clo, chi, lptr, lidx, llo, lhi, lex, qptr, qpair, qlo, qhi, qex, pj, pk = tab
    d = y.shape[0]
    for i in range(d):
        s = 0.0
        elo = 0.0  # the interval of everything not in s
        ehi = 0.0
        if clo[i] == chi[i]:
            s = clo[i]
        else:
            elo = clo[i]
            ehi = chi[i]
        for t in range(lptr[i], lptr[i + 1]):
            yj = y[lidx[t]]
            a = llo[t] * yj
            if lex[t] and (abs(a) >= TINY or yj == 0.0):
                s, err = _two_sum(s, a)
                elo = _addlo(elo, err, u, eta)
                ehi = _addhi(ehi, err, u, eta)
            else:
                plo, phi = _mul(llo[t], lhi[t], yj, yj, u, eta)
                elo = _addlo(elo, plo, u, eta)
                ehi = _addhi(ehi, phi, u, eta)
        for t in range(qptr[i], qptr[i + 1]):
            m = qpair[t]
            a = y[pj[m]]
            b = y[pk[m]]
            p, pe, exact = _two_prod(a, b)
            q = qlo[t]
            if qex[t] and exact and (pe == 0.0 or abs(q * pe) >= TINY):
                s, err = _two_sum(s, q * p)
                elo = _addlo(_addlo(elo, err, u, eta), q * pe, u, eta)
                ehi = _addhi(_addhi(ehi, err, u, eta), q * pe, u, eta)
            else:
                alo, ahi = _mul(a, a, b, b, u, eta)
                plo, phi = _mul(qlo[t], qhi[t], alo, ahi, u, eta)
                elo = _addlo(elo, plo, u, eta)
                ehi = _addhi(ehi, phi, u, eta)
        outlo[i] = _addlo(s, elo, u, eta)
        outhi[i] = _addhi(s, ehi, u, eta)


@njit(cache=True)
def _jac_taylor(Tlo, Thi, J0lo, J0hi, q, tab, Jlo, Jhi, u, eta):
    """``J_0 .. J_q`` (``Jlo/Jhi[k]``) of ``J' = (A + D(y)) J``, ``J_0 = J0``, along the coefficients ``T``.

    The coefficient products ``q_t y_a[.]`` of the quadratic terms are formed once per call (the same
    outward products the column loop would form again for every column)."""
    clo, chi, lptr, lidx, llo, lhi, lex, qptr, qpair, qlo, qhi, qex, pj, pk = tab
    d = Tlo.shape[1]
    nq = qlo.shape[0]
    Ak = np.empty((nq, max(q, 1), 4))  # [t, a]: q_t y_a[kk] (lo, hi), q_t y_a[j] (lo, hi)
    for t in range(nq):
        m = qpair[t]
        for a in range(q):
            Ak[t, a, 0], Ak[t, a, 1] = _cmul(
                qlo[t], qhi[t], qex[t], Tlo[a, pk[m]], Thi[a, pk[m]], u, eta
            )
            Ak[t, a, 2], Ak[t, a, 3] = _cmul(
                qlo[t], qhi[t], qex[t], Tlo[a, pj[m]], Thi[a, pj[m]], u, eta
            )
    Jlo[0] = J0lo
    Jhi[0] = J0hi
    for k in range(q):
        for i in range(d):
            for c in range(d):
                slo = 0.0
                shi = 0.0
                for t in range(lptr[i], lptr[i + 1]):
                    j = lidx[t]
                    plo, phi = _cmul(llo[t], lhi[t], lex[t], Jlo[k, j, c], Jhi[k, j, c], u, eta)
                    slo = _addlo(slo, plo, u, eta)
                    shi = _addhi(shi, phi, u, eta)
                for t in range(qptr[i], qptr[i + 1]):
                    m = qpair[t]
                    j = pj[m]
                    kk = pk[m]
                    for a in range(k + 1):  # q (y_a[kk] J_{k-a}[j] + y_a[j] J_{k-a}[kk])
                        plo, phi = _mul(
                            Ak[t, a, 0], Ak[t, a, 1], Jlo[k - a, j, c], Jhi[k - a, j, c], u, eta
                        )
                        slo = _addlo(slo, plo, u, eta)
                        shi = _addhi(shi, phi, u, eta)
                        plo, phi = _mul(
                            Ak[t, a, 2], Ak[t, a, 3], Jlo[k - a, kk, c], Jhi[k - a, kk, c], u, eta
                        )
                        slo = _addlo(slo, plo, u, eta)
                        shi = _addhi(shi, phi, u, eta)
                Jlo[k + 1, i, c], Jhi[k + 1, i, c] = _divk(slo, shi, k + 1, u, eta)


@njit(cache=True)
def _matmul(Alo, Ahi, Blo, Bhi, Clo, Chi, u, eta):
    """``C = A B`` for interval matrices (``B`` may have one column)."""
    n, m = Alo.shape
    p = Blo.shape[1]
    for i in range(n):
        for c in range(p):
            slo = 0.0
            shi = 0.0
            for j in range(m):
                plo, phi = _mul(Alo[i, j], Ahi[i, j], Blo[j, c], Bhi[j, c], u, eta)
                slo = _addlo(slo, plo, u, eta)
                shi = _addhi(shi, phi, u, eta)
            Clo[i, c] = slo
            Chi[i, c] = shi


@njit(cache=True)
def _hull_times(hhi, flo, fhi, u, eta):
    """``[0, hhi] * [flo, fhi]`` (``hhi >= 0``)."""
    a = hhi * flo
    b = hhi * fhi
    return _dn(min(0.0, a), u, eta), _up(max(0.0, b), u, eta)


@njit(cache=True)
def _powers(hhi, m, u, eta):
    """Upper bounds ``hk[k] >= h^k``, ``k = 0..m`` (``h <= hhi``, ``hhi >= 0``)."""
    hk = np.empty(m + 1)
    hk[0] = 1.0
    for k in range(1, m + 1):
        hk[k] = _up(hk[k - 1] * hhi, u, eta)
    return hk


@njit(cache=True)
def _enclosure(TYlo, TYhi, P, hk, tol, tab, conv, Elo, Ehi, TElo, TEhi, u, eta):
    """A-priori box ``E`` by the high-order enclosure test (Nedialkov, Jackson and Corliss 1999):

    ``sum_{k<=P} F_k(Y) [0, h]^k + F_{P+1}(E) [0, h]^(P+1)`` strictly inside ``E`` proves that every
    solution from ``Y`` stays in ``E`` on ``[0, h]`` (if one left ``E`` first at ``tau <= h``, Taylor's
    formula with Lagrange's remainder along it, all in ``E`` on ``[0, tau]``, would put ``y(tau)``
    in the interior). ``TE`` holds on return the coefficients over a box containing ``E``.
    False when ten inflations fail."""
    d = Elo.shape[0]
    for i in range(d):
        lo = TYlo[0, i]
        hi = TYhi[0, i]
        for k in range(1, P + 1):
            a, b = _hull_times(hk[k], TYlo[k, i], TYhi[k, i], u, eta)
            lo = _dn(lo + a, u, eta)
            hi = _up(hi + b, u, eta)
        TYlo[P + 1, i] = lo  # the polynomial part, kept in the spare row
        TYhi[P + 1, i] = hi
        w = 0.1 * (hi - lo) + 4.0 * tol + 1e-15 * (1.0 + max(abs(lo), abs(hi)))
        Elo[i] = lo - w
        Ehi[i] = hi + w
    for _ in range(10):
        TElo[0] = Elo
        TEhi[0] = Ehi
        _taylor(TElo, TEhi, P + 1, tab, conv, u, eta)
        inside = True
        for i in range(d):
            a, b = _hull_times(hk[P + 1], TElo[P + 1, i], TEhi[P + 1, i], u, eta)
            lo = _dn(TYlo[P + 1, i] + a, u, eta)
            hi = _up(TYhi[P + 1, i] + b, u, eta)
            if not (Elo[i] < lo and hi < Ehi[i]):
                inside = False
                w = 0.5 * (hi - lo) + 1e-15 * (1.0 + max(abs(lo), abs(hi)))
                Elo[i] = min(Elo[i], lo - w)
                Ehi[i] = max(Ehi[i], hi + w)
        if inside:
            return True
    return False


@njit(cache=True)
def _jac_enclosure(Jlo, Jhi, q, hk, tab, TElo, TEhi, EJlo, EJhi, JRlo, JRhi, u, eta):
    """A-priori enclosure ``E_J`` of the Jacobian on ``[0, h]``, the same test on ``(y, J)``:
    ``sum_{k<=q} J_k(Y) [0, h]^k + J_{q+1}(E, E_J) [0, h]^(q+1)`` strictly inside ``E_J``. On return
    ``JR[q + 1]`` is the remainder coefficient over ``(E, E_J)``. False when ten inflations fail."""
    d = EJlo.shape[0]
    Slo = np.empty((d, d))
    Shi = np.empty((d, d))
    for i in range(d):
        for c in range(d):
            lo = Jlo[0, i, c]
            hi = Jhi[0, i, c]
            for k in range(1, q + 1):
                a, b = _hull_times(hk[k], Jlo[k, i, c], Jhi[k, i, c], u, eta)
                lo = _dn(lo + a, u, eta)
                hi = _up(hi + b, u, eta)
            Slo[i, c] = lo
            Shi[i, c] = hi
            w = 0.1 * (hi - lo) + 1e-10 * (1.0 + max(abs(lo), abs(hi)))
            EJlo[i, c] = lo - w
            EJhi[i, c] = hi + w
    for _ in range(10):
        _jac_taylor(TElo, TEhi, EJlo, EJhi, q + 1, tab, JRlo, JRhi, u, eta)
        inside = True
        for i in range(d):
            for c in range(d):
                a, b = _hull_times(hk[q + 1], JRlo[q + 1, i, c], JRhi[q + 1, i, c], u, eta)
                lo = _dn(Slo[i, c] + a, u, eta)
                hi = _up(Shi[i, c] + b, u, eta)
                if not (EJlo[i, c] < lo and hi < EJhi[i, c]):
                    inside = False
                    w = 0.5 * (hi - lo) + 1e-10 * (1.0 + max(abs(lo), abs(hi)))
                    EJlo[i, c] = min(EJlo[i, c], lo - w)
                    EJhi[i, c] = max(EJhi[i, c], hi + w)
        if inside:
            return True
    return False


@njit(cache=True)
def _series_sum(Tlo, Thi, P, hlo, hhi, outlo, outhi, u, eta):
    """``sum_{k<=P} T_k h^k`` (vectors ``T[k, :]``), ``h`` in ``[hlo, hhi]``: the terms ``T_k h^k`` summed
    from the smallest (``k = P``) to ``k = 1``, then ``T_0`` -- each widening is then relative to the
    partial sum, small until the last addition (Horner's rule would widen by ``u |T_0|`` ``P`` times)."""
    d = Tlo.shape[1]
    for i in range(d):
        outlo[i] = 0.0
        outhi[i] = 0.0
    point = hlo == hhi
    plo = 1.0
    phi = 1.0
    pw = np.empty((P + 1, 2))
    for k in range(1, P + 1):
        if point:  # a point power (exact for a power-of-two step while normal)
            plo = plo * hlo if _pow2(hlo) and plo * hlo >= TINY else _dn(plo * hlo, u, eta)
            phi = phi * hhi if _pow2(hhi) and phi * hhi >= TINY else _up(phi * hhi, u, eta)
            point = plo == phi
        else:
            plo, phi = _mul(plo, phi, hlo, hhi, u, eta)
        pw[k, 0] = plo
        pw[k, 1] = phi
    for i in range(d):
        slo = 0.0
        shi = 0.0
        for k in range(P, 0, -1):
            if pw[k, 0] == pw[k, 1]:
                a, b = _scale(Tlo[k, i], Thi[k, i], pw[k, 0], u, eta)
            else:
                a, b = _mul(Tlo[k, i], Thi[k, i], pw[k, 0], pw[k, 1], u, eta)
            slo = _addlo(slo, a, u, eta)
            shi = _addhi(shi, b, u, eta)
        outlo[i] = slo
        outhi[i] = shi


@njit(cache=True)
def _qr_basis(M, weight):
    """An (approximately) orthogonal ``Q``: modified Gram-Schmidt on the columns of ``M`` taken in the
    order of decreasing ``|M_col| weight_col`` (Lohner's ordering). Floats: only tightness depends on it."""
    d = M.shape[0]
    key = np.empty(d)
    for c in range(d):
        key[c] = -np.sqrt(np.sum(M[:, c] ** 2)) * weight[c]
    order = np.argsort(key)
    Q = np.empty((d, d))
    for c in range(d):
        Q[:, c] = M[:, order[c]]
    for c in range(d):
        for b in range(c):
            s = 0.0
            for i in range(d):
                s += Q[i, b] * Q[i, c]
            for i in range(d):
                Q[i, c] -= s * Q[i, b]
        nrm = 0.0
        for i in range(d):
            nrm += Q[i, c] * Q[i, c]
        nrm = np.sqrt(nrm)
        if not nrm > 0.0:
            return np.eye(d)
        for i in range(d):
            Q[i, c] /= nrm
    return Q


@njit(cache=True)
def _inverse_enclosure(Q, Xlo, Xhi, u, eta):
    """Enclose ``Q^-1`` entrywise: with ``X = Q^T`` and ``E = I - X Q`` (intervals), ``delta = ||E||_inf
    < 1`` gives ``Q^-1 = (I - E)^-1 X = X + sum_{k>=1} E^k X``, whose entries lie within
    ``delta ||X||_inf / (1 - delta)`` of ``X``'s. Returns False when ``delta >= 1/2`` (refused)."""
    d = Q.shape[0]
    delta = 0.0
    nx = 0.0
    for i in range(d):
        row = 0.0
        xrow = 0.0
        for j in range(d):
            slo = 1.0 if i == j else 0.0
            shi = slo
            for k in range(d):
                p = Q[k, i] * Q[k, j]  # X[i, k] Q[k, j]
                slo = _dn(slo - _up(p, u, eta), u, eta)
                shi = _up(shi - _dn(p, u, eta), u, eta)
            row = _up(row + max(abs(slo), abs(shi)), u, eta)
            xrow = _up(xrow + abs(Q[j, i]), u, eta)
        delta = max(delta, row)
        nx = max(nx, xrow)
    if not delta < 0.5:
        return False
    rad = _up(_up(delta * nx, u, eta) / _dn(1.0 - delta, u, eta), u, eta)
    for i in range(d):
        for j in range(d):
            Xlo[i, j] = _dn(Q[j, i] - rad, u, eta)
            Xhi[i, j] = _up(Q[j, i] + rad, u, eta)
    return True


PROBE = np.array([2.0**-54, 2.0**-53 + 2.0**-105, 1.0])  # run-time operands of :func:`_nearest`


@njit(cache=True)
def _nearest(probe):
    """The current rounding mode is round-to-nearest (the model's assumption), probed at run time on
    the argument ``probe`` = :data:`PROBE` (run-time values, so nothing is folded at compile time):
    ``1 + 2^-54`` rounds to 1 and ``1 + (2^-53 + 2^-105)`` to ``1 + 2^-52``, and the same negated --
    only round-to-nearest does all four (another library may have left the mode directed)."""
    one = probe[2]
    up = 1.0 + 2.0**-52  # exact
    return (
        one + probe[0] == one
        and one + probe[1] == up
        and -one - probe[0] == -one
        and -one - probe[1] == -up
    )


@njit(cache=True)
def rounding_mode(probe):
    """The current rounding mode as seen by compiled code (the SSE/NEON control register, which C's
    ``fegetround`` need not report: on x86-64 glibc reads the x87 word): 0 to nearest, 1 upward,
    2 downward, 3 toward zero; probed like :func:`_nearest`."""
    if _nearest(probe):
        return 0
    one = probe[2]
    up = 1.0 + 2.0**-52
    if one + probe[0] == up:
        return 1
    if -one - probe[0] == -up:
        return 2
    return 3


@njit(cache=True)
def enclose(tab, y0lo, y0hi, T, P, q, tol, h0, max_steps, u, eta, probe):
    """Enclose ``y(T)`` for ``y' = F(y)`` (tables ``tab``), ``y(0)`` in ``[y0lo, y0hi]``.

    Returns ``(lo, hi, steps, rejected, status)`` (module docstring for ``status``).
    """
    d = y0lo.shape[0]
    if not _nearest(probe):
        return y0lo, y0hi, 0, 0, NOT_NEAREST
    npair = tab[12].shape[0]
    conv = np.empty((2, max(npair, 1)))
    yhat = np.empty(d)
    rlo = np.empty((d, 1))
    rhi = np.empty((d, 1))
    for i in range(d):
        yhat[i] = 0.5 * y0lo[i] + 0.5 * y0hi[i]
        rlo[i, 0] = _dn(y0lo[i] - yhat[i], u, eta)
        rhi[i, 0] = _up(y0hi[i] - yhat[i], u, eta)
    B = np.eye(d)
    steps = 0
    rejected = 0
    t = 0.0
    # work arrays
    Plo = np.zeros((P + 2, d))
    Phi = np.zeros((P + 2, d))
    Elo = np.empty(d)
    Ehi = np.empty(d)
    TElo = np.zeros((P + 2, d))
    TEhi = np.zeros((P + 2, d))
    TYlo = np.zeros((P + 2, d))
    TYhi = np.zeros((P + 2, d))
    Ylo = np.empty(d)
    Yhi = np.empty(d)
    Jlo = np.zeros((q + 2, d, d))
    Jhi = np.zeros((q + 2, d, d))
    Ilo = np.eye(d)
    Clo = np.empty((d, d))
    Chi = np.empty((d, d))
    Mlo = np.empty((d, d))
    Mhi = np.empty((d, d))
    Xlo = np.empty((d, d))
    Xhi = np.empty((d, d))
    XMlo = np.empty((d, d))
    XMhi = np.empty((d, d))
    philo = np.empty(d)
    phihi = np.empty(d)
    elo = np.empty((d, 1))
    ehi = np.empty((d, 1))
    n1lo = np.empty((d, 1))
    n1hi = np.empty((d, 1))
    n2lo = np.empty((d, 1))
    n2hi = np.empty((d, 1))
    h = h0
    fac = 0.8  # the step as a fraction of the point series' estimate, learnt from rejections
    hjac = 1e300  # the step the last set-dependent width predicts (below)
    Dw = np.empty(d)
    while t < T:
        if steps >= max_steps:
            return yhat, yhat, steps, rejected, MAXSTEPS
        # the set as a box, and the point series at its centre (also sets the step)
        _matmul(B, B, rlo, rhi, n1lo, n1hi, u, eta)
        for i in range(d):
            Ylo[i] = min(_dn(yhat[i] + n1lo[i, 0], u, eta), yhat[i])
            Yhi[i] = max(_up(yhat[i] + n1hi[i, 0], u, eta), yhat[i])
            Plo[0, i] = yhat[i]
            Phi[0, i] = yhat[i]
        _point_field(yhat, tab, Plo[1], Phi[1], u, eta)  # the dominant term, nearly exact
        _taylor(Plo, Phi, P + 1, tab, conv, u, eta, 1)
        a1 = 0.0
        a2 = 0.0
        for i in range(d):
            a1 = max(a1, abs(Phi[P, i]), abs(Plo[P, i]))
            a2 = max(a2, abs(Phi[P + 1, i]), abs(Plo[P + 1, i]))
        hest = 1e300
        if a1 > 0.0:
            hest = min(hest, (tol / a1) ** (1.0 / P))
        if a2 > 0.0:
            hest = min(hest, (tol / a2) ** (1.0 / (P + 1)))
        h = min(fac * hest, 2.0 * h, hjac)
        TYlo[0] = Ylo
        TYhi[0] = Yhi
        _taylor(TYlo, TYhi, P, tab, conv, u, eta)
        _jac_taylor(TYlo, TYhi, Ilo, Ilo, q, tab, Jlo, Jhi, u, eta)
        accepted = False
        for _try in range(60):
            # h rounded down to STEP_BITS significant bits (a power of two when STEP_BITS = 1: then
            # the scalings by h^k are exact; otherwise outward, a rounding each, and the grid is finer)
            mh, eh = math.frexp(h)
            h = math.ldexp(math.floor(mh * 2.0**STEP_BITS) / 2.0**STEP_BITS, eh)
            last = t + h >= T
            tn = T if last else t + h
            hh = tn - t
            sm = t + hh  # TwoSum: t + hh == tn exactly when the rounding error is 0
            bb = sm - t
            if sm == tn and (t - (sm - bb)) + (hh - bb) == 0.0:
                hlo = hh
                hhi = hh
            else:
                hlo = max(0.0, _dn(hh, u, eta))
                hhi = _up(hh, u, eta)
            hk = _powers(hhi, P + 1, u, eta)
            dfail = False
            ok = _enclosure(TYlo, TYhi, P, hk, tol, tab, conv, Elo, Ehi, TElo, TEhi, u, eta)
            if ok:
                hplo = 1.0
                hphi = 1.0
                for _k in range(P + 1):
                    hplo, hphi = _mul(hplo, hphi, hlo, hhi, u, eta)
                remmax = 0.0
                for i in range(d):
                    a, b = _mul(TElo[P + 1, i], TEhi[P + 1, i], hplo, hphi, u, eta)
                    remmax = max(remmax, abs(a), abs(b))
                if remmax <= tol:
                    # D: the set-dependent part of the terms q < k <= P, T_k(Y) - T_k(yhat), over
                    # the step (symmetric bound); it joins the error box, so keep it small against
                    # the set's width (it plays the part of a Jacobian remainder)
                    dmax = 0.0
                    ywid = 0.0
                    for i in range(d):
                        s_ = 0.0
                        for k in range(P, q, -1):
                            dlo = _dn(TYlo[k, i] - Phi[k, i], u, eta)
                            dhi = _up(TYhi[k, i] - Plo[k, i], u, eta)
                            s_ = _up(s_ + _up(max(-dlo, dhi) * hk[k], u, eta), u, eta)
                        Dw[i] = s_
                        dmax = max(dmax, s_)
                        ywid = max(ywid, Yhi[i] - Ylo[i])
                    dlim = JTOL * ywid + tol
                    if dmax > dlim:
                        ok = False
                        dfail = True
                        hjac = SHRINK * hh * (dlim / dmax) ** (1.0 / (q + 1))
                    elif dmax > 0.0:
                        hjac = 0.9 * hh * (dlim / dmax) ** (1.0 / (q + 1))
                    else:
                        hjac = 1e300
                else:
                    ok = False
            if ok:
                accepted = True
                break
            rejected += 1
            if dfail:  # the set-dependent width: the step it predicts
                h = hjac
            else:  # the enclosure or the remainder: the point series' factor shrinks
                fac = SHRINK * fac
                h = SHRINK * (tn - t)
            if h < 1e-12 * (1.0 + T):
                return yhat, yhat, steps, rejected, UNDERFLOW
        if not accepted:
            return yhat, yhat, steps, rejected, UNDERFLOW
        # phi_h(yhat): the point series plus the remainder over E (the small terms first)
        _series_sum(Plo, Phi, P, hlo, hhi, philo, phihi, u, eta)
        for i in range(d):
            a, b = _mul(TElo[P + 1, i], TEhi[P + 1, i], hplo, hphi, u, eta)
            philo[i] = _dn(philo[i] + a, u, eta)  # the tail: phi = yhat + tail
            phihi[i] = _up(phihi[i] + b, u, eta)
        # C: the Jacobian of the terms k <= q over the set (the series of D_y T_k over Y); the terms
        # q < k <= P enter through D, the remainder through the tail (module docstring, Steps)
        for i in range(d):
            for c in range(d):
                slo = Jlo[q, i, c]
                shi = Jhi[q, i, c]
                for k in range(q - 1, -1, -1):
                    a, b = _mul(slo, shi, hlo, hhi, u, eta)
                    slo = _dn(Jlo[k, i, c] + a, u, eta)
                    shi = _up(Jhi[k, i, c] + b, u, eta)
                Clo[i, c] = slo
                Chi[i, c] = shi
        # Lohner: M = C B, B' = Q(mid M), yhat' = mid(phi), r' = (B'^-1 M) r + B'^-1 (phi - yhat')
        _matmul(Clo, Chi, B, B, Mlo, Mhi, u, eta)
        Mm = 0.5 * Mlo + 0.5 * Mhi
        wgt = np.empty(d)
        for c in range(d):
            wgt[c] = max(abs(rlo[c, 0]), abs(rhi[c, 0])) + 1e-300
        Bn = _qr_basis(Mm, wgt)
        if not _inverse_enclosure(Bn, Xlo, Xhi, u, eta):
            Bn = np.eye(d)
            Xlo[:, :] = Bn
            Xhi[:, :] = Bn
        for i in range(d):
            # yhat' = fl(yhat + m), m the tail's midpoint; Knuth's TwoSum gives the rounding error
            # err exactly (yhat + m = yhat' + err), so phi - yhat' = err + (tail - m): no widening
            # at the size of |yhat|, only at the size of the tail's width
            m = 0.5 * philo[i] + 0.5 * phihi[i]
            sm = yhat[i] + m
            bb = sm - yhat[i]
            err = (yhat[i] - (sm - bb)) + (m - bb)
            elo[i, 0] = _dn(_dn(err + _dn(philo[i] - m, u, eta), u, eta) - Dw[i], u, eta)
            ehi[i, 0] = _up(_up(err + _up(phihi[i] - m, u, eta), u, eta) + Dw[i], u, eta)
            yhat[i] = sm
        _matmul(Xlo, Xhi, Mlo, Mhi, XMlo, XMhi, u, eta)
        _matmul(XMlo, XMhi, rlo, rhi, n1lo, n1hi, u, eta)
        _matmul(Xlo, Xhi, elo, ehi, n2lo, n2hi, u, eta)
        finite = True
        for i in range(d):
            rlo[i, 0] = _dn(n1lo[i, 0] + n2lo[i, 0], u, eta)
            rhi[i, 0] = _up(n1hi[i, 0] + n2hi[i, 0], u, eta)
            if not (np.isfinite(rlo[i, 0]) and np.isfinite(rhi[i, 0]) and np.isfinite(yhat[i])):
                finite = False
        if not finite:
            return yhat, yhat, steps, rejected, NONFINITE
        B = Bn
        steps += 1
        t = tn
        h = hhi
        fac = min(0.8, 1.05 * fac)
    _matmul(B, B, rlo, rhi, n1lo, n1hi, u, eta)
    lo = np.empty(d)
    hi = np.empty(d)
    for i in range(d):
        lo[i] = _dn(yhat[i] + n1lo[i, 0], u, eta)
        hi[i] = _up(yhat[i] + n1hi[i, 0], u, eta)
        if not (np.isfinite(lo[i]) and np.isfinite(hi[i])):
            return lo, hi, steps, rejected, NONFINITE
    return lo, hi, steps, rejected, OK
