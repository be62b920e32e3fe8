"""The Gotay-Nester-Hinds constraint algorithm for ``omega_L`` on its degenerate set (vijf6 -- vijf16).

Setting (paper section quatre, vier12 -- vier14, and section cinq). In the frame
``theta = (eps_L^a, dpi_m)`` the two-form is ``omega_L = 1/2 theta^T ^ W theta`` with
``W = [[S, 1], [-1, Upsilon]]``, ``S_ab = pi_m f^m_ab - Theta_ab`` (vier3). A vector
``X`` (frame components ``(X^a, X_m)``) solves ``i_X omega_L = dH`` iff ``X^T W = dH^T``
(vier4). Where ``Delta = det(1 + S Upsilon)`` vanishes (vier7, vier12), ``W`` is singular
and the Gotay-Nester-Hinds algorithm [GNH 1978] finds the submanifold on which a
solution tangent to it exists:

1. **Primary constraints** ``M_1``: the irreducible factors of the numerator of
   ``Delta`` (for SU(2), ``Delta = C1^2`` with ``C1 = 1 - pi'.tau``, vijf6).
2. **Consistency**: on the current manifold ``M_k``, ``X^T W = dH^T`` is solvable iff
   ``<dH|Z> = 0`` for every null vector ``Z`` of ``W`` (``Z^T W = 0``, vijf12). Those that
   do not vanish on ``M_k`` are new constraints (secondary: ``C21, C22``, vijf13).
3. **General solution** on ``M_k``: ``X = X_P + sum_i zeta_i Z^i`` (vijf14, vijf15).
4. **Tangency**: ``<dC|X> = 0`` for every constraint ``C`` found so far (vijf16); these are
   linear in the multipliers ``zeta``. Writing them ``M zeta = -r``, each left null
   vector ``y`` of ``M`` gives a new constraint ``y.r = 0`` (tertiary, ...); go back to 2.
   Otherwise the multipliers are determined (``rank M = #zeta``) or partly free (gauge).
5. A constraint free of state variables is a condition on the parameters: a nonzero
   number means the set is **inconsistent** (empty); an expression in the parameters
   means "inconsistent unless that expression vanishes".

Functions of the configuration enter through body variables on which the left-invariant
frame acts linearly: for gravity (twee15, twee16) ``Gamma = Ad(g)^T gamma`` with
``e^L_a Gamma = ad(e_a)^T Gamma``, i.e. ``e^L_a(Gamma_b) = Gamma_m f^m_ab``. A model
without potential uses no configuration variables.

Everything is sympy: ``f``, ``Theta``, ``Upsilon``, the inertia and the potential may be
rational numbers or symbols. Generic-rank reasoning is used (a symbolic pivot is taken
as nonzero); each stage records what was assumed in its report.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from numbers import Integral, Real

import numpy as np
import sympy as sp

from ._validate import parse_number

__all__ = ["GNHResult", "PresymplecticModel", "Stage", "gnh", "lie_poisson_model", "verify_result"]


@dataclass
class PresymplecticModel:
    """A presymplectic system in a frame.

    Rules:
    1. ``state``: the coordinates functions depend on (e.g. ``Gamma_1..n, pi_1..n``);
    2. ``W``: ``(N, N)`` sympy matrix of ``omega`` in the frame, antisymmetric, entries in ``state``;
    3. ``frame_derivative(F)``: the ``N`` frame components ``<dF|e_i>`` of a function ``F`` of ``state``;
    4. ``hamiltonian``: ``H`` as an expression in ``state``;
    5. ``primary``: primary constraints (expressions vanishing on ``M_1``);
    6. ``solve_order``: the state variables the algorithm may eliminate, in order of preference.
    """

    state: list
    W: sp.Matrix
    frame_derivative: Callable[[sp.Expr], sp.Matrix]
    hamiltonian: sp.Expr
    primary: list
    solve_order: list
    names: dict = field(default_factory=dict)

    def __post_init__(self):
        W = _matrix(self.W, "W")
        self.hamiltonian = _expr(self.hamiltonian)
        self.primary = [_expr(c) for c in self.primary]
        if W.shape[0] != W.shape[1]:
            raise ValueError(f"W must be square, got shape {W.shape}")
        if any(sp.simplify(v) != 0 for v in (W + W.T)):
            raise ValueError("W must be antisymmetric (W + W^T != 0)")
        unknown = set(self.solve_order) - set(self.state)
        if unknown:
            raise ValueError(
                f"solve_order names variables that are not state variables: {sorted(map(str, unknown))}"
            )
        self.W = W


@dataclass
class Stage:
    """One pass of steps 2-4: the constraints known on entry, what was found, and why."""

    index: int
    constraints: list
    substitution: dict
    kernel: list
    new_constraints: list
    multipliers: dict | None = None
    tangency: list | None = None
    note: str = ""


@dataclass
class GNHResult:
    """Outcome: ``"determined"`` (multipliers fixed), ``"gauge"`` (some stay free),
    ``"inconsistent"`` (empty final set) or ``"conditional"`` (consistent only if
    ``conditions`` on the parameters hold)."""

    outcome: str
    stages: list
    constraints: list
    substitution: dict
    vector_field: sp.Matrix | None
    multipliers: dict
    free_multipliers: list
    conditions: list

    def render(self) -> str:
        lines = [f"outcome: {self.outcome}"]
        for st in self.stages:
            lines.append(
                f"stage {st.index}: {len(st.constraints)} constraint(s), kernel dim {len(st.kernel)}"
            )
            for c in st.new_constraints:
                lines.append(f"  new constraint: {sp.sstr(c)} = 0")
            if st.multipliers:
                for k, v in st.multipliers.items():
                    lines.append(f"  {k} = {sp.sstr(v)}")
            if st.note:
                lines.append(f"  {st.note}")
        if self.conditions:
            lines.append(
                "conditions on the parameters: "
                + ", ".join(f"{sp.sstr(c)} = 0" for c in self.conditions)
            )
        if self.free_multipliers:
            lines.append("free multipliers: " + ", ".join(map(str, self.free_multipliers)))
        if self.substitution:
            lines.append(
                "final manifold: "
                + ", ".join(f"{k} = {sp.sstr(v)}" for k, v in self.substitution.items())
            )
        return "\n".join(lines)


def _clean(expr) -> sp.Expr:
    expr = sp.together(sp.expand(_expr(expr)))  # _expr: strings parsed, never evaluated
    num, _den = sp.fraction(expr)
    try:
        return sp.factor(sp.expand(num))
    except sp.PolynomialError:  # radicals of the state variables (from a quadratic branch)
        return sp.expand(num)


def _primitive(z: sp.Matrix) -> sp.Matrix:
    """A null vector with denominators cleared and common factors removed, so that it neither
    blows up nor vanishes on a subvariety by the accident of sympy's pivot choice."""
    z = z.applyfunc(lambda v: sp.together(sp.simplify(v)))
    dens = [sp.fraction(v)[1] for v in z]
    z = (z * sp.lcm_list(dens)).applyfunc(lambda v: sp.expand(sp.cancel(v)))
    nonzero = [v for v in z if v != 0]
    g = sp.gcd_list(nonzero) if nonzero else 1
    return z.applyfunc(lambda v: sp.factor(sp.cancel(v / g)))


