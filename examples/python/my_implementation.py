"""A minimal implementation of the tstarg protocol in Python: the template for your own.

Certify it from a clone of tstarg::

    PYTHONPATH=examples/python:${PYTHONPATH:-} tstarg certify my_implementation:implementation --max-examples 10

It provides ``poisson_tensor`` only (the other checks are skipped, with the reason, in the
certificate). The mathematics is that of docs/conventions.md and the paper's vier9:
``L(g, e) = phi1(-ad_x)^-1`` with ``phi1(A) = (e^A - 1)/A`` (Van Loan: the top-right block of
``expm([[A, 1], [0, 0]])``), ``S = pi.f - Theta``, ``Phi = 1 + S Upsilon``, ``Psi = Phi^T``,
``-W^-1 = [[-Upsilon Phi^-1, Psi^-1], [-Phi^-1, -S Psi^-1]]`` and ``P = T (-W^-1) T^T``,
``T = diag(L, 1)``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg


class MyImplementation:
    name = "my implementation"
    version = "0.1"
    batched = False  # x and pi are single points of shape (n,)

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        f, theta, upsilon = (np.asarray(a, dtype=float) for a in (f, theta, upsilon))
        x, pi = np.asarray(x, dtype=float), np.asarray(pi, dtype=float)
        n = f.shape[0]
        ad = np.einsum("a,mab->mb", x, f)  # ad_x[m, b] = x^a f^m_ab
        big = np.zeros((2 * n, 2 * n))
        big[:n, :n], big[:n, n:] = -ad, np.eye(n)
        L = np.linalg.inv(scipy.linalg.expm(big)[:n, n:])  # L(g, e) = phi1(-ad_x)^-1
        S = np.einsum("m,mab->ab", pi, f) - theta
        Phi = np.eye(n) + S @ upsilon
        # the degenerate set Delta = det Phi = 0 (vier7): refuse with ValueError, as the protocol asks
        # (singular to working precision: cond_2(Phi) >= 1 / (2 eps), where no float64 answer means anything)
        sv = np.linalg.svd(Phi, compute_uv=False)
        if not sv[-1] > 2 * np.finfo(float).eps * sv[0]:
            raise ValueError(
                f"degenerate point: Phi = 1 + S Upsilon is singular to working precision (sigma {sv})"
            )
        Phi_inv = np.linalg.inv(Phi)
        Psi_inv = Phi_inv.T
        P = np.block(
            [[L @ (-upsilon @ Phi_inv) @ L.T, L @ Psi_inv], [-Phi_inv @ L.T, -S @ Psi_inv]]
        )
        return 0.5 * (P - P.T)  # the exact P is antisymmetric; this is no farther from it


implementation = MyImplementation()
