"""Deliberately broken implementations: each one a plausible mistake (mutation testing).

Used by the meta-tests (tests/meta/) and by :func:`reports.certification.kill_rate`, which
``tstarg verify`` reports: the fraction of mutants the certification battery rejects. This module
imports nothing of the certification (the kill rate sits above both). Each check names the mutants
planted against it (``Check.mutants``, :data:`reports.certification.MUTANT_CHECKS`); mutants that
need more than a switch of this shared implementation are defined beside their check.

:class:`Plain` is a straightforward per-point numpy implementation of the protocol,
written from docs/conventions.md independently of refimpl.fast; with ``mutation=None`` it is
correct, and each name in :data:`MUTATIONS` switches on exactly one mistake.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import scipy.linalg

MUTATIONS = {
    "f_sign": "the sign of the structure constants flipped (f -> -f)",
    "theta_sign": "Theta added with the wrong sign in S (S = pi.f + Theta)",
    "upsilon_sign": "the sign of Upsilon flipped",
    "phi_psi_swapped": "Phi and Psi swapped (Phi^-1 where Psi^-1 belongs and vice versa)",
    "psi_not_transposed": "Psi computed as 1 + S U (= Phi) instead of 1 + U S",
    "frame_inverted": "the frame L(g,e) replaced by its inverse phi1(-ad_x)",
    "frame_identity": "the frame L(g,e) replaced by the identity",
    "frame_half_missing": "a missing factor 1/2: L = 1 + ad_x + ... instead of 1 + ad_x/2 + ...",
    "theta_in_pp_block": "Theta added to {pi, pi} after the solve instead of inside S",
    "kinetic_factor": "a missing factor 1/2 in K: dK/dpi = 2 I^-1 pi",
    "gravity_frame": "the gravity force in the wrong frame: Gamma = Ad(g) gamma instead of Ad(g)^T gamma",
    "so3_only": "su(2) closed forms used for every 3-dimensional algebra (right only for so(3)-like ones)",
    "near_degenerate_1e6": "a result 1e-6 off (relative) only where cond(Phi) > 1e6",
    "xx_sign": "{x, x} block with the wrong sign",
    "pidot_s_sign": "pidot = Phi^-1 (-dV + S dK): wrong sign of the S term",
    "xdot_no_frame": "xdot = Omega: the frame L(g,e) forgotten in the vector field",
    "batch_first_point": "a batched call reuses the first point's Phi for every point",
    "degenerate_garbage": "points on the degenerate set return finite numbers (pinv) instead of an error",
    "flow_wrong_stage": "a flow whose RK4 uses a wrong weight in one stage",
    "pp_block_psi_left": "{pi, pi} block as -Psi^-1 S instead of -S Psi^-1 (= -Phi^-1 S): not antisymmetric",
    "mutates_input": "x negated in place as scratch space and never restored (the caller's array changes)",
    "stale_cache": "S and the frame cached by id(f): a caller that refills its f array gets stale results",
    "lists_rejected": "inputs assumed to be arrays (x.shape on a list raises AttributeError)",
    "float32_output": "results returned as float32",
    "batch_flattened": "a batch of any rank returned flattened to one leading axis",
    "flow_abs_time": "the flow integrates to |t| (negative times run forward)",
    "flow_fixed_steps": "a flow with 40 RK4 steps whatever t (fine for short times, wrong for long ones)",
    "order_overclaimed": "declares order 4 but integrates with Kutta's third-order method",
    "energy_dissipation": "a flow that damps pi by (1 - 1e-6 |t|) (energy drifts linearly, 100 times its declared flow_tolerance per unit time)",
    "not_a_poisson_map": "declares poisson_integrator = True but takes plain RK4 steps (not a Poisson map)",
    "domain_ignored": "declares an su(2)-only domain but returns numbers for every algebra",
    "centre_lost": "a flow that re-bases through Ad(g) for |t| >= 1 and so drops the central part "
    "of x (Ad(g) and pi stay right; g is wrong along the centre)",
    "batch_tail_stale": "a batch of more than 8 points returns the next-to-last point's result in the last place",
    "small_dims_only": "past dimension 6 the frame L(g,e) is truncated to 1 + ad_x/2 (a fixed-size series buffer)",
    "layout_assumed": "f read from its memory buffer as if C-ordered (a Fortran-ordered f is scrambled)",
}


# Independent of refimpl/_phi.py on purpose: Plain is written from the conventions alone (module docstring).
def _phi1(M):
    n = M.shape[0]
    big = np.zeros((2 * n, 2 * n))
    big[:n, :n] = M
    big[:n, n:] = np.eye(n)
    return scipy.linalg.expm(big)[:n, n:]


def _eps3():
    e = np.zeros((3, 3, 3))
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        e[a, b, c], e[a, c, b] = 1.0, -1.0
    return e


class Plain:
    """A per-point numpy implementation (correct unless ``mutation`` is set)."""

    precision_digits = 15.0

    def __init__(self, mutation: str | None = None):
        if mutation is not None and mutation not in MUTATIONS:
            raise ValueError(f"unknown mutation {mutation!r}")
        self.mutation = mutation
        self.name = f"plain[{mutation or 'correct'}]"
        self.version = "test"
        self.batched = (
            mutation in ("batch_first_point", "batch_flattened", "batch_tail_stale")
            or mutation is None
        )
        self._cache: dict = {}
        if mutation == "not_a_poisson_map":
            self.poisson_integrator = True
        if mutation == "domain_ignored":
            self.domain = {"algebras": ["su(2)"]}

    # -------------------------------------------------------------- pieces
    def _frame(self, f, x):
        ad = np.einsum("a,mab->mb", x, f)
        m = self.mutation
        if m == "so3_only" and f.shape[0] == 3:
            ad = np.einsum("a,mab->mb", x, _eps3())
        A = _phi1(-ad)
        if m == "frame_inverted":
            return A
        if m == "frame_identity":
            return np.eye(len(x))
        if m == "small_dims_only" and len(x) > 6:
            return np.eye(len(x)) + 0.5 * ad
        L = np.linalg.inv(A)
        if m == "frame_half_missing":
            L = L + 0.5 * ad
        return L

    def _S(self, f, theta, pi):
        if self.mutation == "so3_only" and f.shape[0] == 3:
            f = _eps3()
        S = np.einsum("m,mab->ab", pi, f)
        return S + theta if self.mutation == "theta_sign" else S - theta

    def _prep(self, f, theta, upsilon):
        if self.mutation == "stale_cache":
            f = self._cache.setdefault(("f", id(f)), np.array(f, dtype=float))
        if self.mutation == "layout_assumed":  # the raw buffer, read back as C order
            a = np.asarray(f, dtype=float)
            f = np.frombuffer(a.tobytes(order="A")).reshape(a.shape)
        f = np.asarray(f, dtype=float)
        if self.mutation == "f_sign":
            f = -f
        theta = np.asarray(theta, dtype=float)
        U = np.asarray(upsilon, dtype=float)
        if self.mutation == "upsilon_sign":
            U = -U
        if self.mutation == "theta_in_pp_block":
            return f, np.zeros_like(theta), U, theta
        return f, theta, U, None

    def _inverses(self, S, U):
        n = S.shape[0]
        Phi = np.eye(n) + S @ U
        Psi = Phi.copy() if self.mutation == "psi_not_transposed" else np.eye(n) + U @ S
        if abs(np.linalg.det(Phi)) < 1e-300 or np.linalg.cond(Phi) > 1e15:
            if self.mutation == "degenerate_garbage":
                return np.linalg.pinv(Phi), np.linalg.pinv(Psi), Phi
            raise ValueError("degenerate point: Delta = det Phi = 0")
        Phi_inv, Psi_inv = np.linalg.inv(Phi), np.linalg.inv(Psi)
        if self.mutation == "phi_psi_swapped":
            Phi_inv, Psi_inv = Psi_inv, Phi_inv
        return Phi_inv, Psi_inv, Phi

    # ------------------------------------------------------------ protocol
    def _tensor(self, f, theta, upsilon, x, pi, Phi_override=None):
        f, theta, U, theta_pp = self._prep(f, theta, upsilon)
        n = f.shape[0]
        L = self._frame(f, np.asarray(x, dtype=float))
        S = self._S(f, theta, np.asarray(pi, dtype=float))
        Phi_inv, Psi_inv, Phi = self._inverses(S, U) if Phi_override is None else Phi_override
        P = np.empty((2 * n, 2 * n))
        P[:n, :n] = -L @ U @ Phi_inv @ L.T
        if self.mutation == "xx_sign":
            P[:n, :n] *= -1
        P[:n, n:] = L @ Psi_inv
        P[n:, :n] = -Phi_inv @ L.T
        P[n:, n:] = -Psi_inv @ S if self.mutation == "pp_block_psi_left" else -S @ Psi_inv
        if theta_pp is not None:
            P[n:, n:] += theta_pp
        if self.mutation == "near_degenerate_1e6" and np.linalg.cond(Phi) > 1e6:
            P *= 1 + 1e-6
        return P

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        if self.mutation == "lists_rejected" and x.shape is None:  # AttributeError for a list
            raise AssertionError
        if self.mutation == "mutates_input" and isinstance(x, np.ndarray) and x.dtype == float:
            x *= (
                -1
            )  # scratch space, "restored" by the negated use below (the caller's x stays negated)
            x = -x
        x, pi = np.asarray(x, dtype=float), np.asarray(pi, dtype=float)
        if x.ndim == 1:
            out = self._tensor(f, theta, upsilon, x, pi)
            return out.astype(np.float32) if self.mutation == "float32_output" else out
        if not self.batched:
            raise ValueError("not batched")
        X, Pm = x.reshape(-1, x.shape[-1]), pi.reshape(-1, pi.shape[-1])
        first = None
        out = []
        for k in range(len(X)):
            if self.mutation == "batch_first_point":
                if first is None:
                    ff, th, U, _ = self._prep(f, theta, upsilon)
                    first = self._inverses(self._S(ff, th, Pm[0]), U)
                out.append(self._tensor(f, theta, upsilon, X[k], Pm[k], Phi_override=first))
            else:
                out.append(self._tensor(f, theta, upsilon, X[k], Pm[k]))
        n = X.shape[1]
        if self.mutation == "batch_tail_stale" and len(out) > 8:
            out[-1] = out[-2]
        if self.mutation == "batch_flattened":
            return np.array(out).reshape(-1, 2 * n, 2 * n)
        return np.array(out).reshape(x.shape[:-1] + (2 * n, 2 * n))

    def hamiltonian_vector_field(self, f, theta, upsilon, inertia, potential, x, pi):
        f, theta, U, theta_pp = self._prep(f, theta, upsilon)
        x, pi = np.asarray(x, dtype=float), np.asarray(pi, dtype=float)
        if x.ndim > 1:
            if not self.batched:
                raise ValueError("not batched")
            res = [
                self.hamiltonian_vector_field(f, theta, upsilon, inertia, potential, a, b)
                for a, b in zip(x.reshape(-1, x.shape[-1]), pi.reshape(-1, pi.shape[-1]))
            ]
            return tuple(np.array([r[k] for r in res]).reshape(x.shape) for k in (0, 1))
        n = f.shape[0]
        dK = np.linalg.solve(np.asarray(inertia, dtype=float), pi)
        if self.mutation == "kinetic_factor":
            dK = 2 * dK
        dV = np.zeros(n)
        if potential is not None:
            Ad = scipy.linalg.expm(np.einsum("a,mab->mb", x, f))
            gamma = np.asarray(potential["gamma"], dtype=float)
            Gamma = Ad @ gamma if self.mutation == "gravity_frame" else Ad.T @ gamma
            dV = -np.einsum("m,mbc,c->b", Gamma, f, np.asarray(potential["L"], dtype=float))
        L = self._frame(f, x)
        S = self._S(f, theta, pi)
        Phi_inv, Psi_inv, _ = self._inverses(S, U)
        Omega = Psi_inv @ (dK - U @ dV)
        pidot = (
            Phi_inv @ (-dV + S @ dK)
            if self.mutation == "pidot_s_sign"
            else Phi_inv @ (-dV - S @ dK)
        )
        if theta_pp is not None:
            pidot = pidot + theta_pp @ dK
        xdot = Omega if self.mutation == "xdot_no_frame" else L @ Omega
        return xdot, pidot

    order = 4

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t, steps=None):
        """Classical RK4 with 400 steps per unit of ``t * rate`` (``rate``: the fastest frequency at the
        start), or ``steps``."""
        x0, pi0 = np.asarray(x0, dtype=float), np.asarray(pi0, dtype=float)
        if x0.ndim > 1:
            if not self.batched:
                raise ValueError("not batched")
            res = [
                self.flow(f, theta, upsilon, inertia, potential, a, b, t, steps)
                for a, b in zip(x0.reshape(-1, x0.shape[-1]), pi0.reshape(-1, pi0.shape[-1]))
            ]
            return tuple(np.array([r[k] for r in res]).reshape(x0.shape) for k in (0, 1))
        z = np.concatenate([x0, pi0])
        n = len(z) // 2
        m = self.mutation
        if m == "flow_abs_time":
            t = abs(t)
        per_unit = 2000 if m == "order_overclaimed" else 400
        if steps is None:
            # h * rate <= 1/per_unit, rate ~ the fastest frequency at the start (inertia, momenta, forces)
            Iinv = np.linalg.norm(np.linalg.inv(np.asarray(inertia, dtype=float)), 2)
            fn = np.linalg.norm(np.asarray(f, dtype=float))
            rate = Iinv * (
                np.linalg.norm(pi0) * fn + np.linalg.norm(np.asarray(theta, dtype=float))
            )
            if potential is not None:
                rate += np.sqrt(
                    fn * np.linalg.norm(potential["L"]) * np.linalg.norm(potential["gamma"]) * Iinv
                )
            steps = (
                40
                if m == "flow_fixed_steps"
                else max(1, int(np.ceil(per_unit * abs(t) * max(1.0, rate))))
            )
        h = t / steps

        def F(zz):
            a, b = self.hamiltonian_vector_field(
                f, theta, upsilon, inertia, potential, zz[:n], zz[n:]
            )
            return np.concatenate([a, b])

        w2 = 1.0 / 3 if self.mutation != "flow_wrong_stage" else 0.3
        for _ in range(steps):
            k1 = F(z)
            if m == "order_overclaimed":  # Kutta's third-order method
                k2 = F(z + 0.5 * h * k1)
                k3 = F(z + h * (2 * k2 - k1))
                z = z + h * (k1 + 4 * k2 + k3) / 6
                continue
            k2 = F(z + 0.5 * h * k1)
            k3 = F(z + 0.5 * h * k2)
            k4 = F(z + h * k3)
            z = z + h * (k1 / 6 + w2 * k2 + k3 / 3 + k4 / 6)
        if m == "energy_dissipation":
            z[n:] *= 1 - 1e-6 * abs(t)
        if m == "centre_lost":
            ff = np.asarray(f, dtype=float)
            if abs(t) >= 1:
                Zc = scipy.linalg.null_space(ff.transpose(0, 2, 1).reshape(n * n, n))
                z[:n] -= Zc @ (Zc.T @ z[:n])  # Ad(exp(x)) is unchanged: only the centre moves
        return z[:n], z[n:]

    flow_tolerance = 1e-8


CORRECT = Plain(None)
"""The correct :class:`Plain`, importable as ``tstarg.reports.mutants:CORRECT`` (certify targets)."""

MUTANT = SimpleNamespace(**{name: Plain(name) for name in MUTATIONS})
"""Every mutant as a certify target: ``tstarg certify tstarg.reports.mutants:MUTANT.xx_sign``."""
