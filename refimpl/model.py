"""One model: ``(f, Theta, Upsilon, inertia, potential)`` validated once, and what is derived from it.

:class:`Model` is the single float64 model type of the fast side (the protocol's five model inputs
of docs/design.md, ``H = 1/2 pi.I^-1 pi + V(g)`` under ``omega_L``, twee10/twee15). It is built once at the
protocol boundary by the validation of :mod:`refimpl._validate` (never repeated downstream) and is
immutable: every attribute is fixed at construction. Everything derived from it -- the inverse
inertia, which terms are present, the faithful representation, the quadratic and rational body fields
and their compiled forms, the generated right-hand sides -- is a :func:`functools.cached_property`,
so each cache lives and dies with its model and nothing else writes into the instance.

:class:`State` is one point ``(x, pi)`` at time ``t`` (or a batch: leading axes), the example type
shared by strategies, certification and the runner.

Example::

    >>> import numpy as np
    >>> from tstarg.refimpl import Model, catalogue
    >>> m = Model(catalogue("su(2)"), inertia=np.diag([1.0, 2.0, 3.0]))
    >>> m.n, m.upsilon_zero, m.gravity, m.su2
    (3, True, False, True)
    >>> m
    Model(su(2), n=3, inertia=diag(1, 2, 3), Theta=0, Upsilon=0, potential=None)
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from . import _compiled_rational as _cr
from . import _compiled_taylor as _ct
from ._algebra import LieAlgebra
from ._catalogue import catalogue
from ._fast_kernels import _is_su2, _su2_theta_to_xi
from ._representation import Representation, representation_for
from ._taylor import QuadraticField, quadratic_field, quadratic_field_su2_full
from ._validate import (
    check_inertia,
    check_points,
    check_potential,
    check_structure_constants,
    check_theta,
    check_upsilon,
)
from .codegen import numpy_body_rhs, numpy_body_rhs_inplace

__all__ = ["Model", "State"]


_OMITTED: Any = (
    object()
)  # an argument left out (an explicit None is validated, and refused, as given)


def _numbers(a: np.ndarray) -> str:
    return ", ".join(f"{float(v) + 0.0:.6g}" for v in a)  # + 0.0: no "-0"


class _Su2:
    """``Model.su2(xi=..., tau=..., ...)`` on the class builds an su(2) model with the paper's
    names (:meth:`Model.from_catalogue`); ``model.su2`` on an instance says whether ``f`` is
    su(2)'s ``epsilon`` exactly (the closed forms apply), computed once and cached."""

    def __get__(self, obj, owner=None):
        if obj is None:
            return lambda **kw: owner.from_catalogue("su(2)", **kw)
        value = bool(_is_su2(obj.f))
        obj.__dict__["su2"] = value  # cached like a cached_property (the instance dict wins)
        return value


