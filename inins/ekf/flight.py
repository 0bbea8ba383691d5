"""Simulated flight for run-ekf (003 §3.2-3.3): legs, RLG dither, IMU stream, alignment.

A flight is a list of :class:`Leg` (ground wait, take-off roll, climbs and
descents, straight legs, coordinated bank turns); the plan types
(:class:`~inins.core.flight.FlightPlan`, :class:`~inins.core.flight.Leg`) live in
:mod:`inins.core.flight`, where the scenario layer builds them, and are re-exported
here. :func:`flight_trajectory` turns it into an
:class:`inins.core.trajectory.Analytic` truth: the NED velocity is a
:class:`inins.core.flight.SmoothVelocity` (logistic steps, closed form position and
derivatives), the heading is the track of that velocity, the
roll the coordinated bank ``atan(V chi' / g)`` and the pitch the flight-path angle
plus a constant angle of attack. A turn of angle ``A`` at bank ``phi`` and speed
``V`` turns at ``r = g tan(phi) / V`` (coordinated) for ``|A| / r``.

In a coordinated bank turn (roll ``phi``, level) the body rate is
``omega_b = r [0, sin phi, cos phi]`` and the heading error grows at
``phi_D' = -r sin(phi) cos(phi) (m_yz + m_zy) - r (s_y sin^2 phi + s_z cos^2 phi)``
for gyro misalignments ``m_ij`` and scale factors ``s_i``: ``r`` and ``phi`` change
sign together between left and right turns, so the symmetric misalignment part
accumulates in every turn while the scale-factor part cancels in alternating turns
(003 §1, §3.3.1).

:class:`Dithered` adds the mechanical dither of a monolithic RLG triad: a single
angular vibration ``theta(t) = A sin(2 pi f t + p)`` of the sensor block about a
fixed body axis ``u`` (the triad diagonal by default), ``mat_nb = mat_nb0 exp(theta [u x])``.
For a rotation about a fixed axis the body rate is exact,
``omega_ib_b = exp(-theta [u x]) omega_ib_b0 + theta' u``; the accelerometers, a
lever ``r`` from the pivot, see ``f_b = exp(-theta [u x]) f_b0 + theta'' u x r +
theta' u x (theta' u x r)`` (sculling through the rotated ``f_b0`` and lever-arm
acceleration). Dropped: the cross term ``2 omega_0 x (theta' u x r)``
(zero mean, < 1e-3 m/s^2 in turns) and the accelerometer displacement
``(exp(theta [u x]) - I) r`` (< 0.1 mm); the truth velocity includes the dither
velocity ``mat_nb theta' u x r``.
"""

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from inins.core import earth, imu, prefetch, rotation, trajectory
from inins.core.flight import (  # the plan types live in core (the scenario builds them)
    TURN_STEP,
    FlightPlan,
    Leg,
    LegKind,
    SmoothVelocity,
    plan_velocity,
)
from inins.core.trajectory import Analytic
from inins.ekf import flight_kernel

__all__ = [
    "TURN_STEP",
    "Dither",
    "Dithered",
    "FlightPlan",
    "FlightTruth",
    "Leg",
    "LegKind",
    "analytic_trajectory",
    "dither_window",
    "flight_trajectory",
    "flight_velocity",
    "gyrocompass_attitude",
    "imu_stream",
]

flight_velocity = plan_velocity
"""Velocity of a plan and its leg start times (:func:`inins.core.flight.plan_velocity`)."""

_SPEED_FLOOR = 1e-3  # m/s: keeps roll and pitch defined at rest (bias < 1e-10 rad in flight)
_TRACK_FLOOR = 1e-9  # m/s along the ground heading: the track at rest is that heading


def _position(velocity, origin, scale, index, order, time):
    offset = origin[index] if order < 0 else 0.0
    return offset + scale[index] * velocity(time, order)[..., index]


