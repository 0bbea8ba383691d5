"""Piecewise-constant segments of a manoeuvre, given or cut from a trajectory.

A PWCS analysis (Goshen-Meskin & Bar-Itzhack 1992) holds the operating point
of the error model constant over each segment: attitude ``mat_nb``, specific
force ``f_n``, body rate ``omega_ib_b``, velocity ``vel_n`` and position
``lla``. :func:`make_segment` fills the physics a designer leaves out (the
specific force of unaccelerated flight, the body rate of a body fixed in the
nav frame); :func:`cut_segments` turns sampled trajectory arrays into segments,
starting a new one where the attitude or the specific force has moved by more
than a threshold since the segment began.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import earth, jit, rotation
from inins.core.units import DEG
from inins.exceptions import InputError

_ORTHO_TOL = 1e-6


def _vector(value, key, shape=(3,)):
    arr = np.array(value, dtype=float)
    if arr.shape != shape or not np.all(np.isfinite(arr)):
        raise InputError(
            f"expected finite numbers of shape {shape}, got {np.shape(value)}", key=key
        )
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class Segment:
    """One constant operating point of the error model.

    Attributes
    ----------
    duration : float
        Segment length (s), > 0.
    mat_nb : ndarray, shape (3, 3)
        Body-to-NED attitude (orthonormal, det +1).
    f_n : ndarray, shape (3,)
        Specific force in NED (m/s^2); ``[0, 0, -g]`` at rest.
    omega_ib_b : ndarray, shape (3,)
        Body angular rate relative to inertial space (rad/s).
    vel_n : ndarray, shape (3,)
        NED velocity (m/s).
    lla : ndarray, shape (3,)
        ``[lat (rad), lon (rad), height (m)]``.
    los_n : ndarray, shape (k, 3) or None
        Unit lines of sight receiver -> satellite in NED, used by satellite
        measurements that carry no geometry of their own.
    key : str
        Where the segment came from, for error messages (``"segments.3"``).
    """

    duration: float
    mat_nb: np.ndarray
    f_n: np.ndarray
    omega_ib_b: np.ndarray
    vel_n: np.ndarray
    lla: np.ndarray
    los_n: np.ndarray | None = None
    key: str = "segment"

    def __post_init__(self):
        k = self.key
        duration = float(self.duration)
        if not np.isfinite(duration) or duration <= 0.0:
            raise InputError(f"duration must be > 0 s, got {self.duration}", key=f"{k}.duration")
        object.__setattr__(self, "duration", duration)
        mat = _vector(self.mat_nb, f"{k}.mat_nb", (3, 3))
        err = np.abs(mat @ mat.T - np.eye(3)).max()
        if err > _ORTHO_TOL or np.linalg.det(mat) < 0.0:
            raise InputError(
                f"attitude matrix is not a rotation (|C C^T - I| = {err:.2e}, det = "
                f"{np.linalg.det(mat):.3f})",
                key=f"{k}.mat_nb",
            )
        object.__setattr__(self, "mat_nb", mat)
        for name in ("f_n", "omega_ib_b", "vel_n", "lla"):
            object.__setattr__(self, name, _vector(getattr(self, name), f"{k}.{name}"))
        if abs(self.lla[0]) >= 0.5 * np.pi:
            raise InputError("latitude must be inside (-90, 90) deg", key=f"{k}.lla")
        if self.los_n is not None:
            los = np.array(self.los_n, dtype=float)
            if los.ndim != 2 or los.shape[1] != 3 or len(los) == 0:
                raise InputError(f"expected shape (k, 3), got {los.shape}", key=f"{k}.los_n")
            norm = np.linalg.norm(los, axis=1)
            if np.abs(norm - 1.0).max() > 1e-6:
                raise InputError("lines of sight must be unit vectors", key=f"{k}.los_n")
            los.setflags(write=False)
            object.__setattr__(self, "los_n", los)

    @property
    def f_b(self):
        """Specific force in the body frame (m/s^2), shape (3,)."""
        return self.mat_nb.T @ self.f_n


def flight_specific_force(lla, vel_n, acc_n=(0.0, 0.0, 0.0)):
    """Specific force (m/s^2, NED) of a body moving with ``vel_n`` and acceleration ``acc_n``.

    ``f_n = v' + (2 w_ie + w_en) x v - g_n`` (the velocity equation of the
    strapdown mechanisation solved for ``f``); ``[0, 0, -g]`` at rest.
    """
    lla = np.asarray(lla, dtype=float)
    vel_n = np.asarray(vel_n, dtype=float)
    w = 2.0 * earth.rate_ie_n(lla[0]) + earth.rate_en_n(lla[0], lla[2], vel_n)
    return np.asarray(acc_n, float) + np.cross(w, vel_n) - earth.gravity_n(lla[0], lla[2])


def make_segment(
    duration,
    lla,
    *,
    heading=None,
    mat_nb=None,
    vel_n=(0.0, 0.0, 0.0),
    f_n=None,
    f_b=None,
    omega_ib_b=None,
    los_n=None,
    key="segment",
):
    """A :class:`Segment` with the physics of unaccelerated motion filled in.

    Parameters
    ----------
    duration : float
        Segment length (s).
    lla : array_like, shape (3,)
        ``[lat (rad), lon (rad), height (m)]``.
    heading : float, optional
        Heading (rad) of a level body; give this or ``mat_nb`` (default level, north).
    mat_nb : array_like, shape (3, 3), optional
    vel_n : array_like, shape (3,)
        NED velocity (m/s).
    f_n, f_b : array_like, shape (3,), optional
        Specific force in NED or body (m/s^2), at most one. Default: constant
        velocity, ``f_n = (2 w_ie + w_en) x v - g_n``.
    omega_ib_b : array_like, shape (3,), optional
        Body rate (rad/s). Default: the body does not turn relative to the nav
        frame, ``omega_ib_b = C_nb^T (w_ie + w_en)``.
    los_n : array_like, shape (k, 3), optional
        Satellite lines of sight (NED unit vectors).
    """
    if heading is not None and mat_nb is not None:
        raise InputError("give heading or mat_nb, not both", key=f"{key}.heading")
    if f_n is not None and f_b is not None:
        raise InputError("give f_n or f_b, not both", key=f"{key}.f_b")
    lla_arr = _vector(lla, f"{key}.lla")
    vel = _vector(vel_n, f"{key}.vel_n")
    mat = (
        np.asarray(mat_nb, float)
        if mat_nb is not None
        else rotation.mat_from_euler(0.0, 0.0, 0.0 if heading is None else heading)
    )
    if f_n is None:
        f_n = flight_specific_force(lla_arr, vel) if f_b is None else mat @ np.asarray(f_b, float)
    if omega_ib_b is None:
        w_in = earth.rate_ie_n(lla_arr[0]) + earth.rate_en_n(lla_arr[0], lla_arr[2], vel)
        omega_ib_b = mat.T @ w_in
    return Segment(duration, mat, f_n, omega_ib_b, vel, lla_arr, los_n, key)


@jit.njit(cache=True)
def _segment_starts(mat_nb, f_b, trace_min, force_max):
    """Indices where a segment starts: attitude angle since the start > threshold
    (``trace(C_s^T C_k) < 1 + 2 cos(threshold)``) or ``|f_k - f_s| > force_max``."""
    n = mat_nb.shape[0]
    starts = np.empty(n, dtype=np.int64)
    count = 1
    starts[0] = 0
    s = 0
    for k in range(1, n):
        trace = 0.0
        for i in range(3):
            for j in range(3):
                trace += mat_nb[s, i, j] * mat_nb[k, i, j]
        df = 0.0
        for i in range(3):
            df += (f_b[k, i] - f_b[s, i]) ** 2
        if trace < trace_min or df > force_max * force_max:
            starts[count] = k
            count += 1
            s = k
    return starts[:count]


def cut_segments(
    time,
    mat_nb,
    f_b,
    omega_ib_b,
    vel_n,
    lla,
    *,
    attitude_threshold=2.0 * DEG,
    force_threshold=0.5,
    los_n=None,
):
    """Cut a sampled trajectory into piecewise-constant segments.

    Rule: a segment starts at sample ``s``; the first later sample ``k`` whose
    attitude differs from sample ``s`` by more than ``attitude_threshold``
    (rotation angle of ``C_s^T C_k``) or whose body specific force differs by
    more than ``force_threshold`` starts the next one. Each segment spans from
    its first sample to the first sample of the next (the last to the final
    time) and takes the operating point of its middle sample, with ``f_b`` and
    ``omega_ib_b`` averaged over its samples.

    Parameters
    ----------
    time : array_like, shape (n,)
        Strictly increasing sample times (s).
    mat_nb : array_like, shape (n, 3, 3)
    f_b, omega_ib_b : array_like, shape (n, 3)
        Specific force (m/s^2) and body rate (rad/s).
    vel_n : array_like, shape (n, 3)
        NED velocity (m/s).
    lla : array_like, shape (n, 3)
        ``[lat (rad), lon (rad), height (m)]``.
    attitude_threshold : float
        Rad (default 2 deg).
    force_threshold : float
        m/s^2 (default 0.5).
    los_n : array_like, shape (k, 3), optional
        Satellite geometry given to every segment.

    Returns
    -------
    tuple of Segment
    """
    time = np.asarray(time, dtype=float)
    arrays = {
        "mat_nb": (mat_nb, (3, 3)),
        "f_b": (f_b, (3,)),
        "omega_ib_b": (omega_ib_b, (3,)),
        "vel_n": (vel_n, (3,)),
        "lla": (lla, (3,)),
    }
    n = len(time)
    if time.ndim != 1 or n < 2 or not np.all(np.diff(time) > 0.0):
        raise InputError("time must be a strictly increasing 1-D array of >= 2 samples", key="time")
    data = {}
    for name, (value, shape) in arrays.items():
        arr = np.ascontiguousarray(value, dtype=float)
        if arr.shape != (n, *shape):
            raise InputError(f"expected shape {(n, *shape)}, got {arr.shape}", key=name)
        data[name] = arr
    ortho = np.abs(data["mat_nb"] @ np.swapaxes(data["mat_nb"], 1, 2) - np.eye(3)).max(axis=(1, 2))
    if ortho.max() > _ORTHO_TOL:
        k = int(np.argmax(ortho))
        raise InputError(
            f"attitude matrix at sample {k} is not orthonormal (|C C^T - I| = {ortho[k]:.2e})",
            key="mat_nb",
        )
    if attitude_threshold <= 0.0 or force_threshold <= 0.0:
        raise InputError("thresholds must be > 0", key="attitude_threshold")
    starts = _segment_starts(
        data["mat_nb"], data["f_b"], 1.0 + 2.0 * np.cos(attitude_threshold), float(force_threshold)
    )
    ends = np.append(starts[1:], n - 1)
    segments = []
    for j, (s, e) in enumerate(zip(starts, ends, strict=True)):
        if time[e] <= time[s]:
            continue
        mid = (s + e) // 2
        mat = data["mat_nb"][mid]
        stop = max(e, s + 1)
        f_n = mat @ data["f_b"][s:stop].mean(axis=0)
        omega = data["omega_ib_b"][s:stop].mean(axis=0)
        seg = Segment(
            time[e] - time[s],
            mat,
            f_n,
            omega,
            data["vel_n"][mid],
            data["lla"][mid],
            los_n,
            key=f"segments.{j}",
        )
        segments.append(seg)
    return tuple(segments)


def interval_means(chunks, edges, dt):
    """Mean body rate and specific force of IMU increments over consecutive intervals.

    Parameters
    ----------
    chunks : iterable of (k0, dtheta, dv)
        Increments in order, ``dtheta`` and ``dv`` (m, 3) of samples ``k0 .. k0 + m``
        (rad, m/s), e.g. :meth:`inins.core.records.TableRecord.imu_chunks`.
    edges : array_like of int, shape (J + 1,)
        Sample index where each interval starts, then the end of the last; samples
        outside ``[edges[0], edges[-1])`` are ignored.
    dt : float
        Sample interval (s).

    Returns
    -------
    omega_b, f_b : ndarray, shape (J, 3)
        ``sum dtheta / (n dt)`` and ``sum dv / (n dt)`` per interval (rad/s, m/s^2);
        an empty interval divides by one sample.
    """
    edges = np.asarray(edges, dtype=np.int64)
    sums = np.zeros((len(edges) - 1, 6))
    for k0, dtheta, dv in chunks:
        rows = np.hstack([dtheta, dv])
        owner = np.searchsorted(edges, np.arange(k0, k0 + len(rows)), side="right") - 1
        inside = (owner >= 0) & (owner < len(sums))
        np.add.at(sums, owner[inside], rows[inside])
    span = np.maximum(np.diff(edges), 1)[:, None] * dt
    return sums[:, :3] / span, sums[:, 3:] / span


TURN_ROLL = 10.0 * DEG
"""A segment banked more than this is part of a turn."""


def turns(segments):
    """(start, end) times (s) of the turns: runs of segments banked beyond :data:`TURN_ROLL`."""
    ends = np.cumsum([s.duration for s in segments])
    banked = [abs(rotation.euler_from_mat(s.mat_nb)[0]) > TURN_ROLL for s in segments]
    out, start = [], None
    for j, b in enumerate(banked):
        if b and start is None:
            start = float(ends[j] - segments[j].duration)
        if start is not None and not b:
            out.append((start, float(ends[j - 1])))
            start = None
    if start is not None:
        out.append((start, float(ends[-1])))
    return out
