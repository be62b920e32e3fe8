"""What the checks share: constants, calls into the implementation, the judges' caches.

The float64 judge and the error models live in :mod:`tstarg.oracles.float_judge`."""

from __future__ import annotations

import functools
import hashlib
import inspect
import json
import math
import os
import re
from collections import OrderedDict
from pathlib import Path

import numpy as np
from hypothesis import currently_in_test_context
from hypothesis import target as hyp_target

from tstarg.oracles.float_judge import (
    FloatJudge,
    MatrixGroup,
    ad,
    compare_state,
    conditioning,
    expm,
    max_err,
    phi1,
    reference_work,
    sensitivity_at,
)
from tstarg.properties.runner import note
from tstarg.refimpl import (
    CATALOGUE_NAMES,
    RepresentationError,
    catalogue,
    provides,
    representation_for,
)
from tstarg.refimpl.flows import reference as _flow_reference
from tstarg.refimpl.flows import reference_flow
from tstarg.refimpl.reference import Reference
from tstarg.refimpl.rigorous import (
    INTERVAL_JUDGE,
    Rigorous,
    arb_judge_name,
    judge_flows,
)

from .._atomic import write_text

_REF = Reference(30)

_JUDGE = Rigorous(200)

PROVEN_PREC_BITS = 64
"""Working precision of the proven flow judge's Arb route (:func:`_proven_state`; ``Upsilon != 0`` or
where the intervals refuse): its balls' radii are ~1e-17 at ``|t| <= 1``, far below every float64 flow
tolerance (>= 1e-9 for a declared ``flow_tolerance``)."""

PROVEN_MAX_SECONDS = 4.0
"""CPU budget of one proven flow enclosure by the Arb route (estimated from its first steps; over it
the balls refuse and the mpmath reference judges, named in the certificate's counts)."""

LONG_ROUTE = "interval"
"""The proven judge's route in ``flow.long``, ``flow.order`` and ``protocol.inputs``: the interval
route only. The Arb route (``Upsilon != 0``) was measured there on refimpl.fast and the plain RK4
(ci budget, seed 0): within a 1 s budget it answered none of 23 examples (its rational field at
``|t|`` up to 10 takes 0.16-12 s per example) and spent up to 6.7 s on a refusal; the float64 judge
answers those (counted by reason)."""

ARB_JUDGE = arb_judge_name(PROVEN_PREC_BITS)
"""The name of the proven flow judge's second route."""

PROVEN_JUDGE = (
    f"{INTERVAL_JUDGE} where Upsilon = 0, {ARB_JUDGE} where Upsilon != 0 or the intervals refuse"
)
"""The name of the proven flow judge in certificates and reports (each check counts the examples
by the route that answered: :data:`INTERVAL_JUDGE` or :data:`ARB_JUDGE`)."""

JUDGE = (
    "brackets: refimpl.rigorous (Arb balls, 200 bits; errors are proven upper bounds, digits proven "
    f"digits); flow.reference: {PROVEN_JUDGE}; flow.long, flow.order, protocol.inputs: "
    f"{INTERVAL_JUDGE} where Upsilon = 0 (refimpl.rigorous.judge_flow): the whole state (pi, Gamma, rho(g), Ad(g)) enclosed by an "
    "interval Taylor method with Lohner's wrapping and x by a proven principal logarithm (its error: "
    "the boxes' radius plus half an ulp, proven, added to every tolerance); where no box is given "
    "(counted by reason in each check): flow.reference by refimpl.reference (mpmath, 25 digits), the "
    "others by oracles.float_judge.FloatJudge (scipy DOP853 at rtol 1e-13 on the body system, on the "
    "flow's group; its error estimated by a run at rtol 1e-12, examples where it exceeds a tenth of "
    "the tolerance drawn again); flow.drift and flow.poisson_map need no flow judge (the energy and "
    "Casimir of the implementation's own states against their start values; D Phi P D Phi^T against "
    "P o Phi with P from the mpmath reference); vector fields: refimpl.reference (mpmath, 25-30 digits)"
)

FLOW_T_MAX = 10.0
"""Largest ``|t|`` drawn by ``flow.long`` (a declared ``max_abs_t`` lowers it). Widen it once every
algebra can be flowed past the chart edge by the judges (issue 13)."""

FLOW_REF_T_MAX = 1.0
"""Largest ``|t|`` compared against the mpmath reference flow (``flow.reference``)."""

