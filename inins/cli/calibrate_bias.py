"""``inins calibrate-bias``: gyro-bias calibration on a rate table (spec §4, paper 000).

See :mod:`inins.calibration.calibrate`.
"""

from inins.calibration import calibrate, ett, report
from inins.io import plots
from inins.io.ettresult import read_ett_result
from inins.io.records import load_record
from inins.io.scenarios.calibrate_bias import CalibrateBiasScenario

SCENARIO_MODEL = CalibrateBiasScenario
PLOTS = {"calibrate-bias-roll.png": plots.calibrate_bias_roll,
         "calibrate-bias-pitch.png": plots.calibrate_bias_pitch}


def _ett(model, record):
    """The ETT mounting for alignment method ett: from a file, or from this record."""
    if model.alignment.method != "ett":
        return None
    if model.alignment.ett_file is not None:
        return read_ett_result(model.alignment.ett_file)
    nominal = None if model.simulate is None else model.simulate.mount.nominal()
    return ett.align_ett(record, ett.EttOptions(mat_tb0=nominal)).result


def run(model, seed, progress=None):
    """Calibrate from the scenario's data file or its in-memory simulation."""
    record, sensor = load_record(model.data, model.simulate, seed)
    settings = model.settings(sensor, _ett(model, record))
    outcome = calibrate.calibrate(record, settings, progress)
    return report.build(outcome, record, settings, model.paper000_case)
