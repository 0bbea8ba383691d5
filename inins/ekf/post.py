"""Post-processing of a recorded drive: from the read files to the loosely coupled run.

The steps of ``inins run-ekf`` with a ``post:`` section between reading and scoring,
each a plain function of arrays and :class:`PostSettings` (SI):

1. :func:`prepare`: keep the epochs of the wanted quality flags and scale their
   sigmas; the NED velocity of the positions (:func:`velocity_from_positions`); the
   IMU-to-GNSS time mapping (:func:`map_time`: the turn-rate fit of
   :mod:`inins.ekf.timeoffset`, or a constant offset); the rates resampled to a
   uniform grid where IMU and GNSS overlap (:func:`resample`); the initial state
   (:func:`initial_state`: levelled on the static window with the heading from the
   first motion, :func:`inins.ekf.sources.velocity_heading`, or the reference's
   attitude), shifted from the antenna to the IMU by the lever arm; the outage windows.
2. :func:`forward`: the loosely coupled run (:func:`inins.ekf.loose.run_loose`) into a
   store; :func:`smooth`: the RTS pass (:mod:`inins.ekf.smoother`); :func:`solutions`:
   both copied out of the store.

Times are GNSS seconds from the solution file's first epoch (the filter's axis).
The inputs are read elsewhere: ``gnss`` has the attributes ``path``, ``time`` (m,) s,
``lla`` (m, 3), ``sigma_ned``, ``vel_ned``, ``sigma_vel`` (m, 3), ``q`` (m,) of
:class:`inins.io.solution_files.SolutionFile`; ``imu`` the ``path``, ``time`` (n,) s,
``gyro`` (n, 3) rad/s, ``accel`` (n, 3) m/s^2, ``odometer`` (n,) m/s or None of
:class:`~inins.io.solution_files.ImuRates`. Errors name the ``post:`` keys.
"""

import math
import time as _time
from dataclasses import dataclass

import numpy as np

from inins.core import earth, error_model, rotation, strapdown
from inins.core.error_model import TIME_OFFSET
from inins.ekf import loose, outages, smoother, sources, timeoffset
from inins.exceptions import InputError


@dataclass(frozen=True)
class TimeSettings:
    """IMU time -> GNSS time (s): ``fit`` the turn-rate fit in windows of ``window``
    searching lags within ``search`` (``model`` of :func:`inins.ekf.timeoffset.fit_clock`:
    a constant offset unless the rate passes its test at the false-alarm probability
    ``alpha``), else the constant ``offset``; ``state``: the filter estimates a residual
    offset."""

    fit: bool = True
    window: float = 60.0
    search: float = 10.0
    model: str = "auto"
    alpha: float = 0.01
    offset: float = 0.0
    state: bool = True


@dataclass(frozen=True)
class OutageSettings:
    """Outage windows (s from the run start): every ``every`` for ``length`` from
    ``first`` (None: ``every``), at most ``count`` of them (None: as many as fit), and
    explicit ``windows``."""

    every: float | None = None
    length: float | None = None
    first: float | None = None
    windows: tuple = ()
    count: int | None = None


