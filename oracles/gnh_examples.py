"""Worked examples of the Gotay-Nester-Hinds algorithm (refimpl.gnh) for SU(2), section cinq.

Model: ``f = eps``, ``Theta = -xi.f``, ``Upsilon^mn = t eps_3mn`` (``tau = (0, 0, t)``),
``H = 1/2 pi.I^-1 pi + V``. Primary set ``M_1 = {C1 = 1 - t pi'_3 = 0}`` (vijf6); secondary
``C21 = C22 = 0`` (vijf13); the solution ``X_G = X_P + zeta_1 Z^1 + zeta_2 Z^2`` (vijf15); tangency
(vijf16). Expected outcomes, derived by hand (not by the tool):

* free top (``V = 0``): ``C21 = C22 = 0`` say ``pi' x K = 0`` in its first two components, hence
  (``K_3 != 0``) ``pi' || K = I^-1 pi`` and then ``C23 = (pi' x K)_3 = 0`` too: ``X_P`` is tangent to
  ``M_1``. ``M_2`` is the set of relative equilibria with ``pi'.tau = 1``. For ``xi = 0`` and
  ``I_3 != I_1, I_2`` it is the single momentum ``pi = (0, 0, 1/t)``; tangency to ``M_2`` (a point in
  momentum space) forces ``X_1 = -zeta_2/t = 0`` and ``X_2 = zeta_1/t = 0``: **determined**, steady
  rotation about the ``tau`` axis. The same holds for the symmetric top ``I_1 = I_2 != I_3``.
* asymmetric top, ``xi = (1/3, 1/5, 1/7)``, ``I = diag(1, 2, 3)``, ``t = 2``: ``pi_3 = 5/14``;
  ``C21 = 0`` gives ``pi_2 (5/42 - 1/4) = -1/42``, ``pi_2 = 2/11``; ``C22 = 0`` gives ``pi_1 = 5/48``;
  **determined**, ``zeta = 0``.
* spherical top ``I = a 1``: with ``xi = 0``, ``C21 = C22 = 0`` identically (``pi' = pi || K``):
  ``M_2 = M_1`` and tangency ``X_3 = C23 - zeta_1 pi'_2 + zeta_2 pi'_1 = 0`` is one equation for two
  multipliers: **gauge**, one multiplier free. With ``xi = (1, 0, 0)``, ``a = 2``, ``t = 2``:
  ``C22 = pi'_3 K_1 - pi'_1 K_3 = -1/4``: **inconsistent** (``M_2`` is empty).
* heavy (Lagrange) top ``I = diag(2, 2, 3)``, ``L = (0, 0, 1)``, ``xi = 0``, ``t = 2``:
  ``<dV|e^L_1> = Gamma_2``, ``<dV|e^L_2> = -Gamma_1`` (twee16), so ``C21 = -pi_2/12 - Gamma_2``,
  ``C22 = pi_1/12 + Gamma_1``: ``M_2 = {pi_3 = 1/2, pi_1 = -12 Gamma_1, pi_2 = -12 Gamma_2}``;
  tangency then fixes both multipliers: **determined**.
* heavy asymmetric top ``I = diag(1, 2, 3)``, ``L = (1, 0, 0)``, ``xi = 0``, ``t = 2`` :
  ``<dV|e^L_1> = 0``, ``<dV|e^L_2> = Gamma_3``, so ``C21 = -pi_2/12``, ``C22 = pi_1/3 - Gamma_3``:
  ``pi_2 = 0``, ``pi_1 = 3 Gamma_3``. By hand, with vijf15 (``X^1 = zeta_1 + K_1``,
  ``X^2 = zeta_2 + K_2``, ``X_1 = -zeta_2/t``, ``X_2 = zeta_1/t``) and dGamma/dt = Gamma x Omega
  (twee17 corrected): tangency to C21 gives ``zeta_1 = 0``; ``X_3 = 0`` gives ``Gamma_2 + zeta_2 pi_1 = 0``;
  tangency to C22 gives ``zeta_2 (1/6 + Gamma_1) = Gamma_2 pi_1``. Together: the tertiary constraint
  ``Gamma_2 (6 Gamma_1 + 54 Gamma_3^2 + 1) = 0``. Branch ``Gamma_2 = 0``: tangency of ``Gamma_2``,
  ``dGamma_2/dt = Gamma_3 pi_1 - Gamma_1/6 = 0``, adds ``Gamma_1 = 18 Gamma_3^2``; **determined**.
  Branch ``Gamma_1 = -1/6 - 9 Gamma_3^2``: ends in ``9 Gamma_3^2/2 + 1/36 = 0``, no real point:
  **inconsistent**.

Expected manifolds are numbers or functions of the symbols by name (``lambda s: -12 * s["Gamma1"]``):
no string is ever parsed as an expression.
"""

