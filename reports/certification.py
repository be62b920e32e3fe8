"""Certification of implementations of the protocol (DESIGN.md) against the mpmath reference.

Public API:

* :func:`certify` -- run the battery on an implementation object; returns a :class:`Certificate`;
* :func:`load_target` -- ``"module:object"`` to the object;
* :data:`CHECKS` -- the check ids, each with the method it needs.

The battery (each check drawn by Hypothesis, shrunk to a minimal failing example):

``poisson_tensor.reference``
    ``P`` vs the 30-digit reference at points in every conditioning regime
    (generic, near the degenerate set, large momenta, near the chart boundary), on
    every catalogue algebra with random cocycles Theta and Upsilon;
``poisson_tensor.antisymmetry``
    ``P^T = -P`` to rounding;
``poisson_tensor.degenerate``
    at a point of the degenerate set Pi_1 (exactly representable) the implementation
    raises ``ValueError`` or returns non-finite values; finite numbers there fail;
``poisson_tensor.batch`` (batched implementations)
    a batch equals its points evaluated one by one, and keeps its shape;
``hamiltonian_vector_field.reference``
    ``(xdot, pidot)`` vs the reference, free and with gravity (twee15);
``flow.reference``
    the state at ``t`` vs the reference flow (``refimpl.flows.reference_flow``).

Tolerances come from the error model ``C * n * eps_impl * max(cond_phi, cond_data) *
frame * scale`` evaluated at the reference point (``cond_phi = ||Phi||_F ||Phi^-1||_F / n``,
``cond_data = ||Phi^-1||_F (1 + ||S||_F ||U||_F) / sqrt(n)``, ``frame = 1/(1 - r)``,
``r >= ||ad_x||_2 / 2 pi``, ``scale = max(1, max|ref|)``), with ``C = 8`` and
``eps_impl = 10^-precision_digits`` from the implementation's ``precision_digits``
attribute (float64's eps when absent). Flows use ``max(flow_tolerance, that)`` with the
implementation's declared ``flow_tolerance`` (default 1e-9).
"""

from __future__ import annotations

import importlib
import json
import math
import sys
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ._imports import resolve
from hypothesis import strategies as st
from hypothesis import target as hyp_target

from tstarg.properties.runner import CheckResult, run_property
from tstarg.properties.strategies import REGIMES, catalogue_algebras, cocycles, points, upsilons
from tstarg.refimpl import CATALOGUE_NAMES, catalogue, su2
from tstarg.refimpl.reference import DegeneratePointError, Reference

__all__ = ["CHECKS", "Certificate", "certify", "certify_parallel", "load_target", "C_CERT"]

C_CERT = 8.0
EPS64 = float(np.finfo(float).eps)
_REF = Reference(30)

CHECKS = {
    "poisson_tensor.reference": "poisson_tensor",
    "poisson_tensor.antisymmetry": "poisson_tensor",
    "poisson_tensor.degenerate": "poisson_tensor",
    "poisson_tensor.batch": "poisson_tensor",
    "hamiltonian_vector_field.reference": "hamiltonian_vector_field",
    "flow.reference": "flow",
}


# ------------------------------------------------------------------ helpers
def load_target(spec: str):
    """``"package.module:object"`` (object may be dotted) to the object."""
    return resolve(spec)


def _eps_impl(impl) -> float:
    digits = getattr(impl, "precision_digits", None)
    return EPS64 if digits is None else max(EPS64, 10.0 ** (-float(digits)))


def _conditioning(f, theta, ups, x, pi) -> tuple[float, float]:
    """``max(cond_phi, cond_data)`` and ``frame`` at a point, from float64 arithmetic on the inputs."""
    n = f.shape[0]
    S = np.einsum("m,mab->ab", pi, f) - theta
    Phi = np.eye(n) + S @ ups
    try:
        Pinv = np.linalg.inv(Phi)
    except np.linalg.LinAlgError:
        return math.inf, 1.0
    fro = np.linalg.norm
    cond = max(fro(Phi) * fro(Pinv) / n, fro(Pinv) * (1 + fro(S) * fro(ups)) / math.sqrt(n))
    A = np.einsum("a,mab->mb", x, f)
    r = min(fro(A), math.sqrt(np.abs(A).sum(0).max() * np.abs(A).sum(1).max())) / (2 * math.pi) if A.any() else 0.0
    return cond, 1.0 / max(1e-300, 1.0 - min(r, 0.999999))


