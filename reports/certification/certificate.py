"""The certificate: the verdict per check, what was skipped and why, notes, incidents."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

from ._common import JUDGE
from .registry import CHECKS


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
    domain: str = "the whole model space (no domain declared)"
    notes: list = field(default_factory=list)
    judge: str = JUDGE
    group: str = ""

    def _is_xfail(self, check_name: str) -> bool:
        return check_name.split("[", 1)[0] in self.xfailed

    @property
    def failed(self) -> list:
        return [c for c in self.checks if not c.passed and not self._is_xfail(c.name)]

    @property
    def passed(self) -> bool:
        return not self.failed and not self.incidents

    @property
    def reproduce(self) -> str:
        """The command that reproduces this certificate (``tstarg certify TARGET ...``)."""
        cmd = self.command.strip()
        if cmd.startswith("tstarg ") and not cmd.startswith("tstarg certify"):
            cmd = "tstarg certify " + cmd[len("tstarg ") :]
        return cmd or reproduce_command(self.target, self.seed, self.max_examples)

    def structure(self) -> list[str]:
        """What the certified flow preserves and what it does not (from the structure checks)."""
        out = []
        for c in self.checks:
            if c.name == "flow.drift":
                kept = c.extra.get("preserved", "energy")
                out.append(
                    f"{kept}: {'drift within' if c.passed else 'drift beyond'} "
                    f"{'a bound (Poisson integrator)' if c.extra.get('poisson') else 'Brouwer sqrt(t) law'}"
                )
            if c.name == "flow.poisson_map":
                out.append(
                    f"Poisson map: {'yes' if c.passed else 'NO'} (D Phi P D Phi^T = P o Phi)"
                )
            if c.name == "flow.order":
                out.append(
                    f"order: declared {c.extra.get('declared order')}, observed "
                    f"{c.extra.get('observed order', '-')}"
                )
        return out

    def to_json(self) -> dict:
        d = {k: v for k, v in asdict(self).items() if k != "checks"}
        d["checks"] = [c.to_json() for c in self.checks]
        d["passed"] = self.passed
        d["reproduce"] = self.reproduce
        d["structure"] = self.structure()
        return d

    def summary(self) -> str:
        lines = [
            (
                f"certificate for {self.implementation} {self.version} ({self.target}): "
                f"{'PASS' if self.passed else 'FAIL'}"
            ),
            f"  certified for: {self.domain}",
            *([f"  group: {self.group}"] if self.group else []),
            f"  judge: {self.judge}",
        ]
        for c in self.checks:
            verdict = "PASS" if c.passed else ("XFAIL" if self._is_xfail(c.name) else "FAIL")
            digits = (
                "-"
                if c.min_digits is None
                else ("exact" if not math.isfinite(c.min_digits) else f"{c.min_digits:.1f}")
            )
            lines.append(
                f"  {c.name:38s} {c.examples:4d} examples  worst ratio {c.worst_ratio:9.3g}  digits {digits:>6s}  {verdict}"
            )
            if not c.passed:
                lines.append("    " + c.detail.replace("\n", "\n    ")[:800])
                if c.extra.get("smallest failing example"):
                    lines.append(f"    example shown: {c.extra['smallest failing example']}")
        for k, why in self.skipped.items():
            lines.append(f"  {k:38s} skipped: {why}")
        for note in self.notes + self.structure():
            lines.append(f"  note: {note}")
        for i in self.incidents:
            lines.append(
                f"  program incident: request {i['id']} ({i['method']}): {i['kind']} ({i['detail']})"
            )
        return "\n".join(lines)

    def to_markdown(self) -> str:
        out = [
            f"# Certificate: {self.implementation} {self.version}",
            "",
            f"- target: `{self.target}`",
            f"- verdict: **{'PASS' if self.passed else 'FAIL'}**",
            f"- certified for: {self.domain}",
            *([f"- group: {self.group}"] if self.group else []),
            f"- judge: {self.judge}",
            f"- seed: {self.seed}, max examples per check: {self.max_examples}, time: {self.seconds:.1f} s",
            f"- reproduce: `{self.reproduce}`",
            "",
            "| check | examples | skipped examples | worst error/tolerance | min digits | verdict |",
            "|---|---:|---:|---:|---:|---|",
        ]
        for c in self.checks:
            verdict = "PASS" if c.passed else ("XFAIL" if self._is_xfail(c.name) else "FAIL")
            digits = "-" if c.min_digits is None else f"{c.min_digits:.1f}"
            out.append(
                f"| {c.name} | {c.examples} | {c.skipped} | {c.worst_ratio:.3g} | {digits} | {verdict} |"
            )
        for k, why in self.skipped.items():
            out.append(f"| {k} | 0 | - | - | - | skipped: {why} |")
        notes = self.notes + self.structure()
        if notes:
            out += ["", "## Notes", ""] + [f"- {n}" for n in notes]
        if self.incidents:
            out += ["", "## Program incidents (hangs and crashes; each restarted the program)", ""]
            out += [
                f"- request {i['id']} ({i['method']}): **{i['kind']}** ({i['detail']})"
                for i in self.incidents
            ]
        bad = [c for c in self.checks if not c.passed]
        if bad:
            out += ["", "## Failures (minimal examples as shrunk by Hypothesis)", ""]
            for c in bad:
                out += [f"### {c.name}", "", "```", c.detail, c.falsifying_example, "```", ""]
        return "\n".join(out) + "\n"


def reproduce_command(target: str, seed, max_examples) -> str:
    """``tstarg certify TARGET --seed S --max-examples N`` (``TARGET`` may be ``--cmd '...'``)."""
    return f"tstarg certify {target or '<object>'} --seed {seed} --max-examples {max_examples}"


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
            warnings.warn(
                f"{what} file {path}: unknown check id {key!r} (known: {', '.join(CHECKS)})",
                stacklevel=2,
            )
            continue
        out[key] = why.strip() or f"listed in {what} file"
    return out


def write_certificate(cert: Certificate, out: str | Path) -> Path:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "certificate.json").write_text(json.dumps(cert.to_json(), indent=2, default=str))
    (out / "certificate.md").write_text(cert.to_markdown())
    return out
