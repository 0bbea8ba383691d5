"""Run one inins command in this process and report its wall time and peak RSS as JSON.

``python -m benchmarks._measure simulate-table SCENARIO -o OUT`` -> stdout of the
command, then one JSON line on stderr: ``{"wall_s", "peak_rss_mb", "exit"}``.
"""

import json
import resource
import sys
import time


def main():
    start = time.perf_counter()
    from inins.cli import app

    try:
        app(args=sys.argv[1:], prog_name="inins")
        code = 0
    except SystemExit as exc:
        code = exc.code or 0
    wall = time.perf_counter() - start
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(json.dumps({"wall_s": wall, "peak_rss_mb": rss, "exit": code}), file=sys.stderr)


if __name__ == "__main__":
    main()
