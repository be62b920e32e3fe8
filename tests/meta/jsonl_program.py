"""A protocol implementation over JSON lines (for tests of ``tstarg certify --cmd``).

Usage: ``python jsonl_program.py [--hang-on K] [--crash-on K] [--state FILE] [--only METHOD ...]
[--flow]``: answers with refimpl.fast, but sleeps forever on the K-th request (a hang) or exits on
the K-th request (a crash); methods not in ``--only`` are answered "unknown method". ``flow`` is
answered only with ``--flow`` (used by ``tstarg bench --cmd``).
With ``--state FILE`` the request count survives restarts (the harness restarts a hung or
crashed program), so each incident happens once.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--hang-on", type=int, default=-1)
    ap.add_argument("--crash-on", type=int, default=-1)
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--state", default=None)
    ap.add_argument("--flow", action="store_true", help="answer flow too (refimpl.fast)")
    a = ap.parse_args()
    import os

    from tstarg.refimpl.fast import implementation as fast

    # warm the kernels before the first request: their first call (numba cache load) must fall
    # in the start-up time, not in a 2 s per-request timeout on a loaded machine
    eps = np.zeros((3, 3, 3))
    eps[0, 1, 2], eps[0, 2, 1], eps[1, 2, 0], eps[1, 0, 2], eps[2, 0, 1], eps[2, 1, 0] = (
        1,
        -1,
        1,
        -1,
        1,
        -1,
    )
    z, e = np.zeros((3, 3)), np.eye(3)
    fast.poisson_tensor(eps, z, z, np.full(3, 0.1), np.ones(3))
    fast.hamiltonian_vector_field(eps, z, z, e, None, np.full(3, 0.1), np.ones(3))
    count = int(open(a.state).read() or 0) if a.state and os.path.exists(a.state) else 0
    for line in sys.stdin:
        count += 1
        if a.state:
            with open(a.state, "w") as fh:
                fh.write(str(count))
        req = json.loads(line)
        rid, method, args = req["id"], req["method"], req["args"]
        if count == a.hang_on:
            time.sleep(3600)
        if count == a.crash_on:
            sys.stdout.flush()
            os._exit(3)  # at once: an interpreter teardown can outlast a 2 s timeout under load
        if (a.only is not None and method not in a.only) or method not in (
            "poisson_tensor",
            "hamiltonian_vector_field",
            *(("flow",) if a.flow else ()),
        ):
            reply = {"id": rid, "error": f"unknown method {method}"}
        else:
            try:
                arr = {
                    k: (np.asarray(v, dtype=float) if v is not None and k != "potential" else v)
                    for k, v in args.items()
                }
                if method == "poisson_tensor":
                    res = fast.poisson_tensor(
                        arr["f"], arr["theta"], arr["upsilon"], arr["x"], arr["pi"]
                    ).tolist()
                elif method == "flow":
                    xs, ps = fast.flow(
                        *(arr[k] for k in ("f", "theta", "upsilon", "inertia")),
                        arr["potential"],
                        arr["x0"],
                        arr["pi0"],
                        float(arr["t"]),
                    )
                    res = [xs.tolist(), ps.tolist()]
                else:
                    xd, pd = fast.hamiltonian_vector_field(
                        arr["f"],
                        arr["theta"],
                        arr["upsilon"],
                        arr["inertia"],
                        arr["potential"],
                        arr["x"],
                        arr["pi"],
                    )
                    res = [xd.tolist(), pd.tolist()]
                reply = {"id": rid, "result": res}
            except ValueError as exc:
                reply = {"id": rid, "error": f"ValueError: {exc}"}
        sys.stdout.write(json.dumps(reply) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
