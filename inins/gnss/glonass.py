"""GLONASS broadcast ephemerides: PZ-90.11 state vectors integrated by Runge-Kutta.

The navigation message gives, at ``tb`` (every 30 min), position, velocity and the
lunisolar acceleration in PZ-90.11 (ECEF), valid +-15 min. GLONASS ICD (2016, 5.1
Appendix J "simplified algorithm"): in the rotating frame, with ``r = |x|``::

    a = -GM/r^3 x + 3/2 J2 GM ae^2 / r^5 * (x (5 z^2/r^2 - 1), y (5 z^2/r^2 - 1),
        z (5 z^2/r^2 - 3)) + (w^2 x + 2 w vy, w^2 y - 2 w vx, 0) + a_ls

``GM = 398600.4418 km^3/s^2``, ``ae = 6378136 m``, ``J2 = 1082625.75e-9``,
``w = 7.292115e-5 rad/s``, ``a_ls`` the broadcast lunisolar acceleration held constant.
Fourth-order Runge-Kutta from ``tb`` to the requested time in equal steps of at most
:data:`STEP_S` (60 s, as RTKLIB's ``glorbit``); one compiled loop over any number of
(set, time) pairs. PZ-90.11 and WGS84 (G1762) agree to a few cm: no transformation.

Clock: ``dt_sv = -tau_n + gamma_n (t - tb)`` (RINEX stores ``-tau_n`` and
``+gamma_n``); it refers to GLONASS time, whose offset to GPS time is left to the
receiver's GLONASS inter-system bias (docs/gnss.md). No relativistic term (the
broadcast clock includes it). Times are GPS time: the reader converts ``tb`` from
UTC with the file's leap seconds (:mod:`inins.gnss.timescales`).
"""

from dataclasses import dataclass, fields

import numpy as np

from inins.core import jit
from inins.gnss import gpstime
from inins.gnss.orbit import SatelliteStates
from inins.gnss.systems import C

GM = 3.9860044418e14
"""PZ-90.11 Earth gravitational constant (m^3/s^2)."""
AE = 6378136.0
"""PZ-90.11 equatorial radius (m)."""
J2 = 1082625.75e-9
"""PZ-90.11 second zonal harmonic."""
OMEGA_E = 7.292115e-5
"""PZ-90.11 Earth rotation rate (rad/s)."""
STEP_S = 60.0
"""Largest Runge-Kutta step (s)."""
MAX_AGE_S = 900.0
"""Validity of a set around its ``tb`` (s): sets come every 30 min."""


@dataclass(frozen=True)
class GlonassEphemeris:
    """GLONASS broadcast sets, one row each, sorted by satellite and time.

    Attributes
    ----------
    sat : ndarray of int64, (n,), satellite number ``100 + slot``
    week, toe : ndarray, (n,), GPS week and seconds of week of ``tb``
    clock_bias : ndarray, (n,), s, ``-tau_n``
    gamma : ndarray, (n,), relative frequency bias ``gamma_n``
    pos, vel, acc : ndarray, (n, 3), m, m/s, m/s^2, PZ-90.11 at ``tb``
    health : ndarray of int64, (n,), 0 healthy
    channel : ndarray of int64, (n,), frequency channel k (-7 .. +6)
    """

    sat: np.ndarray
    week: np.ndarray
    toe: np.ndarray
    clock_bias: np.ndarray
    gamma: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    health: np.ndarray
    channel: np.ndarray

    def __len__(self):
        return len(self.sat)

    def take(self, index):
        return GlonassEphemeris(**{f.name: getattr(self, f.name)[index] for f in fields(self)})


def from_columns(sat, week, toe, clock_bias, gamma, pos, vel, acc, health, channel):
    """A :class:`GlonassEphemeris` with dtypes checked, sorted by satellite and time."""
    eph = GlonassEphemeris(
        sat=np.asarray(sat, np.int64),
        week=np.asarray(week, np.int64),
        toe=np.asarray(toe, float),
        clock_bias=np.asarray(clock_bias, float),
        gamma=np.asarray(gamma, float),
        pos=np.asarray(pos, float).reshape(-1, 3),
        vel=np.asarray(vel, float).reshape(-1, 3),
        acc=np.asarray(acc, float).reshape(-1, 3),
        health=np.asarray(health, np.int64),
        channel=np.asarray(channel, np.int64),
    )
    order = np.lexsort((eph.toe + gpstime.WEEK * eph.week, eph.sat))
    return eph.take(order)


