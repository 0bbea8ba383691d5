"""The stationary check of an imported log: every hold levelled, gyrocompassed and
compared with the Earth's rate and normal gravity; the step schedule; the report.

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
Angle (velocity) random walk: the minimum over octave-spaced tau of
``sigma_A(tau) sqrt(tau)``, the overlapping Allan deviation of the quiet block
rates (tau >= one block, at least 8 clusters). Where the Allan slope is -1/2
that product is flat and equals the random-walk coefficient; quantization
(slope -1) raises it at short tau and bias instability at long tau, so the
minimum sits on the -1/2 part. Informational.
"""

from dataclasses import dataclass

import numpy as np

from inins.calibration import alignment
from inins.core import earth
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, UG, UG_RTHZ
from inins.io.report import format_table
from inins.results import Series
from inins.table.record import Step

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
        whole = rows[:nb * self.size].reshape(nb, self.size, rows.shape[1])
        rel = whole[:, :, 6:] - whole[:, :1, 6:]
        rel = np.mod(rel + np.pi, 2.0 * np.pi) - np.pi  # encoder wrap-around
        self._parts.append(np.hstack([
            whole[:, :, :6].sum(axis=1), whole[:, :, :3].std(axis=1),
            whole[:, 0, 6:] + rel.mean(axis=1), np.ptp(rel, axis=1)]))
        self._rest = rows[nb * self.size:]

    def finish(self):
        """Concatenate: sets ``dtheta``, ``dv``, ``spread`` (nb, 3), ``angle_mean``,
        ``angle_range`` (nb, g); the samples after the last whole block are dropped."""
        table = np.concatenate(self._parts) if self._parts else np.zeros((0, 9 + 2 *
                                                                          self.n_angles))
        g = self.n_angles
        self.dtheta, self.dv, self.spread = table[:, 0:3], table[:, 3:6], table[:, 6:9]
        self.angle_mean, self.angle_range = table[:, 9:9 + g], table[:, 9 + g:]
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
        same = first is not None and np.all(np.abs(_wrap(stats.angle_mean[j] - anchor))
                                            <= tolerance)
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
            steps.append(Step("rotate", f"M{len(steps) // 2 + 1}", axis, prev.end_time,
                                   t0 + k0 * dt, prev.stop_index, k0, prev.angles_end, angles))
        steps.append(Step("hold", f"H{len(steps) // 2 + 1}", -1, t0 + k0 * dt,
                               t0 + k1 * dt, k0, k1, angles, angles))
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
    opts : inins.io.scenarios.import_log.Check
    """
    rate = dtheta / block_dt
    dev = np.abs(rate - np.median(rate, axis=0))
    sigma = MAD_SIGMA * np.median(dev, axis=0)
    med_spread = np.median(spread, axis=0)
    disturbed = np.any(spread > opts.std_ratio * med_spread + FLOOR * dt, axis=1)
    disturbed |= np.any(dev > opts.rate_sigma * sigma + FLOOR, axis=1)
    guard, n = int(np.ceil(opts.guard_s / block_dt - 1e-9)), disturbed.size
    count = np.concatenate([[0], np.cumsum(disturbed)])  # disturbed blocks within the guard
    near = count[np.minimum(np.arange(n) + guard + 1, n)] - count[np.maximum(np.arange(n) -
                                                                            guard, 0)]
    return near == 0


def white_noise(rates, tau0):
    """Random-walk coefficient per axis: ``min over tau of sigma_A(tau) sqrt(tau)``.

    Parameters
    ----------
    rates : ndarray, shape (m, 3)
        Block mean rates (rad/s or m/s^2), one block every ``tau0`` s.

    Returns
    -------
    ndarray, shape (3,)
        rad/sqrt(s) (or m/s/sqrt(s)); NaN with fewer than 16 blocks.
    """
    m = rates.shape[0]
    best = np.full(3, np.inf)
    cum = np.vstack([np.zeros(3), np.cumsum(rates, axis=0)])
    k = 1
    while m >= 8 * k and m >= 16:
        means = (cum[k:] - cum[:-k]) / k
        avar = 0.5 * np.mean((means[k:] - means[:-k]) ** 2, axis=0)
        best = np.minimum(best, np.sqrt(avar * k * tau0))
        k *= 2
    return np.where(np.isfinite(best), best, np.nan)


@dataclass(frozen=True)
class HoldCheck:
    """The stationary check of one hold (SI; ``*_all`` without screening)."""

    step: int
    label: str
    used: float
    quiet: float
    screened: bool
    align: alignment.Alignment
    earth_rate: tuple
    align_all: alignment.Alignment
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
        quiet = (quiet_blocks(dth, stats.spread[sel], tau, stats.dt, opts) if opts.screen
                 else np.ones(j1 - j0, bool))
        screened = opts.screen and quiet.sum() >= need
        use = quiet if screened else np.ones(j1 - j0, bool)
        arw, vrw = white_noise(dth[use] / tau, tau), white_noise(dv[use] / tau, tau)
        align = alignment.align_stationary(dth[use], dv[use], tau, lla[0],
                                           arw=float(np.mean(arw)))  # NaN if unknown
        align_all = alignment.align_stationary(dth, dv, tau, lla[0])
        out.append(HoldCheck(
            i, step.label, (j1 - j0) * tau, float(quiet.sum() * tau), bool(screened), align,
            alignment.earth_rate_check(align.omega_b, align.f_b), align_all,
            alignment.earth_rate_check(align_all.omega_b, align_all.f_b),
            float(np.linalg.norm(align.f_b) - earth.gravity(lla[0], lla[2])), arw, vrw))
    return out


def hold_numbers(c, lla):
    """A check in lab units: dict of flat, unit-suffixed numbers."""
    w_h = earth.RATE * np.cos(lla[0])
    roll, pitch, heading = c.align.euler
    rate, lat, hor = c.earth_rate
    _, lat_all, hor_all = c.earth_rate_all
    out = {
        "roll_deg": roll / DEG, "pitch_deg": pitch / DEG,
        "heading_deg": np.mod(heading, 2 * np.pi) / DEG,
        "heading_sigma_deg": c.align.heading_sigma / DEG,
        "earth_rate_dph": rate / DPH, "earth_rate_err_pct": 100 * (rate / earth.RATE - 1),
        "earth_rate_horizontal_dph": hor / DPH,
        "earth_rate_horizontal_err_pct": 100 * (hor / w_h - 1),
        "implied_lat_deg": lat / DEG, "implied_lat_err_deg": (lat - lla[0]) / DEG,
        "gravity_err_ug": c.gravity_err / UG, "hold_s": c.used, "quiet_s": c.quiet,
        "heading_unscreened_deg": np.mod(c.align_all.euler[2], 2 * np.pi) / DEG,
        "earth_rate_horizontal_unscreened_dph": hor_all / DPH,
        "implied_lat_unscreened_deg": lat_all / DEG,
    }
    for i, axis in enumerate("xyz"):
        out[f"arw_{axis}_deg_rth"] = c.arw[i] / DEG_RTH
        out[f"vrw_{axis}_ug_rthz"] = c.vrw[i] / UG_RTHZ
    return {k: (None if not np.isfinite(v) else float(v)) for k, v in out.items()}


def first_results(checks, lla):
    """Flat results of the first checked hold (in time order), or {}."""
    first = next((c for c in checks if c is not None), None)
    return {} if first is None else hold_numbers(first, lla)


def step_datasets(steps, g):
    """The step schedule of the table-data layout."""
    def col(name, dtype=float):
        return np.array([getattr(s, name) for s in steps], dtype=dtype)

    def angles(name):
        return np.array([getattr(s, name) for s in steps], float).reshape(len(steps), g)

    return {
        "steps/kind": Series(col("kind", "S8"), "1", "", "hold, rotate or spin"),
        "steps/label": Series(np.array([s.label.encode() for s in steps], "S32"), "1", "",
                              "label given in the scenario or found from the encoder"),
        "steps/axis": Series(col("axis", np.int32), "1", "",
                             "moving gimbal index (outer = 0), -1 for a hold"),
        "steps/start_time": Series(col("start_time"), "s", "", "step start"),
        "steps/end_time": Series(col("end_time"), "s", "", "step end"),
        "steps/start_index": Series(col("start_index", np.int64), "1", "",
                                    "first IMU sample starting at or after the start"),
        "steps/stop_index": Series(col("stop_index", np.int64), "1", "",
                                   "one past the last IMU sample ending by the end"),
        "steps/angles_start": Series(angles("angles_start"), "rad", "t",
                                     "gimbal angles at the step start"),
        "steps/angles_end": Series(angles("angles_end"), "rad", "t",
                                   "gimbal angles at the step end"),
    }


def block_datasets(stats, t0, dt):
    """Block means of the log (what the check works on), under ``check/``."""
    tau = stats.duration
    n = stats.dtheta.shape[0]
    return {
        "check/time": Series(t0 + tau * np.arange(1, n + 1), "s", "", "end of each block"),
        "check/omega_b": Series(stats.dtheta / tau, "rad/s", "b", "block mean angular rate"),
        "check/f_b": Series(stats.dv / tau, "m/s^2", "b", "block mean specific force"),
        "check/gyro_spread": Series(stats.spread / dt, "rad/s", "b",
                                    "standard deviation of the gyro samples in each block"),
    }


def log_y_azimuth(mat_nb, mat_bl):
    """Azimuth (rad, clockwise from north, in [0, 2 pi)) of the log's +y axis."""
    v_n = mat_nb @ mat_bl @ np.array([0.0, 1.0, 0.0])
    return float(np.mod(np.arctan2(v_n[1], v_n[0]), 2.0 * np.pi))


