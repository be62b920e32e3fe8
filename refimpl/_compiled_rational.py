"""Compiled (numba) adaptive Taylor method for the rational body fields with ``Upsilon != 0``.

The field (vier10/vier11, the body system of :meth:`refimpl._flow_fast.NumpyModel.omega_pidot`)
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
    the orders stay loops). The module is written under :func:`refimpl._compiled_taylor.cache_dir`
    named by its hash and compiled with ``cache=True`` (a second process loads machine code). Without
    numba the same source runs as plain Python (``njit`` replaced by the identity).
"""

from __future__ import annotations

import numpy as np

from . import _compiled_taylor as _ct
from ._errors import DegeneratePointError

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
STALL = 64 * float(np.finfo(float).eps)  # a step below STALL * t cannot advance t reliably: stalled


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


# ------------------------------------------------------------------------------ code generation
_HEADER = '''"""Generated by tstarg.refimpl._compiled_rational (one structure; numbers are arguments)."""
import math
import numpy as np

try:
    from numba import njit
except ImportError:  # plain-Python path

    def njit(**kw):
        return lambda fn: fn


@njit(cache=True, nogil=True)
def invert(A, Ainv, n, M):
    """Gauss-Jordan with partial pivoting: Ainv = A^-1 (M: an (n, 2n) work array); returns cond_inf(A)
    (inf when a pivot is 0)."""
    anorm = 0.0
    for i in range(n):
        r = 0.0
        for j in range(n):
            M[i, j] = A[i, j]
            M[i, n + j] = 1.0 if i == j else 0.0
            r += abs(A[i, j])
        anorm = max(anorm, r)
    for c in range(n):
        p = c
        for i in range(c + 1, n):
            if abs(M[i, c]) > abs(M[p, c]):
                p = i
        if not (abs(M[p, c]) > 0.0):
            return np.inf
        if p != c:
            for j in range(2 * n):
                tmp = M[c, j]
                M[c, j] = M[p, j]
                M[p, j] = tmp
        piv = 1.0 / M[c, c]
        for j in range(2 * n):
            M[c, j] *= piv
        for i in range(n):
            if i != c:
                g = M[i, c]
                if g != 0.0:
                    for j in range(2 * n):
                        M[i, j] -= g * M[c, j]
    inorm = 0.0
    for i in range(n):
        r = 0.0
        for j in range(n):
            Ainv[i, j] = M[i, n + j]
            r += abs(M[i, n + j])
        inorm = max(inorm, r)
    return anorm * inorm


@njit(cache=True, nogil=True)
def gamma0(x0, trip, fv, gamma, out):
    """out[i] = Ad(exp x0[i])^T gamma = exp(ad_x^T) gamma (twee16), ``(ad_x)_mb = x_a f^m_ab``: the Taylor
    series of exp on the vector, scaled to ||A/2^s||_inf <= 1/2 and applied 2^s times."""
    N, n = x0.shape
    A = np.zeros((n, n))
    v = np.empty(n)
    term = np.empty(n)
    acc = np.empty(n)
    for it in range(N):
        for i in range(n):
            for j in range(n):
                A[i, j] = 0.0
        for t in range(trip.shape[0]):
            A[trip[t, 2], trip[t, 0]] += x0[it, trip[t, 1]] * fv[t]
        nrm = 0.0
        for i in range(n):
            r = 0.0
            for j in range(n):
                r += abs(A[i, j])
            nrm = max(nrm, r)
        s = 0
        while nrm > 0.5:
            nrm *= 0.5
            s += 1
        scale = 0.5**s
        for i in range(n):
            v[i] = gamma[i]
        for _ in range(2**s):
            vmax = 0.0
            for i in range(n):
                term[i] = v[i]
                acc[i] = v[i]
                vmax = max(vmax, abs(v[i]))
            for k in range(1, 40):
                c = scale / k
                tmax = 0.0
                for i in range(n):
                    r = 0.0
                    for j in range(n):
                        r += A[i, j] * term[j]
                    v[i] = r * c
                for i in range(n):
                    term[i] = v[i]
                    acc[i] += v[i]
                    tmax = max(tmax, abs(v[i]))
                if tmax <= 1e-17 * vmax:
                    break
            for i in range(n):
                v[i] = acc[i]
        for i in range(n):
            out[it, i] = v[i]
'''


def _matvec(name: str, mask: np.ndarray, vec: str, transpose: bool = False) -> list[list[str]]:
    """Per output row ``a``: the terms ``name[a, b] * vec(b)`` over the nonzero pattern ``mask``."""
    n = mask.shape[0]
    rows = []
    for a in range(n):
        terms = []
        for b in range(n):
            nz = mask[b, a] if transpose else mask[a, b]
            if nz:
                idx = f"{b}, {a}" if transpose else f"{a}, {b}"
                terms.append(f"{name}[{idx}] * {vec.format(b)}")
        rows.append(terms)
    return rows


