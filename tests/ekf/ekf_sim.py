"""Test helper: a nominal 24-satellite Walker constellation and a simulated epoch stream.

Kept for the numerics tests of the filter (independent of the GNSS layer; the
command and the benchmark use :func:`inins.ekf.sources.simulated_epochs`):
circular orbits (Walker 24/6/1, i = 55 deg, a = 26,559.7 km), transmit time by
iteration, Sagnac rotation into the receive-time ECEF frame, receiver clock bias
and drift, white noise.
"""

import math
from dataclasses import dataclass

import numpy as np

from inins.core import earth
from inins.ekf.config import EpochInput, TruthEpoch
from inins.ekf.flight import imu_stream
from inins.ekf.measurements import C_LIGHT, GnssEpoch, antenna

A_ORBIT = 26_559_700.0
INCLINATION = math.radians(55.0)


def walker(time, per_plane=4):
    """ECEF positions (m) and velocities (m/s), each (6 per_plane, 3), of a Walker
    constellation of 6 planes (24/6/1 by default; 30/6/1 with ``per_plane=5``)."""
    total = 6 * per_plane
    plane, slot = np.divmod(np.arange(total), per_plane)
    raan = np.radians(60.0) * plane
    n = math.sqrt(earth.GM / A_ORBIT**3)
    u = 2.0 * np.pi * (slot / per_plane + plane / total) + n * time
    cu, su, co, so, ci, si = (
        np.cos(u),
        np.sin(u),
        np.cos(raan),
        np.sin(raan),
        math.cos(INCLINATION),
        math.sin(INCLINATION),
    )
    r_i = A_ORBIT * np.stack([co * cu - so * su * ci, so * cu + co * su * ci, su * si], -1)
    v_i = A_ORBIT * n * np.stack([-co * su - so * cu * ci, -so * su + co * cu * ci, cu * si], -1)
    theta = earth.RATE * time
    r_e, v_e = _rot_z(r_i, theta), _rot_z(v_i, theta)
    v_e = v_e - np.cross([0.0, 0.0, earth.RATE], r_e)
    return r_e, v_e


def _rot_z(vec, angle):
    """Coordinates in a frame turned by ``angle`` about z: ``[c x + s y, -s x + c y, z]``."""
    angle = np.broadcast_to(angle, vec.shape[:-1])
    c, s = np.cos(angle), np.sin(angle)
    return np.stack(
        [c * vec[..., 0] + s * vec[..., 1], -s * vec[..., 0] + c * vec[..., 1], vec[..., 2]], -1
    )


@dataclass(frozen=True)
class Receiver:
    """Receiver simulation settings (SI)."""

    lever_arm: tuple = (1.5, 0.2, -1.0)
    sigma_pr: float = 2.0
    sigma_rr: float = 0.05
    mask: float = math.radians(10.0)
    clock_bias: float = 3000.0
    clock_drift: float = 0.5
    latency: float = 0.15
    per_plane: int = 4


def gnss_epoch(t, r_ant, v_ant, rx, rng, sat_clock):
    """Measurements of the visible satellites at receive time ``t`` (:class:`GnssEpoch`)."""
    total = 6 * rx.per_plane
    tau = np.full(total, 0.075)
    for _ in range(3):
        pos, _ = walker(t - tau, rx.per_plane)
        tau = np.linalg.norm(pos - r_ant, axis=1) / C_LIGHT
    pos, vel = walker(t - tau, rx.per_plane)
    pos, vel = _rot_z(pos, earth.RATE * tau), _rot_z(vel, earth.RATE * tau)
    d = pos - r_ant
    rho = np.linalg.norm(d, axis=1)
    e = d / rho[:, None]
    lat, lon, _ = earth.llh_from_ecef(r_ant)
    up = -earth.mat_en(lat, lon)[:, 2]
    visible = e @ up > math.sin(rx.mask)
    k = int(visible.sum())
    b = rx.clock_bias + rx.clock_drift * t
    pr = rho + b - sat_clock + rx.sigma_pr * rng.standard_normal(total)
    rr = (
        np.einsum("ij,ij->i", vel - v_ant, e)
        + rx.clock_drift
        + rx.sigma_rr * rng.standard_normal(total)
    )
    return GnssEpoch(
        t,
        np.flatnonzero(visible) + 1,
        pos[visible],
        vel[visible],
        sat_clock[visible],
        np.zeros(k),
        pr[visible],
        rr[visible],
        np.full(k, rx.sigma_pr),
        np.full(k, rx.sigma_rr),
        arrival=t + rx.latency,
    )


def epoch_stream(truth, base, errors, dt, duration, rx, seed, *, nodes=3, on_gnss=None):
    """EpochInput per second from t = 1 s to ``duration`` (generator, memory flat).

    ``truth`` is the (dithered) IMU trajectory, ``base`` the airframe (antenna) one.
    ``on_gnss(index, epoch)`` may alter an epoch (fault injection) and returns it.
    """
    rng = np.random.default_rng(seed)
    sat_clock = 1e5 * rng.uniform(-1.0, 1.0, 6 * rx.per_plane)
    count = round(duration)
    pps = np.arange(1, count + 1)
    lat_samples = round(rx.latency / dt)
    edges = np.concatenate([[0], np.round(pps / dt).astype(np.int64) + lat_samples])
    lever = np.asarray(rx.lever_arm, dtype=float)
    chunks = imu_stream(truth, errors, dt, edges, rng, nodes=nodes)
    for k, (dtheta, dv) in enumerate(chunks):
        t = float(pps[k])
        mat0, vel0, lla0 = base.state([t])
        omega0, _ = base.rates([t])
        omega_eb = omega0[0] - mat0[0].T @ earth.rate_ie_n(lla0[0, 0])
        r_ant, v_ant = antenna(lla0[0], vel0[0], mat0[0], omega_eb, lever)
        epoch = gnss_epoch(t, r_ant, v_ant, rx, rng, sat_clock)
        if on_gnss is not None:
            epoch = on_gnss(k, epoch)
        mat, vel, lla = truth.state([t, t + rx.latency])
        yield EpochInput(
            dtheta,
            dv,
            round(t / dt) - int(edges[k]),
            epoch,
            TruthEpoch(
                mat[0],
                vel[0],
                lla[0],
                rx.clock_bias + rx.clock_drift * t,
                rx.clock_drift,
                at_arrival=(mat[1], vel[1], lla[1]),
            ),
        )