def _expr(v) -> sp.Expr:
    """A caller's value as a sympy expression without evaluating strings (``sympify`` runs Python code).

    sympy objects pass; ints, ``Fraction`` and float numbers become exact numbers (floats via
    ``nsimplify`` of the float itself); strings are parsed as decimal or rational literals by
    :class:`fractions.Fraction` only; anything else is refused by name.
    """
    if isinstance(v, sp.Basic):
        return v
    if isinstance(v, bool) or type(v).__name__ == "bool_":
        raise TypeError(f"booleans are not numbers here, got {v!r}")
    if isinstance(v, Integral):
        return sp.Integer(int(v))
    if isinstance(v, Fraction):
        return sp.Rational(v.numerator, v.denominator)
    if isinstance(v, str):
        q = parse_number(v)  # the one parser (refimpl._validate): never evaluated
        return sp.Rational(q.numerator, q.denominator)
    if isinstance(v, Real):
        fv = float(v)
        if not math.isfinite(fv):
            raise ValueError(f"non-finite number {v!r}")
        return (
            sp.nsimplify(sp.Float(fv, 17), rational=True) if fv != int(fv) else sp.Integer(int(fv))
        )
    raise TypeError(f"cannot use {type(v).__name__} {v!r:.60} as a sympy expression")


