"""A JSON-lines program that misbehaves in one chosen way (issue 15, findings 2 and 5).

``python bad_program.py MODE``: ``garbage`` prints non-JSON lines forever; ``exit`` exits
at once; ``silent`` reads but never answers; ``nan`` answers every request with NaNs;
``flood`` floods replies with a wrong id; ``fork`` starts children that sleep, then answers
correctly; ``abc`` answers ``"abc"``; ``noresult`` answers without ``result``; ``stderr``
answers correctly but writes to stderr, and crashes on the 6th request after a message there.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np


def answer(req):
    from tstarg.refimpl.fast import implementation as fast

    a = {
        k: (np.asarray(v, dtype=float) if v is not None and k != "potential" else v)
        for k, v in req["args"].items()
    }
    if req["method"] != "poisson_tensor":
        return {"id": req["id"], "error": f"unknown method {req['method']}"}
    try:
        return {
            "id": req["id"],
            "result": fast.poisson_tensor(
                a["f"], a["theta"], a["upsilon"], a["x"], a["pi"]
            ).tolist(),
        }
    except ValueError as exc:
        return {"id": req["id"], "error": f"ValueError: {exc}"}


def main() -> None:
    mode = sys.argv[1]
    if mode == "exit":
        sys.exit(1)
    if mode == "garbage":
        while True:
            sys.stdout.write("this is not json\n")
            sys.stdout.flush()
    if mode == "fork":  # argv[2]: a file that receives the children's pids
        kids = [
            subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
            for _ in range(3)
        ]
        with open(sys.argv[2], "a") as fh:
            fh.write("".join(f"{k.pid}\n" for k in kids))
    count = 0
    for line in sys.stdin:
        count += 1
        req = json.loads(line)
        if mode == "silent":
            continue
        if mode == "flood":
            while True:
                sys.stdout.write(json.dumps({"id": -1, "result": 0}) + "\n")
                sys.stdout.flush()
        if mode == "nan":
            n = len(req["args"]["f"])
            reply = {"id": req["id"], "result": [[float("nan")] * (2 * n)] * (2 * n)}
        elif mode == "abc":
            reply = {"id": req["id"], "result": "abc"}
        elif mode == "noresult":
            reply = {"id": req["id"]}
        else:
            if mode == "stderr":
                print(f"stderr line for request {count}", file=sys.stderr, flush=True)
                if count == 6:
                    print("fatal: planted crash", file=sys.stderr, flush=True)
                    sys.exit(7)
            reply = answer(req)
        sys.stdout.write(json.dumps(reply) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
