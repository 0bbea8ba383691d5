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


def test_spilled_and_in_memory_records_give_identical_results(monkeypatch, tmp_path):
    # a temporary folder of this test's own: another process's spilled simulation (a
    # second test worker) never shows in the count
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
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


def test_file_truth_reads_every_truth_series_lazily(tmp_path):
    """The file's truth has every series of the in-memory truth, equal to the last bit,
    read when asked and not kept."""
    from inins.core.records import TRUTH_SERIES
    from inins.io.tabledata import FileTruth

    lazy = {n for n, v in vars(FileTruth).items() if isinstance(v, property)}
    assert lazy == set(TRUTH_SERIES)
    scenario = shipped(AlignEttScenario, "align-ett/default.yaml")
    memory, _ = _table.load_record(scenario.data, scenario.simulate, 3)
    spilled = _table.spilled_record(scenario.simulate, 3)
    for name in TRUTH_SERIES:
        assert (getattr(spilled.truth, name) == getattr(memory.truth, name)).all(), name
