"""A module as a certification target (docs/design.md: an implementation is an instance or a module)."""

from tstarg.refimpl.fast import implementation as _fast

name = "module target"
version = "1"


def poisson_tensor(f, theta, upsilon, x, pi):
    return _fast.poisson_tensor(f, theta, upsilon, x, pi)
