"""Issue 7 item 2: where the east formulas are rejected (mount rotation about the east
axis after gyrocompassing), eq. 38 must not borrow the east bias from the rejected pair.

Before the fix beta_y came from the eq. 44 pair: -23 % at a 0.01 deg rotation (T = 300 s,
latitude 20 deg, beta = (-0.015, 0.008) deg/h), the wrong sign at 0.05 deg, and the y-axis
mount check fired (1.3"). The north formula sees the east bias only through the two turns,
2 Delta / (pi T) = 3.8 % here; the east bias now comes from the velocity method, which a
mount rotation does not reach.
"""

import numpy as np
import pytest

from inins.calibration import bias
from inins.commands._table import load_record
from inins.scenario.calibrate_bias import CalibrateBiasScenario
from inins.scenario.si.calibrate_bias import method_settings
from tests.helpers import shipped

X, Y = 0, 1
MOTION = [
    {"kind": "hold", "duration_s": 300, "label": "align"},
    {"kind": "hold", "duration_s": 300, "label": "0deg"},
    {"kind": "rotate", "axis": "yaw", "angle_deg": 180, "rate_dps": 10},
    {"kind": "hold", "duration_s": 300, "label": "180deg"},
    {"kind": "rotate", "axis": "yaw", "angle_deg": -180, "rate_dps": 10},
    {"kind": "hold", "duration_s": 60, "label": "0deg-return"},
]


def calibrate(angle_deg, **updates):
    model = shipped(
        CalibrateBiasScenario,
        "paper000/case1-no-disturbance.yaml",
        **{
            "simulate.imu.gyro.bias_dph": [-0.015, 0.008, 0.0],
            "simulate.site.lat_deg": 20.0,
            "simulate.imu.sample_rate_hz": 50,
            "simulate.motion": MOTION,
            "simulate.mount.rotations": [
                {"axis": "x", "angle_deg": angle_deg, "start_s": 350, "duration_s": 200}
            ],
            **updates,
        },
    )
    record, sensor = load_record(model.data, model.simulate, 1)
    return bias.calibrate_bias(record, method_settings(model, sensor))


@pytest.mark.parametrize("angle", [0.01, 0.05])
def test_eq38_holds_when_the_east_axis_is_rejected(angle):
    out = calibrate(angle)
    truth = out.truth.bias
    assert out.choice.east_formula is None and out.chosen[X] is None
    value, _, formula = out.chosen[Y]
    assert formula == "eq38"
    assert abs(value - truth[Y]) < 1e-3 * abs(truth[Y])
    # the rejected pair would have been far off: that is what eq. 38 no longer borrows
    assert abs(out.estimates["eq44"].value[Y] - truth[Y]) > 0.2 * abs(truth[Y])
    moved = np.abs(out.check.residual) > out.threshold
    assert moved.tolist() == [True, False]  # x turned; no false y detection


def test_eq38_alone_with_an_accelerometer_change_stays_within_its_coupling():
    """The velocity method's east bias is spoiled by an accelerometer change after the
    turns (000 Fig. 2); eq. 38 carries that error times the turn coupling 2 Delta/(pi T)
    only (noise-free: the coupling bound is checked directly)."""
    out = calibrate(
        0.01,
        **{
            "simulate.disturbances.accel_bias_after_rotation": {
                "step_ug": [50.0, 50.0, 0.0],
                "settle_time_s": 120,
            }
        },
    )
    truth = out.truth.bias
    east_err = out.estimates["velocity"].value[X] - truth[X]
    coupling = 2 * 18.0 / (np.pi * 300.0)
    err = out.chosen[Y][0] - truth[Y]
    assert abs(east_err) > 0.1 * abs(truth[X])  # the velocity method is really off
    assert abs(err) < 1.5 * coupling * abs(east_err) + 1e-3 * abs(truth[Y])
