"""The unrolled Taylor recurrence of :mod:`refimpl.codegen.taylor` as LLVM IR, built by numba intrinsics.

Why IR rather than Python source: numba's front end types and lowers every arithmetic operation of a
function on its own (resolving ``operator.mul`` against all its templates, about 0.3 ms per operation),
so a straight-line kernel of ~10^4 operations (the su(2) full state unrolled at order 15) spent ~6 of
its ~8 s of compilation there (issue 25: type inference 3.3 s, lowering 2.5 s, LLVM itself under 1 s).
An intrinsic is one call to numba's front end; its ``codegen`` writes the operations straight into the
kernel's LLVM function with llvmlite, in the order and with the flags the Python source had:

* every floating-point operation carries ``contract`` (the kernels' ``fastmath={'contract'}``: LLVM may
  fuse a multiply and an add into one FMA, never reassociates), so the compensated (Kahan) update and
  the summation trees stay as written; in the recurrence of the one-trajectory and pair kernels
  (:func:`_coefficients_packed`) every multiply-add is an explicit ``llvm.fmuladd`` instead, so that
  a run's coefficients are the same whether it is computed alone or on a lane beside another;
* the Cauchy products of the one-trajectory and pair kernels are computed in packs of monomials side
  by side (:func:`pack_groups`: one vector lane per monomial and run), each product's sum a chain;
  the components' sums are the balanced trees of :func:`refimpl.codegen.taylor.tree_sum`; the batch
  kernel's lanes sum as the chains of :func:`refimpl.codegen.taylor.chain_sum`;
* ``max`` is numba's (``select(v > acc, v, acc)``), ``abs`` LLVM's ``fabs``.

The state and the coefficients travel as tuples of float64 (LLVM aggregates that SROA splits into
registers), so the kernels' control (step size, time, bookkeeping) stays numba Python around three
intrinsics built per structure from its spec (:func:`spec`): :func:`coefficients_intrinsic`,
:func:`update_intrinsic` and, for the batch kernel's lane rows, :func:`rows_coefficients_intrinsic`
and :func:`rows_update_intrinsic`.

The generated module text names :data:`IR_VERSION` (so its hash, the kernel's cache key, changes with
the IR built here: numba's disk cache keys on the generated file, not on this module).
"""

from __future__ import annotations

try:  # only the generated kernels use the intrinsics; spec() and the layout helpers need neither
    import llvmlite.ir as ir
    from numba import types
    from numba.core import cgutils
    from numba.extending import intrinsic
except ImportError:  # pragma: no cover - exercised only where numba is missing
    ir = types = cgutils = intrinsic = None

__all__ = [
    "IR_VERSION",
    "coefficients_intrinsic",
    "lanes_coefficients_intrinsic",
    "lanes_update_intrinsic",
    "rows_coefficients_intrinsic",
    "rows_update_intrinsic",
    "spec",
    "update_intrinsic",
]

IR_VERSION = "3"
_F64 = None if ir is None else ir.DoubleType()
_FLAGS = ("contract",)


def spec(cf, P: int) -> tuple:
    """The structure of ``cf`` at order ``P`` as nested tuples of ints (literal in the generated text):
    ``(d, P, monomials, constant components, qptr, qmon, lptr, lidx)``."""
    return (
        int(cf.d),
        int(P),
        tuple((int(i), int(j)) for i, j in cf.mons.tolist()),
        tuple(int(c) for c in range(cf.d) if cf.const[c]),
        tuple(int(x) for x in cf.qptr.tolist()),
        tuple(int(x) for x in cf.qmon.tolist()),
        tuple(int(x) for x in cf.lptr.tolist()),
        tuple(int(x) for x in cf.lidx.tolist()),
    )


def variable_components(sp) -> list[int]:
    """The components that are not constant (the ones with coefficients ``k >= 1``), in order."""
    const = set(sp[3])
    return [c for c in range(sp[0]) if c not in const]


