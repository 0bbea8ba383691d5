"""Analytic truth trajectories and exact ("ideal") IMU increments.

A trajectory gives the truth as functions of time: ``state(time)`` returns
attitude, velocity and position, ``rates(time)`` the angular rate and specific
force an ideal IMU senses, and ``breakpoints`` lists the times at which rates or
accelerations may jump. :func:`ideal_increments` integrates the rates over each
sample interval by Gauss-Legendre quadrature, split at breakpoints, which is
what an error-free rate-integrating gyro / accelerometer pair delivers.
Trajectories: :class:`Stationary`, :class:`Analytic` (Euler angles and position
as analytic functions, derivatives by complex step), :class:`Coning`, and
:func:`aircraft_trajectory` (10-min flight with turns, speed changes, climbs).

Governing equations (NED, package conventions):

``omega_ib_b = omega_nb_b + mat_bn (omega_ie_n + omega_en_n)``

``f_b = mat_bn (acc_n + (2 omega_ie_n + omega_en_n) x vel_n - g_n)``

with ``acc_n = d vel_n / dt`` and ``g_n`` normal gravity (centrifugal included).
"""

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from inins.core import earth, rotation

CS_STEP = 1e-20
"""Complex step (s): ``f'(t) = Im f(t + i CS_STEP) / CS_STEP`` to machine precision."""


class Trajectory(Protocol):
    """Truth trajectory: ``breakpoints`` (k,) s where rates may jump (may be empty),
    ``rates(time (n,) s) -> (omega_ib_b (n, 3) rad/s, f_b (n, 3) m/s^2)`` and
    ``state(time) -> (mat_nb (n, 3, 3), vel_n (n, 3) m/s NED, lla (n, 3) [rad, rad, m])``.
    A trajectory may also give ``integrals(start, stop, rule)``, the Gauss-Legendre
    integrals :func:`quadrature` computes (the flight truth compiles them), which
    :func:`ideal_increments` then uses.
    """

    breakpoints: np.ndarray

    def rates(self, time): ...

    def state(self, time): ...


def _to_body(mat_nb, vec_n):
    return np.einsum("...ji,...j->...i", mat_nb, vec_n)


def body_rates(mat_nb, omega_nb_b, vel_n, acc_n, lla):
    """Angular rate and specific force sensed by an ideal IMU.

    ``omega_ib_b = omega_nb_b + mat_bn (omega_ie_n + omega_en_n)`` and
    ``f_b = mat_bn (acc_n + (2 omega_ie_n + omega_en_n) x vel_n - g_n)``.

    Parameters
    ----------
    mat_nb : array_like, shape (n, 3, 3)
        Body-to-NED attitude.
    omega_nb_b : array_like, shape (n, 3)
        Body rate relative to the nav frame, in body axes (rad/s).
    vel_n : array_like, shape (n, 3)
        NED velocity relative to the Earth (m/s).
    acc_n : array_like, shape (n, 3)
        ``d vel_n / dt`` (m/s^2).
    lla : array_like, shape (n, 3)
        ``[lat (rad), lon (rad), height (m)]``.

    Returns
    -------
    omega_ib_b : ndarray, shape (n, 3)
        Inertial angular rate in body axes (rad/s).
    f_b : ndarray, shape (n, 3)
        Specific force in body axes (m/s^2).
    """
    lla = np.asarray(lla, dtype=float)
    vel_n = np.asarray(vel_n, dtype=float)
    lat, height = lla[..., 0], lla[..., 2]
    w_ie = earth.rate_ie_n(lat)
    w_en = earth.rate_en_n(lat, height, vel_n)
    omega_ib_b = np.asarray(omega_nb_b, dtype=float) + _to_body(mat_nb, w_ie + w_en)
    f_n = np.asarray(acc_n, dtype=float) + np.cross(2.0 * w_ie + w_en, vel_n)
    f_b = _to_body(mat_nb, f_n - earth.gravity_n(lat, height))
    return omega_ib_b, f_b


