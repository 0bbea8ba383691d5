"""The ``post:`` section validates what its readers need before any file is read: column
indices >= 0 and not shared, an axis map that is a rotation, CSV/.mat column roles
complete (one rule with the readers), attitude columns roll, pitch and yaw."""

import pytest

from inins.exceptions import InputError
from inins.scenario.import_flight import ImportFlightScenario
from inins.scenario.run_ekf import RunEkfScenario
from tests.helpers import shipped


@pytest.mark.parametrize(
    ("item", "key", "match"),
    [
        ("post.imu.accel_columns=[-1, 1, 2]", "accel_columns[0]", "must be >= 0"),
        ("post.imu.accel_columns=[0, 0, 2]", "accel_columns", "column 0 is given twice"),
        ("post.imu.gyro_columns=[3, 4, 6]", "time_column", "column 6 is given twice"),
        ("post.imu.axes=[x, y, -z]", "axes", "mirror image"),
        ("post.imu.axes=[x, x, z]", "axes", "do not name x, y and z once each"),
    ],
)
def test_imu_columns_and_axes(item, key, match):
    with pytest.raises(InputError, match=match) as err:
        shipped(RunEkfScenario, "run-ekf/lc-drive-15s.yaml", item)
    assert err.value.key.endswith(key), err.value.key


@pytest.mark.parametrize(
    ("item", "key", "match"),
    [
        ("post.gnss.columns={time: 9, lat: 6, lon: 7, height: 8, vel_n: 4}", "vel_e",
         "vel_e missing"),
        ("post.gnss.columns={lat: 6, lon: 7, height: 8}", "time", "time column is required"),
        ("post.gnss.columns={time: 9, lat: 6, lon: 7}", "height", "position columns incomplete"),
        ("post.gnss.columns={time: 9, lat: 6, lon: 7, height: t}", "height",
         "0-based column index"),
        ("post.gnss.attitude_columns={pitch: 0, roll: 1}", "attitude_columns", "yaw"),
    ],
)  # fmt: skip
def test_mat_column_roles(item, key, match):
    with pytest.raises(InputError, match=match) as err:
        shipped(RunEkfScenario, "run-ekf/fog-mems.yaml", item)
    assert err.value.key.endswith(key), err.value.key


def test_the_shipped_post_scenarios_validate():
    for name in ("lc-drive-15s", "lc-drive-30s-aided", "fog-mems"):
        assert shipped(RunEkfScenario, f"run-ekf/{name}.yaml").post is not None
    assert shipped(ImportFlightScenario, "import-flight/lc-drive-solution.yaml").solution_imu
