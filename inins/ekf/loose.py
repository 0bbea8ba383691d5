"""Loosely coupled INS/GNSS error-state filter for post-processing (run-ekf loose mode).

The GNSS receiver's own solution is the measurement: antenna position (and NED
velocity where the solution file has it) with its per-epoch 1-sigma. The filter
is the one of :mod:`inins.ekf.filter` without the receiver clock:

- States: ``LOOSE15`` = position, velocity, attitude (phi angle), accel bias,
  gyro bias (EKF17 without the clock, 15); ``LOOSE24`` adds the accel (3) and gyro
  (6) misalignments (EKF26 without the clock, 24). With ``time_offset`` one more
  state, the GNSS-minus-IMU time offset ``dt_g`` (s), last.
- Propagation once per GNSS epoch with ``F`` from
  :func:`inins.ekf.kernels.system_matrix26` at the mid-interval INS state (the
  clock rows and columns dropped), third-order ``Phi`` and series ``Qd``
  (:func:`inins.ekf.kernels.discretize`).
- Measurement at the solution's time tag ``t_k``: the INS state after the IMU
  sample boundary nearest ``t_k`` (the stored state of the 1PPS machinery; in
  post-processing there is no latency) carried by ``v (t_k - t_b)`` to ``t_k``.
  With the errors ``dr, dv, phi`` (estimated minus true), the antenna at
  ``r_ant = r + C_nb l`` and moving at ``v_ant = v + C_nb (omega_eb x l)``::

      y_pos = z_pos - r_ant_est = -dr - [l_n x] phi        + v dt_g + noise
      y_vel = z_vel - v_ant_est = -dv - [u_n x] phi        + a dt_g + noise

  in NED metres at the INS position, ``l_n = C_nb l``, ``u_n = C_nb (omega_eb x l)``
  (``C_est = (I - [phi x]) C`` gives ``C_est l = C l + [l_n x] phi``). So ``H`` is
  ``-I`` on position (velocity), ``-[l_n x]`` (``-[u_n x]``) on attitude and
  ``+v`` (``+a``, ``a = C_nb f_b + g`` the INS acceleration, Coriolis dropped) on
  ``dt_g`` (a solution tagged ``t_k`` was taken at IMU time ``t_k + dt_g``:
  the prediction is the INS antenna position carried to it by ``v (t_k - t_b + dt_g)``).
  The frame rotation ``J_v dr`` of the velocity (O(v/R)) is dropped.
- Scalar Joseph updates per axis, each gated on chi-square(1)
  (:func:`inins.ekf.kernels.sequential_update`); the NED sigmas are taken as
  uncorrelated (RTKLIB's ``sdne``, ``sdeu``, ``sdun`` are not used).
- FB: the correction goes into the INS state and the sensor compensation at
  ``t_k``, the states reset (``dt_g`` is never reset: it is a parameter the
  measurement model uses). FF: the INS runs free, the output is ``nav (-) x``.

Every epoch writes to a store (arrays the caller provides, e.g. memory maps, so
that a long run does not keep every ``P`` in RAM): the INS state after the
epoch's reset ``N_k+``, the state after the update ``x_k`` and the reset ``r_k``
(``x_k`` in FB, zero in FF), ``P_k``, the transition ``Phi_k`` from ``k - 1`` to
``k`` and the prediction ``P_k-``. :mod:`inins.ekf.smoother` runs backwards on it.
"""

import math
from dataclasses import dataclass, field

import numpy as np

from inins.core import earth, error_model, jit, rotation, stats, strapdown
from inins.ekf import aiding, kernels, step
from inins.exceptions import InputError

