"""refimpl: the system itself -- Lie algebras, cohomology, frames, and the two implementations.

Public API (everything else is private):

Algebras
    :class:`LieAlgebra` (validated structure constants ``f[m, a, b] = f^m_ab``),
    the catalogue (:func:`catalogue`, :data:`CATALOGUE_NAMES`, :func:`su2`,
    :func:`so3_other_basis`, :func:`sl2r`, :func:`abelian`, :func:`heisenberg`,
    :func:`bianchi`, :func:`aff1`, :func:`se2`, :func:`se3`, :func:`so4`,
    :func:`su3`, :func:`sl3r`).
Cohomology (zeven1, zeven3)
    :func:`delta1`, :func:`delta2`, :func:`cocycle_basis`, :func:`coboundary_basis`,
    :func:`cohomology`, :func:`h2_dim`, :func:`check_cocycle`, :func:`solve_coboundary`.
Helpers shared with the other packages
    :func:`jacobi_residual`, :func:`exact_sympy` and :func:`parse_number` (exact inputs),
    :func:`representation_for` (a faithful representation, or :class:`RepresentationError`),
    :func:`quadratic_field` (the body system ``pi' = F(pi)`` as a quadratic form when
    ``Upsilon = 0``), :data:`COMPILED_PATH` and :func:`compile_count` (the compiled kernels'
    path, ``"numba"`` or ``"python"``, and their compilations so far).
Frames (twee1, twee3)
    :func:`frames` (float64 or mpmath at any precision).
Implementations (docs/design.md protocol)
    :mod:`refimpl.reference` (``Reference(dps)``, ``implementation`` at 50 digits)
    and :mod:`refimpl.fast` (``Fast``, ``implementation``); :class:`Implementation`
    states the protocol.
Rigorous (Arb balls, python-flint; :mod:`refimpl.rigorous`)
    :class:`Rigorous` (``Rigorous(prec_bits)``, ``implementation`` at 200 bits), :class:`Balls`,
    :class:`UndecidedError` (degenerate points raise the shared :class:`DegeneratePointError`), the judge API
    (:func:`judge_poisson`, :func:`judge_vector_field`, :func:`error_bounds`, :func:`distance_to_ball`)
    and :func:`body_flow_enclosure` (validated flows of the polynomial body systems).
"""

from ._algebra import LieAlgebra, jacobi_residual
from ._catalogue import (
    BIANCHI_TYPES,
    CATALOGUE_NAMES,
    abelian,
    aff1,
    bianchi,
    catalogue,
    heisenberg,
    se2,
    se3,
    sl2r,
    sl3r,
    so3_other_basis,
    so4,
    su2,
    su3,
)
from ._cohomology import (
    Cohomology,
    check_cocycle,
    coboundary_basis,
    cocycle_basis,
    cocycle_residual,
    cohomology,
    delta1,
    delta2,
    h2_dim,
    solve_coboundary,
)
from ._compiled_taylor import PATH as COMPILED_PATH
from ._compiled_taylor import compile_count
from ._errors import ChartError, DegeneratePointError
from ._frames import frames
from ._protocol import SPEC as PROTOCOL
from ._protocol import Implementation, check_attributes, provided_methods, provides
from ._representation import RepresentationError, representation_for
from ._taylor import quadratic_field
from ._validate import exact_sympy, parse_number
from .fast import Fast
from .model import Model, State
from .reference import Reference
from .scenes import Plan, Scene, load_scene, plan, run_scene

__all__ = [
    "LieAlgebra",
    "jacobi_residual",
    "COMPILED_PATH",
    "compile_count",
    "RepresentationError",
    "representation_for",
    "quadratic_field",
    "exact_sympy",
    "parse_number",
    "Model",
    "State",
    "BIANCHI_TYPES",
    "CATALOGUE_NAMES",
    "abelian",
    "aff1",
    "bianchi",
    "catalogue",
    "heisenberg",
    "se2",
    "se3",
    "sl2r",
    "sl3r",
    "so3_other_basis",
    "so4",
    "su2",
    "su3",
    "Cohomology",
    "check_cocycle",
    "coboundary_basis",
    "cocycle_basis",
    "cocycle_residual",
    "cohomology",
    "delta1",
    "delta2",
    "h2_dim",
    "solve_coboundary",
    "frames",
    "Implementation",
    "PROTOCOL",
    "provided_methods",
    "check_attributes",
    "provides",
    "Fast",
    "Reference",
    "DegeneratePointError",
    "ChartError",
    "Scene",
    "Plan",
    "load_scene",
    "plan",
    "run_scene",
]

from ._version import __version__  # pyproject.toml's version, through importlib.metadata
from .notebook import Trajectory, bracket, protocol_args, trajectory, vector_field
from .rigorous import (
    Balls,
    Rigorous,
    UndecidedError,
    body_flow_enclosure,
    distance_to_ball,
    error_bounds,
    judge_poisson,
    judge_vector_field,
)

__all__ += [
    "__version__",
    "Trajectory",
    "bracket",
    "protocol_args",
    "trajectory",
    "vector_field",
    "Balls",
    "Rigorous",
    "UndecidedError",
    "body_flow_enclosure",
    "distance_to_ball",
    "error_bounds",
    "judge_poisson",
    "judge_vector_field",
]
