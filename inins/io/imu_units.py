"""Units and axes of an IMU log of rates checked against its GNSS solution, before any
filter runs (spec §10a).

:func:`check_against_gnss` is called by every command that joins an IMU log of rates
to a solution file (``run-ekf post:``, ``import-flight format: solution``). It refuses,
as bad input naming the check, the data it was made on and the likely mistake:

1. **Gravity at rest.** In the quietest second of the log (the smallest scatter of the
   specific force), ``|f|`` must be within :data:`GRAVITY_BAND` of the local normal
   gravity at the first solution epoch (WGS 84, :func:`inins.core.earth.gravity`). An
   accelerometer in g declared m/s² reads 0.102 of it; the message names the unit
   mistake whose factor brings the reading into the band.
2. **Gravity's direction.** There the specific force must point up, along body -z
   (within :data:`TILT_DEG` of the vehicle's vertical through ``mounting_deg``): body
   z points down. Otherwise the axis map is wrong; the message gives the IMU axis that
   carries gravity and an axis map that puts it on z.
3. **Angular rate at rest.** Where the GNSS stands still for :data:`STAND_S` and the quietest
   second is still (scatter below :data:`STILL_SCATTER` of ``|f|``), ``|ω|`` there
   must be below the Earth rate plus :data:`BIAS_SIGMAS` times the gyro bias 1-sigma
   the scenario states (its grade); a gyro in deg/s declared rad/s reads 57 times its
   bias.
4. **Turns.** The GNSS course rate (where faster than ``min_speed``) is correlated with
   each body gyro axis, binned at :data:`BIN_S`, over lags of ±``search_s`` around
   ``offset_s``. Where some axis correlates (|r| >= :data:`MIN_CORR`): the turn axis
   must be body +z (down), and the gyro's turn rate must match the course rate within
   :data:`SCALE_BAND` (a least-squares factor: 57.3 is deg/s read as rad/s). Where
   ``forward_needed`` (NHC, odometer), the body axis whose specific force follows the
   GNSS along-track acceleration must be +x.

A drive without turns or a stop leaves the checks that need them undone (nothing is
refused on a guess).
"""

import math

import numpy as np

from inins.core import earth, rotation
from inins.exceptions import InputError

GRAVITY_BAND = (0.8, 1.25)
"""Accepted ``|f| / g`` in the quietest second (a car, a drone, an aircraft in level flight)."""
TILT_DEG = 30.0
"""Largest angle between the measured up and body -z at rest (deg)."""
STAND_S = 10.0
"""The GNSS must stand still this long (s, below 0.2 m/s) for the rate at rest to be checked."""
STILL_SCATTER = 0.02
"""RMS scatter of the specific force, as a fraction of ``|f|``, below which a second is
still (a parked car with its engine running: 0.4 %)."""
BIAS_SIGMAS = 5.0
"""Gyro bias 1-sigmas (the scenario's grade) allowed at rest above the Earth rate."""
BIN_S = 0.25
"""Bin of the turn-rate comparison (s)."""
MIN_CORR = 0.6
"""Correlation of the course rate with a gyro axis that makes the turn checks conclusive."""
SCALE_BAND = (0.5, 2.0)
"""Accepted gyro turn rate / GNSS course rate."""
_OMEGA_IE = 7.292115e-5
_FACTORS = {
    "accel": (
        (1.0 / 9.80665, "the accelerometer in g declared m/s^2 (accel_unit: g)"),
        (9.80665, "the accelerometer in m/s^2 declared g (accel_unit: mps2)"),
        (1000.0, "the accelerometer in mg declared g (a scale of 1e-3 missing)"),
        (1e-3, "the accelerometer in g declared mg"),
        (1000.0 / 9.80665, "the accelerometer in mg declared m/s^2"),
    ),
    "gyro": (
        (180.0 / math.pi, "the gyro in deg/s declared rad/s (gyro_unit: dps)"),
        (math.pi / 180.0, "the gyro in rad/s declared deg/s (gyro_unit: rads)"),
        (1e3 * math.pi / 180.0, "the gyro in mrad/s declared deg/s"),
        (3600.0, "the gyro in deg/h declared deg/s"),
        (1.0 / 3600.0, "the gyro in deg/s declared deg/h"),
    ),
}
_NAMES = ("x", "y", "z")