BLOCK = 512
"""Epochs the compiled kernel runs per call (the store is written block by block)."""
_HOME = np.zeros(8)


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
    gate_probability : float
        Chi-square(1) gate of each scalar row.
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
    gate_probability: float = 0.9999
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
        for name in ("nhc_sigma", "zupt_sigma", "zaru_sigma", "odometer_sigma"):
            if not 0.0 <= getattr(self, name) < 100.0:
                raise InputError("aiding sigma must be in [0, 100) (0: off)", key=name)
        mount = np.asarray(self.mounting, float).reshape(3)
        object.__setattr__(self, "mounting", mount)
        if not 0.0 < self.time_offset_sigma < 100.0:
            raise InputError("time offset sigma must be in (0, 100) s", key="time_offset_sigma")

    @property
    def n_base(self):
        """Error states without the time offset (15 or 24)."""
        return 24 if self.misalignments else 15

    @property
    def n(self):
        """All states."""
        return self.n_base + int(self.time_offset)

    @property
    def keep(self):
        """Indices of the states in the EKF26 order of :mod:`inins.ekf.kernels`."""
        return np.r_[0:15, 17:26] if self.misalignments else np.arange(15)

    def covariance0(self):
        """Diagonal ``P0`` (n, n)."""
        s = list(self.sigma0) + ([self.time_offset_sigma] if self.time_offset else [])
        return np.diag(np.square(s))

    def c_vb(self):
        """IMU body to vehicle axes (3, 3) from the mounting roll, pitch, yaw."""
        return rotation.mat_from_euler(*self.mounting)

    def noise(self):
        """Densities in the order of :func:`inins.ekf.step.propagate` (clock PSDs zero)."""
        return np.concatenate([self.arw, self.vrw, self.accel_bias_rw, self.gyro_bias_rw, [0, 0]])


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


@jit.njit(cache=True)
def _skew_rows(H, row, col, a, sign):
    """``H[row:row+3, col:col+3] = sign [a x]``."""
    H[row, col + 1] = -sign * a[2]
    H[row, col + 2] = sign * a[1]
    H[row + 1, col] = sign * a[2]
    H[row + 1, col + 2] = -sign * a[0]
    H[row + 2, col] = -sign * a[1]
    H[row + 2, col + 1] = sign * a[0]


