"""The examples in the public docstrings run and print what they show (``doctest``). The modules
listed here are the public faces whose functions carry examples; a listed module without a single
example fails, so the list cannot rot into a list of names."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = (
    "tstarg.refimpl._algebra",  # jacobi_residual
    "tstarg.refimpl._catalogue",  # catalogue
    "tstarg.refimpl._cohomology",  # delta1, h2_dim
    "tstarg.refimpl._validate",  # parse_number, exact_sympy
    "tstarg.refimpl._protocol",  # provides, provided_methods, check_attributes
    "tstarg.refimpl.model",  # Model
    "tstarg.refimpl.notebook",  # the notebook helpers
    "tstarg.properties.runner",  # RunState, limits
    "tstarg.properties.identity_checks",  # IdentityCheck
)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = finder.find(module)
    assert sum(len(t.examples) for t in tests) > 0, f"{name} has no docstring example"
    for t in tests:
        runner.run(t)
    res = runner.summarize(verbose=False)
    assert res.failed == 0, f"{name}: {res.failed} of {res.attempted} docstring examples failed"
