"""Feed code strings to every function of tstarg's four packages; report any that runs one.

Run as ``python _string_walk.py SENTINEL [MODULE_PREFIX ...]`` in a scratch working folder (it is not a test module:
``tests/adversarial/test_strings.py`` starts it in a child process). Every function and method
defined in ``tstarg.refimpl``, ``tstarg.properties``, ``tstarg.oracles`` and ``tstarg.reports``,
public and private, is called once per parameter with that parameter set to a code string, to a
list of three, and to a 3 x 3 list of them (the other parameters keep their defaults, or ``1``).
The strings would create the file ``SENTINEL`` if Python evaluated them (module prefixes, when
given, restrict the walk to those modules). Each call runs under a 0.25 s interval timer; whatever it raises is recorded, never judged: the walk only asks whether the
sentinel appeared. Output: one JSON line per function that created it, then a summary line
``{"done": ..., "calls": ..., "executed": [...]}``.

Left out, with the reason: the command-line layers (``reports.cli``, ``reports.cmd_*``: they parse
argv, start worker processes and write folders; their number inputs go through the functions
walked here), ``reports._parallel`` (starts process pools), ``reports.pytest_plugin`` (pytest
hooks), and the functions whose parameter *is* generated kernel source by design
(:data:`SKIP_FUNCTIONS`: they import or compile text the code generator wrote, never a number).
"""

from __future__ import annotations

import importlib
import inspect
import io
import json
import os
import pkgutil
import signal
import sys
import time
import warnings

SKIP_MODULES = ("tstarg.reports.cli", "tstarg.reports.cmd_", "tstarg.reports._parallel")
SKIP_MODULES += ("tstarg.reports.pytest_plugin",)
SKIP_FUNCTIONS = {
    "tstarg.refimpl._compiled_taylor._import_kernel_module": "imports generated kernel source",
    "tstarg.refimpl._compiled_tensors._module": "imports generated kernel source",
    "tstarg.refimpl.codegen._loader.define": "executes generated kernel source",
    "tstarg.refimpl.codegen._loader.import_source": "imports generated kernel source",
    "tstarg.refimpl.codegen.define": "executes generated kernel source",
    "tstarg.refimpl.codegen.import_source": "imports generated kernel source",
    # they write the package's own shipped paper index (oracles/paper_index.json) by default: a walk
    # with a string for the paper's text replaced the repository's index (found after a slow run)
    "tstarg.oracles.paper_index.write_index": "writes the shipped index into the package",
    "tstarg.oracles.paper_index.main": "writes the shipped index into the package",
    # suite runners: (max_examples, seed), no model numbers; walked once (no string ran), they run
    # the whole suite with max_examples = 1 whatever the seed (20 min under load): left out
    "tstarg.oracles.oracle_checks.oracle_checks": "runs the oracle suite",
    "tstarg.properties.identity_checks.identity_checks": "runs the identity suite",
    "tstarg.properties.core_checks.core_checks": "runs the core suite",
}
PACKAGES = ("tstarg.refimpl", "tstarg.properties", "tstarg.oracles", "tstarg.reports")


class _Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise _Timeout()


def payloads(sentinel: str) -> list[str]:
    return [f"__import__('pathlib').Path({sentinel!r}).touch()"]


def modules(only: tuple[str, ...] = ()):
    for pkg_name in PACKAGES:
        pkg = importlib.import_module(pkg_name)
        if not only or pkg_name.startswith(only):
            yield pkg
        for info in pkgutil.walk_packages(pkg.__path__, pkg_name + "."):
            if info.name.startswith(SKIP_MODULES) or (only and not info.name.startswith(only)):
                continue
            try:
                yield importlib.import_module(info.name)
            except Exception:  # noqa: BLE001 - an optional dependency missing: nothing to walk
                continue


def callables(mod):
    """``(qualified name, callable, parameters)`` for functions and methods defined in ``mod``."""
    for name, obj in sorted(vars(mod).items()):
        if inspect.isfunction(obj) and obj.__module__ == mod.__name__:
            yield f"{mod.__name__}.{name}", obj
        elif inspect.isclass(obj) and obj.__module__ == mod.__name__:
            instance = None
            try:
                instance = obj()
            except BaseException:  # noqa: BLE001 - needs arguments: methods are walked unbound
                pass
            for mname, meth in sorted(vars(obj).items()):
                if isinstance(meth, (staticmethod, classmethod)):
                    yield f"{mod.__name__}.{name}.{mname}", getattr(obj, mname)
                elif inspect.isfunction(meth):
                    if instance is not None:
                        yield f"{mod.__name__}.{name}.{mname}", getattr(instance, mname)
                    else:
                        yield f"{mod.__name__}.{name}.{mname}", meth
        elif (
            not inspect.isclass(obj)
            and not inspect.ismodule(obj)
            and type(obj).__module__.startswith(PACKAGES)
            and not inspect.isfunction(obj)
        ):  # module-level instances such as fast.implementation
            for mname in dir(type(obj)):
                meth = getattr(type(obj), mname, None)
                if inspect.isfunction(meth) and not mname.startswith("__"):
                    yield f"{mod.__name__}.{name}.{mname}", getattr(obj, mname)


def arguments(fn, payload: str):
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return
    params = [p for p in sig.parameters.values() if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    base = {}
    for p in params:
        base[p.name] = p.default if p.default is not p.empty else 1
    for p in params:
        for value in (payload, [payload] * 3, [[payload] * 3] * 3):
            args = dict(base)
            args[p.name] = value
            yield args


def main() -> None:
    sentinel = os.path.abspath(sys.argv[1])
    home = os.getcwd()
    executed, calls, seen = [], 0, 0
    warnings.simplefilter("ignore")
    signal.signal(signal.SIGALRM, _alarm)
    slow = []
    for mod in modules(tuple(sys.argv[2:])):
        for qual, fn in callables(mod):
            if qual in SKIP_FUNCTIONS:
                continue
            seen += 1
            start = time.perf_counter()
            for payload in payloads(sentinel):
                for kwargs in arguments(fn, payload):
                    calls += 1
                    stdout, stderr = sys.stdout, sys.stderr
                    sys.stdout = sys.stderr = io.StringIO()
                    signal.signal(signal.SIGALRM, _alarm)
                    signal.setitimer(signal.ITIMER_REAL, 0.25)
                    try:
                        res = fn(**kwargs)
                        if inspect.isgenerator(res):
                            next(res, None)
                    except BaseException:  # noqa: BLE001 - only the sentinel is judged here
                        pass
                    finally:
                        signal.setitimer(signal.ITIMER_REAL, 0)
                        sys.stdout, sys.stderr = stdout, stderr
                        os.chdir(home)
                    if os.path.exists(sentinel):
                        executed.append(qual)
                        print(json.dumps({"executed": qual, "argument": list(kwargs)}), flush=True)
                        os.remove(sentinel)
            slow.append((time.perf_counter() - start, qual))
    slow.sort(reverse=True)
    summary = {"done": True, "functions": seen, "calls": calls, "executed": executed}
    summary["slowest"] = [f"{q} {s:.2f}s" for s, q in slow[:15]]
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