@dataclass(frozen=True, eq=False, repr=False, init=False)
class Model:
    """A validated model in float64 (frozen; compared by identity).

    ``Model(f, theta=None, upsilon=None, inertia=None, potential=None)``: ``f`` the structure
    constants ``f[m, a, b] = f^m_ab`` (an ``(n, n, n)`` array or a :class:`LieAlgebra`), ``theta`` the
    closed 2-form (``Theta``, 0 when left out), ``upsilon`` the bivector (``Upsilon``, 0 when
    left out), ``inertia`` the symmetric positive definite ``I`` (the identity when left out), ``potential`` ``None``
    or ``{"kind": "gravity", "L": (n,), "gamma": (n,)}`` (twee15). Validation is that of
    :mod:`refimpl._validate` (Jacobi, closedness of Theta, antisymmetry, positivity, shapes): a bad
    input raises ``ValueError`` naming it. The arrays are private copies (the caller's are only
    read); do not write into them.
    """

    f: np.ndarray
    theta: np.ndarray
    upsilon: np.ndarray
    inertia: np.ndarray
    potential: dict | None
    algebra: LieAlgebra | None

    def __init__(self, f, theta=_OMITTED, upsilon=_OMITTED, inertia=_OMITTED, potential=None):
        algebra = f if isinstance(f, LieAlgebra) else None
        fa = np.array(check_structure_constants(f), dtype=float, order="C")
        n = fa.shape[0]
        th = (
            np.zeros((n, n)) if theta is _OMITTED else np.array(check_theta(theta, fa), dtype=float)
        )
        up = (
            np.zeros((n, n))
            if upsilon is _OMITTED
            else np.array(check_upsilon(upsilon, n), dtype=float)
        )
        inertia = np.eye(n) if inertia is _OMITTED else inertia
        pot = check_potential(potential, n)
        if pot is not None:
            pot = {"kind": pot["kind"], "L": np.array(pot["L"]), "gamma": np.array(pot["gamma"])}
        for name, value in (
            ("f", fa),
            ("theta", th),
            ("upsilon", up),
            ("inertia", np.array(check_inertia(inertia, n), dtype=float)),
            ("potential", pot),
            ("algebra", algebra),
        ):
            object.__setattr__(self, name, value)

    def __repr__(self) -> str:
        alg = self.algebra.name if self.algebra is not None else "f"
        I = self.inertia
        if self.I_diagonal:
            inertia = f"diag({_numbers(np.diag(I))})"
        else:
            inertia = "[" + "; ".join(_numbers(row) for row in I) + "]"

        def pairs(a):  # an antisymmetric matrix by its entries above the diagonal
            k = int(np.count_nonzero(np.triu(a, 1)))
            return f"<{k} entr{'y' if k == 1 else 'ies'} above the diagonal>"

        if self.su2:  # the paper's names: Theta = -xi.f, Upsilon^mn = tau_l eps_lmn
            th = "0" if self.theta_zero else pairs(self.theta)
            if not self.theta_zero and self.xi is not None:
                th = f"-xi.f with xi=({_numbers(self.xi)})"
            tau = np.array([self.upsilon[1, 2], self.upsilon[2, 0], self.upsilon[0, 1]])
            up = "0" if self.upsilon_zero else f"tau.eps with tau=({_numbers(tau)})"
        else:
            th = "0" if self.theta_zero else pairs(self.theta)
            up = "0" if self.upsilon_zero else pairs(self.upsilon)
        pot = "None"
        if self.potential is not None:
            assert self.Lvec is not None and self.gamma is not None  # gravity's vectors
            pot = f"gravity(L=({_numbers(self.Lvec)}), gamma=({_numbers(self.gamma)}))"
        return f"Model({alg}, n={self.n}, inertia={inertia}, Theta={th}, Upsilon={up}, potential={pot})"

    # ------------------------------------------------------------------ derived, cached
    @cached_property
    def n(self) -> int:
        """``dim g``."""
        return int(self.f.shape[0])

    @cached_property
    def Iinv(self) -> np.ndarray:
        """``I^-1``, symmetrised."""
        Iinv = np.linalg.inv(self.inertia)
        return 0.5 * (Iinv + Iinv.T)

    @cached_property
    def theta_zero(self) -> bool:
        return not self.theta.any()

    @cached_property
    def upsilon_zero(self) -> bool:
        return not self.upsilon.any()

    @cached_property
    def I_diagonal(self) -> bool:
        return not np.any(self.inertia - np.diag(np.diag(self.inertia)))

    @cached_property
    def gravity(self) -> bool:
        return self.potential is not None

    @cached_property
    def Lvec(self) -> np.ndarray | None:
        """``L`` of the gravity potential (twee15), or None."""
        return None if self.potential is None else self.potential["L"]

    @cached_property
    def gamma(self) -> np.ndarray | None:
        """``gamma`` of the gravity potential (twee15), or None."""
        return None if self.potential is None else self.potential["gamma"]

    su2 = _Su2()
    """On an instance: ``f = epsilon`` exactly (su(2)/so(3) in the catalogue's basis), the closed
    forms apply. On the class: ``Model.su2(xi=..., tau=..., inertia=..., potential=...)``, an su(2)
    model with the paper's names (:meth:`from_catalogue`)."""

    @classmethod
    def from_catalogue(
        cls,
        name: str,
        *,
        theta=None,
        xi=None,
        upsilon=None,
        tau=None,
        inertia=None,
        potential=None,
    ) -> "Model":
        """A model on the catalogue algebra ``name`` (``tstarg.refimpl.CATALOGUE_NAMES``), with the
        paper's names: ``Theta`` as a matrix ``theta`` or through ``xi``, ``Theta_ab = -xi_k
        f^k_ab`` (a coboundary, ``Theta = -xi.f``); ``Upsilon`` as a matrix ``upsilon`` or, on
        su(2), through ``tau``, ``Upsilon^mn = tau_l eps_lmn`` (section cinq); ``inertia`` an
        ``(n, n)`` matrix or its diagonal ``(n,)`` (the identity when left out); ``potential``
        ``None`` or ``{"L": (n,), "gamma": (n,)}`` (gravity, twee15; ``"kind"`` optional).

        >>> Model.su2(xi=[0.1, 0, 0], tau=[0, 0, 0.2], inertia=[1, 2, 3])
        Model(su(2), n=3, inertia=diag(1, 2, 3), Theta=-xi.f with xi=(0.1, 0, 0), Upsilon=tau.eps with tau=(0, 0, 0.2), potential=None)
        """

        alg = catalogue(name)
        n, f = alg.dim, alg.f
        if theta is not None and xi is not None:
            raise ValueError("give theta (a matrix) or xi (Theta = -xi.f), not both")
        if upsilon is not None and tau is not None:
            raise ValueError("give upsilon (a matrix) or tau (su(2): Upsilon = tau.eps), not both")
        if xi is not None:
            xi = np.asarray(xi, dtype=float)
            if xi.shape != (n,):
                raise ValueError(f"xi must have shape ({n},) for {name}, got {xi.shape}")
            theta = -np.einsum("k,kab->ab", xi, f)
        if tau is not None:
            tau = np.asarray(tau, dtype=float)
            if n != 3 or not _is_su2(f) or tau.shape != (3,):
                raise ValueError(
                    f"tau (Upsilon^mn = tau_l eps_lmn) is for su(2) with shape (3,); got {name} "
                    f"and shape {tau.shape}: give upsilon of shape ({n}, {n})"
                )
            eps = np.zeros((3, 3, 3))
            for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
                eps[a, b, c], eps[a, c, b] = 1.0, -1.0
            upsilon = np.einsum("l,lmn->mn", tau, eps)
        if inertia is not None and np.ndim(inertia) == 1:
            inertia = np.diag(np.asarray(inertia, dtype=float))
        if potential is not None and "kind" not in potential:
            potential = {"kind": "gravity", **potential}
        kw = {
            k: v
            for k, v in (("theta", theta), ("upsilon", upsilon), ("inertia", inertia))
            if v is not None
        }
        return cls(alg, potential=potential, **kw)

    @cached_property
    def xi(self) -> np.ndarray | None:
        """su(2): ``Theta_ab = -xi_k eps_kab`` (None for ``Theta = 0``; su(2) only)."""
        return _su2_theta_to_xi(None if self.theta_zero else self.theta)

    @cached_property
    def f_flat(self) -> np.ndarray:
        """``f`` as ``(n, n^2)``: ``S_flat = f_flat^T pi``."""
        return self.f.reshape(self.n, self.n * self.n)

    @cached_property
    def G_L(self) -> np.ndarray | None:
        """``(L x .)``: ``dV = -G_L Gamma`` (twee16), or None without gravity."""
        return None if self.Lvec is None else np.einsum("mbc,c->bm", self.f, self.Lvec)

    @cached_property
    def rate_const(self) -> float:
        """``||I^-1||_2 max(1, max|f|)``: the model's part of the flow-rate budget
        (:func:`refimpl._validate.check_flow_rates`)."""
        inv_norm = 1.0 / float(np.linalg.eigvalsh(0.5 * (self.inertia + self.inertia.T))[0])
        fmax = max(1.0, float(np.max(np.abs(self.f)))) if self.f.size else 1.0
        return inv_norm * fmax

    @cached_property
    def representation(self) -> Representation:
        """The faithful matrix representation the flows use (:mod:`refimpl._representation`); raises
        :class:`refimpl._representation.RepresentationError` naming the condition when none exists."""
        return representation_for(self.algebra if self.algebra is not None else self.f)

    @cached_property
    def quadratic_field(self) -> QuadraticField:
        """The body field as a quadratic polynomial (``Upsilon = 0``; :func:`refimpl._taylor.quadratic_field`)."""
        return quadratic_field(self)

    @cached_property
    def quadratic_field_full(self) -> QuadraticField:
        """The su(2) body field with the quaternion (:func:`refimpl._taylor.quadratic_field_su2_full`)."""
        return quadratic_field_su2_full(self)

    @cached_property
    def compiled_body_field(self) -> _ct.CompiledField:
        """The sparse arrays of :attr:`quadratic_field` (the compiled Taylor kernels' arguments)."""
        return _ct.compiled_field(self.quadratic_field)

    @cached_property
    def compiled_full_field(self) -> _ct.CompiledField:
        """The sparse arrays of :attr:`quadratic_field_full`."""
        return _ct.compiled_field(self.quadratic_field_full)

    @cached_property
    def rational_body_field(self) -> _cr.RationalField:
        """The rational body field (``Upsilon != 0``; :class:`refimpl._compiled_rational.RationalField`)."""
        return _cr.RationalField(self, False)

    @cached_property
    def rational_full_field(self) -> _cr.RationalField:
        """The rational su(2) field with the quaternion."""
        return _cr.RationalField(self, True)

    @cached_property
    def numpy_rhs(self):
        """The generated straight-line body field over numpy rows (``Upsilon = 0``)."""
        return numpy_body_rhs(self.quadratic_field)

    @cached_property
    def numpy_rhs_inplace(self):
        """The same field written into ``out`` with ufunc ``out=`` calls only (``Upsilon = 0``)."""
        return numpy_body_rhs_inplace(self.quadratic_field)

    # ------------------------------------------------------------------ batched body formulas
    def S(self, pi):
        """``S_ab = pi_m f^m_ab - Theta_ab`` for pi of shape (n, N): result (n, n, N)."""
        n = self.n
        S = (self.f_flat.T @ pi).reshape(n, n, -1)
        if not self.theta_zero:
            S = S - self.theta[:, :, None]
        return S

    def omega_pidot(self, pi, Gamma):
        """``Omega`` (vier10) and ``pidot`` (vier11) for pi, Gamma of shape (n, N)."""
        n = self.n
        dK = self.Iinv @ pi
        S = self.S(pi)
        SdK = np.einsum("abN,bN->aN", S, dK)
        dV = None if Gamma is None else -(self.G_L @ Gamma)
        if self.upsilon_zero:
            return dK, (-SdK if dV is None else -dV - SdK)
        U = self.upsilon
        Psi = np.eye(n)[None] + np.einsum("ab,bcN->Nac", U, S)
        rhs_o = dK if dV is None else dK - U @ dV
        rhs_p = -SdK if dV is None else -dV - SdK
        Omega = np.linalg.solve(Psi, rhs_o.T[:, :, None])[:, :, 0].T
        pidot = np.linalg.solve(Psi.transpose(0, 2, 1), rhs_p.T[:, :, None])[:, :, 0].T
        return Omega, pidot

    def gamma_dot(self, Omega, Gamma):
        """``dGamma_mu/dt = Omega^b f^a_{b mu} Gamma_a`` (twee17, sign corrected)."""
        return np.einsum("bN,abm,aN->mN", Omega, self.f, Gamma)

    def delta(self, pi):
        """``Delta = det(1 + S Upsilon)`` per point (vier7)."""
        if self.upsilon_zero:
            return np.ones(pi.shape[1])
        S = self.S(pi)
        return np.linalg.det(np.eye(self.n)[None] + np.einsum("abN,bc->Nac", S, self.upsilon))

    def body_rhs(self):
        """The body system's field ``F(y)``, ``y = pi`` or ``(pi, Gamma)`` of shape (d, N)."""
        n = self.n
        if self.upsilon_zero:
            return self.numpy_rhs  # straight-line polynomial (twee14/drie6, twee17-18)
        if self.gravity:

            def F(y):
                Omega, pidot = self.omega_pidot(y[:n], y[n:])
                return np.concatenate([pidot, self.gamma_dot(Omega, y[n:])])

            return F

        def F_body(y):
            return self.omega_pidot(y, None)[1]

        return F_body


@dataclass(frozen=True)
class State:
    """A point ``(x, pi)`` of ``T*G`` in exponential coordinates at time ``t`` (docs/conventions.md).

    ``x`` and ``pi`` have shape ``(n,)``, or a batch ``(..., n)``; :meth:`checked` validates them
    against a model (finite, real, matching shapes; :func:`refimpl._validate.check_points`).
    """

    x: Any
    pi: Any
    t: float = 0.0

    def checked(self, model: Model, *, batched: bool = True) -> State:
        """The same state with float64 arrays validated against ``model`` (``ValueError`` naming the
        bad input otherwise)."""
        x, pi = check_points(self.x, self.pi, model.n, batched=batched)
        return State(x, pi, float(self.t))
