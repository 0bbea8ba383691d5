"""The shipped scenarios give the same results, to the last bit, as the stored reference.

``tests/data/reference_summaries.json`` holds the ``results`` and ``truth`` of every
shipped scenario's ``summary.json`` (default seed), written by the CLI before the
package was reorganised into ``scenario/``, ``commands/`` and ``io/``
(``inins CMD configs/... -o DIR`` for each file). A change of arithmetic shows here
as a change of digits; a deliberate one updates the reference in the same commit
and says why.
"""

import json
import math
from pathlib import Path

import pytest

from inins.commands import find_command
from inins.commands.execute import execute

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = json.loads((ROOT / "tests" / "data" / "reference_summaries.json").read_text())


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
        diff = {k: (got[k], want[k]) for k in want if not _same(got[k], want[k])}
        assert diff == {}, f"{part} differ: {diff}"
