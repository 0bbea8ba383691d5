"""The recorded-flight start: the IMU position below the antenna's fix (lever arm)."""

import numpy as np

from inins.core import earth, rotation
from inins.core.units import DEG
from inins.ekf import recorded
from inins.gnss.simulate import antenna_states


def test_imu_position_inverts_the_antenna_lever_arm():
    """The antenna of the IMU at ``lla`` with attitude ``mat_nb`` and lever ``l_b`` is
    ``r + mat_en mat_nb l_b``; back from the antenna to the IMU within 2 mm (the NED
    frame taken at the antenna, 100 m away at most)."""
    lla = np.array([37.0 * DEG, 127.0 * DEG, 120.0])
    for euler, lever in (
        ((0.1, -0.05, 2.0), (1.5, 0.2, -1.0)),
        ((0.0, 0.3, -1.0), (-40.0, 60.0, 20.0)),
    ):
        mat_nb = rotation.mat_from_euler(*euler)
        r_ant, _ = antenna_states(lla[None], np.zeros((1, 3)), mat_nb[None], None, lever)
        r_imu = recorded.imu_position(r_ant[0], mat_nb, lever)
        assert np.linalg.norm(r_imu - earth.ecef_from_llh(*lla)) < 2e-3
        assert abs(np.linalg.norm(r_ant[0] - r_imu) - np.linalg.norm(lever)) < 1e-6


def test_antenna_positions_add_the_lever_arm_along_the_attitude():
    lla = np.array([[0.6, 2.0, 50.0], [0.6001, 2.0001, 60.0]])
    quat = np.array([rotation.quat_from_mat(rotation.mat_from_euler(0.0, 0.0, h)) for h in (0, 1)])
    lever = np.array([2.0, 0.0, 0.0])  # 2 m forward
    pos = recorded.antenna_positions(lla, quat, lever)
    base = earth.ecef_from_llh(lla[:, 0], lla[:, 1], lla[:, 2])
    for k, heading in enumerate((0.0, 1.0)):
        forward_n = 2.0 * np.array([np.cos(heading), np.sin(heading), 0.0])
        np.testing.assert_allclose(
            earth.mat_en(lla[k, 0], lla[k, 1]).T @ (pos[k] - base[k]), forward_n, atol=1e-9
        )
