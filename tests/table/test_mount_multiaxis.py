"""Mount rotations about several body axes at once (``m`` and ``dm/dt`` not parallel):
the gyro must sense ``omega_tb_b = J_r(m) dm/dt`` with the full right Jacobian of SO(3),
``dm/dt - b (m x dm/dt) + c m x (m x dm/dt)``; a single-axis mount only sees the first
term. Checked against the numerical derivative of the attitude, at mount angles large
enough (0.3 and 0.4 rad) that the second-order terms are far above the difference error."""

import numpy as np
import pytest

from inins.core import earth, rotation
from inins.core.units import DEG
from inins.table.kinematics import MountRotation, TableTrajectory, base_matrix, gimbal_axes
from inins.table.program import Hold, Rotate, compile_program

LLA = np.array([37.0 * DEG, 127.0 * DEG, 50.0])


def _trajectory(mounts):
    steps = [Hold(5.0), Rotate(0, np.pi, 10 * DEG, 20 * DEG), Hold(10.0)]
    return TableTrajectory(
        compile_program(steps, np.zeros(2)),
        gimbal_axes(["yaw", "pitch"], None),
        base_matrix(0.3),
        rotation.mat_from_euler(0.1, 0.2, 0.3),
        tuple(mounts),
        LLA,
    )


def _omega_from_attitude(traj, t, h=1e-5):
    mat = traj.state(t)[0]
    d_mat = (traj.state(t + h)[0] - traj.state(t - h)[0]) / (2 * h)
    w_nb = np.swapaxes(mat, 1, 2) @ d_mat
    omega_nb = np.stack([w_nb[:, 2, 1], w_nb[:, 0, 2], w_nb[:, 1, 0]], axis=1)
    return omega_nb + np.einsum("kji,j->ki", mat, earth.rate_ie_n(LLA[0]))


@pytest.mark.parametrize("smooth", [True, False])
def test_two_axis_mount_rates_are_the_derivative_of_the_attitude(smooth):
    mounts = (
        MountRotation(np.array([1.0, 0.0, 0.0]), 0.3, 2.0, 20.0, smooth=smooth),
        MountRotation(np.array([0.0, 0.6, 0.8]), -0.4, 6.0, 18.0, smooth=smooth),
    )
    traj = _trajectory(mounts)
    t = np.linspace(6.5, 19.5, 27)  # both mounts moving, the table too for a while
    t = t[np.min(np.abs(t[:, None] - traj.breakpoints[None]), axis=1) > 1e-3]
    omega, f = traj.rates(t)
    np.testing.assert_allclose(omega, _omega_from_attitude(traj, t), atol=1e-9)
    g_n = earth.gravity_n(LLA[0], LLA[2])
    mat = traj.state(t)[0]
    np.testing.assert_allclose(f, -np.einsum("kji,j->ki", mat, g_n), atol=1e-13)
    # the case discriminates: the rate differs from dm/dt alone by far more than 1e-9
    m = traj.mount_rotvec(t)
    mdot = (traj.mount_rotvec(t + 1e-6) - traj.mount_rotvec(t - 1e-6)) / 2e-6
    assert np.max(np.linalg.norm(np.cross(m, mdot), axis=1)) > 1e-3