def _tolerance(impl, n, cond, frame, ref) -> float:
    scale = max(1.0, float(np.max(np.abs(ref))))
    return C_CERT * n * _eps_impl(impl) * cond * frame * scale


def _aim(ratio: float, label: str) -> None:
    """Guide Hypothesis' search towards the largest error/tolerance ratio (targeted PBT)."""
    if math.isfinite(ratio) and ratio > 0:
        hyp_target(math.log10(ratio), label=label)


def _call(impl, method, *args):
    return getattr(impl, method)(*args)


def _finite_array(value, shape, what) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != shape:
        raise AssertionError(f"{what}: result has shape {arr.shape}, expected {shape}")
    return arr


@st.composite
def _models(draw, regime: str):
    names = [n for n in CATALOGUE_NAMES if regime != "near_degenerate" or catalogue(n).f.any()]
    alg = draw(catalogue_algebras(names=names), label="algebra")
    n = alg.dim
    theta = draw(cocycles(alg, exact=False), label="theta")
    ups = draw(upsilons(n, exact=False, zero=False if regime == "near_degenerate" and n > 1 else None), label="upsilon")
    x, pi = draw(points(alg, theta, ups, regime=regime), label="point")
    return alg.name, alg.f, theta, ups, x, pi


_GRAVITY = st.sampled_from([None, "gravity"])


# ------------------------------------------------------------------ checks
def _poisson_reference(impl):
    def body(ex):
        name, f, theta, ups, x, pi = ex
        try:
            ref = _REF.poisson_tensor(f, theta, ups, x, pi)
        except DegeneratePointError:
            return None
        cond, frame = _conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond * _eps_impl(impl) * C_CERT * f.shape[0] >= 1:
            return None  # numerically degenerate for this precision: judged by the degenerate check
        try:
            got = _finite_array(_call(impl, "poisson_tensor", f, theta, ups, x, pi), ref.shape, "poisson_tensor")
        except ValueError as exc:
            raise AssertionError(f"{name}: raised ValueError at a non-degenerate point (cond {cond:.3g}): {exc}") from None
        err = float(np.max(np.abs(got - ref))) if np.all(np.isfinite(got)) else math.inf
        tol = _tolerance(impl, f.shape[0], cond, frame, ref)
        scale = max(1.0, float(np.max(np.abs(ref))))
        _aim(err / tol, "poisson ratio")
        return err / tol, (math.inf if err == 0 else -math.log10(err / scale))
    return body


def _poisson_antisymmetry(impl):
    def body(ex):
        name, f, theta, ups, x, pi = ex
        cond, frame = _conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond * _eps_impl(impl) * C_CERT * f.shape[0] >= 1:
            return None
        got = np.asarray(_call(impl, "poisson_tensor", f, theta, ups, x, pi), dtype=float)
        err = float(np.max(np.abs(got + got.T)))
        tol = C_CERT * _eps_impl(impl) * max(1.0, float(np.max(np.abs(got))))
        return err / tol, None
    return body


def _poisson_degenerate(impl):
    """su(2), Upsilon = tau.eps with tau = (0, 0, 1/2): the plane pi'_3 = 2 is Pi_1 (exact in binary)."""
    def body(ex):
        p1, p2, x = ex
        f = su2().f
        ups = np.einsum("l,lmn->mn", np.array([0.0, 0.0, 0.5]), f)
        pi = np.array([p1, p2, 2.0])
        try:
            out = np.asarray(_call(impl, "poisson_tensor", f, np.zeros((3, 3)), ups, np.array(x), pi), dtype=float)
        except ValueError:
            return 0.0, None
        if np.all(np.isfinite(out)):
            raise AssertionError(f"finite Poisson tensor returned on the degenerate set (pi = {pi.tolist()}): "
                                 "must raise ValueError or return non-finite values")
        return 0.0, None
    small = st.floats(-2, 2, allow_nan=False)
    return body, st.tuples(small, small, st.lists(st.floats(-1, 1), min_size=3, max_size=3))


