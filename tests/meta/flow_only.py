"""Flow-only implementations for the certification tests (issue 26): most third-party code is an
integrator with nothing but ``flow``.

* ``correct``: refimpl.fast's flow and nothing else (its accuracy declared);
* the broken ones are defined beside the checks that reject them (``Check.mutants``) and
  exposed here as CLI targets (``tests.meta.flow_only:loose_after_5``, ...).
"""

from __future__ import annotations

from tstarg.refimpl.fast import implementation as _fast


class FlowOnly:
    """Only ``flow``: refimpl.fast's (SU(2) for su(2), the default group)."""

    name = "flow-only"
    version = "test"
    flow_tolerance = _fast.flow_tolerance

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):
        return _fast.flow(f, theta, upsilon, inertia, potential, x0, pi0, t)


correct = FlowOnly()


def _mutant(name):
    from tstarg.reports.certification.registry import mutant

    return mutant(name)


domain_ignored = _mutant("domain_ignored_flow_only")
so3_undeclared = _mutant("so3_undeclared")
loose_after_5 = _mutant("loose_after_5")