from __future__ import annotations

import sympy as sp

from tstarg.refimpl import exact_sympy
from tstarg.refimpl.gnh import gnh, lie_poisson_model, verify_result

__all__ = ["EXAMPLES", "check_example", "paper_zetas", "run_example", "su2_model"]

R = sp.Rational


def _eps():
    return [[[int(sp.LeviCivita(m, a, b)) for b in range(3)] for a in range(3)] for m in range(3)]


def _numbers(values, name: str, length: int) -> list:
    """``length`` caller numbers as sympy expressions (:func:`refimpl._validate.exact_sympy`:
    strings are parsed as decimal or rational literals, never evaluated)."""
    if isinstance(values, (str, bytes)) or len(values) != length:
        raise ValueError(f"{name} must be a sequence of {length} numbers, got {values!r:.60}")
    return [exact_sympy(v, f"{name}[{k}]") for k, v in enumerate(values)]


def su2_model(xi, t, inertia_diag, potential=None):
    """The section-cinq model with ``tau = (0, 0, t)`` (sympy rationals or symbols; ints,
    ``Fraction``, floats and decimal or rational strings are converted exactly, never evaluated)."""
    e = _eps()
    xs = _numbers(xi, "xi", 3)
    ts = exact_sympy(t, "t")
    Is = _numbers(inertia_diag, "inertia_diag", 3)
    th = [[-sum(xs[k] * e[k][a][b] for k in range(3)) for b in range(3)] for a in range(3)]
    up = [[ts * e[2][m][n] for n in range(3)] for m in range(3)]
    return lie_poisson_model(e, th, up, sp.diag(*Is), potential=potential)


EXAMPLES = {
    "free_asymmetric_xi0": {
        "xi": (0, 0, 0),
        "t": 2,
        "I": (1, 2, 3),
        "V": None,
        "outcome": "determined",
        "manifold": {"pi1": 0, "pi2": 0, "pi3": R(1, 2)},
    },
    "free_asymmetric_xi": {
        "xi": (R(1, 3), R(1, 5), R(1, 7)),
        "t": 2,
        "I": (1, 2, 3),
        "V": None,
        "outcome": "determined",
        "manifold": {"pi1": R(5, 48), "pi2": R(2, 11), "pi3": R(5, 14)},
    },
    "free_symmetric_xi0": {
        "xi": (0, 0, 0),
        "t": 2,
        "I": (2, 2, 3),
        "V": None,
        "outcome": "determined",
        "manifold": {"pi1": 0, "pi2": 0, "pi3": R(1, 2)},
    },
    "free_spherical_xi0": {
        "xi": (0, 0, 0),
        "t": 2,
        "I": (2, 2, 2),
        "V": None,
        "outcome": "gauge",
        "manifold": {"pi3": R(1, 2)},
    },
    "free_spherical_xi": {
        "xi": (1, 0, 0),
        "t": 2,
        "I": (2, 2, 2),
        "V": None,
        "outcome": "inconsistent",
    },
    "heavy_lagrange": {
        "xi": (0, 0, 0),
        "t": 2,
        "I": (2, 2, 3),
        "V": {"kind": "gravity", "L": (0, 0, 1), "gamma": (0, 0, 1)},
        "outcome": "determined",
        "manifold": {
            "pi3": R(1, 2),
            "pi1": lambda s: -12 * s["Gamma1"],
            "pi2": lambda s: -12 * s["Gamma2"],
        },
    },
    "heavy_asymmetric": {
        "xi": (0, 0, 0),
        "t": 2,
        "I": (1, 2, 3),
        "V": {"kind": "gravity", "L": (1, 0, 0), "gamma": (0, 0, 1)},
        "outcome": "determined",
        "manifold": {
            "pi3": R(1, 2),
            "pi2": 0,
            "pi1": lambda s: 3 * s["Gamma3"],
            "Gamma2": 0,
            "Gamma1": lambda s: 18 * s["Gamma3"] ** 2,
        },
    },
}


