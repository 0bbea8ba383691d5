"""Tightly coupled INS/GPS EKF run (003): EKF1/EKF2, FF/FB, 1PPS timing, gating, outages.

Per epoch ``k`` (1PPS time ``t_k``, data arriving at ``t_k + tau``):

1. Strapdown (the compiled kernel of :func:`inins.core.strapdown.integrate`) over the
   IMU chunk up to the arrival; in FB the increments are first compensated with the
   cumulative sensor estimates, ``omega = (I - M_g) (omega_meas - b_g)`` (and alike
   for the accelerometers). The INS state after ``pps_index`` samples is the one
   stored at the PPS (003 §2.1).
2. Propagation over ``[t_{k-1}, t_k]``: ``F`` at the state in the middle of the
   interval with ``f_b``, ``omega_b`` moving-averaged over the dither window
   (003 §2.2, ``f_n = C_nb f_b`` eq. 6); third-order ``Phi``, series ``Qd``
   (:func:`inins.ekf.kernels.discretize`). When the rates change fast within the
   interval (a roll transient: ``omega_b`` or ``f_b`` at the middles of
   :data:`SUB_STEPS` sub-intervals differ from the mid-interval value by more than
   :data:`RATE_CHANGE` or :data:`FORCE_CHANGE`), ``F`` and ``Qd`` are evaluated
   on each sub-interval and the prediction made sub-interval by sub-interval.
3. Update at ``t_k`` with the stored state: scalar Joseph updates per pseudorange
   and range rate, each gated on chi-square(1) (:func:`inins.ekf.kernels.sequential_update`).
   The measurement is predicted at the corrected INS state ``nav (-) x``; epochs
   without satellites or inside an outage window are coasted. With several systems
   (:attr:`inins.ekf.config.FilterConfig.systems`) a pseudorange of a further system
   also has 1 at its inter-system bias state (appended after the 17 or 26 states,
   random walk, never reset by the feedback; docs/gnss.md).
4. FF: nothing else; the output is ``nav (-) x``. FB: the correction, carried over
   the latency by ``I + F tau``, is applied to the current INS state, the sensor
   estimates are added to the compensation, those states reset to zero and the
   cumulative corrections logged (003 §3.3.2).

``nav (-) dx``: ``lat - dr_N / (R_N + h)``, ``lon - dr_E / ((R_E + h) cos lat)``,
``h + dr_D``, ``v - dv``, ``mat_nb <- exp([phi x]) mat_nb`` (the phi-angle error
``mat_nb_est = (I - [phi x]) mat_nb_true`` of :mod:`inins.core.error_model`).

Epoch time: with 1PPS storage the update and the logged solution refer to the PPS
``t_k``; with the naive pairing (``pps_storage`` false) they refer to the INS state
at the data arrival ``t_k + tau``, and the result is labelled with that time and
scored against the truth there (the measurements of ``t_k`` pulled onto the state
of ``t_k + tau`` leave it ``v tau`` behind along track, which a score at ``t_k``
hides).

All four steps of an epoch, and its log, are the compiled :func:`inins.ekf.fused.epoch`,
which composes the building-block kernels of :mod:`inins.ekf.step` (the per-epoch
Python glue of one call per block cost as much as the arithmetic;
``tests/ekf/test_fused_epoch.py`` holds it bit for bit to that loop). The epochs run
:data:`BATCH` at a time through one call of :func:`inins.ekf.fused.epochs` (its
arguments a few packed records: a call costs some microseconds through numba's
dispatcher, against some 33 us of arithmetic an epoch). The kernel writes a batch into
reused buffers; its rows are copied into the run's log (arrays doubled when full).

With truth (simulation) the output error, the heading error and the NEES of all
states are computed batch by batch as the run goes (:func:`inins.ekf.scoring.epoch_errors`,
vectorised over the batch's epochs), from the batch's ``P``, which is then dropped: the
run keeps no ``P`` (memory flat in flight length beyond the output rows) unless the
caller hands it an array for them (``covariance``) or a smoother's store. The
navigation states estimate the INS error, so their estimation error is minus the output
error.
"""

import functools
import itertools
import operator
import time as _time

import numpy as np

from inins.core.satellites import LETTERS
from inins.core.stats import chi2_ppf
from inins.core.strapdown import FreeInertial
from inins.ekf import epoch_log, fused, scoring, step
from inins.ekf.config import Coupling
from inins.ekf.kernels import NAV
from inins.ekf.result import EkfResult
from inins.exceptions import InputError

