"""``inins align-ett``: azimuth of the IMU on the table from the pitch-90 deg / level
positions with accelerometers only (spec §5, 000 §3.1), compared with gyrocompassing.

See :mod:`inins.calibration.ett` (method) and :mod:`inins.io.ettresult` (output layout,
and :func:`~inins.io.ettresult.read_ett_result` for calibrate-bias).
"""

from inins.calibration.ett import align_ett
from inins.io.ettresult import command_result
from inins.io.records import load_record
from inins.io.scenarios.align_ett import AlignEttScenario

SCENARIO_MODEL = AlignEttScenario


def run(model, seed, progress=None):
    """ETT alignment of the scenario's table record (the data file, or the ``simulate``
    section simulated in memory with ``seed``); see :func:`align_ett`."""
    record, _ = load_record(model.data, model.simulate, seed, progress)
    return command_result(align_ett(record, model.options()), record.gimbals, record.source)
