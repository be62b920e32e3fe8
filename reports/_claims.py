"""The worker of ``tstarg claims`` (:mod:`reports.cmd_claims` parses the arguments and calls
:func:`main`): run every check of the claims registries, write ``claims.md`` and the figures."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from tstarg.oracles.claims import (
    CLAIMS,
    coverage,
    evaluate,
    evaluate_entries,
    render_entries_markdown,
    render_markdown,
)
from tstarg.oracles.gnh_examples import EXAMPLES, check_example
from tstarg.oracles.paper_index import shipped_index

from . import _progress
from ._atomic import claim_output
from ._atomic import write_text as atomic_write_text


def _destinations(args) -> tuple[Path, Path]:
    """Where to write: under reports/latest/claims unless ``--write`` (the tracked files) or
    ``--out``/``--figures`` say otherwise."""
    write = getattr(args, "write", False)
    out = (
        Path(args.out)
        if args.out
        else Path("reports/claims.md" if write else "reports/latest/claims/claims.md")
    )
    figures = (
        Path(args.figures)
        if getattr(args, "figures", None)
        else (Path("reports/figures") if write else out.parent / "figures")
    )
    return out, figures


def _order(x: float) -> str:
    """A float64 round-off level as a power-of-ten bound (``<= 1e-13``): the digits below that vary
    with the BLAS and the machine, the bound does not."""
    if x == 0:
        return "0"
    return f"<= 1e{math.ceil(math.log10(x))}"


def _quantum_section(fig_dir: Path, display=None) -> list[str]:
    # qutip is heavy (seconds to import) and this section is skipped with --no-quantum
    from tstarg.oracles.qutip_spin import (
        adjoint_from_spin_half,
        attitude_classical,
        attitude_propagator,
        bloch_plot,
        commutator_defect,
        linear_flow_error,
        rep_defect,
        rigid_body_expectation,
    )

    lines = ["", "## qutip's spin picture (pi <-> -J - xi)", ""]
    lines.append("| comparison | measured | bar |")
    lines.append("|---|---|---|")
    for j in (0.5, 1, 5):
        lines.append(
            f"| [P_a,P_b] + i (P_k+xi_k) eps_kab, j={j} | {commutator_defect(j, (0.2, -0.1, 0.4)):.0e} | exact |"
        )
        lines.append(
            f"| same with P = +J (wrong sign), j={j} | {commutator_defect(j, (0.2, -0.1, 0.4), sign=1):.0e} | must be O(j) |"
        )
    for j in (0.5, 1, 5, 20):
        err, _ = linear_flow_error(j, (0.3, -0.5, 0.8), (0.2, 0.1, -0.3), np.linspace(0, 5, 6))
        lines.append(
            f"| H = b.pi with Theta shift, j={j}: max abs error of <P>(t) | {_order(err)} | 1e-10 |"
        )
    js = [4, 8, 16, 32, 64]
    ts = np.linspace(0, 2, 41)
    errs = []
    fig_dir.mkdir(parents=True, exist_ok=True)
    for j in js:
        if display is not None:
            display.phase(f"qutip: rigid body coherent state, j={j}")
        q, c = rigid_body_expectation(j, (1.0, 2.0, 3.0), ts)
        errs.append(float(np.max(np.abs(q[-1] - c[-1]))))
        if j in (4, 32):
            tp = np.linspace(0, 12, 121)
            qp, cp = rigid_body_expectation(j, (1.0, 2.0, 3.0), tp)
            bloch_plot(
                fig_dir / f"bloch_rigid_body_j{j}.png",
                cp,
                qp,
                f"rigid body I=(1,2,3), j={j}, t in [0,12]",
            )
    slope = float(np.polyfit(np.log(js), np.log(errs), 1)[0])
    lines.append(
        f"| rigid body coherent state, error at t=2 for j={js} | {', '.join(f'{e:.1e}' for e in errs)} | ~1/j |"
    )
    lines.append(f"| fitted exponent | {slope:.2f} | within 0.1 of -1 |")
    g_half = attitude_propagator(0.5, (1.0, 2.0, 3.0), (0.3, 0.9, -0.5), 3.0).full()
    g_cl = attitude_classical((1.0, 2.0, 3.0), (0.3, 0.9, -0.5), 3.0)
    lines.append(
        f"| attitude g(3): qutip spin-1/2 propagator vs DOP853 | {_order(np.max(np.abs(g_half - g_cl)))} | 1e-10 |"
    )
    U1 = attitude_propagator(1, (1.0, 2.0, 3.0), (0.3, 0.9, -0.5), 3.0)
    lines.append(
        f"| attitude g(3): spin-1 propagator vs Ad(g) from spin-1/2 | {_order(rep_defect(U1, adjoint_from_spin_half(g_cl)))} | 1e-10 |"
    )
    lines.append("")
    lines.append(
        f"Figures: `{fig_dir}/bloch_rigid_body_j4.png`, `{fig_dir}/bloch_rigid_body_j32.png`."
    )
    return lines


def _gnh_section(display=None) -> list[str]:
    lines = ["", "## Gotay-Nester-Hinds worked examples (refimpl.gnh, SU(2), tau = (0, 0, t))", ""]
    for k, ex in EXAMPLES.items():
        if ex.get("slow"):
            continue
        if display is not None:
            display.phase(f"Gotay-Nester-Hinds example {k}")
        ok, results, detail = check_example(k)
        lines.append(
            f"### {k}: expected {ex['outcome']} -- {'reproduced' if ok else 'NOT reproduced: ' + detail}"
        )
        lines.append("```")
        for r in results:
            lines.append(r.render())
        lines.append("```")
    return lines


def main(args) -> int:
    threadpool_limits(1)

    with _progress.Progress("claims", total=len(CLAIMS), quiet=_progress.is_quiet(args)) as display:
        display.phase("importing the checks")
        md, bad, missing = _run(args, display, CLAIMS, evaluate, render_markdown)
    out, _ = _destinations(args)
    print(f"wrote {out}")
    return 1 if bad or missing else 0


def _run(args, display, claims, evaluate, render_markdown):
    """Every check of the registries, one progress step per labelled claim; returns the
    Markdown, the contradicted labels and the items without an entry."""

    cache: dict = {}  # each named check runs once across the claims
    obs = []
    for c in claims:
        display.start(c.label)
        (o,) = evaluate([c], cache=cache)
        obs.append(o)
        display.done(c.label, o.verdict)
    width = max(len(o.claim.label) for o in obs)
    print(f"{'label':{width}s}  {'status':14s} {'observed':18s} checks")
    for o in obs:
        chk = ", ".join(f"{n}={'ok' if r.ok else 'FAIL'}" for n, r in o.results.items())
        print(f"{o.claim.label:{width}s}  {o.claim.status:14s} {o.verdict:18s} {chk}")
    md = render_markdown(obs)
    bad = [o.claim.label for o in obs if o.verdict == "CONTRADICTED"]
    n = len(obs)
    print(
        f"\n{n} labelled claims: {sum(o.verdict == 'verified' for o in obs)} verified, "
        f"{sum(o.verdict == 'erratum confirmed' for o in obs)} errata confirmed, "
        f"{sum(o.verdict == 'not checkable' for o in obs)} not checkable, {len(bad)} contradicted {bad}"
    )
    # the index ships with the package (oracles/paper_index.json): paper.tex is needed only to re-index
    index = shipped_index()
    cov = coverage(index)
    missing: list[str] = cov["missing"] + cov["misanchored"]
    if missing:
        print(f"items of the paper without a (well-anchored) entry: {missing}")
    else:
        display.phase(f"checking {cov['entries']} entries of the displays and sentences")
        eobs = evaluate_entries(index)
        md += "\n" + render_entries_markdown(index, eobs)
        ebad = [o.item.id for o in eobs if o.verdict == "CONTRADICTED"]
        bad += ebad
        print(
            f"coverage: {cov['displays']} displayed formulas + {cov['sentences']} mathematical "
            f"sentences = {cov['items']} items; {cov['entries']} entries; contradicted {ebad}"
        )
    md += "\n".join(_gnh_section(display)) + "\n"
    out, figures = _destinations(args)
    if not getattr(args, "write", False) and not getattr(args, "figures", None):
        folder = claim_output(
            out.parent
        )  # the lock of verify: a concurrent run gets its own folder
        out, figures = folder / out.name, folder / "figures"
    if not args.no_quantum:
        md += "\n".join(_quantum_section(figures, display)) + "\n"
    display.phase(f"writing {out}")
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, md)
    return md, bad, missing
