"""Bad input to the flows: a clear ValueError naming the input and the violated condition."""

from __future__ import annotations

import numpy as np
import pytest

from tstarg.refimpl import catalogue, su2
from tstarg.refimpl.flows import fast_flow, reference_flow, reference_trajectory

F = su2().f
Z = np.zeros((3, 3))
I = np.diag([1.0, 2.0, 3.0])
X0, PI0 = np.array([0.1, 0.0, 0.0]), np.array([0.4, -0.3, 1.1])


@pytest.mark.parametrize(
    "t", [float("nan"), float("inf"), -float("inf"), "soon", 1j, complex(1, 0), None]
)
@pytest.mark.parametrize("flow", ["fast", "reference"])
def test_bad_time_span(flow, t):
    """t must be a finite real number (negative t runs the flow backwards, tests/test_flow_any_model.py)."""
    fn = fast_flow if flow == "fast" else (lambda *a: reference_flow(*a, dps=15))
    with pytest.raises(ValueError, match="t must be a finite real number"):
        fn(F, Z, Z, I, None, X0, PI0, t)


@pytest.mark.parametrize("tol", [0.0, -1e-9, float("nan"), float("inf")])
def test_bad_tolerance(tol):
    """tol must be finite and > 0."""
    with pytest.raises(ValueError, match="tol must be a finite number > 0"):
        fast_flow(F, Z, Z, I, None, X0, PI0, 1.0, tol=tol)


def test_start_on_degenerate_set_fast_names_the_point():
    """su(2): pi'.tau = 1 is the degenerate set Pi_1 (C1 = 0); the batch index is named, no point dropped."""
    tau = np.array([0.0, 0.0, 0.5])
    U = np.einsum("l,lmn->mn", tau, F)
    pi0 = np.array([[0.4, -0.3, 1.1], [0.3, 0.1, 2.0]])  # second: pi.tau = 1
    with pytest.raises(ValueError, match=r"initial point\(s\) \[1\] lie on the degenerate set"):
        fast_flow(F, Z, U, I, None, np.zeros((2, 3)), pi0, 1.0)


@pytest.mark.parametrize("one", [False, True], ids=["batch", "single"])
def test_start_on_degenerate_set_generic_algebra_names_the_point(one):
    """Off su(2) (sl(2,R), the compiled generic route of the start check): ``Delta = det(1 + S Upsilon)``
    with ``S_ab = pi_m f^m_ab`` (docs/conventions.md, vier6) vanishes at ``pi = -5 v`` for
    ``Upsilon = 0.5 (e_0 ^ e_1)`` and ``v = (0.3, -0.2, 1)`` (a double root of the quadratic
    ``s -> Delta(s v)``); that start is refused by index, alone or in a batch, and the other one flows."""
    f = np.asarray(catalogue("sl(2,R)").f, float)
    U = np.zeros((3, 3))
    U[0, 1], U[1, 0] = 0.5, -0.5
    bad = -5.0 * np.array([0.3, -0.2, 1.0])
    S = np.einsum("m,mab->ab", bad, f)
    assert abs(np.linalg.det(np.eye(3) + S @ U)) <= 1e-14  # the premise, by numpy's determinant
    good = np.array([0.4, -0.3, 1.1])
    x, pi = fast_flow(f, Z, U, I, None, np.zeros(3), good, 0.5)
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(pi))
    pi0 = bad if one else np.stack([good, bad])
    idx = "0" if one else "1"
    with pytest.raises(
        ValueError, match=rf"initial point\(s\) \[{idx}\] lie on the degenerate set"
    ):
        fast_flow(f, Z, U, I, None, np.zeros_like(pi0), pi0, 0.5)


def test_start_on_degenerate_set_reference():
    """The reference refuses a start with Delta = 0 (exact rational input)."""
    U = np.array([[0, "1/2", 0], ["-1/2", 0, 0], [0, 0, 0]], dtype=object)  # tau = (0, 0, 1/2)
    with pytest.raises(ValueError, match="degenerate set"):
        reference_flow(F, Z, U, I, None, [0, 0, 0], ["2/5", "-3/10", 2], 1, dps=15)


def test_chart_exit_is_re_based_through_a_built_representation():
    """An algebra typed in without a representation (Bianchi III scaled, f' = 2 f: no catalogue match)
    leaves the chart and is re-based through the representation built from f; the x(t) returned
    satisfies exp(x) = g(t) (the group element returned alongside), so nothing is refused."""
    from tstarg.refimpl import LieAlgebra

    alg = LieAlgebra.from_structure_constants(
        2 * catalogue("Bianchi III").f, name="Bianchi III (scaled)"
    )
    assert alg.rep is None
    I3 = np.diag([1.0, 1.5, 2.0])
    x0, pi0 = np.array([0.9, -0.6, 0.3]), np.array([2.0, 1.5, -1.0])
    x, pi, g = fast_flow(alg, Z, Z, I3, None, x0, pi0, 5.0, steps=200, return_group=True)
    from scipy.linalg import expm

    from tstarg.refimpl._representation import representation_for

    E = representation_for(alg).mats
    G = expm(np.einsum("a,aij->ij", x, E))
    # exp(rho(x)) against g: rounding of expm / logm, c eps cond scale with cond ~ |g| |g^-1|
    scale = np.linalg.norm(g, 1) * np.linalg.norm(np.linalg.inv(g), 1)
    assert np.all(np.isfinite(x)) and np.max(np.abs(G - g)) <= 1e4 * np.finfo(
        float
    ).eps * scale * np.max(np.abs(g))
    tr = reference_trajectory(alg, Z, Z, I3, None, x0, pi0, [0, "1/2"], dps=15)
    assert tr.Ad is not None and tr.Ad.shape == (2, 3, 3)


def test_trajectory_blowing_up_is_named_not_dropped():
    """A trajectory that becomes non-finite raises ValueError naming it (the others are not silently kept)."""
    # pi = 1e200: pi x Omega overflows float64 in the first stage of trajectory 1 only
    pi0 = np.array([[0.4, -0.3, 1.1], [1e200, 1e200, 1e200]])
    with np.errstate(over="ignore", invalid="ignore"):
        with pytest.raises(ValueError, match=r"trajectories \[1\] became non-finite"):
            fast_flow(F, Z, Z, I, None, np.zeros((2, 3)), pi0, 1.0, steps=10)