def _matrix(value, name: str) -> sp.Matrix:
    """A caller's matrix, entry by entry through :func:`_expr`."""
    if isinstance(value, sp.MatrixBase):
        return sp.Matrix(value)
    rows = [list(r) for r in value]
    try:
        return sp.Matrix([[_expr(e) for e in r] for r in rows])
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: {exc}") from None


def _on(expr, subs: dict) -> sp.Expr:
    return sp.simplify(sp.together(_expr(expr).subs(subs)))


def _eliminate(constraint, subs: dict, model: PresymplecticModel):
    """Solve ``constraint`` (already restricted) on each of its irreducible components: returns
    the list of substitutions, one per branch (a factor that comes from the choice of null
    vectors only gives a redundant branch, analysed afresh, never a wrong one). An empty list
    means no real point satisfies it; ``None`` that sympy could not solve it."""
    c = _clean(constraint)
    try:
        _, factors = sp.factor_list(c)
    except sp.PolynomialError:
        factors = [(c, 1)]
    out = []
    for fac, _m in factors:
        present = [v for v in model.solve_order if v not in subs and fac.has(v)]
        if not present:
            continue
        linear = []
        for v in present:
            try:
                if sp.degree(fac, v) == 1:
                    linear.append(v)
            except sp.PolynomialError:
                pass
        v = (linear + [v for v in present if v not in linear])[0]
        try:
            sols = sp.solve(fac, v, dict=False)
        except NotImplementedError:
            return None
        # real state variables: no real root means this component is empty
        for s in sols:
            new = {k: sp.simplify(val.subs(v, s)) for k, val in subs.items()}
            new[v] = sp.simplify(s)
            out.append(new)
    return out


def _split(constraints: Sequence, subs: dict, model: PresymplecticModel):
    """Restrict constraints to the manifold; separate zero ones, parameter conditions and state ones."""
    state = set(model.state)
    real, conditions = [], []
    for c in constraints:
        r = _clean(_on(c, subs))
        if r == 0:
            continue
        if not (r.free_symbols & state):
            conditions.append(r)
        else:
            real.append((c, r))
    return real, conditions


def gnh(model: PresymplecticModel, *, max_stages: int = 8) -> list[GNHResult]:
    """Run the algorithm; one :class:`GNHResult` per branch of the constraint set (usually one)."""
    results: list[GNHResult] = []
    _run(model, list(model.primary), {}, [], 1, max_stages, results, [])
    unique, seen = [], set()
    for r in results:
        key = (
            r.outcome,
            tuple(sorted((str(k), sp.srepr(sp.simplify(v))) for k, v in r.substitution.items())),
            tuple(map(str, r.conditions)),
        )
        if key not in seen:
            seen.add(key)
            unique.append(r)
    # drop a consistent branch lying inside another whose vector field restricts to it
    keep = []
    for i, r in enumerate(unique):
        inside = False
        for j, o in enumerate(unique):
            if (
                i == j
                or r.vector_field is None
                or o.vector_field is None
                or len(o.substitution) >= len(r.substitution)
            ):
                continue
            contained = all(
                sp.simplify((v - e).subs(r.substitution)) == 0 for v, e in o.substitution.items()
            )
            if contained and all(
                sp.simplify(a.subs(r.substitution) - b) == 0
                for a, b in zip(o.vector_field, r.vector_field)
            ):
                inside = True
        if not inside:
            keep.append(r)
    return keep


