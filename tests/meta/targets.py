"""Implementations for the certify-process tests: a planted wrong one, and broken ones.

``planted`` is ``refimpl.fast`` with the Poisson tensor entry ``P[0, n]`` (the block
``{x_0, pi_0}``) off by 1e-6 relative: a planted failure the reference check must show with
its worst entry. The others misbehave in one way each (issue 15, finding 2 and 5).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from tstarg.refimpl.fast import implementation as _fast


class Planted:
    name = "planted"
    version = "1"

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        P = np.array(_fast.poisson_tensor(f, theta, upsilon, x, pi), dtype=float)
        n = np.shape(f)[0]
        P[..., 0, n] *= 1 + 1e-6
        P[..., n, 0] *= 1 + 1e-6
        return P


class Fixed:
    """``planted`` after its bug was fixed: refimpl.fast's tensor (replay must pass it)."""

    name = "planted, fixed"
    version = "2"

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        return _fast.poisson_tensor(f, theta, upsilon, x, pi)


class Exits:
    def poisson_tensor(self, f, theta, upsilon, x, pi):
        sys.exit(0)


class Garbage:
    def poisson_tensor(self, f, theta, upsilon, x, pi):
        return "abc"


class Nothing:
    def poisson_tensor(self, f, theta, upsilon, x, pi):
        return None


class Mutates:
    def poisson_tensor(self, f, theta, upsilon, x, pi):
        P = _fast.poisson_tensor(f, theta, upsilon, x, pi)
        x *= 2.0
        return P


class Sleeps:
    def poisson_tensor(self, f, theta, upsilon, x, pi):
        time.sleep(3600)


planted = Planted()
fixed = Fixed()
exits = Exits()
garbage = Garbage()
nothing = Nothing()
mutates = Mutates()
sleeps = Sleeps()
not_an_implementation = 42