@dataclass(frozen=True, eq=False)
class PostSettings:
    """A ``post:`` section in SI (:func:`inins.scenario.si.run_ekf_post.post_settings`).

    Attributes
    ----------
    dt : float
        Interval of the uniform IMU grid (s).
    q_flags : tuple of int
        Quality flags of the epochs used; ``sigma_scale`` {flag: factor} their sigmas.
    use_velocity : bool
        Update with the file's velocities too.
    time : TimeSettings
    static_window : (float, float)
        Standing still, s from the first GNSS epoch (levelling).
    motion_speed : float
        Speed above which the motion gives the heading (m/s).
    init_reference : bool
        Initial attitude and velocity from the reference attitude instead.
    init_heading_error : float
        Heading error added to the reference's (rad).
    lever_arm : ndarray (3,)
        Antenna minus IMU, body axes (m).
    outages : OutageSettings
    stationary_windows : tuple of (float, float) or None
        Stationary windows (s from the run start) instead of the detector.
    odometer : bool
        Odometer aiding on (needs an odometer column).
    reference_q : int
        Quality flag of the reference epochs the outages are scored against.
    score_from : float
        Attitude scored against the reference from this time on (s from the run start).
    smooth : bool
        Run the RTS smoother.
    """

    dt: float
    q_flags: tuple = (1, 2)
    sigma_scale: dict | None = None
    use_velocity: bool = False
    time: TimeSettings = TimeSettings()
    static_window: tuple = (1.0, 30.0)
    motion_speed: float = 3.0
    init_reference: bool = False
    init_heading_error: float = 0.0
    lever_arm: np.ndarray = None
    outages: OutageSettings = OutageSettings()
    stationary_windows: tuple | None = None
    odometer: bool = False
    reference_q: int = 1
    score_from: float = 0.0
    smooth: bool = True

    def __post_init__(self):
        lever = np.zeros(3) if self.lever_arm is None else self.lever_arm
        object.__setattr__(self, "lever_arm", np.asarray(lever, float).reshape(3))


@dataclass(frozen=True, eq=False)
class Prepared:
    """What the filter runs on (:func:`prepare`).

    Attributes
    ----------
    t0, dt : float
        Run start (an IMU grid boundary, s) and the grid interval (s).
    dtheta, dv : ndarray (N, 3)
        Uniform increments from ``t0`` (rad, m/s), compensated if asked.
    solution : inins.ekf.loose.GnssSolution
        The epochs the IMU covers, sigmas scaled.
    initial : inins.core.strapdown.NavState
        IMU state at ``t0``.
    heading : inins.ekf.sources.HeadingInit
    fit : inins.ekf.timeoffset.ClockFit or None
    gnss_time : ndarray (m,)
        Times of the selected epochs (s); ``reference_attitude`` (m, 3, 3) or None.
    outages : tuple of (float, float)
    stationary_windows : list of (float, float) or None
    odometer : (ndarray, ndarray) or None
        Odometer times on the GNSS axis (s) and speeds (m/s).
    """

    t0: float
    dt: float
    dtheta: np.ndarray
    dv: np.ndarray
    solution: loose.GnssSolution
    initial: strapdown.NavState
    heading: sources.HeadingInit
    fit: timeoffset.ClockFit | None
    gnss_time: np.ndarray
    reference_attitude: np.ndarray | None
    outages: tuple
    stationary_windows: list | None
    odometer: tuple | None

    def imu(self, lo, hi):
        """Increments of samples ``lo..hi-1`` after ``t0``."""
        return self.dtheta[lo:hi], self.dv[lo:hi]

    @property
    def t_end(self):
        """End of the IMU grid (s)."""
        return self.t0 + self.dtheta.shape[0] * self.dt


def velocity_from_positions(time, lla):
    """NED velocity (m, 3) m/s of positions ``lla`` (m, 3) at ``time`` (m,) s: central
    differences of the ECEF positions rotated into the NED axes of the first epoch."""
    ecef = earth.ecef_from_llh(lla[:, 0], lla[:, 1], lla[:, 2])
    m_en = earth.mat_en(lla[0, 0], lla[0, 1])
    return np.gradient((ecef - ecef[0]) @ m_en, time, axis=0)


