"""Rate-table kinematics against closed forms and numerical differentiation."""

import numpy as np
import pytest

from inins.core import earth, rotation
from inins.core.units import ARCSEC, DEG
from inins.table.kinematics import MountRotation, TableTrajectory, base_matrix, gimbal_axes
from inins.table.program import Hold, Rotate, compile_program

LLA = np.array([37.0 * DEG, 127.0 * DEG, 50.0])
RFU = np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, -1]])  # IMU x right, y forward, z up (000)


def table(steps, initial=(0.0, 0.0), mat_tb0=None, mounts=(), azimuth=0.0, nonorth=None):
    return TableTrajectory(
        compile_program(steps, np.array(initial)),
        gimbal_axes(["yaw", "pitch"], nonorth),
        base_matrix(azimuth),
        np.eye(3) if mat_tb0 is None else mat_tb0,
        tuple(mounts),
        LLA,
    )


def test_level_hold_senses_earth_rate_and_gravity():
    g = earth.gravity(LLA[0], LLA[2])
    w_ie = earth.rate_ie_n(LLA[0])
    omega, f = table([Hold(10.0)]).rates([1.0, 5.0])
    np.testing.assert_allclose(omega, [w_ie, w_ie], atol=1e-20)
    np.testing.assert_allclose(f, [[0, 0, -g]] * 2, atol=1e-15)
    # 000 mounting (z up), table turned to yaw 90: IMU y (forward) points east
    omega, f = table([Hold(10.0)], initial=(90 * DEG, 0.0), mat_tb0=RFU).rates([1.0])
    np.testing.assert_allclose(f[0], [0, 0, g], atol=1e-14)
    np.testing.assert_allclose(omega[0], [-w_ie[0], 0.0, -w_ie[2]], atol=1e-19)


def test_pitch_90_points_forward_axis_up():
    traj = table([Hold(1.0)], initial=(0.0, 90 * DEG))
    mat_nb, vel, lla = traj.state([0.5])
    np.testing.assert_allclose(mat_nb[0] @ [1.0, 0, 0], [0, 0, -1.0], atol=1e-15)
    np.testing.assert_allclose(vel, 0.0)
    np.testing.assert_allclose(lla[0], LLA)


@pytest.mark.parametrize(
    "mounts", [(), (MountRotation(np.array([0, 1.0, 0]), 0.2, 3.0, 40.0, smooth=True),)]
)
def test_rates_are_the_derivative_of_the_attitude(mounts):
    steps = [
        Hold(5.0),
        Rotate(0, np.pi, 10 * DEG, 20 * DEG),
        Hold(3.0),
        Rotate(1, np.pi / 2, 10 * DEG, 20 * DEG),
        Hold(2.0),
    ]
    traj = table(
        steps,
        mat_tb0=rotation.mat_from_euler(0.1, 0.2, 0.3),
        mounts=mounts,
        azimuth=0.3,
        nonorth=[[200 * ARCSEC, 400 * ARCSEC], [600 * ARCSEC, 0.0]],
    )
    t = np.linspace(0.7, traj.program.duration - 0.7, 61)
    t = t[np.min(np.abs(t[:, None] - traj.breakpoints[None]), axis=1) > 1e-3]
    h = 1e-5
    mat, _, _ = traj.state(t)
    d_mat = (traj.state(t + h)[0] - traj.state(t - h)[0]) / (2 * h)
    w_nb = np.swapaxes(mat, 1, 2) @ d_mat  # the table is fixed to the Earth: [omega_nb_b x]
    omega_nb = np.stack([w_nb[:, 2, 1], w_nb[:, 0, 2], w_nb[:, 1, 0]], axis=1)
    omega, f = traj.rates(t)
    w_ie_b = np.einsum("kji,j->ki", mat, earth.rate_ie_n(LLA[0]))
    np.testing.assert_allclose(omega, omega_nb + w_ie_b, atol=1e-9)  # central-difference error
    g_n = earth.gravity_n(LLA[0], LLA[2])
    np.testing.assert_allclose(f, -np.einsum("kji,j->ki", mat, g_n), atol=1e-14)


def test_mount_rotation_enters_the_attitude():
    axis = np.array([1.0, 0, 0])
    mount = MountRotation(axis, 0.005 * DEG, 10.0, 100.0)
    traj = table([Hold(200.0)], mat_tb0=RFU, mounts=[mount])
    np.testing.assert_allclose(
        traj.mount_rotvec([0.0, 60.0, 150.0])[:, 0], [0.0, 0.0025 * DEG, 0.005 * DEG], atol=1e-18
    )
    before, after = traj.state([5.0, 150.0])[0]
    np.testing.assert_allclose(
        before.T @ after, rotation.mat_from_rotvec(axis * 0.005 * DEG), atol=1e-16
    )
    # the gyro senses the mount rate on top of the Earth rate
    omega, _ = traj.rates([50.0])
    w_ie_b = RFU.T @ earth.rate_ie_n(LLA[0])
    assert omega[0, 0] - w_ie_b[0] == pytest.approx(0.005 * DEG / 100.0, rel=1e-6)