def verify_result(model: PresymplecticModel, result: GNHResult) -> dict[str, bool]:
    """Independent check of a consistent outcome: on the final manifold the vector field solves
    ``X^T W = dH^T`` (vier4) and is tangent to every constraint (``<dC|X> = 0``, vijf16)."""
    if result.vector_field is None:
        raise ValueError(f"result has no vector field (outcome {result.outcome!r})")
    subs, X = result.substitution, result.vector_field
    W = sp.Matrix(model.W).subs(subs)
    dH = model.frame_derivative(model.hamiltonian).subs(subs)
    solves = all(sp.simplify(v) == 0 for v in ((X.T * W).T - dH))
    graph = [v - e for v, e in subs.items()]
    tangent = all(
        sp.simplify(((model.frame_derivative(c).T * X)[0]).subs(subs)) == 0 for c in graph
    )
    on_manifold = all(sp.simplify(_expr(c).subs(subs)) == 0 for c in result.constraints)
    return {"solves": solves, "tangent": tangent, "on_manifold": on_manifold}


def _add_constraints(model, constraints, subs, new, stages, k, max_stages, results, conditions):
    real, conds = _split(new, subs, model)
    conditions = conditions + conds
    if conds and any(c.is_number for c in conds):
        results.append(
            GNHResult("inconsistent", stages, constraints + new, subs, None, {}, [], conditions)
        )
        return
    if conds:
        results.append(
            GNHResult("conditional", stages, constraints + new, subs, None, {}, [], conditions)
        )
        return
    branches = [subs]
    for orig, restricted in real:
        nxt = []
        for b in branches:
            r = _clean(_on(orig, b))
            if r == 0:
                nxt.append(b)
                continue
            if not (r.free_symbols & set(model.state)):  # this branch contradicts the constraint
                kind = "inconsistent" if r.is_number else "conditional"
                results.append(
                    GNHResult(kind, stages, constraints + new, b, None, {}, [], conditions + [r])
                )
                continue
            el = _eliminate(r, b, model)
            if el is None:
                raise ValueError(
                    f"GNH: cannot solve constraint {r} = 0 for any of {model.solve_order}"
                )
            if not el:
                results.append(
                    GNHResult(
                        "inconsistent",
                        stages,
                        constraints + new,
                        b,
                        None,
                        {},
                        [],
                        conditions + [sp.Eq(r, 0)],
                    )
                )
            nxt.extend(el)
        branches = nxt
    for b in branches:
        _run(
            model,
            constraints + [c for c, _ in real],
            b,
            stages,
            k + 1,
            max_stages,
            results,
            conditions,
        )