REFERENCE_WORK_LIMIT = 60.0
"""Per-example work limit of the mpmath reference flow, in the units of :func:`reference_work`
(about 2 s of reference time on this machine; su(2) with gravity at t = 1 costs ~25)."""

LONG_WORK_LIMIT = 30.0
"""``flow.long``: largest ``|t| (1 + rho)`` (time in units of the fastest rate at the start), so that
exponential growth on non-compact algebras stays within float64's reach."""

FLOW_COND_LIMIT = 1e3
"""Flows in the batch and input checks start where ``cond(Phi) <= 1e3`` and ``|t| (1 + rho) <= 3``:
those checks are about the protocol, not accuracy, and must stay cheap for any implementation."""

ALLOW_CHART_REFUSAL = False
"""Accept (count, and state in the certificate) a ``ValueError`` from ``flow`` when the trajectory
leaves the chart of exponential coordinates (the judge's ``x`` reaches ``||ad_x||_2 = 0.9 * 2 pi``)
or the algebra is not a catalogue algebra with a known matrix representation: refimpl's flows
cannot yet re-base ``g(t)`` there (issue 13). Set False once they can."""

DRIFT_T = 25.0
"""Longest time of ``flow.drift`` (a declared ``max_abs_t`` lowers it)."""

DRIFT_WORK_LIMIT = 12.0
"""``flow.drift`` runs to ``T = min(DRIFT_T, DRIFT_WORK_LIMIT / (1 + rho))``: long in the motion's
own time scale, bounded in cost for any implementation (raise both for a thorough run)."""


def _aim(ratio: float, label: str) -> None:
    """Guide Hypothesis' search towards the largest error/tolerance ratio (targeted PBT). Outside a
    Hypothesis test (``--replay``, a body called directly) there is no search to guide: nothing."""
    if math.isfinite(ratio) and ratio > 0 and currently_in_test_context():
        hyp_target(math.log10(ratio), label=label)


def _call(impl, method, *args, **kw):
    return getattr(impl, method)(*args, **kw)


def _finite_array(value, shape, what) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != shape:
        raise AssertionError(f"{what}: result has shape {arr.shape}, expected {shape}")
    return arr


def _digits(err, scale):
    return math.inf if err == 0 else -math.log10(err / scale)


class _RefCache:
    """Reference flows cached by value (shrinking replays the same inputs many times)."""

    def __init__(self, size: int = 256):
        self.data: OrderedDict = OrderedDict()
        self.size = size

    def get(self, key, compute):
        if key in self.data:
            self.data.move_to_end(key)
            return self.data[key]
        val = compute()
        self.data[key] = val
        if len(self.data) > self.size:
            self.data.popitem(last=False)
        return val


_FLOW_CACHE = _RefCache()


def _key(*arrays) -> tuple:
    out = []
    for a in arrays:
        if isinstance(a, dict):
            out.append(tuple((k, _key(v)) for k, v in sorted(a.items())))
        elif a is None or isinstance(a, (str, float, int)):
            out.append(a)
        else:
            arr = np.ascontiguousarray(np.asarray(a, dtype=float))
            out.append((arr.shape, arr.tobytes()))
    return tuple(out)


def _accepts_steps(impl) -> bool:
    try:
        sig = inspect.signature(impl.flow)
    except (TypeError, ValueError):
        return False
    return "steps" in sig.parameters or any(
        p.kind is p.VAR_KEYWORD for p in sig.parameters.values()
    )


def _as_lists(a):
    return (
        None
        if a is None
        else (
            np.asarray(a).tolist()
            if not isinstance(a, dict)
            else {k: (v if k == "kind" else np.asarray(v).tolist()) for k, v in a.items()}
        )
    )


def _odd_layout(a):
    """``a`` with the same values in an unusual, read-only memory layout: a vector as a strided view
    (every other element of a larger buffer), a matrix or ``f`` in Fortran order."""
    if a is None:
        return None
    if isinstance(a, dict):
        return {k: (v if k == "kind" else _odd_layout(v)) for k, v in a.items()}
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        buf = np.zeros(2 * a.size)
        buf[::2] = a
        v = buf[::2]
    else:
        v = np.asfortranarray(a)
    v.flags.writeable = False
    return v


