"""The shipped scenarios give the same results, to the last bit, as the stored reference.

``tests/data/reference_summaries.json`` holds the ``results`` and ``truth`` of every
shipped scenario's ``summary.json`` (default seed), written by the CLI before the
package was reorganised into ``scenario/``, ``commands/`` and ``io/``
(``inins CMD configs/... -o DIR`` for each file). A change of arithmetic shows here
as a change of digits; a deliberate one updates the reference in the same commit
and says why: ``python -m tests.test_reference_results CONFIG...`` rewrites the
entries of the named scenarios from a run of the current tree.

The run-ekf (the recorded PSINS drive), observability and import-flight entries were
added later, from the tree of their commit (the run-ekf timing results
``realtime_factor`` and ``update_time_mean_s`` are only checked to be present).
"""

import json
import math
from pathlib import Path

import pytest

from inins.commands import find_command
from inins.commands.execute import execute

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = json.loads((ROOT / "tests" / "data" / "reference_summaries.json").read_text())


VOLATILE = {"realtime_factor", "update_time_mean_s"}
"""Results that measure the machine, not the arithmetic."""


def _same(a, b):
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


@pytest.mark.parametrize("config", sorted(REFERENCE))
def test_shipped_scenario_reproduces_the_reference(config):
    ref = REFERENCE[config]
    summary = execute(find_command(ref["command"]), ROOT / config).summary
    assert summary["seed"] == ref["seed"]
    for part in ("results", "truth"):
        got, want = summary[part], ref[part]
        assert sorted(got) == sorted(want), part
        diff = {
            k: (got[k], want[k]) for k in want if k not in VOLATILE and not _same(got[k], want[k])
        }
        assert diff == {}, f"{part} differ: {diff}"


def _update(configs):
    """Rewrite the reference entries of ``configs`` (paths relative to the repository)."""
    data = dict(REFERENCE)
    for config in configs:  # configs/<command>/<name>.yaml unless already listed
        command = data.get(config, {}).get("command") or Path(config).parent.name
        summary = execute(find_command(command), ROOT / config).summary
        data[config] = {
            "command": command,
            "results": summary["results"],
            "seed": summary["seed"],
            "truth": summary["truth"],
        }
    path = ROOT / "tests" / "data" / "reference_summaries.json"
    path.write_text(json.dumps(dict(sorted(data.items())), indent=1))  # the file's own format


if __name__ == "__main__":
    import sys

    _update(sys.argv[1:])
