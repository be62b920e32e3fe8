"""An su(2)-only implementation of the tstarg protocol on jaxlie's SO(3) (an example; ``pip install jaxlie``).

It covers part of the model space and declares it (``domain``): su(2) in the catalogue basis
(``f^m_ab = eps_mab``), any cocycle Theta, Upsilon = 0, no potential, flows with ``|t| <= 100``.
Outside that domain every method raises ``ValueError`` naming the violated condition, as the
certification checks. Certify it from a clone of tstarg::

    PYTHONPATH=examples/jaxlie_su2:${PYTHONPATH:-} tstarg certify su2_jaxlie:implementation --max-examples 10

The mathematics (docs/conventions.md of tstarg):

* jaxlie stores an SO(3) element as a unit quaternion ``(w, v)`` and does not fold it to ``w >= 0``:
  it *is* the SU(2) element ``w - i v.sigma = exp(x^a E_a)``, ``E_a = -(i/2) sigma_a``, and
  ``jaxlie.SO3.exp(x)`` is the exponential map of su(2). jaxlie's ``log`` is SO(3)'s (``|x| <= pi``);
  exponential coordinates on SU(2) reach ``|x| < 2 pi``, so :func:`su2_log` inverts ``exp`` there:
  ``x = 2 atan2(|v|, w) v / |v|``;
* the left-invariant frame is the derivative of the coordinates along ``s -> g exp(s e_a)``:
  ``L(g, e)^m_a = d/ds x^m(g exp(s e_a))`` at ``s = 0`` (the paper's twee1, derivative in the
  second argument: the erratum), here by forward-mode automatic differentiation through jaxlie's
  group product;
* with Upsilon = 0, ``Phi = Psi = 1`` and vier9 gives ``P = [[0, L], [-L^T, -S]]``,
  ``S = pi.f - Theta``; the vector field is ``xdot = L Omega``, ``pidot = Omega S`` with
  ``Omega = I^-1 pi`` (vier10, vier11);
* the flow integrates ``pi' = Omega S`` and ``dq/dt = q (0, Omega / 2)`` (the body equation
  ``g^-1 dg/dt = Omega^a E_a`` for the quaternion ``q``) with jax's adaptive Dormand-Prince
  integrator, and returns ``x = su2_log(q)``.
"""

from __future__ import annotations

from typing import ClassVar

import jax
import jax.numpy as jnp
import jaxlie
import numpy as np
from jax.experimental.ode import odeint

# float64 throughout (jax defaults to float32); before any array is made: nothing above makes one
jax.config.update("jax_enable_x64", True)

EPS3 = np.zeros((3, 3, 3))
for _a, _b, _c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
    EPS3[_a, _b, _c], EPS3[_a, _c, _b] = 1.0, -1.0
MAX_ABS_T = 100.0


def su2_log(wxyz):
    """Exponential coordinates of the first kind of the SU(2) element ``(w, v)``: ``|x| < 2 pi``."""
    w, v = wxyz[0], wxyz[1:]
    n2 = v @ v
    tiny = n2 < 1e-30  # then x = 2 v / w up to O(|v|^3); the double where keeps derivatives finite
    n = jnp.sqrt(jnp.where(tiny, 1.0, n2))
    return jnp.where(tiny, 2.0 / w, 2.0 * jnp.arctan2(n, w) / n) * v


def _coords_after(x, s, side):
    g, h = jaxlie.SO3.exp(x), jaxlie.SO3.exp(s)
    return su2_log((g @ h if side == "left" else h @ g).wxyz)


@jax.jit
def _frame_left(x):
    return jax.jacfwd(lambda s: _coords_after(x, s, "left"))(jnp.zeros(3))


@jax.jit
def _frame_right(x):
    return jax.jacfwd(lambda s: _coords_after(x, s, "right"))(jnp.zeros(3))


def _body_rhs(y, t, inertia_inv, S_theta):
    pi, q = y[:3], y[3:]
    omega = inertia_inv @ pi
    S = jnp.einsum("m,mab->ab", pi, EPS3) - S_theta
    pidot = omega @ S
    qdot = (
        jaxlie.SO3(q) @ jaxlie.SO3(jnp.concatenate([jnp.zeros(1), 0.5 * omega]))
    ).wxyz  # q (0, Omega/2)
    return jnp.concatenate([pidot, qdot])