@jit.njit(cache=True)
def _block(
    dtheta,
    dv,
    dt,
    quat,
    vel,
    lla,
    prev,
    count,
    comp,
    x,
    P,
    state,
    ep_end,
    ep_frac,
    ep_pos,
    ep_var,
    ep_vel,
    ep_var_vel,
    ep_use,
    ep_stat,
    ep_odo,
    aid_sig,
    c_vb,
    lever,
    noise,
    keep,
    n_base,
    td,
    threshold,
    feedback,
    window,
    o_quat,
    o_vel,
    o_lla,
    o_comp,
    o_x,
    o_r,
    o_P,
    o_Pp,
    o_Phi,
    o_y,
    o_s,
    o_acc,
    o_aid,
):
    """Run the epochs of one block (module docstring); state arrays updated in place.

    ``ep_end[k]``: samples of ``dtheta`` up to epoch ``k``'s boundary (increasing);
    ``ep_frac[k]``: ``t_k`` minus that boundary (s). ``state[0]``: time (s) of the
    last epoch (``-inf`` before the first: no propagation then).
    ``ep_pos`` are ECEF positions (m). Rows of ``o_y``, ``o_s``, ``o_acc``: pos N,
    E, D, vel N, E, D (NaN / False when unused).
    """
    n = x.shape[0]
    nf = 26 if n_base == 24 else 17
    Ff, Qf = np.zeros((nf, nf)), np.zeros((nf, nf))
    Phi, Qd, F, Qc = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    rates = np.zeros((2, 3))
    start = 0
    cq, cv, cl = np.empty(4), np.empty(3), np.empty(3)
    w = earth.RATE
    for k in range(ep_end.shape[0]):
        hi = ep_end[k]
        m = hi - start
        if feedback:
            dth, dvv = step.compensate(dtheta[start:hi], dv[start:hi], dt, comp)
        else:
            dth, dvv = dtheta[start:hi].copy(), dv[start:hi].copy()
        sq, sv, sl = quat.copy(), vel.copy(), lla.copy()
        oi = np.empty(m, np.int64)
        oq, ov, ol = np.empty((m, 4)), np.empty((m, 3)), np.empty((m, 3))
        if m > 0:
            strapdown._navigate(
                quat,
                vel,
                lla,
                prev,
                count[0],
                dth,
                dvv,
                dt,
                0,
                True,
                True,
                1,
                _HOME,
                oi,
                oq,
                ov,
                ol,
            )
            count[0] += m
        t_k = state[1] + hi * dt + ep_frac[k]  # state[1]: time of the block's sample 0
        dt_k = t_k - state[0]
        for i in range(n):
            for j in range(n):
                Phi[i, j] = 1.0 if i == j else 0.0
        if math.isfinite(state[0]) and dt_k > 0.0:
            mid = m - math.floor(0.5 * dt_k / dt + 0.5)
            if mid <= 0 or m == 0:
                mq, mv, ml = sq, sv, sl
                mid = 0
            else:
                mq, mv, ml = oq[mid - 1], ov[mid - 1], ol[mid - 1]
            step.mean_rates(dth, dvv, mid, window, dt, rates)
            kernels.system_matrix26(
                ml[0], ml[2], mv, rates[1], step.mat_from_quat(mq), rates[0], Ff
            )
            kernels.noise26(
                step.mat_from_quat(mq),
                noise[0:3],
                noise[3:6],
                noise[6:9],
                noise[9:12],
                0.0,
                0.0,
                Qf,
            )
            F.fill(0.0)
            Qc.fill(0.0)
            for i in range(n_base):
                for j in range(n_base):
                    F[i, j] = Ff[keep[i], keep[j]]
                    Qc[i, j] = Qf[keep[i], keep[j]]
            if td >= 0:
                Qc[td, td] = 1e-12
            kernels.discretize(F, Qc, dt_k, Phi, Qd)
            kernels.predict(x, P, Phi, Qd)
        o_Phi[k] = Phi
        o_Pp[k] = P
        state[0] = t_k
        # INS state at t_k: after the boundary, carried by v * frac
        step.mean_rates(dth, dvv, m, window, dt, rates)
        o_y[k].fill(np.nan)
        o_s[k].fill(np.nan)
        o_acc[k].fill(False)
        if ep_use[k]:
            step.correct(quat, vel, lla, x, cq, cv, cl)
            mat_nb = step.mat_from_quat(cq)
            w_ie = np.array([w * math.cos(cl[0]), 0.0, -w * math.sin(cl[0])])
            omega_eb = rates[0] - mat_nb.T @ w_ie
            lever_n = mat_nb @ lever
            u_n = mat_nb @ np.cross(omega_eb, lever)
            m_en = step.mat_en(cl[0], cl[1])
            lag = ep_frac[k] + (x[td] if td >= 0 else 0.0)
            r_ant = step.ecef(cl) + m_en @ (lever_n + cv * lag)
            d_n = m_en.T @ (ep_pos[k] - r_ant)
            has_vel = math.isfinite(ep_vel[k, 0])
            rows = 6 if has_vel else 3
            H = np.zeros((rows, n))
            y0, r = np.empty(rows), np.empty(rows)
            for i in range(3):
                H[i, i] = -1.0
                y0[i] = d_n[i]
                r[i] = ep_var[k, i]
                if td >= 0:
                    H[i, td] = cv[i]
            _skew_rows(H, 0, 6, lever_n, -1.0)
            if has_vel:
                # acceleration (NED) carries the velocity over the lag: C_nb f_b + g
                a_n = mat_nb @ rates[1]
                a_n[2] += kernels._gravity(cl[0], cl[2])
                for i in range(3):
                    H[3 + i, 3 + i] = -1.0
                    y0[3 + i] = ep_vel[k, i] - cv[i] - u_n[i] - a_n[i] * lag
                    r[3 + i] = ep_var_vel[k, i]
                    if td >= 0:
                        H[3 + i, td] = a_n[i]
                _skew_rows(H, 3, 6, u_n, -1.0)
            acc = np.zeros(rows, np.bool_)
            yy, ss = np.empty(rows), np.empty(rows)
            kernels.sequential_update(x, P, H, y0, r, threshold, acc, yy, ss)
            for i in range(rows):
                o_y[k, i] = yy[i]
                o_s[k, i] = ss[i]
                o_acc[k, i] = acc[i]
        if aid_sig[0] > 0.0 or ep_stat[k] or (aid_sig[3] > 0.0 and math.isfinite(ep_odo[k])):
            omega = np.zeros(3)
            for j in range(m):
                for i in range(3):
                    omega[i] += dth[j, i]
            if m > 0:
                omega /= m * dt
            aiding.vehicle_update(
                x,
                P,
                quat,
                vel,
                lla,
                omega,
                c_vb,
                ep_stat[k],
                ep_odo[k],
                aid_sig,
                threshold,
                o_aid[k],
            )
        else:
            o_aid[k].fill(False)
        o_x[k] = x
        o_r[k].fill(0.0)
        if feedback:
            for i in range(9):
                o_r[k, i] = x[i]
            step.correct(quat, vel, lla, x, quat, vel, lla)
            for i in range(9):
                x[i] = 0.0
            for j in range(n_base - 9):
                comp[j] += x[9 + j]
                o_r[k, 9 + j] = x[9 + j]
                x[9 + j] = 0.0
        o_quat[k] = quat
        o_vel[k] = vel
        o_lla[k] = lla
        o_comp[k] = comp
        o_P[k] = P
        start = hi


