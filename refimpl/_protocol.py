"""The implementation protocol (docs/design.md), as an abstract class.

An implementation is any object providing a subset of the methods below.
Conventions are those of docs/conventions.md. The obligations:

1. ``poisson_tensor(f, theta, upsilon, x, pi) -> P``: ``f`` of shape
   ``(n, n, n)`` with ``f[m, a, b] = f^m_ab``; ``theta``, ``upsilon``
   antisymmetric ``(n, n)``; ``x`` canonical coordinates of the first kind and
   ``pi`` body momenta, each ``(n,)``. ``P`` is ``(2n, 2n)`` with
   ``P[i, j] = {z_i, z_j}``, ``z = (x, pi)``.
2. ``hamiltonian_vector_field(f, theta, upsilon, inertia, potential, x, pi)
   -> (xdot, pidot)`` for ``H = 1/2 pi.I^-1 pi + V``; ``inertia`` symmetric
   positive definite ``(n, n)``; ``potential`` is ``None`` or
   ``{"kind": "gravity", "L": (n,), "gamma": (n,)}`` (twee15).
3. ``flow(f, theta, upsilon, inertia, potential, x0, pi0, t) -> (x, pi)``:
   the state at time ``t`` starting from ``(x0, pi0)`` at time 0.
4. Arrays are numpy float64. With ``batched = True`` the methods accept
   leading batch axes on ``x`` and ``pi`` and return the same leading axes.
5. At a degenerate point (``Delta = det Phi = 0``, vier7) an implementation
   either returns a flagged result or raises ``ValueError`` (or a subclass).
6. Optional attributes: ``name``, ``version``, ``batched``.
"""

from __future__ import annotations

import abc


class Implementation(abc.ABC):
    """Abstract base for implementations; subclasses override the methods they provide."""

    name: str = "unnamed"
    version: str = "0"
    batched: bool = False

    @abc.abstractmethod
    def poisson_tensor(self, f, theta, upsilon, x, pi):
        """Obligation 1 of the module docstring."""

    @abc.abstractmethod
    def hamiltonian_vector_field(self, f, theta, upsilon, inertia, potential, x, pi):
        """Obligation 2 of the module docstring."""

    @abc.abstractmethod
    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):
        """Obligation 3 of the module docstring."""