@jax.jit
def _flow(pi0, x0, inertia_inv, theta, t):
    sign = jnp.sign(t)
    y0 = jnp.concatenate([pi0, jaxlie.SO3.exp(x0).wxyz])

    def rhs(y, s, a, b):  # t < 0 runs the field backwards
        return sign * _body_rhs(y, s, a, b)

    ys = odeint(
        rhs,
        y0,
        jnp.array([0.0, jnp.abs(t)]),
        inertia_inv,
        theta,
        rtol=1e-13,
        atol=1e-13,
        mxstep=10**6,
    )
    pi, q = ys[-1, :3], ys[-1, 3:]
    return su2_log(q / jnp.linalg.norm(q)), pi


class SU2Jaxlie:
    """The protocol for su(2) only, on jaxlie (see the module docstring)."""

    name = "su(2) on jaxlie SO3 (example)"
    version = "1.0"
    batched = False
    flow_tolerance = 1e-9
    domain: ClassVar[dict] = {  # what the certification draws from, and checks refusal outside of
        "algebras": ["su(2)"],
        "upsilon": False,
        "gravity": False,
        "max_abs_t": MAX_ABS_T,
        "negative_t": True,
    }
    _frame = staticmethod(_frame_left)

    # ---------------------------------------------------------------- the domain, enforced
    def _inputs(self, f, theta, upsilon, x, pi, potential=None):
        f, theta, upsilon = (np.asarray(a, dtype=float) for a in (f, theta, upsilon))
        x, pi = np.asarray(x, dtype=float), np.asarray(pi, dtype=float)
        if f.shape != (3, 3, 3) or not np.array_equal(f, EPS3):
            raise ValueError(
                f"outside the declared domain: only su(2) with f^m_ab = eps_mab (got f of shape {f.shape})"
            )
        if theta.shape != (3, 3) or upsilon.shape != (3, 3) or x.shape != (3,) or pi.shape != (3,):
            raise ValueError(
                "theta and upsilon must be 3 x 3, x and pi of length 3 (one point: batched = False)"
            )
        if np.any(upsilon != 0):
            raise ValueError("outside the declared domain: Upsilon must be 0")
        if potential is not None:
            raise ValueError(
                f"outside the declared domain: no potential (got {potential.get('kind')!r})"
            )
        if not np.linalg.norm(x) < 2 * np.pi:
            raise ValueError(
                f"x = {x.tolist()} is outside the chart |x| < 2 pi of exponential coordinates"
            )
        return theta, x, pi

    # ---------------------------------------------------------------- the protocol
    def poisson_tensor(self, f, theta, upsilon, x, pi):
        theta, x, pi = self._inputs(f, theta, upsilon, x, pi)
        L = np.asarray(self._frame(jnp.asarray(x)), dtype=float)
        S = np.einsum("m,mab->ab", pi, EPS3) - theta
        return np.block([[np.zeros((3, 3)), L], [-L.T, -S]])

    def hamiltonian_vector_field(self, f, theta, upsilon, inertia, potential, x, pi):
        theta, x, pi = self._inputs(f, theta, upsilon, x, pi, potential)
        omega = np.linalg.solve(np.asarray(inertia, dtype=float), pi)
        L = np.asarray(self._frame(jnp.asarray(x)), dtype=float)
        S = np.einsum("m,mab->ab", pi, EPS3) - theta
        return L @ omega, omega @ S

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):
        theta, x0, pi0 = self._inputs(f, theta, upsilon, x0, pi0, potential)
        t = float(t)
        if not abs(t) <= MAX_ABS_T:
            raise ValueError(
                f"outside the declared domain: |t| = {abs(t):g} > max_abs_t = {MAX_ABS_T:g}"
            )
        if t == 0.0:
            return x0.copy(), pi0.copy()
        inertia_inv = np.linalg.inv(np.asarray(inertia, dtype=float))
        x, pi = _flow(
            jnp.asarray(pi0), jnp.asarray(x0), jnp.asarray(inertia_inv), jnp.asarray(theta), t
        )
        return np.asarray(x, dtype=float), np.asarray(pi, dtype=float)


class BrokenSU2Jaxlie(SU2Jaxlie):
    """A deliberately broken copy: the frame of the *right* translations ``exp(s e_a) g`` (the
    right-invariant frame) where the left-invariant one belongs. The certification rejects it."""

    name = "su(2) on jaxlie SO3 (broken: right-invariant frame)"
    _frame = staticmethod(_frame_right)


implementation = SU2Jaxlie()
broken_implementation = BrokenSU2Jaxlie()
