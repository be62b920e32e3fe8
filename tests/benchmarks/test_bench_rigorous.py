"""Benchmark: the rigorous (Arb) Poisson tensor against the mpmath reference, per point, at equal digits.

Equal digits: the reference at dps 50 (its default, 50 digits promised, 62 working digits) against
``Rigorous(prec_bits=170)`` (51 digits plus 32 guard bits and more for the frame's cancellation),
whose balls are *checked* here to prove at least 50 digits (radius <= 1e-50 * max(1, max|P|)).
Both run the same points of a random model with Theta (a coboundary) and Upsilon, one after the other
for each repeat (interleaved), CPU time (``time.process_time``), best of repeats; BLAS pinned to one
thread (tests/conftest.py). The ratio reference / rigorous is the claim (issue 16's target: >= 30x
for su(2) and su(3)).

Run: ``python -m pytest -p no:cacheprovider tests/benchmarks/test_bench_rigorous.py --benchmark-enable -s``
(with ``--benchmark-disable``, the default, each case runs once as a smoke test).
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from tstarg.refimpl import su2, su3
from tstarg.refimpl.reference import Reference
from tstarg.refimpl.rigorous import Rigorous

RIG = Rigorous(prec_bits=170)
REF = Reference(dps=50)
CASES = {"su2": (su2, 20, 30.0), "su3": (su3, 4, 30.0)}  # (algebra, points, target ratio)


def _points(alg, N, seed=0):
    rng = np.random.default_rng(seed)
    n = alg.f.shape[0]
    xi = 0.3 * rng.normal(size=n)
    theta = -np.einsum("k,kab->ab", xi, alg.f)  # a coboundary: a cocycle (zeven3)
    u = 0.2 * rng.normal(size=(n, n))
    return theta, u - u.T, 0.4 * rng.normal(size=(N, n)), rng.normal(size=(N, n))


def _cpu_best(fns, repeat):
    best = [float("inf")] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            t0 = time.process_time()
            fn()
            best[i] = min(best[i], time.process_time() - t0)
    return best


@pytest.mark.parametrize("case", list(CASES))
def test_bench_rigorous_vs_reference(benchmark, case):
    make, N, target = CASES[case]
    alg = make()
    theta, ups, X, PI = _points(alg, N)

    def rigorous():
        return [RIG.poisson_tensor_balls(alg, theta, ups, x, p) for x, p in zip(X, PI)]

    def reference():
        return [REF.poisson_tensor_mp(alg, theta, ups, x, p) for x, p in zip(X, PI)]

    balls = benchmark(rigorous)
    for B in balls:  # equal digits: the balls prove >= 50 digits
        assert B.max_rad() <= 1e-50 * max(1.0, float(np.max(np.abs(B.mid))))
    if benchmark.disabled:
        return
    reference()  # warm-up (caches of both sides filled: rigorous ran above)
    t_rig, t_ref = _cpu_best([rigorous, reference], repeat=3)
    ratio = t_ref / t_rig
    benchmark.extra_info.update(
        {
            "points": N,
            "ratio_reference_over_rigorous": ratio,
            "rigorous_ms_per_point": 1e3 * t_rig / N,
            "reference_ms_per_point": 1e3 * t_ref / N,
        }
    )
    print(
        f"\n[{case}] per point: rigorous {1e3 * t_rig / N:.3f} ms (170 bits, >= 50 digits proven), "
        f"reference {1e3 * t_ref / N:.2f} ms (dps 50): ratio {ratio:.1f}x (target >= {target:.0f}x; CPU time, "
        f"interleaved, best of 3)"
    )
    assert ratio >= target, (
        f"{case}: rigorous only {ratio:.1f}x faster than the reference (target {target}x)"
    )
