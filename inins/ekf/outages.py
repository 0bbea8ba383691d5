"""Simulated GNSS outage protocol: windows and the drift scores of published comparisons.

Windows are ``[a, a + length)`` every ``every`` s from ``first`` (or given
explicitly); the filter coasts through them. Per outage the score is the maximum
horizontal and 3D position error inside the window and the heading error at its
last epoch, each against the reference; over all outages the RMS of those
maxima (and of the end heading errors). Scoring forward and smoothed solutions of
one run with the same windows is how INS/GNSS post-processors are compared.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import error_model, rotation
from inins.exceptions import InputError


def periodic_windows(t_start, t_end, every, length, first=None, key="outages"):
    """Windows ``[a, a + length)`` every ``every`` s from ``first`` (default
    ``t_start + every``), those ending by ``t_end``; tuple of (float, float).

    Raises InputError when the length is not positive, exceeds the spacing or the run.
    """
    if not length > 0:
        raise InputError(f"outage length must be > 0 s, got {length}", key=f"{key}.length_s")
    if not every >= length:
        raise InputError(f"outages every {every} s cannot last {length} s", key=f"{key}.every_s")
    a = t_start + every if first is None else first
    if a + length > t_end:
        raise InputError(
            f"the first outage [{a:g}, {a + length:g}) s does not fit in the run "
            f"[{t_start:g}, {t_end:g}] s",
            key=f"{key}.length_s",
        )
    out = []
    while a + length <= t_end:
        out.append((float(a), float(a + length)))
        a += every
    return tuple(out)


def check_windows(windows, t_start, t_end, key="outages.windows"):
    """Validate explicit windows: increasing, non-overlapping, inside the run."""
    prev = -np.inf
    for i, (a, b) in enumerate(windows):
        if not b > a:
            raise InputError(f"outage end {b} s not after start {a} s", key=f"{key}.{i}")
        if a < prev:
            raise InputError("outage windows overlap or are out of order", key=f"{key}.{i}")
        if a < t_start or b > t_end:
            raise InputError(
                f"outage [{a:g}, {b:g}) s outside the run [{t_start:g}, {t_end:g}] s",
                key=f"{key}.{i}",
            )
        prev = b
    return tuple((float(a), float(b)) for a, b in windows)


@dataclass(frozen=True)
class OutageScore:
    """Per outage (arrays (k,)): ``window`` (k, 2) s, ``max_horizontal``, ``max_3d`` (m),
    ``heading_end`` (rad, estimated minus reference); RMS of each over the outages."""

    window: np.ndarray
    max_horizontal: np.ndarray
    max_3d: np.ndarray
    heading_end: np.ndarray

    @property
    def rms_horizontal(self):
        return float(np.sqrt(np.mean(self.max_horizontal**2)))

    @property
    def rms_3d(self):
        return float(np.sqrt(np.mean(self.max_3d**2)))

    @property
    def rms_heading(self):
        return float(np.sqrt(np.mean(self.heading_end**2)))


def score(time, lla, mat_nb, ref_lla, ref_mat_nb, windows):
    """Drift scores of a solution over outage windows.

    Parameters
    ----------
    time : ndarray (m,)
        Epochs (s) of the solution and the reference (same epochs).
    lla, ref_lla : ndarray (m, 3)
        Solution and reference positions (rad, rad, m).
    mat_nb, ref_mat_nb : ndarray (m, 3, 3) or None
        Attitudes (None: no heading score, NaN).
    windows : sequence of (a, b)

    Returns
    -------
    OutageScore
    """
    err = error_model.position_error_ned(lla, ref_lla)
    hor = np.hypot(err[:, 0], err[:, 1])
    d3 = np.linalg.norm(err, axis=1)
    out = ([], [], [], [])
    for a, b in windows:
        i = np.flatnonzero((time >= a) & (time < b))
        if i.size == 0:
            raise InputError(f"no reference epoch in the outage [{a:g}, {b:g}) s", key="outages")
        out[0].append((a, b))
        out[1].append(hor[i].max())
        out[2].append(d3[i].max())
        if mat_nb is None:
            out[3].append(np.nan)
        else:
            j = i[-1]
            h = rotation.euler_from_mat(mat_nb[j])[2] - rotation.euler_from_mat(ref_mat_nb[j])[2]
            out[3].append(float(rotation.wrap_angle(h)))
    return OutageScore(*(np.asarray(v, float) for v in out))
