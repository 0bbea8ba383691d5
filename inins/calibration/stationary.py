"""The stationary check of a log: every hold levelled, gyrocompassed and compared with
the Earth's rate and normal gravity; holds found from the table angles.

Blocks
------
While the log streams in, the import keeps per block of ``c = round(block_s / dt)``
samples the sums of the gyro and accelerometer increments, the spread (standard
deviation) of the gyro samples, and the mean and spread of the table angles
(:class:`BlockStats`). A hold is checked on the whole blocks inside it, with
:func:`inins.calibration.alignment.align_stationary` and
:func:`~inins.calibration.alignment.earth_rate_check` applied to the block sums.

Screening (data-driven, per hold)
---------------------------------
A block is *disturbed* when, for any gyro, its sample spread exceeds
``std_ratio`` (3) times the hold's median spread (vibration, knocks), or its mean
rate lies more than ``rate_sigma`` (6) robust sigmas (1.4826 x the median
absolute deviation of the hold's block rates) from the hold's median rate
(slow motion: tilting, a turn that does not come back). Disturbed blocks are
widened by ``guard_s`` (5 s) on both sides for the settling. Both thresholds
carry a floor of 0.001 Earth rate so noiseless data are not screened. The
check uses the quiet blocks if they add up to ``min_hold_s``, else all blocks
(with a note); the unscreened values are reported beside the screened ones.

White noise
-----------
Angle (velocity) random walk of the quiet block rates by
:func:`inins.core.noise.random_walk` (minimum of the Allan deviation times
sqrt(tau)). Informational.
"""

from dataclasses import dataclass

import numpy as np

from inins.calibration import alignment
from inins.core import earth, noise
from inins.core.records import Step, StepKind

MAD_SIGMA = 1.4826
"""Robust sigma per median absolute deviation (normal distribution)."""
FLOOR = 1e-3 * earth.RATE
"""Smallest rate threshold of the screening (rad/s)."""


class BlockStats:
    """Block sums of a log, gathered chunk by chunk (see the module docstring)."""

    def __init__(self, dt, size, n_angles):
        self.dt, self.size, self.n_angles = dt, size, n_angles
        self._rest = np.zeros((0, 6 + n_angles))
        self._parts = []

    @classmethod
    def start(cls, dt, block_s, n_angles):
        """Blocks of ``round(block_s / dt)`` samples (at least 1)."""
        return cls(dt, max(1, round(block_s / dt)), n_angles)

    def add(self, dtheta, dv, angles):
        """Add samples: increments (k, 3) rad and m/s, table angles (k, g) rad."""
        rows = np.concatenate([self._rest, np.hstack([dtheta, dv, angles])])
        nb = rows.shape[0] // self.size
        whole = rows[: nb * self.size].reshape(nb, self.size, rows.shape[1])
        rel = whole[:, :, 6:] - whole[:, :1, 6:]
        rel = np.mod(rel + np.pi, 2.0 * np.pi) - np.pi  # encoder wrap-around
        self._parts.append(
            np.hstack(
                [
                    whole[:, :, :6].sum(axis=1),
                    whole[:, :, :3].std(axis=1),
                    whole[:, 0, 6:] + rel.mean(axis=1),
                    np.ptp(rel, axis=1),
                ]
            )
        )
        self._rest = rows[nb * self.size :]

    def finish(self):
        """Concatenate: sets ``dtheta``, ``dv``, ``spread`` (nb, 3), ``angle_mean``,
        ``angle_range`` (nb, g); the samples after the last whole block are dropped."""
        table = np.concatenate(self._parts) if self._parts else np.zeros((0, 9 + 2 * self.n_angles))
        g = self.n_angles
        self.dtheta, self.dv, self.spread = table[:, 0:3], table[:, 3:6], table[:, 6:9]
        self.angle_mean, self.angle_range = table[:, 9 : 9 + g], table[:, 9 + g :]
        return self

    @property
    def duration(self):
        """Block length (s)."""
        return self.size * self.dt


