"""Loosely coupled INS/GNSS error-state filter for post-processing (run-ekf loose mode).

The GNSS receiver's own solution is the measurement: antenna position (and NED
velocity where the solution file has it) with its per-epoch 1-sigma. The filter is the
tight one of :mod:`inins.ekf.filter` without the receiver clock; its states, model and
rows block by block are spec §6b:

- States: :data:`LOOSE15` or :data:`LOOSE24` (+ the misalignments), then with
  ``time_offset`` the GNSS-minus-IMU time offset ``dt_g`` (s) (:attr:`LooseConfig.layout`).
- Propagation once per GNSS epoch, ``F`` of EKF26 at the mid-interval INS state.
- Update at the INS state after the IMU sample boundary nearest the solution's tag,
  ``lag = t_k - t_b + dt_g`` before it: the antenna position and velocity rows and the
  vehicle aiding (:mod:`inins.ekf.rows`, :mod:`inins.ekf.aiding`): each fix (position,
  velocity) through the outlier gate of :mod:`inins.ekf.gate` (chi-square(3), with a
  re-initialisation after ``reinit_after`` rejected epochs), then scalar Joseph updates
  gated on chi-square(1); the NED sigmas taken as uncorrelated (RTKLIB's ``sdne``,
  ``sdeu``, ``sdun`` are not used).
- FB: the correction into the INS state and the sensor compensation, the states reset
  (``dt_g`` never: a parameter of the model). FF: the INS runs free, the output is
  ``nav (-) x``.

Every epoch writes to a store (arrays the caller provides, e.g. memory maps, so
that a long run does not keep every ``P`` in RAM): the INS state after the
epoch's reset ``N_k+``, the state after the update ``x_k`` and the reset ``r_k``
(``x_k`` in FB, zero in FF), ``P_k``, the transition ``Phi_k`` from ``k - 1`` to
``k`` and the prediction ``P_k-``. :mod:`inins.ekf.smoother` runs backwards on it.
"""

import math
from dataclasses import dataclass, field

import numpy as np

from inins.core import earth, error_model, rotation, stats
from inins.core.error_model import EKF26, GROUPS, NAV15, TIME_OFFSET, StateLayout
from inins.ekf import aiding, gate, loose_kernel, step
from inins.ekf.kernels import NAV
from inins.ekf.smoother import ForwardRecord, correct_many, default_store
from inins.exceptions import InputError

BLOCK = 512
"""Epochs the compiled kernel runs per call (the store is written block by block)."""
LOOSE15 = NAV15
"""The loosely coupled filter's states: EKF17 without the receiver clock."""
LOOSE24 = NAV15 + StateLayout(GROUPS["accel_misalignment"] + GROUPS["gyro_misalignment"])
"""With the accelerometer (3) and gyro (6) misalignments: EKF26 without the clock."""


