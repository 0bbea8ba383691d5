"""Vehicle aiding of the loosely coupled filter: ZUPT, ZARU, NHC, odometer (and the
stationary detector).

The rows (:mod:`inins.ekf.rows`, block by block in spec §6b), at the INS state
``nav (-) x`` of an epoch, the vehicle frame ``v`` turned from the body by the mounting
``C_vb``:

- ZUPT (while stationary): the velocity is zero.
- ZARU (while stationary): the compensated gyro mean over the epoch's IMU chunk is the
  Earth rate in body axes plus the residual gyro bias.
- NHC: the lateral and vertical velocity in the vehicle frame are zero (the lever arm
  to the point that does not slip is neglected: below 0.1 m/s for 1 m at 5 deg/s).
- Odometer (where a column exists): the forward vehicle speed is the wheel speed.

Stationary detector (:func:`stationary`): over the ``window`` samples up to each
epoch, the RMS deviation of the specific-force vector from its window mean,
``sqrt(mean |f - mean f|^2)``, below ``accel_threshold`` (m/s^2), and the
magnitude of the window-mean angular rate ``|mean omega|`` below ``gyro_threshold``
(rad/s; the mean averages vibration and noise down, a turn stays). Defaults
0.05 m/s^2 and 0.5 deg/s over 0.5 s. It cannot tell rest from motion at constant
velocity without vibration (a simulated drive on a straight): there, give the
stationary windows instead; a real car's vibration while rolling exceeds it.
"""

import math

import numpy as np

from inins.core import earth, jit
from inins.ekf import kernels, rows, step

NHC, ZUPT, ZARU, ODOMETER = 0, 2, 5, 8
"""The flags of the vehicle rows in :func:`vehicle_update`'s ``acc_out`` (9,): NHC y, z,
ZUPT N, E, D, ZARU x, y, z, odometer."""


@jit.njit(cache=True)
def _append(H, y, r, at, part):
    """Rows ``part`` = (y, H, r) into ``H``, ``y``, ``r`` from row ``at``; the next row."""
    py, pH, pr = part
    m = py.shape[0]
    H[at : at + m] = pH
    y[at : at + m] = py
    r[at : at + m] = pr
    return at + m


@jit.njit(cache=True)
def vehicle_update(x, P, ins, omega_mean, c_vb, stationary, odo, sig, threshold, acc_out):
    """ZUPT + ZARU (when ``stationary``), NHC and odometer rows at one epoch
    (:mod:`inins.ekf.rows`), at the INS state ``nav (-) x`` of ``ins``
    (:data:`inins.ekf.step.Ins`); returns the rows accepted.

    ``sig``: [nhc, zupt, zaru, odometer] 1-sigma (m/s, m/s, rad/s, m/s); a value <= 0
    turns that aid off; ``odo`` the odometer's forward speed (m/s, NaN: none).
    ``acc_out`` (9,): accepted flags of rows NHC y, z, ZUPT N, E, D, ZARU x, y, z, odometer.
    """
    n = x.shape[0]
    cq, cv, cl = np.empty(4), np.empty(3), np.empty(3)
    step.correct(ins.quat, ins.vel, ins.lla, x, cq, cv, cl)
    c_bn = step.mat_from_quat(cq).T
    c_vn = c_vb @ c_bn
    H, y0, r = np.zeros((9, n)), np.zeros(9), np.zeros(9)
    slots = np.empty(9, np.int64)  # the acc_out flag of each row
    at = 0
    acc_out.fill(False)
    if sig[0] > 0.0:
        at = _append(H, y0, r, at, rows.nhc_rows(c_vn, cv, sig[0], n))
        slots[0], slots[1] = NHC, NHC + 1
    if stationary and sig[1] > 0.0:
        first = at
        at = _append(H, y0, r, at, rows.zupt_rows(cv, sig[1], n))
        slots[first:at] = np.arange(ZUPT, ZUPT + 3)
    if stationary and sig[2] > 0.0:
        w = earth.RATE
        w_ie = np.array([w * math.cos(cl[0]), 0.0, -w * math.sin(cl[0])])
        first = at
        at = _append(H, y0, r, at, rows.zaru_rows(omega_mean, c_bn, w_ie, x, sig[2]))
        slots[first:at] = np.arange(ZARU, ZARU + 3)
    if sig[3] > 0.0 and math.isfinite(odo):
        slots[at] = ODOMETER
        at = _append(H, y0, r, at, rows.odometer_rows(c_vn, cv, odo, sig[3], n))
    if at == 0:
        return 0
    acc = np.zeros(at, np.bool_)
    yy, ss = np.empty(at), np.empty(at)
    count = kernels.sequential_update(
        x, P, H[:at].copy(), y0[:at].copy(), r[:at].copy(), threshold, acc, yy, ss
    )
    for i in range(at):
        acc_out[slots[i]] = acc[i]
    return count


def stationary(dtheta, dv, dt, ends, window, accel_threshold=0.05, gyro_threshold=0.0087266):
    """Stationary flag per epoch (module docstring): ``ends`` (m,) sample counts up to each
    epoch; ``window`` samples before each end; thresholds m/s^2 and rad/s (0.5 deg/s).
    Returns bool (m,)."""
    f = dv / dt
    w = dtheta / dt
    c1 = np.concatenate([np.zeros((1, 3)), np.cumsum(f, axis=0)])
    c2 = np.concatenate([[0.0], np.cumsum(np.sum(f * f, axis=1))])
    cw = np.concatenate([np.zeros((1, 3)), np.cumsum(w, axis=0)])
    hi = np.clip(np.asarray(ends, np.int64), 0, f.shape[0])
    lo = np.maximum(hi - window, 0)
    cnt = np.maximum(hi - lo, 1)
    mean = (c1[hi] - c1[lo]) / cnt[:, None]
    var = np.maximum((c2[hi] - c2[lo]) / cnt - np.sum(mean**2, axis=1), 0.0)
    wmean = np.linalg.norm((cw[hi] - cw[lo]) / cnt[:, None], axis=1)
    return (hi - lo >= window) & (np.sqrt(var) < accel_threshold) & (wmean < gyro_threshold)
