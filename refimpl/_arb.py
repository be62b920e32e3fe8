"""Ball arithmetic helpers for the rigorous implementation (python-flint's Arb balls).

A ball ``[m +/- r]`` (``flint.arb``) is a set that provably contains the exact
value: every operation rounds its midpoint and widens its radius so that the
result contains every value the operation can take on the input balls.

* :func:`workprec` sets ``flint.ctx.prec`` (bits) for a block and restores it.
* :func:`to_arb` turns an input number into a ball *containing it exactly*:
  floats and mpmath numbers are binary rationals and become exact (radius 0)
  balls; ints are exact; ``Fraction``, rational strings ("1/3", "0.1") and
  sympy rationals become the ball of their exact rational value; sympy
  algebraic expressions (``sqrt(3)/2``, ``sqrt(2)`` of VII_h) are evaluated
  by walking their expression tree in ball arithmetic, so ``sqrt(3)`` enters
  as a ball around the irrational number, never as a rounded float.
* :func:`to_exact` turns the same inputs into sympy numbers (for the exact
  decision ``Delta == 0``).
* :class:`Balls`: an array of balls with its float64 midpoint/radius views and
  containment tests against other values (the judge's primitive).
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache
from typing import Any

import flint
import mpmath
import numpy as np
import sympy
from flint import arb, arb_mat, fmpq, fmpz

from ._algebra import LieAlgebra
from ._validate import parse_number

__all__ = [
    "Balls",
    "algebra_balls",
    "exact_source",
    "float_view",
    "mat_entries",
    "to_arb",
    "to_exact",
    "upper",
    "workprec",
]


@contextmanager
def workprec(bits: int):
    """Run a block at ``bits`` bits of Arb precision; restore the caller's precision afterwards."""
    old = flint.ctx.prec
    flint.ctx.prec = int(bits)
    try:
        yield
    finally:
        flint.ctx.prec = old


def _pow2(e: int) -> arb:
    return arb(2) ** int(e)  # exact: a power of two is representable at any precision


def _tuple_to_arb(t: tuple) -> arb:
    sign, man, exp, _ = t
    return arb(fmpz(-int(man) if sign else int(man))) * _pow2(exp)


def _mpf_to_arb(v: mpmath.mpf) -> arb:
    if not mpmath.isfinite(v):
        raise ValueError(f"non-finite number {v!r}")
    return _tuple_to_arb(v._mpf_)


def _sympy_to_arb(e: sympy.Basic) -> arb:
    """Evaluate a real sympy number in ball arithmetic, following its expression tree."""
    if e.is_Integer:
        return arb(fmpz(int(e)))
    if e.is_Rational:
        return arb(fmpq(int(e.p), int(e.q)))
    if e.is_Float:  # a binary float of any precision: exact, from its (sign, man, exp, bc) tuple
        if not e.is_finite:
            raise ValueError(f"non-finite number {e}")
        return _tuple_to_arb(e._mpf_)
    if e is sympy.pi:
        return arb.pi()
    if e is sympy.E:
        return arb.const_e()
    if e.is_Add:
        out = arb(0)
        for a in e.args:
            out += _sympy_to_arb(a)
        return out
    if e.is_Mul:
        out = arb(1)
        for a in e.args:
            out *= _sympy_to_arb(a)
        return out
    if e.is_Pow:
        base, ex = e.args
        b = _sympy_to_arb(base)
        if ex.is_Integer:
            return b ** int(ex)
        if ex.is_Rational:
            if not (b > 0):
                raise ValueError(f"{e}: a fractional power needs a provably positive base")
            r = b.root(int(ex.q)) if int(ex.q) != 2 else b.sqrt()
            return r ** int(ex.p)
    raise TypeError(
        f"cannot evaluate the sympy number {e} in ball arithmetic (use rationals and radicals)"
    )


