"""The implementation protocol (docs/design.md): one machine-readable spec, and the class stating it.

:data:`SPEC` is the single source of truth for the protocol. It holds, per method, the
arguments (name, kind, shape), the optional keyword arguments, the result (kind, shape, the
names of its parts) and the precision at which the reference recomputes it; and, per optional
attribute or capability, its type, its admissible range and where it is declared (a
top-level attribute, or a key of the ``domain`` dict; in the JSON-lines ``capabilities``
reply every one of them is a top-level key). Everything else is generated from it or checked
against it by a test:

* :class:`Implementation` below (its method placeholders and their signatures);
* the JSON Schemas ``reports/schema/*.schema.json`` (:func:`tstarg.reports.jsonl_schema.build_schema`;
  ``tests/test_schema.py`` compares the shipped files with the generated ones);
* the JSON-lines client and guard (:mod:`tstarg.reports.jsonl`, :mod:`tstarg.reports._guard`:
  argument names, result shapes, the worst-entry explanation);
* the certification's method probing (:func:`provided_methods`) and the attribute caps
  (:func:`check_attributes`);
* the protocol table of ``docs/protocol.md`` (:func:`markdown_table`; checked by a test).

Adding a method is: one :class:`Method` entry here, one check, one client line (the worked
example is in ``docs/protocol.md``).

The obligations, in words (conventions of docs/conventions.md):

1. ``poisson_tensor(f, theta, upsilon, x, pi) -> P``: ``f`` of shape ``(n, n, n)`` with
   ``f[m, a, b] = f^m_ab``; ``theta``, ``upsilon`` antisymmetric ``(n, n)``; ``x`` canonical
   coordinates of the first kind and ``pi`` body momenta, each ``(n,)``. ``P`` is
   ``(2n, 2n)`` with ``P[i, j] = {z_i, z_j}``, ``z = (x, pi)``.
2. ``hamiltonian_vector_field(f, theta, upsilon, inertia, potential, x, pi) -> (xdot, pidot)``
   for ``H = 1/2 pi.I^-1 pi + V``; ``inertia`` symmetric positive definite ``(n, n)``;
   ``potential`` is ``None`` or ``{"kind": "gravity", "L": (n,), "gamma": (n,)}`` (twee15).
3. ``flow(f, theta, upsilon, inertia, potential, x0, pi0, t) -> (x, pi)``: the state at time
   ``t`` starting from ``(x0, pi0)`` at time 0 (optional keyword ``steps``).
4. Arrays are numpy float64. With ``batched = True`` the methods accept leading batch axes on
   the point arguments and return the same leading axes.
5. At a degenerate point (``Delta = det Phi = 0``, vier7) an implementation raises
   ``ValueError`` (or a subclass, e.g. ``DegeneratePointError``) naming the point; it never
   returns finite numbers there (only the fast batch API flags and returns NaN).
6. An implementation provides **any subset** of the methods; the optional attributes are
   listed in :data:`SPEC` (``ATTRIBUTES``).
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "ATTRIBUTES",
    "METHODS",
    "SPEC",
    "Arg",
    "Attribute",
    "Implementation",
    "Method",
    "check_attributes",
    "markdown_table",
    "method",
    "provided_methods",
    "provides",
]

PROTOCOL_VERSION = "1.0"

# argument kinds: the JSON Schema definition each maps to (reports/schema/request.schema.json)
KINDS = {
    "structure_constants": "(n, n, n), f[m][a][b] = f^m_ab",
    "matrix": "(n, n), row-major",
    "points": "(n,), or (..., n) with leading batch axes (batched implementations)",
    "potential": 'None or {"kind": "gravity", "L": (n,), "gamma": (n,)}',
    "number": "a float",
    "integer": "an integer >= 1",
}


@dataclass(frozen=True)
class Arg:
    """One argument of a method: ``kind`` is a key of :data:`KINDS`."""

    name: str
    kind: str
    doc: str = ""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(
                f"protocol spec: argument {self.name!r} has unknown kind {self.kind!r}"
            )


@dataclass(frozen=True)
class Method:
    """One protocol method.

    ``result`` is ``"tensor"`` (one ``(*lead, 2n, 2n)`` array) or ``"pair"`` (two ``(*lead, n)``
    arrays named ``parts``); ``lead`` is the leading batch shape of the first ``points``
    argument. ``reference_digits``: the precision at which the mpmath reference recomputes the
    result to explain a failure.
    """

    name: str
    args: tuple[Arg, ...]
    result: str
    parts: tuple[str, ...]
    doc: str
    optional: tuple[Arg, ...] = ()
    reference_digits: int = 30
    equations: str = ""

    def __post_init__(self):
        if self.result not in ("tensor", "pair"):
            raise ValueError(f"protocol spec: {self.name} result kind {self.result!r}")
        if self.result == "pair" and len(self.parts) != 2:
            raise ValueError(f"protocol spec: {self.name} returns a pair: two part names")
        if not any(a.kind == "points" for a in self.args):
            raise ValueError(f"protocol spec: {self.name} has no point argument")

    @property
    def arg_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.args)

    @property
    def optional_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.optional)

    @property
    def lead_index(self) -> int:
        """Index of the argument whose leading axes are the batch axes (the first point)."""
        return next(k for k, a in enumerate(self.args) if a.kind == "points")

    @property
    def symbol(self) -> str:
        """The result's name in messages: ``P`` or ``(xdot, pidot)``."""
        return self.parts[0] if self.result == "tensor" else f"({', '.join(self.parts)})"

    def result_shapes(self, n: int, lead: tuple = ()) -> tuple[tuple, ...]:
        """The expected shapes of the result's parts for dimension ``n`` and batch axes ``lead``."""
        if self.result == "tensor":
            return ((*lead, 2 * n, 2 * n),)
        return ((*lead, n), (*lead, n))


