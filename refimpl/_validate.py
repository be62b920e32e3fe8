"""Validation of the implementation protocol's inputs, shared by both implementations.

Every failure is a ``ValueError`` naming the input and the violated condition
(with the residual where there is one). Tolerances are error models in units
of float64 ``eps``, stated next to each check. Validated structure constants
and cocycles are cached by value, so a batch pays for the checks once.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from ._algebra import EPS, LieAlgebra, jacobi_residual

__all__ = [
    "check_structure_constants", "check_theta", "check_upsilon", "check_inertia",
    "check_potential", "check_points", "as_float_array",
]


def as_float_array(value: Any, name: str) -> np.ndarray:
    """``value`` as float64; a clear error for non-numeric input."""
    if isinstance(value, LieAlgebra):
        return value.f
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} is not a numeric array: {exc}") from None
    return arr


def _finite(arr: np.ndarray, name: str) -> None:
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        raise ValueError(
            f"{name} contains NaN or infinity at {len(bad)} entr{'y' if len(bad) == 1 else 'ies'}, "
            f"first at index {tuple(int(i) for i in bad[0])}"
        )


@lru_cache(maxsize=64)
def _check_f_cached(data: bytes, n: int) -> None:
    f = np.frombuffer(data, dtype=float).reshape(n, n, n)
    scale = max(1.0, float(np.max(np.abs(f)))) if f.size else 1.0
    asym = np.abs(f + f.transpose(0, 2, 1))
    # Stored antisymmetric numbers may differ by rounding only: 4 eps max|f|.
    if asym.size and asym.max() > 4 * EPS * scale:
        idx = np.unravel_index(int(np.argmax(asym)), asym.shape)
        raise ValueError(
            f"structure constants f are not antisymmetric in (a, b): |f[m,a,b] + f[m,b,a]| = "
            f"{asym.max():.3g} at (m, a, b) = {tuple(int(i) for i in idx)}"
        )
    jac = np.abs(jacobi_residual(f))
    # Each Jacobi entry sums 3n rounded products of size <= max|f|^2: 3 n eps max|f|^2, x4 slack.
    tol = 12 * n * EPS * scale**2
    if jac.size and jac.max() > tol:
        idx = np.unravel_index(int(np.argmax(jac)), jac.shape)
        raise ValueError(
            f"structure constants f break the Jacobi identity: worst residual {jac.max():.3g} at "
            f"(m, a, b, c) = {tuple(int(i) for i in idx)} (tolerance 12 n eps max|f|^2 = {tol:.3g})"
        )


def check_structure_constants(f: Any) -> np.ndarray:
    arr = as_float_array(f, "structure constants f")
    if arr.ndim != 3 or not (arr.shape[0] == arr.shape[1] == arr.shape[2]) or arr.shape[0] == 0:
        raise ValueError(f"structure constants f must have shape (n, n, n) with n >= 1, got {arr.shape}")
    _finite(arr, "structure constants f")
    arr = np.ascontiguousarray(arr)
    _check_f_cached(arr.tobytes(), arr.shape[0])
    return arr


def _check_square_antisym(value: Any, n: int, name: str) -> np.ndarray:
    arr = as_float_array(value, name)
    if arr.shape != (n, n):
        raise ValueError(f"{name} must have shape ({n}, {n}) to match f, got {arr.shape}")
    _finite(arr, name)
    asym = np.abs(arr + arr.T)
    # Antisymmetry up to the rounding of the stored entries: 4 eps max|entry|.
    if asym.max() > 4 * EPS * max(float(np.max(np.abs(arr))), np.finfo(float).tiny):
        i, j = np.unravel_index(int(np.argmax(asym)), asym.shape)
        raise ValueError(
            f"{name} is not antisymmetric: |{name}[{i},{j}] + {name}[{j},{i}]| = {asym.max():.3g}"
        )
    return arr


@lru_cache(maxsize=64)
def _check_theta_cached(fdata: bytes, tdata: bytes, n: int) -> None:
    f = np.frombuffer(fdata, dtype=float).reshape(n, n, n)
    t = np.frombuffer(tdata, dtype=float).reshape(n, n)
    res = (
        -np.einsum("kc,kab->abc", t, f) + np.einsum("kb,kac->abc", t, f) - np.einsum("ka,kbc->abc", t, f)
    )
    worst = float(np.max(np.abs(res)))
    # delta_2 Theta sums 3n products: 3 n eps max|f| max|Theta|, x8 slack.
    tol = 24 * n * EPS * max(1.0, float(np.max(np.abs(f)))) * max(1.0, float(np.max(np.abs(t))))
    if worst > tol:
        idx = np.unravel_index(int(np.argmax(np.abs(res))), res.shape)
        raise ValueError(
            f"theta is not a 2-cocycle (zeven1): max |delta_2 theta| = {worst:.3g} at (a, b, c) = "
            f"{tuple(int(i) for i in idx)} > tolerance 24 n eps max|f| max|theta| = {tol:.3g}"
        )


def check_theta(theta: Any, f: np.ndarray) -> np.ndarray:
    n = f.shape[0]
    arr = _check_square_antisym(theta, n, "theta")
    arr = np.ascontiguousarray(0.5 * (arr - arr.T))
    _check_theta_cached(np.ascontiguousarray(f).tobytes(), arr.tobytes(), n)
    return arr


def check_upsilon(upsilon: Any, n: int) -> np.ndarray:
    arr = _check_square_antisym(upsilon, n, "upsilon")
    return np.ascontiguousarray(0.5 * (arr - arr.T))


def check_inertia(inertia: Any, n: int) -> np.ndarray:
    """Symmetric positive definite inertia tensor ``I``; returns it as float64."""
    arr = as_float_array(inertia, "inertia")
    if arr.shape != (n, n):
        raise ValueError(f"inertia must have shape ({n}, {n}) to match f, got {arr.shape}")
    _finite(arr, "inertia")
    scale = float(np.max(np.abs(arr)))
    asym = float(np.max(np.abs(arr - arr.T)))
    if asym > 4 * EPS * scale:
        raise ValueError(f"inertia is not symmetric: max |I - I^T| = {asym:.3g}")
    w = np.linalg.eigvalsh(0.5 * (arr + arr.T))
    # Positive definite with a margin: the smallest eigenvalue must exceed the
    # eigenvalue error of a symmetric solver, n eps ||I||.
    if scale == 0 or w[0] <= 8 * n * EPS * scale:
        raise ValueError(
            f"inertia is not positive definite: smallest eigenvalue {w[0]:.3g} "
            f"(largest {w[-1]:.3g})"
        )
    return arr


def check_potential(potential: Any, n: int) -> dict | None:
    if potential is None:
        return None
    if not isinstance(potential, dict):
        raise ValueError(f"potential must be None or a dict with kind 'gravity', got {type(potential).__name__}")
    kind = potential.get("kind")
    if kind != "gravity":
        raise ValueError(f"potential kind {kind!r} is not supported (expected 'gravity', twee15)")
    unknown = set(potential) - {"kind", "L", "gamma"}
    if unknown:
        raise ValueError(f"potential has unknown keys {sorted(unknown)} (expected kind, L, gamma)")
    out = {"kind": "gravity"}
    for key in ("L", "gamma"):
        if key not in potential:
            raise ValueError(f"gravity potential needs {key!r} of shape ({n},)")
        arr = as_float_array(potential[key], f"potential[{key!r}]")
        if arr.shape != (n,):
            raise ValueError(f"potential[{key!r}] must have shape ({n},), got {arr.shape}")
        _finite(arr, f"potential[{key!r}]")
        out[key] = arr
    return out


def check_points(x: Any, pi: Any, n: int, *, batched: bool) -> tuple[np.ndarray, np.ndarray]:
    """``x`` and ``pi`` with matching shape ``(..., n)``; every point finite."""
    xa = as_float_array(x, "x")
    pa = as_float_array(pi, "pi")
    if xa.shape[-1:] != (n,) or pa.shape[-1:] != (n,):
        raise ValueError(f"x and pi must have last axis {n} to match f, got {xa.shape} and {pa.shape}")
    if xa.shape != pa.shape:
        raise ValueError(f"x and pi must have the same shape, got {xa.shape} and {pa.shape}")
    if not batched and xa.ndim != 1:
        raise ValueError(f"x and pi must have shape ({n},) for an unbatched implementation, got {xa.shape}")
    for arr, name in ((xa, "x"), (pa, "pi")):
        ok = np.all(np.isfinite(arr), axis=-1)
        if not np.all(ok):
            bad = np.argwhere(~ok)
            where = ", ".join(str(tuple(int(i) for i in b)) for b in bad[:5])
            more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
            raise ValueError(f"{name} contains NaN or infinity at point(s) {where or '()'}{more}")
    return xa, pa