def to_arb(v: Any, name: str = "value") -> arb:
    """The ball of an input number at the current precision (see the module docstring)."""
    try:
        if isinstance(v, (bool, np.bool_)):
            raise TypeError("booleans are not numbers here")
        if isinstance(v, arb):
            return +v
        if isinstance(v, (int, np.integer)):
            return arb(fmpz(int(v)))
        if isinstance(v, (float, np.floating)):
            if not math.isfinite(float(v)):
                raise ValueError(f"non-finite number {v!r} (NaN or infinity)")
            return arb(float(v))  # a double is a binary rational: exact ball
        if isinstance(v, Fraction):
            return arb(fmpq(v.numerator, v.denominator))
        if isinstance(v, str):
            q = parse_number(v)  # the one parser (refimpl._validate): never evaluated
            return arb(fmpq(q.numerator, q.denominator))
        if isinstance(v, mpmath.mpf):
            return _mpf_to_arb(v)
        if isinstance(v, sympy.Basic):
            if not v.is_real or not v.is_number:
                raise ValueError(f"{v} is not a real number")
            return _sympy_to_arb(v)
    except (TypeError, ValueError, ZeroDivisionError) as exc:
        raise ValueError(f"{name}: {exc}") from None
    raise ValueError(f"{name}: cannot use {type(v).__name__} {v!r} as a real number")


def to_exact(v: Any) -> sympy.Expr:
    """The exact sympy value of an input number (floats and mpf as the binary rationals they are)."""
    if isinstance(v, sympy.Basic):
        return v
    if isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)):
        return sympy.Integer(int(v))
    if isinstance(v, (float, np.floating)):
        return sympy.Rational(*float(v).as_integer_ratio())
    if isinstance(v, Fraction):
        return sympy.Rational(v.numerator, v.denominator)
    if isinstance(v, str):
        q = parse_number(v)  # the one parser (refimpl._validate): never evaluated
        return sympy.Rational(q.numerator, q.denominator)
    if isinstance(v, mpmath.mpf):
        sign, man, exp, _ = v._mpf_
        return sympy.Integer(-int(man) if sign else int(man)) * sympy.Integer(2) ** int(exp)
    raise TypeError(f"no exact value for {type(v).__name__} {v!r}")


def upper(b: arb) -> float:
    """A float64 upper bound of ``|b|`` (rounded outward, so it is still an upper bound)."""
    u = float(abs(b).upper())
    return math.nextafter(u, math.inf) if u != 0 else 0.0


def mat_entries(M: arb_mat) -> np.ndarray:
    """An ``arb_mat`` as an object array of ``arb`` balls."""
    return np.array(M.entries(), dtype=object).reshape(M.nrows(), M.ncols())


@dataclass(frozen=True)
class Balls:
    """An array of Arb balls, each provably containing the exact value of its entry.

    ``balls``: object array of ``flint.arb``; ``prec_bits``: the working precision
    that produced them. ``mid``/``rad`` are float64 views: ``mid`` is the midpoint
    rounded to the nearest double, ``rad`` an upper bound of the radius (rounded up),
    so ``|exact - mid| <= rad + |mid_exact - mid|`` where the last term is at most half
    an ulp of ``mid``; :meth:`error_bounds` accounts for it exactly.
    """

    balls: np.ndarray
    prec_bits: int

    @property
    def shape(self) -> tuple:
        return self.balls.shape

    @property
    def mid(self) -> np.ndarray:
        return np.array([float(b.mid()) for b in self.balls.flat], dtype=float).reshape(self.shape)

    @property
    def rad(self) -> np.ndarray:
        return np.array([upper(b.rad()) for b in self.balls.flat], dtype=float).reshape(self.shape)

    def __getitem__(self, idx) -> Balls | arb:
        out = self.balls[idx]
        return Balls(out, self.prec_bits) if isinstance(out, np.ndarray) else out

    def _values(self, values: Any) -> np.ndarray:
        arr = np.asarray(values, dtype=object)
        if arr.shape != self.shape:
            raise ValueError(f"values must have shape {self.shape}, got {arr.shape}")
        return arr

    def contains(self, values: Any) -> np.ndarray:
        """Elementwise: does the ball contain the (exactly converted) value? Booleans array."""
        arr = self._values(values)
        with workprec(max(self.prec_bits, 64) + 64):
            return np.array(
                [b.contains(to_arb(v, "value")) for b, v in zip(self.balls.flat, arr.flat)],
                dtype=bool,
            ).reshape(self.shape)

    def error_bounds(self, values: Any) -> tuple[np.ndarray, np.ndarray]:
        """Proven bounds ``lo <= |value - exact| <= hi`` per entry (float64, rounded outward).

        ``lo = max(0, |value - m| - r)`` and ``hi = |value - m| + r`` for the ball ``[m +/- r]``,
        computed in ball arithmetic and rounded outward. ``lo`` is the distance from the value
        to the ball: an error the value provably has; ``hi`` is an error it provably does not exceed.
        """
        arr = self._values(values)
        lo, hi = np.empty(self.shape), np.empty(self.shape)
        with workprec(max(self.prec_bits, 64) + 64):
            for k, (b, v) in enumerate(zip(self.balls.flat, arr.flat)):
                d = abs(to_arb(v, "value") - b)  # the set {|v - y| : y in b}, enclosed
                lo.flat[k] = max(0.0, math.nextafter(float(d.lower()), -math.inf))
                hi.flat[k] = math.nextafter(float(d.upper()), math.inf)
        return lo, hi

    def max_rad(self) -> float:
        return float(np.max(self.rad)) if self.balls.size else 0.0