@dataclass(frozen=True)
class Attribute:
    """An optional attribute (Python) or capability key (JSON lines).

    ``type``: ``"string"``, ``"boolean"``, ``"number"``, ``"integer"``, ``"algebras"``,
    ``"integers"`` or ``"number_or_null"``. ``low``/``high`` (with ``low_open``) bound numbers;
    they are caps the certification enforces (a declared tolerance past its cap would let a
    flow that does not move pass). ``where``: ``"attribute"`` (an attribute of the object),
    ``"domain"`` (a key of its ``domain`` dict; ``batched`` may be either) or ``"jsonl"`` (a
    capabilities key with no Python counterpart).
    """

    name: str
    type: str
    doc: str
    where: str = "attribute"
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    default: Any = None

    def check(self, value: Any, label: str = "") -> str | None:
        """Why ``value`` is not admissible (None: it is)."""
        who = f"{label}: " if label else ""
        if self.type in ("number", "integer", "number_or_null"):
            if value is None and self.type == "number_or_null":
                return None
            ok = isinstance(value, (int, float)) or type(value).__module__ == "numpy"
            if isinstance(value, bool) or not ok:
                return f"{who}{self.name} = {value!r} is not a number"
            try:
                v = float(value)
            except (TypeError, ValueError):
                return f"{who}{self.name} = {value!r} is not a number"
            if not math.isfinite(v):
                return f"{who}{self.name} = {value!r} is not finite"
            if self.type == "integer" and v != int(v):
                return f"{who}{self.name} = {value!r} is not an integer"
            lo_bad = self.low is not None and (v <= self.low if self.low_open else v < self.low)
            hi_bad = self.high is not None and v > self.high
            if lo_bad or hi_bad:
                lo = "-inf" if self.low is None else f"{self.low:g}"
                hi = "inf" if self.high is None else f"{self.high:g}"
                return (
                    f"{who}{self.name} = {value!r} is outside its admissible range "
                    f"{'(' if self.low_open else '['}{lo}, {hi}] ({self.doc})"
                )
            return None
        if self.type == "boolean" and not isinstance(value, bool):
            return f"{who}{self.name} = {value!r} must be True or False"
        if self.type == "string" and not isinstance(value, str):
            return f"{who}{self.name} = {value!r} must be a string"
        return None


_MODEL = (
    Arg("f", "structure_constants", "structure constants f^m_ab"),
    Arg("theta", "matrix", "the cocycle Theta, antisymmetric"),
    Arg("upsilon", "matrix", "Upsilon, antisymmetric"),
)
_HAMILTONIAN = (
    Arg("inertia", "matrix", "symmetric positive definite"),
    Arg("potential", "potential", "None (free motion) or gravity (twee15)"),
)

METHODS: tuple[Method, ...] = (
    Method(
        "poisson_tensor",
        (*_MODEL, Arg("x", "points", "canonical coordinates"), Arg("pi", "points", "body momenta")),
        result="tensor",
        parts=("P",),
        doc="`P[i][j] = {z_i, z_j}`, `z = (x, pi)`, `2n x 2n`",
        equations="vier9",
    ),
    Method(
        "hamiltonian_vector_field",
        (*_MODEL, *_HAMILTONIAN, Arg("x", "points"), Arg("pi", "points")),
        result="pair",
        parts=("xdot", "pidot"),
        doc="`[xdot, pidot]` for `H = 1/2 pi.I^-1 pi + V`",
        equations="vier10, vier11, twee16",
    ),
    Method(
        "flow",
        (*_MODEL, *_HAMILTONIAN, Arg("x0", "points"), Arg("pi0", "points"), Arg("t", "number")),
        result="pair",
        parts=("x", "pi"),
        doc="`[x, pi]` at time `t`",
        optional=(Arg("steps", "integer", "fixed step count (order measurements)"),),
        reference_digits=25,
        equations="vier10, vier11",
    ),
)

