"""Scores of a post-processed run against an independent reference trajectory
(run-ekf ``post.reference``): the forward and smoothed solutions at the reference
epochs, their position, velocity and attitude errors as RMS, 95th percentile and
maximum, and the outage protocol (largest drift per window) against the reference.
Plain functions of the runs' arrays (SI); the file is read in
:mod:`inins.io.reference_files`, the run assembled in :mod:`inins.commands.run_ekf_post`.
"""

import math
from dataclasses import dataclass

import numpy as np

from inins.core import error_model, rotation
from inins.ekf import loose, outages
from inins.exceptions import InputError


@dataclass(frozen=True)
class ErrorStats:
    """RMS, 95th percentile and largest absolute value of an error series (its unit)."""

    rms: float
    p95: float
    max: float


def error_stats(values):
    """:class:`ErrorStats` of ``values`` (k,) over its finite entries; None without any."""
    a = np.abs(np.asarray(values, float))
    a = a[np.isfinite(a)]
    if not a.size:
        return None
    return ErrorStats(float(np.sqrt(np.mean(a**2))), float(np.percentile(a, 95)), float(a.max()))


@dataclass(frozen=True, eq=False)
class ReferenceScore:
    """A solution minus a reference trajectory at the reference epochs it spans:
    ``time`` (k,) s; ``pos_ned`` (k, 3) m; ``vel_ned`` (k, 3) m/s and ``euler`` (k, 3)
    rad roll, pitch, heading (wrapped to ±pi), NaN where the reference has none;
    ``drift`` the outage protocol against the reference
    (:class:`inins.ekf.outages.OutageScore`), None without windows."""

    time: np.ndarray
    pos_ned: np.ndarray
    vel_ned: np.ndarray
    euler: np.ndarray
    drift: outages.OutageScore | None = None

    def stats(self):
        """{``hor``, ``ver`` (m), ``vel`` (m/s, 3D), ``roll``, ``pitch``, ``heading``
        (rad)} -> :class:`ErrorStats` or None (no such reference column)."""
        e = self.pos_ned
        parts = {
            "hor": np.hypot(e[:, 0], e[:, 1]),
            "ver": e[:, 2],
            "vel": np.linalg.norm(self.vel_ned, axis=1),
        }
        parts |= {k: self.euler[:, i] for i, k in enumerate(("roll", "pitch", "heading"))}
        return {k: error_stats(v) for k, v in parts.items()}


def _interp(t, time, values):
    """Columns of ``values`` (m, n) interpolated linearly from ``time`` (m,) to ``t`` (k,)."""
    return np.column_stack([np.interp(t, time, v) for v in values.T])


