"""A long simulated record is spilled to a temporary table-data file (memory flat in the
record length); calibrate-bias and align-ett give the same results from it, to the last
bit, as from the record kept in memory, and the file goes away with the record."""

import gc
import tempfile
from pathlib import Path

from inins.commands import _table, align_ett, calibrate_bias
from inins.scenario.align_ett import AlignEttScenario
from inins.scenario.calibrate_bias import CalibrateBiasScenario
from tests.helpers import shipped


def _leftovers():
    return sorted(Path(tempfile.gettempdir()).glob("inins-simulation-*"))


def test_spilled_and_in_memory_records_give_identical_results(monkeypatch):
    before = _leftovers()
    cases = (
        (
            calibrate_bias,
            shipped(
                CalibrateBiasScenario,
                "paper000/case3-pitch-mount.yaml",
                **{"simulate.imu.sample_rate_hz": 20},
            ),
        ),
        (align_ett, shipped(AlignEttScenario, "align-ett/default.yaml")),
    )
    for command, scenario in cases:
        memory = command.run(scenario, 3).results
        monkeypatch.setattr(_table, "SPILL_BYTES", 0)
        record, _ = _table.load_record(scenario.data, scenario.simulate, 3)
        assert record.source == "simulation" and not hasattr(record, "dtheta")
        del record
        spilled = command.run(scenario, 3).results
        monkeypatch.setattr(_table, "SPILL_BYTES", 32 << 20)
        assert spilled == memory, command.__name__
    gc.collect()
    assert _leftovers() == before