ATTRIBUTES: tuple[Attribute, ...] = (
    Attribute("name", "string", "a display name"),
    Attribute("version", "string", "the implementation's version"),
    Attribute("batched", "boolean", "leading batch axes on the points accepted", default=False),
    Attribute(
        "precision_digits",
        "number",
        "promised decimal digits: tolerances use eps = 10^-digits; below 6 digits nothing is certified",
        low=6.0,
        high=10000.0,
    ),
    Attribute(
        "flow_tolerance",
        "number",
        "the flow's promised error per unit of state: at most 1e-4, above it a flow that never "
        "moves would pass",
        low=0.0,
        low_open=True,
        high=1e-4,
        default=1e-9,
    ),
    Attribute("order", "integer", "the integrator's order (flow.order)", low=1, high=100),
    Attribute(
        "poisson_integrator",
        "boolean",
        "the flow map is a Poisson map (flow.poisson_map)",
        default=False,
    ),
    Attribute(
        "group",
        "string",
        "the Lie group x lives on past the chart (default: the group of the documented "
        "representation, SU(2) for su(2)); e.g. 'SO(3)'",
    ),
    Attribute("algebras", "algebras", '"all" or catalogue names', where="domain"),
    Attribute("theta", "boolean", "a nonzero cocycle Theta supported", where="domain"),
    Attribute("upsilon", "boolean", "a nonzero Upsilon supported", where="domain"),
    Attribute("gravity", "boolean", "the gravity potential (twee15) supported", where="domain"),
    Attribute(
        "max_abs_t",
        "number_or_null",
        "flows only for |t| <= max_abs_t (null: no bound)",
        where="domain",
        low=0.0,
        low_open=True,
    ),
    Attribute(
        "negative_t",
        "boolean",
        "flows to t < 0: true (supported), false (refused with a ValueError), absent (either)",
        where="domain",
    ),
    Attribute(
        "dimensions",
        "integers",
        "informational: the dimensions n supported (not drawn from)",
        where="jsonl",
    ),
)


@dataclass(frozen=True)
class Spec:
    version: str
    methods: tuple[Method, ...]
    attributes: tuple[Attribute, ...]
    by_name: dict = field(default_factory=dict, compare=False)

    @property
    def method_names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.methods)

    def attribute(self, name: str) -> Attribute:
        return next(a for a in self.attributes if a.name == name)

    def declared(self, impl, name: str) -> Any:
        """``impl``'s attribute ``name`` as it declares it, else the protocol's default for it (the
        attribute's ``default``, the one place a default is written; None where there is none)."""
        return getattr(impl, name, self.attribute(name).default)


def _validate(spec: Spec) -> Spec:
    names = spec.method_names
    if len(set(names)) != len(names) or "capabilities" in names:
        raise ValueError("protocol spec: method names must be unique and not 'capabilities'")
    anames = [a.name for a in spec.attributes]
    if len(set(anames)) != len(anames):
        raise ValueError("protocol spec: attribute names must be unique")
    for a in spec.attributes:
        if a.where not in ("attribute", "domain", "jsonl"):
            raise ValueError(f"protocol spec: attribute {a.name}: where = {a.where!r}")
    spec.by_name.update({m.name: m for m in spec.methods})
    return spec


SPEC = _validate(Spec(PROTOCOL_VERSION, METHODS, ATTRIBUTES))
"""The protocol, validated on import."""

METHOD_NAMES = SPEC.method_names


def method(name: str) -> Method:
    """The spec of method ``name`` (a ``ValueError`` naming the known ones otherwise)."""
    try:
        return SPEC.by_name[name]
    except KeyError:
        raise ValueError(
            f"unknown protocol method {name!r} (known: {', '.join(METHOD_NAMES)})"
        ) from None


# ------------------------------------------------------------------ the class
def _placeholder(fn):
    """Mark a method of :class:`Implementation` as not provided (:func:`provides`)."""
    fn.__tstarg_placeholder__ = True
    return fn