def _ecef(lla):
    return earth.ecef_from_llh(lla[:, 0], lla[:, 1], lla[:, 2])


def default_store(name, shape, dtype=float):
    """The in-RAM store: a zero array (callers pass memory maps for long runs)."""
    return np.zeros(shape, dtype)


@dataclass(frozen=True, eq=False)
class LooseRun:
    """Forward run stored per epoch (arrays from the store; see module docstring).

    ``time`` (m,) s; ``quat`` (m, 4), ``vel`` (m, 3), ``lla`` (m, 3): ``N_k+``;
    ``comp`` (m, 15) sensor compensation; ``x``, ``r`` (m, n); ``P``, ``P_pred``,
    ``Phi`` (m, n, n); ``innovation``, ``variance`` (m, 6), ``accepted`` (m, 6) per
    pos N/E/D, vel N/E/D row; ``used`` (m,) bool; ``aided`` (m, 9) accepted vehicle
    rows (NHC y, z, ZUPT N, E, D, ZARU x, y, z, odometer); ``stationary`` (m,) the flag.
    """

    config: LooseConfig
    time: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    lla: np.ndarray
    comp: np.ndarray
    x: np.ndarray
    r: np.ndarray
    P: np.ndarray
    P_pred: np.ndarray
    Phi: np.ndarray
    innovation: np.ndarray
    variance: np.ndarray
    accepted: np.ndarray
    used: np.ndarray
    aided: np.ndarray
    stationary: np.ndarray

    def output(self):
        """Forward navigation output ``N+ (-) (x - r)`` (quat, vel, lla), sensor estimates
        ``comp + x - r`` on the sensor states (m, n - 9) and 1-sigma (m, n)."""
        e = self.x - self.r
        quat, vel, lla = _correct_many(self.quat, self.vel, self.lla, e)
        sens = self.comp[:, : self.config.n_base - 9] + e[:, 9 : self.config.n_base]
        sigma = np.sqrt(np.einsum("kii->ki", self.P))
        return quat, vel, lla, sens, sigma


def _correct_many(quat, vel, lla, dx):
    oq, ov, ol = np.empty_like(quat), np.empty_like(vel), np.empty_like(lla)
    _correct_all(
        np.ascontiguousarray(quat),
        np.ascontiguousarray(vel),
        np.ascontiguousarray(lla),
        np.ascontiguousarray(dx),
        oq,
        ov,
        ol,
    )
    return oq, ov, ol