def _sensor_line(name, sensor, pw, unit, scale, scale_name):
    if sensor.counts:
        return (f"{name}: pulse counts, stored as int32; pulse weight per body axis x y z "
                f"{np.array2string(pw / scale, precision=6)} {scale_name}")
    how = "rates, stored as increments rate x dt" if sensor.quantity == "rate" else \
        "increments"
    return f"{name}: {how} in {unit} (float64)"


def _input_lines(cfg, run):
    n, dt, t0, lla = run["n"], run["dt"], run["t0"], run["lla"]
    lines = [f"log: {cfg.path.name} ({cfg.format}), {n} samples at {1 / dt:.6g} Hz "
             f"({n * dt:.2f} s) from t0 = {t0:.6g} s; imported at {run['rate_s']:.3g} rows/s"]
    if run["time_span"] is not None:
        first, last = run["time_span"]
        mean = (last - first) / (n - 1)
        lines.append(f"time column: {first:.6f} s to {last:.6f} s, mean step {mean:.9g} s "
                     f"({(mean / dt - 1) * 1e6:+.1f} ppm from the nominal {dt:.6g} s)")
    h = run["header"]
    if h is not None:
        att = ", ".join(f"{v:g}" for v in h["attitude_deg"])
        lines += [
            f"PSINS header: lat {h['lat_deg']:.8f} deg, lon {h['lon_deg']:.8f} deg, height "
            f"{h['height_m']:g} m, t0 {h['t0_s']:g} s, interval {h['dt_s'] * 1e3:g} ms, "
            f"g {h['g_mps2']:g} m/s^2 (the g of its ug); pulse weights gyro "
            f"{h['gyro_pulse_arcsec']} arcsec, accel {h['accel_pulse_ug_s']} ug*s (log axes)",
            f"  attitude (pitch, roll, yaw; PSINS yaw is counter-clockwise from north, of the "
            f"log y axis, 'maybe inaccurate'): {att} deg",
            "  scenario values used instead of the header: "
            + (", ".join(run["overrides"]) or "none"),
        ]
    sign = {1.0: "+", -1.0: "-"}
    mapping = ", ".join(f"body {b} = {sign[cfg.mat_bl[i][j]]}log {'xyz'[j]}"
                        for i, b in enumerate("xyz") for j in range(3) if cfg.mat_bl[i][j])
    lines += [
        _sensor_line("gyro", cfg.gyro, run["gyro_pw"], "rad", ARCSEC, "arcsec"),
        _sensor_line("accel", cfg.accel, run["accel_pw"], "m/s", 1e-6 * run["g"],
                     f"ug*s (ug = 1e-6 x {run['g']:.7g} m/s^2)"),
        f"axes: {mapping}",
        f"site: lat {lla[0] / DEG:.8f} deg, lon {lla[1] / DEG:.8f} deg, height {lla[2]:g} m; "
        f"normal gravity {earth.gravity(lla[0], lla[2]):.6f} m/s^2, Earth rate "
        f"{earth.RATE / DPH:.4f} deg/h, horizontal {earth.RATE * np.cos(lla[0]) / DPH:.4f} "
        "deg/h",
    ]
    return lines