def empty():
    """A set of no GLONASS ephemerides."""
    z = np.zeros(0)
    return from_columns(z, z, z, z, z, z, z, z, z, z)


def select(eph, sat, week, sow, *, max_age_s=MAX_AGE_S, healthy_only=True):
    """Row of the set with the nearest ``tb`` for each (satellite, GPS time); -1 if none
    lies within ``max_age_s``."""
    sat, week, sow = np.broadcast_arrays(
        np.asarray(sat, np.int64), np.asarray(week, np.int64), np.asarray(sow, float)
    )
    rows = np.flatnonzero(eph.health == 0) if healthy_only else np.arange(len(eph))
    if rows.size == 0 or sat.size == 0:
        return np.full(sat.shape, -1, np.int64)
    ref = int(week.min())
    toe = gpstime.time_diff(eph.week[rows], eph.toe[rows], ref, 0.0)
    key = eph.sat[rows] * 1e8 + toe
    order = np.argsort(key, kind="stable")
    rows, key, toe = rows[order], key[order], toe[order]
    t = gpstime.time_diff(week, sow, ref, 0.0)
    hi = np.clip(np.searchsorted(key, sat * 1e8 + t, side="right"), 0, len(rows) - 1)
    lo = np.clip(hi - 1, 0, None)
    d_lo = np.where(eph.sat[rows[lo]] == sat, np.abs(t - toe[lo]), np.inf)
    d_hi = np.where(eph.sat[rows[hi]] == sat, np.abs(t - toe[hi]), np.inf)
    best = np.where(d_lo < d_hi, lo, hi)
    return np.where(np.minimum(d_lo, d_hi) <= max_age_s, rows[best], -1)


def satellite_states(eph, index, week, sow):
    """Position, velocity (PZ-90.11 ~ WGS84 ECEF), clock and drift at GPS time (week, sow).

    Parameters
    ----------
    eph : GlonassEphemeris
    index : ndarray of int, shape (...), rows from :func:`select` (>= 0)
    week, sow : GPS time of transmission, broadcastable to ``index``

    Returns
    -------
    SatelliteStates
        ``clock = c (-tau_n + gamma_n dt)`` (m), ``drift = c gamma_n`` (m/s).
    """
    index = np.asarray(index, np.int64)
    index, week, sow = np.broadcast_arrays(index, np.asarray(week, np.int64), sow)
    shape = index.shape
    flat = np.array(index, np.int64).ravel()
    dt = gpstime.time_diff(week.ravel(), sow.ravel(), eph.week[flat], eph.toe[flat])
    state = np.concatenate([eph.pos, eph.vel, eph.acc], axis=1)
    if _use_numpy(flat.size):
        pos, vel = _rk4_numpy(flat, np.asarray(dt, float), state, STEP_S)
    else:
        pos = np.empty((flat.size, 3))
        vel = np.empty((flat.size, 3))
        _rk4_kernel(flat, np.asarray(dt, float), state, STEP_S, pos, vel)
    clock = C * (eph.clock_bias[flat] + eph.gamma[flat] * dt)
    return SatelliteStates(
        pos=pos.reshape(*shape, 3),
        vel=vel.reshape(*shape, 3),
        clock=clock.reshape(shape),
        drift=(C * eph.gamma[flat]).reshape(shape),
    )


@jit.njit(cache=True)
def _deriv(x, acc, out):
    r2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2]
    r = np.sqrt(r2)
    mu_r3 = GM / (r2 * r)
    j = 1.5 * J2 * GM * AE * AE / (r2 * r2 * r)
    zz = 5.0 * x[2] * x[2] / r2
    w2 = OMEGA_E * OMEGA_E
    out[0], out[1], out[2] = x[3], x[4], x[5]
    out[3] = -mu_r3 * x[0] + j * x[0] * (zz - 1.0) + w2 * x[0] + 2.0 * OMEGA_E * x[4] + acc[0]
    out[4] = -mu_r3 * x[1] + j * x[1] * (zz - 1.0) + w2 * x[1] - 2.0 * OMEGA_E * x[3] + acc[1]
    out[5] = -mu_r3 * x[2] + j * x[2] * (zz - 3.0) + acc[2]