@dataclass(frozen=True, eq=False)
class LooseConfig:
    """Loosely coupled filter settings (SI units).

    Attributes
    ----------
    dt : float
        IMU interval (s).
    misalignments : bool
        False: 15 states; True: 24 (accel 3, gyro 6 misalignments).
    feedback : bool
        True: FB (corrections fed back, states reset); False: FF.
    lever_arm : ndarray (3,)
        GNSS antenna relative to the IMU, body axes (m).
    arw, vrw, gyro_bias_rw, accel_bias_rw : ndarray (3,)
        Process noise densities (rad/sqrt(s), m/s/sqrt(s), rad/s/sqrt(s), m/s^2/sqrt(s)).
    sigma0 : ndarray (n,)
        Initial 1-sigma of the error states (m, m/s, rad, m/s^2, rad/s, rad).
    time_offset : bool
        Estimate the GNSS-minus-IMU time offset as a state.
    time_offset_sigma : float
        Its initial 1-sigma (s).
    time_offset_walk : float
        Its random-walk density (s/sqrt(s)); 1e-6 (2e-5 s over 500 s) keeps it a
        constant.
    gate_probability : float
        Chi-square(1) gate of each scalar row (1: none).
    outlier_probability, outlier_sigma_scale : float
        The outlier gate of each position and velocity fix (:mod:`inins.ekf.gate`): the
        chi-square(3) acceptance probability (1: no gate) and the scale (>= 1) of the
        innovation sigma tested against.
    reinit_after : int
        Consecutive rejected epochs after which a failing fix re-initialises (>= 1).
    window : int
        Samples averaged for ``f_b``, ``omega_b`` of the model and the lever-arm rate.
    nhc_sigma, zupt_sigma, zaru_sigma, odometer_sigma : float
        Vehicle aiding 1-sigma (m/s, m/s, rad/s, m/s), 0 = off (:mod:`inins.ekf.aiding`).
    mounting : ndarray (3,)
        Roll, pitch, yaw (rad) of the IMU body in the vehicle axes (``C_vb`` for the NHC).
    stationary_accel, stationary_gyro, stationary_window : float
        Stationary detector: ``|f|`` std (m/s^2), mean ``|omega|`` (rad/s), window (s).
    """

    dt: float
    misalignments: bool = False
    feedback: bool = True
    lever_arm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    arw: np.ndarray = field(default_factory=lambda: np.full(3, 1e-4))
    vrw: np.ndarray = field(default_factory=lambda: np.full(3, 1e-3))
    gyro_bias_rw: np.ndarray = field(default_factory=lambda: np.zeros(3))
    accel_bias_rw: np.ndarray = field(default_factory=lambda: np.zeros(3))
    sigma0: np.ndarray | None = None
    time_offset: bool = False
    time_offset_sigma: float = 0.5
    time_offset_walk: float = 1e-6
    gate_probability: float = 0.9999
    outlier_probability: float = 0.999999
    outlier_sigma_scale: float = 10.0
    reinit_after: int = 10
    window: int = 1
    nhc_sigma: float = 0.0
    odometer_sigma: float = 0.0
    zupt_sigma: float = 0.0
    zaru_sigma: float = 0.0
    mounting: np.ndarray = field(default_factory=lambda: np.zeros(3))
    stationary_accel: float = 0.05
    stationary_gyro: float = 0.0087266
    stationary_window: float = 0.5

    def __post_init__(self):
        if not (math.isfinite(self.dt) and 0.0 < self.dt <= 0.1):
            raise InputError(f"IMU interval must be in (0, 0.1] s, got {self.dt}", key="dt")
        for name in ("lever_arm", "arw", "vrw", "gyro_bias_rw", "accel_bias_rw"):
            arr = np.broadcast_to(np.asarray(getattr(self, name), float), (3,)).copy()
            if not np.all(np.isfinite(arr)) or (name != "lever_arm" and np.any(arr < 0)):
                raise InputError(f"expected 3 finite values (>= 0), got {arr}", key=name)
            object.__setattr__(self, name, arr)
        if self.sigma0 is None:
            s = [5.0] * 3 + [0.5] * 3 + [0.01, 0.01, 0.1] + [0.01] * 3 + [1e-4] * 3
            s += [1e-3] * 9 if self.misalignments else []
            object.__setattr__(self, "sigma0", np.array(s))
        sig = np.asarray(self.sigma0, float)
        if sig.shape != (self.n_base,) or not np.all(sig > 0):
            raise InputError(f"need {self.n_base} positive initial sigmas", key="sigma0")
        object.__setattr__(self, "sigma0", sig)
        if not 0.5 < self.gate_probability <= 1.0:
            raise InputError("gate probability must be in (0.5, 1]", key="gate_probability")
        if not 0.5 < self.outlier_probability <= 1.0:
            raise InputError("gate probability must be in (0.5, 1]", key="outlier_probability")
        if not 1.0 <= self.outlier_sigma_scale <= 1e3:
            raise InputError("sigma scale must be in [1, 1000]", key="outlier_sigma_scale")
        if not 1 <= self.reinit_after <= 100_000:
            raise InputError("reinit_after must be in [1, 100000] epochs", key="reinit_after")
        for name in ("nhc_sigma", "zupt_sigma", "zaru_sigma", "odometer_sigma"):
            if not 0.0 <= getattr(self, name) < 100.0:
                raise InputError("aiding sigma must be in [0, 100) (0: off)", key=name)
        mount = np.asarray(self.mounting, float).reshape(3)
        object.__setattr__(self, "mounting", mount)
        if not 0.0 < self.time_offset_sigma < 100.0:
            raise InputError("time offset sigma must be in (0, 100) s", key="time_offset_sigma")
        if not 0.0 <= self.time_offset_walk < 1.0:
            raise InputError("time offset walk must be in [0, 1) s/sqrt(s)", key="time_offset_walk")

    @property
    def n_base(self):
        """Error states without the time offset (15 or 24)."""
        return 24 if self.misalignments else 15

    @property
    def n(self):
        """All states."""
        return self.n_base + int(self.time_offset)

    @property
    def layout(self):
        """The states (:class:`inins.core.error_model.StateLayout`): :data:`LOOSE15` or
        :data:`LOOSE24`, then ``dt_g`` with the time offset."""
        base = LOOSE24 if self.misalignments else LOOSE15
        return base + StateLayout((TIME_OFFSET,)) if self.time_offset else base

    @property
    def keep(self):
        """Indices of the states but the time offset in the EKF26 order of
        :mod:`inins.ekf.kernels` (the loose model is EKF26's without the clock)."""
        return np.array([EKF26.index(name) for name in self.layout.names if name in EKF26.names])

    def covariance0(self):
        """Diagonal ``P0`` (n, n)."""
        s = list(self.sigma0) + ([self.time_offset_sigma] if self.time_offset else [])
        return np.diag(np.square(s))

    def c_vb(self):
        """IMU body to vehicle axes (3, 3) from the mounting roll, pitch, yaw."""
        return rotation.mat_from_euler(*self.mounting)

    def noise(self):
        """Densities in the order of :func:`inins.ekf.step.propagate` (clock PSDs zero),
        then the time offset's random-walk density (s/sqrt(s))."""
        return np.concatenate(
            [
                self.arw,
                self.vrw,
                self.accel_bias_rw,
                self.gyro_bias_rw,
                [0, 0, self.time_offset_walk],
            ]
        )


