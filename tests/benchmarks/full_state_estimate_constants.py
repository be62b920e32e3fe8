"""The full state's first pair (refimpl._full_state: A's order and tolerance) against the reference.

    python tests/benchmarks/full_state_estimate_constants.py [SEED] [PER_ALGEBRA] [A_ORDERS] [TIMES]

For random models on h(3), Bianchi III (with a cocycle Theta), V, VI0, se(2), sl(2, R), se(3), so(4)
and su(3) (SPD inertia with eigenvalues in [0.5, 3], ``x0 = 0.3 N(0, 1)``, ``pi0 = N(0, 1)``;
PER_ALGEBRA models each, seeded by SEED) at the times TIMES (default 1,3,10,30; 1,3,10 for n > 3):
the first pair of one trajectory as the protocol call runs it (:func:`refimpl._full_state._pair_of`:
``A`` at :data:`A_LOOSE`, ``B`` at :data:`EPS_B_FIRST`), with ``A`` at each order of A_ORDERS
(default: the current one and B's), and the answer's error against heyoka in long double at tol
1e-19 (``err(B)`` over ``pi`` and ``Ad(exp x)``, the bench's, with ``expm`` at 40 digits:
:func:`exact_error`). Printed per order: the fraction of starts whose first pair passes ``tol =
1e-10`` (the others go on through the control) and, over those (their ``B`` is returned), the worst
coverage ``err(B) / estimate`` (the estimate, with its floor, must bound the error: below 1). A_ORDERS
``flow``: the whole answers instead (:func:`flow`). Needs heyoka (the bench extra). No timing.
"""

from __future__ import annotations

import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import mpmath  # noqa: E402
import numpy as np  # noqa: E402

from tstarg.refimpl import _flow_compiled as FC  # noqa: E402
from tstarg.refimpl import _full_state as FS  # noqa: E402
from tstarg.refimpl import _full_state_kernel as fk  # noqa: E402
from tstarg.refimpl._catalogue import bianchi, catalogue  # noqa: E402
from tstarg.refimpl._cohomology import cocycle_basis  # noqa: E402
from tstarg.refimpl.flows import cached_model  # noqa: E402
from tstarg.refimpl.flows._common import _AbelianPart  # noqa: E402
from tstarg.reports import _bench_protocol as bp  # noqa: E402

ALGEBRAS = ["h(3)", "Bianchi III", "Bianchi V", "Bianchi VI0", "se(2)", "sl(2,R)", "se(3)", "so(4)"]
ALGEBRAS += ["su(3)"]
TOL = 1e-10  # the protocol's tolerance


def _spd(rng, n):
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    return Q @ np.diag(rng.uniform(0.5, 3.0, n)) @ Q.T


def problems(seed: int, per: int, times: list[float]) -> list:
    rng = np.random.default_rng(seed)
    out = []
    for name in ALGEBRAS:
        alg = bianchi(name.split()[1]) if name.startswith("Bianchi") else catalogue(name)
        f = np.asarray(alg.f, dtype=float)
        n = f.shape[0]
        theta = np.zeros((n, n))
        if name == "Bianchi III":
            basis = cocycle_basis(alg, exact=False)
            theta = np.asarray(sum(c * b for c, b in zip([0.5, -0.3, 0.2], basis)), float)
        for k in range(per):
            inertia = _spd(rng, n)
            x0, pi0 = 0.3 * rng.standard_normal(n), rng.standard_normal(n)
            for T in times if n == 3 else [t for t in times if t <= 10]:
                label = f"{name} #{k} T={T:g} (seed {seed})"  # heyoka_taylor caches by name
                out.append(
                    bp.ProtocolProblem(
                        label,
                        label,
                        name,
                        f,
                        theta,
                        np.zeros((n, n)),
                        inertia,
                        None,
                        x0,
                        pi0,
                        T,
                        [],
                    )
                )
    return out


def first_pair(p, order_a: int):
    """``(estimate, err(B), proportional part, |A - B|, steps of A, steps of B)`` of ``p``'s first pair
    with ``A`` at ``order_a`` (B at its order), through :func:`refimpl._full_state._pair_of`."""
    model = cached_model(p.f, p.theta, p.upsilon, p.inertia, p.potential)
    fs = FS.full_state(model, _AbelianPart)
    keep = FS._FIRST_ORDERS
    FS._FIRST_ORDERS = (order_a, keep[1])
    fs.__dict__.pop("_pair", None)
    try:
        s = FS._scratch(fs)
        X, P = p.x0[:, None].copy(), p.pi0[:, None].copy()
        fk.start(X, P, *fs.start_consts, s[0])
        e, _ = FS._pair_of(fs)(s[0], float(p.T), s)
    finally:
        FS._FIRST_ORDERS = keep
        fs.__dict__.pop("_pair", None)
    d = float(s[7][0])
    prop = FC.first_estimate(d, FS.A_LOOSE, FS.EPS_B_FIRST, FS.PROP_MIN_B, FC.PROP_MAX_D)
    return e, s[9][0].copy(), s[2][0, : p.n].copy(), prop, d, int(s[3][0]), int(s[4][0])


def R_of(p, x) -> np.ndarray:
    """``Ad(exp x) = expm(ad_x)`` of the float64 ``x``, evaluated at 40 digits (a float64 ``expm`` at
    ``|x| ~ 10^2`` errs by more than the flow)."""
    with mpmath.workdps(40):
        adx = mpmath.matrix(np.einsum("a,mab->mb", np.asarray(x, float), p.f).tolist())
        return np.array(mpmath.expm(adx).tolist(), dtype=float)


