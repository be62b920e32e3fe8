"""One order of the full-state kernels' recurrence as LLVM IR, built by numba intrinsics.

Why IR (issue 25, the compile time of :func:`refimpl.codegen.full_state.full_state_source`'s kernel):
numba's front end types and lowers every statement of a function on its own, and the per-order body
of the full state is hundreds of them (su(3): 26 derived rows, 140 Cauchy products in chunk loops,
26 state rows): measured on free su(3), empty caches, 3.6 s of CPU, of which type inference 2.0 s
(1.2 s of it the product helpers'), lowering 1.0 s, LLVM about 0.8 s. The intrinsic ``_order(V, k,
C)`` is one call for the front end; its ``codegen`` writes the order-``k`` body straight into the
kernel's LLVM function, the operations of the former Python source in its evaluation order, each
multiply-add that the ``contract`` flag let the back end fuse written as an ``llvm.fmuladd``
(:class:`_FOps`: the same fusions on one lane and on many, so the pair kernel's lanes are the single
kernel's runs bitwise):

* the derived rows ``V[r, k] = sum_t C[ci_t] V[s_t, k]`` (``Omega_k``, then ``M_k``), sums as the
  balanced trees of :func:`refimpl.codegen.taylor.tree_sum`;
* the general Cauchy products ``p = sum_{a=0..k} V[u, a] V[w, k - a]``, side by side in loops over
  ``a`` of at most :data:`refimpl.codegen.full_state.PRODUCT_CHUNK` products (each accumulated in the
  order ``a = 0..k``; each distinct factor loaded once per ``a``);
  In the single kernel and the pair kernel the general products are packed into vectors
  (:func:`pack_plan`, :func:`_packed_products`): ``W`` products (the pair kernel: ``W / 2`` products
  on its two runs' lanes) per vector, their factors' coefficients packed into operand buffers ``B``
  as each order's become known, each lane the same chain ``acc = fmuladd(u[a], w[k - a], acc)``,
  ``a = 0..k``, as the scalar loop (bitwise: end states hash-identical to the scalar chunks' on the
  bench structures and the sweep's), one vector multiply-add for ``W`` products;
* the products with a constant factor (``k``-th coefficient times the other's ``0``-th; both
  constant: their product at ``k = 0``, else 0);
* the state rows ``V[v, k + 1] = (sum of terms) * (1 / (k + 1))``, terms ``p``, ``-p``, ``C[ci] p``,
  ``C[ci] V[u, k]`` and, for a constant ``u``, ``C[ci] V[u, 0]`` at ``k = 0`` (else 0).

The field's numbers ``C`` travel as a tuple of float64 read once per call by ``_load(c)``
(:func:`load_intrinsic`): loaded from the array inside the order, LLVM could not keep them in
registers across the stores into ``V`` (it cannot tell the two arrays apart).

The same body on vectors of lanes (:func:`lanes_order_intrinsic`: the generated lane kernel of
:mod:`refimpl.codegen.full_state_batch`, and the one-trajectory first pair, A and B on two lanes, of
:func:`refimpl.codegen.full_state.pair_lines`), the single kernel's Horner update
(:func:`update_intrinsic`), and the order bodies of the two kernels compiled for every structure,
the tables read at run time: :func:`packed_order` (:func:`refimpl._full_state_batch.adaptive_packed`)
and :func:`rational_order` (:func:`refimpl._full_state_rational_kernel.adaptive`, ``Upsilon != 0``).

The generated module names :data:`IR_VERSION` (numba's disk cache keys on the generated file's text,
not on this module, so a change of the IR built here must change that text; the two fixed kernels
name it in a comment of their own file, which is their cache key).
"""

from __future__ import annotations

try:  # only the generated kernels use the intrinsics
    import llvmlite.ir as ir
    from numba import types
    from numba.core import cgutils
    from numba.extending import intrinsic
except ImportError:  # pragma: no cover - exercised only where numba is missing
    ir = types = cgutils = intrinsic = None

from ._taylor_ir import _F64, _FOps, _Mul, _Ops, _unpack

__all__ = [
    "IR_VERSION",
    "lane_update_intrinsic",
    "lanes_order_intrinsic",
    "load_intrinsic",
    "order_intrinsic",
    "pack_plan",
    "pack_streams",
    "packed_order",
    "rational_order",
    "update_intrinsic",
]

IR_VERSION = "5"

# the kinds of a state row's term (the spec's ``(kind, ci, x)``; ``x`` a product or a row)
PLUS, MINUS, SCALED, LIN_CONST, LIN = range(5)
# the classes of a product with a constant factor (the spec's ``(p, u, w, cls)``)
U_CONST, W_CONST, BOTH_CONST = 1, 2, 3


def _check_array(name, V, ndim):
    if not (
        isinstance(V, types.Array)
        and V.ndim == ndim
        and V.dtype == types.float64
        and V.layout == "C"
    ):
        raise TypeError(f"{name}: expects a C-contiguous {ndim}-d float64 array, got {V}")


def load_intrinsic(ncoef: int):
    """The intrinsic ``C = load(c)``: the first ``ncoef`` floats of the 1-d array ``c`` as a tuple
    (the caller checks ``c`` has them)."""

    @intrinsic
    def load(typingctx, c):
        _check_array("load", c, 1)
        ret = types.UniTuple(types.float64, ncoef)

        def codegen(context, builder, sig, args):
            data = context.make_array(sig.args[0])(context, builder, args[0]).data
            vals = [
                builder.load(builder.gep(data, [ir.Constant(ir.IntType(64), i)], inbounds=True))
                for i in range(ncoef)
            ]
            return context.make_tuple(builder, ret, vals)

        return ret(c), codegen

    return load


def _packer(context, builder, sig, args, plan, Q: int, W: int, load_col):
    """``packed_at(kk, kp1)``: :func:`_order_body`'s ``packed`` hook at order ``kk`` (None where
    ``plan`` is None: no packing), the general products ``Q`` to a vector of ``Q W`` lanes
    (:class:`_Pack`) from the packed operand buffers ``B`` (the intrinsic's second argument);
    ``load_col(row, col)``: a row's value (or lanes) at the order ``col``. The one hook of the single
    and the lane bodies, which differ only in addressing and vector shape."""
    if plan is None:
        return lambda kk, kp1: None
    pk = _Pack(builder, Q, W)
    bat = _buffer_at(context, builder, sig.args[1], args[1], pk.ops.ty)

    def packed_at(kk, kp1):
        def packed(prod, fresh):
            _packed_products(builder, pk, plan, kk, kp1, load_col, fresh, bat, prod)

        return packed

    return packed_at


