"""An analytic aircraft flight for strapdown and filter tests: turns, speed changes, climbs.

:func:`aircraft_trajectory` builds an :class:`inins.core.trajectory.Analytic`
truth from a smooth NED velocity (:class:`SmoothVelocity`, logistic steps with
closed-form position and derivatives) and coordinated-turn attitude, so every
derivative is exact to machine precision. :class:`FlightPlan` (legs: ground wait,
take-off, climbs, straight legs, coordinated turns; validated, keys named) and
:func:`plan_velocity` describe the flights of run-ekf, whose attitude, dither and
IMU stream :mod:`inins.ekf.flight` adds.
"""

import math
from dataclasses import dataclass, field
from enum import Enum
from functools import partial

import numpy as np

from inins.core import earth
from inins.core.trajectory import Analytic
from inins.core.units import DEG
from inins.exceptions import InputError

_DUAL_LIMIT = 1e-18  # s: below, f(t + iy) = f(t) + i y f'(t) to machine precision
_SATURATED = 37.0  # |x| > 37: sigma is 0 or 1 to < 1e-16 (1.0 exactly in double)


_MEMO_BLOCKS = 2  # time blocks remembered (a chunk's quadrature times, its epoch times)


@dataclass(frozen=True)
class SmoothVelocity:
    """NED velocity as a sum of logistic steps, with closed-form integral and derivatives.

    ``v(t) = v0 + sum_k dv_k sigma((t - t_k) / tau_k)``, ``sigma(x) = 1 / (1 + e^-x)``;
    displacement ``p(t) = v0 t + sum_k dv_k tau_k softplus((t - t_k) / tau_k)`` with
    ``softplus(x) = log(1 + e^x)``. Analytic in the strip ``|Im t| < pi min(tau)``
    and complex-safe; a complex-step argument (``|Im t| < 1e-18 s``) is evaluated
    as ``f(t) + i Im(t) f'(t)`` in real arithmetic, which is exact and fast.

    Cost: a block of times touches only the steps near it (found by bisection in the
    steps sorted by centre; the finished ones enter through prefix sums), so a long
    flight costs per block what a short one does; the logistic terms of the last
    few real blocks are kept, so the ten calls an attitude-and-position evaluation
    makes on one block compute ``exp`` once (``tests/core/test_flight_truth.py``
    compares with the direct sum).

    Parameters
    ----------
    v0 : ndarray, shape (3,)
        Velocity before the first step (m/s).
    times, taus : ndarray, shape (m,)
        Step centres and time constants (s).
    steps : ndarray, shape (m, 3)
        Velocity changes ``dv_k`` (m/s).
    """

    v0: np.ndarray
    times: np.ndarray
    taus: np.ndarray
    steps: np.ndarray
    _index: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    _memo: list = field(default_factory=list, init=False, repr=False, compare=False)

    def _sorted(self):
        """Steps sorted by centre, prefix sums of ``dv_k`` and ``t_k dv_k``, reach (s)."""
        index = self._index
        if not index:
            times = np.asarray(self.times, dtype=float)
            steps = np.asarray(self.steps, dtype=float).reshape(-1, 3)
            order = np.argsort(times, kind="stable")
            zero = np.zeros((1, 3))
            index["order"] = order
            index["times"] = times[order]
            index["cum_v"] = np.concatenate([zero, np.cumsum(steps[order], axis=0)])
            index["cum_p"] = np.concatenate(
                [zero, np.cumsum(times[order, None] * steps[order], axis=0)]
            )
            # beyond this distance from a block a step is saturated for certain
            index["reach"] = _SATURATED * float(np.max(self.taus, initial=0.0)) + 1.0
        return index

    def _terms(self, time):
        """Folded constants and the logistic terms of the steps live over ``time``."""
        real = np.real(time)
        t_min, t_max = real.min(initial=np.inf), real.max(initial=-np.inf)
        index = self._sorted()
        lo, hi = np.searchsorted(
            index["times"], [t_min - index["reach"], t_max + index["reach"]], side="left"
        )
        near = np.sort(index["order"][lo:hi])  # candidates, in the steps' own order
        times, taus, steps = self.times[near], self.taus[near], self.steps[near]
        done = (t_min - times) / taus > _SATURATED
        live = ~done & ((t_max - times) / taus > -_SATURATED)
        v0 = self.v0 + index["cum_v"][lo] + steps[done].sum(axis=0)
        p0 = -(index["cum_p"][lo] + times[done] @ steps[done])
        taus, steps = taus[live], steps[live]
        x = (time[..., None] - times[live]) / taus
        pos = x.real > 0.0
        e = np.exp(np.where(pos, -x, x))  # exp(-|x|), no overflow
        inv = 1.0 / (1.0 + e)
        sigma = np.where(pos, 1.0, e) * inv
        dsigma = e * inv * inv / taus
        return {
            "v0": v0,
            "p0": p0,
            "taus": taus,
            "steps": steps,
            "x": x,
            "pos": pos,
            "e": e,
            "sigma": sigma,
            "dsigma": dsigma,
        }

    def _order(self, time, block, j):
        """``d^j p / dt^j`` (n, 3) from the terms of ``block``."""
        v0, steps, taus = block["v0"], block["steps"], block["taus"]
        if j < 0:
            terms = (np.where(block["pos"], block["x"], 0.0) + np.log1p(block["e"])) * taus
            return time[..., None] * v0 + block["p0"] + terms @ steps
        sigma, dsigma = block["sigma"], block["dsigma"]
        terms = (sigma, dsigma, dsigma * (1.0 - 2.0 * sigma) / taus)[j]
        return (v0 if j == 0 else 0.0) + terms @ steps

    def _sum(self, time, orders):
        """``d^j p / dt^j`` (n, 3) for j in ``orders`` (-1..2: p, v, a, jerk).

        Steps saturated over the whole block (``|x| > 37``, where ``sigma`` is 0 or 1
        in double precision) are folded into the constant and linear parts.
        """
        if np.iscomplexobj(time):
            block = self._terms(time)
            return [self._order(time, block, j) for j in orders]
        block = self._block(time)
        out = []
        for j in orders:
            if j not in block["out"]:
                block["out"][j] = self._order(time, block, j)
            out.append(block["out"][j].copy())
        return out

    def _block(self, time):
        """The remembered terms of the real time array ``time`` (computed on a miss)."""
        for block in self._memo:
            if block["time"].shape == time.shape and np.array_equal(block["time"], time):
                return block
        block = self._terms(time)
        block["time"], block["out"] = np.array(time, dtype=float), {}
        self._memo.insert(0, block)
        del self._memo[_MEMO_BLOCKS:]
        return block

    def __call__(self, time, order):
        """Displacement (order -1, m), velocity (0), acceleration (1) or jerk (2), (n, 3)."""
        time = np.asarray(time)
        if not np.iscomplexobj(time) or np.max(np.abs(time.imag), initial=0.0) > _DUAL_LIMIT:
            return self._sum(time, [order])[0]
        value, slope = self._sum(np.ascontiguousarray(time.real), [order, order + 1])
        return value + 1j * time.imag[..., None] * slope