def _cheap_flow(model, inertia, pot, pts, t) -> bool:
    f, theta, ups = model
    for x, p in pts:
        c, _ = conditioning(f, theta, ups, x, p)
        if not c <= FLOW_COND_LIMIT:
            return False
        if reference_work(f, theta, ups, inertia, pot, x, p, t) / f.shape[0] ** 3 > 3.0:
            return False
    return True


def _judge_state(f, theta, ups, inertia, pot, x, pi, t, stats=None):
    """``((x, pi, Ad), errors)`` at ``t``: the proven judge's box midpoints and proven errors
    (:func:`_proven_flows` by :data:`LONG_ROUTE`; ``x`` None where it is not proven), or where no box is given (counted by
    reason in ``stats``) the float64 judge's state and estimated errors; cached by value."""
    out = _proven_flows(
        f, theta, ups, inertia, pot, x, pi, (float(t),), want_ad=True, arb_seconds=0.0,
        route=LONG_ROUTE,
    )  # fmt: skip
    if isinstance(out, str):
        if stats is not None:
            _count(stats, f"float64 judge (no box: {out})")
        return _FLOW_CACHE.get(
            ("judge",) + _key(f, theta, ups, inertia, pot, x, pi, float(t)),
            lambda: FloatJudge(f, theta, ups, inertia, pot).judged(x, pi, t),
        )
    (o,) = out
    if stats is not None:
        _count(stats, f"judged by {o['judge']}")
    xm = None if o["x"] is None else o["x"][0]
    ex = None if o["x"] is None else _proven_err(o["x"])
    return (xm, o["pi"][0], o["Ad_g"][0]), (ex, _proven_err(o["pi"]), _proven_err(o["Ad_g"]))


def _judge_group(f, theta, ups, inertia, pot, x, pi, t):
    """``((x, pi, Ad), errors, G)`` of the float64 judge carrying ``G = rho(g)`` as well where the
    centre is non-trivial (``G`` None and three errors otherwise; four with ``G``), cached by value."""
    out = _FLOW_CACHE.get(
        ("judge-group",) + _key(f, theta, ups, inertia, pot, x, pi, float(t)),
        lambda: FloatJudge(f, theta, ups, inertia, pot, group=True).judged(x, pi, t),
    )
    return out if len(out) == 3 else (*out, None)


def _judge_on(group, f, theta, ups, inertia, pot, x, pi, times):
    """The float64 judge carrying ``G = rho(g)`` on ``group`` (a :class:`MatrixGroup`) at every time
    of ``times`` (one sign) from one integration: ``(states, Gs, errors, sensitivities)`` (see
    :meth:`FloatJudge.judged_at` and :func:`sensitivity_at`), cached by value."""
    times = [float(t) for t in times]

    def compute():
        judge = FloatJudge(f, theta, ups, inertia, pot, rep=group)
        states, groups, errs = judge.judged_at(x, pi, times)
        return states, groups, errs, sensitivity_at(judge, x, pi, times, states, groups)

    gkey = ("none",) if group is None else (group.name, group.mats.tobytes())
    return _FLOW_CACHE.get(
        ("judge-on", *gkey, tuple(times)) + _key(f, theta, ups, inertia, pot, x, pi), compute
    )


def _proven_err(mr) -> float:
    """A proven bound of ``|exact - mid|`` over a part ``(mid, rad)`` of the judge's answer: the radius
    plus half an ulp of the float64 midpoint."""
    mid, rad = mr
    return float(np.max(rad + 0.5 * np.spacing(np.abs(mid)), initial=0.0))


def _short(text: str) -> str:
    """A refusal's message as a count key: its first clause, decimal numbers replaced by ``#`` (so that the
    same reason counts once, whatever the example)."""
    text = text.split(" (")[0].split(": ", 1)[-1]
    return re.sub(r"\d+\.\d+([eE][-+]?\d+)?|\d+[eE][-+]?\d+|\d{2,}", "#", text)[:90]


def _reason(exc: BaseException) -> str:
    """Why the proven judge gave no box: the Arb route's reason, and the interval route's before it."""
    out = f"{type(exc).__name__}: {_short(str(exc))}"
    for n in getattr(exc, "__notes__", ()):
        if n.startswith("the interval route refused first: "):
            first = n.removeprefix("the interval route refused first: ")
            out = f"intervals: {_short(first)}; Arb balls: {out}"
    return out