def _attitude(velocity, aoa, heading, index, time):
    """Roll (coordinated bank), pitch (flight path + aoa) or heading (track), complex-safe."""
    vel = velocity(time, 0)
    v_n, v_e = vel[..., 0], vel[..., 1]
    ground = np.sqrt(v_n * v_n + v_e * v_e + _SPEED_FLOOR**2)
    if index == 0:
        acc = velocity(time, 1)
        return np.arctan((v_n * acc[..., 1] - v_e * acc[..., 0]) / ground / earth.GAMMA_E)
    if index == 1:
        return np.arctan(-vel[..., 2] / ground) + aoa
    # track of the velocity plus a 1e-9 m/s floor along the ground heading (at rest the
    # track is that heading; < 1e-10 rad in flight), branch by the real velocity
    v_n = v_n + _TRACK_FLOOR * math.cos(heading)
    v_e = v_e + _TRACK_FLOOR * math.sin(heading)
    ground = np.sqrt(v_n * v_n + v_e * v_e)
    with np.errstate(divide="ignore", invalid="ignore"):  # the branch not taken may be 0/0
        north = 2.0 * np.arctan(v_e / (ground + v_n))
        south = np.pi + 2.0 * np.arctan(-v_e / (ground - v_n))
    return np.where(np.real(v_n) > 0.0, north, south)


def analytic_trajectory(plan):
    """The truth of a plan as an :class:`inins.core.trajectory.Analytic` (derivatives by
    complex step): the reference :class:`FlightTruth` is tested against."""
    velocity, _ = plan_velocity(plan)
    rn, re = earth.principal_radii(plan.lat)
    origin = (plan.lat, plan.lon, plan.height)
    scale = (1.0 / (rn + plan.height), 1.0 / ((re + plan.height) * math.cos(plan.lat)), -1.0)
    pos = [lambda t, i=i: _position(velocity, origin, scale, i, -1, t) for i in range(3)]
    rate = [lambda t, i=i: _position(velocity, origin, scale, i, 0, t) for i in range(3)]
    angles = [lambda t, i=i: _attitude(velocity, plan.aoa, plan.heading, i, t) for i in range(3)]
    return Analytic(*angles, *pos, *rate)


@dataclass(frozen=True)
class FlightTruth:
    """Analytic truth of a :class:`FlightPlan` (module docstring), derivatives in closed form.

    The functions of :func:`analytic_trajectory` (position ``lla0 + scale p(t)``,
    the bank, flight-path and track angles of the velocity) with their time
    derivatives written out, in real arithmetic, from the displacement, velocity,
    acceleration and jerk of the :class:`~inins.core.flight.SmoothVelocity`:
    ``d/dt atan(u) = u' / (1 + u^2)``, the track rate ``(V_N a_E - V_E a_N) / V^2``,
    ``acc_n`` the derivative of ``[(R_N + h) lat', (R_E + h) cos(lat) lon', -h']``
    with ``dR_N/dlat = 3 R_N e^2 sin cos / w^2``, ``dR_E/dlat = R_E e^2 sin cos / w^2``.
    The same trajectory as the complex-step one to rounding (tested), at a fraction
    of its cost: ``state``, ``rates`` and the quadrature ``integrals`` that
    :func:`inins.core.trajectory.ideal_increments` uses are compiled,
    :mod:`inins.ekf.flight_kernel` (one pass per time, no array temporaries;
    ``Dithered`` over a ``FlightTruth`` adds the dither there too). A
    :class:`inins.core.trajectory.Trajectory`.
    """

    plan: FlightPlan
    velocity: SmoothVelocity = field(default=None, repr=False)

    def __post_init__(self):
        if self.velocity is None:
            object.__setattr__(self, "velocity", plan_velocity(self.plan)[0])

    @property
    def breakpoints(self):
        """None: the flight is smooth (s)."""
        return np.empty(0)

    def _scale(self):
        p = self.plan
        rn, re = earth.principal_radii(p.lat)
        return np.array([1.0 / (rn + p.height), 1.0 / ((re + p.height) * math.cos(p.lat)), -1.0])

    def state(self, time):
        """Attitude (n, 3, 3), NED velocity (n, 3) m/s and lla (n, 3) at ``time`` (n,) s
        (:func:`inins.ekf.flight_kernel.states`)."""
        out = flight_kernel.states(_kernel_array(time), *self.kernel_params[0])
        mat_nb = rotation.mat_from_euler(out[:, 6], out[:, 7], out[:, 8])
        return mat_nb, out[:, 3:6], out[:, :3]

    @cached_property
    def kernel_params(self):
        """The arrays :mod:`inins.ekf.flight_kernel` takes: steps in centre order
        (centres, taus, dv), prefix sums, plan constants (its docstring)."""
        v, p = self.velocity, self.plan
        index = v._sorted()
        order = index["order"]
        prefix = np.ascontiguousarray(np.concatenate([index["cum_v"], index["cum_p"]], axis=1))
        plan = np.concatenate(
            [
                np.asarray(v.v0, dtype=float),
                [p.lat, p.lon, p.height],
                self._scale(),
                [p.heading, p.aoa, index["reach"]],
                [math.cos(p.aoa), math.sin(p.aoa), math.cos(p.heading), math.sin(p.heading)],
            ]
        )
        taus = np.ascontiguousarray(np.asarray(v.taus, dtype=float)[order])
        class_taus, klass = np.unique(taus, return_inverse=True)
        return (
            np.ascontiguousarray(index["times"]),
            taus,
            np.ascontiguousarray(np.asarray(v.steps, dtype=float).reshape(-1, 3)[order]),
            prefix,
            plan,
        ), (klass.astype(np.int64).ravel(), class_taus)

    def rates(self, time):
        """``omega_ib_b`` (n, 3) rad/s and ``f_b`` (n, 3) m/s^2 at ``time`` (n,) s
        (:func:`inins.ekf.flight_kernel.rates`: the equations of the class docstring)."""
        return _kernel_rates(self.kernel_params, _NO_DITHER, time)

    def integrals(self, start, stop, rule):
        """Gauss-Legendre integrals (n, 3), (n, 3) of the rates over ``[start_k, stop_k]``
        (``rule``: nodes and weights on [-1, 1]), for
        :func:`inins.core.trajectory.ideal_increments`."""
        return _kernel_integrals(self.kernel_params, _NO_DITHER, start, stop, rule)