def map_time(imu_time, yaw_rate, gnss_time, vel, settings, start, min_speed):
    """GNSS times (n,) s of the IMU samples, and the :class:`~inins.ekf.timeoffset.ClockFit`
    (None for a constant offset).

    The fit (``settings.fit``) correlates the IMU yaw rate ``yaw_rate`` (n,) rad/s with
    the course rate of ``vel`` (m, 3) m/s in windows of ``settings.window`` from ``start``
    (s), lags within ``settings.search``; else ``t_gnss = t_imu + settings.offset``.
    """
    if not settings.fit:
        return imu_time + settings.offset, None
    course = timeoffset.course_rate(gnss_time, vel, min_speed=min_speed)
    w = settings.window
    windows = [(a, a + w) for a in np.arange(start, gnss_time[-1] - w + 1e-9, w)]
    if not windows:
        raise InputError("the drive is shorter than one time-fit window", key="post.time.window_s")
    fit = timeoffset.fit_clock(
        imu_time,
        yaw_rate,
        gnss_time,
        course,
        windows,
        search=(-settings.search, settings.search),
        model=settings.model,
        alpha=settings.alpha,
    )
    return fit.to_gnss(imu_time), fit


def overlap(imu_time, gnss_time, dt, source=None):
    """Start (a multiple of ``dt``) and end (s) of the span both time axes cover; bad input
    when shorter than 10 s."""
    t0 = max(math.ceil(imu_time[0] / dt) * dt, float(gnss_time[0]))
    t1 = min(float(imu_time[-1]), float(gnss_time[-1]))
    if not t1 > t0 + 10.0:
        raise InputError(
            f"IMU ({imu_time[0]:.1f}..{imu_time[-1]:.1f} s) and GNSS ({gnss_time[0]:.1f}.."
            f"{gnss_time[-1]:.1f} s) overlap by less than 10 s (GNSS time from its first epoch)",
            source=source,
            key="post.time",
        )
    return t0, t1


def resample(time, rates, dt, t0, t1):
    """Increments (N, 3) on ``[t0 + k dt, t0 + (k + 1) dt]`` before ``t1`` of ``rates``
    (n, 3) at ``time`` (n,) s: the rate interpolated at each interval's middle times
    ``dt``; and the interval starts (N,) s."""
    grid = np.arange(t0, t1 - 0.5 * dt, dt)
    mid = grid + 0.5 * dt
    return np.stack([np.interp(mid, time, rates[:, i]) for i in range(3)], -1) * dt, grid


def initial_state(lla0, mat_nb, vel_n, lever_arm):
    """IMU state from the antenna's position ``lla0`` (3,) with attitude ``mat_nb``, velocity
    ``vel_n`` (3,) m/s: the IMU is at the antenna minus ``C_nb l_b`` (spec §10)."""
    lla_imu = error_model.lla_offset(lla0, -(mat_nb @ lever_arm))
    return strapdown.NavState.from_attitude(mat_nb, vel_n, lla_imu)


def _heading(settings, t0, grid, dth, dvv, gnss_time, lla, vel, ref_att, source):
    """The :class:`~inins.ekf.sources.HeadingInit`, velocity and antenna position at ``t0``."""
    first = min(int(np.searchsorted(gnss_time, t0)), len(gnss_time) - 1)
    if settings.init_reference:
        if ref_att is None:
            raise InputError("init: reference needs gnss.attitude_columns", key="post.init")
        eul = rotation.euler_from_mat(ref_att[first]) + np.array(
            [0, 0, settings.init_heading_error]
        )
        mat0 = rotation.mat_from_euler(*eul)
        vel0 = vel[first]
        lla0 = error_model.lla_offset(lla[first], -vel0 * (gnss_time[first] - t0))
        init = sources.HeadingInit(mat0, float(eul[2]), 0.0, gnss_time[first : first + 1])
        return init, vel0, lla0
    sw = (t0 + settings.static_window[0], t0 + settings.static_window[1])
    try:
        init = sources.velocity_heading(
            grid + settings.dt,
            dth,
            dvv,
            settings.dt,
            lla[first],
            sw,
            gnss_time,
            vel,
            settings.motion_speed,
        )
    except InputError as exc:  # its keys are the tight scenario's
        key = str(exc.key or "").replace("data.", "post.")
        raise InputError(exc.message, source=source, key=key) from None
    return init, np.zeros(3), lla[first]