def exact_error(p, x, pi, ref) -> float:
    """``max(|pi - pi_ref|, |Ad(exp x) - R_ref|)`` with :func:`R_of`."""
    return bp.protocol_error(p, pi, R_of(p, x), ref)


def flow(probs) -> int:
    """``A_ORDERS = flow``: the answers of :func:`refimpl._full_state.full_state_flow` (the first pair
    and, where it fails, the control's retries) at ``tol = 1e-10``: per answer ``err(B) / estimate``
    and the rounding floor's factor that just covers the error, ``ROUND_AMPLIFIED + (err(B) -
    estimate) / (eps kappa)`` (``kappa`` of the answer's last floor); the worst of each."""
    last = {}
    one = FS._floor_one

    def floor_one(steps, n, size, kappa, resid):  # one trajectory's floor: record its kappa
        last["kappa"] = kappa
        return one(steps, n, size, kappa, resid)

    FS._floor_one = floor_one
    worst_q, worst_r, returned = (0.0, ""), (-np.inf, ""), 0
    for i, p in enumerate(probs):
        ref_ta = bp.heyoka_taylor(p, 1e-19, fp="longdouble", compact=True)
        ref_ta.propagate_until(np.longdouble(p.T))
        ref = np.array(ref_ta.state, dtype=np.longdouble)
        model = cached_model(p.f, p.theta, p.upsilon, p.inertia, p.potential)
        last.clear()
        try:
            out = FS.full_state_flow(
                model, p.x0[:, None].copy(), p.pi0[:, None].copy(), p.T, TOL, abelian=_AbelianPart
            )
        except ValueError as exc:  # refused: no answer to cover
            print(f"[{i + 1}/{len(probs)}] {p.name}: refused ({str(exc)[:60]})", flush=True)
            continue
        returned += 1
        e = float(out["error_estimate"][0])
        err = exact_error(p, out["x"][:, 0], out["pi"][:, 0], ref)
        k = last.get("kappa", 0.0)
        r = FS.ROUND_AMPLIFIED + (err - e) / (FS._EPS * k) if k > 0 else -np.inf
        worst_q = max(worst_q, (err / e, p.name))
        worst_r = max(worst_r, (r, p.name))
        print(
            f"[{i + 1}/{len(probs)}] {p.name}: err {err:.2e} estimate {e:.2e} err/estimate "
            f"{err / e:.3f} kappa {k:.2e} factor needed {r:.1f}",
            flush=True,
        )
    FS._floor_one = one
    print(f"{returned} answers: worst err/estimate {worst_q[0]:.3f} ({worst_q[1]}), worst factor "
          f"needed {worst_r[0]:.2f} ({worst_r[1]}), ROUND_AMPLIFIED = {FS.ROUND_AMPLIFIED:g}")  # fmt: skip
    return 0


def main(argv: list[str]) -> int:
    seed = int(argv[1]) if len(argv) > 1 else 25
    per = int(argv[2]) if len(argv) > 2 else 2
    if len(argv) > 3 and argv[3] == "flow":
        times = [float(v) for v in argv[4].split(",")] if len(argv) > 4 else [1.0, 3.0, 10.0, 30.0]
        return flow(problems(seed, per, times))
    orders = (
        [int(v) for v in argv[3].split(",")]
        if len(argv) > 3
        else [FS._FIRST_ORDERS[0], FS._FIRST_ORDERS[1]]
    )
    times = [float(v) for v in argv[4].split(",")] if len(argv) > 4 else [1.0, 3.0, 10.0, 30.0]
    probs = problems(seed, per, times)
    worst = {o: [0.0, 0, 0, -np.inf] for o in orders}  # err/estimate, passes, cases, excess
    for i, p in enumerate(probs):
        ref_ta = bp.heyoka_taylor(p, 1e-19, fp="longdouble", compact=True)
        ref_ta.propagate_until(np.longdouble(p.T))
        ref = np.array(ref_ta.state, dtype=np.longdouble)
        line = [f"[{i + 1}/{len(probs)}] {p.name}:"]
        for o in orders:
            try:
                e, x, pi, prop, d, sa, sb = first_pair(p, o)
            except (
                ValueError
            ) as exc:  # refused (e.g. g(t) outside exp's image on sl(2, R)): no pair
                line.append(f"A P{o}: refused ({str(exc)[:60]})")
                continue
            err = exact_error(p, x, pi, ref)
            w = worst[o]
            if e <= TOL:  # a pair that passes: its B is returned, its estimate must bound its error
                w[0] = max(w[0], err / e)
                size = max(1.0, float(np.max(np.abs(pi))), float(np.max(np.abs(R_of(p, x)))))
                w[3] = max(w[3], (err - e) / (FS._EPS * float(np.max(np.abs(x))) * size))
            w[1] += e <= TOL
            w[2] += 1
            line.append(
                f"A P{o} ({sa} st) |A-B| {d:.1e} est {e:.1e} err(B) {err:.1e} ({sb} st) "
                f"q {err / e:.2f}"
            )
        print(" | ".join(line), flush=True)
    for o, (q, passes, cases, excess) in worst.items():
        print(
            f"A at order {o}: first pair passes tol {TOL:g} on {passes}/{cases}; over those, worst "
            f"err(B)/estimate {q:.3f}, worst (err(B) - estimate) / (eps max|x| max(1, |pi|, |Ad|)) "
            f"{excess:.2f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv))
