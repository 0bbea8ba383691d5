"""The flight truth (:class:`inins.core.flight.SmoothVelocity`) equals the direct sum it
replaced: the same displacement, velocity, acceleration and jerk, the same
trajectory and ideal increments, to 1e-12 of their scale, on a few flights."""

import math
from dataclasses import dataclass

import numpy as np
import pytest

from inins.core import flight, trajectory
from inins.core.units import DEG
from inins.ekf import flight as ekf_flight

_SATURATED = 37.0


@dataclass(frozen=True)
class DirectVelocity:
    """Frozen copy of the former implementation: every call sums over every step."""

    v0: np.ndarray
    times: np.ndarray
    taus: np.ndarray
    steps: np.ndarray

    def _sum(self, time, orders):
        real = np.real(time)
        x_lo = (real.min(initial=np.inf) - self.times) / self.taus
        done = x_lo > _SATURATED
        live = ~done & ((real.max(initial=-np.inf) - self.times) / self.taus > -_SATURATED)
        v0 = self.v0 + self.steps[done].sum(axis=0)
        p0 = -self.times[done] @ self.steps[done]
        taus, steps = self.taus[live], self.steps[live]
        x = (time[..., None] - self.times[live]) / taus
        pos = x.real > 0.0
        e = np.exp(np.where(pos, -x, x))
        inv = 1.0 / (1.0 + e)
        sigma = np.where(pos, 1.0, e) * inv
        dsigma = e * inv * inv / taus
        out = []
        for j in orders:
            if j < 0:
                terms = (np.where(pos, x, 0.0) + np.log1p(e)) * taus
                out.append(time[..., None] * v0 + p0 + terms @ steps)
            else:
                terms = (sigma, dsigma, dsigma * (1.0 - 2.0 * sigma) / taus)[j]
                out.append((v0 if j == 0 else 0.0) + terms @ steps)
        return out

    def __call__(self, time, order):
        time = np.asarray(time)
        if not np.iscomplexobj(time) or np.max(np.abs(time.imag), initial=0.0) > 1e-18:
            return self._sum(time, [order])[0]
        value, slope = self._sum(time.real, [order, order + 1])
        return value + 1j * time.imag[..., None] * slope


def _long_plan(hours):
    legs = [
        ekf_flight.Leg(ekf_flight.LegKind.WAIT, 120),
        ekf_flight.Leg(ekf_flight.LegKind.TAKEOFF, 40, speed=80.0),
        ekf_flight.Leg(ekf_flight.LegKind.CLIMB, 100, climb_rate=5.0),
    ]
    pattern = [
        ekf_flight.Leg(ekf_flight.LegKind.STRAIGHT, 60, speed=90.0),
        ekf_flight.Leg(ekf_flight.LegKind.TURN, bank=30 * DEG, angle=360 * DEG),
        ekf_flight.Leg(ekf_flight.LegKind.CLIMB, 60, climb_rate=4.0),
        ekf_flight.Leg(ekf_flight.LegKind.TURN, bank=25 * DEG, angle=-200 * DEG),
        ekf_flight.Leg(ekf_flight.LegKind.CLIMB, 60, climb_rate=-4.0, speed=80.0),
    ]
    plan = ekf_flight.FlightPlan(37 * DEG, 127 * DEG, 100.0, math.pi, tuple(legs))
    while plan.duration < 3600.0 * hours:
        plan = ekf_flight.FlightPlan(
            37 * DEG, 127 * DEG, 100.0, math.pi, plan.legs + tuple(pattern)
        )
    return plan


FLIGHTS = {
    "aircraft": lambda: flight.flight_velocity(),
    "run-ekf 1 h": lambda: ekf_flight.flight_velocity(_long_plan(1.0))[0],
    "run-ekf 3 h": lambda: ekf_flight.flight_velocity(_long_plan(3.0))[0],
}


def _direct(velocity):
    return DirectVelocity(velocity.v0, velocity.times, velocity.taus, velocity.steps)


def _assert_close(got, want):
    scale = np.max(np.abs(want))
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-12 * scale)


@pytest.mark.parametrize("name", FLIGHTS)
def test_every_order_equals_the_direct_sum(name):
    velocity = FLIGHTS[name]()
    direct = _direct(velocity)
    end = float(velocity.times.max()) + 60.0
    rng = np.random.default_rng(7)
    blocks = [np.sort(rng.uniform(0.0, end, 50))]  # spread over the flight
    for start in rng.uniform(0.0, end, 12):  # a chunk's quadrature times, repeatedly
        blocks += [start + np.linspace(0.0, 1.0, 600)] * 2
    for time in blocks:
        for order in (-1, 0, 1, 2):
            _assert_close(velocity(time, order), direct(time, order))
        step = time + 1j * 1e-20
        for order in (-1, 0, 1):
            got, want = velocity(step, order), direct(step, order)
            _assert_close(got.real, want.real)
            _assert_close(got.imag, want.imag)