@dataclass(frozen=True, eq=False)
class GnssSolution:
    """GNSS solutions on the IMU time axis (SI).

    Attributes
    ----------
    time : ndarray (m,)
        Solution time tags (s, IMU axis), strictly increasing.
    lla : ndarray (m, 3)
        Antenna latitude, longitude (rad), ellipsoidal height (m).
    sigma_ned : ndarray (m, 3)
        1-sigma north, east, down (m), > 0.
    vel_ned : ndarray (m, 3), optional
        Antenna NED velocity (m/s); NaN rows where absent.
    sigma_vel : ndarray (m, 3), optional
        Its 1-sigma (m/s).
    """

    time: np.ndarray
    lla: np.ndarray
    sigma_ned: np.ndarray
    vel_ned: np.ndarray | None = None
    sigma_vel: np.ndarray | None = None

    def __post_init__(self):
        t = np.asarray(self.time, float).reshape(-1)
        m = t.size
        if m < 2 or not np.all(np.diff(t) > 0):
            raise InputError("solution times must increase (at least 2 epochs)", key="time")
        lla = np.asarray(self.lla, float).reshape(m, 3)
        sig = np.asarray(self.sigma_ned, float).reshape(m, 3)
        if not np.all(sig > 0):
            raise InputError("position sigmas must be > 0", key="sigma_ned")
        vel = np.full((m, 3), np.nan) if self.vel_ned is None else np.asarray(self.vel_ned, float)
        svel = (
            np.full((m, 3), np.nan) if self.sigma_vel is None else np.asarray(self.sigma_vel, float)
        )
        ok = np.isfinite(vel).all(1)
        if np.any(ok & ~(svel > 0).all(1)):
            raise InputError("velocity sigmas must be > 0", key="sigma_vel")
        for name, value in (
            ("time", t),
            ("lla", lla),
            ("sigma_ned", sig),
            ("vel_ned", vel.reshape(m, 3)),
            ("sigma_vel", svel.reshape(m, 3)),
        ):
            object.__setattr__(self, name, value)

    def __len__(self):
        return self.time.size


def _ecef(lla):
    return earth.ecef_from_llh(lla[:, 0], lla[:, 1], lla[:, 2])


