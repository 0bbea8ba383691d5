"""The one finite-difference check every filter and observability model goes through, and
the nonlinear models it differentiates (written from the physics, not from the kernels).

:func:`assert_jacobian` compares each column of a model's ``H`` (or ``F``) with the central
difference of a nonlinear function of the full state, column by column, in the state's
own units: the step per state and the tolerance per column are physical (m, m/s, rad,
m/s^2, rad/s, s). A column that is wrong in sign, that swaps two cross-product factors,
that rotates with the wrong matrix or that leaves out a term larger than the stated
tolerance fails with its state's name.

The nonlinear models (design.md §6a, §6b, §10):

- :func:`error_rate`: the time derivative of the error state (estimated minus true, phi
  angle) from two nonlinear NED mechanisations, the estimate's driven by the measured
  increments ``meas = (I + M) true + b`` (the rows of ``F``);
- :func:`truth_of`: ``nav (-) x``, the truth an error state ``x`` says the estimate
  stands for (the filters' own definition, :func:`inins.ekf.filter.correct`);
- the antenna of an INS state (:func:`antenna`) and the GNSS measurements of it
  (:func:`inins.ekf.measurements.predict`), the vehicle-frame velocity, the Earth rate.
"""

import numpy as np
from scipy.linalg import expm

from inins.core import earth, error_model, rotation
from inins.ekf.filter import correct
from inins.ekf.measurements import antenna as _antenna

STEPS = {
    "position": 1.0,  # m
    "velocity": 1e-2,  # m/s
    "attitude": 1e-4,  # rad
    "accel_bias": 1e-4,  # m/s^2
    "gyro_bias": 1e-5,  # rad/s
    "accel_scale": 1e-4,
    "gyro_scale": 1e-4,
    "accel_misalignment": 1e-4,  # rad
    "gyro_misalignment": 1e-4,
    "clock": 1.0,  # m, m/s
    "inter_system_bias": 1.0,  # m
    "time_offset": 1e-3,  # s
}
"""Central-difference step of each group's states, in its units: above rounding, small
enough that the second-order terms of the nonlinear models stay below the tolerances."""


def column_tolerance(M, layout, relative, floor=0.0):
    """{state name: ``relative`` x the largest entry of its column of ``M`` + ``floor``}."""
    return {n: relative * np.abs(M[:, j]).max() + floor for j, n in enumerate(layout.names)}


def group_of(name):
    """The group of a state name (:data:`inins.core.error_model.GROUPS` and the filter-only
    states)."""
    for group, names in error_model.GROUPS.items():
        if name in names:
            return group
    if name in error_model.SYSTEM_BIASES:
        return "inter_system_bias"
    if name == error_model.TIME_OFFSET:
        return "time_offset"
    raise KeyError(name)


def assert_jacobian(H, model, x0, layout, label, atol=1e-6, rtol=1e-6, steps=None):
    """Every column of ``H`` (m, n) against the central difference of ``model`` (a function
    of the state (n,) returning (m,)) at ``x0``.

    ``atol`` is a float or a dict {state name: tolerance}, in units of the row per unit
    of the state; ``steps`` {group: step} overrides :data:`STEPS`.
    """
    H = np.asarray(H, float)
    steps = STEPS | (steps or {})
    for j, name in enumerate(layout.names):
        h = steps[group_of(name)]
        dx = np.zeros(len(x0))
        dx[j] = h
        fd = (np.asarray(model(x0 + dx)) - np.asarray(model(x0 - dx))) / (2 * h)
        tol = atol.get(name, 1e-6) if isinstance(atol, dict) else atol
        np.testing.assert_allclose(
            H[:, j], fd, rtol=rtol, atol=tol, err_msg=f"{label}: column {name}"
        )


# --------------------------------------------------------------------------- navigation


def earth_rate(lat):
    """``w_ie`` (3,) rad/s in NED."""
    return earth.rate_ie_n(lat)


def truth_of(nav, x, x0=None):
    """``nav (-) x``: (quat, vel, lla) of the truth for the estimate ``nav`` and the error
    state ``x`` (its first nine states: position, velocity, attitude errors).

    With ``x0``: ``(nav (-) x0) (-) (x - x0)``, the error ``x - x0`` about the corrected
    estimate ``nav (-) x0``, as the filter linearises (its rows are taken at
    ``nav (-) x0``; a correction composed on it, not added to ``x0``, which would differ
    by the second-order terms of the rotation vector, ``|phi0| / 2`` of a column).
    """
    if x0 is None:
        return correct(*nav, x[:9])
    return correct(*correct(*nav, x0[:9]), x[:9] - x0[:9])


def antenna(nav, omega_eb_b, lever_b):
    """ECEF position (m) and velocity (m/s) of the antenna of ``nav`` = (quat, vel, lla)
    turning at ``omega_eb_b`` (body rate over the Earth): ``r + C_en C_nb l_b`` and
    ``C_en (v + C_nb (omega_eb_b x l_b))`` (:func:`inins.gnss.simulate.antenna_states`)."""
    quat, vel, lla = nav
    return _antenna(lla, vel, rotation.mat_from_quat(quat), omega_eb_b, lever_b)


def antenna_shift(nav, ref, lever_b, lag=0.0):
    """``r_ant(nav) - r_ant(ref)`` (3,) ECEF m of the antennas ``r + C_en (C_nb l_b + v lag)``
    of two close INS states, without rounding them at the ECEF scale (a finite difference
    of 2e7 m positions would carry their last bits, 1e-9 m, into the columns)."""
    out = earth.ecef_from_llh(*nav[2]) - earth.ecef_from_llh(*ref[2])
    for sign, (quat, vel, lla) in ((1.0, nav), (-1.0, ref)):
        shift = rotation.mat_from_quat(quat) @ lever_b + vel * lag
        out = out + sign * (earth.mat_en(lla[0], lla[1]) @ shift)
    return out


