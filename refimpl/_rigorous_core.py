"""Shared pieces of the rigorous (Arb ball) modules: the input boundary, the float views of inputs, and the
``phi1`` series in balls (refimpl/rigorous.py states the mathematics; refimpl/_rigorous_flow.py and
refimpl/_rigorous_state.py use them). The limits are the reference's, imported from where it states them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from flint import arb, arb_mat

from ._arb import float_view, upper
from ._reference_core import MAX_AD_NORM, MAX_DPS, MAX_MAGNITUDE
from ._validate import check_chart

__all__ = [
    "MAX_PREC_BITS",
    "check_frames_budget",
    "check_magnitudes",
    "fview",
    "phi1_ball",
    "point_view",
]

MAX_PREC_BITS = math.ceil(MAX_DPS * math.log2(10))
"""Precision cap in bits: the reference's cap of ``MAX_DPS`` = 5000 digits (16610 bits), for
``prec_bits`` and ``max_prec_bits`` alike (beyond it one 8 x 8 inverse takes seconds)."""
_MAX_MAG = float(MAX_MAGNITUDE)


def check_magnitudes(arr: np.ndarray, name: str) -> np.ndarray:
    """The shared magnitude boundary (the reference's ``MAX_MAGNITUDE`` = 1e300): finite numbers of
    modulus at most 1e300, on the float64 view of an input; raises ``ValueError`` naming the input."""
    a = np.asarray(arr, dtype=float)
    with np.errstate(all="ignore"):
        bad = ~(np.abs(a) <= _MAX_MAG)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        v = a[idx] if a.ndim else float(a)
        why = "NaN or infinity" if not np.isfinite(v) else f"magnitude {abs(v):.3g} > {_MAX_MAG:g}"
        raise ValueError(
            f"{name}: {why} at index {idx} (inputs are real numbers of magnitude at most {_MAX_MAG:g}, "
            "as for the reference)"
        )
    return a


def fview(v: Any, name: str) -> np.ndarray:
    """:func:`float_view`, with an exact number beyond the float64 range reported as a magnitude error."""
    try:
        return float_view(v, name)
    except OverflowError:
        raise ValueError(
            f"{name}: a number beyond the float64 range (inputs have magnitude at most {_MAX_MAG:g})"
        ) from None


def point_view(v: Any, n: int, name: str) -> np.ndarray:
    """The float64 view of a point input of shape ``(n,)``: shape, finiteness and magnitude checked."""
    a = fview(v, name)
    if a.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {a.shape}")
    return check_magnitudes(a, name)


def check_frames_budget(ff: np.ndarray, xf: np.ndarray) -> None:
    """The chart and the work budget of the frames at ``x`` (float64 view), shared with the fast path and
    the reference: ``x`` at or beyond the chart edge to float64 accuracy is refused with
    :class:`ChartError` (``check_chart(strict=True)``, the fast path's rule; it refuses every point the
    reference's determinant test refuses), and ``||ad_x||_1 > MAX_AD_NORM`` (400, the reference's
    budget) with ``ValueError``: the phi1 series needs ``~1.5 log2(e) ||ad_x||`` guard bits."""
    check_chart(ff, xf[None, :], strict=True)
    with np.errstate(all="ignore"):
        norm = float(np.max(np.abs(np.einsum("a,mab->mb", xf, ff)).sum(axis=0), initial=0.0))
    if not norm <= MAX_AD_NORM:
        raise ValueError(
            f"x = {np.array2string(xf, precision=6)}: ||ad_x||_1 = {norm:.5g} exceeds the work budget "
            f"{MAX_AD_NORM:g} (the reference's; the frame series needs ~||ad_x|| guard bits and terms)"
        )


def _eye(n: int) -> arb_mat:
    return arb_mat(n, n, [1 if i == j else 0 for i in range(n) for j in range(n)])


def _norm_inf_upper(M: arb_mat) -> float:
    """An upper bound of ``||M||_inf`` (largest row sum of moduli), rounded up."""
    n, m = M.nrows(), M.ncols()
    e = M.entries()
    return max(
        (math.fsum(upper(e[i * m + j]) for j in range(m)) for i in range(n)), default=0.0
    ) * (1 + 1e-15)


# ------------------------------------------------------------------ frames
def _phi1_terms(nu: float, prec: int) -> int:
    """The smallest ``N`` with ``N + 3 > 2 nu`` and ``nu^(N+1)/(N+2)! < 2^-(prec+4)`` (float estimate; the
    bound itself is then computed rigorously)."""
    target = -(prec + 4) * math.log(2)
    N = max(1, int(2 * nu))
    while (N + 1) * math.log(max(nu, 1e-300)) - math.lgamma(N + 3) > target:
        N += 1
    return N


# Not refimpl/_phi.py's phi1: balls with a rigorous tail bound need Arb arithmetic throughout.
def phi1_ball(M: arb_mat, prec: int) -> arb_mat:
    """``phi1(M) = sum_k M^k/(k+1)!`` as a ball matrix with a rigorous tail bound (module docstring).

    Scaling and doubling: with ``B = M / 2^s`` (exact: a power of two), the truncated series
    ``sum_{k<=N} B^k/(k+1)!`` is evaluated in ball arithmetic by Horner's scheme
    ``I + B/2 (I + B/3 (I + ... (I + B/(N+1))))``, and the tail beyond ``N`` is enclosed by
    ``t = nu^(N+1)/(N+2)! / (1 - nu/(N+3))`` (``nu >= ||B||_inf``), added to every entry's radius.
    Then ``s`` exact doublings ``phi1(2B) = phi1(B) (2 + B phi1(B)) / 2`` (from
    ``e^(2B) - 1 = (e^B - 1)(e^B + 1)`` and ``e^B = 1 + B phi1(B)``), in ball arithmetic.
    """
    n = M.nrows()
    nuf = _norm_inf_upper(M)
    s = max(0, math.ceil(math.log2(nuf)) + 4) if nuf > 0 else 0
    B = M * arb(2) ** (-s) if s else M
    nuf = nuf * 2.0**-s * (1 + 1e-15)
    N = _phi1_terms(nuf, prec)
    eye = _eye(n)
    acc = eye
    for k in range(N, 0, -1):
        acc = eye + (B * acc) / (k + 1)
    nu = arb(nuf)
    tail = nu ** (N + 1) / arb.fac_ui(N + 2) / (1 - nu / (N + 3))
    acc = acc + arb_mat(n, n, [arb(0, upper(tail))] * (n * n))
    for _ in range(s):
        acc = acc * (2 * eye + B * acc) / 2
        B = 2 * B
    return acc