# ------------------------------------------------------------------ model inputs
def float_view(v: Any, name: str) -> np.ndarray:
    """Any accepted input as float64 (for the shared float-side validation only)."""
    if isinstance(v, LieAlgebra):
        return v.f
    arr = np.asarray(v, dtype=object)
    try:
        return np.asarray(arr, dtype=float)
    except (TypeError, ValueError):
        pass
    out = np.empty(arr.shape)
    for idx, e in np.ndenumerate(arr):
        try:
            out[idx] = float(to_exact(e))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}: {exc}") from None
    return out


def exact_source(f: Any) -> np.ndarray:
    """The entries of ``f`` to convert: the exact constants of an exact LieAlgebra, else the values given."""
    if isinstance(f, LieAlgebra):
        return f.f_exact if f.is_exact else f.f
    return np.asarray(f, dtype=object)


def _balls_of(arr: np.ndarray, name: str) -> list:
    return [to_arb(e, name) for e in arr.flat]


@lru_cache(maxsize=64)
def _algebra_cached(key, prec: int, holder) -> tuple:
    return _algebra_convert(holder.value, prec)


class _Holder:
    """Keeps a LieAlgebra alive and hashable by identity for the cache."""

    def __init__(self, value):
        self.value = value

    def __hash__(self):
        return id(self.value)

    def __eq__(self, other):
        return isinstance(other, _Holder) and other.value is self.value


def _algebra_convert(f: Any, prec: int) -> tuple:
    """``(Fad, FS, n)``: ``ad_x = reshape(Fad x)`` and ``pi_m f^m = reshape(FS pi)`` as ball matrices."""
    src = exact_source(f)
    n = src.shape[0]
    with workprec(prec):
        vals = np.array(_balls_of(src, "structure constants f"), dtype=object).reshape(n, n, n)
        # Fad[(m, b), a] = f[m, a, b];  FS[(a, b), m] = f[m, a, b]
        Fad = arb_mat(n * n, n, list(vals.transpose(0, 2, 1).reshape(n * n, n).flat))
        FS = arb_mat(n * n, n, list(vals.transpose(1, 2, 0).reshape(n * n, n).flat))
    return Fad, FS, n


def algebra_balls(f: Any, prec: int) -> tuple:
    """``(Fad, FS, n)`` for ``f`` at ``prec`` bits, cached for LieAlgebra objects and float arrays."""
    if isinstance(f, LieAlgebra):
        return _algebra_cached(id(f), prec, _Holder(f))
    arr = np.asarray(f)
    if arr.dtype == float and arr.ndim == 3:
        return _algebra_cached_float(arr.shape, np.ascontiguousarray(arr).tobytes(), prec)
    return _algebra_convert(f, prec)


@lru_cache(maxsize=64)
def _algebra_cached_float(shape: tuple, data: bytes, prec: int) -> tuple:
    return _algebra_convert(np.frombuffer(data, dtype=float).reshape(shape), prec)
