"""The su(2) full state's two-run constants (refimpl._flow_compiled.A_LOOSE_FULL), as a script.

    python tests/benchmarks/su2_estimate_constants.py [SEED] [RANDOM_MODELS] [EPS_A,...]

For the heavy top (I = diag(1, 1.3, 0.6), L = (0.2, 0.1, 1)), the Lagrange top (diag(1, 1, 0.5), L = e3)
and the asymmetric top diag(1, 2, 3) at T = 10 and 100 (x0 = (0.1, 0.2, 0), pi0 = (0.3, 0.2, 2),
gamma = -e3), then RANDOM_MODELS random su(2) models (SPD inertia, Theta = -xi.f on every other one,
gravity on two of three, T in 10/30/100; seeded by SEED): the quaternion kernel at B's order
(``_order_b(cf, 1e-13)``) at each local tolerance, its global error against heyoka in long double at
tol 1e-19 (``kappa = error / eps``, steps), and the coverage ``q = err(B) / ((eps_B / eps_A) |A - B|)``
that the proportional estimate's safety factor PROP = 30 must exceed (B at 1e-13), the worst taken
over the pairs the control would use it on (``|A - B| <= PROP_MAX_D``; a saturated ``A`` on a chaotic
trajectory is marked "not used"). Needs heyoka (the bench extra). No timing.
"""

from __future__ import annotations

import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from tstarg.refimpl import _compiled_taylor as CT  # noqa: E402
from tstarg.refimpl import _flow_compiled as FC  # noqa: E402
from tstarg.refimpl._catalogue import catalogue  # noqa: E402
from tstarg.refimpl.flows import cached_model  # noqa: E402
from tstarg.reports import _bench_protocol as bp  # noqa: E402

SU2 = np.array(catalogue("su(2)").f, dtype=float)
Z = np.zeros((3, 3))
EB = 1e-13


def prob(name, I, L, theta=Z, x0=(0.1, 0.2, 0.0), pi0=(0.3, 0.2, 2.0), T=100.0, gamma=(0, 0, -1.0)):
    pot = (
        None
        if L is None
        else {"kind": "gravity", "L": np.array(L, float), "gamma": np.array(gamma, float)}
    )
    return bp.ProtocolProblem(
        name, name, "su(2)", SU2, np.array(theta, float), Z, np.array(I, float), pot,
        np.array(x0, float), np.array(pi0, float), T, [],
    )  # fmt: skip


def problems(seed: int, nrand: int) -> list:
    out = []
    for T in (10.0, 100.0):
        out.append(prob(f"heavy{T:g}", np.diag([1.0, 1.3, 0.6]), [0.2, 0.1, 1.0], T=T))
        out.append(prob(f"lagr{T:g}", np.diag([1.0, 1.0, 0.5]), [0, 0, 1.0], T=T))
        out.append(prob(f"asym{T:g}", np.diag([1.0, 2.0, 3.0]), [0, 0, 1.0], T=T))
    rng = np.random.default_rng(seed)
    for k in range(nrand):
        A = rng.standard_normal((3, 3))
        I = A @ A.T / 3 + np.diag(rng.uniform(0.3, 2, 3))
        xi = 0.5 * rng.standard_normal(3)
        th = -np.einsum("k,kab->ab", xi, SU2) if k % 2 == 0 else Z
        L = rng.standard_normal(3) if k % 3 != 2 else None
        g = rng.standard_normal(3)
        g /= np.linalg.norm(g)
        T = float(rng.choice([10.0, 30.0, 100.0]))
        x0, pi0 = rng.standard_normal(3), 2 * rng.standard_normal(3)
        out.append(prob(f"rand{seed}_{k}", I, L, th, x0, pi0, T, g))
    return out


def main(argv) -> int:
    seed = int(argv[0]) if argv else 0
    nrand = int(argv[1]) if len(argv) > 1 else 6
    epss = [float(e) for e in (argv[2] if len(argv) > 2 else "1e-5,1e-6,1e-8,1e-13").split(",")]
    if EB not in epss:
        epss.append(EB)
    worst = {}
    for p in problems(seed, nrand):
        ta = bp.heyoka_taylor(p, 1e-19, fp="longdouble", compact=True)
        ta.propagate_until(np.longdouble(p.T))
        ref = np.array(ta.state, dtype=np.longdouble)
        m = cached_model(p.f, p.theta, p.upsilon, p.inertia, p.potential)
        cf = m.compiled_full_field
        y0 = np.empty((1, 3 + (3 if m.gravity else 0) + 4))
        g = m.gamma if m.gravity else FC._NO_GAMMA
        FC._start(p.x0[:, None].copy(), p.pi0[:, None].copy(), g, m.gravity, y0)
        P = FC._order_b(cf, EB)
        outs = {}
        line = f"{p.name:10s} T={p.T:g} P={P}"
        for e in epss:
            y, st = CT.taylor_adaptive(cf, y0, p.T, e, P)
            err = bp.protocol_error(p, y[0, :3], FC.quat_rotation(y[:, -4:].T)[0], ref)
            outs[e] = (y, err)
            line += f" | {e:.0e}: kappa={err / e:.2g} steps={st[0]}"
        print(line, flush=True)
        yB, eB = outs[EB]
        qs = []
        for e in epss:
            if e <= EB:
                continue
            d1 = np.empty(1)
            FC._estimate(outs[e][0], yB, 3, d1)
            q = eB / ((EB / e) * d1[0])
            prop = d1[0] <= FC.PROP_MAX_D  # past it the control does not use the proportional form
            qs.append(f"{e:.0e}: q={q:.2g}" + ("" if prop else f" (|A-B|={d1[0]:.2g}: not used)"))
            if prop:
                worst[e] = max(worst.get(e, 0.0), q)
        print("    coverage", " ".join(qs), f"err(B)={eB:.2e}", flush=True)
    print(
        "worst q per eps_A (pairs with |A - B| <= PROP_MAX_D):",
        {f"{k:.0e}": round(float(v), 2) for k, v in worst.items()},
    )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
