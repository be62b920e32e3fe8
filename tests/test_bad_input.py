"""Bad input gets a clear ValueError naming the input and the violated condition, from both
implementations; a batch is never silently truncated or corrupted."""

from __future__ import annotations

import numpy as np
import pytest

from tstarg.refimpl import bianchi, su2
from tstarg.refimpl.fast import implementation as fast
from tstarg.refimpl.reference import Reference

REF = Reference(30)
IMPLS = [pytest.param(fast, id="fast"), pytest.param(REF, id="reference")]
F = su2().f
Z3 = np.zeros((3, 3))
X = np.array([0.1, 0.2, 0.3])
PI = np.array([1.0, -0.5, 0.25])


def _pt(impl, **kw):
    args = dict(f=F, theta=Z3, upsilon=Z3, x=X, pi=PI)
    args.update(kw)
    return impl.poisson_tensor(args["f"], args["theta"], args["upsilon"], args["x"], args["pi"])


def _vf(impl, **kw):
    args = dict(
        f=F, theta=Z3, upsilon=Z3, inertia=np.diag([1.0, 2.0, 3.0]), potential=None, x=X, pi=PI
    )
    args.update(kw)
    return impl.hamiltonian_vector_field(
        *[args[k] for k in ("f", "theta", "upsilon", "inertia", "potential", "x", "pi")]
    )


@pytest.mark.parametrize("impl", IMPLS)
def test_theta_not_antisymmetric(impl):
    with pytest.raises(ValueError, match=r"theta is not antisymmetric"):
        _pt(impl, theta=np.array([[0, 1.0, 0], [1.0, 0, 0], [0, 0, 0]]))


@pytest.mark.parametrize("impl", IMPLS)
def test_upsilon_not_antisymmetric(impl):
    with pytest.raises(ValueError, match=r"upsilon is not antisymmetric"):
        _pt(impl, upsilon=np.eye(3))


@pytest.mark.parametrize("impl", IMPLS)
def test_theta_not_a_cocycle_reports_residual(impl):
    """Bianchi V: Theta = e^1 ^ e^2 has delta_2 Theta = -2 (see test_cohomology)."""
    f = bianchi("V").f
    theta = np.array([[0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])
    with pytest.raises(
        ValueError, match=r"theta is not a 2-cocycle \(zeven1\): max \|delta_2 theta\| = 2"
    ):
        _pt(impl, f=f, theta=theta)


@pytest.mark.parametrize("impl", IMPLS)
def test_structure_constants_break_jacobi(impl):
    f = np.zeros((3, 3, 3))
    for m, a, b, v in ((1, 0, 1, 1.0), (0, 1, 2, 1.0), (2, 2, 0, -1.0)):
        f[m, a, b], f[m, b, a] = v, -v
    with pytest.raises(ValueError, match=r"break the Jacobi identity: worst residual 2"):
        _pt(impl, f=f)


@pytest.mark.parametrize("impl", IMPLS)
def test_structure_constants_not_antisymmetric(impl):
    f = F.copy()
    f[0, 1, 2] = 2.0
    with pytest.raises(ValueError, match=r"not antisymmetric in \(a, b\)"):
        _pt(impl, f=f)


@pytest.mark.parametrize("impl", IMPLS)
@pytest.mark.parametrize(
    "inertia, message",
    [
        (np.array([[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]]), "inertia is not symmetric"),
        (np.diag([1.0, -2.0, 3.0]), "inertia is not positive definite: smallest eigenvalue -2"),
        (np.diag([1.0, 0.0, 3.0]), "inertia is not positive definite"),
        (np.eye(2), r"inertia must have shape \(3, 3\)"),
    ],
)
def test_bad_inertia(impl, inertia, message):
    with pytest.raises(ValueError, match=message):
        _vf(impl, inertia=inertia)


@pytest.mark.parametrize("impl", IMPLS)
@pytest.mark.parametrize(
    "kw, message",
    [
        (dict(x=np.array([0.1, 0.2])), r"x"),
        (dict(theta=np.zeros((2, 2))), r"theta must have shape \(3, 3\)"),
        (dict(f=np.zeros((3, 3))), r"shape \(n, n, n\)"),
    ],
)
def test_shape_mismatch(impl, kw, message):
    with pytest.raises(ValueError, match=message):
        _pt(impl, **kw)


@pytest.mark.parametrize("impl", IMPLS)
@pytest.mark.parametrize("where", ["x", "pi", "theta", "upsilon", "f"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nan_or_infinity(impl, where, bad):
    kw = {"x": X.copy(), "pi": PI.copy(), "theta": Z3.copy(), "upsilon": Z3.copy(), "f": F.copy()}
    kw[where].flat[1] = bad
    with pytest.raises(ValueError, match=r"NaN or infinity|non-finite"):
        _pt(impl, **kw)


@pytest.mark.parametrize("impl", IMPLS)
def test_bad_potential(impl):
    with pytest.raises(ValueError, match=r"potential kind 'spring' is not supported"):
        _vf(impl, potential={"kind": "spring"})
    with pytest.raises(ValueError, match=r"potential\['L'\] must have shape \(3,\)"):
        _vf(impl, potential={"kind": "gravity", "L": [1.0, 0.0], "gamma": [0.0, 0.0, 1.0]})
    with pytest.raises(ValueError, match=r"NaN or infinity|non-finite"):
        _vf(impl, potential={"kind": "gravity", "L": [1.0, 0.0, np.nan], "gamma": [0.0, 0.0, 1.0]})


def test_batch_with_one_bad_point_names_it():
    """The fast implementation never drops a point: one NaN in a batch is an error naming its index."""
    x = np.zeros((2, 4, 3))
    pi = np.ones((2, 4, 3))
    pi[1, 2, 0] = np.nan
    with pytest.raises(ValueError, match=r"pi contains NaN or infinity at point\(s\) \(1, 2\)"):
        fast.poisson_tensor(F, Z3, Z3, x, pi)


def test_reference_rejects_batches():
    with pytest.raises(ValueError, match=r"x must have shape \(3,\)"):
        REF.poisson_tensor(F, Z3, Z3, np.zeros((2, 3)), np.zeros((2, 3)))