def encoder_steps(stats, t0, dt, n, tolerance, margin):
    """Holds from the table angles, and a rotate step between each two.

    A block is still when every angle's spread in it is within ``tolerance``
    (rad); a hold is a run of still blocks whose means stay within
    ``tolerance`` of the run's first, shortened by ``margin`` (s) at both ends.
    """
    still = np.all(stats.angle_range <= tolerance, axis=1)
    runs, first, anchor = [], None, None
    for j in range(still.size):
        same = first is not None and np.all(
            np.abs(_wrap(stats.angle_mean[j] - anchor)) <= tolerance
        )
        if still[j] and same:
            continue
        if first is not None:
            runs.append((first, j))
            first = None
        if still[j]:
            first, anchor = j, stats.angle_mean[j]
    if first is not None:
        runs.append((first, still.size))
    cut, steps = round(margin / dt), []
    for a, b in runs:
        k0, k1 = a * stats.size + cut, min(n, b * stats.size - cut)
        if k1 - k0 < stats.size:
            continue
        angles = stats.angle_mean[a] + _wrap(stats.angle_mean[a:b] - stats.angle_mean[a]).mean(0)
        if steps:
            prev = steps[-1]
            axis = int(np.argmax(np.abs(_wrap(angles - prev.angles_end))))
            steps.append(
                Step(
                    StepKind.ROTATE,
                    f"M{len(steps) // 2 + 1}",
                    axis,
                    prev.end_time,
                    t0 + k0 * dt,
                    prev.stop_index,
                    k0,
                    prev.angles_end,
                    angles,
                )
            )
        steps.append(
            Step(
                StepKind.HOLD,
                f"H{len(steps) // 2 + 1}",
                -1,
                t0 + k0 * dt,
                t0 + k1 * dt,
                k0,
                k1,
                angles,
                angles,
            )
        )
    return steps


def _wrap(angle):
    return np.mod(angle + np.pi, 2.0 * np.pi) - np.pi


def quiet_blocks(dtheta, spread, block_dt, dt, opts):
    """Screening mask of a hold's blocks (True = quiet); see the module docstring.

    Parameters
    ----------
    dtheta, spread : ndarray, shape (m, 3)
        Block sums of the gyro increments and spreads of the gyro samples (rad).
    block_dt, dt : float
        Block length and sample interval (s).
    opts : inins.io.logimport.ScreeningOptions (any object with its attributes)
    """
    rate = dtheta / block_dt
    dev = np.abs(rate - np.median(rate, axis=0))
    sigma = MAD_SIGMA * np.median(dev, axis=0)
    med_spread = np.median(spread, axis=0)
    disturbed = np.any(spread > opts.std_ratio * med_spread + FLOOR * dt, axis=1)
    disturbed |= np.any(dev > opts.rate_sigma * sigma + FLOOR, axis=1)
    guard, n = int(np.ceil(opts.guard_s / block_dt - 1e-9)), disturbed.size
    count = np.concatenate([[0], np.cumsum(disturbed)])  # disturbed blocks within the guard
    near = (
        count[np.minimum(np.arange(n) + guard + 1, n)] - count[np.maximum(np.arange(n) - guard, 0)]
    )
    return near == 0


@dataclass(frozen=True)
class HoldCheck:
    """The stationary check of one hold (SI; ``*_all`` without screening)."""

    step: int
    label: str
    used: float
    quiet: float
    screened: bool
    align: alignment.StationaryAlignment
    earth_rate: tuple
    align_all: alignment.StationaryAlignment
    earth_rate_all: tuple
    gravity_err: float
    arw: np.ndarray
    vrw: np.ndarray


def check_holds(stats, steps, lla, opts):
    """The stationary check of every hold of at least ``opts.min_hold_s`` (None for others)."""
    out = []
    tau = stats.duration
    need = int(np.ceil(opts.min_hold_s / tau - 1e-9))
    for i, step in enumerate(steps):
        j0 = -(-step.start_index // stats.size)
        j1 = min(step.stop_index // stats.size, stats.dtheta.shape[0])
        if step.kind != "hold" or j1 - j0 < max(need, 1):
            out.append(None)
            continue
        sel = slice(j0, j1)
        dth, dv = stats.dtheta[sel], stats.dv[sel]
        quiet = (
            quiet_blocks(dth, stats.spread[sel], tau, stats.dt, opts)
            if opts.screen
            else np.ones(j1 - j0, bool)
        )
        screened = opts.screen and quiet.sum() >= need
        use = quiet if screened else np.ones(j1 - j0, bool)
        arw, vrw = noise.random_walk(dth[use] / tau, tau), noise.random_walk(dv[use] / tau, tau)
        align = alignment.align_stationary(
            dth[use], dv[use], tau, lla[0], arw=float(np.mean(arw))
        )  # NaN if unknown
        align_all = alignment.align_stationary(dth, dv, tau, lla[0])
        out.append(
            HoldCheck(
                i,
                step.label,
                (j1 - j0) * tau,
                float(quiet.sum() * tau),
                bool(screened),
                align,
                alignment.earth_rate_check(align.omega_b, align.f_b),
                align_all,
                alignment.earth_rate_check(align_all.omega_b, align_all.f_b),
                float(np.linalg.norm(align.f_b) - earth.gravity(lla[0], lla[2])),
                arw,
                vrw,
            )
        )
    return out


def log_y_azimuth(mat_nb, mat_bl):
    """Azimuth (rad, clockwise from north, in [0, 2 pi)) of the log's +y axis."""
    v_n = mat_nb @ mat_bl @ np.array([0.0, 1.0, 0.0])
    return float(np.mod(np.arctan2(v_n[1], v_n[0]), 2.0 * np.pi))