def body_rate_over_earth(nav, omega_ib_b):
    """``omega_ib_b - C_bn w_ie`` (3,): the body's rate over the Earth."""
    quat, _, lla = nav
    return omega_ib_b - rotation.mat_from_quat(quat).T @ earth_rate(lla[0])


def vehicle_velocity(nav, c_vb):
    """``C_vb C_bn v`` (3,): the INS velocity in the vehicle axes."""
    quat, vel, _ = nav
    return c_vb @ rotation.mat_from_quat(quat).T @ vel


def specific_force_n(nav, f_b):
    """``C_nb f_b + g`` (3,) m/s^2: the INS acceleration (Coriolis left out)."""
    quat, _, lla = nav
    return rotation.mat_from_quat(quat) @ f_b + np.array([0.0, 0.0, earth.gravity(lla[0], lla[2])])


# --------------------------------------------------------------------------- dynamics


def _nav_rates(lla, vel_n, mat_nb, f_b, w_en=None):
    """Right-hand side of the nonlinear NED mechanisation (``w_en`` of ``lla``, ``vel_n``
    unless given)."""
    lat, _, h = lla
    rn, re = earth.principal_radii(lat)
    lla_dot = np.array([vel_n[0] / (rn + h), vel_n[1] / ((re + h) * np.cos(lat)), -vel_n[2]])
    w_ie = earth.rate_ie_n(lat)
    w_en = earth.rate_en_n(lat, h, vel_n) if w_en is None else w_en
    vel_dot = mat_nb @ f_b - np.cross(2 * w_ie + w_en, vel_n) + earth.gravity_n(lat, h)
    return lla_dot, vel_dot, w_ie + w_en


def _flow(lla, vel_n, mat_nb, f_b, omega_ib_b, u, w_en=None):
    """State after a short time ``u`` (s), to O(u^2):
    ``C(u) = exp(-u [w_in x]) C exp(u [w_ib x])``."""
    lla_dot, vel_dot, w_in = _nav_rates(lla, vel_n, mat_nb, f_b, w_en)
    mat = expm(-u * rotation.skew(w_in)) @ mat_nb @ expm(u * rotation.skew(omega_ib_b))
    return lla + u * lla_dot, vel_n + u * vel_dot, mat


def _nav_error(est, true):
    return np.concatenate(
        [
            error_model.position_error_ned(est[0], true[0]),
            est[1] - true[1],
            error_model.attitude_error(est[2], true[2]),
        ]
    )


def sensor_matrices(names, x):
    """``(E_a, E_g)``: the accelerometer and gyro matrices of :func:`_sensor_matrix`."""
    return _sensor_matrix(names, x, "a"), _sensor_matrix(names, x, "g")


def _sensor_matrix(names, x, sensor):
    """``E`` with ``measured = (I + E) true + bias``: scale factors on the diagonal,
    misalignments ``m_ij`` off it (the states of ``names`` present in ``x``)."""
    val = dict(zip(names, x, strict=True))
    m = np.diag([val.get(f"s{sensor}_{k}", 0.0) for k in "xyz"])
    for i in range(3):
        for j in range(3):
            if i != j:
                m[i, j] = val.get(f"m{sensor}_{'xyz'[i]}{'xyz'[j]}", 0.0)
    return m


def error_rate(layout, point, x, tau=0.05, transport_from_estimate=True):
    """d/dt of the error state ``x`` of ``layout`` at ``point`` = (lla, vel_n, mat_nb, f_b,
    omega_ib_b): the two nonlinear mechanisations (the estimate's on the measured
    increments) differenced over ``+-tau`` (s); the clock bias integrates the drift, the
    sensor, inter-system bias and time-offset states are constants."""
    lla, vel_n, mat_nb, f_b, omega_ib_b = point
    names = layout.names
    val = dict(zip(names, x, strict=True))
    e_a, e_g = _sensor_matrix(names, x, "a"), _sensor_matrix(names, x, "g")
    ba = np.array([val.get(f"ba_{k}", 0.0) for k in "xyz"])
    bg = np.array([val.get(f"bg_{k}", 0.0) for k in "xyz"])
    pos = np.array([val.get(f"dr_{k}", 0.0) for k in "NED"])
    vel = np.array([val.get(f"dv_{k}", 0.0) for k in "NED"])
    phi = np.array([val.get(f"phi_{k}", 0.0) for k in "NED"])
    est = (
        error_model.lla_offset(lla, pos),
        vel_n + vel,
        rotation.mat_from_rotvec(-phi) @ mat_nb,
    )
    w_en = None if transport_from_estimate else earth.rate_en_n(lla[0], lla[2], vel_n)
    f_meas, w_meas = f_b + ba + e_a @ f_b, omega_ib_b + bg + e_g @ omega_ib_b
    ends = [
        _nav_error(
            _flow(*est, f_meas, w_meas, u, w_en),
            _flow(lla, vel_n, mat_nb, f_b, omega_ib_b, u, w_en),
        )
        for u in (tau, -tau)
    ]
    nav = (ends[0] - ends[1]) / (2 * tau)
    rate = np.zeros(len(names))
    for k, n in enumerate(("dr_N", "dr_E", "dr_D", "dv_N", "dv_E", "dv_D")):
        if n in val:
            rate[layout.index(n)] = nav[k]
    for k, n in enumerate(("phi_N", "phi_E", "phi_D")):
        if n in val:
            rate[layout.index(n)] = nav[6 + k]
    if "clock_bias" in val and "clock_drift" in val:
        rate[layout.index("clock_bias")] = val["clock_drift"]
    return rate