def _run(model, constraints, subs, stages, k, max_stages, results, conditions):
    if k > max_stages:
        results.append(GNHResult("unfinished", stages, constraints, subs, None, {}, [], conditions))
        return
    if k == 1 and not subs:  # the primary constraints define M_1
        stage = Stage(
            0, [], {}, [], list(constraints), note="primary constraints (factors of Delta)"
        )
        _add_constraints(model, [], {}, constraints, [stage], 0, max_stages, results, conditions)
        return
    W = sp.Matrix(model.W).subs(subs).applyfunc(sp.simplify)
    dH_full = model.frame_derivative(model.hamiltonian)
    dH = dH_full.subs(subs).applyfunc(sp.simplify)
    kernel = [_primitive(z) for z in W.T.nullspace(simplify=True)]  # Z^T W = 0 <=> W^T Z = 0
    consistency = [sp.simplify((dH_full.T * z)[0]) for z in kernel]
    stage = Stage(k, list(constraints), dict(subs), kernel, [])
    real, conds = _split(consistency, subs, model)
    if real or conds:
        stage.new_constraints = [c for c, _ in real] + conds
        stage.note = "consistency <dH|Z> = 0 on the null vectors of omega"
        _add_constraints(
            model,
            constraints,
            subs,
            consistency,
            stages + [stage],
            k,
            max_stages,
            results,
            conditions,
        )
        return
    # general solution X = X_P + sum zeta_i Z_i of X^T W = dH^T on M_k
    sol, params = W.T.gauss_jordan_solve(dH)
    zetas = sp.symbols(f"zeta1:{len(params) + 1}")
    X = sol.subs(dict(zip(list(params), zetas))).applyfunc(sp.simplify)
    tang_rows, tang_rhs = [], []
    # tangency to M_k, written with the regular (graph) equations v - v(free) of the manifold:
    # products such as pi1*pi2 have a vanishing differential where two components meet
    for c in [v - e for v, e in subs.items()]:
        eq = sp.simplify(((model.frame_derivative(c).T * X)[0]).subs(subs))
        eq = sp.together(sp.expand(eq))
        tang_rows.append([sp.simplify(sp.diff(eq, z)) for z in zetas])
        tang_rhs.append(sp.simplify(eq.subs({z: 0 for z in zetas})))
    stage.tangency = [
        sp.simplify(sum(a * z for a, z in zip(row, zetas)) + r)
        for row, r in zip(tang_rows, tang_rhs)
    ]
    Mz = sp.Matrix(tang_rows) if tang_rows and zetas else sp.zeros(len(tang_rows), len(zetas))
    r = sp.Matrix(tang_rhs) if tang_rhs else sp.zeros(0, 1)
    if len(zetas) and Mz.rows:
        left = Mz.T.nullspace(simplify=True)
    else:
        left = [sp.eye(Mz.rows)[:, i] for i in range(Mz.rows)]
    new = [sp.simplify((y.T * r)[0]) for y in left]
    real, conds = _split(new, subs, model)
    if real or conds:
        stage.new_constraints = [c for c, _ in real] + conds
        stage.note = "tangency <dC|X_G> = 0 leaves conditions free of the multipliers"
        _add_constraints(
            model, constraints, subs, new, stages + [stage], k, max_stages, results, conditions
        )
        return
    if len(zetas) and Mz.rows:
        zsol, zfree = Mz.gauss_jordan_solve(-r)
        rename = {}
        for z, v in zip(zetas, zsol):
            if v in set(zfree):
                rename[v] = z
        zsol = zsol.subs(rename).applyfunc(sp.simplify)
        mult = {z: v for z, v in zip(zetas, zsol) if v != z}
        free = [z for z, v in zip(zetas, zsol) if v == z]
    else:
        mult, free = {}, list(zetas)
    stage.multipliers = mult
    Xf = X.subs(mult).applyfunc(sp.simplify)
    outcome = "gauge" if free else "determined"
    stage.note = "multipliers determined" if not free else f"{len(free)} multiplier(s) stay free"
    results.append(
        GNHResult(outcome, stages + [stage], constraints, subs, Xf, mult, free, conditions)
    )