@jit.njit(cache=True)
def _correct_all(quat, vel, lla, dx, oq, ov, ol):
    for k in range(quat.shape[0]):
        step.correct(quat[k], vel[k], lla[k], dx[k], oq[k], ov[k], ol[k])


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
    sol_t = solution.time
    sel = sol_t >= t0 - 1e-9
    if not np.any(sel):
        raise InputError("no GNSS solution after the IMU start", key="gnss")
    time, idx = _epoch_grid(sol_t[sel])
    m, n = time.size, cfg.n
    src = np.flatnonzero(sel)[np.maximum(idx, 0)]
    has = idx >= 0
    pos = _ecef(solution.lla[src])
    var = solution.sigma_ned[src] ** 2
    vel = np.where(has[:, None], solution.vel_ned[src], np.nan)
    var_vel = solution.sigma_vel[src] ** 2
    use = has.copy()
    for a, b in outages:
        use &= ~((time >= a) & (time < b))
    rel = time - t0
    end = np.round(rel / cfg.dt).astype(np.int64)
    frac = rel - end * cfg.dt
    names = {
        "quat": (m, 4),
        "vel": (m, 3),
        "lla": (m, 3),
        "comp": (m, 15),
        "x": (m, n),
        "r": (m, n),
        "P": (m, n, n),
        "P_pred": (m, n, n),
        "Phi": (m, n, n),
        "innovation": (m, 6),
        "variance": (m, 6),
    }
    out = {k: store(k, s) for k, s in names.items()}
    out["accepted"] = store("accepted", (m, 6), np.bool_)
    out["aided"] = store("aided", (m, 9), np.bool_)
    out["stationary"] = store("stationary", (m,), np.bool_)
    aid_sig = np.array([cfg.nhc_sigma, cfg.zupt_sigma, cfg.zaru_sigma, cfg.odometer_sigma])
    odo = np.full(m, np.nan)
    if odometer is not None:
        o_t, o_v = (np.asarray(a, float) for a in odometer)
        inside = (time >= o_t[0]) & (time <= o_t[-1])
        odo[inside] = np.interp(time[inside], o_t, o_v)
    c_vb = cfg.c_vb()
    want_stat = cfg.zupt_sigma > 0 or cfg.zaru_sigma > 0
    if stationary_windows is not None:
        stat_all = np.zeros(m, np.bool_)
        for a, b in stationary_windows:
            stat_all |= (time >= a) & (time < b)
    quat, velo, lla = initial.quat_nb.copy(), initial.vel_n.copy(), initial.lla.copy()
    prev = np.concatenate([initial.dtheta_prev, initial.dv_prev])
    count = np.array([initial.count], np.int64)
    comp, x, P = np.zeros(15), np.zeros(n), cfg.covariance0()
    state = np.array([t0, 0.0])  # the first epoch propagates from t0
    threshold = float(stats.chi2_ppf(cfg.gate_probability, 1))
    noise, keep = cfg.noise(), cfg.keep.astype(np.int64)
    td = cfg.n_base if cfg.time_offset else -1
    lever = cfg.lever_arm
    sample0 = 0
    for lo in range(0, m, BLOCK):
        hi = min(lo + BLOCK, m)
        last = int(end[hi - 1])
        dtheta, dv = imu(sample0, last)
        if dtheta.shape[0] != last - sample0:
            raise InputError(
                f"IMU record ends before the GNSS epoch at {time[hi - 1]:.3f} s", key="imu"
            )
        state[1] = t0 + sample0 * cfg.dt
        buf = {k: np.empty((hi - lo, *s[1:])) for k, s in names.items()}
        acc = np.zeros((hi - lo, 6), np.bool_)
        aided = np.zeros((hi - lo, 9), np.bool_)
        if not want_stat:
            stat = np.zeros(hi - lo, np.bool_)
        elif stationary_windows is not None:
            stat = stat_all[lo:hi]
        else:
            stat = aiding.stationary(
                dtheta,
                dv,
                cfg.dt,
                end[lo:hi] - sample0,
                max(round(cfg.stationary_window / cfg.dt), 2),
                cfg.stationary_accel,
                cfg.stationary_gyro,
            )
        _block(
            np.ascontiguousarray(dtheta, float),
            np.ascontiguousarray(dv, float),
            cfg.dt,
            quat,
            velo,
            lla,
            prev,
            count,
            comp,
            x,
            P,
            state,
            end[lo:hi] - sample0,
            frac[lo:hi],
            pos[lo:hi],
            var[lo:hi],
            np.ascontiguousarray(vel[lo:hi]),
            np.ascontiguousarray(var_vel[lo:hi]),
            use[lo:hi],
            stat,
            odo[lo:hi],
            aid_sig,
            c_vb,
            lever,
            noise,
            keep,
            cfg.n_base,
            td,
            threshold,
            cfg.feedback,
            cfg.window,
            buf["quat"],
            buf["vel"],
            buf["lla"],
            buf["comp"],
            buf["x"],
            buf["r"],
            buf["P"],
            buf["P_pred"],
            buf["Phi"],
            buf["innovation"],
            buf["variance"],
            acc,
            aided,
        )
        out["aided"][lo:hi] = aided
        out["stationary"][lo:hi] = stat
        for k, v in buf.items():
            out[k][lo:hi] = v
        out["accepted"][lo:hi] = acc
        sample0 = last
    return LooseRun(config=cfg, time=time, used=use, **out)


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
