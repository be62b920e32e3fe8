"""The committed baseline catches slowdowns: a copy of it with one speed row planted 2x slower
fails ``regression.speed``; a copy much faster on every speed row is reported as a stale
baseline, with the command that renews it. No timing is measured here: the reports are edited
copies of the committed one."""

from __future__ import annotations

import copy
import json
from argparse import Namespace

import pytest

from tstarg.reports import _verify, regression


@pytest.fixture(scope="module")
def base() -> dict:
    return regression.load_report(regression.BASELINE)


def _speed_rows(report: dict) -> list[dict]:
    return [c for c in report["checks"] if "speedup" in (c.get("extra") or {})]


def _scaled(report: dict, factors: dict) -> dict:
    new = copy.deepcopy(report)
    for c in _speed_rows(new):
        c["extra"]["speedup"] = c["extra"]["speedup"] * factors.get(c["name"], 1.0)
    return new


def test_the_baseline_has_the_speed_rows_of_verify(base):
    names = [c["name"] for c in _speed_rows(base)]
    assert names == ["speed.poisson[su2]", "speed.poisson[su3]", "speed.flow[heavy_top]"]
    assert all(c["extra"]["speedup"] > 1 for c in _speed_rows(base))
    assert (base["profile"], base["seed"]) == ("ci", 0)  # what RENEW asks for


@pytest.mark.parametrize(
    "row", ["speed.poisson[su2]", "speed.poisson[su3]", "speed.flow[heavy_top]"]
)
def test_a_planted_2x_slowdown_of_any_speed_row_fails(base, row):
    new = _scaled(base, {row: 0.5})
    cmp = regression.compare(base, new)
    assert cmp["speed_regressions"] == [row] and cmp["regressed"]
    acc, spd = regression.regression_checks(cmp)
    assert not spd.passed and acc.passed
    assert not cmp["stale"]


def test_noise_below_the_factor_passes(base):
    new = _scaled(base, {c["name"]: 0.6 for c in _speed_rows(base)})  # 1.67x slower everywhere
    cmp = regression.compare(base, new)
    assert cmp["speed_regressions"] == [] and not cmp["stale"]
    assert regression.regression_checks(cmp)[1].passed


def test_a_much_faster_run_says_the_baseline_is_stale(base, tmp_path, capsys):
    faster = _scaled(base, {c["name"]: 3.0 for c in _speed_rows(base)})
    cmp = regression.compare(base, faster)
    assert cmp["stale"] and not cmp["regressed"]
    assert regression.RENEW in cmp["stale_note"]
    assert "**the baseline is stale" in regression.render_markdown(cmp)
    # one row faster by less than the factor: the baseline still catches a slowdown there
    mixed = _scaled(base, {"speed.poisson[su2]": 3.0, "speed.poisson[su3]": 1.5})
    assert not regression.compare(base, mixed)["stale"]
    # verify prints it and writes it into report.md
    base_file = tmp_path / "base.json"
    base_file.write_text(json.dumps(base))
    report = dict(faster, checks=list(faster["checks"]))
    args = Namespace(
        baseline=str(base_file), no_baseline=False, digits_slack=None, speed_factor=None
    )
    results: list = []
    _verify._compare_with_baseline(args, report, results, tmp_path, _verify._load_baseline(args))
    out = capsys.readouterr().out
    assert "the baseline is stale" in out and regression.RENEW in out
    assert report["comparison"]["stale"]
    assert [r.name for r in results] == ["regression.accuracy", "regression.speed"]
    assert all(r.passed for r in results)
