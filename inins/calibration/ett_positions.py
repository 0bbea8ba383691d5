"""The two ETT positions of a table record (000 §3.1): which holds they are, and the
mean specific force and table angles over their windows.

Used by :func:`inins.calibration.ett.align_ett`.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import noise, rotation
from inins.core.units import DEG
from inins.exceptions import InputError
from inins.table.kinematics import platform_matrix

METHOD = "align-ett (ETT azimuth alignment, 000 §3.1)"
UP_N = np.array([0.0, 0.0, -1.0])
LEVEL_COS = np.cos(10.0 * DEG)
"""A hold is level when the platform normal is within 10 deg of the vertical ..."""
VERTICAL_SIN = np.sin(10.0 * DEG)
"""... and vertical (table pitched 90 deg) when it is within 10 deg of the horizontal."""


@dataclass(frozen=True)
class EttPosition:
    """One table position: the hold (``step`` index, ``label``), the averaged window
    ``[time_start, time_end]`` (s), the mean specific force ``f_b`` (m/s^2, (3,)) and
    encoder angles ``angles`` (rad, (g,)) with the 1 sigma of each mean."""

    label: str
    step: int
    time_start: float
    time_end: float
    f_b: np.ndarray
    f_sigma: np.ndarray
    angles: np.ndarray
    angles_sigma: np.ndarray


def _holds(record):
    return [(i, s) for i, s in enumerate(record.steps) if s.kind == "hold"]


def _up_t(record, step):
    """Up direction in platform axes at a hold (nominal angles)."""
    return platform_matrix(record.axes, record.mat_n_base, step.angles_end).T @ UP_N


def _named(record, label, key):
    for i, s in _holds(record):
        if s.label == label:
            return i
    known = ", ".join(repr(s.label) for _, s in _holds(record)) or "none"
    raise InputError(
        f"{METHOD}: no hold labelled {label!r} in the step schedule (hold labels: {known})",
        source=record.source,
        key=key,
    )


def _no_vertical(record, holds, up):
    listed = (
        ", ".join(
            f"{s.label or '#' + str(i)} (normal "
            f"{np.degrees(np.arccos(min(abs(up[i][2]), 1.0))):.0f} deg from "
            "vertical)"
            for i, s in holds
        )
        or "none"
    )
    return InputError(
        f"{METHOD}: the record has no vertical position (a hold with the table pitched "
        f"90 deg, platform normal horizontal); holds: {listed}. Add one to the motion "
        "program or name it with positions.vertical_label",
        source=record.source,
        key="positions.vertical_label",
    )


def select_positions(record, options):
    """Step indices (vertical, level) of the ETT positions.

    Named by label, or found: the vertical position is the first hold whose platform
    normal (along which the IMU's nominally vertical axis lies) is within 10 deg of the
    horizontal; the level position the first hold after it with the normal within 10 deg
    of the vertical, else the last such hold before it.

    Raises
    ------
    InputError
        No such hold, an unknown label, or two positions whose up directions in the
        table frame are within 45 deg of (anti)parallel: they do not fix the azimuth.
    """
    holds = _holds(record)
    up = {i: _up_t(record, s) for i, s in holds}
    if options.vertical_label is not None:
        vertical = _named(record, options.vertical_label, "positions.vertical_label")
    else:
        found = [i for i, _ in holds if abs(up[i][2]) < VERTICAL_SIN]
        if not found:
            raise _no_vertical(record, holds, up)
        vertical = found[0]
    if options.level_label is not None:
        level = _named(record, options.level_label, "positions.level_label")
        if abs(up[level][2]) < LEVEL_COS:
            raise InputError(
                f"{METHOD}: the hold {options.level_label!r} is not level "
                "(platform normal more than 10 deg from the vertical)",
                source=record.source,
                key="positions.level_label",
            )
    else:
        found = [i for i, _ in holds if abs(up[i][2]) > LEVEL_COS]
        if not found:
            raise InputError(
                f"{METHOD}: the record has no level hold (platform normal "
                "vertical); add one or name it with positions.level_label",
                source=record.source,
                key="positions.level_label",
            )
        after = [i for i in found if i > vertical]
        level = after[0] if after else found[-1]
    if abs(up[vertical] @ up[level]) > np.cos(45.0 * DEG):
        names = (record.steps[vertical].label, record.steps[level].label)
        raise InputError(
            f"{METHOD}: the holds {names[0]!r} and {names[1]!r} see gravity within 45 deg "
            "of the same table axis, so they do not fix the azimuth; use one vertical "
            "(table pitch 90 deg) and one level hold",
            source=record.source,
            key="positions",
        )
    return vertical, level


def hold_window(record, index, settle, window, name):
    step = record.steps[index]
    first = step.start_index + int(np.ceil(settle / record.dt - 1e-9))
    stop = step.stop_index
    if window is not None:
        stop = min(stop, first + round(window / record.dt))
    if stop - first < 2:
        raise InputError(
            f"{METHOD}: the {name} hold {step.label!r} is "
            f"{step.end_time - step.start_time:g} s long, too short for a "
            f"settle time of {settle:g} s",
            source=record.source,
            key="positions.settle_s",
        )
    return first, stop


def window_mean(increments, dt, random_walk=None):
    """Mean rate of increments and the 1 sigma of that mean per axis.

    ``sigma = N / sqrt(T)`` for a stated random walk ``N``; otherwise the scatter of
    :data:`inins.core.noise.BLOCKS` block means, ``std(block means) / sqrt(blocks)``
    (block sums carry the quantization remainder, so quantized data are not penalised per sample).

    Parameters
    ----------
    increments : ndarray, shape (n, 3)
    dt : float
        Sample interval (s).
    random_walk : float, optional
        Random walk (unit/sqrt(s)).
    """
    n = increments.shape[0]
    mean = increments.sum(axis=0) / (n * dt)
    if random_walk is None:
        random_walk = noise.noise_density(increments, dt)
    return mean, np.broadcast_to(random_walk, (3,)) / np.sqrt(n * dt)


def _encoder(record, step, t_a, t_b):
    sel = (record.encoder_time >= t_a) & (record.encoder_time <= t_b)
    ref = np.asarray(step.angles_end, dtype=float)
    if np.count_nonzero(sel) < 2:
        return ref, np.zeros_like(ref)
    diff = rotation.wrap_angle(record.encoder[sel] - ref)
    return ref + diff.mean(axis=0), diff.std(axis=0, ddof=1) / np.sqrt(diff.shape[0])


def measure(record, index, options, name):
    """The :class:`EttPosition` of hold ``index``: accelerometer and encoder means."""
    first, stop = hold_window(record, index, options.settle, options.window, name)
    _, dv = record.imu(first, stop)
    f_b, f_sigma = window_mean(dv, record.dt, options.accel_vrw)
    t_a, t_b = record.t0 + first * record.dt, record.t0 + stop * record.dt
    step = record.steps[index]
    angles, angles_sigma = _encoder(record, step, t_a, t_b)
    return EttPosition(step.label, index, t_a, t_b, f_b, f_sigma, angles, angles_sigma)
