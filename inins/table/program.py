"""Rate-table motion programs: hold / rotate / spin steps turned into piecewise profiles.

A motion program is a list of steps executed in order. Each step moves one
gimbal (or none, for a hold). The program compiles to a table of segments on
which every gimbal angle is a quadratic in time,
``theta_g(t) = theta0[k, g] + rate0[k, g] tau + 0.5 accel[k, g] tau^2`` with
``tau = t - t0[k]``, which the kinematics kernel evaluates at arbitrary times.

A ``rotate`` step follows a trapezoidal rate profile (constant angular
acceleration, cruise at the commanded rate, constant deceleration), or a
triangular one when the angle is too short to reach the rate. A ``spin`` step
accelerates to a constant rate, spins for its duration and decelerates to rest.
All quantities are SI (rad, rad/s, rad/s^2, s).
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Hold:
    """Stand still for ``duration`` (s)."""

    duration: float
    label: str = ""


@dataclass(frozen=True)
class Rotate:
    """Turn gimbal ``axis`` by ``angle`` (rad, signed) at ``rate`` (rad/s, > 0).

    ``accel`` (rad/s^2, > 0) is the angular acceleration and deceleration.
    """

    axis: int
    angle: float
    rate: float
    accel: float
    label: str = ""


@dataclass(frozen=True)
class Spin:
    """Spin gimbal ``axis`` at ``rate`` (rad/s, signed) for ``duration`` (s) at full rate.

    The spin-up and spin-down at ``accel`` (rad/s^2) come on top of ``duration``.
    """

    axis: int
    rate: float
    duration: float
    accel: float
    label: str = ""


@dataclass(frozen=True)
class Segments:
    """Piecewise-quadratic gimbal angles.

    Attributes
    ----------
    t0 : ndarray, shape (k,)
        Segment start times (s), increasing; the last segment extends forever.
    theta0, rate0, accel : ndarray, shape (k, g)
        Angle (rad), rate (rad/s) and acceleration (rad/s^2) at each segment start.
    """

    t0: np.ndarray
    theta0: np.ndarray
    rate0: np.ndarray
    accel: np.ndarray

    def evaluate(self, time):
        """Gimbal angles (rad) and rates (rad/s) at ``time`` (s), each shape (n, g)."""
        time = np.atleast_1d(np.asarray(time, dtype=float))
        k = np.clip(np.searchsorted(self.t0, time, side="right") - 1, 0, None)
        tau = (time - self.t0[k])[:, None]
        rate = self.rate0[k] + self.accel[k] * tau
        return self.theta0[k] + self.rate0[k] * tau + 0.5 * self.accel[k] * tau * tau, rate


@dataclass(frozen=True)
class StepRecord:
    """Where one step sits on the timeline (s) and the gimbal angles (rad) at its ends."""

    index: int
    kind: str
    label: str
    axis: int
    start: float
    end: float
    angles_start: np.ndarray
    angles_end: np.ndarray


@dataclass(frozen=True)
class Program:
    """A compiled motion program: segments, step schedule and total duration (s)."""

    segments: Segments
    steps: tuple
    duration: float

    @property
    def breakpoints(self):
        """Times (s) where gimbal rates or accelerations jump."""
        return self.segments.t0[1:]


def _rate_profile(angle, rate, accel):
    """Phases (duration, accel) of a rest-to-rest turn by ``angle`` (rad)."""
    sign = np.sign(angle)
    size = abs(angle)
    if size == 0.0:
        return []
    if size >= rate * rate / accel:
        t_acc = rate / accel
        t_cruise = (size - rate * t_acc) / rate
        phases = [(t_acc, sign * accel), (t_cruise, 0.0), (t_acc, -sign * accel)]
    else:
        t_acc = np.sqrt(size / accel)
        phases = [(t_acc, sign * accel), (t_acc, -sign * accel)]
    return [p for p in phases if p[0] > 0.0]


def _phases(step):
    """(axis, [(duration, accel), ...]) of one step; axis -1 for a hold."""
    if isinstance(step, Hold):
        return -1, [(step.duration, 0.0)]
    if isinstance(step, Rotate):
        return step.axis, _rate_profile(step.angle, step.rate, step.accel)
    if isinstance(step, Spin):
        t_acc = abs(step.rate) / step.accel
        a = np.sign(step.rate) * step.accel
        return step.axis, [(t_acc, a), (step.duration, 0.0), (t_acc, -a)]
    raise TypeError(f"unknown step {step!r}")


def compile_program(steps, initial_angles, start_time=0.0):
    """Compile a list of steps into piecewise-quadratic gimbal profiles.

    Parameters
    ----------
    steps : sequence of Hold, Rotate, Spin
    initial_angles : array_like, shape (g,)
        Gimbal angles (rad) at ``start_time``, outer gimbal first.
    start_time : float
        Time (s) at which the program starts.

    Returns
    -------
    Program
    """
    angles = np.array(initial_angles, dtype=float)
    n_gimbals = angles.size
    rate = np.zeros(n_gimbals)
    t = float(start_time)
    t0, th0, r0, acc = [], [], [], []
    records = []
    for index, step in enumerate(steps):
        axis, phases = _phases(step)
        start, angles_start = t, angles.copy()
        for duration, a in phases:
            accel = np.zeros(n_gimbals)
            if axis >= 0:
                accel[axis] = a
            t0.append(t)
            th0.append(angles.copy())
            r0.append(rate.copy())
            acc.append(accel)
            angles = angles + rate * duration + 0.5 * accel * duration**2
            rate = rate + accel * duration
            t += duration
        rate[np.abs(rate) < 1e-12] = 0.0  # end of a rest-to-rest turn: exactly at rest
        if isinstance(step, Rotate):  # and exactly at the commanded angle
            angles[axis] = angles_start[axis] + step.angle
        kind = type(step).__name__.lower()
        records.append(
            StepRecord(index, kind, step.label, axis, start, t, angles_start, angles.copy())
        )
    # closing segment: hold the final angles forever
    t0.append(t)
    th0.append(angles.copy())
    r0.append(np.zeros(n_gimbals))
    acc.append(np.zeros(n_gimbals))
    segments = Segments(np.array(t0), np.array(th0), np.array(r0), np.array(acc))
    return Program(segments, tuple(records), t - start_time)
