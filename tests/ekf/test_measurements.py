"""The measurement rows of the tightly coupled filter against a finite difference of the
nonlinear pseudorange and range-rate model (lever arm included, spec §6a)."""

import numpy as np
import pytest

from inins.core import earth, error_model, rotation
from inins.core.units import DEG
from inins.ekf import kernels, rows
from inins.ekf.measurements import GnssEpoch, antenna, predict
from inins.exceptions import InputError


def _epoch(lla):
    """Four satellites around a receiver at ``lla`` with arbitrary velocities."""
    r = earth.ecef_from_llh(*lla)
    rng = np.random.default_rng(3)
    dirs = rng.normal(size=(4, 3)) + 2.0 * r / np.linalg.norm(r)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    pos = r + 2.2e7 * dirs
    vel = rng.normal(scale=2500.0, size=(4, 3))
    k = 4
    return GnssEpoch(
        0.0,
        np.arange(1, 5),
        pos,
        vel,
        np.zeros(k),
        np.zeros(k),
        np.zeros(k),
        np.zeros(k),
        np.ones(k),
        np.ones(k),
    )


def _measure(x, lla, vel_n, mat_nb, omega_eb_b, lever_b, epoch):
    """Nonlinear measurements of the truth ``nav (-) x`` for the estimate ``nav`` and the
    error state ``x`` (17,): navigation states are errors, clock states values."""
    lla_e = error_model.lla_offset(lla, -x[0:3])
    mat_e = rotation.mat_from_rotvec(x[6:9]) @ mat_nb  # mat_nb_est = exp(-[phi x]) mat_nb
    r, v = antenna(lla_e, vel_n - x[3:6], mat_e, omega_eb_b, lever_b)
    pr, rr = predict(epoch, r, v, x[15], x[16])
    return np.ravel(np.column_stack([pr, rr]))


def _rows(lla, vel_n, mat_nb, omega_eb_b, lever_b, epoch):
    """The filter's pseudorange and range-rate rows (interleaved, 2 k x 17) and their
    predictions at the error state zero."""
    r, v = antenna(lla, vel_n, mat_nb, omega_eb_b, lever_b)
    j_v = np.empty((3, 3))
    kernels.earth_jacobians(lla[0], lla[2], vel_n, j_v, *np.empty((3, 3, 3)))
    ant = rows.Antenna(
        lla,
        earth.ecef_from_llh(*lla),
        earth.mat_en(lla[0], lla[1]),
        mat_nb,
        vel_n,
        mat_nb @ lever_b,
        mat_nb @ np.cross(omega_eb_b, lever_b),
        r,
        v,
        j_v,
    )
    sats = rows.Satellites(
        epoch.prn,
        epoch.sat_pos,
        epoch.sat_vel,
        epoch.pseudorange,
        epoch.sat_clock,
        epoch.delay,
        epoch.range_rate,
        epoch.sat_clock_drift,
        epoch.sigma_pr,
        epoch.sigma_rr,
    )
    x = np.zeros(17)
    y_pr, H_pr, _ = rows.pseudorange_rows(ant, sats, x, np.full(len(epoch), -1))
    y_rr, H_rr, _ = rows.range_rate_rows(ant, sats, x)
    H = np.empty((2 * len(epoch), 17))
    H[0::2], H[1::2] = H_pr, H_rr
    # the epoch's measurements and satellite clocks are zero: y = -zhat
    return H, -np.ravel(np.column_stack([y_pr, y_rr]))


@pytest.mark.parametrize("lever_b", [np.zeros(3), np.array([3.0, -1.0, -2.0])])
def test_rows_match_finite_difference(lever_b):
    lla = np.array([37.0 * DEG, 127.0 * DEG, 3000.0])
    vel_n = np.array([150.0, -80.0, 5.0])
    mat_nb = rotation.mat_from_euler(0.5, 0.1, 2.0)
    omega_eb_b = np.array([0.2, -0.1, 0.3])  # rad/s: a strong lever-arm velocity
    epoch = _epoch(lla)
    H, zhat = _rows(lla, vel_n, mat_nb, omega_eb_b, lever_b, epoch)
    z0 = _measure(np.zeros(17), lla, vel_n, mat_nb, omega_eb_b, lever_b, epoch)
    np.testing.assert_allclose(zhat, z0, rtol=0, atol=1e-6)
    steps = np.array([1.0] * 3 + [0.01] * 3 + [1e-3] * 3 + [1.0] * 8)  # FD above rounding
    for j in [0, 1, 2, 3, 4, 5, 6, 7, 8, 15, 16]:
        dx = np.zeros(17)
        dx[j] = steps[j]
        fd = (
            _measure(dx, lla, vel_n, mat_nb, omega_eb_b, lever_b, epoch)
            - _measure(-dx, lla, vel_n, mat_nb, omega_eb_b, lever_b, epoch)
        ) / (2 * steps[j])
        # Unmodelled: the lever arm turning with the local NED frame of the displaced
        # position, |l| / R ~ 6e-7 per metre (a 1 km position error moves the
        # antenna by 0.6 mm); its velocity alike, |u| / R ~ 1.5e-7 m/s per metre.
        # Plus the central difference's own O(|l| h^2) for the attitude columns.
        tol = np.linalg.norm(lever_b) * (1.0 / 6.37e6 + (j in (6, 7, 8)) * steps[j] ** 2) + 1e-9
        np.testing.assert_allclose(H[0::2, j], fd[0::2], rtol=1e-6, atol=tol, err_msg=str(j))
        np.testing.assert_allclose(H[1::2, j], fd[1::2], rtol=1e-5, atol=tol, err_msg=str(j))


def test_bad_epoch_names_the_key():
    with pytest.raises(InputError) as info:
        GnssEpoch(
            0.0, [1], np.zeros((1, 3)), np.zeros((1, 3)), [0.0], [0.0], [0.0], [0.0], [0.0], [1.0]
        )
    assert info.value.key == "sigma"
    with pytest.raises(InputError) as info:
        GnssEpoch(
            1.0,
            [1],
            np.zeros((1, 3)),
            np.zeros((1, 3)),
            [0.0],
            [0.0],
            [0.0],
            [0.0],
            [1.0],
            [1.0],
            arrival=0.5,
        )
    assert info.value.key == "arrival"