def _order_of(codegen, ncoef: int, ndim: int, packed: bool):
    """The intrinsic of ``codegen`` with its argument checks: ``order(V, k, C)``, or ``order(V, B, k,
    C)`` where the products are ``packed`` (``B`` the packed factor streams, 3-d); ``V`` ``ndim``-d
    (2: one trajectory, 3: lanes)."""
    if not packed:

        @intrinsic
        def order(typingctx, V, k, C):
            _check_order_args(V, k, C, ncoef, ndim)
            return types.none(V, k, C), codegen

        return order

    @intrinsic
    def order(typingctx, V, B, k, C):
        _check_order_args(V, k, C, ncoef, ndim)
        _check_array("order", B, 3)
        return types.none(V, B, k, C), codegen

    return order


def _check_order_args(V, k, C, ncoef: int, ndim: int) -> None:
    _check_array("order", V, ndim)
    if not (
        isinstance(k, types.Integer)
        and isinstance(C, types.BaseTuple)
        and len(C) == ncoef
        and all(t == types.float64 for t in C.types)
    ):
        raise TypeError(f"order: expects (V, int, {ncoef} float64), got ({V}, {k}, {C})")


def pack_plan(chunks, W: int, per_loop: int):
    """The general products ``chunks`` (``((p, u, w), ...)`` per chunk, as the spec's) packed into
    vectors of ``W`` lanes for :func:`order_intrinsic`: ``(loops, streams)``. ``streams``: the
    distinct lane tuples of factor rows ``(r_0, .., r_{W-1})`` that are not one row on every lane,
    each a packed operand buffer ``B[s, a, lane] = V[r_lane, a]``; ``loops``: the groups in loops of at
    most ``per_loop`` groups, a group ``(ps, su, sw)`` with ``ps`` its products (``None`` on a padding
    lane) and ``su``, ``sw`` its factors as ``("s", stream)`` or ``("r", row)`` (one row broadcast).
    The products in the spec's order (sorted by their second factor: groups of one ``w`` broadcast it),
    ``W`` consecutive ones a group; padding lanes repeat the group's first product's factors. From the
    structure only (deterministic)."""
    prods = [t for ch in chunks for t in ch]
    streams: dict[tuple, int] = {}

    def operand(rows):
        if all(r == rows[0] for r in rows):
            return ("r", rows[0])
        return ("s", streams.setdefault(rows, len(streams)))

    groups = []
    for g0 in range(0, len(prods), W):
        grp = prods[g0 : g0 + W]
        pad = [grp[0]] * (W - len(grp))
        us = tuple(u for _, u, _ in grp + pad)
        ws = tuple(w for _, _, w in grp + pad)
        ps = tuple(p for p, _, _ in grp) + (None,) * len(pad)
        groups.append((ps, operand(us), operand(ws)))
    nloop = -(-len(groups) // per_loop)  # the fewest loops of at most per_loop, sizes within one
    cuts = [len(groups) * i // max(nloop, 1) for i in range(nloop + 1)]
    loops = [tuple(groups[cuts[i] : cuts[i + 1]]) for i in range(nloop)]
    inv = sorted(streams, key=streams.get)
    return tuple(loops), tuple(inv)


class _Pack:
    """Vectors of ``Q`` products on ``L`` lanes each (``W = Q L`` float64, the lane of product ``j``
    and run ``l`` at ``j L + l``; ``L = 1``: the single kernel's scalars, ``L = 2``: the pair kernel's
    two runs), built from and taken apart into the order body's values (a float64 for ``L = 1``,
    else a vector of ``L``)."""

    def __init__(self, builder, Q: int, L: int):
        if Q & (Q - 1):
            raise ValueError(f"pack: Q must be a power of two, got {Q}")
        self.b, self.Q, self.L = builder, Q, L
        self.ops = _FOps(builder, Q * L)
        i32 = ir.IntType(32)
        self.idx = [ir.Constant(i32, i) for i in range(Q * L)]

    def pack(self, xs):
        """The vector of the ``Q`` values ``xs`` (each ``L`` lanes; ``L > 1``: joined by shuffles)."""
        if self.L == 1:
            v = ir.Constant(self.ops.ty, None)
            for j, x in enumerate(xs):
                v = self.b.insert_element(v, x, self.idx[j])
            return v
        while len(xs) > 1:  # pairwise joins: 2 L lanes, 4 L, ... (Q a power of two)
            n = 2 * xs[0].type.count
            mask = ir.Constant(ir.VectorType(ir.IntType(32), n), list(range(n)))
            xs = [self.b.shuffle_vector(a, c, mask) for a, c in zip(xs[::2], xs[1::2])]
        return xs[0]

    def part(self, v, j):
        """Product ``j``'s ``L`` lanes of the vector ``v``."""
        if self.L == 1:
            return self.b.extract_element(v, self.idx[j])
        mask = ir.Constant(
            ir.VectorType(ir.IntType(32), self.L), list(range(j * self.L, (j + 1) * self.L))
        )
        return self.b.shuffle_vector(v, ir.Constant(v.type, None), mask)


def _packed_products(builder, pk, plan, kk, kp1, row_at, fresh, bat, prod) -> None:
    """The general products of one order as vectors of products (:func:`pack_plan`, :class:`_Pack`
    ``pk``): the order-``k`` coefficients of every stream's rows packed into ``B[s, k]``, then per
    loop of groups ``acc_g = fmuladd(U_g[a], W_g[k - a], acc_g)`` for ``a = 0..k`` from ``0.0`` (the
    term ``a = 0`` before the loop, its order-``k`` operand from registers) -- on each lane the
    scalar chain of the chunk loop (same operands, same order, same fusions: bitwise its sum), one
    vector load (or one broadcast row) per operand and ``a``. ``row_at(row, col)``: the value
    ``V[row, col]`` (``L`` lanes) loaded; ``fresh``: the rows' values of order ``k`` computed in this
    order (used instead of loads); ``bat(s, col)``: the vector pointer ``&B[s, col, :]``; the sums
    go to ``prod[p]``."""
    loops, streams = plan
    ops = pk.ops
    seen = dict(fresh)
    packed_k = {}
    for s, rows in enumerate(streams):
        vals = []
        for r in rows:
            if r not in seen:
                seen[r] = row_at(r, kk)
            vals.append(seen[r])
        packed_k[s] = pk.pack(vals)
        builder.store(packed_k[s], bat(s, kk), align=8)
    zero = ir.Constant(ir.IntType(64), 0)

    def at_k(op):  # an operand's order-k vector
        kind, x = op
        if kind == "s":
            return packed_k[x]
        if x not in seen:
            seen[x] = row_at(x, kk)
        return pk.pack([seen[x]] * pk.Q)

    def get(cache, op, col, key):
        if (key, op) not in cache:
            kind, x = op
            if kind == "s":
                cache[(key, op)] = builder.load(bat(x, col), align=8)
            else:
                cache[(key, op)] = pk.pack([row_at(x, col)] * pk.Q)
        return cache[(key, op)]

    for loop_groups in loops:
        c0: dict = {}
        accs = [
            cgutils.alloca_once_value(builder, ops.fma(get(c0, su, zero, "a"), at_k(sw), ops.zero))
            for _, su, sw in loop_groups
        ]
        with cgutils.for_range(builder, kp1, start=ir.Constant(ir.IntType(64), 1)) as loop:
            ia = loop.index
            ib = builder.sub(kk, ia)
            cache: dict = {}
            for (_, su, sw), acc in zip(loop_groups, accs):
                u, w = get(cache, su, ia, "a"), get(cache, sw, ib, "b")
                builder.store(ops.fma(u, w, builder.load(acc)), acc)
        for (ps, _, _), acc in zip(loop_groups, accs):
            v = builder.load(acc)
            for j, p in enumerate(ps):
                if p is not None:
                    prod[p] = pk.part(v, j)


def _order_body(
    builder, ops, c, sp, kk, kp1, handle, load, store, preload: bool, packed=None, carry=None
) -> dict:
    """The IR of one order ``k`` of the recurrence, the one body of :func:`order_intrinsic` (one
    trajectory) and :func:`lanes_order_intrinsic` (``W`` lanes): they differ only in addressing and
    share every operation and its order, which keeps a lane bitwise the single kernel's run.
    ``handle(kv)``: the address base of order ``kv``; ``load(row, h)`` / ``store(value, row, h)``: a
    row's value (or vector of lanes) at order base ``h``; ``c``: the coefficients (splat on lanes).
    ``preload``: a chunk's factors all loaded before its multiply-adds (else each as first needed;
    the loads' order only, not the arithmetic). ``carry``: the state rows' values of order ``k``
    already in registers (used instead of loads). Returns the state rows' values of order ``k + 1``
    (also stored)."""
    _, derived, chunks, consts, state = sp
    zero = ir.Constant(ir.IntType(64), 0)  # order 0: column 0, offset 0
    hk, hk1 = handle(kk), handle(kp1)
    # derived rows: Omega_k, then M_k
    # the values of order k in registers (carried state rows; derived rows once computed): used
    # where they are read again, not loaded
    fresh = dict(carry or {})

    def kval(row):  # V[row, k]
        return fresh[row] if row in fresh else load(row, hk)

    for row, terms in derived:
        v = ops.ftree([lambda ci=ci, s=s: _Mul(c[ci], kval(s)) for ci, s in terms])
        fresh[row] = ops.val(v)
        store(fresh[row], row, hk)
    # general products, a loop over a per chunk, each distinct factor loaded once per a (or packed
    # in vectors of products: packed(prod))
    prod: dict[int, object] = {}
    if packed is not None:
        packed(prod, fresh)
        chunks = ()
    for chunk in chunks:
        accs = [cgutils.alloca_once_value(builder, ops.zero) for _ in chunk]
        with cgutils.for_range(builder, kp1) as loop:
            ha = handle(loop.index)
            hb = handle(builder.sub(kk, loop.index))
            fu, fw = {}, {}
            if preload:
                for _, u, w in chunk:
                    fu.setdefault(u, None)
                    fw.setdefault(w, None)
                for u in fu:
                    fu[u] = load(u, ha)
                for w in fw:
                    fw[w] = load(w, hb)
            for (_, u, w), acc in zip(chunk, accs):
                if fu.get(u) is None:
                    fu[u] = load(u, ha)
                if fw.get(w) is None:
                    fw[w] = load(w, hb)
                builder.store(ops.fma(fu[u], fw[w], builder.load(acc)), acc)
        for (p, _, _), acc in zip(chunk, accs):
            prod[p] = builder.load(acc)
    # products with a constant factor
    is0 = builder.icmp_signed("==", kk, zero)
    for p, u, w, cls in consts:
        if cls == BOTH_CONST:
            prod[p] = builder.select(is0, ops.mul(load(u, zero), load(w, zero)), ops.zero)
        elif cls == U_CONST:
            prod[p] = _Mul(load(u, zero), kval(w))
        else:
            prod[p] = _Mul(kval(u), load(w, zero))
    ik = ops.splat(  # 1.0 / (k + 1)
        builder.fdiv(ir.Constant(_F64, 1.0), builder.sitofp(kp1, _F64), flags=("contract",))
    )

    def term(kind, ci, x):
        if kind == PLUS:
            return lambda: prod[x]
        if kind == MINUS:
            return lambda: ops.neg(prod[x])
        if kind == SCALED:
            return lambda: _Mul(c[ci], ops.val(prod[x]))
        if kind == LIN_CONST:
            return lambda: builder.select(is0, ops.mul(c[ci], load(x, zero)), ops.zero)
        if kind == LIN:
            return lambda: _Mul(c[ci], kval(x))
        raise ValueError(f"order: term kind {kind}")

    out = {}
    for row, terms in state:
        v = ops.val(ops.ftree([term(*t) for t in terms])) if terms else ops.zero
        out[row] = ops.mul(v, ik)
        store(out[row], row, hk1)
    return out


def _orders_loop(builder, ty, rows, P, load0, body) -> None:
    """``for k in range(P): carry = body(k, k + 1, carry)``, the carried values (the state ``rows``'
    coefficients of the current order, from ``load0(row)`` at ``k = 0``) kept in registers across
    orders (allocas that LLVM promotes): the next order reads them without a store-to-load round
    trip through ``V``."""
    i64 = ir.IntType(64)
    cur = {r: cgutils.alloca_once(builder, ty) for r in rows}
    for r in rows:
        builder.store(load0(r), cur[r])
    with cgutils.for_range(builder, P) as loop:
        kk = loop.index
        carry = {r: builder.load(cur[r]) for r in rows}
        new = body(kk, builder.add(kk, ir.Constant(i64, 1)), carry)
        for r in rows:
            builder.store(new[r], cur[r])


def _buffer_at(context, builder, bty, bval, vty):
    """``bat(s, col)``: the vector pointer ``&B[s, col, :]`` of the packed operand buffers ``B``
    (``(streams, P + 1, W)``, C order, the ``W`` lanes one vector of type ``vty``)."""
    i64 = ir.IntType(64)
    W = vty.count
    barr = context.make_array(bty)(context, builder, bval)
    bdata = barr.data
    sstride = builder.mul(cgutils.unpack_tuple(builder, barr.shape, 3)[1], ir.Constant(i64, W))
    vptr = ir.PointerType(vty)

    def bat(s, col):
        off = builder.add(
            builder.mul(ir.Constant(i64, s), sstride), builder.mul(col, ir.Constant(i64, W))
        )
        return builder.bitcast(builder.gep(bdata, [off], inbounds=True), vptr)

    return bat


def order_intrinsic(sp, W: int = 1, per_loop: int = 8, loop: bool = False):
    """The intrinsic ``order(V, k, C)`` (``W = 1``) or ``order(V, B, k, C)`` (``W > 1``): the
    order-``k`` body of the recurrence (module docstring) on the coefficient rows ``V`` (``(rows, P +
    1)``, C order), ``C`` the tuple of :func:`load_intrinsic`.

    ``sp = (ncoef, derived, chunks, consts, state)`` (literal in the generated text):
    ``derived``: ``(row, ((ci, src), ...))`` in order; ``chunks``: the general products, each chunk
    ``((p, u, w), ...)`` one loop over ``a``; ``consts``: ``(p, u, w, cls)``; ``state``: ``(row,
    ((kind, ci, x), ...))`` (kinds :data:`PLUS` ...).

    ``W > 1``: the general products packed ``W`` to a vector (:func:`pack_plan`, loops of at most
    ``per_loop`` vectors; ``B``: ``(max(1, len(streams)), P + 1, W)`` C order, the packed operand
    buffers, written before read): each product the same chain of multiply-adds as with ``W = 1``
    (bitwise), ``W`` of them per instruction.

    ``loop``: the intrinsic ``orders(V, B, P, C)``, the orders ``k = 0 .. P - 1`` in one loop of IR,
    the state rows' newest coefficients carried in registers from one order to the next
    (:func:`_orders_loop`; the same operations)."""
    ncoef, derived, chunks, consts, state = sp
    nrows = 1 + max(
        [r for r, t in derived for r in (r, *(x for _, x in t))]
        + [r for ch in chunks for _, u, w in ch for r in (u, w)]
        + [r for _, u, w, _ in consts for r in (u, w)]
        + [r for r, t in state for r in (r, *(x for kd, _, x in t if kd >= LIN_CONST))]
    )
    plan = pack_plan(chunks, W, per_loop) if W > 1 else None

    def codegen(context, builder, sig, args):
        i64 = ir.IntType(64)
        arr = context.make_array(sig.args[0])(context, builder, args[0])
        data = arr.data
        ncol = cgutils.unpack_tuple(builder, arr.shape, 2)[1]
        kk = context.cast(builder, args[-2], sig.args[-2], types.int64)
        c = _unpack(builder, args[-1], ncoef)
        # each row's offset computed once, before the loops (a value made inside a loop body
        # would not dominate its uses after it)
        base = {r: builder.mul(ir.Constant(i64, r), ncol) for r in range(nrows)}

        def at(row, col):  # &V[row, col]
            return builder.gep(data, [builder.add(base[row], col)], inbounds=True)

        packed_at = _packer(
            context, builder, sig, args, plan, W, 1, lambda row, col: builder.load(at(row, col))
        )

        def one(kk, kp1, carry):
            packed = packed_at(kk, kp1)
            return _order_body(
                builder,
                _FOps(builder),
                c,
                sp,
                kk,
                kp1,
                handle=lambda kv: kv,  # the column of order kv
                load=lambda row, col: builder.load(at(row, col)),
                store=lambda v, row, col: builder.store(v, at(row, col)),
                preload=True,
                packed=packed,
                carry=carry,
            )

        if loop:
            zero = ir.Constant(i64, 0)
            rows = [r for r, _ in state]
            _orders_loop(builder, _F64, rows, kk, lambda r: builder.load(at(r, zero)), one)
        else:
            one(kk, builder.add(kk, ir.Constant(i64, 1)), None)
        return context.get_dummy_value()

    return _order_of(codegen, ncoef, 2, plan is not None)


def pack_streams(sp, W: int, per_loop: int = 8) -> int:
    """The packed operand buffers :func:`order_intrinsic` ``(sp, W, per_loop)`` needs (at least 1)."""
    return max(1, len(pack_plan(sp[2], W, per_loop)[1]))


def lanes_order_intrinsic(sp, W: int, Q: int = 1, per_loop: int = 8, loop: bool = False):
    """The intrinsic ``order(V, k, C)`` (``Q = 1``) or ``order(V, B, k, C)`` (``Q > 1``) of the
    lane-batched kernel (:func:`refimpl.codegen.full_state_batch.batch_source`) and of the pair
    kernel: the order-``k`` body of the recurrence on ``W`` trajectories at once, ``V[k, row, lane]``
    (``(P + 1, rows, W)``, C order: the ``W`` lanes of one coefficient are contiguous and move as one
    vector of ``W`` float64), each lane's operations those of the scalar body, element by element.

    ``sp = (ncoef, derived, groups, consts, state)`` as :func:`order_intrinsic`'s ``spec`` (the lane
    kernel's: the terms of the state rows' products all :data:`SCALED`; the pair kernel of
    :func:`refimpl.codegen.full_state.full_state_source` passes the single kernel's own spec, its
    chunks as groups), ``groups`` the general products summed
    side by side in one loop over ``a`` (each distinct factor row loaded once per ``a``). The products
    stay values (never stored into ``V``). ``Q > 1``: the general products ``Q`` to a vector of ``Q W``
    lanes (:func:`pack_plan`, :class:`_Pack`; ``B``: ``(max(1, len(streams)), P + 1, Q W)``), each
    lane's chain the same (bitwise). ``loop``: ``orders(V, B, P, C)``, the orders ``k = 0 .. P - 1``
    in one loop of IR as :func:`order_intrinsic`'s."""
    ncoef = sp[0]
    plan = pack_plan(sp[2], Q, per_loop) if Q > 1 else None

    def codegen(context, builder, sig, args):
        ops = _FOps(builder, W)
        i64 = ir.IntType(64)
        vptr = ir.PointerType(ops.ty)
        arr = context.make_array(sig.args[0])(context, builder, args[0])
        data = arr.data
        nrow = cgutils.unpack_tuple(builder, arr.shape, 3)[1]
        kk = context.cast(builder, args[-2], sig.args[-2], types.int64)
        kp1 = builder.add(kk, ir.Constant(i64, 1))
        c = [ops.splat(x) for x in _unpack(builder, args[-1], ncoef)]
        stride = builder.mul(nrow, ir.Constant(i64, W))  # one order's floats

        def at(row, off):  # the W lanes of V[., row, :] (off: base of the order)
            p = builder.gep(data, [builder.add(off, ir.Constant(i64, row * W))], inbounds=True)
            return builder.bitcast(p, vptr)

        def handle(kv):  # offset of V[kv, 0, 0]
            return builder.mul(kv, stride)

        packed_at = _packer(
            context,
            builder,
            sig,
            args,
            plan,
            Q,
            W,
            lambda row, col: builder.load(at(row, handle(col)), align=8),
        )

        def one(kk, kp1, carry):
            packed = packed_at(kk, kp1)
            return _order_body(
                builder,
                ops,
                c,
                sp,
                kk,
                kp1,
                handle=handle,
                load=lambda row, off: builder.load(at(row, off), align=8),
                store=lambda v, row, off: builder.store(v, at(row, off), align=8),
                preload=False,
                packed=packed,
                carry=carry,
            )

        if loop:
            zero = ir.Constant(i64, 0)
            rows = [r for r, _ in sp[4]]
            load0 = lambda r: builder.load(at(r, zero), align=8)  # noqa: E731
            _orders_loop(builder, ops.ty, rows, kk, load0, one)
        else:
            one(kk, kp1, None)
        return context.get_dummy_value()

    return _order_of(codegen, ncoef, 3, plan is not None)


def _horner_update(builder, ops, nrows, at, cat, h, pp):
    """The compensated Horner update's IR on ``nrows`` rows, addressed by ``at(c, col)`` (the row's
    coefficient of order ``col``) and ``cat(c)`` (its carry): ``z = V[P]``, ``z = z h + V[kk]`` for
    ``kk = P - 1 .. 1`` (the rows' chains side by side in one loop), ``z = z h - comp``, ``w = V[0] +
    z``, ``comp = (w - V[0]) - z``, ``V[0] = w``; returns the i1 ``every w finite``. One emitter for
    :func:`update_intrinsic` and the pair kernel's lane update (their addressing differs, not their
    arithmetic)."""
    i64 = ir.IntType(64)
    zs = [cgutils.alloca_once_value(builder, builder.load(at(c, pp))) for c in range(nrows)]
    top = builder.sub(pp, ir.Constant(i64, 1))  # kk = P - 1 - j, j = 0 .. P - 2
    with cgutils.for_range(builder, top) as loop:
        kk = builder.sub(top, loop.index)
        for c, z in enumerate(zs):
            builder.store(ops.add(ops.mul(builder.load(z), h), builder.load(at(c, kk))), z)
    fin = cgutils.true_bit
    inf = ops.const(float("inf"))
    zero = ir.Constant(i64, 0)
    for c, z in enumerate(zs):
        zz = ops.sub(ops.mul(builder.load(z), h), builder.load(cat(c)))
        y = builder.load(at(c, zero))
        w = ops.add(y, zz)
        builder.store(ops.sub(ops.sub(w, y), zz), cat(c))
        builder.store(w, at(c, zero))
        fin = builder.and_(fin, builder.fcmp_ordered("<", ops.abs(w), inf))
    return fin


def update_intrinsic(rows):
    """The intrinsic ``fin = update(V, comp, hs, P)``: the compensated Horner update of the kernel's
    step on the rows ``rows`` of ``V`` (``(rows, P + 1)``, C order), row ``rows[c]`` with the carry
    ``comp[c]``: ``z = V[i, P]``, ``z = z hs + V[i, kk]`` for ``kk = P - 1 .. 1``, ``z = z hs -
    comp[c]``, ``w = V[i, 0] + z``, ``comp[c] = (w - V[i, 0]) - z``, ``V[i, 0] = w``; ``fin``: every
    ``w`` finite. Each row's operations in that order (as the Python loop it replaces), the rows'
    Horner chains interleaved in one loop over ``kk``: one row's chain is ``P`` dependent multiply-adds
    (latency-bound, one row at a time), the rows side by side fill the multiply-add units."""
    rows = tuple(int(r) for r in rows)

    @intrinsic
    def update(typingctx, V, comp, hs, P):
        _check_array("update", V, 2)
        _check_array("update", comp, 1)
        if not (isinstance(hs, types.Float) and isinstance(P, types.Integer)):
            raise TypeError(f"update: expects (V, comp, float, int), got {hs}, {P}")

        def codegen(context, builder, sig, args):
            ops = _Ops(builder)
            i64 = ir.IntType(64)
            arr = context.make_array(sig.args[0])(context, builder, args[0])
            data = arr.data
            ncol = cgutils.unpack_tuple(builder, arr.shape, 2)[1]
            cdata = context.make_array(sig.args[1])(context, builder, args[1]).data
            h = context.cast(builder, args[2], sig.args[2], types.float64)
            pp = context.cast(builder, args[3], sig.args[3], types.int64)
            base = [builder.mul(ir.Constant(i64, r), ncol) for r in rows]

            def at(c, col):
                return builder.gep(data, [builder.add(base[c], col)], inbounds=True)

            def cat(c):
                return builder.gep(cdata, [ir.Constant(i64, c)], inbounds=True)

            return _horner_update(builder, ops, len(rows), at, cat, h, pp)

        return types.boolean(V, comp, hs, P), codegen

    return update


def lane_update_intrinsic(rows, W: int):
    """The intrinsic ``fin = update(V, comp, hs, P, l)``: :func:`update_intrinsic`'s compensated
    Horner update on lane ``l`` of the lane kernels' ``V[k, row, lane]`` (``(P' + 1, rows, W)``, C
    order, ``P <= P'``) with the carries ``comp[c, l]`` (``(len(rows), W)``): each row's operations
    those of :func:`update_intrinsic` in the same order (so lane ``l`` is updated as the single kernel
    updates its run), the rows' chains side by side (the pair kernel's lanes: one lane's rows in one
    loop over ``kk``, not one row's chain after another)."""
    rows = tuple(int(r) for r in rows)

    @intrinsic
    def update(typingctx, V, comp, hs, P, l):
        _check_array("lane update", V, 3)
        _check_array("lane update", comp, 2)
        if not (
            isinstance(hs, types.Float)
            and isinstance(P, types.Integer)
            and isinstance(l, types.Integer)
        ):
            raise TypeError(f"lane update: expects (V, comp, float, int, int), got {hs}, {P}, {l}")

        def codegen(context, builder, sig, args):
            ops = _Ops(builder)
            i64 = ir.IntType(64)
            arr = context.make_array(sig.args[0])(context, builder, args[0])
            data = arr.data
            nrow = cgutils.unpack_tuple(builder, arr.shape, 3)[1]
            cdata = context.make_array(sig.args[1])(context, builder, args[1]).data
            h = context.cast(builder, args[2], sig.args[2], types.float64)
            pp = context.cast(builder, args[3], sig.args[3], types.int64)
            ln = context.cast(builder, args[4], sig.args[4], types.int64)
            w_ = ir.Constant(i64, W)
            stride = builder.mul(nrow, w_)  # one order's floats
            lane = [builder.add(ir.Constant(i64, r * W), ln) for r in rows]

            def at(c, col):  # &V[col, rows[c], l]
                return builder.gep(
                    data, [builder.add(builder.mul(col, stride), lane[c])], inbounds=True
                )

            def cat(c):  # &comp[c, l]
                off = builder.add(ir.Constant(i64, c * W), ln)
                return builder.gep(cdata, [off], inbounds=True)

            return _horner_update(builder, ops, len(rows), at, cat, h, pp)

        return types.boolean(V, comp, hs, P, l), codegen

    return update


def _aryptr(context, builder, ty, val):
    """The data pointer of the numba array ``val`` of type ``ty``."""
    return context.make_array(ty)(context, builder, val).data


def _packed_order(context, builder, sig, args):
    """The codegen of :func:`packed_order` (its docstring)."""
    W = 4
    ops = _Ops(builder, W)
    i64 = ir.IntType(64)
    c = lambda x: ir.Constant(i64, x)  # noqa: E731
    vptr = ir.PointerType(ops.ty)
    tys = sig.args
    V, UB, WB = (context.make_array(tys[i])(context, builder, args[i]) for i in range(3))
    kk = context.cast(builder, args[3], tys[3], types.int64)
    nv = context.cast(builder, args[4], tys[4], types.int64)
    (drow, dptr, didx, dcoef, gp, gu, gw, pu, pw, pcls, vrow, qptr, qprod, qcoef, lptr, lvar,
     lcoef, lcon) = (_aryptr(context, builder, tys[i], args[i]) for i in range(5, 23))  # fmt: skip
    nd = builder.sub(
        cgutils.unpack_tuple(
            builder, context.make_array(tys[6])(context, builder, args[6]).shape, 1
        )[0],
        ir.Constant(i64, 1),
    )

    def get(ptr, i):  # ptr[i] of a 1-d table
        return builder.load(builder.gep(ptr, [i], inbounds=True))

    vshape = cgutils.unpack_tuple(builder, V.shape, 3)
    vrows = vshape[1]
    ngu = cgutils.unpack_tuple(
        builder, context.make_array(tys[10])(context, builder, args[10]).shape, 1
    )[0]
    ngrp = builder.sdiv(ngu, c(2))  # the blocks (UB has at least one, used or not)
    P1 = cgutils.unpack_tuple(builder, UB.shape, 4)[1]
    npr = cgutils.unpack_tuple(
        builder, context.make_array(tys[12])(context, builder, args[12]).shape, 1
    )[0]
    nvar = cgutils.unpack_tuple(
        builder, context.make_array(tys[15])(context, builder, args[15]).shape, 1
    )[0]

    def vat(kv, row):  # &V[kv, row, :] as a vector pointer
        off = builder.mul(builder.add(builder.mul(kv, vrows), row), c(W))
        return builder.bitcast(builder.gep(V.data, [off], inbounds=True), vptr)

    def bat(B, nj, g, kv, j):  # &B[g, kv, j, :] (B: (ngrp, P + 1, nj, W))
        off = builder.add(builder.mul(builder.add(builder.mul(g, P1), kv), c(nj)), j)
        return builder.bitcast(builder.gep(B.data, [builder.mul(off, c(W))], inbounds=True), vptr)

    def vload(p):
        return builder.load(p, align=8)

    def vstore(v, p):
        builder.store(v, p, align=8)

    kp1 = builder.add(kk, c(1))
    is0 = builder.icmp_signed("==", kk, c(0))
    acc = cgutils.alloca_once(builder, ops.ty)
    # derived rows: V[k, drow[r]] = sum_t dcoef[t] V[k, didx[t]] (from 0.0, in the order of t)
    with cgutils.for_range(builder, nd) as lr:
        builder.store(ops.zero, acc)
        t0, t1 = get(dptr, lr.index), get(dptr, builder.add(lr.index, c(1)))
        with cgutils.for_range(builder, t1, start=t0) as lt:
            cf = ops.splat(get(dcoef, lt.index))
            term = ops.mul(cf, vload(vat(kk, get(didx, lt.index))))
            builder.store(ops.add(builder.load(acc), term), acc)
        vstore(builder.load(acc), vat(kk, get(drow, lr.index)))
    # the general products in blocks of 2 x 4 factor rows
    accs = [cgutils.alloca_once(builder, ops.ty) for _ in range(8)]
    with cgutils.for_range(builder, ngrp) as lg:
        g = lg.index
        for blk, idx, nj in ((UB, gu, 2), (WB, gw, 4)):
            for j in range(nj):
                u = get(idx, builder.add(builder.mul(g, c(nj)), c(j)))
                vstore(vload(vat(kk, u)), bat(blk, nj, g, kk, c(j)))
        for a_ in accs:
            builder.store(ops.zero, a_)
        with cgutils.for_range(builder, kp1) as la:
            b = builder.sub(kk, la.index)
            us = [vload(bat(UB, 2, g, la.index, c(i))) for i in range(2)]
            ws = [vload(bat(WB, 4, g, b, c(j))) for j in range(4)]
            for i in range(2):
                for j in range(4):
                    a_ = accs[i * 4 + j]
                    builder.store(ops.add(builder.load(a_), ops.mul(us[i], ws[j])), a_)
        for i in range(2):
            for j in range(4):
                q = get(gp, builder.add(builder.mul(g, c(8)), c(i * 4 + j)))
                vstore(builder.load(accs[i * 4 + j]), vat(kk, q))
    # the products with a constant factor (classes 1, 2, 3; 0 above, 5 the padding)
    zero_k = c(0)
    with cgutils.for_range(builder, npr) as lp:
        p = lp.index
        cl = get(pcls, p)
        isc = builder.and_(builder.icmp_signed(">=", cl, c(1)), builder.icmp_signed("<=", cl, c(3)))
        with builder.if_then(isc):
            u, w = get(pu, p), get(pw, p)
            row = builder.add(nv, p)
            with builder.if_else(builder.icmp_signed("==", cl, c(1))) as (one, other):
                with one:
                    vstore(ops.mul(vload(vat(zero_k, u)), vload(vat(kk, w))), vat(kk, row))
                with other:
                    with builder.if_else(builder.icmp_signed("==", cl, c(2))) as (two, three):
                        with two:
                            vstore(ops.mul(vload(vat(kk, u)), vload(vat(zero_k, w))), vat(kk, row))
                        with three:
                            v3 = ops.mul(vload(vat(zero_k, u)), vload(vat(zero_k, w)))
                            vstore(builder.select(is0, v3, ops.zero), vat(kk, row))
    ik = ops.splat(builder.fdiv(ir.Constant(_F64, 1.0), builder.sitofp(kp1, _F64), flags=_IKFLAGS))
    # the state rows: V[k + 1, vrow[c]] = (sum of qcoef prod + sum of lcoef V[k or 0, lvar]) / (k + 1)
    with cgutils.for_range(builder, nvar) as lc:
        builder.store(ops.zero, acc)
        t0, t1 = get(qptr, lc.index), get(qptr, builder.add(lc.index, c(1)))
        with cgutils.for_range(builder, t1, start=t0) as lt:
            cf = ops.splat(get(qcoef, lt.index))
            term = ops.mul(cf, vload(vat(kk, builder.add(nv, get(qprod, lt.index)))))
            builder.store(ops.add(builder.load(acc), term), acc)
        t0, t1 = get(lptr, lc.index), get(lptr, builder.add(lc.index, c(1)))
        with cgutils.for_range(builder, t1, start=t0) as lt:
            cf = ops.splat(get(lcoef, lt.index))
            i = get(lvar, lt.index)
            con = builder.icmp_unsigned("!=", get(lcon, lt.index), ir.Constant(ir.IntType(8), 0))
            with builder.if_else(con) as (yes, no):
                with yes:
                    with builder.if_then(is0):
                        term = ops.mul(cf, vload(vat(zero_k, i)))
                        builder.store(ops.add(builder.load(acc), term), acc)
                with no:
                    term = ops.mul(cf, vload(vat(kk, i)))
                    builder.store(ops.add(builder.load(acc), term), acc)
        vstore(ops.mul(builder.load(acc), ik), vat(kp1, get(vrow, lc.index)))
    del vshape
    return context.get_dummy_value()


_IKFLAGS = ("contract",)


def packed_order():
    """The intrinsic ``order(V, UB, WB, k, nv, drow, dptr, didx, dcoef, gp, gu, gw, pu, pw, pcls,
    vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon)`` of :func:`refimpl._full_state_batch.
    adaptive_packed` (one machine code for every structure: the field as the tables of
    :meth:`refimpl._full_state.FullState.tables`, the blocks ``gp, gu, gw`` of
    :func:`refimpl.codegen.full_state_batch.batch_groups`): the order-``k`` body on four lanes,
    ``V[k, row, lane]`` with the lanes as one vector of four float64, each lane's operations those of
    the numba Python it replaced (sums from ``0.0`` in the order of the tables; the blocks' eight sums
    in the order ``a = 0..k``). ``None`` without numba.

    numba's disk cache keys :func:`refimpl._full_state_batch.adaptive_packed` on that module's file,
    not on this one: a change of the IR built here must change that file too (its comment naming
    :data:`IR_VERSION`)."""
    if intrinsic is None:  # pragma: no cover - exercised only where numba is missing
        return None

    @intrinsic
    def order(typingctx, V, UB, WB, k, nv, drow, dptr, didx, dcoef, gp, gu, gw, pu, pw, pcls, vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon):  # fmt: skip
        _check_array("packed order", V, 3)
        _check_array("packed order", UB, 4)
        _check_array("packed order", WB, 4)
        for name, a, dt in (
            ("drow", drow, types.int64), ("dptr", dptr, types.int64),
            ("didx", didx, types.int64), ("dcoef", dcoef, types.float64),
            ("gp", gp, types.int64), ("gu", gu, types.int64), ("gw", gw, types.int64),
            ("pu", pu, types.int64), ("pw", pw, types.int64), ("pcls", pcls, types.int64),
            ("vrow", vrow, types.int64), ("qptr", qptr, types.int64),
            ("qprod", qprod, types.int64), ("qcoef", qcoef, types.float64),
            ("lptr", lptr, types.int64), ("lvar", lvar, types.int64),
            ("lcoef", lcoef, types.float64), ("lcon", lcon, types.boolean),
        ):  # fmt: skip
            if not (
                isinstance(a, types.Array) and a.ndim == 1 and a.dtype == dt and a.layout == "C"
            ):
                raise TypeError(f"packed order: {name} must be a 1-d {dt} array, got {a}")
        sig = types.none(V, UB, WB, k, nv, drow, dptr, didx, dcoef, gp, gu, gw, pu, pw, pcls, vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon)  # fmt: skip
        return sig, _packed_order

    return order


class _Arrays:
    """Element pointers of numba arrays passed to an intrinsic inside tuples (any layout, no bounds
    or wraparound checks: the kernels index within their arrays)."""

    def __init__(self, context, builder, tupty, tupval):
        self.ctx, self.b = context, builder
        self.arrs = []
        for i, ty in enumerate(tupty.types):
            ary = context.make_array(ty)(context, builder, builder.extract_value(tupval, i))
            shape = cgutils.unpack_tuple(builder, ary.shape, ty.ndim)
            strides = cgutils.unpack_tuple(builder, ary.strides, ty.ndim)
            self.arrs.append((ty, ary, shape, strides))

    def ptr(self, i, *idx):
        ty, ary, shape, strides = self.arrs[i]
        return cgutils.get_item_pointer2(
            self.ctx, self.b, ary.data, shape, strides, ty.layout, list(idx)
        )

    def get(self, i, *idx):
        v = self.b.load(self.ptr(i, *idx))
        if self.arrs[i][0].dtype == types.boolean:  # stored as a byte
            v = self.b.icmp_unsigned("!=", v, ir.Constant(v.type, 0))
        return v

    def put(self, v, i, *idx):
        self.b.store(v, self.ptr(i, *idx))

    def len(self, i, axis=0):
        return self.arrs[i][2][axis]


def rational_order():
    """The intrinsic ``order(k, grav, S, Wk, D, T)`` of :func:`refimpl._full_state_rational_kernel.
    adaptive` (one machine code for every structure): the order-``k`` body of its recurrence (that
    module's docstring), each operation as in the numba Python it replaced and in the same order.
    ``S = (PI, GA, OM, DK, W, GG, MM, SS)`` the series rows, ``Wk = (po, pd, pwv, og, gm, r, q, cs)``
    work vectors, ``D = (Mi, Ii, U, UGL, th, GL, Pab)`` matrices, ``T = (tm, ta, tb, fv, svm, svb,
    sv_of, stm, sta, st_of, gpa, gpm, gp_of, mptr, mb, mc, pu, pw, pconst, gvar, gptr, gprod, gsign)``
    the tables. ``None`` without numba.

    numba's disk cache keys that kernel on its module's file, not on this one: a change of the IR
    built here must change that file too (its comment naming :data:`IR_VERSION`)."""
    if intrinsic is None:  # pragma: no cover - exercised only where numba is missing
        return None

    @intrinsic
    def order(typingctx, k, grav, S, Wk, D, T):
        for name, tup, n_ in (("S", S, 8), ("Wk", Wk, 8), ("D", D, 7), ("T", T, 23)):
            if not (
                isinstance(tup, types.BaseTuple)
                and len(tup) == n_
                and all(isinstance(t, types.Array) for t in tup.types)
            ):
                raise TypeError(f"rational order: {name} must be a tuple of {n_} arrays, got {tup}")
        return types.none(k, grav, S, Wk, D, T), _rational_order

    return order


def _rational_order(context, builder, sig, args):
    """The codegen of :func:`rational_order`."""
    ops = _Ops(builder)
    i64 = ir.IntType(64)
    c = lambda x: ir.Constant(i64, x)  # noqa: E731
    kk = context.cast(builder, args[0], sig.args[0], types.int64)
    grav = context.cast(builder, args[1], sig.args[1], types.boolean)
    S = _Arrays(context, builder, sig.args[2], args[2])
    Wk = _Arrays(context, builder, sig.args[3], args[3])
    D = _Arrays(context, builder, sig.args[4], args[4])
    T = _Arrays(context, builder, sig.args[5], args[5])
    PI, GA, OM, DK, W_, GG, MM, SS = range(8)
    po, pd, pwv, og, gm, r, q, cs = range(8)
    Mi, Ii, U, UGL, th, GL, Pab = range(7)
    (tm, ta, tb, fv, svm, svb, sv_of, stm, sta, st_of, gpa, gpm, gp_of, mptr, mb, mc, pu, pw, pconst,
     gvar, gptr, gprod, gsign) = range(23)  # fmt: skip
    del tm
    n = S.len(PI)
    ntr = T.len(ta)
    kp1 = builder.add(kk, c(1))
    ik = builder.fdiv(ops.const(1.0), builder.sitofp(kp1, _F64), flags=_IKFLAGS)
    acc = cgutils.alloca_once(builder, _F64)
    loop = cgutils.for_range

    def add_to(v):
        builder.store(ops.add(builder.load(acc), v), acc)

    def pairs(X, xi, Y, yi, j0, out):
        """out[p] = sum_{j=j0..k} X[xi[p], j] Y[yi[p], k - j], four sums side by side (as _pairs)."""
        npr = T.len(xi)
        s4 = [cgutils.alloca_once(builder, _F64) for _ in range(4)]
        nq = builder.sdiv(npr, c(4))
        with loop(builder, nq) as lq:
            p0 = builder.mul(lq.index, c(4))
            us = [T.get(xi, builder.add(p0, c(i))) for i in range(4)]
            ws = [T.get(yi, builder.add(p0, c(i))) for i in range(4)]
            for s in s4:
                builder.store(ops.zero, s)
            with loop(builder, kp1, start=c(j0)) as lj:
                b = builder.sub(kk, lj.index)
                for i in range(4):
                    v = ops.mul(S.get(X, us[i], lj.index), S.get(Y, ws[i], b))
                    builder.store(ops.add(builder.load(s4[i]), v), s4[i])
            for i in range(4):
                Wk.put(builder.load(s4[i]), out, builder.add(p0, c(i)))
        with loop(builder, npr, start=builder.mul(nq, c(4))) as lp:
            u, w = T.get(xi, lp.index), T.get(yi, lp.index)
            builder.store(ops.zero, acc)
            with loop(builder, kp1, start=c(j0)) as lj:
                add_to(ops.mul(S.get(X, u, lj.index), S.get(Y, w, builder.sub(kk, lj.index))))
            Wk.put(builder.load(acc), out, lp.index)

    def scatter(dst, idx, src, src_of, sign):  # dst[idx[e]] (+/-)= fv[e] * src[src_of[e]]
        with loop(builder, ntr) as le:
            e = le.index
            i = T.get(idx, e)
            v = ops.mul(T.get(fv, e), Wk.get(src, T.get(src_of, e)))
            old = Wk.get(dst, i)
            Wk.put(ops.add(old, v) if sign > 0 else ops.sub(old, v), dst, i)

    def zero(vec):
        with loop(builder, n) as la:
            Wk.put(ops.zero, vec, la.index)

    def matvec(M, vec, transpose, store):  # store(a, sum_b M[a, b] vec[b]) (M[b, a]: transpose)
        with loop(builder, n) as la:
            builder.store(ops.zero, acc)
            with loop(builder, n) as lb:
                a, b = la.index, lb.index
                m = D.get(M, b, a) if transpose else D.get(M, a, b)
                add_to(ops.mul(m, vec(b)))
            store(a, builder.load(acc))

    # ---- Omega_k
    pairs(PI, svm, OM, svb, 1, po)
    zero(cs)
    scatter(cs, ta, po, sv_of, +1)
    with loop(builder, n) as la:
        a = la.index
        builder.store(ops.zero, acc)
        with loop(builder, n) as lb:
            b = lb.index
            add_to(
                ops.sub(
                    ops.mul(D.get(Ii, a, b), S.get(PI, b, kk)),
                    ops.mul(D.get(U, a, b), Wk.get(cs, b)),
                )
            )
            with builder.if_then(grav):
                add_to(ops.mul(D.get(UGL, a, b), S.get(GA, b, kk)))
        Wk.put(builder.load(acc), r, a)
    matvec(Mi, lambda b: Wk.get(r, b), False, lambda a, v: S.put(v, OM, a, kk))
    matvec(Ii, lambda b: S.get(PI, b, kk), False, lambda a, v: S.put(v, DK, a, kk))
    # ---- pidot_k
    pairs(PI, svm, DK, svb, 0, pd)
    pairs(PI, stm, W_, sta, 1, pwv)
    with loop(builder, n) as la:
        a = la.index
        builder.store(ops.zero, acc)
        with loop(builder, n) as lb:
            b = lb.index
            add_to(ops.mul(D.get(th, a, b), S.get(DK, b, kk)))
            with builder.if_then(grav):
                add_to(ops.mul(D.get(GL, a, b), S.get(GA, b, kk)))
        Wk.put(builder.load(acc), q, a)
    with loop(builder, ntr) as le:  # q[ta] -= fv pd[sv_of], then q[tb] -= fv pwv[st_of], per e
        e = le.index
        f = T.get(fv, e)
        i = T.get(ta, e)
        Wk.put(ops.sub(Wk.get(q, i), ops.mul(f, Wk.get(pd, T.get(sv_of, e)))), q, i)
        i = T.get(tb, e)
        Wk.put(ops.sub(Wk.get(q, i), ops.mul(f, Wk.get(pwv, T.get(st_of, e)))), q, i)

    def pidot(a, v):
        Wk.put(v, r, a)
        S.put(ops.mul(v, ik), PI, a, kp1)

    matvec(Mi, lambda b: Wk.get(q, b), True, pidot)
    matvec(U, lambda b: Wk.get(r, b), True, lambda a, v: S.put(v, W_, a, kk))
    with builder.if_then(grav):
        pairs(OM, gpa, GA, gpm, 0, og)
        zero(q)
        scatter(q, tb, og, gp_of, +1)
        with loop(builder, n) as la:
            S.put(ops.mul(Wk.get(q, la.index), ik), GA, la.index, kp1)
    # ---- G_{k+1} from M_k = rho(Omega_k)
    with loop(builder, builder.sub(T.len(mptr), c(1))) as le:  # the nm = len(mptr) - 1 entries
        e = le.index
        builder.store(ops.zero, acc)
        with loop(builder, T.get(mptr, builder.add(e, c(1))), start=T.get(mptr, e)) as lz:
            add_to(ops.mul(T.get(mc, lz.index), S.get(OM, T.get(mb, lz.index), kk)))
        S.put(builder.load(acc), MM, e, kk)
    pairs(GG, pu, MM, pw, 0, gm)
    with loop(builder, T.len(pu)) as lp:
        p = lp.index
        with builder.if_then(T.get(pconst, p)):
            Wk.put(ops.mul(S.get(GG, T.get(pu, p), c(0)), S.get(MM, T.get(pw, p), kk)), gm, p)
    with loop(builder, T.len(gvar)) as lc:
        builder.store(ops.zero, acc)
        with loop(
            builder, T.get(gptr, builder.add(lc.index, c(1))), start=T.get(gptr, lc.index)
        ) as lz:
            add_to(ops.mul(T.get(gsign, lz.index), Wk.get(gm, T.get(gprod, lz.index))))
        S.put(ops.mul(builder.load(acc), ik), GG, T.get(gvar, lc.index), kp1)
    with loop(builder, D.len(Pab)) as ll:
        builder.store(ops.zero, acc)
        with loop(builder, n) as lb:
            add_to(ops.mul(D.get(Pab, ll.index, lb.index), S.get(OM, lb.index, kk)))
        S.put(ops.mul(builder.load(acc), ik), SS, ll.index, kp1)
    return context.get_dummy_value()