def _likely(kind, ratio, band):
    """The unit mistake whose factor brings ``ratio`` into ``band``, or None."""
    for factor, mistake in _FACTORS[kind]:
        if band[0] <= ratio / factor <= band[1]:
            return mistake
    return None


def quietest_second(time, accel):
    """Index range ``(i, j)`` of the one-second window of the least specific-force scatter
    (RMS deviation from its mean) and that scatter (m/s^2)."""
    dt = float(np.median(np.diff(time)))
    n = max(round(1.0 / dt), 4)
    k = accel.shape[0] // n
    if k == 0:
        return 0, accel.shape[0], float(np.sqrt(np.sum(np.var(accel, axis=0))))
    blocks = accel[: k * n].reshape(k, n, 3)
    scatter = np.sqrt(np.sum(np.var(blocks, axis=1), axis=1))
    best = int(np.argmin(scatter))
    return best * n, (best + 1) * n, float(scatter[best])


def _gnss_motion(sol):
    """GNSS time from the first epoch (s), NED velocity from the positions (m/s)."""
    lla = sol.lla
    tg = sol.time - sol.time[0]
    ecef = earth.ecef_from_llh(lla[:, 0], lla[:, 1], lla[:, 2])
    m_en = earth.mat_en(lla[0, 0], lla[0, 1])
    return tg, np.gradient((ecef - ecef[0]) @ m_en, tg, axis=0)


def _axis_text(down_b, forward_b, axes):
    """The axis map (IMU axis names) putting ``down_b`` on z and ``forward_b`` on x, both
    given as (index, sign) of the current body axes."""
    declared = [(a.lstrip("-"), -1 if a.startswith("-") else 1) for a in axes]

    def imu(axis):
        k, s = axis
        name, sign = declared[k]
        return name, s * sign

    z, x = imu(down_b), imu(forward_b)
    vec = {}
    for name, (axis, sign) in (("z", z), ("x", x)):
        v = np.zeros(3)
        v[_NAMES.index(axis)] = sign
        vec[name] = v
    y = np.cross(vec["z"], vec["x"])
    k = int(np.argmax(np.abs(y)))
    parts = [x, (_NAMES[k], int(np.sign(y[k]))), z]
    return "[" + ", ".join(("-" if s < 0 else "") + n for n, s in parts) + "]"


def _nearest_axis(v):
    k = int(np.argmax(np.abs(v)))
    return k, int(np.sign(v[k]))


def _body(axis):
    k, s = axis
    return ("-" if s < 0 else "+") + _NAMES[k]


def check_gravity(imu, sol, axes, mounting_deg=(0.0, 0.0, 0.0)):
    """Checks 1 and 2 of the module docstring; returns ``(i, j, scatter, down_b)`` of the
    quietest second (``down_b`` the measured down in body axes, unit)."""
    i, j, scatter = quietest_second(imu.time, imu.accel)
    f = imu.accel[i:j].mean(axis=0)
    g = float(earth.gravity(sol.lla[0, 0], sol.lla[0, 2]))
    norm = float(np.linalg.norm(f))
    rows = imu.row_names()
    where = f"the quietest second of the log, from IMU t = {imu.time[i] - imu.time[0]:.1f} s"
    ratio = norm / g
    if not GRAVITY_BAND[0] <= ratio <= GRAVITY_BAND[1]:
        mistake = _likely("accel", ratio, GRAVITY_BAND)
        if mistake is None and ratio < 0.1:
            mistake = "gravity removed (a linear-acceleration output; inins needs specific force)"
        raise rows.error(
            i,
            f"specific force at rest reads {norm:.4g} m/s^2 ({where}) against local gravity "
            f"{g:.4f} m/s^2: {'is ' + mistake if mistake else 'a scale or unit wrong'}?",
            "accel",
        )
    down_b = -f / norm
    mat_vb = rotation.mat_from_euler(*np.radians(np.asarray(mounting_deg, float)))
    expect = mat_vb.T @ np.array([0.0, 0.0, 1.0])
    angle = math.degrees(math.acos(min(1.0, float(down_b @ expect))))
    if angle > TILT_DEG:
        axis = _nearest_axis(down_b)
        forward = _forward_from_motion(imu, sol, down_b, axis, search=(-10.0, 10.0))
        told = "" if forward else " (its forward axis a guess: the drive did not tell it)"
        forward = forward or ((0, 1) if axis[0] != 0 else (1, 1))
        raise rows.error(
            i,
            f"gravity at rest reads down along body {_body(axis)} (specific force "
            f"{np.array2string(f, precision=3)} m/s^2 in body axes, {where}), {angle:.0f} deg "
            f"from body +z: body z must point down. The axis map axes {list(axes)} is wrong; "
            f"axes: {_axis_text(axis, forward, axes)} puts z down and x forward{told}",
            "accel",
        )
    return i, j, scatter, down_b


