"""Issue 15, reports and baselines: no lost report, no torn baseline, no pass from a corrupted file.

Each finding's reproducer is a test: a kill -9 during ``--write-baseline`` keeps the old baseline,
concurrent runs get distinct folders, corrupted report files give a clear error (exit 2), the
comparison plot without speed rows does not kill a run, ``tstarg report`` of the baseline folder
adds nothing there, scene output names are sanitised.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from tstarg.properties.runner import CheckResult
from tstarg.reports import _atomic, cli, regression

ENV = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")


def _report(rows: list[dict], **top) -> dict:
    rep = {
        "tool": "tstarg verify",
        "profile": "ci",
        "max_examples": 5,
        "seed": 0,
        "checks": rows,
        "passed": True,
        "n_failed": 0,
        "seconds": 1.0,
        "environment": {"blas_threads": 1},
    }
    rep.update(top)
    return rep


def _row(name="core.x", passed=True, min_digits=14.0, worst_ratio=0.1, **extra) -> dict:
    row = CheckResult(name="placeholder", equations="-", examples=3).to_json()
    row.update(
        name=name, passed=passed, min_digits=min_digits, worst_ratio=worst_ratio, extra=extra
    )
    return row


def _write(path: Path, rep) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(rep if isinstance(rep, str) else json.dumps(rep))
    return path


# ------------------------------------------------------------------ atomic writes
def test_atomic_write_replaces_whole_and_leaves_no_temporary(tmp_path):
    p = tmp_path / "a" / "report.json"
    _atomic.write_text(p, "old")
    _atomic.write_text(p, "new" * 1000)
    assert p.read_text() == "new" * 1000
    assert sorted(x.name for x in p.parent.iterdir()) == ["report.json"]


def test_atomic_writes_take_the_umask_permissions(tmp_path):
    """write_text and replacing give the new file the mode open() would (0666 minus the umask), not
    mkstemp's 0600; independent of the code: the mode of a file made by open() in the same folder."""
    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    want = plain.stat().st_mode & 0o777
    a = _atomic.write_text(tmp_path / "a.txt", "x")
    with _atomic.replacing(tmp_path / "b.txt") as tmp:
        tmp.write_text("y")
    assert (a.stat().st_mode & 0o777) == want == ((tmp_path / "b.txt").stat().st_mode & 0o777)
    assert (tmp_path / "b.txt").read_text() == "y"


def test_atomic_write_failure_keeps_the_old_file(tmp_path, monkeypatch):
    p = tmp_path / "report.json"
    _atomic.write_text(p, '{"old": 1}')

    def boom(fd):
        raise OSError("disk full")

    monkeypatch.setattr(_atomic.os, "fsync", boom)
    with pytest.raises(OSError, match="disk full"):
        _atomic.write_text(p, '{"new": 2}')
    assert json.loads(p.read_text()) == {"old": 1}
    assert [x.name for x in tmp_path.iterdir()] == ["report.json"]


_PROVIDER = """
from tstarg.properties.runner import CheckResult

def checks(max_examples, seed):
    return [CheckResult(name="fake.one", equations="-", examples=1, worst_ratio=0.5, min_digits=15.0)]
"""


def _fake_provider(tmp_path: Path) -> str:
    (tmp_path / "fakeprov15.py").write_text(_PROVIDER)
    return "fakeprov15:checks"