def _proven_flows(
    f, theta, ups, inertia, pot, x, pi, times, *, want_ad, arb_seconds, want_x=True, route="auto"
):
    """:func:`refimpl.rigorous.judge_flows` at ``times`` (one sign; ``route="auto"``: the interval
    route first, the Arb route at :data:`PROVEN_PREC_BITS` within ``arb_seconds``; ``"interval"``: that
    one only), or a string, the reason no box is given; cached by value."""
    times = tuple(float(t) for t in times)

    def compute():
        try:
            return judge_flows(
                f, theta, ups, inertia, pot, x, pi, times, prec_bits=PROVEN_PREC_BITS,
                want_ad=want_ad, want_x=want_x, max_seconds=arb_seconds, route=route,
            )  # fmt: skip
        except (ValueError, ArithmeticError) as exc:
            return _reason(exc)

    return _FLOW_CACHE.get(
        ("proven-flows", PROVEN_PREC_BITS, times, want_ad, want_x, arb_seconds, route)
        + _key(f, theta, ups, inertia, pot, x, pi),
        compute,
    )


@functools.lru_cache(maxsize=64)
def _faithful_mats(key: bytes, n: int):
    """The realified matrices of refimpl's faithful representation of ``f`` (those the judge's
    ``rho(g)`` is carried in), as :class:`MatrixGroup` stores them; None without one."""
    try:
        return MatrixGroup(representation_for(np.frombuffer(key).reshape(n, n, n)).mats, "").mats
    except RepresentationError:
        return None


def _proven_on(group, f, theta, ups, inertia, pot, x, pi, times):
    """The proven judge at every time of ``times`` (one sign), in the shape of :func:`_judge_on`:
    ``(states, Gs, errors, sensitivities, judge)`` -- box midpoints ``(x or None, pi, Ad)``, ``G`` on
    ``group`` (the box of ``rho(g)`` realified when ``group`` is refimpl's faithful representation,
    of ``Ad(g)`` when it is the adjoint group), proven errors ``(x, pi, Ad[, G])`` (radius plus half an
    ulp), and the flow's condition estimated as :func:`sensitivity_at` does, from a second box run
    from a start moved by ``h u``; ``judge`` names the route. A string where no box is given (the
    reason), or where ``group`` is a declared representation (no box of it is carried). By
    :data:`LONG_ROUTE`."""
    f = np.ascontiguousarray(np.asarray(f, dtype=float))
    n = f.shape[0]
    mode = None
    if group is not None:
        rho = _faithful_mats(f.tobytes(), n)
        if rho is not None and np.array_equal(group.mats, rho):
            mode = "rho"
        elif np.array_equal(group.mats, np.transpose(f, (1, 0, 2))):
            mode = "Ad"
        else:
            return "a declared representation (no box of its rho(g) is carried)"
    kw = {"want_ad": True, "arb_seconds": 0.0, "route": LONG_ROUTE}
    out = _proven_flows(f, theta, ups, inertia, pot, x, pi, times, **kw)
    if isinstance(out, str):
        return out
    u = np.cos(np.arange(1, 2 * n + 1) * 1.618)  # sensitivity_at's fixed direction
    u /= np.linalg.norm(u)
    x, pi = np.asarray(x, dtype=float), np.asarray(pi, dtype=float)
    h = 1e-6 * max(1.0, float(np.max(np.abs(np.concatenate([x, pi])))))
    moved = _proven_flows(
        f, theta, ups, inertia, pot, x + h * u[:n], pi + h * u[n:], times, want_x=False, **kw
    )
    if isinstance(moved, str):
        return f"the moved start of the condition estimate: {moved}"

    def G_of(o):
        if mode == "Ad":
            return o["Ad_g"][0], _proven_err(o["Ad_g"])
        re, im = o["rho_g"], o["rho_g_imag"]
        if im is None:
            return re[0], _proven_err(re)
        return np.block([[re[0], -im[0]], [im[0], re[0]]]), max(_proven_err(re), _proven_err(im))

    states, Gs, errs, sens = [], [], [], []
    for o, m in zip(out, moved):
        xm = None if o["x"] is None else o["x"][0]
        states.append((xm, o["pi"][0], o["Ad_g"][0]))
        e = (
            None if o["x"] is None else _proven_err(o["x"]),
            _proven_err(o["pi"]),
            _proven_err(o["Ad_g"]),
        )
        G = None
        if mode is not None:
            G, eG = G_of(o)
            e += (eG,)
        Gs.append(G)
        errs.append(e)
        # sqrt(2n) |Phi(z0 + h u) - Phi(z0)|_inf / h over pi, Ad(g), rho(g): the boxes' midpoints
        # err by their radii (<= 1e-10 here), i.e. <= 1e-4 of the estimate's unit floor of 1
        d = max(
            float(np.max(np.abs(o[k][0] - m[k][0])))
            for k in ("pi", "Ad_g", "rho_g", "rho_g_imag")
            if o[k] is not None
        )
        sens.append(max(1.0, math.sqrt(2 * n) * d / h))
    return states, Gs, errs, sens, out[0]["judge"]