def check_rest_rate(imu, sol, quiet, gyro_bias_sigma_dps, min_speed):
    """Check 3 of the module docstring (skipped unless both the GNSS and the quietest
    second say the vehicle stands)."""
    i, j, scatter, _ = quiet
    norm = float(np.linalg.norm(imu.accel[i:j].mean(axis=0)))
    tg, vel = _gnss_motion(sol)
    slow = np.linalg.norm(vel, axis=1) < 0.2 * min(min_speed, 1.0)
    edges = np.diff(np.concatenate([[0], slow.astype(np.int8), [0]]))
    first, last = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    stands = bool(np.any(tg[last] - tg[first] >= STAND_S))
    if gyro_bias_sigma_dps is None or scatter > STILL_SCATTER * norm or not stands:
        return
    w = imu.gyro[i:j].mean(axis=0)
    rate = float(np.linalg.norm(w))
    limit = _OMEGA_IE + BIAS_SIGMAS * math.radians(gyro_bias_sigma_dps)
    if rate > limit:
        mistake = _likely("gyro", rate / limit, (0.0, 1.0))
        raise imu.row_names().error(
            i,
            f"angular rate at rest reads {math.degrees(rate):.4g} deg/s (the quietest second, "
            f"from IMU t = {imu.time[i] - imu.time[0]:.1f} s), beyond the Earth rate "
            f"{math.degrees(_OMEGA_IE):.4f} deg/s plus {BIAS_SIGMAS:g} x the gyro bias "
            f"1-sigma {gyro_bias_sigma_dps:g} deg/s (initial_sigma.gyro_bias_dps): "
            + (f"is {mistake}?" if mistake else "a gyro unit wrong, or a bias beyond its sigma?"),
            "gyro",
        )