@jit.njit(cache=True)
def _rk4_kernel(index, dt, state, max_step, pos, vel):
    """RK4 from each set's ``tb`` over ``dt`` (s) in ``ceil(|dt| / max_step)`` equal steps."""
    x = np.empty(6)
    k1, k2, k3, k4, tmp = np.empty(6), np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    for k in range(index.size):
        s = state[index[k]]
        for i in range(6):
            x[i] = s[i]
        acc = s[6:9]
        n = int(np.ceil(abs(dt[k]) / max_step))
        h = dt[k] / n if n > 0 else 0.0
        for _ in range(n):
            _deriv(x, acc, k1)
            for i in range(6):
                tmp[i] = x[i] + 0.5 * h * k1[i]
            _deriv(tmp, acc, k2)
            for i in range(6):
                tmp[i] = x[i] + 0.5 * h * k2[i]
            _deriv(tmp, acc, k3)
            for i in range(6):
                tmp[i] = x[i] + h * k3[i]
            _deriv(tmp, acc, k4)
            for i in range(6):
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        for i in range(3):
            pos[k, i] = x[i]
            vel[k, i] = x[3 + i]


NUMPY_STATES = 100_000
"""Most states integrated by numpy array arithmetic (:func:`_rk4_numpy`) while numba is
not loaded (as :data:`inins.gnss.orbit.NUMPY_STATES`: a GPS + GLONASS SPP of a drive
then loads no numba); the compiled loop once it is loaded."""


def _use_numpy(count):
    """True where ``count`` states are integrated by numpy (:data:`NUMPY_STATES`)."""
    return count <= NUMPY_STATES and isinstance(_rk4_kernel, jit.Kernel)


def _deriv_numpy(x, acc):
    """:func:`_deriv` of states (6, m) with accelerations (3, m): the same expressions."""
    r2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2]
    r = np.sqrt(r2)
    mu_r3 = GM / (r2 * r)
    j = 1.5 * J2 * GM * AE * AE / (r2 * r2 * r)
    zz = 5.0 * x[2] * x[2] / r2
    w2 = OMEGA_E * OMEGA_E
    return np.stack(
        [
            x[3],
            x[4],
            x[5],
            -mu_r3 * x[0] + j * x[0] * (zz - 1.0) + w2 * x[0] + 2.0 * OMEGA_E * x[4] + acc[0],
            -mu_r3 * x[1] + j * x[1] * (zz - 1.0) + w2 * x[1] - 2.0 * OMEGA_E * x[3] + acc[1],
            -mu_r3 * x[2] + j * x[2] * (zz - 3.0) + acc[2],
        ]
    )


def _rk4_numpy(index, dt, state, max_step):
    """:func:`_rk4_kernel` over all states at once: step ``j`` taken by the states that
    need more than ``j`` steps, each with the kernel's arithmetic. Returns (pos, vel),
    (m, 3) each."""
    x = state[index, :6].T.copy()
    acc = state[index, 6:9].T
    n = np.ceil(np.abs(dt) / max_step).astype(np.int64)
    h = np.where(n > 0, dt / np.maximum(n, 1), 0.0)
    for step in range(int(n.max(initial=0))):
        k = np.flatnonzero(n > step)
        xs, a, hk = x[:, k], acc[:, k], h[k]
        k1 = _deriv_numpy(xs, a)
        k2 = _deriv_numpy(xs + 0.5 * hk * k1, a)
        k3 = _deriv_numpy(xs + 0.5 * hk * k2, a)
        k4 = _deriv_numpy(xs + hk * k3, a)
        x[:, k] = xs + hk / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x[:3].T.copy(), x[3:].T.copy()


def warm_up():
    """Compile (or load from the on-disk cache) the RK4 kernel with the argument types
    :func:`satellite_states` passes."""
    state = np.zeros((1, 9))
    state[0, 0], state[0, 4] = 25.5e6, 3.9e3  # a GLONASS orbit
    _rk4_kernel(
        np.zeros(1, np.int64), np.array([60.0]), state, STEP_S, np.empty((1, 3)), np.empty((1, 3))
    )