def _levi(a: int, b: int, c: int) -> int:
    """The Levi-Civita symbol eps_abc (0-based indices)."""
    return (a - b) * (b - c) * (c - a) // 2


def _sum(terms) -> str:
    return " + ".join(terms) if terms else "0.0"


def kernel_source(rf: RationalField) -> str:
    """The kernel module for the structure of ``rf`` (see the module docstring)."""
    n, d = rf.n, rf.d
    trip = rf.trip
    nzI = rf.Iinv != 0.0
    nzU = rf.U != 0.0
    nzT = rf.theta != 0.0
    nzG = rf.GL != 0.0
    nzUG = rf.UGL != 0.0
    grav = rf.gravity
    I1, I2, I3, I4, I5 = ("    " * i for i in range(1, 6))

    # pairs of the contractions: (S v)_a <- (m, b); (S^T w)_b <- (m, a); Gdot_mu <- (Omega b, Gamma m)
    sv_pairs = sorted({(m, b) for m, a, b in trip})
    st_pairs = sorted({(m, a) for m, a, b in trip})
    g_pairs = sorted({(a, m) for m, a, b in trip})

    def contract(prefix, out_of, pair_of):
        rows = [[] for _ in range(n)]
        for t, (m, a, b) in enumerate(trip):
            p = pair_of(m, a, b)
            rows[out_of(m, a, b)].append(f"fv{t} * {prefix}_{p[0]}_{p[1]}")
        return rows

    body = []
    # ---- Psi_0 = 1 + U S_0 and its inverse; the condition number
    for a in range(n):
        for b in range(n):
            terms = [
                f"fv{t} * PI[{m}, 0]" for t, (m, aa, bb) in enumerate(trip) if (aa, bb) == (a, b)
            ]
            if nzT[a, b]:
                terms.append(f"- th[{a}, {b}]")
            body.append(f"S0[{a}, {b}] = {_sum(terms).replace('+ -', '-')}")
    body += [
        "for a in range(n):",
        I1 + "for b in range(n):",
        I2 + "acc = 1.0 if a == b else 0.0",
        I2 + "for c in range(n):",
        I3 + "acc += U[a, c] * S0[c, b]",
        I2 + "Psi[a, b] = acc",
        "cnd = invert(Psi, Mi, n, GJ)",
        "if not (cnd <= cond_max):",
        I1 + "status = -2",
        I1 + "cond_seen = cnd",
        I1 + "break",
        "cond_seen = max(cond_seen, cnd)",
        "for k in range(P):",
    ]
    # ---- order k
    kb = []
    # Omega_k: r = Iinv pi_k + UGL Gamma_k - U (sum_{j=1..k} S_j Omega_{k-j})
    kb += [f"po_{m}_{b} = 0.0" for m, b in sv_pairs]
    kb += ["for j in range(1, k + 1):"]
    kb += [I1 + f"po_{m}_{b} += PI[{m}, j] * OM[{b}, k - j]" for m, b in sv_pairs]
    cso = contract("po", lambda m, a, b: a, lambda m, a, b: (m, b))
    kb += [f"cs{a} = {_sum(cso[a])}" for a in range(n)]
    rI = _matvec("Ii", nzI, "PI[{}, k]")
    rG = _matvec("UGL", nzUG, "GA[{}, k]") if grav else [[] for _ in range(n)]
    rU = _matvec("U", nzU, "cs{}")
    for a in range(n):
        terms = rI[a] + rG[a]
        e = _sum(terms)
        if rU[a]:
            e += " - (" + " + ".join(rU[a]) + ")"
        kb.append(f"r{a} = {e}")
    for a in range(n):
        kb.append(f"OM[{a}, k] = " + _sum([f"Mi[{a}, {b}] * r{b}" for b in range(n)]))
    # dK_k = Iinv pi_k
    for a in range(n):
        kb.append(f"DK[{a}, k] = {_sum(rI[a])}")
    # sum_{j=0..k} S_j dK_{k-j} (f part) and sum_{j=1..k} S_j^T w_{k-j}
    kb += [f"pd_{m}_{b} = PI[{m}, 0] * DK[{b}, k]" for m, b in sv_pairs]
    kb += [f"pw_{m}_{a} = 0.0" for m, a in st_pairs]
    kb += ["for j in range(1, k + 1):"]
    kb += [I1 + f"pd_{m}_{b} += PI[{m}, j] * DK[{b}, k - j]" for m, b in sv_pairs]
    kb += [I1 + f"pw_{m}_{a} += PI[{m}, j] * W[{a}, k - j]" for m, a in st_pairs]
    csd = contract("pd", lambda m, a, b: a, lambda m, a, b: (m, b))
    csw = contract("pw", lambda m, a, b: b, lambda m, a, b: (m, a))
    rTh = _matvec("th", nzT, "DK[{}, k]")
    rGL = _matvec("GL", nzG, "GA[{}, k]") if grav else [[] for _ in range(n)]
    for a in range(n):
        pos = rGL[a] + rTh[a]  # G_L Gamma_k + Theta dK_k
        neg = csd[a] + csw[a]
        e = _sum(pos)
        if neg:
            e += " - (" + " + ".join(neg) + ")"
        kb.append(f"q{a} = {e}")
    inv = "ik"
    kb.append(f"{inv} = 1.0 / (k + 1)")
    for a in range(n):
        kb.append(f"pd{a} = " + _sum([f"Mi[{b}, {a}] * q{b}" for b in range(n)]))
    for a in range(n):
        kb.append(f"PI[{a}, k + 1] = pd{a} * {inv}")
    wU = _matvec("U", nzU, "pd{}", transpose=True)
    for a in range(n):
        kb.append(f"W[{a}, k] = {_sum(wU[a])}")
    if grav:
        kb += [f"og_{b}_{m} = 0.0" for b, m in g_pairs]
        kb += ["for j in range(k + 1):"]
        kb += [I1 + f"og_{b}_{m} += OM[{b}, j] * GA[{m}, k - j]" for b, m in g_pairs]
        cg = contract("og", lambda m, a, b: b, lambda m, a, b: (a, m))
        for mu in range(n):
            kb.append(f"GA[{mu}, k + 1] = ({_sum(cg[mu])}) * {inv}")
    if rf.quat:
        # the group element as the unit quaternion q (g = q_0 - i q.sigma, refimpl._taylor.
        # quadratic_field_su2_full): dq/dt = q * (0, Omega/2), i.e. dq_0/dt = -1/2 q.Omega and
        # dq/dt = 1/2 (q_0 Omega + q x Omega); bilinear in (q, Omega): Cauchy products with OM
        qb = ["for j in range(k + 1):"]
        kb += [f"qo_{i}_{b} = 0.0" for i in range(4) for b in range(n)]
        kb += qb + [
            I1 + f"qo_{i}_{b} += QQ[{i}, j] * OM[{b}, k - j]" for i in range(4) for b in range(n)
        ]
        kb.append(
            f"QQ[0, k + 1] = -0.5 * ({' + '.join(f'qo_{b + 1}_{b}' for b in range(n))}) * {inv}"
        )
        for a in range(n):
            cross = []
            for e in range(n):
                for b in range(n):
                    sgn = _levi(a, e, b)
                    if sgn:
                        cross.append(f"{'+' if sgn > 0 else '-'} qo_{e + 1}_{b}")
            kb.append(f"QQ[{a + 1}, k + 1] = 0.5 * (qo_0_{a} {' '.join(cross)}) * {inv}")
    body += [I1 + x for x in kb]

    rows = [("PI", c) for c in range(n)] + ([("GA", c) for c in range(n)] if grav else [])
    if rf.quat:
        rows += [("QQ", c) for c in range(4)]

    def amax(k):
        e = f"abs({rows[0][0]}[{rows[0][1]}, {k}])"
        for r, c in rows[1:]:
            e = f"max({e}, abs({r}[{c}, {k}]))"
        return e

    step = [
        f"s = tol * max(1.0, {amax(0)})",
        f"a1 = {amax('P - 1')}",
        f"a2 = {amax('P')}",
        "h = np.inf",
        "if a1 > 0.0:",
        I1 + "h = (s / a1) ** e1",
        "if a2 > 0.0:",
        I1 + "h = min(h, (s / a2) ** e2)",
        "h *= damp",
        # no step (the coefficients overflowed) or a step collapsed below float64's resolution of t:
        # a real singularity of the field ahead (vier12); the caller checks the state is finite
        "if not (h > stall * t):",
        I1 + "status = -4",
        I1 + "break",
        "if t + h >= Tabs:",
        I1 + "h = Tabs - t",
        I1 + "t = Tabs",
        "else:",
        I1 + "t += h",
        "hs = sgn * h",
    ]
    for c, (r, i) in enumerate(rows):
        step += [
            f"z = {r}[{i}, P]",
            "for kk in range(P - 1, 0, -1):",
            I1 + f"z = z * hs + {r}[{i}, kk]",
            f"z = z * hs - comp[{c}]",
            f"w = {r}[{i}, 0] + z",
            f"comp[{c}] = (w - {r}[{i}, 0]) - z",
            f"{r}[{i}, 0] = w",
        ]
    fin = " and ".join(f"math.isfinite({r}[{i}, 0])" for r, i in rows)
    step += [
        "nst += 1",
        f"if not ({fin}):",
        I1 + "status = -1",
        I1 + "break",
        "if nst > max_steps:",
        I1 + "status = -3",
        I1 + "break",
    ]

    src = [
        _HEADER,
        "",
        "@njit(cache=True, nogil=True)",
        "def adaptive(y0, T, tol, P, max_steps, fv, th, U, Ii, GL, UGL, cond_max, out, nsteps, tend, conds):",
        I1 + f"n = {n}",
    ]
    src += [I1 + f"fv{t} = fv[{t}]" for t in range(len(trip))]
    src += [
        I1 + "N = y0.shape[0]",
        I1 + "PI = np.zeros((n, P + 1))",
        I1 + "GA = np.zeros((n, P + 1))",
        I1 + "OM = np.zeros((n, P + 1))",
        I1 + "DK = np.zeros((n, P + 1))",
        I1 + "W = np.zeros((n, P + 1))",
        I1 + "QQ = np.zeros((4, P + 1))",
        I1 + "S0 = np.zeros((n, n))",
        I1 + "Psi = np.zeros((n, n))",
        I1 + "Mi = np.zeros((n, n))",
        I1 + "GJ = np.zeros((n, 2 * n))",
        I1 + f"comp = np.zeros({d})",
        I1 + "sgn = 1.0 if T >= 0 else -1.0",
        I1 + "Tabs = abs(T)",
        I1 + "damp = math.exp(-0.7 / (P - 1))",
        I1 + "e1 = 1.0 / (P - 1)",
        I1 + "e2 = 1.0 / P",
        I1 + f"stall = {STALL!r}",
        I1 + "for it in range(N):",
    ]
    for c, (r, i) in enumerate(rows):
        src.append(I2 + f"{r}[{i}, 0] = y0[it, {c}]")
    src += [
        I2 + f"for c in range({d}):",
        I3 + "comp[c] = 0.0",
        I2 + "t = 0.0",
        I2 + "nst = 0",
        I2 + "status = 0",
        I2 + "cond_seen = 0.0",
        I2 + "while t < Tabs:",
    ]
    src += [I3 + x for x in body]
    src += [I3 + x for x in step]
    for c, (r, i) in enumerate(rows):
        src.append(I2 + f"out[it, {c}] = {r}[{i}, 0]")
    src += [
        I2 + "nsteps[it] = nst if status == 0 else status",
        I2 + "tend[it] = sgn * t",
        I2 + "conds[it] = cond_seen",
    ]
    del I4, I5
    return "\n".join(src) + "\n"


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

    Returns the dict of :func:`refimpl._flow_fast.integrate_fast` (``x`` None) plus ``steps`` (N,) and
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