def ideal_increments(trajectory, time_edges, *, nodes=3, chunk=4096):
    """Exact gyro and accelerometer increments over sample intervals.

    ``dtheta_k = int omega_ib_b dt`` and ``dv_k = int f_b dt`` over
    ``[t_k, t_{k+1}]``: integrated rate and integrated specific force in the
    moving body axes (not rotation vectors). Gauss-Legendre quadrature with
    ``nodes`` points per interval (exact for polynomials of degree
    ``2 nodes - 1``); the few intervals that contain a breakpoint are integrated
    piecewise so that a step inside a sample is integrated exactly.

    Parameters
    ----------
    trajectory : Trajectory
        Truth with ``rates(time)`` and ``breakpoints``.
    time_edges : array_like, shape (n + 1,)
        Strictly increasing interval edges (s).
    nodes : int
        Quadrature points per interval.
    chunk : int
        Intervals evaluated at once; bounds memory for long records.

    Returns
    -------
    dtheta : ndarray, shape (n, 3)
        Gyro increments (rad).
    dv : ndarray, shape (n, 3)
        Accelerometer increments (m/s).
    """
    edges = np.asarray(time_edges, dtype=float)
    if edges.ndim != 1 or edges.size < 2 or not np.all(np.diff(edges) > 0.0):
        raise ValueError("time_edges must be a strictly increasing 1-D array of >= 2 times")
    if nodes < 1 or chunk < 1:
        raise ValueError("nodes and chunk must be positive")
    rule = np.polynomial.legendre.leggauss(nodes)
    dtheta, dv = _quadrature(trajectory, edges[:-1], edges[1:], rule, chunk)
    _redo_split_intervals(trajectory, edges, rule, chunk, dtheta, dv)
    return dtheta, dv


def _quadrature(trajectory, start, stop, rule, chunk):
    """The trajectory's own ``integrals`` (a compiled quadrature) where it has one,
    else :func:`quadrature`."""
    integrals = getattr(trajectory, "integrals", None)
    if integrals is not None:
        return integrals(start, stop, rule)
    return quadrature(trajectory, start, stop, rule, chunk)


def quadrature(trajectory, start, stop, rule, chunk=4096):
    """Gauss-Legendre integrals (n, 3), (n, 3) of ``trajectory.rates`` over
    ``[start_k, stop_k]`` (``rule``: nodes and weights on [-1, 1]), ``chunk``
    intervals at a time."""
    x, w = rule
    n = start.size
    dtheta = np.empty((n, 3))
    dv = np.empty((n, 3))
    for lo in range(0, n, chunk):
        hi = min(lo + chunk, n)
        half = 0.5 * (stop[lo:hi] - start[lo:hi])
        mid = 0.5 * (stop[lo:hi] + start[lo:hi])
        if x.size == 1:  # midpoint rule
            omega, force = trajectory.rates(mid)
            dtheta[lo:hi] = (2.0 * half)[:, None] * omega
            dv[lo:hi] = (2.0 * half)[:, None] * force
            continue
        omega, force = trajectory.rates((mid[:, None] + half[:, None] * x).ravel())
        shape = (hi - lo, x.size, 3)
        dtheta[lo:hi] = half[:, None] * np.einsum("j,kjc->kc", w, omega.reshape(shape))
        dv[lo:hi] = half[:, None] * np.einsum("j,kjc->kc", w, force.reshape(shape))
    return dtheta, dv