class _Ops:
    """Floating-point operations on one builder, each with the kernels' ``contract`` flag, on float64
    or (``lanes > 1``) on vectors of ``lanes`` float64 (one trajectory per lane, element by element:
    the same operations on each lane)."""

    def __init__(self, builder, lanes: int = 1):
        self.b = builder
        self.lanes = lanes
        self.ty = _F64 if lanes == 1 else ir.VectorType(_F64, lanes)
        self.zero = self.const(0.0)
        self._fabs = None

    def const(self, x: float):
        return ir.Constant(self.ty, x if self.lanes == 1 else [x] * self.lanes)

    def splat(self, x):
        """A float64 value on every lane."""
        return x if self.lanes == 1 else self.pack([x] * self.lanes)

    def pack(self, xs):
        """The lanes' float64 values as one vector."""
        if self.lanes == 1:
            return xs[0]
        v = ir.Constant(self.ty, None)
        for i, x in enumerate(xs):
            v = self.b.insert_element(v, x, ir.Constant(ir.IntType(32), i))
        return v

    def lane(self, v, i: int):
        return v if self.lanes == 1 else self.b.extract_element(v, ir.Constant(ir.IntType(32), i))

    def mul(self, a, c):
        return self.b.fmul(a, c, flags=_FLAGS)

    def add(self, a, c):
        return self.b.fadd(a, c, flags=_FLAGS)

    def sub(self, a, c):
        return self.b.fsub(a, c, flags=_FLAGS)

    def tree(self, v):
        """``tree_sum`` of the terms ``v`` (each a function building its value): ``((v0 + v1) + (v2 +
        v3))``, the first half one larger on an odd count. Each term is built where Python evaluates
        it in the source's expression, so the IR is in the source's order (x86's instruction
        scheduling follows that order, and with it the register pressure of a long block)."""
        if len(v) == 1:
            return v[0]()
        half = (len(v) + 1) // 2
        return self.add(self.tree(v[:half]), self.tree(v[half:]))

    def chain(self, v):
        """``chain_sum`` of the terms ``v`` (functions, as :meth:`tree`): ``(((v0 + v1) + v2) + v3)``."""
        acc = v[0]()
        for t in v[1:]:
            acc = self.add(acc, t())
        return acc

    def abs(self, a):
        if self._fabs is None:
            name = "llvm.fabs." + ("f64" if self.lanes == 1 else f"v{self.lanes}f64")
            self._fabs = cgutils.get_or_insert_function(
                self.b.module, ir.FunctionType(self.ty, [self.ty]), name
            )
        return self.b.call(self._fabs, [a])

    def amax(self, vals):
        """``max(max(abs(v0), abs(v1)), ...)`` as numba lowers it: ``select(v > acc, v, acc)``."""
        if not vals:
            return self.zero
        acc = self.abs(vals[0])
        for t in vals[1:]:
            v = self.abs(t)
            acc = self.b.select(self.b.fcmp_ordered(">", v, acc), v, acc)
        return acc


class _Mul:
    """A product ``a b`` not yet built: the sum that takes it as a term fuses it (:class:`_FOps`)."""

    __slots__ = ("a", "b")

    def __init__(self, a, b):
        self.a, self.b = a, b