def _bins(time, values, step):
    """Means of ``values`` (n, k) in bins of ``step`` from ``time[0]``; NaN where empty."""
    k = np.floor((time - time[0]) / step).astype(np.int64)
    count = np.bincount(k)
    out = np.stack([np.bincount(k, values[:, c], count.size) for c in range(values.shape[1])], 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return out / count[:, None]


def _corr(a, b):
    """Correlation coefficient of two series (0 when either is constant)."""
    a, b = a - a.mean(), b - b.mean()
    den = math.sqrt(float(np.dot(a, a)) * float(np.dot(b, b)))
    return float(np.dot(a, b)) / den if den > 0 else 0.0


def _best_lags(x, y, lags):
    """For each column of ``x`` (n, k): the lag (bins) of the largest |correlation| with
    ``y`` (m,) pairing ``x[t]`` with ``y[t + lag]``, and that correlation."""
    best = np.zeros((x.shape[1], 2))
    for c in range(x.shape[1]):
        top = (0, 0.0)
        for lag in lags:
            a, b = _pair(x[:, c : c + 1], y, lag)
            a = a[:, 0]
            ok = np.isfinite(a) & np.isfinite(b)
            if ok.sum() < 40:
                continue
            r = _corr(a[ok], b[ok])
            if abs(r) > abs(top[1]):
                top = (lag, float(r))
        best[c] = top
    return best


def _course_rate(sol, min_speed):
    """``(tg, speed, rate)`` of the GNSS epochs (s from the first, m/s, rad/s; rate 0 where
    slower than ``min_speed``), or None without turns (course rate never above 5 deg/s)."""
    tg, vel = _gnss_motion(sol)
    speed = np.hypot(vel[:, 0], vel[:, 1])
    course = np.unwrap(np.arctan2(vel[:, 1], vel[:, 0]))
    rate = np.where(speed > min_speed, np.gradient(course, tg), 0.0)
    if np.max(np.abs(rate)) < math.radians(5.0) or np.count_nonzero(speed > min_speed) < 20:
        return None
    return tg, speed, rate


def _lag_range(offset_s, search_s):
    lo, hi = (offset_s - search_s) / BIN_S, (offset_s + search_s) / BIN_S
    return range(math.floor(lo), math.ceil(hi) + 1)


def _pair(x, y, lag):
    """The overlapping parts of ``x`` (n, k) and ``y`` (m,) with ``x[t]`` at ``y[t + lag]``."""
    a0, b0 = max(0, -lag), max(0, lag)
    n = max(0, min(x.shape[0] - a0, y.size - b0))
    return x[a0 : a0 + n], y[b0 : b0 + n]


def _forward_from_motion(imu, sol, down_b, down_axis, search, min_speed=3.0):
    """The body axis (index, sign) along which the specific force follows the GNSS
    along-track acceleration, among those across ``down_axis``; the lag from the turn
    rate about the measured ``down_b``. None where the drive does not tell."""
    turns = _course_rate(sol, min_speed)
    if turns is None:
        return None
    tg, speed, rate = turns
    grid = np.arange(0.0, tg[-1], BIN_S)
    yaw = _bins(imu.time, (imu.gyro @ down_b)[:, None], BIN_S)
    lag, r = _best_lags(yaw, np.interp(grid, tg, rate), _lag_range(0.0, search[1]))[0]
    if abs(r) < MIN_CORR:
        return None
    along = np.where(speed > min_speed, np.gradient(speed, tg), 0.0)
    best = _best_lags(_bins(imu.time, imu.accel, BIN_S), np.interp(grid, tg, along), [int(lag)])
    best[down_axis[0]] = 0.0
    k = int(np.argmax(np.abs(best[:, 1])))
    return (k, int(np.sign(best[k, 1]))) if abs(best[k, 1]) >= MIN_CORR else None


def check_turns(
    imu, sol, axes, *, search_s=10.0, offset_s=0.0, min_speed=3.0, forward_needed=False
):
    """Check 4 of the module docstring."""
    turns = _course_rate(sol, min_speed)
    if turns is None:
        return
    tg, speed, rate = turns
    y = np.interp(np.arange(0.0, tg[-1], BIN_S), tg, rate)
    x = _bins(imu.time, imu.gyro, BIN_S)
    best = _best_lags(x, y, _lag_range(offset_s, search_s))
    k = int(np.argmax(np.abs(best[:, 1])))
    if abs(best[k, 1]) < MIN_CORR:
        return
    lag, r = int(best[k, 0]), best[k, 1]
    rows = imu.row_names()
    if k != 2 or r < 0:
        raise InputError(
            f"the GNSS course rate (the turns of the track) follows gyro "
            f"{_body((k, int(np.sign(r))))} (r = {abs(r):.2f} at a lag of {lag * BIN_S:+.2f} s), "
            f"not gyro +z (r = {best[2, 1]:+.2f}), while the accelerometers put down on +z: "
            "the gyro columns are in another order or sign than the accelerometer columns "
            "(gyro_columns, accel_columns)",
            source=rows.source,
            key=rows.keys.get("gyro", "gyro_columns"),
        )
    a, b = _pair(x[:, 2:3], y, lag)
    ok = np.isfinite(a[:, 0]) & (b != 0.0)
    if not ok.any():
        return
    scale = float(np.dot(a[ok, 0], b[ok]) / np.dot(b[ok], b[ok]))
    if not SCALE_BAND[0] <= scale <= SCALE_BAND[1]:
        mistake = _likely("gyro", scale, SCALE_BAND)
        raise InputError(
            f"the gyro's turn rate about z is {scale:.3g} times the GNSS course rate (least "
            f"squares over the turns, lag {lag * BIN_S:+.2f} s): "
            + (f"is {mistake}?" if mistake else "a gyro scale or unit wrong?"),
            source=rows.source,
            key=rows.keys.get("gyro", "gyro_unit"),
        )
    if forward_needed:
        along = np.where(speed > min_speed, np.gradient(speed, tg), 0.0)
        along = np.interp(np.arange(0.0, tg[-1], BIN_S), tg, along)
        best = _best_lags(_bins(imu.time, imu.accel, BIN_S), along, [lag])
        best[2] = 0.0
        k = int(np.argmax(np.abs(best[:, 1])))
        r = best[k, 1]
        if abs(r) >= MIN_CORR and (k != 0 or r < 0):
            axis = (k, int(np.sign(r)))
            raise InputError(
                f"the GNSS along-track acceleration follows accel {_body(axis)} (r = "
                f"{abs(r):.2f}), not accel +x (r = {best[0, 1]:+.2f}): body x is not forward, "
                f"as NHC and the odometer need; axes: {_axis_text((2, 1), axis, axes)} puts "
                "it forward",
                source=rows.source,
                key=rows.keys.get("accel", "axes"),
            )


def check_against_gnss(
    imu, sol, axes, *, mounting_deg=(0.0, 0.0, 0.0), gyro_bias_sigma_dps=None, search_s=10.0,
    offset_s=0.0, min_speed=3.0, forward_needed=False,
):  # fmt: skip
    """Every check of the module docstring on an :class:`~inins.io.imu_files.ImuRates`
    (body axes, SI) and a :class:`~inins.io.solution_files.SolutionFile`.

    Parameters
    ----------
    axes : sequence of str
        The axis map the log was read with (named in messages and suggestions).
    mounting_deg : (3,)
        Roll, pitch, yaw of the IMU body in the vehicle axes (deg).
    gyro_bias_sigma_dps : float or None
        The scenario's gyro bias 1-sigma (deg/s); None skips the rate at rest.
    search_s, offset_s : float
        Lags searched (s) around ``offset_s`` (GNSS time from its first epoch minus IMU
        time from its first sample).
    min_speed : float
        GNSS speed above which the course is defined (m/s).
    forward_needed : bool
        Body x must be forward (NHC or odometer aiding).

    Raises
    ------
    InputError
        A check failed (the check, the data and the likely mistake named).
    """
    with np.errstate(invalid="ignore", divide="ignore"):  # NaN comparisons refuse nothing
        quiet = check_gravity(imu, sol, axes, mounting_deg)
        check_rest_rate(imu, sol, quiet, gyro_bias_sigma_dps, min_speed)
        check_turns(
            imu, sol, axes, search_s=search_s, offset_s=offset_s, min_speed=min_speed,
            forward_needed=forward_needed,
        )  # fmt: skip


def post_settings(post):
    """The keyword arguments of :func:`check_against_gnss` from a ``run-ekf`` ``post:``
    section (its mounting, gyro bias 1-sigma, time search and aiding)."""
    aiding = post.aiding
    return dict(
        mounting_deg=aiding.mounting_deg,
        gyro_bias_sigma_dps=post.initial_sigma.gyro_bias_dps,
        search_s=post.time.search_s,
        offset_s=post.time.offset_s if post.time.fit == "none" else 0.0,
        min_speed=post.motion_speed_mps,
        forward_needed=aiding.nhc_sigma_mps > 0 or aiding.odometer_sigma_mps > 0,
    )
