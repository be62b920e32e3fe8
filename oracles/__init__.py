"""oracles: independent judges -- published tables, closed forms, symbolic checks.

Public API:

* :data:`PUBLISHED_H2` (second Betti numbers of the catalogue, with sources; oracles.published);
* the paper's claims registry: :data:`CLAIMS`, :data:`LABELS`, :data:`ERRATA`, :func:`evaluate_claims`
  (oracles.claims, data in oracles/registry/*.toml) and the checks it runs, :data:`CLAIM_CHECKS`
  (oracles.claim_checks, one module per section of the paper);
* section cinq symbolically: :func:`su2_nondegenerate_residuals`, :func:`su2_degenerate_residuals`
  (oracles.su2_symbolic); GNH worked examples: :data:`GNH_EXAMPLES`, :func:`check_gnh_example`;
* closed forms: :func:`rigid_body_solution`, :func:`detest_b5`, :func:`detest_b5_exact`,
  :func:`heavy_top_integrals`, :func:`integral_rates`, :data:`HEAVY_TOPS` (oracles.closed_forms);
* qutip's spin picture: module :mod:`oracles.qutip_spin` (imported lazily: qutip is heavy);
* :func:`oracle_checks` for ``tstarg verify`` (oracles.oracle_checks, imported lazily).
"""

from .claim_checks import CHECKS as CLAIM_CHECKS
from .claims import CLAIMS, ERRATA, LABELS
from .claims import evaluate as evaluate_claims
from .closed_forms import (
    HEAVY_TOPS,
    detest_b5,
    detest_b5_exact,
    heavy_top_integrals,
    integral_rates,
    rigid_body_solution,
)
from .gnh_examples import EXAMPLES as GNH_EXAMPLES
from .gnh_examples import check_example as check_gnh_example
from .published import PUBLISHED_B1, PUBLISHED_H2
from .su2_symbolic import residuals_degenerate as su2_degenerate_residuals
from .su2_symbolic import residuals_nondegenerate as su2_nondegenerate_residuals

__all__ = [
    "CLAIMS",
    "CLAIM_CHECKS",
    "ERRATA",
    "GNH_EXAMPLES",
    "HEAVY_TOPS",
    "LABELS",
    "PUBLISHED_B1",
    "PUBLISHED_H2",
    "check_gnh_example",
    "detest_b5",
    "detest_b5_exact",
    "evaluate_claims",
    "heavy_top_integrals",
    "integral_rates",
    "rigid_body_solution",
    "su2_degenerate_residuals",
    "su2_nondegenerate_residuals",
    "oracle_checks",
]


def __getattr__(name):
    if name == "oracle_checks":
        from .oracle_checks import oracle_checks

        return oracle_checks
    raise AttributeError(name)