@dataclass(frozen=True, eq=False)
class LooseRun(ForwardRecord):
    """Forward run stored per epoch (arrays from the store; see module docstring): the
    smoother's :class:`~inins.ekf.smoother.ForwardRecord` and ``config``;
    ``innovation``, ``variance`` (m, 6), ``accepted`` (m, 6) per pos N/E/D, vel N/E/D
    row; ``used`` (m,) bool; ``aided`` (m, 9) accepted vehicle rows (NHC y, z, ZUPT N,
    E, D, ZARU x, y, z, odometer); ``stationary`` (m,) the flag; the outlier gate's
    ``nis`` (m, 2) of the position and velocity fixes (NaN: none), ``rejected`` (m, 2)
    the fixes it rejected, ``reinit`` (m,) the re-initialising epochs (:mod:`inins.ekf.gate`).
    """

    config: LooseConfig
    innovation: np.ndarray
    variance: np.ndarray
    accepted: np.ndarray
    used: np.ndarray
    aided: np.ndarray
    stationary: np.ndarray
    nis: np.ndarray
    rejected: np.ndarray
    reinit: np.ndarray

    def output(self):
        """Forward navigation output ``N+ (-) (x - r)`` (quat, vel, lla), sensor estimates
        ``comp + x - r`` on the sensor states (m, n_sensors) and 1-sigma (m, n)."""
        e = self.x - self.r
        quat, vel, lla = correct_many(self.quat, self.vel, self.lla, e)
        sigma = np.sqrt(np.einsum("kii->ki", self.P))
        return quat, vel, lla, self.sensors(e), sigma


_STORED = {
    "quat": 4,
    "vel": 3,
    "lla": 3,
    "comp": 15,
    "x": None,
    "r": None,
    "P": None,
    "P_pred": None,
    "Phi": None,
    "innovation": 6,
    "variance": 6,
    "nis": 2,
}
"""The float arrays of a run per epoch: width, or None for ``n`` (``x``, ``r``) and
``(n, n)`` (the matrices)."""


def _shapes(m, n):
    """Shape of each stored float array of ``m`` epochs and ``n`` states."""
    square = ("P", "P_pred", "Phi")
    return {k: (m, n, n) if k in square else (m, n if w is None else w) for k, w in _STORED.items()}


def _epoch_inputs(cfg, solution, t0, outages, stationary_windows, odometer):
    """The filter epochs and their inputs: (time (m,), used (m,), the boundary sample and
    fraction of each epoch, the ECEF positions and variances, velocities and
    variances, stationary flags (or None: the detector) and odometer speeds)."""
    sol_t = solution.time
    sel = sol_t >= t0 - 1e-9
    if not np.any(sel):
        raise InputError("no GNSS solution after the IMU start", key="gnss")
    time, idx = _epoch_grid(sol_t[sel])
    m = time.size
    src = np.flatnonzero(sel)[np.maximum(idx, 0)]
    has = idx >= 0
    use = has.copy()
    for a, b in outages:
        use &= ~((time >= a) & (time < b))
    rel = time - t0
    end = np.round(rel / cfg.dt).astype(np.int64)
    odo = np.full(m, np.nan)
    if odometer is not None:
        o_t, o_v = (np.asarray(a, float) for a in odometer)
        inside = (time >= o_t[0]) & (time <= o_t[-1])
        odo[inside] = np.interp(time[inside], o_t, o_v)
    stat = None
    if stationary_windows is not None:
        stat = np.zeros(m, np.bool_)
        for a, b in stationary_windows:
            stat |= (time >= a) & (time < b)
    epochs = loose_kernel.LooseEpochs(
        end=end,
        frac=rel - end * cfg.dt,
        pos=_ecef(solution.lla[src]),
        var=solution.sigma_ned[src] ** 2,
        vel=np.ascontiguousarray(np.where(has[:, None], solution.vel_ned[src], np.nan)),
        var_vel=np.ascontiguousarray(solution.sigma_vel[src] ** 2),
        use=use,
        stationary=stat,
        odometer=odo,
    )
    return time, epochs