def _redo_split_intervals(trajectory, edges, rule, chunk, dtheta, dv):
    """Re-integrate, piece by piece, the intervals with a breakpoint strictly inside."""
    n = edges.size - 1
    marks = np.unique(np.asarray(trajectory.breakpoints, dtype=float))
    owner = np.searchsorted(edges, marks, side="right") - 1
    inside = (owner >= 0) & (owner < n)
    inside[inside] &= marks[inside] > edges[owner[inside]]
    marks, owner = marks[inside], owner[inside]
    if marks.size == 0:
        return
    split = np.unique(owner)
    points = np.concatenate([edges[split], edges[split + 1], marks])
    labels = np.concatenate([split, split, owner])
    order = np.lexsort((points, labels))
    points, labels = points[order], labels[order]
    same = labels[1:] == labels[:-1]
    piece_theta, piece_v = _quadrature(trajectory, points[:-1][same], points[1:][same], rule, chunk)
    dtheta[split] = 0.0
    dv[split] = 0.0
    np.add.at(dtheta, labels[:-1][same], piece_theta)
    np.add.at(dv, labels[:-1][same], piece_v)


class _Smooth:
    @property
    def breakpoints(self):
        """No discontinuities: empty array (s)."""
        return np.empty(0)


@dataclass(frozen=True)
class Stationary(_Smooth):
    """A body at rest on the Earth: ``omega_ib_b = mat_bn omega_ie_n``, ``f_b = -mat_bn g_n``.

    Parameters
    ----------
    lat, lon, height : float
        Geodetic position (rad, rad, m).
    mat_nb : array_like, shape (3, 3)
        Body-to-NED attitude (default identity).
    """

    lat: float
    lon: float
    height: float
    mat_nb: np.ndarray = field(default_factory=lambda: np.eye(3))

    def state(self, time):
        """Attitude (n, 3, 3), velocity (n, 3) m/s (zero) and lla (n, 3) at ``time`` (n,) s."""
        n = np.size(time)
        mat_nb = np.broadcast_to(np.asarray(self.mat_nb, dtype=float), (n, 3, 3)).copy()
        lla = np.tile([self.lat, self.lon, self.height], (n, 1))
        return mat_nb, np.zeros((n, 3)), lla

    def rates(self, time):
        """Constant ``omega_ib_b`` (n, 3) rad/s and ``f_b`` (n, 3) m/s^2 at ``time`` (n,) s."""
        mat_nb, vel_n, lla = self.state([0.0])
        omega, force = body_rates(mat_nb, vel_n, vel_n, vel_n, lla)
        n = np.size(time)
        return np.repeat(omega, n, axis=0), np.repeat(force, n, axis=0)


def complex_step(func, time):
    """Value and derivative, each (n,), of a complex-safe analytic ``func`` at ``time`` (n,) s.

    ``f(t) = Re f(t + i h)``, ``f'(t) = Im f(t + i h) / h`` with ``h = CS_STEP``:
    no subtraction, so exact to machine precision.
    """
    z = np.broadcast_to(np.asarray(func(time + 1j * CS_STEP), dtype=complex), np.shape(time))
    return z.real.copy(), z.imag / CS_STEP


def second_derivative(func, time, step):
    """Second derivative (n,) of ``func`` at ``time`` (n,) s, 45-degree complex step ``h = step``.

    ``f''(t) = Im[f(t + h w) + f(t - h w)] / h^2 + O(h^4)``, ``w = exp(i pi/4)``
    (Lai & Crassidis 2008): the odd terms cancel in the imaginary part only, so
    round-off is ``eps |f'| / h``, not the ``eps |f| / h^2`` of a real difference.
    """
    shift = step * np.exp(0.25j * np.pi)
    total = np.asarray(func(time + shift), dtype=complex) + func(time - shift)
    return np.broadcast_to(total.imag / step**2, np.shape(time)).copy()


def _vel_n(lla, lla_rate):
    """``[(rn + h) dlat, (re + h) cos(lat) dlon, -dh]`` (complex-safe), shape (n, 3)."""
    lat, height = lla[..., 0], lla[..., 2]
    rn, re = earth.principal_radii(lat)
    return np.stack(
        [
            (rn + height) * lla_rate[..., 0],
            (re + height) * np.cos(lat) * lla_rate[..., 1],
            -lla_rate[..., 2],
        ],
        -1,
    )