_NO_DITHER = np.zeros(10)


def _kernel_array(value):
    """``value`` as the kernels take it (float64, 1-D at least, C-contiguous, writable:
    one specialisation per kernel, :func:`inins.ekf.flight_kernel.warm_up`)."""
    arr = np.ascontiguousarray(np.atleast_1d(np.asarray(value, dtype=float)))
    return arr if arr.flags.writeable else arr.copy()


def _kernel_rates(params, dither, time):
    out = flight_kernel.rates(_kernel_array(time), *params[0], dither)
    return out[:, :3], out[:, 3:]


def _kernel_integrals(params, dither, start, stop, rule):
    x, w = (_kernel_array(a) for a in rule)
    out = flight_kernel.integrals(
        _kernel_array(start), _kernel_array(stop), x, w, *params[0], dither, *params[1]
    )
    return out[:, :3], out[:, 3:]


def flight_trajectory(plan):
    """Analytic truth of a :class:`FlightPlan` (module docstring), a :class:`FlightTruth`;
    position as in :func:`inins.core.flight.aircraft_trajectory`:
    ``lat = lat0 + p_N / (R_N0 + h0)``, ``lon = lon0 + p_E / ((R_E0 + h0) cos lat0)``,
    ``h = h0 - p_D``."""
    return FlightTruth(plan)


@dataclass(frozen=True)
class Dither:
    """RLG mechanical dither: ``theta(t) = amplitude sin(2 pi frequency t + phase)`` about ``axis``.

    Attributes
    ----------
    amplitude : float
        Peak angle (rad).
    frequency : float
        Hz; :func:`dither_window` averages over whole periods of it.
    axis : ndarray, shape (3,)
        Unit dither axis in body axes (default the triad diagonal).
    lever : ndarray, shape (3,)
        Accelerometer position relative to the dither pivot, body axes (m).
    phase : float
        rad.
    """

    amplitude: float
    frequency: float
    axis: np.ndarray = field(default_factory=lambda: np.ones(3) / math.sqrt(3.0))
    lever: np.ndarray = field(default_factory=lambda: np.array([0.03, -0.02, 0.04]))
    phase: float = 0.3

    def angles(self, time):
        """``theta``, ``theta'``, ``theta''`` (rad, rad/s, rad/s^2), each (n,)."""
        w = 2.0 * math.pi * self.frequency
        arg = w * np.asarray(time, dtype=float) + self.phase
        s, c = np.sin(arg), np.cos(arg)
        return self.amplitude * s, self.amplitude * w * c, -self.amplitude * w * w * s