def _model(cfg):
    """The :data:`LooseModel` of a configuration."""
    return loose_kernel.LooseModel(
        dt=float(cfg.dt),
        window=int(cfg.window),
        feedback=bool(cfg.feedback),
        threshold=float(stats.chi2_ppf(cfg.gate_probability, 1)),
        n_base=cfg.n_base,
        td=cfg.layout.index(TIME_OFFSET) if cfg.time_offset else -1,
        keep=cfg.keep.astype(np.int64),
        noise=cfg.noise(),
        lever=cfg.lever_arm,
        c_vb=cfg.c_vb(),
        aid_sigma=np.array([cfg.nhc_sigma, cfg.zupt_sigma, cfg.zaru_sigma, cfg.odometer_sigma]),
        bound=gate.bound(cfg.outlier_probability, cfg.outlier_sigma_scale),
        reinit_after=int(cfg.reinit_after),
    )


def _stationary(cfg, ep, lo, hi, dtheta, dv, sample0):
    """Stationary flags of epochs ``lo..hi-1``: the given windows, the detector of
    :func:`inins.ekf.aiding.stationary` when ZUPT or ZARU is on, else none."""
    if not (cfg.zupt_sigma > 0 or cfg.zaru_sigma > 0):
        return np.zeros(hi - lo, np.bool_)
    if ep.stationary is not None:
        return ep.stationary[lo:hi]
    return aiding.stationary(
        dtheta,
        dv,
        cfg.dt,
        ep.end[lo:hi] - sample0,
        max(round(cfg.stationary_window / cfg.dt), 2),
        cfg.stationary_accel,
        cfg.stationary_gyro,
    )


def _block_epochs(ep, lo, hi, sample0, stationary):
    """Epochs ``lo..hi-1`` of ``ep`` for a block whose sample 0 is ``sample0``."""
    kept = {f: getattr(ep, f)[lo:hi] for f in ("frac", "pos", "var", "vel", "var_vel", "use")}
    return loose_kernel.LooseEpochs(
        end=ep.end[lo:hi] - sample0,
        stationary=stationary,
        odometer=ep.odometer[lo:hi],
        **kept,
    )