class _FOps(_Ops):
    """:class:`_Ops` with the multiply-adds of the order bodies written as ``llvm.fmuladd`` calls.

    Why: with only the ``contract`` flag the back end chooses which ``fmul`` of a sum it fuses into
    the ``fadd`` (of ``a b + c d``: either ``fma(a, b, c d)`` or ``fma(c, d, a b)``), and it chose
    differently on the scalar body and on the vector body of the same sum (measured: the two-lane
    first pair's lanes and the single kernel apart by 1 ulp at some order on 125 of 2000 random
    Bianchi III + cocycle states; lane B of the pair 3.5e-13 from the single run at ``T = 40``). Here
    the IR fixes each fusion, the same for one lane or many: a sum's term that is a product (a
    :class:`_Mul`) is fused into the addition that takes it, the left one when both are; no ``fmul``
    is left as an operand of an ``fadd`` or ``fsub`` for the back end to fuse."""

    def fma(self, a, b, c):
        """``a b + c`` as ``llvm.fmuladd``: one rounding where the target has fast FMA (x86 with
        FMA3: every lane count alike), else a multiply and an add -- never a libm ``fma`` call
        (``llvm.fma`` on a target without FMA would be one)."""
        name = "llvm.fmuladd." + ("f64" if self.lanes == 1 else f"v{self.lanes}f64")
        fn = cgutils.get_or_insert_function(
            self.b.module, ir.FunctionType(self.ty, [self.ty] * 3), name
        )
        return self.b.call(fn, [a, b, c])

    def val(self, x):
        """The value of a term (a :class:`_Mul` built as its product)."""
        return self.mul(x.a, x.b) if isinstance(x, _Mul) else x

    def add2(self, x, y):
        """``x + y`` of two terms, a product among them fused (the left one when both are)."""
        if isinstance(x, _Mul):
            return self.fma(x.a, x.b, self.val(y))
        if isinstance(y, _Mul):
            return self.fma(y.a, y.b, x)
        return self.add(x, y)

    def ftree(self, v):
        """:meth:`_Ops.tree`'s sum (the same balanced tree) of terms that may be :class:`_Mul`; a
        single term is returned as it is (a :class:`_Mul` stays one)."""
        if len(v) == 1:
            return v[0]()
        half = (len(v) + 1) // 2
        return self.add2(self.ftree(v[:half]), self.ftree(v[half:]))

    def neg(self, x):
        """``-x`` (exact; of a product, the product of ``-a`` and ``b``)."""
        if isinstance(x, _Mul):
            return _Mul(self.sub(self.const(-0.0), x.a), x.b)
        return self.sub(self.const(-0.0), x)