def _poisson_batch(impl):
    def body(ex):
        f, theta, ups, xs, pis = ex
        if not getattr(impl, "batched", False):
            return None
        conds = [_conditioning(f, theta, ups, x, p)[0] for x, p in zip(xs, pis)]
        if any(not math.isfinite(c) or c > 1e8 for c in conds):
            return None
        X, Pm = np.array(xs), np.array(pis)
        n = f.shape[0]
        batch = np.asarray(_call(impl, "poisson_tensor", f, theta, ups, X, Pm), dtype=float)
        if batch.shape != (len(xs), 2 * n, 2 * n):
            raise AssertionError(f"batched poisson_tensor returned shape {batch.shape}, expected {(len(xs), 2 * n, 2 * n)}")
        worst = 0.0
        for k in range(len(xs)):
            one = np.asarray(_call(impl, "poisson_tensor", f, theta, ups, X[k], Pm[k]), dtype=float)
            err = float(np.max(np.abs(one - batch[k])))
            tol = C_CERT * n * _eps_impl(impl) * max(conds[k], 1.0) * max(1.0, float(np.max(np.abs(one))))
            worst = max(worst, err / tol)
        return worst, None

    @st.composite
    def strat(draw):
        alg = draw(catalogue_algebras(max_dim=6), label="algebra")
        theta = draw(cocycles(alg, exact=False))
        ups = draw(upsilons(alg.dim, exact=False))
        k = draw(st.integers(2, 5), label="batch size")
        pts = [draw(points(alg, regime="generic")) for _ in range(k)]
        return alg.f, theta, ups, [p[0] for p in pts], [p[1] for p in pts]
    return body, strat()


def _vector_field_reference(impl):
    def body(ex):
        (name, f, theta, ups, x, pi), grav = ex
        n = f.shape[0]
        inertia = np.diag(np.arange(2.0, 2.0 + n)) + 0.1 * (np.ones((n, n)) - np.eye(n))
        pot = None if grav is None else {"kind": "gravity", "L": np.linspace(0.3, -0.4, n),
                                          "gamma": np.linspace(-0.5, 0.7, n)}
        try:
            xd, pd = _REF.hamiltonian_vector_field(f, theta, ups, inertia, pot, x, pi)
        except DegeneratePointError:
            return None
        cond, frame = _conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond * _eps_impl(impl) * C_CERT * n >= 1:
            return None
        try:
            gx, gp = _call(impl, "hamiltonian_vector_field", f, theta, ups, inertia, pot, x, pi)
        except ValueError as exc:
            raise AssertionError(f"{name}: raised ValueError at a non-degenerate point: {exc}") from None
        got = np.concatenate([_finite_array(gx, (n,), "xdot"), _finite_array(gp, (n,), "pidot")])
        ref = np.concatenate([xd, pd])
        L = np.linalg.inv(_phi1(-np.einsum("a,mab->mb", x, f)))
        err = float(np.max(np.abs(got - ref))) if np.all(np.isfinite(got)) else math.inf
        tol = _tolerance(impl, n, cond, frame, ref) * max(1.0, float(np.max(np.abs(L))))
        scale = max(1.0, float(np.max(np.abs(ref))))
        _aim(err / tol, "vector field ratio")
        return err / tol, (math.inf if err == 0 else -math.log10(err / scale))
    return body


def _phi1(M: np.ndarray) -> np.ndarray:
    import scipy.linalg

    n = M.shape[0]
    big = np.zeros((2 * n, 2 * n))
    big[:n, :n] = M
    big[:n, n:] = np.eye(n)
    return scipy.linalg.expm(big)[:n, n:]


def _flow_reference(impl):
    try:
        from tstarg.refimpl.flows import reference_flow
    except ImportError:
        return None

    def body(ex):
        (name, f, theta, ups, x, pi), t = ex
        n = f.shape[0]
        inertia = np.diag(np.arange(2.0, 2.0 + n))
        try:
            xr, pr = reference_flow(f, theta, ups, inertia, None, x, pi, t, dps=25)
        except ValueError:
            return None
        cond, frame = _conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond > 1e6:
            return None
        gx, gp = _call(impl, "flow", f, theta, ups, inertia, None, x, pi, t)
        got = np.concatenate([_finite_array(gx, (n,), "x(t)"), _finite_array(gp, (n,), "pi(t)")])
        ref = np.concatenate([np.asarray(xr, dtype=float), np.asarray(pr, dtype=float)])
        scale = max(1.0, float(np.max(np.abs(ref))))
        tol = max(float(getattr(impl, "flow_tolerance", 1e-9)), C_CERT * n * _eps_impl(impl) * cond * frame) * scale
        err = float(np.max(np.abs(got - ref))) if np.all(np.isfinite(got)) else math.inf
        return err / tol, (math.inf if err == 0 else -math.log10(err / scale))
    return body


