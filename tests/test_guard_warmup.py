"""The guard's per-call timeout allows compilation on first use, once per model structure.

A JIT-compiled implementation (numba, JAX, heyoka) is slow on its first call for a structure and
fast afterwards; a hang must still be caught. The target below sleeps for 2x the per-call timeout
on its first call per dimension and returns at once later: accepted. A target that sleeps on its
second call of the same structure is reported as a hang.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from tstarg.reports._guard import WARMUP_FACTOR, Guarded, structure_key

TIMEOUT = 0.2


def _su2():
    f = np.zeros((3, 3, 3))
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        f[c, a, b], f[c, b, a] = 1.0, -1.0
    return f


class _Sleepy:
    name, version = "sleepy", "1"

    def __init__(self, sleep_on_call: int):
        self.calls = 0
        self.sleep_on_call = sleep_on_call

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        from tstarg.refimpl.reference import Reference

        self.calls += 1
        if self.calls == self.sleep_on_call:
            time.sleep(2 * TIMEOUT)
        return np.array(Reference(dps=20).poisson_tensor(f, theta, upsilon, x, pi), dtype=float)


def _call(g):
    z = np.zeros((3, 3))
    return g.poisson_tensor(_su2(), z, z, np.array([0.1, 0.2, 0.3]), np.array([1.0, 0.5, -0.2]))


def test_a_slow_first_call_per_structure_is_compilation_not_a_hang():
    assert 2 * TIMEOUT < WARMUP_FACTOR * TIMEOUT  # the sleep fits the warm-up allowance
    g = Guarded(_Sleepy(sleep_on_call=1), call_timeout=TIMEOUT)
    first, second = _call(g), _call(g)
    assert np.array_equal(first, second)
    assert not [i for i in g.incidents if i["kind"] == "hang"]


@pytest.mark.skipif(
    not hasattr(__import__("signal"), "setitimer"), reason="the guard's timeout needs SIGALRM"
)
def test_a_slow_later_call_of_the_same_structure_is_a_hang():
    g = Guarded(_Sleepy(sleep_on_call=2), call_timeout=TIMEOUT)
    _call(g)
    with pytest.raises(AssertionError, match="per-call timeout of 0.2 s"):
        _call(g)
    assert [i["kind"] for i in g.incidents] == ["hang"]


def test_structure_key_separates_what_compilers_specialise_on():
    f, z = _su2(), np.zeros((3, 3))
    up = np.zeros((3, 3))
    up[0, 1], up[1, 0] = 0.3, -0.3
    x, p = np.zeros(3), np.ones(3)
    base = structure_key("poisson_tensor", (f, z, z, x, p))
    assert base == structure_key("poisson_tensor", (f, z, z, x + 1, 2 * p))  # values: same key
    assert base != structure_key("poisson_tensor", (f, z, up, x, p))  # Upsilon present
    assert base != structure_key("poisson_tensor", (f, z, z, np.zeros((4, 3)), np.ones((4, 3))))
    grav = {"kind": "gravity", "L": p, "gamma": -p}
    assert structure_key("flow", (f, z, z, np.eye(3), None, x, p, 1.0)) != structure_key(
        "flow", (f, z, z, np.eye(3), grav, x, p, 1.0)
    )
