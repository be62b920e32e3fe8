"""pytest plugin: certify an implementation inside any test suite.

Name the target with ``--tstarg-impl module:object`` or ``--tstarg-impl module`` (or the
environment variable ``TSTARG_IMPL``). The target runs behind the same guard as under
``tstarg certify`` (:mod:`reports._guard`: a time limit per call, ``sys.exit`` and garbage
results are failures, a target without any protocol method is an error). The session fixture ``tstarg_certificate`` runs the battery on it once
(``--tstarg-examples``, ``--tstarg-seed``) and an author writes::

    def test_certified(tstarg_certificate):
        assert tstarg_certificate.passed, tstarg_certificate.summary()

Without a target the fixture certifies ``refimpl.fast:implementation``. The target and
its version are printed in the report header.
"""

from __future__ import annotations

import os

import pytest


def pytest_addoption(parser):
    g = parser.getgroup("tstarg")
    g.addoption(
        "--tstarg-impl", default=os.environ.get("TSTARG_IMPL"), help="module:object to certify"
    )
    g.addoption("--tstarg-examples", type=int, default=10, help="examples per certification check")
    g.addoption("--tstarg-seed", type=int, default=0)


def _target(config) -> str:
    return config.getoption("--tstarg-impl") or "tstarg.refimpl.fast:implementation"


def pytest_report_header(config):
    from tstarg.reports._guard import materialize

    spec = _target(config)
    try:
        obj = materialize(spec)
        return f"tstarg certification target: {spec} ({getattr(obj, 'name', '?')} {getattr(obj, 'version', '?')})"
    except Exception as exc:  # noqa: BLE001 - only a header
        return f"tstarg certification target: {spec} (cannot load: {exc})"


@pytest.fixture(scope="session")
def tstarg_certificate(pytestconfig):
    from tstarg.properties.runner import limits
    from tstarg.reports._certify import BUDGETS
    from tstarg.reports._guard import materialize
    from tstarg.reports.certification import certify

    spec = _target(pytestconfig)
    b = BUDGETS["dev"]
    with limits(
        example_seconds=b["example_seconds"],
        check_seconds=b["check_seconds"],
        shrink_seconds=b["shrink_seconds"],
    ):
        return certify(
            materialize(spec),
            max_examples=pytestconfig.getoption("--tstarg-examples"),
            seed=pytestconfig.getoption("--tstarg-seed"),
            target=spec,
        )