def _step_rows(cfg, steps):
    rows = []
    for i, s in enumerate(steps):
        axis = cfg.gimbals[s.axis] if s.axis >= 0 and cfg.gimbals else ""
        rows.append([i, s.kind, s.label, axis, s.start_time, s.end_time,
                     s.stop_index - s.start_index, *np.degrees(s.angles_end)])
    heads = ["#", "kind", "label", "axis", "start", "end", "samples",
             *[f"{g} end" for g in cfg.gimbals]]
    units = ["", "", "", "", "s", "s", "", *["deg"] * len(cfg.gimbals)]
    return format_table(rows, heads, units, fmt=".8g")


def report(cfg, run, steps, checks):
    """Report body: the input as read, the steps, the stationary check of each hold."""
    lla = run["lla"]
    lines = [*_input_lines(cfg, run), "", "steps", _step_rows(cfg, steps)]
    done = [c for c in checks if c is not None]
    if not done:
        return "\n".join([*lines, "", "no hold long enough to check"])
    rows, raw, noise = [], [], []
    for c in done:
        v = hold_numbers(c, lla)
        rows.append([c.label, v["hold_s"], v["quiet_s"], v["roll_deg"], v["pitch_deg"],
                     v["heading_deg"], v["heading_sigma_deg"], v["gravity_err_ug"],
                     v["earth_rate_dph"], v["earth_rate_horizontal_dph"],
                     v["earth_rate_horizontal_err_pct"], v["implied_lat_deg"],
                     v["implied_lat_err_deg"]])
        raw.append([c.label, v["heading_unscreened_deg"],
                    v["earth_rate_horizontal_unscreened_dph"],
                    100 * (c.earth_rate_all[2] / (earth.RATE * np.cos(lla[0])) - 1),
                    v["implied_lat_unscreened_deg"]])
        noise.append([c.label, *(v[f"arw_{a}_deg_rth"] for a in "xyz"),
                      *(v[f"vrw_{a}_ug_rthz"] for a in "xyz")])
    opts = cfg.check
    lines += [
        "", "stationary check of each hold (quiet blocks; first hold -> summary.json)",
        format_table(rows, ["hold", "used", "quiet", "roll", "pitch", "heading", "1 sigma",
                            "|f|-gamma", "|omega|", "horizontal", "vs W cos L", "latitude",
                            "vs site"],
                     ["", "s", "s", "deg", "deg", "deg", "deg", "ug", "deg/h", "deg/h", "%",
                      "deg", "deg"], fmt=".5g"),
        "", "the same without screening",
        format_table(raw, ["hold", "heading", "horizontal", "vs W cos L", "latitude"],
                     ["", "deg", "deg/h", "%", "deg"], fmt=".5g"),
        "", "white noise (min over tau of Allan deviation x sqrt(tau), quiet blocks)",
        format_table(noise, ["hold", "ARW x", "ARW y", "ARW z", "VRW x", "VRW y", "VRW z"],
                     ["", *["deg/sqrt(h)"] * 3, *["ug/sqrt(Hz)"] * 3], fmt=".4g"),
        "", (f"screening: {'on' if opts.screen else 'off'}; blocks of {opts.block_s:g} s; a "
             f"block is disturbed when a gyro's sample spread exceeds {opts.std_ratio:g} x the "
             f"hold's median or its mean rate is more than {opts.rate_sigma:g} robust sigma "
             f"from the hold's median; widened by {opts.guard_s:g} s"),
    ]
    lines += [f"  {c.label}: too few quiet blocks, all blocks used" for c in done
              if opts.screen and not c.screened]
    h = run["header"]
    if h is not None:
        azimuth = log_y_azimuth(done[0].align.mat_nb, cfg.mat_bl) / DEG
        lines.append(f"log y axis azimuth from the gyrocompass ({done[0].label}): "
                     f"{azimuth:.3f} deg; header yaw {h['attitude_deg'][2]:g} deg "
                     f"(counter-clockwise) = azimuth {np.mod(-h['attitude_deg'][2], 360):.3f} "
                     "deg")
    return "\n".join(lines)