SUB_STEPS = 10
"""Sub-intervals probed (and used when the rates change fast) per propagation."""
RATE_CHANGE = 5.0 * np.pi / 180.0
"""rad/s: a change of ``omega_b`` within an interval beyond this splits the propagation
(the bank ripple of a turn flown as 15-deg track steps stays below; a roll in or out
within a second, ~100 deg/s, is far above)."""
FORCE_CHANGE = 2.0
"""m/s^2: a change of ``f_b`` within an interval beyond this splits the propagation."""
BATCH = 32
"""Epochs per call of the compiled :func:`inins.ekf.fused.epochs` (one with a smoother's store)."""
_GNSS_ARRAYS = operator.attrgetter(
    "prn",
    "sat_pos",
    "sat_vel",
    "pseudorange",
    "sat_clock",
    "delay",
    "range_rate",
    "sat_clock_drift",
    "sigma_pr",
    "sigma_rr",
)
"""The :class:`~inins.ekf.measurements.GnssEpoch` arrays :func:`inins.ekf.fused.epochs` takes,
in its order (the fields of :data:`inins.ekf.rows.Satellites`)."""


_SENSORS = ("accel_bias", "gyro_bias", "accel_misalignment", "gyro_misalignment")


def _sensor_index(layout):
    """Sensor states of ``layout`` (EKF17 or EKF26) in ``comp`` order ``[ba, bg, ma, mg]``."""
    groups = [g for g in _SENSORS if g in layout.groups()]
    return np.concatenate([np.arange(layout.size)[layout.slice(g)] for g in groups])


def correct(quat, vel, lla, dx):
    """Navigation state minus the error estimate ``dx`` (first 9 states), module docstring.

    Returns quat (4,), vel (3,), lla (3,) as new arrays.
    """
    out = np.empty(4), np.empty(3), np.empty(3)
    step.correct(
        np.asarray(quat, float),
        np.asarray(vel, float),
        np.asarray(lla, float),
        np.asarray(dx, float),
        *out,
    )
    return out


class _Run:
    """Mutable state of one filter run (kept out of the public API): the records the
    compiled epochs take (:data:`inins.ekf.step.Ins`, :data:`~inins.ekf.fused.TightState`,
    :data:`~inins.ekf.fused.TightModel`)."""

    def __init__(self, config, initial, t0, keep):
        self.cfg = config
        n = self.n = len(config.layout)
        base = len(config.model.layout)  # 17 or 26; inter-system biases after them
        self.nav = FreeInertial(initial)
        home = np.zeros(8)  # Earth terms of the strapdown's fixed modes; unused (free)
        self.ins = step.Ins(self.nav.quat, self.nav.vel, self.nav.lla, self.nav.prev, home)
        self.state = fused.TightState(
            x=np.zeros(n),
            P=config.initial_sigma.covariance(base, n - base),
            mats=np.zeros((7, n, n)),  # slots fused.F_ ... (F, Qc, Phi, Qd, store)
            comp=np.zeros(15),
            cum=np.zeros(NAV),
            rates=np.zeros((2, 3)),  # omega_b, f_b at the last PPS (dither-filtered)
            rates_sub=np.zeros((SUB_STEPS + 1, 2, 3)),
            kept=np.zeros(n + 25),  # a smoother's store: x, INS state, compensation
        )
        noise = np.concatenate(
            [
                config.arw,
                config.vrw,
                config.accel_bias_rw,
                config.gyro_bias_rw,
                [config.clock_bias_psd, config.clock_drift_psd],
                [config.system_bias_psd] * (n - base),
            ]
        )
        self.model = fused.TightModel(
            dt=float(config.dt),
            window=int(config.dither_window),
            noise=noise,
            lever=np.asarray(config.lever_arm, dtype=float),
            limits=np.array([RATE_CHANGE, FORCE_CHANGE]),
            # chi-square(1) quantile: P(chi2_1 <= threshold) = gate_probability
            threshold=float(chi2_ppf(config.gate_probability, 1)),
            use_rr=bool(config.use_range_rate),
            fb=config.coupling is Coupling.FB,
            keep=keep,
            sens=_sensor_index(config.model.layout),
            bias_columns=config.bias_columns(),
        )
        # the records as plain tuples for the compiled call (fused.epochs names them)
        self.packed = (tuple(self.ins), tuple(self.state), tuple(self.model))


def _batches(epochs, size):
    """Lists of ``size`` consecutive epochs of ``epochs`` (the last may be shorter)."""
    stream = iter(epochs)
    while batch := list(itertools.islice(stream, size)):
        yield batch