def _raise_failed(y, steps, tend, conds, t, cond_max):
    deg = np.flatnonzero(steps == -2)
    if deg.size:
        raise DegeneratePointError(
            f"rational Taylor flow: trajectories {deg[:10].tolist()} reached the degenerate set Pi_1 "
            f"(vier12) at t = {tend[deg[:3]].tolist()}: cond_inf(Phi) = {conds[deg[:3]].tolist()} > "
            f"{cond_max:g} (Delta = det Phi = 0 to float64 accuracy); no value past that point is returned"
        )
    stall = np.flatnonzero((steps == -4) & np.all(np.isfinite(y), axis=1))
    if stall.size:
        raise DegeneratePointError(
            f"rational Taylor flow: trajectories {stall[:10].tolist()} reach the degenerate set Pi_1 (vier12) "
            f"at about t = {tend[stall[:3]].tolist()}: the step size collapsed (below {STALL:.2g} t, or the Taylor "
            "coefficients overflowed) while the "
            f"state stayed finite and cond_inf(Phi) grew to {conds[stall[:3]].tolist()} (the field's only "
            "real singularities are the zeros of Delta = det Phi); no value past that point is returned"
        )
    bad = np.flatnonzero(steps < 0)
    if bad.size:
        raise ValueError(
            f"rational Taylor flow: trajectories {bad[:10].tolist()} became non-finite or exceeded the step "
            f"budget before t = {t} (stopped at t = {tend[bad[:3]].tolist()}); no point is dropped"
        )
