"""The JSON-lines protocol of ``tstarg certify --cmd`` as JSON Schema (draft 2020-12), version 1.0.

The schemas are package data beside this module: ``schema/request.schema.json`` and
``schema/reply.schema.json``. An implementer in any language can validate their messages
against them; the harness validates on its side with :func:`validate_request` (what it sends)
and :func:`validate_reply` (what it receives).

Rules the schemas encode:

1. a request is ``{"id", "method", "args"}`` (optionally ``"protocol_version": "1.x"``), with
   ``method`` one of ``capabilities``, ``poisson_tensor``, ``hamiltonian_vector_field``, ``flow``
   and ``args`` holding exactly that method's protocol parameters by name (docs/design.md); arrays
   are nested lists of numbers;
2. a reply is ``{"id", "result"}`` or ``{"id", "error"}`` (never both, nothing else), ``error`` a
   non-empty string; ``"unknown method ..."`` means not provided, ``"ValueError: ..."`` is a
   refusal (degenerate point, or outside the declared domain);
3. results: the Poisson tensor as a ``2n x 2n`` nested list; ``[xdot, pidot]``; ``[x, pi]``;
   ``null`` for a non-finite entry (JSON has no NaN);
4. the ``capabilities`` result declares the domain: ``protocol_version`` and ``methods``
   (required), ``algebras`` (``"all"`` or catalogue names), ``dimensions``, ``theta``,
   ``upsilon``, ``gravity``, ``batched``, ``max_abs_t``, ``negative_t``, ``precision_digits``,
   ``flow_tolerance``, ``order``, ``poisson_integrator``.

A violation raises :class:`ProtocolError`, deliberately *not* a ``ValueError``: in the
protocol a ``ValueError`` is a legitimate refusal, and a malformed reply must never count as one.

``python -m tstarg.reports.jsonl_schema --cmd "PROGRAM ARGS"`` sends a ``capabilities`` request
and one small su(2) request per method to a program and validates every reply.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Any

from jsonschema import Draft202012Validator
from jsonschema.exceptions import best_match

__all__ = [
    "METHODS",
    "SCHEMA_VERSION",
    "ProtocolError",
    "load_schema",
    "validate_reply",
    "validate_request",
]

SCHEMA_VERSION = "1.0"
METHODS = ("capabilities", "poisson_tensor", "hamiltonian_vector_field", "flow")
SCHEMA_DIR = Path(__file__).with_name("schema")


class ProtocolError(Exception):
    """A message violates the JSON-lines protocol schema (not a ``ValueError``: see the module docstring)."""


@functools.cache
def load_schema(kind: str) -> dict:
    """The schema ``"request"`` or ``"reply"`` as a dict."""
    if kind not in ("request", "reply"):
        raise ValueError(f"schema kind must be 'request' or 'reply', got {kind!r}")
    return json.loads((SCHEMA_DIR / f"{kind}.schema.json").read_text())


@functools.cache
def _validator(kind: str, method: str | None) -> Draft202012Validator:
    schema = load_schema(kind)
    if method is not None:
        schema = {
            "$schema": schema["$schema"],
            "$defs": schema["$defs"],
            "$ref": f"#/$defs/reply_{method}",
        }
    return Draft202012Validator(schema)


def _where(error) -> str:
    path = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path)
    return path.lstrip(".") or "(the message)"


def _check(kind: str, method: str | None, obj: Any) -> None:
    _check_finite(obj, kind)
    err = best_match(_validator(kind, method).iter_errors(obj))
    if err is not None:
        what = f"{kind}" + (f" to {method}" if method else "")
        raise ProtocolError(
            f"{what} violates the JSON-lines protocol {SCHEMA_VERSION}: at {_where(err)}: "
            f"{err.message[:300]}"
        )


def _check_finite(obj: Any, kind: str) -> None:
    """JSON has no NaN or Infinity (Python's json module writes them anyway): reject them by name."""
    stack = [obj]
    while stack:
        v = stack.pop()
        if isinstance(v, float) and not math.isfinite(v):
            raise ProtocolError(
                f"{kind} contains {v!r}, which is not JSON: write null for a non-finite value"
            )
        if isinstance(v, dict):
            stack.extend(v.values())
        elif isinstance(v, list):
            stack.extend(v)


def validate_request(obj: Any) -> None:
    """Raise :class:`ProtocolError` unless ``obj`` (a parsed JSON object) is a valid request."""
    _check("request", None, obj)


def validate_reply(obj: Any, method: str | None = None) -> None:
    """Raise :class:`ProtocolError` unless ``obj`` is a valid reply; with ``method`` (the request's
    method) the result is checked against that method's result shape too."""
    if method is not None and method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    _check("reply", method, obj)


# ------------------------------------------------------------------ a checker for programs
def _sample_requests() -> list[dict]:
    eps = [
        [[0, 0, 0], [0, 0, 1], [0, -1, 0]],
        [[0, 0, -1], [0, 0, 0], [1, 0, 0]],
        [[0, 1, 0], [-1, 0, 0], [0, 0, 0]],
    ]
    z = [[0.0] * 3 for _ in range(3)]
    eye = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    x, pi = [0.1, 0.2, 0.3], [1.0, 0.5, -0.2]
    args = {
        "capabilities": {},
        "poisson_tensor": {"f": eps, "theta": z, "upsilon": z, "x": x, "pi": pi},
        "hamiltonian_vector_field": {
            "f": eps,
            "theta": z,
            "upsilon": z,
            "inertia": eye,
            "potential": None,
            "x": x,
            "pi": pi,
        },
        "flow": {
            "f": eps,
            "theta": z,
            "upsilon": z,
            "inertia": eye,
            "potential": None,
            "x0": x,
            "pi0": pi,
            "t": 0.1,
        },
    }
    return [{"id": k + 1, "method": m, "args": args[m]} for k, m in enumerate(METHODS)]


def check_program(command: str, *, timeout: float = 30.0) -> list[str]:
    """Send the sample requests to ``command`` and return the protocol violations found (empty: valid)."""
    requests = _sample_requests()
    for req in requests:
        validate_request(req)
    text = "".join(json.dumps(r) + "\n" for r in requests)
    try:
        done = subprocess.run(
            shlex.split(command),
            check=False,
            input=text,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        return [
            f"no complete answer within {timeout} s (each request needs exactly one reply line)"
        ]
    problems, seen = [], {}
    for k, line in enumerate(done.stdout.splitlines(), 1):
        try:
            msg = json.loads(line)
        except json.JSONDecodeError as exc:
            problems.append(f"stdout line {k} is not JSON ({exc}): {line[:120]!r}")
            continue
        rid = msg.get("id") if isinstance(msg, dict) else None
        method = next((r["method"] for r in requests if r["id"] == rid), None)
        if method is None:
            problems.append(f"stdout line {k}: reply id {rid!r} matches no request")
            continue
        seen[rid] = msg
        try:
            validate_reply(msg, method)
        except ProtocolError as exc:
            problems.append(f"stdout line {k}: {exc}")
    problems += [
        f"no reply to request {r['id']} ({r['method']})" for r in requests if r["id"] not in seen
    ]
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m tstarg.reports.jsonl_schema",
        description="Validate a JSON-lines program's replies against the protocol schema.",
    )
    ap.add_argument(
        "--cmd", required=True, help='the program, e.g. --cmd "node examples/js/client.mjs"'
    )
    ap.add_argument("--timeout", type=float, default=30.0)
    a = ap.parse_args(argv)
    problems = check_program(a.cmd, timeout=a.timeout)
    for p in problems:
        print(p)
    print(
        f"JSON-lines protocol {SCHEMA_VERSION}: {'valid' if not problems else f'{len(problems)} violation(s)'}"
    )
    return 1 if problems else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