@dataclass(frozen=True)
class Dithered:
    """A trajectory with the sensor block dithered (module docstring); :class:`Trajectory`."""

    base: trajectory.Trajectory
    dither: Dither

    @property
    def breakpoints(self):
        """Those of the base trajectory (s)."""
        return self.base.breakpoints

    def _rot(self, time):
        theta, rate, acc = self.dither.angles(time)
        axis = np.asarray(self.dither.axis, dtype=float)
        return rotation.mat_from_rotvec(theta[:, None] * axis), rate, acc, axis

    def state(self, time):
        """Attitude (n, 3, 3), NED velocity (n, 3) of the accelerometers, lla (n, 3)."""
        time = np.atleast_1d(np.asarray(time, dtype=float))
        mat_nb0, vel_n, lla = self.base.state(time)
        mat_d, rate, _, axis = self._rot(time)
        mat_nb = mat_nb0 @ mat_d
        lever_vel = rate[:, None] * np.cross(axis, self.dither.lever)
        return mat_nb, vel_n + np.einsum("nij,nj->ni", mat_nb, lever_vel), lla

    def _kernel_dither(self):
        """The dither row of :mod:`inins.ekf.flight_kernel` when the base is a
        :class:`FlightTruth` (then the compiled path applies), else None."""
        if not isinstance(self.base, FlightTruth):
            return None
        d = self.dither
        return np.concatenate(
            [
                [d.amplitude, 2.0 * math.pi * d.frequency, d.phase],
                np.asarray(d.axis, dtype=float),
                np.asarray(d.lever, dtype=float),
                [1.0],
            ]
        )

    def integrals(self, start, stop, rule):
        """Gauss-Legendre integrals (n, 3), (n, 3) of the rates over ``[start_k, stop_k]``
        (compiled for a :class:`FlightTruth` base), for
        :func:`inins.core.trajectory.ideal_increments`."""
        dither = self._kernel_dither()
        if dither is None:
            return trajectory.quadrature(self, start, stop, rule)
        return _kernel_integrals(self.base.kernel_params, dither, start, stop, rule)

    def rates(self, time):
        """``omega_ib_b`` (n, 3) rad/s and ``f_b`` (n, 3) m/s^2 at the accelerometers."""
        dither = self._kernel_dither()
        if dither is not None:
            return _kernel_rates(self.base.kernel_params, dither, time)
        time = np.atleast_1d(np.asarray(time, dtype=float))
        omega0, force0 = self.base.rates(time)
        theta, rate, acc = self.dither.angles(time)
        axis = np.asarray(self.dither.axis, dtype=float)
        cos, sin = np.cos(theta)[:, None], np.sin(theta)[:, None]

        def back(v):  # exp(-theta [u x]) v = v cos - sin (u x v) + (1 - cos) (u . v) u
            return v * cos - sin * np.cross(axis, v) + (1.0 - cos) * (v @ axis)[:, None] * axis

        u_r = np.cross(axis, self.dither.lever)
        omega = back(omega0) + rate[:, None] * axis
        force = back(force0) + acc[:, None] * u_r + (rate * rate)[:, None] * np.cross(axis, u_r)
        return omega, force


def dither_window(dither, dt):
    """Moving-average length (samples) spanning whole dither periods (003 §2.2).

    The smallest ``n`` with ``n dt f`` within 1 % of an integer (at most 1 s of
    samples); 1 without dither.
    """
    if dither is None or dither.amplitude == 0.0:
        return 1
    for n in range(1, round(1.0 / dt) + 1):
        cycles = n * dt * dither.frequency
        if cycles >= 1.0 and abs(cycles - round(cycles)) < 0.01:
            return n
    return round(1.0 / dt)


STREAM_BLOCK = 12_000
"""Samples of truth evaluated together by :func:`imu_stream` (60 s at 200 Hz; the
block is split into its chunks and dropped, so memory stays flat)."""


