"""FB feedback carries the correction over the data latency (003 §3.3.2): the error the
filter estimated at the PPS time ``t_k`` has grown by ``F tau`` when the correction is
applied at ``t_k + tau``. Checked against a finite-difference propagation: the true and
the erroneous INS are both integrated by the strapdown over ``tau`` from the same
increments, and ``nav(t_k + tau) (-) (I + F tau) x`` must give the truth back to second
order in ``tau``.

``inins.ekf.step.feedback`` (compiled) is the only entry point of the FB step; it is
tested directly.
"""

import numpy as np
import pytest

from inins.core import error_model, rotation, strapdown
from inins.core.units import DEG
from inins.ekf import kernels, step

DT = 0.005
TAU = 0.5


def _increments(n, mat_nb, lla):
    """A gentle manoeuvre: level flight with a slow yaw and a small forward push."""
    g = 9.8
    w_b = np.array([0.0, 0.0, 2.0 * DEG])
    f_b = mat_nb.T @ np.array([0.3, 0.0, -g])
    return np.tile(w_b * DT, (n, 1)), np.tile(f_b * DT, (n, 1)), w_b, f_b


def _errors(quat, vel, lla, quat_t, vel_t, lla_t):
    pos = error_model.position_error_ned(lla, lla_t)
    phi = error_model.attitude_error(rotation.mat_from_quat(quat), rotation.mat_from_quat(quat_t))
    return np.concatenate([pos, vel - vel_t, phi])


def _run(tau_used):
    lla = np.array([37.0 * DEG, 127.0 * DEG, 500.0])
    mat_nb = rotation.mat_from_euler(0.0, 0.0, 30.0 * DEG)
    vel = np.array([80.0, 40.0, 0.0])
    n = round(TAU / DT)
    dtheta, dv, w_b, f_b = _increments(n, mat_nb, lla)
    # the INS error at t_k: position, velocity, attitude and an accelerometer bias
    x = np.zeros(17)
    x[0:3] = [6.0, -4.0, 3.0]
    x[3:6] = [2.0, -1.5, 0.5]
    x[6:9] = [2e-3, -1.5e-3, 3e-3]
    x[9:12] = [2e-2, -1e-2, 1.5e-2]
    truth = strapdown.NavState(rotation.quat_from_mat(mat_nb), vel, lla)
    ins = strapdown.NavState(
        rotation.quat_from_mat(rotation.mat_from_rotvec(-x[6:9]) @ mat_nb),
        vel + x[3:6],
        error_model.lla_offset(lla, x[0:3]),
    )
    end_t, _ = strapdown.integrate(truth, dtheta, dv, DT)
    end_i, _ = strapdown.integrate(ins, dtheta, dv + x[9:12] * DT, DT)  # the biased sensor
    grown = _errors(end_i.quat_nb, end_i.vel_n, end_i.lla, end_t.quat_nb, end_t.vel_n, end_t.lla)
    F = np.zeros((17, 17))
    kernels.system_matrix26(lla[0], lla[2], vel, f_b, mat_nb, w_b, F)
    quat, v, p = end_i.quat_nb.copy(), end_i.vel_n.copy(), end_i.lla.copy()
    comp, cum = np.zeros(15), np.zeros(9)
    step.feedback(x.copy(), F, tau_used, quat, v, p, comp, cum, np.r_[9:15])
    left = _errors(quat, v, p, end_t.quat_nb, end_t.vel_n, end_t.lla)
    return x, grown, left, comp, cum


def test_feedback_carries_the_correction_over_the_latency():
    x, grown, left, comp, cum = _run(TAU)
    growth = grown - x[:9]
    # the error has grown measurably over tau: position by v tau, velocity by f x phi + b
    assert np.linalg.norm(growth[0:3]) > 0.9
    assert np.linalg.norm(growth[3:6]) > 0.01
    # second order in tau is left: (F tau)^2 / 2, a per cent of the growth at most
    for block in (slice(0, 3), slice(3, 6), slice(6, 9)):
        assert np.linalg.norm(left[block]) < 0.02 * np.linalg.norm(growth[block]), block
    # the sensor estimate moves into the compensation, the navigation states are logged
    np.testing.assert_array_equal(comp[0:3], x[9:12])
    np.testing.assert_array_equal(cum, x[:9])


@pytest.mark.parametrize("tau_used", [0.0, -TAU])
def test_a_correction_not_carried_over_leaves_the_growth(tau_used):
    """Without ``F tau`` (or with its sign flipped) the growth over the latency stays."""
    x, grown, left, _, _ = _run(tau_used)
    growth = grown - x[:9]
    for block in (slice(0, 3), slice(3, 6)):
        assert np.linalg.norm(left[block]) > 0.5 * np.linalg.norm(growth[block]), block