class Implementation:
    """Optional base class for implementations: a subclass overrides **any subset** of the
    methods (module docstring); the ones it does not override are not provided
    (:func:`provides` is False, calling them raises ``NotImplementedError``). The methods and
    their signatures are checked against :data:`SPEC` on import."""

    name: str = "unnamed"
    version: str = "0"
    batched: bool = False

    @_placeholder
    def poisson_tensor(self, f, theta, upsilon, x, pi):
        """Obligation 1 of the module docstring: ``P``, ``(2n, 2n)``, ``P[i, j] = {z_i, z_j}``."""
        raise NotImplementedError(f"{type(self).__name__} does not provide poisson_tensor")

    @_placeholder
    def hamiltonian_vector_field(self, f, theta, upsilon, inertia, potential, x, pi):
        """Obligation 2 of the module docstring: ``(xdot, pidot)``."""
        raise NotImplementedError(
            f"{type(self).__name__} does not provide hamiltonian_vector_field"
        )

    @_placeholder
    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t, steps=None):
        """Obligation 3 of the module docstring: ``(x, pi)`` at time ``t`` (optional ``steps``)."""
        raise NotImplementedError(f"{type(self).__name__} does not provide flow")


def _check_class_against_spec() -> None:
    for m in METHODS:
        fn = getattr(Implementation, m.name, None)
        if fn is None:
            raise ValueError(f"protocol spec: Implementation lacks {m.name}")
        params = list(inspect.signature(fn).parameters)[1:]
        if params != [*m.arg_names, *m.optional_names]:
            raise ValueError(
                f"protocol spec: Implementation.{m.name}{params} differs from the spec"
            )
    extra = {
        k
        for k, v in vars(Implementation).items()
        if getattr(v, "__tstarg_placeholder__", False) and k not in METHOD_NAMES
    }
    if extra:
        raise ValueError(f"protocol spec: Implementation has methods outside the spec: {extra}")


_check_class_against_spec()


def provides(obj: Any, name: str) -> bool:
    """Does ``obj`` provide the protocol method ``name``? (callable, and not the placeholder of
    :class:`Implementation`).

    >>> class Mine(Implementation):  # overrides one method: the others stay placeholders
    ...     def poisson_tensor(self, f, theta, upsilon, x, pi):
    ...         raise NotImplementedError
    >>> provides(Mine(), "poisson_tensor"), provides(Mine(), "flow"), provided_methods(Mine())
    (True, False, ['poisson_tensor'])
    """
    fn = getattr(obj, name, None)
    return callable(fn) and not getattr(fn, "__tstarg_placeholder__", False)


def provided_methods(obj: Any) -> list[str]:
    """The protocol methods ``obj`` provides, in spec order."""
    return [m for m in METHOD_NAMES if provides(obj, m)]


def check_attributes(obj: Any, label: str = "") -> list[str]:
    """The problems of ``obj``'s declared attributes against the spec's types and caps (empty:
    all admissible). Domain keys are checked by the certification's ``declared_domain``.

    >>> class Loose:
    ...     flow_tolerance = -1.0  # a promised error must be positive
    >>> print(*check_attributes(Loose(), "Loose"))  # doctest: +ELLIPSIS
    Loose: flow_tolerance = -1.0 is outside its admissible range (0, 0.0001] ...
    """
    out = []
    for a in ATTRIBUTES:
        if a.where != "attribute":
            continue
        v = getattr(obj, a.name, None)
        if v is None or (a.name in ("name", "version") and not isinstance(v, bool)):
            continue
        why = a.check(v, label)
        if why:
            out.append(why)
    return out


def markdown_table() -> str:
    """The protocol's method table as it appears in ``docs/protocol.md``."""
    rows = ["| method | `args` | `result` |", "|---|---|---|"]
    for m in METHODS:
        args = ", ".join(m.arg_names)
        if m.optional:
            args += f"` (optional `{', '.join(m.optional_names)}`)"
        else:
            args += "`"
        rows.append(f"| `{m.name}` | `{args} | {m.doc} |")
    rows.append("| `capabilities` | `{}` | the declared domain and attributes (below) |")
    rows += [
        "",
        "| capability / attribute | type | range | declared as | meaning |",
        "|---|---|---|---|---|",
    ]
    for a in ATTRIBUTES:
        where = {
            "attribute": "attribute",
            "domain": "`domain` key",
            "jsonl": "JSON lines only",
        }[a.where]
        rng = "-"
        if a.low is not None or a.high is not None:
            lo = "-inf" if a.low is None else f"{a.low:g}"
            hi = "inf" if a.high is None else f"{a.high:g}"
            rng = f"{'(' if a.low_open else '['}{lo}, {hi}]"
        doc = a.doc.replace("|", "\\|")
        if a.default is not None:
            doc += f" (default: {a.default!r})"
        rows.append(f"| `{a.name}` | {a.type} | {rng} | {where} | {doc} |")
    return "\n".join(rows)