def _judged_state_ratio(impl, f, t, got, want, tol, judge_err, G, group) -> float:
    """The worst error/tolerance of a flow's ``(x(t), pi(t))`` against the judge's state ``want =
    (x or None, pi, Ad)`` and ``G = rho(g(t))`` on ``group``. A failure is raised here with what
    it means: a state right up to ``Ad(g)`` but wrong on the group is a flow on another group (the
    SU(2) sheet lost: ``x = log_SO(3)``), which must declare it."""
    gx, gp = got
    ratio = compare_state(impl, f, gx, gp, *want, tol, judge_err, ref_G=G, rep=group)
    if ratio <= 1.0:
        return ratio
    note(t=t, ratio=ratio)
    if G is not None and group is not None:
        blind = compare_state(impl, f, gx, gp, None, want[1], want[2], tol, judge_err)
        if blind <= 1.0:
            err = max_err(group.exp(gx), G)
            raise AssertionError(
                f"flow at t = {t:g}: x(t) = {np.asarray(gx).tolist()} is right up to Ad(g) (pi and "
                f"the adjoint group agree) but not on the group it is judged on, {group.name}: "
                f"rho(exp(x)) is off by {err:.3g} (ratio {ratio:.3g}). A flow on another group "
                "with this algebra (e.g. SO(3) for su(2), x = log_SO(3)(R) with |x| <= pi) must "
                "declare it: group = 'SO(3)' (docs/conventions.md, 'Which group')"
            )
    raise AssertionError(
        f"flow at t = {t:g}: (x(t), pi(t)) off the judge by error/tolerance ratio {ratio:.3g}"
    )


def _proven_state(f, theta, ups, inertia, pot, x, pi, t):
    """The proven flow judge: ``(x, pi, x_err, pi_err, judge)`` at ``t`` (either sign) from
    :func:`refimpl.rigorous.judge_flow` (the interval route where ``Upsilon = 0``, the Arb route at
    :data:`PROVEN_PREC_BITS` otherwise or where the intervals refuse; ``judge`` names the one that
    answered), where ``x_err``/``pi_err`` are proven upper bounds of ``|exact - value|`` per part (the
    radius plus half an ulp of the rounded midpoint); or a string, the reason no box is given (no exact
    representation, the logarithm not proven unique, the degenerate set, over
    :data:`PROVEN_MAX_SECONDS`). Cached by value."""
    out = _proven_flows(
        f, theta, ups, inertia, pot, x, pi, (float(t),), want_ad=False,
        arb_seconds=PROVEN_MAX_SECONDS,
    )  # fmt: skip
    if isinstance(out, str):
        return out
    (o,) = out
    if o["x"] is None:
        return o["x_note"].split(" (")[0][:100]
    return o["x"][0], o["pi"][0], _proven_err(o["x"]), _proven_err(o["pi"]), o["judge"]


def _judge_errors(f, x, ex: float, ep: float, group) -> tuple:
    """``compare_state``'s ``judge_err`` ``(x, pi, Ad, rho(g))`` for a judge whose ``x`` and ``pi`` err
    by at most ``ex`` and ``ep``: ``Ad = expm(ad_x)`` and ``rho(exp(x))`` computed from the judge's
    ``x`` move by at most ``||Ad||_2 ||f||_F ||phi1(-ad_x)||_2 sqrt(n) ex`` (the first-order bound of
    :func:`compare_state`, with ``||rho||_F`` for ``||f||_F``), doubled for the second-order term
    (the balls' ``ex`` is below 1e-10 at 64 bits, seen up to 1.4e-12, so the quadratic term is far
    below the linear one). Zeros for an
    exact judge (``ex = ep = 0``: the mpmath reference's error is far below every tolerance)."""
    if not (ex or ep):
        return (0.0, 0.0, 0.0, 0.0)
    n = f.shape[0]
    x = np.asarray(x, dtype=float)
    lin = np.linalg.norm(phi1(-ad(f, x)), 2) * math.sqrt(n) * ex
    ea = 2 * np.linalg.norm(expm(ad(f, x)), 2) * max(np.linalg.norm(f), 1e-300) * lin
    eg = 0.0
    if group is not None:
        eg = 2 * np.linalg.norm(group.exp(x), 2) * float(np.linalg.norm(group.mats)) * lin
    return (ex, ep, float(ea), float(eg))