def euler_rates_to_body(euler, euler_rate):
    """``omega_nb_b`` (n, 3) rad/s from roll, pitch, heading (n, 3) rad and their rates.

    ``omega_nb_b = [r' - h' sin p, p' cos r + h' sin r cos p, -p' sin r + h' cos r cos p]``.
    """
    roll, pitch = euler[..., 0], euler[..., 1]
    dr, dp, dh = euler_rate[..., 0], euler_rate[..., 1], euler_rate[..., 2]
    sr, cr, sp, cp = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    return np.stack([dr - dh * sp, dp * cr + dh * sr * cp, -dp * sr + dh * cr * cp], axis=-1)


@dataclass(frozen=True)
class Analytic:
    """Truth from analytic functions of time: Euler angles and geodetic position.

    Derivatives by complex step (:func:`complex_step`), exact to machine
    precision without ODE integration: ``omega_nb_b`` from the Euler-angle rates
    (:func:`euler_rates_to_body`); ``vel_n = [(R_N + h) lat', (R_E + h) cos(lat) lon', -h']``;
    ``acc_n = d vel_n / dt`` by a complex step of ``vel_n`` along the trajectory
    when ``lat_rate``, ``lon_rate``, ``height_rate`` are given, else with the
    position's second derivatives from :func:`second_derivative` (relative
    error ~1e-10 for functions smooth on the scale of ``step2``).

    Parameters
    ----------
    roll, pitch, heading : callable
        Complex-safe numpy functions of time (s) returning rad.
    lat, lon, height : callable
        Complex-safe functions of time returning rad, rad, m.
    lat_rate, lon_rate, height_rate : callable, optional
        Their exact derivatives (rad/s, rad/s, m/s), all three or none.
    breakpoints : array_like, shape (k,)
        Times (s) where the functions are only piecewise analytic. Callables
        must choose their branch from ``Re(t)``. With breakpoints, give the
        rate callables (the 45-degree step would straddle a breakpoint).
    step2 : float
        Step (s) of :func:`second_derivative`, used without rate callables.
    """

    roll: Callable
    pitch: Callable
    heading: Callable
    lat: Callable
    lon: Callable
    height: Callable
    lat_rate: Callable | None = None
    lon_rate: Callable | None = None
    height_rate: Callable | None = None
    breakpoints: np.ndarray = field(default_factory=lambda: np.empty(0))
    step2: float = 0.05

    def __post_init__(self):
        given = [f is not None for f in (self.lat_rate, self.lon_rate, self.height_rate)]
        if any(given) and not all(given):
            raise ValueError("give all of lat_rate, lon_rate, height_rate or none")
        object.__setattr__(self, "breakpoints", np.sort(np.asarray(self.breakpoints, float)))

    def _euler(self, time):
        pairs = [complex_step(f, time) for f in (self.roll, self.pitch, self.heading)]
        return np.stack([p[0] for p in pairs], -1), np.stack([p[1] for p in pairs], -1)

    def _position(self, time, second=True):
        """lla and its first and second (None unless ``second``) derivatives, each (n, 3)."""
        if self.lat_rate is None:
            funcs = (self.lat, self.lon, self.height)
            pairs = [complex_step(f, time) for f in funcs]
            acc = [second_derivative(f, time, self.step2) for f in funcs] if second else None
        else:
            rates = [
                complex_step(f, time) for f in (self.lat_rate, self.lon_rate, self.height_rate)
            ]
            acc = [r[1] for r in rates]
            pairs = [
                (np.real(f(time + 0j)), r[0])
                for f, r in zip((self.lat, self.lon, self.height), rates, strict=True)
            ]
        lla = np.stack([np.broadcast_to(p[0], np.shape(time)) for p in pairs], -1)
        lla_rate = np.stack([p[1] for p in pairs], -1)
        return lla, lla_rate, None if acc is None else np.stack(acc, -1)

    def state(self, time):
        """Attitude (n, 3, 3), NED velocity (n, 3) m/s and lla (n, 3) at ``time`` (n,) s."""
        time = np.atleast_1d(np.asarray(time, dtype=float))
        euler, _ = self._euler(time)
        lla, lla_rate, _ = self._position(time, second=False)
        mat_nb = rotation.mat_from_euler(euler[:, 0], euler[:, 1], euler[:, 2])
        return mat_nb, _vel_n(lla, lla_rate), lla

    def rates(self, time):
        """``omega_ib_b`` (n, 3) rad/s and ``f_b`` (n, 3) m/s^2 at ``time`` (n,) s."""
        time = np.atleast_1d(np.asarray(time, dtype=float))
        euler, euler_rate = self._euler(time)
        lla, lla_rate, lla_acc = self._position(time)
        vel_n = _vel_n(lla, lla_rate)
        # d/dt vel_n(lla, lla_rate): directional complex step along lla' plus the
        # part linear in lla_rate
        acc_n = _vel_n(lla + 1j * CS_STEP * lla_rate, lla_rate).imag / CS_STEP
        acc_n += _vel_n(lla, lla_acc)
        mat_nb = rotation.mat_from_euler(euler[:, 0], euler[:, 1], euler[:, 2])
        omega_nb_b = euler_rates_to_body(euler, euler_rate)
        return body_rates(mat_nb, omega_nb_b, vel_n, acc_n, lla)