def _refuse_systems(gnss, bias_columns, systems):
    """The error for an epoch with satellites of a system the filter does not take."""
    system = gnss.system
    column = np.where(system < bias_columns.size, bias_columns[system % bias_columns.size], -2)
    letters = sorted({LETTERS[i] if i < len(LETTERS) else str(i) for i in system[column < -1]})
    raise InputError(
        f"satellites of system {''.join(letters)} at t = {gnss.time:.3f} s, which the "
        f"filter does not take (systems {systems})",
        key="systems",
    )


def _store(store, row, run, time, feedback):
    """Hand a smoother's store the epoch's record (:func:`inins.ekf.fused.epoch`, ``keep``)."""
    mats, kept, n, sens = run.state.mats, run.state.kept, run.n, run.model.sens
    store.predicted(mats[fused.P_PRED], mats[fused.PHI_K])
    store.updated(
        time,
        kept[:n],
        mats[fused.P_UPD],
        np.r_[0:NAV, sens],
        feedback,
        (kept[n : n + 4], kept[n + 4 : n + 7], kept[n + 7 : n + 10]),
        (
            row[fused.LOG_QUAT : fused.LOG_QUAT + 4],
            row[fused.LOG_VEL : fused.LOG_VEL + 3],
            row[fused.LOG_LLA : fused.LOG_LLA + 3],
        ),
        kept[n + 10 : n + 25],
    )


def run_filter(
    config, initial, t0, epochs, true_sensor=None, store=None, covariance=None, capacity=None
):
    """Run the tightly coupled filter over a stream of epochs (module docstring).

    Each epoch is the compiled :func:`inins.ekf.fused.epoch` (strapdown, propagation,
    update, feedback and the epoch's log), :data:`BATCH` epochs per call of
    :func:`inins.ekf.fused.epochs` into reused batch buffers; this loop only gathers
    the epochs' fields, copies each batch's rows into the run's log, scores the batch
    against its truth (the NEES from the batch's ``P``, which is then dropped: memory
    does not grow with ``P``) and hands a smoother's store its record (then one epoch
    per call).

    Parameters
    ----------
    config : inins.ekf.config.FilterConfig
    initial : inins.core.strapdown.NavState
        Aligned INS state at ``t0`` (e.g. from :func:`inins.ekf.flight.gyrocompass_attitude`).
    t0 : float
        Time of ``initial`` (s), on the IMU time axis of the epochs.
    epochs : iterable of inins.ekf.config.EpochInput
        Consecutive chunks, PPS times increasing; consumed once (may be a generator).
        With truth (:class:`~inins.ekf.config.TruthEpoch`) each batch is scored as the
        run goes (:func:`inins.ekf.scoring.epoch_errors`); with the naive pairing the
        truth needs its ``at_arrival``.
    true_sensor : inins.core.imu.SensorErrors, optional
        Constant true sensor errors, for the NEES of the sensor states when the
        epochs carry truth.
    store : inins.ekf.tight_store.TightStore, optional
        Records what an RTS smoother needs per epoch.
    covariance : ndarray (k, n, n), optional
        Takes ``P`` after the update of each epoch (``k`` at least the epochs; the
        caller's array, e.g. memory-mapped): only where ``P`` itself is wanted.
    capacity : int, optional
        The epochs expected: the log is allocated for them at once (no array copied
        as it grows; more epochs grow it by doubling).

    Returns
    -------
    inins.ekf.result.EkfResult

    Raises
    ------
    inins.exceptions.InputError
        If no epoch had a satellite (nothing to couple with).
    """
    cfg = config
    keep = store is not None
    run = _Run(config, initial, t0, keep)
    size = 1 if keep else BATCH  # a smoother's store takes each epoch's record
    buffers, log = epoch_log.Buffers(run.n, size), epoch_log.Log(run.n, covariance, capacity)
    scorer = functools.partial(
        scoring.epoch_errors,
        true_sensor=true_sensor,
        layout=cfg.layout,
        pps_storage=cfg.pps_storage,
        systems=cfg.systems,
    )
    wall = 0.0  # the filter's own time: producing the epochs (simulation, file) is not counted
    clock = _Clock(t0)
    for batch in _batches(epochs, size):
        start_wall = _time.perf_counter()
        first = log.m
        b = _Batch(batch, cfg, clock, covariance is not None)
        tick = _time.perf_counter()
        written = fused.epochs(
            run.packed[0],
            run.nav.count,
            run.packed[1],
            run.packed[2],
            b.dtheta,
            b.dv,
            b.starts,
            b.times,
            b.flags,
            b.sats,
            b.sat_starts,
            buffers.record(2 * b.sat_starts[-1]),
            0,
            0,
        )
        if written < 0:
            _refuse_systems(batch[-1 - written].gnss, run.model.bias_columns, cfg.systems)
        run.nav.count += b.starts[-1]
        log.take(buffers, b.size, written, (_time.perf_counter() - tick) / b.size)
        if keep:
            _store(store, buffers.flog[0], run, clock.t_prev, b.fed_back)
        wall += _time.perf_counter() - start_wall
        log.score(buffers, first, b.truths, scorer)  # not the filter's time
    epochs_log = log.epochs()
    if epochs_log.n_sats.size and epochs_log.n_sats.max() == 0:
        raise InputError("no satellites above the mask in any epoch of the run", key="gnss")
    result = EkfResult.from_log(cfg, epochs_log, clock.t_end - t0, wall)
    truth = log.truth()
    return result if truth is None else result.with_truth(*truth)