TURN_STEP = 15.0 * DEG
"""A turn is built from track steps of at most this angle (rad)."""


class LegKind(Enum):
    """Kind of a flight leg."""

    WAIT = "wait"
    TAKEOFF = "takeoff"
    STRAIGHT = "straight"
    CLIMB = "climb"
    TURN = "turn"


@dataclass(frozen=True)
class Leg:
    """One leg of a flight plan (SI units).

    Attributes
    ----------
    kind : LegKind
    duration : float
        Leg length (s); for a turn, 0 means "as long as the angle needs".
    speed : float
        Ground speed to reach (m/s): required for ``TAKEOFF``; for ``STRAIGHT``
        and ``CLIMB`` a change of speed (NaN keeps the current speed).
    climb_rate : float
        ``CLIMB``: vertical speed during the leg (m/s, negative descends); level again at its end.
    bank : float
        ``TURN``: bank angle (rad), in (0, 90 deg).
    angle : float
        ``TURN``: heading change (rad), positive to the right.
    turn_rate : float
        ``TURN``: stated turn rate (rad/s, > 0), checked against the coordinated
        ``g tan(bank) / V`` (5 %); NaN takes the coordinated rate.
    """

    kind: LegKind
    duration: float = 0.0
    speed: float = math.nan
    climb_rate: float = 0.0
    bank: float = 0.0
    angle: float = 0.0
    turn_rate: float = math.nan