@dataclass(frozen=True)
class Coning(_Smooth):
    """Classic coning motion at a fixed position (Savage, Strapdown Analytics 7.1.1).

    In a frame r fixed in the nav frame, ``mat_rb(t) = exp([phi(t) x])`` with
    ``phi = theta [0, cos W t, sin W t]``: body x cones about r's x axis at
    half-angle ``theta``, with a constant axial and a rotating transverse rate
    ``omega_rb_b = [-2 W sin^2(theta/2), -W sin(theta) sin W t, W sin(theta) cos W t]``.
    ``mat_nb = mat_nr mat_rb``; :func:`body_rates` adds Earth rate and gravity.

    Parameters
    ----------
    half_angle : float
        ``theta`` (rad).
    frequency : float
        Coning frequency ``W / 2 pi`` (Hz).
    lat, lon, height : float
        Position (rad, rad, m).
    mat_nr : array_like, shape (3, 3)
        Orientation of the cone frame in NED (default identity: axis north).
    """

    half_angle: float
    frequency: float
    lat: float
    lon: float
    height: float
    mat_nr: np.ndarray = field(default_factory=lambda: np.eye(3))

    def _omega_rb_b(self, time):
        w = 2.0 * np.pi * self.frequency
        theta = self.half_angle
        axial = np.full_like(time, -2.0 * w * np.sin(0.5 * theta) ** 2)
        return np.stack(
            [axial, -w * np.sin(theta) * np.sin(w * time), w * np.sin(theta) * np.cos(w * time)], -1
        )

    def state(self, time):
        """Attitude (n, 3, 3), velocity (n, 3) m/s (zero) and lla (n, 3) at ``time`` (n,) s."""
        time = np.atleast_1d(np.asarray(time, dtype=float))
        w = 2.0 * np.pi * self.frequency
        phi = self.half_angle * np.stack([0.0 * time, np.cos(w * time), np.sin(w * time)], -1)
        mat_nb = np.asarray(self.mat_nr, dtype=float) @ rotation.mat_from_rotvec(phi)
        lla = np.tile([self.lat, self.lon, self.height], (time.size, 1))
        return mat_nb, np.zeros((time.size, 3)), lla

    def rates(self, time):
        """``omega_ib_b`` (n, 3) rad/s and ``f_b`` (n, 3) m/s^2 at ``time`` (n,) s."""
        time = np.atleast_1d(np.asarray(time, dtype=float))
        mat_nb, vel_n, lla = self.state(time)
        return body_rates(mat_nb, self._omega_rb_b(time), vel_n, vel_n, lla)