class _Clock:
    """The times a run carries from epoch to epoch: the last state's time, the last data
    arrival, whether the receiver clock is set."""

    def __init__(self, t0):
        self.t_prev = self.t_end = t0
        self.ready = False


class _Batch:
    """A batch of epochs gathered into the arrays :func:`inins.ekf.fused.epochs` takes."""

    def __init__(self, batch, cfg, clock, keep_all):
        pps, outages = cfg.pps_storage, bool(cfg.outages)
        times, flags, samples, satellites, truths = [], [], [0], [0], []
        increments, satellite_arrays = ([], []), []
        coasted = True
        for j, ep in enumerate(batch):
            gnss = ep.gnss
            t_k, arrival, k = gnss.time, gnss.arrival, gnss.prn.size
            length = len(ep.dtheta)
            # naive pairing updates the state at arrival itself: nothing to carry over
            tau, t_state, p = (arrival - t_k, t_k, ep.pps_index) if pps else (0.0, arrival, length)
            coasted = k == 0 or (outages and cfg.in_outage(t_k))
            truth = ep.truth is not None
            times += (t_state, t_k, t_state - clock.t_prev, tau)
            flags += (p, coasted, not clock.ready, truth or keep_all)
            samples.append(samples[-1] + length)
            satellites.append(satellites[-1] + k)
            increments[0].append(ep.dtheta)
            increments[1].append(ep.dv)
            satellite_arrays.append(_GNSS_ARRAYS(gnss))
            if truth:
                truths.append((j, ep.truth))
            clock.ready = clock.ready or not coasted
            clock.t_prev, clock.t_end = t_state, arrival
        self.size = len(batch)
        self.dtheta, self.dv = (np.concatenate(c, dtype=float) for c in increments)
        self.starts = np.array(samples)
        self.times = np.array(times).reshape(self.size, 4)
        self.flags = np.array(flags, np.int64).reshape(self.size, 4)
        # the fields of inins.ekf.rows.Satellites, a plain tuple (fused.epochs names it)
        self.sats = tuple(np.concatenate(c) for c in zip(*satellite_arrays, strict=True))
        self.sat_starts = np.array(satellites)
        self.truths = truths
        self.fed_back = cfg.coupling is Coupling.FB and not coasted  # (the last epoch)


def warm_up():
    """Compile (or load from the on-disk cache) the fused epoch kernel
    (:func:`inins.ekf.fused.epochs`) with the argument types every run passes: two epochs
    of four satellites."""
    from inins.core.strapdown import NavState
    from inins.ekf.config import EpochInput, FilterConfig, Model
    from inins.ekf.measurements import GnssEpoch

    initial = NavState.from_attitude(np.eye(3), np.zeros(3), np.array([0.6, 2.2, 100.0]))
    sats = np.array([[0.6, 0.5, 0.6], [0.7, 0.7, 0.1], [0.8, 0.2, 0.56], [0.5, 0.8, 0.33]]) * 2.6e7
    z = np.zeros(4)
    epochs = [
        EpochInput(
            np.zeros((2, 3)),
            np.zeros((2, 3)),
            2,
            GnssEpoch(
                0.02 * k, np.arange(1, 5), sats, 0.0 * sats, z, z, z + 2.2e7, z, z + 1, z + 1
            ),
        )
        for k in (1, 2)
    ]
    run_filter(FilterConfig(Model.EKF2, Coupling.FB, 0.01), initial, 0.0, epochs)