def _coefficients(ops: _Ops, sp, y0, qv, lv, chain: bool) -> list:
    """The Taylor coefficients ``k = 1..P`` of the variable components, component ``vi``'s ``k`` at
    ``vi * P + k - 1`` (the recurrence of :mod:`refimpl._compiled_taylor`'s docstring,
    unrolled: a square sums half its terms twice, a constant factor keeps its ``k = 0`` term)."""
    d, P, mons, const, qptr, qmon, lptr, lidx = sp
    const = set(const)
    summ = ops.chain if chain else ops.tree
    y = {(c, 0): y0[c] for c in range(d)}

    def z(c, k):  # a constant component's coefficient k >= 1: zero, its terms dropped
        return k >= 1 and c in const

    def prod(i, a, j, b):  # the term y_{i,a} y_{j,b}, built when the sum reaches it
        return lambda: ops.mul(y[i, a], y[j, b])

    def scaled(c, v):
        return lambda: ops.mul(c, v)

    for k in range(P):
        m = []
        for i, j in mons:
            e = None
            if i == j:
                pairs = [(a, k - a) for a in range((k + 1) // 2) if not z(i, a) and not z(i, k - a)]
                if len(pairs) == 1:  # the source's 2.0*y_a*y_b: (2 y_a) y_b, no rounding in 2 y_a
                    (a, b), two = pairs[0], ops.const(2.0)
                    e = ops.mul(ops.mul(two, y[i, a]), y[i, b])
                elif pairs:
                    e = ops.mul(ops.const(2.0), summ([prod(i, a, i, b) for a, b in pairs]))
                if k % 2 == 0 and not z(i, k // 2):
                    sq = ops.mul(y[i, k // 2], y[i, k // 2])
                    e = sq if e is None else ops.add(e, sq)
            else:
                pairs = [(a, k - a) for a in range(k + 1) if not z(i, a) and not z(j, k - a)]
                if pairs:
                    e = summ([prod(i, a, j, b) for a, b in pairs])
            m.append(ops.zero if e is None else e)
        inv = ops.const(1.0 / (k + 1))
        for c in range(d):
            if c in const:
                continue
            terms = [scaled(qv[t], m[qmon[t]]) for t in range(qptr[c], qptr[c + 1])]
            terms += [
                scaled(lv[t], y[lidx[t], k])
                for t in range(lptr[c], lptr[c + 1])
                if not z(lidx[t], k)
            ]
            y[c, k + 1] = ops.mul(summ(terms), inv) if terms else ops.zero
    return [y[c, k] for c in variable_components(sp) for k in range(1, P + 1)]


def _fops(builder, lanes: int = 1):
    """The fused operations of :class:`_FOps` (every multiply-add an explicit ``llvm.fmuladd``, the
    same fusions on any lane count) on ``lanes`` float64. The kernels built here depend on them: a
    change to ``_FOps``'s operations changes both emitters' IR, so it bumps :data:`IR_VERSION` and
    :data:`refimpl.codegen._full_state_ir.IR_VERSION` (each generated module's cache key names its
    emitter's version only)."""
    return _FOps(builder, lanes)


def _kind(sp, m: int) -> tuple:
    """What decides the shape of monomial ``m``'s Cauchy-product sum at every order: square or not,
    and which factors are constant (their terms ``k >= 1`` dropped)."""
    i, j = sp[2][m]
    const = set(sp[3])
    return (i == j, i in const, j in const)


def pack_groups(sp, R: int, width: int) -> list[tuple[int, ...]]:
    """The monomials in packs of ``max(1, width // R)`` of one :func:`_kind` each (in the monomial order,
    the last pack of a kind possibly shorter): one pack's Cauchy products are one vector of
    ``len(pack) R`` lanes (monomial ``g[q]``'s run ``r`` on lane ``q R + r``)."""
    G = max(1, width // R)
    by: dict[tuple, list[int]] = {}
    for m in range(len(sp[2])):
        by.setdefault(_kind(sp, m), []).append(m)
    return [tuple(ms[s : s + G]) for ms in by.values() for s in range(0, len(ms), G)]


def _mask(idx):
    return ir.Constant(ir.VectorType(ir.IntType(32), len(idx)), list(idx))


def _concat(b, vs, R: int):
    """The vectors ``vs`` of ``R`` lanes each, end to end, as one vector (shuffles only)."""
    if len(vs) == 1:
        return vs[0]
    if len(vs) == 2:
        return b.shuffle_vector(vs[0], vs[1], _mask(range(2 * R)))
    h = (len(vs) + 1) // 2
    lo, hi = _concat(b, vs[:h], R), _concat(b, vs[h:], R)
    nl, nh = h * R, (len(vs) - h) * R
    if nh < nl:  # widen the shorter half to the longer one's lanes (undefined lanes dropped below)
        hi = b.shuffle_vector(hi, ir.Constant(hi.type, None), _mask(range(nl)))
    return b.shuffle_vector(lo, hi, _mask([*range(nl), *range(nl, nl + nh)]))


def _part(b, v, q: int, R: int, n: int):
    """Lanes ``q R .. q R + R - 1`` of ``v`` (``n R`` lanes): one value, or ``v`` itself when whole."""
    if n == 1:
        return v
    if R == 1:
        return b.extract_element(v, ir.Constant(ir.IntType(32), q))
    return b.shuffle_vector(v, ir.Constant(v.type, None), _mask(range(q * R, q * R + R)))


def _coefficients_packed(ops, sp, y0, qv, lv, R: int, width: int) -> list:
    """:func:`_coefficients` (the same recurrence) with the Cauchy products of :func:`pack_groups`'s
    packs computed side by side, one lane per monomial and run (``R`` runs: the lanes of ``ops``).

    Each lane's operations are those of the one-monomial sum whatever the pack, so a run's
    coefficients are the same, bit for bit, at any ``R`` and in any pack: every multiply-add is an
    explicit ``llvm.fmuladd`` (``ops`` and the packs' operations are :func:`_fops`'s; with only the
    ``contract`` flag the back end may fuse a scalar and a vector body differently). A product's sum
    is a chain, ``a = 0..k`` in order (one fused multiply-add per term: the packs and the components
    supply the independent work a balanced tree would expose; rounding ``(m - 1) eps`` relative to the
    sum of magnitudes, Higham 2002, section 4.2); a square sums its ``a < k - a`` terms so and doubles
    them (exact), its middle term fused into that; the components' sums stay balanced trees
    (:meth:`_Ops.tree`'s order), their products fused as :class:`_FOps`
    does. A pack's factors of order ``a`` are gathered into one vector once, when first used (each
    serves every order ``k >= a``); the products are then taken apart for the components' sums."""
    d, P, mons, const, qptr, qmon, lptr, lidx = sp
    const = set(const)
    b = ops.b
    y = {(c, 0): y0[c] for c in range(d)}
    wide: dict[int, object] = {}

    def wops(n):
        if n not in wide:
            wide[n] = _fops(b, n)
        return wide[n]

    def z(c, k):
        return k >= 1 and c in const

    packs = pack_groups(sp, R, width)
    fac: dict[tuple, object] = {}

    def factor(g, side, a):  # the pack's factors (side 0: i, 1: j) of order a, one vector
        comps = tuple(mons[m][side] for m in packs[g])
        key = (comps, a)  # packs with the same components on a side share that vector
        if key not in fac:
            vs = [y[c, a] for c in comps]
            if R == 1:
                fac[key] = wops(len(vs)).pack(vs)
            else:
                fac[key] = _concat(b, vs, R)
        return fac[key]

    def mulf(g, a, side_b, bb):
        return lambda: _Mul(factor(g, 0, a), factor(g, side_b, bb))

    def chain(w, terms):  # ((t0 + t1) + t2) + ...: the first product, then one fused step per term
        acc = terms[0]()
        for t in terms[1:]:
            x = t()
            acc = w.fma(x.a, x.b, w.val(acc))
        return acc

    for k in range(P):
        mv = [None] * len(mons)
        for g, pack in enumerate(packs):
            w = wops(len(pack) * R)
            i, j = mons[pack[0]]
            e = None
            if i == j:
                pairs = [(a, k - a) for a in range((k + 1) // 2) if not z(i, a) and not z(i, k - a)]
                if len(pairs) == 1:  # (2 y_a) y_b: no rounding in 2 y_a
                    ((a, bb),) = pairs
                    e = _Mul(w.mul(w.const(2.0), factor(g, 0, a)), factor(g, 0, bb))
                elif pairs:
                    e = _Mul(w.const(2.0), w.val(chain(w, [mulf(g, a, 0, bb) for a, bb in pairs])))
                if k % 2 == 0 and not z(i, k // 2):
                    sq = _Mul(factor(g, 0, k // 2), factor(g, 0, k // 2))
                    e = sq if e is None else w.add2(e, sq)
            else:
                pairs = [(a, k - a) for a in range(k + 1) if not z(i, a) and not z(j, k - a)]
                if pairs:
                    e = chain(w, [mulf(g, a, 1, bb) for a, bb in pairs])
            if e is None:
                for m in pack:
                    mv[m] = ops.zero
                continue
            v = w.val(e)
            for q, m in enumerate(pack):
                mv[m] = _part(b, v, q, R, len(pack))
        inv = ops.const(1.0 / (k + 1))
        for c in range(d):
            if c in const:
                continue
            terms = [(lambda t=t: _Mul(qv[t], mv[qmon[t]])) for t in range(qptr[c], qptr[c + 1])]
            terms += [
                (lambda t=t: _Mul(lv[t], y[lidx[t], k]))
                for t in range(lptr[c], lptr[c + 1])
                if not z(lidx[t], k)
            ]
            y[c, k + 1] = ops.mul(ops.val(ops.ftree(terms)), inv) if terms else ops.zero
    return [y[c, k] for c in variable_components(sp) for k in range(1, P + 1)]


def _norms(ops: _Ops, sp, y0, C) -> list:
    """``max|y_0|``, ``max|y_{P-1}|``, ``max|y_P|`` (the step size's inputs) of the state ``y0`` and
    the coefficients ``C`` of :func:`_coefficients`."""
    P, nv = sp[1], len(variable_components(sp))
    return [
        ops.amax(list(y0)),
        ops.amax(
            [C[vi * P + P - 2] if P > 1 else y0[c] for vi, c in enumerate(variable_components(sp))]
        ),
        ops.amax([C[vi * P + P - 1] for vi in range(nv)]),
    ]


def _update_one(ops: _Ops, y, e, coef, P: int, hs):
    """One component's ``y + sum_{k>=1} Y_k hs^k``: the increment by Horner's rule, added with
    Kahan's compensated summation (carry ``e``). ``coef(k)`` builds ``Y_k`` (``k = 1..P``), ``y()`` and
    ``e()`` the state and the carry, each where the source's expression reads it (the IR in the
    source's order: see :meth:`_Ops.tree`). Returns ``(y, e)`` new."""
    inc = coef(P)
    for k in range(P - 1, 0, -1):
        inc = ops.add(ops.mul(inc, hs), coef(k))
    zz = ops.sub(ops.mul(inc, hs), e())
    y0 = y()
    w = ops.add(y0, zz)
    return w, ops.sub(ops.sub(w, y0), zz)


def _update(ops: _Ops, sp, y0, e0, C, hs):
    """:func:`_update_one` on every variable component (coefficients ``C`` as
    :func:`_coefficients` lays them out). Returns the new state and carries."""
    P = sp[1]
    y, e = list(y0), list(e0)
    for vi, c in enumerate(variable_components(sp)):
        y[c], e[vi] = _update_one(
            ops,
            lambda c=c: y[c],
            lambda vi=vi: e[vi],
            lambda k, vi=vi: C[vi * P + k - 1],
            P,
            hs,
        )
    return y, e


def _unpack(builder, tup, n):
    return [builder.extract_value(tup, i) for i in range(n)]


def _check_floats(name, *tys):
    for ty in tys:
        if not isinstance(ty, types.BaseTuple) or any(t != types.float64 for t in ty.types):
            raise TypeError(f"{name}: expects tuples of float64, got {ty}")


def coefficients_intrinsic(sp, width: int):
    """The intrinsic ``C = coefficients(Y, Q, L)``: ``Y`` the state (``d`` floats), ``Q`` and ``L`` the
    field's quadratic and linear numbers (``cf.qcoef``, ``cf.lcoef`` as tuples); ``C`` the
    ``nv * P + 3`` floats of :func:`_coefficients` (component ``vi``'s coefficient ``k`` at
    ``vi * P + k - 1``) and the three norms of :func:`_norms`, computed as
    :func:`_coefficients_packed` computes them (the Cauchy products in packs of ``width`` lanes)."""
    d, P = sp[0], sp[1]
    nq, nl = len(sp[5]), len(sp[7])
    nout = len(variable_components(sp)) * P + 3

    @intrinsic
    def coefficients(typingctx, Y, Q, L):
        _check_floats("coefficients", Y, Q, L)
        ret = types.UniTuple(types.float64, nout)

        def codegen(context, builder, sig, args):
            y, q, l = args
            ops, y0 = _fops(builder), _unpack(builder, y, d)
            qv, lv = _unpack(builder, q, nq), _unpack(builder, l, nl)
            C = _coefficients_packed(ops, sp, y0, qv, lv, 1, width)
            return context.make_tuple(builder, ret, C + _norms(ops, sp, y0, C))

        return ret(Y, Q, L), codegen

    return coefficients


def update_intrinsic(sp):
    """The intrinsic ``Y, E = update(Y, E, C, hs)`` (:func:`_update`): the state after a step ``hs``
    from the coefficients ``C`` of :func:`coefficients_intrinsic`, and the new Kahan carries ``E``
    (one per variable component)."""
    d, P = sp[0], sp[1]
    nv = len(variable_components(sp))
    nc = nv * P + 3

    @intrinsic
    def update(typingctx, Y, E, C, hs):
        _check_floats("update", Y, E, C)
        ty, te = types.UniTuple(types.float64, d), types.UniTuple(types.float64, nv)
        ret = types.Tuple((ty, te))

        def codegen(context, builder, sig, args):
            y, e, c, h = args
            h = context.cast(builder, h, sig.args[3], types.float64)
            yn, en = _update(
                _Ops(builder),
                sp,
                _unpack(builder, y, d),
                _unpack(builder, e, nv),
                _unpack(builder, c, nc),
                h,
            )
            return context.make_tuple(
                builder,
                ret,
                [context.make_tuple(builder, ty, yn), context.make_tuple(builder, te, en)],
            )

        return ret(Y, E, C, types.float64), codegen

    return update


def lanes_coefficients_intrinsic(sp, W: int, width: int):
    """The intrinsic ``C = coefficients(Y, Q, L)`` of :func:`coefficients_intrinsic` on ``W``
    trajectories at once, one per lane of a vector (the pair kernel: the checking run and the answer
    side by side). ``Y``: ``W d`` floats, trajectory ``i``'s state at ``Y[i d:(i + 1) d]``; ``C``:
    trajectory ``i``'s coefficients at ``i nv P + vi P + k - 1``, then the three norms of each
    trajectory in turn (from ``W nv P``). Each lane's values are the one-trajectory intrinsic's, bit
    for bit (:func:`_coefficients_packed` with ``R = W`` runs, packs of ``width`` lanes)."""
    d, P = sp[0], sp[1]
    nq, nl = len(sp[5]), len(sp[7])
    n1 = len(variable_components(sp)) * P

    @intrinsic
    def coefficients(typingctx, Y, Q, L):
        _check_floats("coefficients", Y, Q, L)
        ret = types.UniTuple(types.float64, W * (n1 + 3))

        def codegen(context, builder, sig, args):
            ops = _fops(builder, W)
            ys = _unpack(builder, args[0], W * d)
            y0 = [ops.pack([ys[i * d + c] for i in range(W)]) for c in range(d)]
            qv = [ops.splat(v) for v in _unpack(builder, args[1], nq)]
            lv = [ops.splat(v) for v in _unpack(builder, args[2], nl)]
            C = _coefficients_packed(ops, sp, y0, qv, lv, W, width)
            norms = _norms(ops, sp, y0, C)
            out = [ops.lane(v, i) for i in range(W) for v in C]
            out += [ops.lane(v, i) for i in range(W) for v in norms]
            return context.make_tuple(builder, ret, out)

        return ret(Y, Q, L), codegen

    return coefficients


def lanes_update_intrinsic(sp, W: int):
    """The intrinsic ``Y, E = update(Y, E, C, H)`` of :func:`update_intrinsic` on ``W`` lanes (the
    layout of :func:`lanes_coefficients_intrinsic`; ``E``: trajectory ``i``'s carries at
    ``i nv .. (i + 1) nv``; ``H``: the ``W`` steps). A lane whose step is 0 keeps its state and
    carries (a trajectory already at its end, or failed, while another lane goes on)."""
    d, P = sp[0], sp[1]
    var = variable_components(sp)
    nv = len(var)
    n1 = nv * P

    @intrinsic
    def update(typingctx, Y, E, C, H):
        _check_floats("update", Y, E, C, H)
        ty, te = types.UniTuple(types.float64, W * d), types.UniTuple(types.float64, W * nv)
        ret = types.Tuple((ty, te))

        def codegen(context, builder, sig, args):
            ops = _Ops(builder, W)
            ys = _unpack(builder, args[0], W * d)
            es = _unpack(builder, args[1], W * nv)
            cs = _unpack(builder, args[2], W * (n1 + 3))
            h = ops.pack(_unpack(builder, args[3], W))
            idle = builder.fcmp_ordered("==", h, ops.zero)
            y0 = [ops.pack([ys[i * d + c] for i in range(W)]) for c in range(d)]
            e0 = [ops.pack([es[i * nv + vi] for i in range(W)]) for vi in range(nv)]
            C = [ops.pack([cs[i * n1 + r] for i in range(W)]) for r in range(n1)]
            yn, en = _update(ops, sp, y0, e0, C, h)
            yn = [builder.select(idle, a, b) for a, b in zip(y0, yn)]
            en = [builder.select(idle, a, b) for a, b in zip(e0, en)]
            return context.make_tuple(
                builder,
                ret,
                [
                    context.make_tuple(builder, ty, [ops.lane(v, i) for i in range(W) for v in yn]),
                    context.make_tuple(builder, te, [ops.lane(v, i) for i in range(W) for v in en]),
                ],
            )

        return ret(Y, E, C, H), codegen

    return update


def _check_lanes(name, B):
    if not (isinstance(B, types.Array) and B.ndim == 1 and B.dtype == types.float64):
        raise TypeError(f"{name}: expects a 1-d float64 array, got {B}")


def _rows_ptr(context, builder, aryty, ary, W: int):
    """``row -> &B[row * W : (row + 1) * W]`` as a pointer to one vector of ``W`` float64 (the flat
    float64 array ``B`` of the batch kernel; no bounds check: it is allocated with every row)."""
    data = context.make_array(aryty)(context, builder, ary).data
    vptr = ir.PointerType(ir.VectorType(_F64, W))

    def ptr(row):
        p = builder.gep(data, [ir.Constant(ir.IntType(64), row * W)], inbounds=True)
        return builder.bitcast(p, vptr)

    return ptr


def rows_coefficients_intrinsic(sp, W: int, RY: int, RC: int):
    """The intrinsic ``rows_coefficients(B, Q, L)``: :func:`_coefficients` (chain sums) on the ``W``
    lanes of the batch kernel's rows at once, each row of ``B`` one vector of ``W`` float64 (each
    lane's operations element by element): the state read from ``B[(RY + c) W : (RY + c + 1) W]``,
    the coefficients written from row ``RC`` in the order of :func:`coefficients_intrinsic`, then
    the three norms after them (computed after the coefficients are stored: computed before, with
    every coefficient still live, the lanes' code spilled more, 6-9 % slower on the heavy top's
    batch, measured on the former per-lane form)."""
    d = sp[0]
    nq, nl = len(sp[5]), len(sp[7])

    @intrinsic
    def rows_coefficients(typingctx, B, Q, L):
        _check_lanes("rows_coefficients", B)
        _check_floats("rows_coefficients", Q, L)

        def codegen(context, builder, sig, args):
            ops = _Ops(builder, W)
            at = _rows_ptr(context, builder, sig.args[0], args[0], W)
            y0 = [builder.load(at(RY + c), align=8) for c in range(d)]
            qv = [ops.splat(v) for v in _unpack(builder, args[1], nq)]
            lv = [ops.splat(v) for v in _unpack(builder, args[2], nl)]
            C = _coefficients(ops, sp, y0, qv, lv, True)
            for r, v in enumerate(C):
                builder.store(v, at(RC + r), align=8)
            for r, v in enumerate(_norms(ops, sp, y0, C)):
                builder.store(v, at(RC + len(C) + r), align=8)
            return context.get_dummy_value()

        return types.none(B, Q, L), codegen

    return rows_coefficients


def rows_update_intrinsic(sp, W: int, RY: int, RE: int, RC: int, RH: int):
    """The intrinsic ``rows_update(B)``: :func:`_update` on the ``W`` lanes of the batch kernel's rows
    at once (state rows from ``RY``, carries from ``RE``, coefficients from ``RC`` in the order of
    :func:`coefficients_intrinsic`, the lanes' signed steps in row ``RH``: 0 on an idle or failed
    lane, which keeps its state), each component loaded, updated and stored in turn (all loaded
    first, the lanes' code spilled more: 8 % slower on the heavy top, measured on the former
    per-lane form)."""
    P = sp[1]
    var = variable_components(sp)

    @intrinsic
    def rows_update(typingctx, B):
        _check_lanes("rows_update", B)

        def codegen(context, builder, sig, args):
            ops = _Ops(builder, W)
            at = _rows_ptr(context, builder, sig.args[0], args[0], W)
            h = builder.load(at(RH), align=8)
            for vi, c in enumerate(var):
                y, e = _update_one(
                    ops,
                    lambda c=c: builder.load(at(RY + c), align=8),
                    lambda c=c: builder.load(at(RE + c), align=8),
                    lambda k, vi=vi: builder.load(at(RC + vi * P + k - 1), align=8),
                    P,
                    h,
                )
                builder.store(e, at(RE + c), align=8)
                builder.store(y, at(RY + c), align=8)
            return context.get_dummy_value()

        return types.none(B), codegen

    return rows_update