REFERENCE_DPS = 25
"""Working digits of the mpmath reference flow of ``flow.reference`` (its error, ~1e-20, is far
below any float64 tolerance)."""


def _reference_cache_dir():
    root = os.environ.get("TSTARG_CACHE_DIR") or os.path.join(
        os.path.expanduser("~"), ".cache", "tstarg"
    )
    return Path(root) / "reference-flows"


@functools.lru_cache(maxsize=1)
def _reference_source() -> str:
    """A digest of the reference flow's source: a changed reference never reads stale runs."""

    return hashlib.sha256(Path(_flow_reference.__file__).read_bytes()).hexdigest()[:16]


def _reference_state(f, theta, ups, inertia, pot, x, pi, t):
    """The mpmath reference flow's ``(x(t), pi(t))`` rounded to float64 (None where the reference
    cannot continue: the chart), cached in memory and on disk (``$TSTARG_CACHE_DIR/reference-flows``,
    keyed by the exact bytes of the inputs and the working digits): a re-certification, shrinking
    and ``--replay`` reuse reference runs instead of repeating them."""

    key = ("ref", REFERENCE_DPS, _reference_source()) + _key(
        f, theta, ups, inertia, pot, x, pi, float(t)
    )
    digest = hashlib.sha256(repr(key).encode()).hexdigest()
    path = _reference_cache_dir() / digest[:2] / f"{digest}.json"

    def compute():
        try:
            data = json.loads(path.read_text())
            return None if data is None else (np.array(data["x"]), np.array(data["pi"]))
        except (OSError, ValueError, KeyError, TypeError):
            pass
        try:
            xr, pr = reference_flow(f, theta, ups, inertia, pot, x, pi, float(t), dps=REFERENCE_DPS)
            out = (np.asarray(xr, dtype=float), np.asarray(pr, dtype=float))
        except ValueError:
            out = None
        try:
            write_text(
                path,
                json.dumps(None if out is None else {"x": out[0].tolist(), "pi": out[1].tolist()}),
            )
        except OSError:
            pass  # a read-only cache: computed again next time
        return out

    return _FLOW_CACHE.get(key, compute)


def _catalogue_rep(f) -> bool:
    f = np.asarray(f, dtype=float)
    return any(
        catalogue(nm).rep is not None
        and catalogue(nm).f.shape == f.shape
        and np.array_equal(catalogue(nm).f, f)
        for nm in CATALOGUE_NAMES
    )


def _count(stats, key, message=None):
    stats[key] = stats.get(key, 0) + 1
    if message is not None:
        stats.setdefault("refusal message", message[:200])


def _time_ok(dom, t) -> bool:
    return (dom.max_abs_t is None or abs(t) <= dom.max_abs_t) and (
        t >= 0 or dom.negative_t is not False
    )


def _flow_call(impl, dom, stats, args, t):
    """``impl.flow(*args, t)``. A ValueError is accepted (``None``, counted) for ``t < 0`` from an
    implementation that does not declare negative times, and for a trajectory that leaves the chart
    (:data:`ALLOW_CHART_REFUSAL`); anything else that raises inside the domain fails."""
    try:
        return _call(impl, "flow", *args, t)
    except ValueError as exc:
        if t < 0 and dom.negative_t is None:
            _count(stats, "negative t refused (ValueError)", str(exc))
            return None
        if ALLOW_CHART_REFUSAL:
            try:
                (jx, _, _), _ = _judge_state(*args, t)
            except (ArithmeticError, np.linalg.LinAlgError):
                jx = None
            if jx is None or not _catalogue_rep(args[0]):
                _count(stats, "refused past the chart edge (ValueError)")
                return None
        raise AssertionError(
            f"flow raised ValueError at t = {t:g} inside the declared domain: {exc}"
        ) from None


def _has(impl, method) -> bool:
    return provides(impl, method)  # the protocol spec: a placeholder is not provided