def test_kill_9_during_write_baseline_keeps_the_old_baseline(tmp_path):
    """A ``tstarg verify --write-baseline`` killed (SIGKILL) in the middle of writing the baseline:
    the baseline file stays the old, complete JSON. The writer is paused inside the write (after
    the new bytes went to disk, before the rename) so the kill lands mid-write deterministically."""
    base = tmp_path / "baseline" / "report.json"
    old = _report([_row("fake.one")])
    _write(base, old)
    ready = tmp_path / "ready"
    script = textwrap.dedent(f"""
        import os, sys, time
        sys.path.insert(0, {str(tmp_path)!r})
        from pathlib import Path
        from tstarg.reports import _atomic, regression, cli
        regression.BASELINE = Path({str(base)!r})
        real_fsync = os.fsync
        def slow_fsync(fd):
            real_fsync(fd)
            if os.fstat(fd).st_size > 0 and Path({str(base.parent)!r}) in [
                    Path(p).parent for p in [os.readlink(f"/proc/self/fd/{{fd}}")]]:
                Path({str(ready)!r}).write_text("mid-write")
                time.sleep(60)
        _atomic.os.fsync = slow_fsync
        sys.exit(cli.main(["verify", "--provider", "fakeprov15:checks", "--no-baseline", "--write-baseline",
                           "--out", {str(tmp_path / "run")!r}, "--quiet", "--max-examples", "1"]))
    """)
    _fake_provider(tmp_path)
    proc = subprocess.Popen(
        [sys.executable, "-c", script],
        env=ENV,
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        for _ in range(1200):
            if ready.exists() or proc.poll() is not None:
                break
            time.sleep(0.1)
        assert ready.exists(), (
            f"the writer never reached the baseline write: {proc.communicate(timeout=30)}"
        )
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert json.loads(base.read_text()) == old  # the old baseline, whole
    regression.load_report(base)  # and still a valid report
    # the run's own report was complete before the baseline was touched
    assert (
        json.loads((tmp_path / "run" / "report.json").read_text())["checks"][0]["name"]
        == "fake.one"
    )


def test_write_baseline_completes_with_the_new_report(tmp_path, monkeypatch):
    base = tmp_path / "baseline" / "report.json"
    _write(base, _report([_row("old.row")]))
    monkeypatch.setattr(regression, "BASELINE", base)
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = _fake_provider(tmp_path)
    rc = cli.main(
        [
            "verify",
            "--provider",
            spec,
            "--no-baseline",
            "--write-baseline",
            "--out",
            str(tmp_path / "run"),
            "--quiet",
            "--max-examples",
            "1",
        ]
    )
    assert rc == 0
    assert [c["name"] for c in regression.load_report(base)["checks"]] == ["fake.one"]


# ------------------------------------------------------------------ concurrent runs
def test_concurrent_runs_get_distinct_folders(tmp_path, capsys):
    out = tmp_path / "latest"
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            textwrap.dedent(f"""
            import sys, time
            from tstarg.reports import _atomic
            print(_atomic.claim_output({str(out)!r}), flush=True)
            time.sleep(60)
        """),
        ],
        env=ENV,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert Path(holder.stdout.readline().strip()) == out
        mine = _atomic.claim_output(out)
        assert mine != out and mine.parent == out and mine.name.startswith("run-")
        assert str(mine) in capsys.readouterr().out  # the run says where it writes
    finally:
        holder.kill()
        holder.wait()