def run_loose(
    config,
    initial,
    t0,
    imu,
    solution,
    outages=(),
    store=default_store,
    stationary_windows=None,
    odometer=None,
):
    """Forward loosely coupled run over a whole IMU record and its GNSS solutions.

    Parameters
    ----------
    config : LooseConfig
    initial : inins.core.strapdown.NavState
        INS state at ``t0`` (the first filter epoch; e.g. aligned at the first fix).
    t0 : float
        Time of ``initial`` (s), an IMU sample boundary.
    imu : callable ``(lo, hi) -> (dtheta, dv)``
        Increments of samples ``lo..hi-1`` after ``t0`` (rad, m/s): read block by block.
    solution : GnssSolution
        Epochs at ``t >= t0``; the filter epochs are the solution epochs (gaps
        longer than 1.5 median intervals are filled with coasted epochs).
    outages : sequence of (float, float)
        Windows ``[a, b)`` (s) whose epochs are coasted (not used).
    store : callable ``(name, shape) -> ndarray``
    stationary_windows : sequence of (float, float), optional
        Where the vehicle stands (s): ZUPT/ZARU epochs. None: the stationary detector
        of :func:`inins.ekf.aiding.stationary` (when ZUPT or ZARU is on).
    odometer : (ndarray, ndarray), optional
        Times (s) and forward speeds (m/s) of a wheel odometer, interpolated to the
        epochs (used when ``odometer_sigma`` > 0).

    Returns
    -------
    LooseRun
    """
    cfg = config
    time, ep = _epoch_inputs(cfg, solution, t0, outages, stationary_windows, odometer)
    m, n = time.size, cfg.n
    shapes = _shapes(m, n)
    out = {k: store(k, s) for k, s in shapes.items()}
    for name, width in (("accepted", 6), ("aided", 9), ("stationary", None), ("rejected", 2)):
        out[name] = store(name, (m,) if width is None else (m, width), np.bool_)
    out["reinit"] = store("reinit", (m,), np.bool_)
    ins = step.Ins(
        initial.quat_nb.copy(),
        initial.vel_n.copy(),
        initial.lla.copy(),
        np.concatenate([initial.dtheta_prev, initial.dv_prev]),
        np.zeros(8),  # Earth terms of the strapdown's fixed modes; unused (free)
    )
    state = loose_kernel.LooseState(
        x=np.zeros(n),
        P=cfg.covariance0(),
        comp=np.zeros(15),
        times=np.array([t0, 0.0]),  # the first epoch propagates from t0
        count=np.array([initial.count], np.int64),
        rejected=np.zeros(1, np.int64),
    )
    model = _model(cfg)
    sample0 = 0
    for lo in range(0, m, BLOCK):
        hi = min(lo + BLOCK, m)
        last = int(ep.end[hi - 1])
        dtheta, dv = imu(sample0, last)
        if dtheta.shape[0] != last - sample0:
            raise InputError(
                f"IMU record ends before the GNSS epoch at {time[hi - 1]:.3f} s", key="imu"
            )
        state.times[1] = t0 + sample0 * cfg.dt
        stat = _stationary(cfg, ep, lo, hi, dtheta, dv, sample0)
        block = loose_kernel.LooseEpochs(
            *(getattr(ep, f)[lo:hi] for f in loose_kernel.LooseEpochs._fields[:-2]),
            stat,
            ep.odometer[lo:hi],
        )._replace(end=ep.end[lo:hi] - sample0)
        buf = {k: np.empty((hi - lo, *s[1:])) for k, s in shapes.items()}
        log = loose_kernel.LooseLog(
            *(buf[k] for k in ("quat", "vel", "lla", "comp", "x", "r", "P", "P_pred", "Phi")),
            y=buf["innovation"],
            s=buf["variance"],
            acc=np.zeros((hi - lo, 6), np.bool_),
            aid=np.zeros((hi - lo, 9), np.bool_),
            nis=buf["nis"],
            rejected=np.zeros((hi - lo, 2), np.bool_),
            reinit=np.zeros(hi - lo, np.bool_),
        )
        loose_kernel.run_block(
            np.ascontiguousarray(dtheta, float),
            np.ascontiguousarray(dv, float),
            ins,
            state,
            block,
            model,
            log,
        )
        for k, v in buf.items():
            out[k][lo:hi] = v
        out["accepted"][lo:hi] = log.acc
        out["aided"][lo:hi] = log.aid
        out["rejected"][lo:hi] = log.rejected
        out["reinit"][lo:hi] = log.reinit
        out["stationary"][lo:hi] = stat
        sample0 = last
    return LooseRun(config=cfg, time=time, used=ep.use, n_sensors=cfg.n_base - NAV, **out)


def _epoch_grid(t):
    """Solution times with gaps over 1.5 median intervals filled; (times, source index or -1)."""
    if t.size < 2:
        return t.copy(), np.arange(t.size)
    step_ = float(np.median(np.diff(t)))
    times, idx = [t[:1]], [np.zeros(1, np.int64)]
    gaps = np.flatnonzero(np.diff(t) > 1.5 * step_)
    lo = 0
    for g in gaps:
        times.append(t[lo + 1 : g + 1])
        idx.append(np.arange(lo + 1, g + 1))
        fill = np.arange(t[g] + step_, t[g + 1] - 0.5 * step_, step_)
        times.append(fill)
        idx.append(np.full(fill.size, -1))
        lo = g
    times.append(t[lo + 1 :])
    idx.append(np.arange(lo + 1, t.size))
    return np.concatenate(times), np.concatenate(idx)


def antenna_positions(quat, lla, lever, vel=None, offset=None):
    """Antenna positions (lla, (m, 3)) of IMU states ``quat`` (m, 4), ``lla`` (m, 3) with the
    body lever arm ``lever`` (3,); with ``vel`` (m, 3) and the time ``offset`` (s, per
    epoch or one) carried to the instant a solution with the same tag was taken (IMU
    time t + offset): ``lla + C_nb l_b + v offset``."""
    shift = rotation.mat_from_quat(quat) @ lever
    if vel is not None and offset is not None:
        shift = shift + vel * np.reshape(offset, (-1, 1))
    return error_model.lla_offset(lla, shift)