def outage_windows(settings, t0, t_end):
    """The outage windows (s on the filter axis) of ``settings`` (:class:`OutageSettings`)."""
    wins = []
    if settings.every is not None:
        first = None if settings.first is None else t0 + settings.first
        wins += outages.periodic_windows(
            t0, t_end, settings.every, settings.length, first, key="post.outages"
        )[: settings.count]
    if settings.windows:
        wins += outages.check_windows(
            [(t0 + a, t0 + b) for a, b in settings.windows], t0, t_end, key="post.outages.windows"
        )
    return tuple(sorted(wins))


def prepare(gnss, imu, settings, reference_euler=None, compensate=None):
    """Everything the forward run needs (module docstring, step 1).

    Parameters
    ----------
    gnss, imu
        The read files (module docstring).
    settings : PostSettings
    reference_euler : ndarray (m, 3), optional
        Reference roll, pitch, heading (rad) at every epoch of ``gnss``: the initial
        attitude with ``init_reference``, and the attitude scored against.
    compensate : callable ``(dtheta, dv, dt) -> (dtheta, dv)``, optional
        Sensor compensation of the resampled increments.

    Returns
    -------
    Prepared
    """
    keep = np.isin(gnss.q, settings.q_flags)
    if not keep.any():
        raise InputError(
            f"no epoch with a quality flag in {list(settings.q_flags)}",
            source=str(gnss.path),
            key="post.gnss.q_flags",
        )
    if settings.odometer and imu.odometer is None:
        raise InputError(
            "odometer aiding needs imu.odometer_column", key="post.aiding.odometer_sigma_mps"
        )
    scales = settings.sigma_scale or {}
    scale = np.array([scales.get(int(q), 1.0) for q in gnss.q[keep]])
    ref_att = None
    if reference_euler is not None:
        ref_att = rotation.mat_from_euler(*np.moveaxis(reference_euler[keep], -1, 0))
    lla = gnss.lla[keep]
    tg = gnss.time[keep] - float(gnss.time[0])
    ti = imu.time - imu.time[0]
    vel = velocity_from_positions(tg, lla)  # the course; the heading without file velocities
    vel_ned = gnss.vel_ned[keep]
    vel_init = np.where(np.isfinite(vel_ned), vel_ned, vel)
    start, speed = settings.static_window[1], settings.motion_speed
    tig, fit = map_time(ti, imu.gyro[:, 2], tg, vel, settings.time, start, speed)
    dt = settings.dt
    t0, t1 = overlap(tig, tg, dt, str(imu.path))
    dth, grid = resample(tig, imu.gyro, dt, t0, t1)
    dvv, _ = resample(tig, imu.accel, dt, t0, t1)
    if compensate is not None:
        dth, dvv = compensate(dth, dvv, dt)
    init, vel0, lla0 = _heading(
        settings, t0, grid, dth, dvv, tg, lla, vel_init, ref_att, str(gnss.path)
    )
    t_end = float(grid[-1] + dt)
    stat = settings.stationary_windows
    inside = (tg >= t0 - 1e-9) & (tg <= t_end + 1e-9)  # epochs the IMU covers
    use_vel = settings.use_velocity
    solution = loose.GnssSolution(
        tg[inside],
        lla[inside],
        (gnss.sigma_ned[keep] * scale[:, None])[inside],
        vel_ned[inside] if use_vel else None,
        (gnss.sigma_vel[keep] * scale[:, None])[inside] if use_vel else None,
    )
    return Prepared(
        t0=t0,
        dt=dt,
        dtheta=dth,
        dv=dvv,
        solution=solution,
        initial=initial_state(lla0, init.mat_nb, vel0, settings.lever_arm),
        heading=init,
        fit=fit,
        gnss_time=tg,
        reference_attitude=ref_att,
        outages=outage_windows(settings.outages, t0, t_end),
        stationary_windows=None if stat is None else [(t0 + a, t0 + b) for a, b in stat],
        odometer=None if imu.odometer is None else (tig, imu.odometer),
    )