@dataclass(frozen=True)
class FlightPlan:
    """Origin, initial heading and legs of a flight.

    Attributes
    ----------
    lat, lon, height : float
        Start position (rad, rad, m).
    heading : float
        Heading on the ground (rad); 003 aligns at 180 deg.
    legs : tuple of Leg
    aoa : float
        Angle of attack added to pitch (rad), also on the ground.
    """

    lat: float
    lon: float
    height: float
    heading: float
    legs: tuple[Leg, ...]
    aoa: float = 0.0

    @property
    def duration(self):
        """Total flight time (s)."""
        return sum(_leg_durations(self))


def _leg_durations(plan):
    """Duration (s) of each leg, turns from their angle and rate; validates the plan."""
    speed, out = 0.0, []
    for i, leg in enumerate(plan.legs):
        key = f"legs.{i}"
        if not isinstance(leg.kind, LegKind):
            raise InputError(f"unknown leg kind {leg.kind!r}", key=f"{key}.kind")
        if not (math.isfinite(leg.duration) and leg.duration >= 0.0):
            raise InputError(f"duration must be >= 0 s, got {leg.duration}", key=f"{key}.duration")
        if not math.isnan(leg.speed) and not 0.0 < leg.speed < 400.0:
            raise InputError(f"speed must be in (0, 400) m/s, got {leg.speed}", key=f"{key}.speed")
        if leg.kind is LegKind.TAKEOFF and math.isnan(leg.speed):
            raise InputError("a take-off needs the speed to reach", key=f"{key}.speed")
        if leg.kind in (LegKind.CLIMB, LegKind.TURN) and speed == 0.0:
            raise InputError(f"a {leg.kind.value} needs speed: take off first", key=f"{key}.kind")
        if leg.kind is not LegKind.WAIT and not math.isnan(leg.speed):
            speed = leg.speed
        duration = leg.duration
        if leg.kind is LegKind.CLIMB and duration < 40.0:
            raise InputError(f"a climb lasts >= 40 s, got {duration}", key=f"{key}.duration")
        if leg.kind is LegKind.CLIMB and not abs(leg.climb_rate) < 0.5 * speed:
            raise InputError(
                f"climb rate {leg.climb_rate} m/s too steep for {speed} m/s",
                key=f"{key}.climb_rate",
            )
        if leg.kind is LegKind.TURN:
            duration = _turn_duration(leg, speed, key)
        if leg.kind is not LegKind.TURN and duration <= 0.0:
            raise InputError(f"duration must be > 0 s, got {leg.duration}", key=f"{key}.duration")
        out.append(duration)
    return out


def _turn_duration(leg, speed, key):
    if not 0.0 < leg.bank < 0.5 * math.pi:
        raise InputError(
            f"bank must be in (0, 90) deg, got {leg.bank / DEG:.6g}", key=f"{key}.bank"
        )
    if leg.angle == 0.0 or not math.isfinite(leg.angle):
        raise InputError("a turn needs a non-zero heading change", key=f"{key}.angle")
    rate = earth.GAMMA_E * math.tan(leg.bank) / speed
    if not math.isnan(leg.turn_rate) and not abs(leg.turn_rate / rate - 1.0) < 0.05:
        raise InputError(
            f"turn rate {leg.turn_rate / DEG:.4g} deg/s cannot be flown coordinated at bank "
            f"{leg.bank / DEG:.4g} deg and {speed:.4g} m/s (needs {rate / DEG:.4g} deg/s)",
            key=f"{key}.turn_rate",
        )
    need = abs(leg.angle) / rate
    if leg.duration and leg.duration < need:
        raise InputError(
            f"duration {leg.duration} s shorter than the turn ({need:.4g} s)", key=f"{key}.duration"
        )
    return max(leg.duration, need)


