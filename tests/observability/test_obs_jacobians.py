"""The observability models' F and measurement rows against a finite difference of the
nonlinear models (``tests/jacobian.py``), every block of every model of the library, at
an operating point that makes every term matter (a turning body, an aircraft's speed, a
lever arm and a baseline of metres, a non-level attitude).

The observability convention (:mod:`inins.observability.measurements`): the error state
is estimated minus true, ``dz = H x`` with ``z`` the INS-predicted minus the measured
value; so the nonlinear model is the prediction of an estimate ``true (+) x``.
"""

import numpy as np
import pytest

from inins.core import earth, rotation
from inins.core.error_model import ALIGN12, EKF17, EKF26
from inins.core.units import DEG
from inins.observability import measurements as meas
from inins.observability.models import MODELS
from inins.observability.segments import make_segment
from tests.jacobian import assert_jacobian, column_tolerance, error_rate

LLA = np.array([37.5 * DEG, 127.0 * DEG, 800.0])
MAT_NB = rotation.mat_from_euler(20 * DEG, -10 * DEG, 130 * DEG)
VEL = np.array([150.0, -80.0, 5.0])
OMEGA_IB = np.array([0.2, -0.1, 0.3])
F_N = MAT_NB @ np.array([1.2, -0.7, -9.5])
LEVER = np.array([1.5, -0.8, -2.0])
BASELINE = np.array([0.3, 1.8, -0.1])
LOS = np.array(
    [[0.0, 0.0, -1.0], [0.5, 0.3, -0.8], [-0.4, 0.6, -0.6], [0.2, -0.7, -0.5], [-0.6, -0.5, -0.3]]
)
LOS = LOS / np.linalg.norm(LOS, axis=1)[:, None]
SEGMENT = make_segment(60.0, LLA, mat_nb=MAT_NB, vel_n=VEL, f_n=F_N, omega_ib_b=OMEGA_IB)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_model_is_the_jacobian_of_the_error_dynamics(name):
    model = MODELS[name]
    layout = model.layout
    F = model.system_matrices([SEGMENT])[0]
    point = (LLA, VEL, MAT_NB, MAT_NB.T @ F_N, OMEGA_IB)
    assert_jacobian(
        F,
        lambda x: error_rate(
            layout, point, x, tau=0.01, transport_from_estimate=model.transport_from_estimate
        ),
        np.zeros(len(layout)),
        layout,
        name,
        atol=column_tolerance(F, layout, 2e-5, 1e-12),
        rtol=0.0,
        steps={"position": 1e4, "velocity": 0.1, "attitude": 1e-3, "gyro_bias": 1e-6},
    )


def _value(layout, x, names):
    return np.array([x[layout.index(n)] if n in layout.names else 0.0 for n in names])


def _estimate(layout, x):
    """The INS estimate ``true (+) x``: attitude ``exp(-[phi x]) C``, the displacement and
    velocity errors, the gyro bias the INS leaves in its rates."""
    phi = _value(layout, x, ("phi_N", "phi_E", "phi_D"))
    c_est = rotation.mat_from_rotvec(-phi) @ MAT_NB
    dr = _value(layout, x, ("dr_N", "dr_E", "dr_D"))
    dv = _value(layout, x, ("dv_N", "dv_E", "dv_D"))
    bg = _value(layout, x, ("bg_x", "bg_y", "bg_z"))
    return c_est, dr, dv, bg


def _predicted(layout, kind):
    """INS-predicted minus measured value of a measurement (satellites far along ``LOS``:
    the range changes by ``-e^T`` the antenna's displacement)."""
    clock = {n: layout.index(n) for n in ("clock_bias", "clock_drift") if n in layout.names}
    w_ie = earth.rate_ie_n(LLA[0])

    def model(x):
        c_est, dr, dv, bg = _estimate(layout, x)
        if kind == "position":
            return dr
        if kind == "velocity":
            return dv
        if kind == "dd_phase":
            pairs = meas.dd_pairs(len(LOS), 2)
            return meas.dd_phase(c_est, BASELINE, LOS, pairs)
        if kind == "pseudorange":
            moved = dr + (c_est - MAT_NB) @ LEVER
            return -LOS @ moved + x[clock["clock_bias"]]
        # range rate: the antenna's velocity over the Earth, w_eb = w_ib - C_bn w_ie
        u_est = c_est @ np.cross(OMEGA_IB + bg - c_est.T @ w_ie, LEVER)
        u_true = MAT_NB @ np.cross(OMEGA_IB - MAT_NB.T @ w_ie, LEVER)
        return -LOS @ (dv + u_est - u_true) + x[clock["clock_drift"]]

    return model


@pytest.mark.parametrize(
    ("kind", "layout"),
    [
        ("position", EKF17),
        ("velocity", ALIGN12),
        ("dd_phase", ALIGN12),
        ("dd_phase", EKF26),
        ("pseudorange", EKF17),
        ("pseudorange", EKF26),
        ("range_rate", EKF17),
        ("range_rate", EKF26),
    ],
)
def test_every_row_is_the_jacobian_of_its_measurement(kind, layout):
    m = meas.Measurement(kind, 0.1, baseline_b=BASELINE, lever_arm_b=LEVER, los_n=LOS, reference=2)
    H, _ = meas.rows(layout, SEGMENT, m)
    model = _predicted(layout, kind)
    # pseudorange: a far satellite's range changes by -e^T d to first order; the
    # curvature term |d|^2 / rho (2e-7 m for 1 m and 1e-4 rad on metres) is below 1e-6
    assert_jacobian(H, model, np.zeros(len(layout)), layout, f"{kind} {len(layout)}", atol=1e-6)