# ------------------------------------------------------------- certificate
@dataclass
class Certificate:
    implementation: str
    version: str
    target: str
    seed: int | None
    max_examples: int
    checks: list = field(default_factory=list)
    skipped: dict = field(default_factory=dict)
    xfailed: dict = field(default_factory=dict)
    seconds: float = 0.0
    command: str = ""
    incidents: list = field(default_factory=list)

    def _is_xfail(self, check_name: str) -> bool:
        return check_name.split("[", 1)[0] in self.xfailed

    @property
    def failed(self) -> list:
        return [c for c in self.checks if not c.passed and not self._is_xfail(c.name)]

    @property
    def passed(self) -> bool:
        return not self.failed and not self.incidents

    def to_json(self) -> dict:
        d = {k: v for k, v in asdict(self).items() if k != "checks"}
        d["checks"] = [c.to_json() for c in self.checks]
        d["passed"] = self.passed
        return d

    def summary(self) -> str:
        lines = [f"certificate for {self.implementation} {self.version} ({self.target}): "
                 f"{'PASS' if self.passed else 'FAIL'}"]
        for c in self.checks:
            verdict = "PASS" if c.passed else ("XFAIL" if self._is_xfail(c.name) else "FAIL")
            digits = "-" if c.min_digits is None else ("exact" if not math.isfinite(c.min_digits) else f"{c.min_digits:.1f}")
            lines.append(f"  {c.name:38s} {c.examples:4d} examples  worst ratio {c.worst_ratio:9.3g}  digits {digits:>6s}  {verdict}")
            if not c.passed:
                lines.append("    " + c.detail.replace("\n", "\n    ")[:800])
        for k, why in self.skipped.items():
            lines.append(f"  {k:38s} skipped: {why}")
        for i in self.incidents:
            lines.append(f"  program incident: request {i['id']} ({i['method']}): {i['kind']} ({i['detail']})")
        return "\n".join(lines)

    def to_markdown(self) -> str:
        out = [f"# Certificate: {self.implementation} {self.version}", "",
               f"- target: `{self.target}`", f"- verdict: **{'PASS' if self.passed else 'FAIL'}**",
               f"- seed: {self.seed}, max examples per check: {self.max_examples}, time: {self.seconds:.1f} s",
               f"- reproduce: `{self.command}`", "",
               "| check | examples | skipped examples | worst error/tolerance | min digits | verdict |",
               "|---|---:|---:|---:|---:|---|"]
        for c in self.checks:
            verdict = "PASS" if c.passed else ("XFAIL" if self._is_xfail(c.name) else "FAIL")
            digits = "-" if c.min_digits is None else f"{c.min_digits:.1f}"
            out.append(f"| {c.name} | {c.examples} | {c.skipped} | {c.worst_ratio:.3g} | {digits} | {verdict} |")
        for k, why in self.skipped.items():
            out.append(f"| {k} | 0 | - | - | - | skipped: {why} |")
        if self.incidents:
            out += ["", "## Program incidents (hangs and crashes; each restarted the program)", ""]
            out += [f"- request {i['id']} ({i['method']}): **{i['kind']}** ({i['detail']})" for i in self.incidents]
        bad = [c for c in self.checks if not c.passed]
        if bad:
            out += ["", "## Failures (minimal examples as shrunk by Hypothesis)", ""]
            for c in bad:
                out += [f"### {c.name}", "", "```", c.detail, c.falsifying_example, "```", ""]
        return "\n".join(out) + "\n"


def _read_ids(path: str | None, what: str) -> dict:
    if not path:
        return {}
    out = {}
    for line in Path(path).read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        key, _, why = line.partition(" ")
        if key not in CHECKS:
            warnings.warn(f"{what} file {path}: unknown check id {key!r} (known: {', '.join(CHECKS)})", stacklevel=2)
            continue
        out[key] = why.strip() or f"listed in {what} file"
    return out


