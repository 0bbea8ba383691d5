"""Simulated land drive for the loosely coupled filter: IMU, GNSS solutions, truth.

A drive is a :class:`inins.ekf.flight.FlightPlan` at constant height (no climbs),
its turns coordinated at a small bank (the body velocity is along body x: the
non-holonomic constraint holds exactly), stops as straight legs at 1 mm/s. The
GNSS solution is the antenna position (lever arm ``l_b``) plus white noise of the
stated NED sigma, optionally the antenna velocity with its own; the IMU stream
goes through :func:`inins.ekf.flight.imu_stream` (the sensor error model).
"""

import math
from dataclasses import dataclass

import numpy as np

from inins.core import earth, error_model, rotation, strapdown
from inins.core.units import DEG
from inins.ekf.flight import FlightPlan, Leg, LegKind, flight_trajectory, imu_stream
from inins.ekf.loose import GnssSolution


def city_plan(duration, speed=15.0, stop_every=0.0, stop_s=20.0, lat=0.6, lon=2.0, height=50.0):
    """A drive of about ``duration`` s: 20 s parked, then legs of 40 s with 90 deg turns
    (bank 3 deg), alternately left and right (a box pattern); with ``stop_every`` > 0 a
    stop of ``stop_s`` s every ``stop_every`` s of driving."""
    legs = [Leg(LegKind.WAIT, 20.0), Leg(LegKind.TAKEOFF, 20.0, speed=speed)]
    t, k, driven = 40.0, 0, 0.0
    while t < duration:
        legs.append(Leg(LegKind.STRAIGHT, 40.0, speed=speed))
        t += 40.0
        driven += 40.0
        if stop_every > 0 and driven >= stop_every:
            legs.append(Leg(LegKind.STRAIGHT, stop_s, speed=1e-3))
            legs.append(Leg(LegKind.STRAIGHT, 20.0, speed=speed))
            t += stop_s + 20.0
            driven = 0.0
        angle = (90.0 if k % 4 < 2 else -90.0) * DEG
        legs.append(Leg(LegKind.TURN, bank=3.0 * DEG, angle=angle))
        t += abs(angle) / (earth.GAMMA_E * math.tan(3.0 * DEG) / speed)
        k += 1
    return FlightPlan(lat, lon, height, 0.3, tuple(legs))


@dataclass(frozen=True, eq=False)
class Drive:
    """A simulated drive: ``dtheta``, ``dv`` (N, 3) from t = 0, ``dt``; ``solution``;
    truth at the solution epochs ``mat_nb`` (m, 3, 3), ``vel`` (m, 3), ``lla`` (m, 3);
    ``truth`` the trajectory; ``initial`` a NavState at t = 0 with ``init_error``."""

    dt: float
    dtheta: np.ndarray
    dv: np.ndarray
    solution: GnssSolution
    mat_nb: np.ndarray
    vel: np.ndarray
    lla: np.ndarray
    truth: object
    initial: strapdown.NavState

    def imu(self, lo, hi):
        """Increments of samples ``lo..hi-1``."""
        return self.dtheta[lo:hi], self.dv[lo:hi]


def simulate_drive(
    plan,
    errors,
    dt,
    seed,
    *,
    lever=(0.5, 0.2, -1.2),
    sigma_ned=(0.02, 0.02, 0.04),
    sigma_vel=None,
    rate=1.0,
    init_attitude=(0.5 * DEG, 0.5 * DEG, 2.0 * DEG),
    init_pos=0.05,
    init_vel=0.02,
    tag_offset=0.0,
):
    """IMU, GNSS solutions and truth of a plan (module docstring).

    The initial INS state at t = 0 has the stated errors (roll, pitch, heading;
    position per axis in m; velocity per axis in m/s), drawn with the seed. The
    solution taken at IMU time ``t`` is tagged ``t - tag_offset`` (the time offset
    the loose filter's ``dt_g`` state estimates); truth stays at the true times.
    """
    rng = np.random.default_rng(seed)
    truth = flight_trajectory(plan)
    n = round(plan.duration / dt)
    (dtheta, dv) = next(imu_stream(truth, errors, dt, [0, n], rng, nodes=2))
    t = np.arange(1.0 / rate, n * dt - 1e-9, 1.0 / rate)
    mat, vel, lla = truth.state(t)
    lever = np.asarray(lever, float)
    r = earth.ecef_from_llh(lla[:, 0], lla[:, 1], lla[:, 2])
    m_en = earth.mat_en(lla[:, 0], lla[:, 1])
    lever_n = mat @ lever
    r_ant = r + np.einsum("kij,kj->ki", m_en, lever_n)
    sig = np.asarray(sigma_ned, float)
    noise_n = rng.standard_normal((t.size, 3)) * sig
    r_ant = r_ant + np.einsum("kij,kj->ki", m_en, noise_n)
    sol_lla = earth.llh_from_ecef(r_ant)
    vel_meas = svel = None
    if sigma_vel is not None:
        omega, _ = truth.rates(t)
        omega_eb = omega - np.einsum("kji,kj->ki", mat, earth.rate_ie_n(lla[:, 0]))
        v_ant = vel + np.einsum("kij,kj->ki", mat, np.cross(omega_eb, lever))
        svel = np.broadcast_to(np.asarray(sigma_vel, float), (t.size, 3))
        vel_meas = v_ant + rng.standard_normal((t.size, 3)) * svel
    sol = GnssSolution(t - tag_offset, sol_lla, np.broadcast_to(sig, (t.size, 3)), vel_meas, svel)
    mat0, vel0, lla0 = truth.state([0.0])
    eul = rotation.euler_from_mat(mat0[0]) + np.asarray(init_attitude) * rng.choice([-1, 1], 3)
    lla_i = error_model.lla_offset(lla0[0], init_pos * rng.standard_normal(3))
    initial = strapdown.NavState.from_attitude(
        rotation.mat_from_euler(*eul), vel0[0] + init_vel * rng.standard_normal(3), lla_i
    )
    return Drive(dt, dtheta, dv, sol, mat, vel, lla, truth, initial)