def imu_stream(truth, errors, dt, edges_index, rng, *, nodes=3, block=STREAM_BLOCK, ahead=False):
    """Measured increments in consecutive chunks: a generator (memory flat in flight length).

    The ideal increments of consecutive chunks are computed together over about
    ``block`` samples (numpy's fixed cost per call is paid once per block, not once
    per chunk) and the sensor errors applied once per block; as
    :func:`inins.core.imu.apply_errors` is exact in chunks, the output equals the
    chunk-by-chunk one (the noise bit for bit, the truth to rounding).

    Parameters
    ----------
    truth : Trajectory
        E.g. ``Dithered(flight_trajectory(plan), dither)``.
    errors : inins.core.imu.SensorErrors
    dt : float
        Sample interval (s); sample ``k`` spans ``[k dt, (k + 1) dt]``.
    edges_index : array_like of int, shape (m + 1,)
        Chunk boundaries as sample indices, non-decreasing.
    rng : numpy.random.Generator
    nodes : int
        Gauss-Legendre nodes per sample (:func:`inins.core.trajectory.ideal_increments`).
    block : int
        Samples evaluated at once (at least one chunk).
    ahead : bool
        Compute the next block in a second thread while the caller consumes this
        one's chunks (:func:`inins.core.prefetch.ahead`; the same output).

    Yields
    ------
    dtheta, dv : ndarray, shape (n_chunk, 3)
        Gyro (rad) and accelerometer (m/s) increments through the sensor error model.
    """
    edges_index = np.asarray(edges_index, dtype=np.int64)
    blocks = _imu_blocks(truth, errors, dt, edges_index, rng, nodes, block)
    for first, last, lo, dtheta, dv in prefetch.ahead(blocks, 1) if ahead else blocks:
        for k in range(first, last):
            a, b = int(edges_index[k]) - lo, int(edges_index[k + 1]) - lo
            yield dtheta[a:b], dv[a:b]


def _imu_blocks(truth, errors, dt, edges_index, rng, nodes, block):
    """The blocks of :func:`imu_stream`: ``(first, last, lo, dtheta, dv)``, the chunks
    ``first`` to ``last - 1``, starting at sample ``lo``, and their increments."""
    state = None
    m = edges_index.size - 1
    first = 0
    while first < m:
        lo = int(edges_index[first])
        last = int(np.searchsorted(edges_index, lo + block, side="right")) - 1
        last = min(max(last, first + 1), m)
        hi = int(edges_index[last])
        if hi == lo:
            dtheta = dv = np.zeros((0, 3))
        else:
            ideal = trajectory.ideal_increments(truth, np.arange(lo, hi + 1) * dt, nodes=nodes)
            dtheta, dv, state, _ = imu.apply_errors(*ideal, dt, errors, rng, state)
        yield first, last, lo, dtheta, dv
        first = last


def gyrocompass_attitude(mat_nb, lat, height, errors):
    """Attitude a stationary levelling + gyrocompass alignment gives for a unit with ``errors``.

    The window means of the sensors are ``omega_b = M_g mat_bn omega_ie_n + b_g`` and
    ``f_b = M_a (-mat_bn g_n) + b_a`` (dither and white noise average out); then the
    closed forms of :mod:`inins.calibration.alignment`: ``roll = atan2(-f_y, -f_z)``,
    ``pitch = atan2(f_x, hypot(f_y, f_z))``, ``heading = atan2(-omega_L[1], omega_L[0])``
    with ``omega_L = Ry(pitch) Rx(roll) omega_b``. To first order the heading error is
    ``-eps_E / (W cos L)`` (003 eq. 10) and the tilts ``phi_E = -b_N / g``, ``phi_N = b_E / g``
    (levelling leaves ``b_n = phi x f_n``).

    Parameters
    ----------
    mat_nb : array_like, shape (3, 3)
        True attitude on the ground.
    lat, height : float
        rad, m.
    errors : inins.core.imu.SensorErrors

    Returns
    -------
    ndarray, shape (3, 3)
        Aligned (erroneous) ``mat_nb``.
    """
    mat_nb = np.asarray(mat_nb, dtype=float)
    omega_b = errors.gyro_matrix() @ (mat_nb.T @ earth.rate_ie_n(lat)) + errors.gyro_bias
    f_b = errors.accel_matrix() @ (-mat_nb.T @ earth.gravity_n(lat, height)) + errors.accel_bias
    roll = math.atan2(-f_b[1], -f_b[2])
    pitch = math.atan2(f_b[0], math.hypot(f_b[1], f_b[2]))
    level = rotation.mat_from_euler(roll, pitch, 0.0)
    omega_l = level @ omega_b
    return rotation.axis_rotation(2, math.atan2(-omega_l[1], omega_l[0])) @ level