def certify(impl, *, max_examples: int = 20, seed: int | None = 0, skips: dict | None = None,
            xfails: dict | None = None, target: str = "", checks: list[str] | None = None,
            shrink: bool = True, stop_on_failure: bool = False) -> Certificate:
    """Run every check ``impl``'s methods allow; missing methods are skipped with the reason.

    ``stop_on_failure=True`` skips the remaining checks after the first failure (enough
    for a verdict).

    ``shrink=False`` reports the first failing example as found (no shrinking, no
    explanation phase): much faster when only the verdict matters (mutation tests).
    """
    from hypothesis import Phase, settings

    previous = settings.default
    if not shrink:
        settings.register_profile("_tstarg_certify_noshrink", parent=previous,
                                  phases=[Phase.explicit, Phase.reuse, Phase.generate, Phase.target])
        settings.load_profile("_tstarg_certify_noshrink")
    try:
        return _certify(impl, max_examples=max_examples, seed=seed, skips=skips, xfails=xfails,
                        target=target, checks=checks, stop_on_failure=stop_on_failure)
    finally:
        if not shrink:
            settings.register_profile("_tstarg_certify_restore", parent=previous)
            settings.load_profile("_tstarg_certify_restore")


def _certify(impl, *, max_examples, seed, skips, xfails, target, checks, stop_on_failure=False) -> Certificate:
    t0 = time.perf_counter()
    cert = Certificate(implementation=str(getattr(impl, "name", type(impl).__name__)),
                       version=str(getattr(impl, "version", "unknown")), target=target or repr(impl),
                       seed=seed, max_examples=max_examples, xfailed=dict(xfails or {}),
                       command=f"tstarg certify {target or '<object>'} --seed {seed} --max-examples {max_examples}")
    skips = dict(skips or {})
    for cid, method in CHECKS.items():
        if stop_on_failure and cert.failed:
            cert.skipped[cid] = "not run: an earlier check already failed (stop_on_failure)"
            continue
        if checks is not None and cid not in checks:
            continue
        if cid in skips:
            cert.skipped[cid] = skips[cid]
            continue
        if not callable(getattr(impl, method, None)):
            cert.skipped[cid] = f"the implementation has no method {method!r}"
            continue
        if cid == "poisson_tensor.batch" and not getattr(impl, "batched", False):
            cert.skipped[cid] = "the implementation does not declare batched = True"
            continue
        if cid == "poisson_tensor.reference":
            for regime in REGIMES:
                # the degenerate neighbourhood gets twice the budget: errors that appear only
                # there (cond(Phi) 1e4..1e9) are the ones a uniform search misses
                k = 2 if regime == "near_degenerate" else 1
                cert.checks.append(run_property(f"{cid}[{regime}]", "vier9", _poisson_reference(impl), _models(regime),
                                                max_examples=k * max_examples, seed=seed))
            continue
        if cid == "poisson_tensor.antisymmetry":
            res = run_property(cid, "vier9", _poisson_antisymmetry(impl), _models("generic"),
                               max_examples=max(5, max_examples // 2), seed=seed)
        elif cid == "poisson_tensor.degenerate":
            body, strat = _poisson_degenerate(impl)
            res = run_property(cid, "vier7, vier12", body, strat, max_examples=max(3, max_examples // 4), seed=seed)
        elif cid == "poisson_tensor.batch":
            body, strat = _poisson_batch(impl)
            res = run_property(cid, "vier9", body, strat, max_examples=max(3, max_examples // 3), seed=seed)
        elif cid == "hamiltonian_vector_field.reference":
            for regime in ("generic", "near_degenerate"):
                cert.checks.append(run_property(f"{cid}[{regime}]", "vier10, vier11, twee16", _vector_field_reference(impl),
                                                st.tuples(_models(regime), _GRAVITY), max_examples=max_examples, seed=seed))
            continue
        elif cid == "flow.reference":
            body = _flow_reference(impl)
            if body is None:
                cert.skipped[cid] = "no reference flow available (refimpl.flows is missing)"
                continue
            res = run_property(cid, "vier10, vier11", body,
                               st.tuples(_models("generic"), st.sampled_from([0.1, 0.7])),
                               max_examples=max(3, max_examples // 4), seed=seed)
        else:  # pragma: no cover
            raise AssertionError(cid)
        cert.checks.append(res)
    cert.incidents = list(getattr(impl, "incidents", []) or [])
    cert.seconds = time.perf_counter() - t0
    return cert


def _materialize(spec):
    """A certification target from its picklable description: ``"module:object"`` or
    ``{"cmd": "PROGRAM ARGS", "timeout": seconds}`` (a fresh program per worker)."""
    if isinstance(spec, str):
        return load_target(spec)
    if isinstance(spec, dict) and "cmd" in spec:
        from .jsonl import CommandImplementation

        return CommandImplementation(spec["cmd"], timeout=float(spec.get("timeout", 10.0)))
    raise ValueError(f"certification target must be 'module:object' or {{'cmd': ...}}, got {spec!r}")


def _certify_unit(item) -> Certificate:
    """Worker of :func:`certify_parallel`: one check id (all its regimes) on a freshly loaded target."""
    spec, cid, kwargs = item
    impl = _materialize(spec)
    try:
        return certify(impl, checks=[cid], **kwargs)
    finally:
        if hasattr(impl, "close"):
            impl.close()


def certify_parallel(spec, *, workers: int | None = None, scheduler=None, max_examples: int = 20,
                     seed: int | None = 0, skips: dict | None = None, xfails: dict | None = None,
                     target: str = "", shrink: bool = True, checks: list[str] | None = None) -> Certificate:
    """:func:`certify` with the check ids spread over worker processes or a Dask cluster.

    ``spec`` names the target so that each worker can load it (``"module:object"``, or
    ``{"cmd": ..., "timeout": ...}`` for a JSON-lines program: one program per worker).
    Each check id runs exactly as it would serially (same seed, same examples); the
    partial certificates are merged in :data:`CHECKS` order, so the result equals the serial
    one except for timings (``tests/test_parallel.py``). ``workers=1`` without a scheduler
    runs in this process.
    """
    from ._parallel import map_tasks

    t0 = time.perf_counter()
    ids = [c for c in CHECKS if checks is None or c in checks]
    kwargs = {"max_examples": max_examples, "seed": seed, "skips": skips, "xfails": xfails, "target": target,
              "shrink": shrink}
    parts = map_tasks(_certify_unit, [(spec, cid, kwargs) for cid in ids], workers=workers, scheduler=scheduler)
    first = parts[0] if parts else _certify_unit((spec, None, kwargs))
    cert = Certificate(implementation=first.implementation, version=first.version, target=first.target,
                       seed=seed, max_examples=max_examples, xfailed=dict(xfails or {}), command=first.command)
    for part in parts:
        cert.checks.extend(part.checks)
        cert.skipped.update(part.skipped)
        cert.incidents.extend(part.incidents)
    cert.seconds = time.perf_counter() - t0
    return cert


def write_certificate(cert: Certificate, out: str | Path) -> Path:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "certificate.json").write_text(json.dumps(cert.to_json(), indent=2, default=str))
    (out / "certificate.md").write_text(cert.to_markdown())
    return out


def certificate_checks(max_examples: int, seed: int | None = 0) -> list[CheckResult]:
    """``tstarg verify`` provider: the certificate of the fast implementation (dogfood) and the
    mutation kill rate (every mutant of :mod:`reports.mutants` must be rejected, the correct
    ``Plain`` accepted). Both at a budget of ``max(4, max_examples // 3)`` examples per check."""
    from tstarg.refimpl.fast import implementation as fast

    from .mutants import kill_rate

    k = max(4, max_examples // 3)
    t0 = time.perf_counter()
    cert = certify(fast, max_examples=k, seed=seed, target="tstarg.refimpl.fast:implementation")
    digits = [c.min_digits for c in cert.checks if c.min_digits is not None]
    res_cert = CheckResult(
        name="certificate[refimpl.fast]", equations="vier9, vier10, vier11", examples=sum(c.examples for c in cert.checks),
        worst_ratio=max((c.worst_ratio for c in cert.checks), default=0.0), min_digits=min(digits) if digits else None,
        passed=cert.passed, detail="" if cert.passed else cert.summary(), seconds=time.perf_counter() - t0,
        extra={"certificate": cert.to_json()})
    t1 = time.perf_counter()
    kr = kill_rate(max_examples=k, seed=seed)
    res_kill = CheckResult(
        name="mutation_kill_rate", equations="(meta)", examples=len(kr["killed"]) + len(kr["survived"]),
        worst_ratio=0.0 if kr["rate"] == 1.0 and kr["correct_passes"] else float("inf"),
        passed=kr["rate"] == 1.0 and kr["correct_passes"],
        detail=f"kill rate {kr['rate']:.0%}; survivors: {kr['survived']}; correct implementation passes: {kr['correct_passes']}",
        seconds=time.perf_counter() - t1, extra=kr)
    return [res_cert, res_kill]
