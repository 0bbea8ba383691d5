"""Run one inins command in this process twice and report JSON on stderr.

``python -m benchmarks._measure simulate-table SCENARIO -o OUT`` -> one JSON line:
``wall_s`` (the first run, as a user sees it: interpreter start-up, imports and
loading the cached JIT code included), ``warm_s`` (the same command run again in
the same process: after JIT warm-up), ``peak_rss_mb`` and ``exit``.
"""

import json
import resource
import sys
import time


def _once(app):
    try:
        app(args=sys.argv[1:], prog_name="inins")
        return 0
    except SystemExit as exc:
        return exc.code or 0


def main():
    start = time.perf_counter()
    from inins.cli import app

    code = _once(app)
    wall = time.perf_counter() - start
    start = time.perf_counter()
    code = code or _once(app)
    warm = time.perf_counter() - start
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(
        json.dumps({"wall_s": wall, "warm_s": warm, "peak_rss_mb": rss, "exit": code}),
        file=sys.stderr,
    )


if __name__ == "__main__":
    main()