def run_example(name: str):
    ex = EXAMPLES[name]
    model = su2_model(ex["xi"], ex["t"], ex["I"], ex["V"])
    return model, gnh(model)


def paper_zetas(model, result, ex) -> tuple:
    """Express a determined ``X`` in the paper's basis (vijf15): ``zeta_a = X^a - K^a`` (a = 1, 2), and
    return ``(zeta, residual)`` with ``residual = X - X_G(zeta)`` (must vanish)."""
    subs = result.substitution
    pi = model.names["pi"]
    Iinv = model.names["Iinv"]
    t = exact_sympy(ex["t"], "t")
    xi = _numbers(ex["xi"], "xi", 3)
    K = (Iinv * pi).subs(subs)
    dH = model.frame_derivative(model.hamiltonian).subs(subs)
    Vg = dH[:3, 0]
    pp = [sp.simplify(pi[k].subs(subs) + xi[k]) for k in range(3)]
    X = result.vector_field
    z1, z2 = sp.simplify(X[0] - K[0]), sp.simplify(X[1] - K[1])
    C23 = pp[0] * K[1] - pp[1] * K[0] - Vg[2]
    XG = (
        z1 * sp.Matrix([1, 0, 0, 0, 1 / t, -pp[1]])
        + z2 * sp.Matrix([0, 1, 0, -1 / t, 0, pp[0]])
        + sp.Matrix([K[0], K[1], K[2], 0, 0, C23])
    )
    return (z1, z2), (X - XG).applyfunc(sp.simplify)


def check_example(name: str):
    """``(ok, results, detail)``: the tool's outcome equals the hand-derived one, its vector field
    solves ``X^T W = dH`` and is tangent (refimpl.gnh.verify_result), the paper's C1, C21, C22 vanish
    on the final manifold, and a determined ``X`` has the form vijf15."""
    ex = EXAMPLES[name]
    model, results = run_example(name)
    outcomes = sorted({r.outcome for r in results})
    consistent = sorted({r.outcome for r in results if r.outcome != "inconsistent"}) or [
        "inconsistent"
    ]
    if consistent != [ex["outcome"]]:
        return False, results, f"outcomes {outcomes}, expected {ex['outcome']}"
    results = [r for r in results if r.outcome == ex["outcome"]]
    pi = model.names["pi"]
    G = model.names["Gamma"]
    for r in results:
        if r.vector_field is not None:
            v = verify_result(model, r)
            if not all(v.values()):
                return False, results, f"verify_result {v}"
            t = exact_sympy(ex["t"], "t")
            xi = _numbers(ex["xi"], "xi", 3)
            K = model.names["Iinv"] * pi
            dV = model.frame_derivative(model.hamiltonian)[:3, 0]
            pp = [pi[k] + xi[k] for k in range(3)]
            C1 = 1 - t * pp[2]
            C21 = pp[1] * K[2] - pp[2] * K[1] - dV[0]
            C22 = pp[2] * K[0] - pp[0] * K[2] - dV[1]
            for c in (C1, C21, C22):
                if sp.simplify(c.subs(r.substitution)) != 0:
                    return (
                        False,
                        results,
                        f"paper constraint {c} does not vanish on {r.substitution}",
                    )
            if r.outcome == "determined":
                _z, res = paper_zetas(model, r, ex)
                if any(v != 0 for v in res):
                    return False, results, f"X is not of the vijf15 form: residual {list(res)}"
        if "manifold" in ex:
            names = {str(s): s for s in list(pi) + (list(G) if G is not None else [])}
            for k, v in ex["manifold"].items():
                val = names[k].subs(r.substitution)
                want = v(names) if callable(v) else exact_sympy(v, f"manifold[{k!r}]")
                if sp.simplify(val - want) != 0:
                    return False, results, f"{k} = {val} on the final manifold, expected {v}"
    return True, results, "; ".join(f"{r.outcome}: {r.substitution}" for r in results)
