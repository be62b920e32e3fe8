"""Independent correct float64 routes to the Poisson tensor, written from docs/conventions.md (not from
tstarg's code): the certification must accept every one of them (issue 26, never reject correct
code). Each differs from the others in how it computes the frame ``J = phi1(-ad_x)`` and how it
inverts omega_L:

* :class:`VanLoanInverse`: ``J`` as the top-right block of ``scipy.linalg.expm`` of Van Loan's block
  matrix ``[[-ad_x, 1], [0, 0]]``; ``P = -inv(W_h)`` (LU) with the holonomic omega_L
  ``W_h = [[J^T S J, J^T], [-J, U]]``. This is the client of the issue's false FAIL;
* :class:`SeriesSolve`: ``J`` by its Taylor series summed until the terms vanish; ``P`` by
  ``-solve(W_h, 1)``;
* :class:`SquaringBlocks`: ``J`` by scaling and squaring of the pair ``(E, J)``
  (``E(2h) = E(h)^2``, ``J(2h) = J(h) (E(h) + 1) / 2``) from a short series; ``L = inv(J)`` (LU);
  the blocks of vier9 (``Phi^-1``, ``Psi^-1`` by LU), symmetrised ``(P - P^T) / 2``.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg


def _ad(f, x):
    return np.einsum("a,mab->mb", x, f)


def phi1_van_loan(M):
    n = M.shape[0]
    big = np.zeros((2 * n, 2 * n))
    big[:n, :n] = M
    big[:n, n:] = np.eye(n)
    return scipy.linalg.expm(big)[:n, n:]


def phi1_series(M):
    n = M.shape[0]
    term, total = np.eye(n), np.eye(n)
    for k in range(1, 400):
        term = term @ M / (k + 1)
        total = total + term
        if k > 3 and np.abs(term).max() <= 1e-18 * max(1.0, np.abs(total).max()):
            break
    return total


def phi1_squaring(M):
    n = M.shape[0]
    norm = float(np.abs(M).sum(0).max())
    s = max(0, math.ceil(math.log2(norm / 0.5))) if norm > 0.5 else 0
    J = phi1_series(M / 2**s)
    E = np.eye(n) + (M / 2**s) @ J
    for _ in range(s):
        J = J @ (E + np.eye(n)) / 2
        E = E @ E
    return J


class _Route:
    version = "test"

    def _data(self, f, theta, upsilon, x, pi):
        f, theta, U = (np.asarray(a, dtype=float) for a in (f, theta, upsilon))
        x, pi = np.asarray(x, dtype=float), np.asarray(pi, dtype=float)
        S = np.einsum("m,mab->ab", pi, f) - theta
        return f, theta, U, x, pi, S

    def _W(self, J, S, U):
        return np.block([[J.T @ S @ J, J.T], [-J, U]])


class VanLoanInverse(_Route):
    name = "route: Van Loan expm, inv(W_h)"

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        f, theta, U, x, pi, S = self._data(f, theta, upsilon, x, pi)
        W = self._W(phi1_van_loan(-_ad(f, x)), S, U)
        if np.linalg.cond(W) > 1e15:
            raise ValueError("degenerate point: omega_L is not invertible (Delta = 0)")
        return -np.linalg.inv(W)


class SeriesSolve(_Route):
    name = "route: Taylor series, solve(W_h, 1)"

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        f, theta, U, x, pi, S = self._data(f, theta, upsilon, x, pi)
        W = self._W(phi1_series(-_ad(f, x)), S, U)
        if np.linalg.cond(W) > 1e15:
            raise ValueError("degenerate point: omega_L is not invertible (Delta = 0)")
        return -np.linalg.solve(W, np.eye(W.shape[0]))


class SquaringBlocks(_Route):
    name = "route: scaling and squaring, vier9 blocks, symmetrised"

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        f, theta, U, x, pi, S = self._data(f, theta, upsilon, x, pi)
        n = f.shape[0]
        L = np.linalg.inv(phi1_squaring(-_ad(f, x)))
        Phi, Psi = np.eye(n) + S @ U, np.eye(n) + U @ S
        if np.linalg.cond(Phi) > 1e15:
            raise ValueError("degenerate point: Delta = det Phi = 0")
        Phi_inv, Psi_inv = np.linalg.inv(Phi), np.linalg.inv(Psi)
        P = np.block([[-L @ U @ Phi_inv @ L.T, L @ Psi_inv], [-Phi_inv @ L.T, -S @ Psi_inv]])
        return 0.5 * (P - P.T)


ROUTES = {
    "van_loan_inverse": VanLoanInverse,
    "series_solve": SeriesSolve,
    "squaring_blocks": SquaringBlocks,
}