def test_trajectory_and_increments_equal_the_direct_sum():
    """State, rates and ideal increments of a run-ekf flight (closed-form derivatives,
    :class:`inins.ekf.flight.FlightTruth`) against the former truth (complex steps
    through the direct sum), on the ground, in the take-off, climbs and turns."""
    plan = _long_plan(1.0)
    velocity, _ = ekf_flight.flight_velocity(plan)
    fast = ekf_flight.flight_trajectory(plan)
    slow = _trajectory_with(plan, _direct(velocity))
    for start in (5.0, 100.0, 135.0, 171.0, 900.0, 2500.0):
        edges = start + 0.005 * np.arange(201)
        for f, s in zip(fast.rates(edges), slow.rates(edges), strict=True):
            _assert_close(f, s)
        for f, s in zip(
            trajectory.ideal_increments(fast, edges),
            trajectory.ideal_increments(slow, edges),
            strict=True,
        ):
            _assert_close(f, s)
        for f, s in zip(fast.state(edges[::20]), slow.state(edges[::20]), strict=True):
            _assert_close(f, s)


def _trajectory_with(plan, velocity):
    """The former truth: :func:`inins.ekf.flight.analytic_trajectory` (complex steps) on
    a given velocity."""
    original = ekf_flight.plan_velocity
    try:
        ekf_flight.plan_velocity = lambda _plan: (velocity, None)
        return ekf_flight.analytic_trajectory(plan)
    finally:
        ekf_flight.plan_velocity = original


def test_stream_in_blocks_equals_chunk_by_chunk():
    """:func:`inins.ekf.flight.imu_stream` evaluates many chunks at once: the same
    measured increments as one chunk at a time (noise draws in the same order)."""
    from inins.core import imu
    from inins.core.units import DPH, UG

    plan = _long_plan(0.1)
    truth = ekf_flight.Dithered(
        ekf_flight.flight_trajectory(plan), ekf_flight.Dither(60 * 4.85e-6, 40.0)
    )
    errors = imu.SensorErrors(gyro_bias=0.01 * DPH, accel_bias=50 * UG, gyro_arw=1e-6)
    edges = np.concatenate([[0], np.arange(1, 70) * 200 + 30])  # 14,000 samples: two blocks
    blocked = list(ekf_flight.imu_stream(truth, errors, 0.005, edges, np.random.default_rng(3)))
    single = list(
        ekf_flight.imu_stream(truth, errors, 0.005, edges, np.random.default_rng(3), block=1)
    )
    assert len(blocked) == len(single) == edges.size - 1
    # dv to 1e-12 of the stream's scale; dtheta to 1e-15 rad: at rest the heading is the
    # track of a 1e-9 m/s floor, where the last bit of a matrix product (which depends
    # on the block's size, in the former code as well) moves the rate by ~1e-13 rad/s
    scale = max(np.abs(v).max() for _, v in single)
    for (t_b, v_b), (t_s, v_s) in zip(blocked, single, strict=True):
        np.testing.assert_allclose(t_b, t_s, rtol=0.0, atol=1e-15)
        np.testing.assert_allclose(v_b, v_s, rtol=0.0, atol=1e-12 * scale)


def test_dithered_rates_equal_the_rotation_matrices():
    """:class:`inins.ekf.flight.Dithered` turns the airframe rates back through the
    dither by Rodrigues' formula: the same as through ``exp(theta [u x])`` matrices."""
    from inins.core import rotation

    plan = _long_plan(0.1)
    base = ekf_flight.flight_trajectory(plan)
    dither = ekf_flight.Dither(60 * 4.85e-6, 40.0)
    time = 171.0 + 0.005 * np.arange(600) / 3.0
    omega, force = ekf_flight.Dithered(base, dither).rates(time)
    omega0, force0 = base.rates(time)
    theta, rate, acc = dither.angles(time)
    axis = dither.axis
    mat_d = rotation.mat_from_rotvec(theta[:, None] * axis)
    u_r = np.cross(axis, dither.lever)
    want_omega = np.einsum("nji,nj->ni", mat_d, omega0) + rate[:, None] * axis
    want_force = (
        np.einsum("nji,nj->ni", mat_d, force0)
        + acc[:, None] * u_r
        + (rate * rate)[:, None] * np.cross(axis, u_r)
    )
    _assert_close(omega, want_omega)
    _assert_close(force, want_force)