def _nlerp(t, time, quat):
    """Quaternions (m, 4) at ``t`` (k,): sign-continuous, interpolated linearly, renormalised."""
    q = np.array(quat, float)
    flip = np.sign(np.einsum("ij,ij->i", q[1:], q[:-1]))
    flip[flip == 0] = 1.0
    q[1:] *= np.cumprod(flip)[:, None]
    q = _interp(t, time, q)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def reference_errors(time, solution, lever_arm, ref_time, ref_lla, ref_vel=None, ref_euler=None):
    """A solution's point ``lever_arm`` against a reference trajectory at its epochs.

    The solution (on the time it is labelled with: :func:`inins.ekf.gnss_time.on_gnss_time`)
    is interpolated linearly to the reference epochs inside its span ``[time[0],
    time[-1]]`` (attitude: normalised linear quaternion interpolation). The point is
    ``lla + C_nb l`` and moves with ``v + d(C_nb l)/dt`` (the derivative by central
    differences on the solution's epochs). Errors are solution minus reference: the NED
    position difference (:func:`inins.core.error_model.position_error_ned`), velocity,
    and roll, pitch, heading wrapped to ±pi (heading positive clockwise: a solution
    heading east of the reference's is positive).

    Parameters
    ----------
    time : ndarray (m,)
        Solution epochs (s), increasing.
    solution : inins.ekf.post.Solution
        ``quat`` (m, 4), ``lla`` (m, 3) rad, rad, m, ``vel`` (m, 3) m/s.
    lever_arm : ndarray (3,)
        Reference point minus IMU, body axes (m).
    ref_time, ref_lla : ndarray (r,), (r, 3)
        Reference epochs (s, on the solution's clock) and positions.
    ref_vel, ref_euler : ndarray (r, 3), optional
        Reference NED velocity (m/s) and roll, pitch, heading (rad); NaN where absent.

    Returns
    -------
    ReferenceScore
        Without ``drift``; None when no reference epoch lies in the span.
    """
    span = (ref_time >= time[0]) & (ref_time <= time[-1])
    if not span.any():
        return None
    t = ref_time[span]
    r_n = rotation.mat_from_quat(solution.quat) @ np.asarray(lever_arm, float)
    vel = solution.vel + (np.gradient(r_n, time, axis=0) if time.size > 1 else 0.0)
    quat = _nlerp(t, time, solution.quat)
    lla = loose.antenna_positions(quat, _interp(t, time, solution.lla), lever_arm)
    pos = error_model.position_error_ned(lla, ref_lla[span])
    k = t.size
    dv = np.full((k, 3), np.nan) if ref_vel is None else _interp(t, time, vel) - ref_vel[span]
    de = np.full((k, 3), np.nan)
    if ref_euler is not None:
        de = rotation.euler_from_mat(rotation.mat_from_quat(quat)) - ref_euler[span]
        de = (de + math.pi) % (2 * math.pi) - math.pi
    return ReferenceScore(t, pos, dv, de)


def reference_scores(time, solutions, lever_arm, ref, windows, t0=0.0, source=None):
    """:func:`reference_errors` of each solution, with the outage protocol (largest
    horizontal and 3D error per window, :func:`inins.ekf.outages.score`) on the
    reference epochs in each window.

    Parameters
    ----------
    time : ndarray (m,)
    solutions : dict of str to inins.ekf.post.Solution
        On the time they are labelled with.
    lever_arm : ndarray (3,)
        Reference point minus IMU, body axes (m).
    ref : (ndarray (r,), ndarray (r, 3), ndarray (r, 3) or None, ndarray (r, 3) or None)
        Reference time (s, solutions' clock), position, velocity and Euler angles.
    windows : sequence of (float, float)
        Outage windows (s); a window without a reference epoch is bad input naming
        ``source``.
    t0 : float
        Run start (s), for messages.

    Returns
    -------
    dict of str to ReferenceScore
    """
    ref_time, ref_lla, ref_vel, ref_euler = ref
    out = {}
    for name, s in solutions.items():
        score = reference_errors(time, s, lever_arm, ref_time, ref_lla, ref_vel, ref_euler)
        if score is None:
            raise InputError(
                f"no reference epoch within the run [{time[0] - t0:g}, {time[-1] - t0:g}] s "
                "(its time system or time_offset_s?)",
                source=source,
                key="post.reference.time_offset_s",
            )
        drift = _reference_drift(score, windows, t0, source) if windows else None
        out[name] = ReferenceScore(score.time, score.pos_ned, score.vel_ned, score.euler, drift)
    return out


def _reference_drift(score, windows, t0, source):
    """:class:`~inins.ekf.outages.OutageScore` of a :class:`ReferenceScore`: the largest
    horizontal and 3D error over the reference epochs in each window (no heading: NaN)."""
    hor = np.hypot(score.pos_ned[:, 0], score.pos_ned[:, 1])
    d3 = np.linalg.norm(score.pos_ned, axis=1)
    max_h, max_3 = [], []
    for a, b in windows:
        i = (score.time >= a) & (score.time < b)
        if not i.any():
            raise InputError(
                f"no reference epoch in the outage [{a - t0:g}, {b - t0:g}) s",
                source=source,
                key="post.reference",
            )
        max_h.append(hor[i].max())
        max_3.append(d3[i].max())
    return outages.OutageScore(
        np.asarray(windows, float).reshape(-1, 2),
        np.asarray(max_h),
        np.asarray(max_3),
        np.full(len(max_h), np.nan),
    )
