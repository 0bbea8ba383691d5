"""Navigation through a table record: alignment window, then stationary strapdown in chunks.

Memory grows with the output grid, not with the record: increments are read
chunk by chunk from the record (a 24 h log streams from disk).
"""

import numpy as np

from inins.calibration import alignment
from inins.calibration.tilt_model import Track, vertical_axis
from inins.core import noise, strapdown
from inins.exceptions import InputError

MAX_TRACK_POINTS = 20_000
"""The output grid is thinned to at most this many points: the linear-model arrays of
the methods take about 1 kB per point, so 10-min and 4-h holds at 1 kHz peak within a
few per cent of each other (``make bench``). Never thinner than ``min_points_per_s``
(calibrate-bias: 3 points per epoch window)."""


def sample_index(record, t):
    """Index of the sample interval that starts at time t (s), rounded."""
    return round((t - record.t0) / record.dt)


def align(record, window, lat, heading=None, arw=None, vrw=None):
    """Stationary alignment over ``window`` (s, s) of the record (000 §2: before Table 1).

    Noise densities not given (None) are estimated from the window
    (:func:`inins.core.noise.noise_density`).

    Returns
    -------
    alignment : inins.calibration.alignment.StationaryAlignment
    arw, vrw : ndarray, shape (3,)
        Angle (rad/sqrt(s)) and velocity (m/s/sqrt(s)) random walk used.
    """
    k0, k1 = sample_index(record, window[0]), sample_index(record, window[1])
    if k1 - k0 < 2 * noise.BLOCKS:
        raise InputError(
            f"the alignment window {window[0]:g}-{window[1]:g} s holds too few samples",
            source=record.source,
            key="alignment",
        )
    dtheta, dv = record.imu(k0, k1)
    arw = noise.noise_density(dtheta, record.dt) if arw is None else arw
    vrw = noise.noise_density(dv, record.dt) if vrw is None else vrw
    arw = np.broadcast_to(np.asarray(arw, float), (3,))
    vrw = np.broadcast_to(np.asarray(vrw, float), (3,))
    result = alignment.align_stationary(dtheta, dv, record.dt, lat, heading, arw.mean(), vrw.mean())
    return result, arw, vrw


def navigate(
    record, mat_nb0, t_start, t_end, output_rate, free=False, progress=None, min_points_per_s=1.0
):
    """Strapdown from ``t_start`` to ``t_end`` (s), outputs at ``output_rate`` (Hz).

    Parameters
    ----------
    record : inins.core.records.TableRecord
    mat_nb0 : ndarray, shape (3, 3)
        Attitude at ``t_start`` (from the alignment).
    output_rate : float
        Output rate (Hz); rounded to a whole number of samples, and lowered for long
        records so that the grid has at most :data:`MAX_TRACK_POINTS` points, but not
        below ``min_points_per_s`` (Hz: the epoch windows need their points).
    free : bool
        False: stationary navigation (known position and zero velocity: no
        transport rate, no Coriolis, the velocity error does not feed back: 000
        eqs. 9-10). True: free-inertial
        navigation (Schuler loop closed), to show the size of the difference.
    progress : callable, optional
        ``progress(done, total)`` in samples.

    Returns
    -------
    Track
    """
    k0, k1 = sample_index(record, t_start), sample_index(record, t_end)
    thinned = min(
        int(np.ceil((k1 - k0) / MAX_TRACK_POINTS)),
        max(1, int(1.0 / (min_points_per_s * record.dt))),
    )
    decimation = max(1, round(1.0 / (output_rate * record.dt)), thinned)
    state = strapdown.NavState.from_attitude(mat_nb0, np.zeros(3), record.lla)
    parts = []
    for k, dtheta, dv in record.imu_chunks(k0, k1):
        state, series = strapdown.integrate(
            state,
            dtheta,
            dv,
            record.dt,
            fixed_position=not free,
            zero_velocity=not free,
            fixed_height=free,
            decimation=decimation,
        )
        parts.append(series)
        if progress is not None:
            progress(k + dtheta.shape[0] - k0, k1 - k0)
    series = strapdown.NavSeries.concatenate(parts)
    time = np.concatenate(
        [[record.t0 + k0 * record.dt], series.time(record.dt, record.t0 + k0 * record.dt)]
    )
    mat_nb = np.concatenate([mat_nb0[None], series.mat_nb()])
    vel = np.concatenate([np.zeros((1, 3)), series.vel_n])
    axis, sign = vertical_axis(mat_nb0)
    return Track(time, mat_nb, vel, float(record.lla[0]), axis, sign)