def plan_velocity(plan):
    """:class:`SmoothVelocity` of a plan and the leg start times (s), shape (legs + 1,).

    Speed changes use ``tau`` = duration / 8 (take-off) or 4 s, climb-rate changes
    4 s; a turn is ``ceil(|A| / 15 deg)`` track steps spread over its duration with
    ``tau`` a third of their spacing (as :func:`flight_velocity`).
    """
    durations = _leg_durations(plan)
    starts = np.concatenate([[0.0], np.cumsum(durations)])
    speed, climb, track = 0.0, 0.0, plan.heading
    current, rows = np.zeros(3), []

    def step(centre, tau):
        nonlocal current
        new = np.array([speed * math.cos(track), speed * math.sin(track), -climb])
        rows.append((centre, tau, new - current))
        current = new

    for leg, start, duration in zip(plan.legs, starts, durations, strict=False):
        if not math.isnan(leg.speed) and leg.kind is not LegKind.WAIT:
            speed = leg.speed
            if leg.kind is LegKind.TAKEOFF:
                step(start + 0.5 * duration, duration / 8.0)
            else:
                step(start + 10.0, 4.0)
        if leg.kind is LegKind.CLIMB:
            climb = leg.climb_rate
            step(start + 10.0, 4.0)
            climb = 0.0
            step(start + duration - 10.0, 4.0)
        if leg.kind is LegKind.TURN:
            count = math.ceil(abs(leg.angle) / TURN_STEP - 1e-9)
            need = abs(leg.angle) / (earth.GAMMA_E * math.tan(leg.bank) / speed)
            spacing = need / count
            first = start + 0.5 * (duration - need)
            for j in range(count):
                track += leg.angle / count
                step(first + (j + 0.5) * spacing, spacing / 3.0)
    velocity = SmoothVelocity(
        np.zeros(3),
        np.array([r[0] for r in rows]),
        np.array([r[1] for r in rows]),
        np.array([r[2] for r in rows]).reshape(-1, 3),
    )
    return velocity, starts


FLIGHT_PLAN = (
    (30.0, "speed", 100.0),
    (40.0, "climb", 5.0),
    (90.0, "turn", 80.0),
    (150.0, "speed", 150.0),
    (170.0, "climb", 0.0),
    (210.0, "turn", -90.0),
    (290.0, "climb", -8.0),
    (330.0, "turn", 70.0),
    (400.0, "speed", 120.0),
    (420.0, "climb", 0.0),
    (450.0, "turn", -100.0),
    (530.0, "climb", 6.0),
    (540.0, "turn", 50.0),
)
"""Default 10-min plan: (start s, kind, value); speed m/s, climb rate m/s, turn deg (+ right)."""