def forward(prepared, config, store=smoother.default_store):
    """The loosely coupled run (:func:`inins.ekf.loose.run_loose`) over ``prepared``, its
    epochs in ``store``; returns the :class:`~inins.ekf.loose.LooseRun` and its wall time (s)."""
    tick = _time.perf_counter()
    run = loose.run_loose(
        config,
        prepared.initial,
        prepared.t0,
        prepared.imu,
        prepared.solution,
        outages=prepared.outages,
        store=store,
        stationary_windows=prepared.stationary_windows,
        odometer=prepared.odometer,
    )
    return run, _time.perf_counter() - tick


def smooth(run, store=smoother.default_store):
    """The RTS pass over a forward run (:func:`inins.ekf.smoother.smooth`) and its wall
    time (s)."""
    tick = _time.perf_counter()
    sm = smoother.smooth(run, store)
    return sm, _time.perf_counter() - tick


@dataclass(frozen=True, eq=False)
class Solution:
    """One solution of a run, in RAM: ``quat`` (m, 4), ``vel`` (m, 3) m/s, ``lla`` (m, 3)
    of the IMU; ``sensors`` (m, s) sensor estimates (m/s^2, rad/s, rad); ``sigma`` (m, n)
    1-sigma of each state; ``offset`` (m,) s the time-offset state, or None."""

    quat: np.ndarray
    vel: np.ndarray
    lla: np.ndarray
    sensors: np.ndarray
    sigma: np.ndarray
    offset: np.ndarray | None


@dataclass(frozen=True, eq=False)
class PostRun:
    """A forward run and its smoothed solution, copied out of their store.

    ``time`` (m,) s; ``forward``, ``smoothed`` (None without smoothing) :class:`Solution`;
    ``innovation``, ``variance`` (m, 6) of the position and velocity rows; ``used``
    GNSS updates and ``stationary`` epochs (counts); ``offset`` (estimate, 1-sigma) s of
    the time-offset state (the smoothed one at the start, else the last forward one),
    or None; wall times (s); the outlier gate's ``rejected`` (m, 2) position and velocity
    fixes and ``reinit`` (m,) re-initialising epochs (:mod:`inins.ekf.gate`)."""

    time: np.ndarray
    forward: Solution
    smoothed: Solution | None
    innovation: np.ndarray
    variance: np.ndarray
    used: int
    stationary: int
    offset: tuple | None
    filter_wall_s: float
    smoother_wall_s: float | None
    rejected: np.ndarray
    reinit: np.ndarray


def solutions(run, sm, filter_wall_s, smoother_wall_s=None):
    """:class:`PostRun` of a forward ``run`` and its smoothed ``sm`` (or None)."""
    cfg = run.config
    td = cfg.layout.index(TIME_OFFSET) if cfg.time_offset else None
    quat, vel, lla, sens, sig = (np.array(a) for a in run.output())
    fwd = Solution(quat, vel, lla, sens, sig, None if td is None else np.array(run.x[:, td]))
    smoothed, offset = None, None
    if td is not None:
        offset = (float(run.x[-1, td]), float(math.sqrt(run.P[-1, td, td])))
    if sm is not None:
        smoothed = Solution(
            *(np.array(a) for a in (sm.quat, sm.vel, sm.lla, sm.sensors, sm.sigma)),
            None if td is None else np.array(sm.s[:, td]),
        )
        if td is not None:
            offset = (float(sm.s[0, td]), float(sm.sigma[0, td]))
    return PostRun(
        time=np.array(run.time),
        forward=fwd,
        smoothed=smoothed,
        innovation=np.array(run.innovation),
        variance=np.array(run.variance),
        used=int(np.sum(run.used)),
        stationary=int(np.sum(run.stationary)),
        offset=offset,
        filter_wall_s=filter_wall_s,
        smoother_wall_s=smoother_wall_s,
        rejected=np.array(run.rejected),
        reinit=np.array(run.reinit),
    )
