"""The Python face for notebooks: build a model once with the paper's names, ask for its brackets
and vector field, integrate a trajectory and plot it.

A :class:`~tstarg.refimpl.Model` is built from a catalogue name (``Model.from_catalogue``) or, for
su(2), straight from the paper's constants (``Model.su2(xi=..., tau=...)``: ``Theta = -xi.f``,
``Upsilon^mn = tau_l eps_lmn``). The functions below take it where the protocol takes its five
model arrays:

>>> import numpy as np
>>> from tstarg.refimpl import Model, bracket, trajectory
>>> m = Model.su2(xi=[0.1, -0.2, 0.3], tau=[0.05, 0.1, -0.05], inertia=[1, 2, 3])
>>> P = bracket(m, x=[0.1, 0.0, 0.0], pi=[0.3, 0.2, 1.0])
>>> P.shape, bool(np.allclose(P, -P.T))
((6, 6), True)
>>> tr = trajectory(m, x0=[0.1, 0, 0], pi0=[0.3, 0.2, 1.0], t_end=2.0, samples=11)
>>> tr.pi.shape, tr.plan.method
((11, 1, 3), 'taylor-rational')

``tr.plot()`` draws the momenta and the drift of the conserved quantities (a matplotlib figure);
``protocol_args(m)`` gives the five arrays for any implementation's methods,
``impl.poisson_tensor(*protocol_args(m), x, pi)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._catalogue import CATALOGUE_NAMES, catalogue
from .fast import implementation as _fast
from .model import Model
from .scenes import Plan, parse_scene, plan, plot_trajectory, run_scene

__all__ = ["Trajectory", "bracket", "protocol_args", "trajectory", "vector_field"]


def protocol_args(model: Model) -> tuple:
    """``(f, theta, upsilon, inertia, potential)``: the model as the protocol's methods take it."""
    if not isinstance(model, Model):
        raise TypeError(f"model must be a tstarg.refimpl.Model, got {type(model).__name__}")
    pot = None
    if model.potential is not None:
        pot = {"kind": "gravity", "L": model.Lvec.copy(), "gamma": model.gamma.copy()}
    return model.f.copy(), model.theta.copy(), model.upsilon.copy(), model.inertia.copy(), pot


def bracket(model: Model, x, pi, implementation=None) -> np.ndarray:
    """The Poisson tensor ``P[i, j] = {z_i, z_j}``, ``z = (x, pi)`` (vier9), at one point or a
    batch, by ``implementation`` (default: tstarg's fast one; the reference,
    ``tstarg.refimpl.reference.implementation``, for 50 digits)."""
    impl = _fast if implementation is None else implementation
    f, theta, upsilon, _, _ = protocol_args(model)
    return impl.poisson_tensor(f, theta, upsilon, np.asarray(x, float), np.asarray(pi, float))


def vector_field(model: Model, x, pi, implementation=None):
    """``(xdot, pidot)`` of ``H = 1/2 pi.I^-1 pi + V`` (the protocol's second method)."""
    impl = _fast if implementation is None else implementation
    return impl.hamiltonian_vector_field(
        *protocol_args(model), np.asarray(x, float), np.asarray(pi, float)
    )


@dataclass
class Trajectory:
    """A sampled run of a model: ``times`` ``(T,)``, ``pi`` ``(T, N, n)``, ``x`` (or None for a
    body system), ``outputs`` (everything the run gave: ``energy``, ``Gamma``, Casimirs, ...),
    the ``plan`` (system, method, why) and the ``path`` that ran (compiled kernels or numpy)."""

    model: Model
    times: np.ndarray
    pi: np.ndarray
    x: np.ndarray | None
    plan: Plan
    path: str
    outputs: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        T, N, n = self.pi.shape
        drift = ""
        if "energy" in self.outputs:
            e = np.asarray(self.outputs["energy"])
            drift = f", energy drift {float(np.nanmax(np.abs(e - e[0]))):.2g}"
        return (
            f"Trajectory({T} samples in [0, {float(self.times[-1]):g}], {N} trajector"
            f"{'y' if N == 1 else 'ies'}, n={n}, method {self.plan.method} on {self.path.split()[0]}{drift})"
        )

    def plot(self, title: str | None = None):
        """The momenta of trajectory 0 and the drift of every conserved quantity (log scale): a
        matplotlib figure (a notebook shows it; ``fig.savefig(...)`` writes it)."""
        return plot_trajectory(
            {"times": self.times, "pi": self.pi, **self.outputs}, title or repr(self.model)
        )


def trajectory(
    model: Model,
    x0,
    pi0,
    t_end: float,
    *,
    samples: int = 101,
    tol: float = 1e-9,
    outputs=("pi", "x", "energy"),
    method: str | None = None,
) -> Trajectory:
    """Integrate ``model`` from ``(x0, pi0)`` (one state ``(n,)`` or several ``(N, n)``) over
    ``[0, t_end]`` at ``samples`` equally spaced times, each within ``tol``: the planner of
    ``tstarg run`` chooses the system and the method (``method`` forces one), as for a scene."""
    if not isinstance(model, Model):
        raise TypeError(f"model must be a tstarg.refimpl.Model, got {type(model).__name__}")
    spec: dict = {"name": repr(model)}
    alg = model.algebra
    if (
        alg is not None
        and alg.name in CATALOGUE_NAMES
        and np.array_equal(catalogue(alg.name).f, model.f)
    ):
        spec["algebra"] = alg.name
    else:
        spec["f"] = model.f.tolist()
    spec.update(
        theta=model.theta.tolist(),
        upsilon=model.upsilon.tolist(),
        inertia=model.inertia.tolist(),
        x0=np.asarray(x0, float).tolist(),
        pi0=np.asarray(pi0, float).tolist(),
        t_end=float(t_end),
        samples=int(samples),
        tol=float(tol),
        outputs=list(outputs),
    )
    if model.potential is not None:
        spec["potential"] = {"L": model.Lvec.tolist(), "gamma": model.gamma.tolist()}
    if method is not None:
        spec["method"] = method
    scene = parse_scene(spec)
    the_plan = plan(scene)
    out = run_scene(scene, the_plan)
    path = out.pop("path")
    times, pi, x = out.pop("times"), out.pop("pi"), out.pop("x", None)
    return Trajectory(model, times, pi, x, the_plan, path, out)