def test_verify_run_while_another_holds_the_folder_writes_elsewhere(tmp_path, monkeypatch, capsys):
    out = tmp_path / "latest"
    code = (
        f"import time; from tstarg.reports import _atomic; _atomic.claim_output({str(out)!r}); "
        f"print('held', flush=True); time.sleep(60)"
    )
    holder = subprocess.Popen(
        [sys.executable, "-c", code], env=ENV, stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "held"
        monkeypatch.syspath_prepend(str(tmp_path))
        rc = cli.main(
            [
                "verify",
                "--provider",
                _fake_provider(tmp_path),
                "--no-baseline",
                "--out",
                str(out),
                "--quiet",
                "--max-examples",
                "1",
            ]
        )
        assert rc == 0
        text = capsys.readouterr().out
        others = [p for p in out.iterdir() if p.name.startswith("run-")]
        assert len(others) == 1 and (others[0] / "report.json").is_file()
        assert not (out / "report.json").exists()
        assert str(others[0]) in text
    finally:
        holder.kill()
        holder.wait()


# ------------------------------------------------------------------ corrupted reports
@pytest.mark.parametrize(
    "row, what",
    [
        (_row(min_digits="lots"), "min_digits"),
        (_row(passed="yes"), "passed"),
        (_row(min_digits=math.nan), "NaN"),
        (_row(min_digits="nan"), "NaN"),
        (_row(worst_ratio=[1]), "worst_ratio"),
        (_row(name=""), "name"),
        (_row(speedup="fast"), "speedup"),
        ("not a row", "object"),
    ],
)
def test_corrupted_rows_are_clear_errors(tmp_path, row, what, capsys):
    good = _write(tmp_path / "a" / "report.json", _report([_row()]))
    bad = tmp_path / "b" / "report.json"
    bad.parent.mkdir()
    bad.write_text(json.dumps(_report([row])))  # NaN written as the bare token NaN
    with pytest.raises(ValueError, match=what):
        regression.load_report(bad)
    rc = cli.main(["report", "--compare", str(good), str(bad), "--out", str(tmp_path / "cmp")])
    assert rc == 2  # never "no regression" (0), never a traceback
    assert what.lower() in capsys.readouterr().err.lower()
    assert not (tmp_path / "cmp").exists()


@pytest.mark.parametrize(
    "text", ["", "{", "[]", '{"checks": 3}', "null", '{"checks": [], "passed": "yes"}']
)
def test_foreign_or_truncated_files_are_clear_errors(tmp_path, text, capsys):
    bad = _write(tmp_path / "b" / "report.json", text)
    good = _write(tmp_path / "a" / "report.json", _report([_row()]))
    assert (
        cli.main(["report", "--compare", str(good), str(bad), "--out", str(tmp_path / "cmp")]) == 2
    )
    assert "report" in capsys.readouterr().err


def test_nan_in_a_failed_row_is_unknown_not_a_pass(tmp_path):
    """A failed check may carry NaN (its computation broke): loaded, and it regresses a passed baseline."""
    base = regression.load_report(_write(tmp_path / "a" / "report.json", _report([_row()])))
    new = regression.load_report(
        _write(
            tmp_path / "b" / "report.json",
            _report([_row(passed=False, min_digits="nan", worst_ratio="nan")]),
        )
    )
    cmp = regression.compare(base, new)
    assert cmp["regressed"] and cmp["accuracy_regressions"] == ["core.x"]


def test_a_zero_byte_baseline_stops_verify_with_a_clear_error(tmp_path, monkeypatch, capsys):
    base = _write(tmp_path / "baseline" / "report.json", "")
    monkeypatch.syspath_prepend(str(tmp_path))
    rc = cli.main(
        [
            "verify",
            "--provider",
            _fake_provider(tmp_path),
            "--baseline",
            str(base),
            "--out",
            str(tmp_path / "run"),
            "--quiet",
            "--max-examples",
            "1",
        ]
    )
    out, err = capsys.readouterr()
    # the baseline is checked first: one line, exit 2, no check ran, nothing written
    assert rc == 2 and "not valid JSON" in err and err.strip().count("\n") == 0
    assert "Traceback" not in err and "ran 1 checks" not in out
    assert not (tmp_path / "run").exists()


# ------------------------------------------------------------------ the comparison plot
def test_comparison_plot_without_speed_rows_is_drawn(tmp_path):
    """``verify --provider ...core_checks`` has no speed rows: the log axis used to raise
    'Data cannot be log-scaled' and the run wrote nothing."""
    base = regression.load_report(
        _write(tmp_path / "a" / "report.json", _report([_row("a"), _row("b")]))
    )
    new = regression.load_report(
        _write(tmp_path / "b" / "report.json", _report([_row("a"), _row("b", min_digits=9.0)]))
    )
    cmp = regression.compare(base, new)
    path = regression.plot(cmp, tmp_path / "fig" / "compare.png")
    assert path is not None and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_verify_against_a_baseline_without_speed_rows_writes_its_report(tmp_path, monkeypatch):
    base = _write(tmp_path / "base" / "report.json", _report([_row("fake.one", min_digits=15.0)]))
    monkeypatch.syspath_prepend(str(tmp_path))
    rc = cli.main(
        [
            "verify",
            "--provider",
            _fake_provider(tmp_path),
            "--baseline",
            str(base),
            "--out",
            str(tmp_path / "run"),
            "--quiet",
            "--max-examples",
            "1",
        ]
    )
    assert rc == 0
    rep = regression.load_report(tmp_path / "run")
    assert rep["comparison"]["regressed"] is False
    assert (tmp_path / "run" / "figures" / "compare.png").is_file()


def test_plot_failure_never_loses_the_comparison(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(
        regression, "_plot", lambda cmp, path: (_ for _ in ()).throw(RuntimeError("no display"))
    )
    assert regression.plot({"rows": []}, tmp_path / "x.png") is None
    assert "no display" in capsys.readouterr().err


# ------------------------------------------------------------------ writes where it should not
def test_report_of_the_baseline_folder_adds_no_file(tmp_path, monkeypatch, capsys):
    base = _write(tmp_path / "baseline" / "report.json", _report([_row()]))
    monkeypatch.setattr(regression, "BASELINE", base)
    assert cli.main(["report", str(base.parent)]) == 0
    assert [p.name for p in base.parent.iterdir()] == ["report.json"]
    assert "not written" in capsys.readouterr().out
    assert cli.main(["report", str(base.parent), "--out", str(tmp_path / "r")]) == 0
    assert (tmp_path / "r" / "report.md").is_file()


@pytest.mark.parametrize(
    "name, expected",
    [
        ("..", "unnamed"),
        ("...", "unnamed"),
        (".hidden", "hidden"),
        ("a/b", "a_b"),
        ("../../etc", "___etc"),
        ("-rf", "rf"),
        ("ok-name_1.2", "ok-name_1.2"),
        ("", "unnamed"),
        ("x" * 300, "x" * 80),
    ],
)
def test_safe_name(name, expected):
    got = _atomic.safe_name(name)
    assert got == expected
    assert "/" not in got and not got.startswith(".") and ".." not in got


def test_scene_named_dots_writes_under_reports_runs(tmp_path, monkeypatch):
    """A scene file named ``...toml`` wrote into ``reports/`` itself (``Path('...toml').stem == '..'``)."""
    (tmp_path / "reports").mkdir()
    scene = tmp_path / "...toml"
    scene.write_text(
        'name = "tiny"\nalgebra = "su(2)"\ninertia_diagonal = [1.0, 2.0, 3.0]\n'
        "x0 = [0.0, 0.0, 0.0]\npi0 = [0.1, 0.2, 0.3]\nt_end = 0.1\nsamples = 3\n"
    )
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", str(scene), "--no-plot", "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "reports").iterdir()) == ["runs"]
    (folder,) = list((tmp_path / "reports" / "runs").iterdir())
    assert folder.name == "scene"
    assert {"trajectory.npz", "trajectory.csv"} <= {p.name for p in folder.iterdir()}


def test_report_of_an_incomplete_report_is_a_clear_error(tmp_path, capsys):
    run = _write(tmp_path / "run" / "report.json", {"checks": [_row()]})
    assert cli.main(["report", str(run.parent)]) == 2
    assert "not a complete tstarg verify report" in capsys.readouterr().err
    assert [p.name for p in run.parent.iterdir()] == ["report.json"]


def test_checkresult_json_round_trip_is_accepted(tmp_path):
    """The rows the runner writes (inf digits as the string "inf") load without complaint."""
    r = CheckResult(name="x", equations="-", examples=1, worst_ratio=0.0, min_digits=math.inf)
    rep = regression.load_report(_write(tmp_path / "r.json", _report([r.to_json()])))
    assert regression._num(rep["checks"][0]["min_digits"]) == math.inf
