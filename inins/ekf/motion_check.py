"""The check after an alignment from the motion (``init: motion``): the filter's heading
against the GNSS course over the first minute of motion.

A vehicle moves along its forward axis, so once it is faster than the motion speed
the heading of its forward axis and the course of its GNSS velocity agree within the
slip angle (a few degrees for a car, more in a skid). An alignment that went wrong
(a start in motion taken for a standing one, axes mapped wrongly) leaves the heading
far from the course, and the filter may never pull it back: issue 33's phone + CAN
drive ran on at 190 deg against a 2 deg course without a word. The statistic is the
median of ``|heading - course|`` (wrapped to 180 deg) over the epochs faster than the
motion speed within ``span`` s of the first such epoch after ``start`` (robust to the
slip of a few turns); the largest is reported beside it.
"""

from dataclasses import dataclass

import numpy as np

from inins.ekf import post, scoring


@dataclass(frozen=True)
class HeadingCourse:
    """``median`` and ``max`` of ``|heading - course|`` (rad) over ``epochs`` epochs in
    the ``window`` (s, s) of the first motion."""

    median: float
    max: float
    epochs: int
    window: tuple


def heading_course(time, quat_nb, forward_b, sol_time, sol_lla, motion_speed, start, span=60.0):
    """:class:`HeadingCourse` of a solution against the GNSS course (module docstring);
    None without an epoch faster than ``motion_speed`` after ``start``.

    Parameters
    ----------
    time, quat_nb : ndarray (m,), (m, 4)
        The filter's epochs (s) and attitude.
    forward_b : ndarray (3,)
        The vehicle's forward axis in the body axes.
    sol_time, sol_lla : ndarray (k,), (k, 3)
        GNSS solution epochs (s) and positions (rad, rad, m); the course of the velocity
        of the positions (:func:`inins.ekf.post.velocity_from_positions`).
    motion_speed : float
        m/s.
    start, span : float
        The window opens at the first epoch faster than ``motion_speed`` after ``start``
        (s) and lasts ``span`` s.
    """
    vel = post.velocity_from_positions(sol_time, sol_lla)
    speed = np.hypot(vel[:, 0], vel[:, 1])
    moving = np.flatnonzero((sol_time > start) & (speed > motion_speed))
    if moving.size == 0:
        return None
    lo = sol_time[moving[0]]
    moving = moving[sol_time[moving] <= lo + span]
    course = np.arctan2(vel[moving, 1], vel[moving, 0])
    idx = np.clip(np.searchsorted(time, sol_time[moving]), 0, time.size - 1)
    heading = scoring.forward_heading(quat_nb[idx], forward_b)
    diff = np.abs(np.angle(np.exp(1j * (heading - course))))
    return HeadingCourse(
        float(np.median(diff)), float(diff.max()), int(diff.size), (float(lo), float(lo + span))
    )
