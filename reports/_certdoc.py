"""The certificate as a CI dashboard reads it: ``certificate.json`` (schema
``reports/schema/certificate.schema.json``), ``certificate.md`` and ``certificate.junit.xml``.

:func:`certificate_document` extends :meth:`Certificate.to_json` with

* ``schema`` (the certificate schema's ``$id``) and ``environment``
  (:func:`reports.environment.environment`: platform, versions, BLAS, tstarg version and commit);
* per check: ``verdict`` (PASS, FAIL, XFAIL), ``margin`` (worst error / tolerance as a number,
  ``null`` when not finite) and ``judge_error`` (the judge's own error bound in the tolerance's
  units, as the check reports it in ``extra["judge_error"]``; ``null`` when it reports none);
* per failing check with a recorded call, ``reproduce``: copy-paste commands, with the
  ``PYTHONPATH`` the target needs: the replay (``tstarg certify ... --replay``) and the one call
  that failed, as a Python snippet (module targets) or as one JSON-lines request piped into the
  program (``--cmd`` targets).

:func:`write_certificate_files` writes the three files atomically (:mod:`reports._atomic`): a
run killed at any instant leaves the old certificate or the new one, never a torn one.
"""

from __future__ import annotations

import functools
import json
import math
import shlex
from pathlib import Path
from typing import Any

import numpy as np
from jsonschema import Draft202012Validator
from jsonschema.exceptions import best_match

from tstarg.properties import runner

from ._atomic import replacing, write_text
from .junit import write_junit

__all__ = [
    "CERTIFICATE_SCHEMA_ID",
    "certificate_document",
    "load_certificate_schema",
    "validate_certificate",
    "write_certificate_files",
]

SCHEMA_FILE = Path(__file__).with_name("schema") / "certificate.schema.json"
CERTIFICATE_SCHEMA_ID = "urn:tstarg:certificate:1.0"


@functools.cache
def load_certificate_schema() -> dict:
    return json.loads(SCHEMA_FILE.read_text())


def validate_certificate(doc: Any) -> None:
    """A ``ValueError`` naming the place unless ``doc`` is a valid certificate document."""
    err = best_match(Draft202012Validator(load_certificate_schema()).iter_errors(doc))
    if err is not None:
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in err.absolute_path)
        raise ValueError(f"certificate violates its schema at {where or '(top)'}: {err.message}")


def _plain(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return v


def _number(v) -> float | None:
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _env_prefix(pythonpath: list[str]) -> str:
    if not pythonpath:
        return ""
    return f"PYTHONPATH={shlex.quote(':'.join(pythonpath))}" + "${PYTHONPATH:+:$PYTHONPATH} "


def _python_call(target: str, call: dict, prefix: str) -> str | None:
    mod, _, obj = target.partition(":")
    method, args = call.get("method"), call.get("args")
    if not isinstance(args, dict) or not method:
        return None
    names = ", ".join(args)
    load = f"from {mod} import {obj} as impl" if obj else f"import {mod} as impl"
    body = "\n".join(
        [
            "import json",
            "import numpy as np",
            load,
            f"args = json.loads({json.dumps(json.dumps(_plain(args)))})",
            "a = {k: v if k == 'potential' or not isinstance(v, list) else np.array(v, dtype=float)"
            " for k, v in args.items()}",
            f"print(impl.{method}(*(a[k] for k in {list(args)!r})))  # {names}",
        ]
    )
    return f"{prefix}python - <<'EOF'\n{body}\nEOF"


def _jsonl_call(command: str, call: dict) -> str | None:
    method, args = call.get("method"), call.get("args")
    if not isinstance(args, dict) or not method:
        return None
    req = json.dumps({"id": 1, "method": method, "args": _plain(args)})
    return f"echo {shlex.quote(req)} | {command}"


def certificate_document(
    cert,
    *,
    environment: dict,
    target: str,
    cmd: str | None,
    pythonpath: list[str],
    cwd: str,
    out: Path,
) -> dict:
    """``cert.to_json()`` with the dashboard fields (module docstring)."""
    doc = {"schema": CERTIFICATE_SCHEMA_ID, **cert.to_json()}
    doc["environment"] = environment
    prefix = "" if cmd else _env_prefix(pythonpath)
    what = f"--cmd {shlex.quote(cmd)}" if cmd else shlex.quote(target)
    replay = (
        f"cd {shlex.quote(cwd)} && {prefix}tstarg certify {what} "
        f"--replay {shlex.quote(str(Path(out).resolve() / 'certificate.json'))}"
    )
    doc["pythonpath"] = [] if cmd else list(pythonpath)
    for c, row in zip(cert.checks, doc["checks"]):
        row["verdict"] = "PASS" if c.passed else ("XFAIL" if cert._is_xfail(c.name) else "FAIL")
        row["margin"] = _number(c.worst_ratio)
        row["judge_error"] = _number((c.extra or {}).get("judge_error"))
        if c.passed:
            continue
        rep = {"replay": replay} if "example" in (c.extra or {}) else {}
        ex = (c.extra or {}).get("example") or {}
        call = runner.decode((ex.get("notes") or {}).get("call"))
        if isinstance(call, dict):
            snippet = (
                _jsonl_call(cmd, call)
                if cmd
                else _python_call(target, call, f"cd {shlex.quote(cwd)} && {prefix}")
            )
            if snippet:
                rep["jsonl" if cmd else "python"] = snippet
        if rep:
            row["reproduce"] = rep
    return _finite_json(json.loads(json.dumps(doc, default=str)))


def _finite_json(v: Any) -> Any:
    """JSON has no NaN or infinity: non-finite floats become the strings "inf", "-inf", "nan"
    (as :meth:`CheckResult.to_json` writes them)."""
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    if isinstance(v, dict):
        return {k: _finite_json(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_finite_json(x) for x in v]
    return v


def write_certificate_files(cert, doc: dict, out: Path, markdown_tail: str = "") -> None:
    """``certificate.json``, ``certificate.md``, ``certificate.junit.xml``, each atomically."""
    out = Path(out)
    md = cert.to_markdown()
    env = doc.get("environment") or {}
    md += (
        f"\nEnvironment: {env.get('platform')}, Python {env.get('python')}, tstarg "
        f"{env.get('tstarg')} (commit {env.get('git_commit') or 'unknown'}).\n"
    )
    fails = [r for r in doc["checks"] if r.get("reproduce")]
    if fails:
        md += "\n## Reproduce\n"
        for r in fails:
            md += f"\n### {r['name']}\n"
            for kind, text in r["reproduce"].items():
                md += f"\n{kind}:\n\n```bash\n{text}\n```\n"
    write_text(out / "certificate.json", json.dumps(doc, indent=2, allow_nan=False))
    write_text(out / "certificate.md", md + markdown_tail)
    with replacing(out / "certificate.junit.xml") as tmp:
        write_junit(doc, tmp)