def lie_poisson_model(
    f,
    theta,
    upsilon,
    inertia,
    *,
    potential: dict | None = None,
    primary: Sequence | None = None,
    prefix: str = "",
) -> PresymplecticModel:
    """The model of the paper: ``W = [[S, 1], [-1, Upsilon]]`` (vier3), ``H = 1/2 pi.I^-1 pi + V``
    (twee10) with optional gravity ``V = -(Gamma|L)`` (twee15) in body variables ``Gamma``.

    ``f``: ``(n, n, n)`` nested sequence or array, ``f[m][a][b] = f^m_ab`` (sympy-convertible);
    ``theta``, ``upsilon``: ``(n, n)`` antisymmetric; ``inertia``: ``(n, n)`` symmetric
    invertible; ``potential``: ``{"kind": "gravity", "L": (n,), "gamma": (n,)}`` or ``None``.
    ``primary`` defaults to the distinct irreducible factors of the numerator of ``Delta``
    that involve the momenta (vier12).
    """

    F = np.array(f, dtype=object)
    if F.ndim != 3 or F.shape[0] != F.shape[1] or F.shape[1] != F.shape[2]:
        raise ValueError(f"f must have shape (n, n, n), got {F.shape}")
    n = F.shape[0]
    try:
        Fs = [[[_expr(F[m, a, b]) for b in range(n)] for a in range(n)] for m in range(n)]
    except (TypeError, ValueError) as exc:
        raise ValueError(f"f: {exc}") from None
    Th = _matrix(theta, "theta")
    Up = _matrix(upsilon, "upsilon")
    I = _matrix(inertia, "inertia")
    for name, M in (("theta", Th), ("upsilon", Up)):
        if M.shape != (n, n):
            raise ValueError(f"{name} must have shape ({n}, {n}), got {M.shape}")
        if any(sp.simplify(v) != 0 for v in (M + M.T)):
            raise ValueError(f"{name} must be antisymmetric")
    if I.shape != (n, n) or any(sp.simplify(v) != 0 for v in (I - I.T)):
        raise ValueError(f"inertia must be a symmetric ({n}, {n}) matrix")
    if sp.simplify(I.det()) == 0:
        raise ValueError("inertia must be invertible (det I = 0)")
    pi = sp.Matrix(sp.symbols(f"{prefix}pi1:{n + 1}", real=True))
    S = sp.Matrix(n, n, lambda a, b: sum(pi[m] * Fs[m][a][b] for m in range(n))) - Th
    W = sp.BlockMatrix([[S, sp.eye(n)], [-sp.eye(n), Up]]).as_explicit()
    Iinv = I.inv()
    H = sp.Rational(1, 2) * (pi.T * Iinv * pi)[0]
    state = list(pi)
    Gam = None
    if potential is not None:
        if not isinstance(potential, dict):
            raise ValueError(
                f"potential must be None or a dict with kind 'gravity', L and gamma, got {potential!r:.60}"
            )
        if potential.get("kind") != "gravity":
            raise ValueError(f"potential['kind'] must be 'gravity', got {potential.get('kind')!r}")
        L = _matrix([[v] for v in potential["L"]], "potential['L']")
        if L.shape != (n, 1):
            raise ValueError(f"potential['L'] must have length {n}")
        Gam = sp.Matrix(sp.symbols(f"{prefix}Gamma1:{n + 1}", real=True))
        H = H - (Gam.T * L)[0]
        state = list(Gam) + state

    def frame_derivative(expr) -> sp.Matrix:
        expr = _expr(expr)
        conf = []
        for a in range(n):
            d = 0
            if Gam is not None:
                d = sum(
                    Gam[m] * Fs[m][a][b] * sp.diff(expr, Gam[b]) for m in range(n) for b in range(n)
                )
            conf.append(d)
        return sp.Matrix(conf + [sp.diff(expr, p) for p in pi])

    if primary is None:
        Phi = sp.eye(n) + S * Up
        num, _ = sp.fraction(sp.together(Phi.det()))
        _, factors = sp.factor_list(sp.expand(num))
        primary = [fac for fac, _mult in factors if fac.free_symbols & set(pi)]
        if not primary:
            raise ValueError("Delta does not vanish anywhere in momentum space: no degenerate set")
    return PresymplecticModel(
        state=state,
        W=W,
        frame_derivative=frame_derivative,
        hamiltonian=H,
        primary=list(primary),
        solve_order=list(pi) + ([] if Gam is None else list(Gam)),
        names={"pi": pi, "Gamma": Gam, "S": S, "Upsilon": Up, "Iinv": Iinv},
    )