def flight_velocity(plan=FLIGHT_PLAN, speed=50.0, track=np.pi / 6, bank=np.pi / 6):
    """:class:`SmoothVelocity` of a flight plan: speed/climb steps and banked turns.

    Speed changes use ``tau = 6 s``, climb-rate changes ``tau = 4 s``. A turn of
    ``A`` at speed ``V`` lasts ``|A| / r`` at the coordinated rate ``r = g tan(bank) / V``,
    as ``ceil(|A| / 15 deg)`` overlapping track steps (``tau`` a third of their
    spacing); the speed dips ~2 % in the turns.

    Parameters
    ----------
    plan : sequence of (float, str, float)
        Events in time order (see :data:`FLIGHT_PLAN`).
    speed, track : float
        Initial ground speed (m/s) and track (rad, clockwise from north); level.
    bank : float
        Nominal bank angle of the turns (rad).
    """
    climb = 0.0
    current = np.array([speed * np.cos(track), speed * np.sin(track), 0.0])
    v0, rows = current, []
    for start, kind, value in plan:
        if kind == "turn":
            angle = np.radians(value)
            count = int(np.ceil(abs(value) / 15.0))
            spacing = abs(angle) / (earth.GAMMA_E * np.tan(bank) / speed) / count
            centres = [start + (j + 0.5) * spacing for j in range(count)]
            tracks = track + angle * np.arange(1, count + 1) / count
            track, tau = tracks[-1], spacing / 3.0
        else:
            speed, climb = (value, climb) if kind == "speed" else (speed, value)
            centres, tracks, tau = [start], [track], 6.0 if kind == "speed" else 4.0
        for centre, course in zip(centres, tracks, strict=True):
            new = np.array([speed * np.cos(course), speed * np.sin(course), -climb])
            rows.append((centre, tau, new - current))
            current = new
    return SmoothVelocity(
        v0,
        np.array([r[0] for r in rows]),
        np.array([r[1] for r in rows]),
        np.array([r[2] for r in rows]),
    )


def _flight_position(velocity, origin, scale, index, order, time):
    offset = origin[index] if order < 0 else 0.0
    return offset + scale[index] * velocity(time, order)[..., index]


def _flight_attitude(velocity, aoa, index, time):
    """Roll (coordinated bank), pitch (flight path + aoa) or heading (track)."""
    vel, acc = velocity(time, 0), velocity(time, 1)
    ground = np.sqrt(vel[..., 0] ** 2 + vel[..., 1] ** 2)
    if index == 0:
        turn = (vel[..., 0] * acc[..., 1] - vel[..., 1] * acc[..., 0]) / ground
        return np.arctan(turn / earth.GAMMA_E)
    if index == 1:
        return np.arctan(-vel[..., 2] / ground) + aoa
    return 2.0 * np.arctan(vel[..., 1] / (ground + vel[..., 0]))  # track, valid off south


def aircraft_trajectory(
    lat=37.0 * DEG, lon=127.0 * DEG, height=1000.0, velocity=None, aoa=2.0 * DEG
):
    """Aircraft-like :class:`Analytic` truth with turns, accelerations, climbs and descents.

    Default: 10 min, speed 50 -> 100 -> 150 -> 120 m/s, five coordinated turns
    at bank +-30 deg, climbs at 5-6 m/s and a descent at 8 m/s, from 37 deg N.
    The displacement ``p(t)`` of ``velocity`` maps to position by
    ``lat = lat0 + p_N / (R_N0 + h0)``, ``lon = lon0 + p_E / ((R_E0 + h0) cos lat0)``,
    ``h = h0 - p_D`` (a definition; the true ``vel_n`` follows from it exactly).
    Heading is the track of ``velocity``, roll ``atan(V chi' / g)``, pitch the
    flight-path angle plus ``aoa``.

    Parameters
    ----------
    lat, lon, height : float
        Origin (rad, rad, m).
    velocity : SmoothVelocity, optional
        Default ``flight_velocity()``; its track must stay away from due south.
    aoa : float
        Constant angle of attack added to pitch (rad).
    """
    velocity = flight_velocity() if velocity is None else velocity
    rn, re = earth.principal_radii(lat)
    origin = (lat, lon, height)
    scale = (1.0 / (rn + height), 1.0 / ((re + height) * np.cos(lat)), -1.0)
    pos = [partial(_flight_position, velocity, origin, scale, i, -1) for i in range(3)]
    rate = [partial(_flight_position, velocity, origin, scale, i, 0) for i in range(3)]
    angles = [partial(_flight_attitude, velocity, aoa, i) for i in range(3)]
    return Analytic(*angles, *pos, *rate)
