"""The fused epoch of the tightly coupled filter: steps 1-4 of :mod:`inins.ekf.filter`
(strapdown, propagation, update at the 1PPS state, FB feedback) and the epoch's log in
one compiled function (:func:`epoch`), run over a batch of epochs by :func:`epochs`.

It composes the building blocks of :mod:`inins.ekf.step` in the order the Python loop
called them (``tests/ekf/test_fused_epoch.py`` holds it bit for bit to that loop). The
kernels take a few packed records, named tuples of arrays (:data:`inins.ekf.step.Ins`,
:data:`TightState`, :data:`TightModel`, :data:`Log`, :data:`inins.ekf.rows.Satellites`),
instead of fifty positional arguments; states are addressed by the named blocks of
:mod:`inins.ekf.kernels`.
"""

from collections import namedtuple

import numpy as np

from inins.core import jit, strapdown
from inins.ekf import rows
from inins.ekf.kernels import NAV
from inins.ekf.step import (
    Ins,
    compensate,
    correct,
    feedback,
    mean_rates,
    mean_rates_at,
    propagate,
    rates_change,
    update,
)

TightState = namedtuple("TightState", "x P mats comp cum rates rates_sub kept")
"""The filter's state, updated in place: ``x`` (n,), ``P`` (n, n), the work matrices
``mats`` (7, n, n) (slots :data:`F_` ...), the FB compensation ``comp`` (15,) and
cumulative navigation corrections ``cum`` (9,), the dither-filtered rates ``rates``
(2, 3) and ``rates_sub`` (j + 1, 2, 3) of the ``j`` sub-intervals, and ``kept``
(n + 25,), a smoother's record of the epoch (:func:`epoch`)."""
TightModel = namedtuple(
    "TightModel", "dt window noise lever limits threshold use_rr fb keep sens bias_columns"
)
"""Settings of a run: IMU interval ``dt`` (s), dither ``window`` (samples), ``noise`` of
:func:`propagate`, ``lever`` (3,) m, ``limits`` of :func:`rates_change`, the gate
``threshold``, ``use_rr``, ``fb``, ``keep`` (a smoother's store), ``sens`` the sensor
states in ``comp`` order, ``bias_columns`` the inter-system bias state of each system
(:meth:`inins.ekf.config.FilterConfig.bias_columns`: -1 the reference, -2 a system the
filter does not take)."""
Log = namedtuple("Log", "flog ilog cov inn_f inn_i")
"""Where epochs are logged: ``flog`` (m, 13 + 3 n) (columns :data:`LOG_TIME` ...),
``ilog`` (m, 4) int (:data:`N_SATS` ...), ``cov`` (j, n, n), the innovation rows
``inn_f`` (r, 2) (value, variance) and ``inn_i`` (r, 4) int (epoch, prn, kind 0
pseudorange / 1 range rate, accepted)."""

# The fused epoch (:func:`epoch`): slots of its matrix work array and columns of its logs.
F_, QC, PHI, QD, P_PRED, PHI_K, P_UPD = range(7)
"""Slots of ``mats`` (7, n, n): the model, its noise, transition and discrete noise of
the last (sub-)interval, then what a smoother's store keeps: ``P`` predicted, the
interval's ``Phi_k`` (the product over sub-intervals) and ``P`` updated."""
LOG_TIME, LOG_GNSS_TIME, LOG_NIS, LOG_QUAT, LOG_VEL, LOG_LLA, LOG_STATE = 0, 1, 2, 3, 7, 10, 13
"""Columns of an epoch's row of ``flog`` (13 + 3 n): the time the state refers to, the
PPS, the NIS sum, the output quaternion, velocity, position, then the state estimate
(sensor totals), its 1-sigma and the cumulative corrections (``n`` each)."""
N_SATS, N_USED, N_REJECTED, COASTED = 0, 1, 2, 3
"""Columns of an epoch's row of ``ilog`` (4, int)."""
T_STATE, T_K, DT_K, TAU = 0, 1, 2, 3
"""Columns of a batch's ``times`` (:func:`epochs`): the arguments of :func:`epoch`."""
PPS_INDEX, IS_COASTED, INIT_CLOCK, KEEP_COV = 0, 1, 2, 3
"""Columns of a batch's ``flags`` (:func:`epochs`): ``p``, ``coasted``, ``init_clock``,
``keep_cov`` of :func:`epoch` (0 or 1 but the first)."""


@jit.njit(cache=True, error_model="numpy")
def _state_at(start_q, start_v, start_l, out_q, out_v, out_l, index):
    """(quat, vel, lla) after ``index`` samples of a chunk (0: the chunk start)."""
    if index == 0:
        return start_q, start_v, start_l
    return out_q[index - 1], out_v[index - 1], out_l[index - 1]


@jit.njit(cache=True, error_model="numpy")
def _strapdown(ins, count, dth, dvc, dt):
    """The INS over a chunk (free mode, coning and sculling, every sample), in place;
    the states after each sample (quat, vel, lla), each (s, .)."""
    samples = dth.shape[0]
    out_q, out_v, out_l = np.empty((samples, 4)), np.empty((samples, 3)), np.empty((samples, 3))
    strapdown._navigate(
        ins.quat,
        ins.vel,
        ins.lla,
        ins.prev,
        count,
        dth,
        dvc,
        dt,
        0,  # free navigation
        True,
        True,
        1,
        ins.home,
        np.empty(samples, np.int64),
        out_q,
        out_v,
        out_l,
    )
    return out_q, out_v, out_l


@jit.njit(cache=True, error_model="numpy")
def _propagate_interval(state, model, start, out, dth, dvc, p, dt_k):
    """Step 2 of :func:`epoch`: the prediction over ``dt_k`` ending at sample ``p``, split
    into sub-intervals when the rates change fast within it; ``start`` and ``out`` the
    INS state at the chunk start and after each sample."""
    mats, rates_sub = state.mats, state.rates_sub
    F, Qc, Phi, Qd = mats[F_], mats[QC], mats[PHI], mats[QD]
    sub = rates_sub.shape[0] - 1
    span = round(dt_k / model.dt)
    probes = np.empty(sub + 1, np.int64)  # sub-interval middles, then the interval's
    for j in range(sub):
        probes[j] = max(p - (span - (2 * j + 1) * span // (2 * sub)), 0)
    probes[sub] = max(p - round(0.5 * dt_k / model.dt), 0)
    mean_rates_at(dth, dvc, probes, model.window, model.dt, rates_sub)
    split = dt_k > 0.0 and rates_change(rates_sub, model.limits)
    x, P, noise = state.x, state.P, model.noise
    if not split:
        q, v, l = _state_at(*start, *out, probes[sub])
        propagate(x, P, F, Qc, Phi, Qd, q, v, l, rates_sub[sub, 0], rates_sub[sub, 1], dt_k, noise)
        if model.keep:
            mats[PHI_K] = Phi
        return
    total = mats[PHI_K]
    if model.keep:
        total[:] = np.eye(x.shape[0])
    for j in range(sub):
        if model.keep and j:
            total[:] = Phi @ total
        q, v, l = _state_at(*start, *out, probes[j])
        propagate(
            x, P, F, Qc, Phi, Qd, q, v, l, rates_sub[j, 0], rates_sub[j, 1], dt_k / sub, noise
        )
    if model.keep:
        total[:] = Phi @ total


@jit.njit(cache=True, error_model="numpy")
def _log_update(state, model, coasted, sats, init_clock, nav, log, index, inn_start):
    """Step 3 of :func:`epoch`: the update at the stored state ``nav`` (unless
    ``coasted``) and its innovation rows; returns the rows written, or -1 if a satellite
    is of a system the filter does not take."""
    k = sats.pos.shape[0]
    flag = log.ilog[index]
    flag[N_SATS], flag[N_USED], flag[N_REJECTED], flag[COASTED] = k, 0, 0, coasted
    row = log.flog[index]
    row[LOG_NIS] = 0.0
    if coasted:
        return 0
    bias_col = np.empty(k, np.int64)
    for i in range(k):
        system = sats.prn[i] // 100  # inins.ekf.measurements.GnssEpoch.system
        columns = model.bias_columns
        column = columns[system] if 0 <= system < columns.size else -2
        if column < -1:
            return -1
        bias_col[i] = column
    used_rows = 2 * k if model.use_rr else k
    acc = np.zeros(used_rows, dtype=np.bool_)
    y, s = np.empty(used_rows), np.empty(used_rows)
    update(state.x, state.P, nav, state.rates[0], model, sats, bias_col, init_clock, (acc, y, s))
    used = 0
    for j in range(used_rows):
        i = j if model.use_rr else 2 * j  # row 2 i pseudorange, 2 i + 1 range rate
        log.inn_f[inn_start + j, 0], log.inn_f[inn_start + j, 1] = y[j], s[j]
        out = log.inn_i[inn_start + j]
        out[0], out[1], out[2], out[3] = index, sats.prn[i // 2], i % 2, acc[j]
        used += acc[j]
    flag[N_USED], flag[N_REJECTED] = used, used_rows - used
    row[LOG_NIS] = np.dot(y * y / s, acc.astype(np.float64))
    return used_rows


@jit.njit(cache=True, error_model="numpy")
def epoch(ins, count, state, model, dtheta, dv, times, flags, sats, log, index, inn_start):
    """One filter epoch (:mod:`inins.ekf.filter`, module docstring, steps 1-4) in place.

    The building blocks in the order :func:`inins.ekf.filter.run_filter` used to call
    them from Python: (FB) :func:`compensate`, the strapdown
    (:func:`inins.core.strapdown._navigate`, free mode, coning and sculling, every
    sample), :func:`mean_rates_at` and :func:`rates_change` at the sub-interval
    middles, :func:`propagate` once or per sub-interval, :func:`mean_rates` at the
    PPS, :func:`update` (unless coasted), :func:`correct` for the output, (FB)
    :func:`feedback`.

    Parameters
    ----------
    ins : Ins
        After ``count`` samples; updated in place.
    state : TightState
        Updated in place; with ``model.keep`` its ``kept`` (n + 25,) takes the updated
        ``x``, the INS (quat, vel, lla) at the update and the compensation after the
        reset, and ``mats`` the store slots (a smoother's store).
    model : TightModel
    dtheta, dv : ndarray (s, 3)
        Increments up to the data arrival.
    times : ndarray (4,)
        :data:`T_STATE` (the logged time), :data:`T_K` (the PPS), :data:`DT_K` (the
        interval to the state the update uses), :data:`TAU` (the FB latency), s.
    flags : ndarray (4,) int
        :data:`PPS_INDEX` (samples to the state the update uses), :data:`IS_COASTED`,
        :data:`INIT_CLOCK` (the first update sets the clock), :data:`KEEP_COV`.
    sats : inins.ekf.rows.Satellites
    log : Log
        Row ``index`` of ``flog`` and ``ilog``, ``cov[index]`` = ``P`` with
        :data:`KEEP_COV`, the innovation rows from ``inn_start`` on.

    Returns
    -------
    int
        The innovation rows written, or -1 (nothing updated or logged) if a satellite is
        of a system the filter does not take.
    """
    x, P, mats, comp = state.x, state.P, state.mats, state.comp
    n, p, dt_k = x.shape[0], flags[PPS_INDEX], times[DT_K]
    coasted = flags[IS_COASTED] != 0
    # 1. strapdown over the chunk (FB: compensated increments)
    if model.fb:
        dth, dvc = compensate(dtheta, dv, model.dt, comp)
    else:
        dth, dvc = dtheta, dv
    start = (ins.quat.copy(), ins.vel.copy(), ins.lla.copy())
    out = _strapdown(ins, count, dth, dvc, model.dt)
    # 2. propagation over dt_k, split when the rates change fast within it
    _propagate_interval(state, model, start, out, dth, dvc, p, dt_k)
    if model.keep:
        mats[P_PRED] = P
    # 3. update at the stored state
    q, v, l = _state_at(*start, *out, p)
    mean_rates(dth, dvc, p, model.window, model.dt, state.rates)
    init_clock = flags[INIT_CLOCK] != 0
    rows_ = _log_update(state, model, coasted, sats, init_clock, (q, v, l), log, index, inn_start)
    if rows_ < 0:
        return -1
    # the output: nav (-) x, the estimate (sensor totals), its sigma
    row = log.flog[index]
    out_quat, out_vel, out_lla = np.empty(4), np.empty(3), np.empty(3)
    correct(q, v, l, x, out_quat, out_vel, out_lla)
    row[LOG_TIME], row[LOG_GNSS_TIME] = times[T_STATE], times[T_K]
    row[LOG_QUAT : LOG_QUAT + 4] = out_quat
    row[LOG_VEL : LOG_VEL + 3] = out_vel
    row[LOG_LLA : LOG_LLA + 3] = out_lla
    sens = model.sens
    estimate = x.copy()
    for j in range(sens.size):
        estimate[sens[j]] += comp[j]
    row[LOG_STATE : LOG_STATE + n] = estimate
    for i in range(n):
        row[LOG_STATE + n + i] = np.sqrt(P[i, i])
    if flags[KEEP_COV] != 0:
        log.cov[index] = P
    if model.keep:
        kept = state.kept
        mats[P_UPD] = P
        kept[:n] = x
        kept[n : n + 4], kept[n + 4 : n + 7], kept[n + 7 : n + 10] = q, v, l
        after = kept[n + 10 : n + 25]
        after[:] = comp
        if model.fb and not coasted:
            for j in range(sens.size):
                after[j] += x[sens[j]]
    # 4. FB: the correction carried over the latency to the current state, reset
    if model.fb and not coasted:
        feedback(x, mats[F_], times[TAU], ins.quat, ins.vel, ins.lla, comp, state.cum, sens)
    cumulative = row[LOG_STATE + 2 * n : LOG_STATE + 3 * n]
    cumulative[:] = 0.0
    cumulative[:NAV] = state.cum
    for j in range(sens.size):
        cumulative[sens[j]] = comp[j]
    return rows_


@jit.njit(cache=True, error_model="numpy")
def _satellites(sats, a, b):
    """Satellites ``a..b-1`` of a batch's."""
    return rows.Satellites(
        sats.prn[a:b],
        sats.pos[a:b],
        sats.vel[a:b],
        sats.pseudorange[a:b],
        sats.clock[a:b],
        sats.delay[a:b],
        sats.range_rate[a:b],
        sats.clock_drift[a:b],
        sats.sigma_pr[a:b],
        sats.sigma_rr[a:b],
    )


@jit.njit(cache=True, error_model="numpy")
def epochs(
    ins,
    count,
    state,
    model,
    dtheta,
    dv,
    starts,
    times,
    flags,
    sats,
    sat_starts,
    log,
    first,
    inn_start,
):
    """:func:`epoch` for each of a batch of ``b`` epochs in turn: one call per batch, so
    that the cost of a call (its records checked and converted, some microseconds) is
    paid once per batch, not once per epoch.

    The state and settings are those of :func:`epoch`, ``count`` the samples before the
    batch. The epochs' increments are concatenated in ``dtheta``, ``dv`` (epoch ``j``:
    rows ``starts[j]:starts[j + 1]``) and their satellites in ``sats`` (rows
    ``sat_starts[j]:sat_starts[j + 1]``); ``times`` (b, 4) and ``flags`` (b, 4) hold
    each epoch's row of :func:`epoch`'s. Epoch ``j`` is logged in row ``first + j``, its
    innovation rows after those of the epochs before it, from ``inn_start`` on.

    The records may come as plain tuples of their fields (what the caller keeps: numba
    checks a plain tuple's types faster than a named one's, a few microseconds a call
    with a smoother's store, one epoch a call); they are named here.

    Returns the number of innovation rows written, or ``-1 - j`` if epoch ``j`` has a
    satellite of a system the filter does not take (:func:`epoch` returns -1; the
    epochs after it are not run).
    """
    ins, state, model = Ins(*ins), TightState(*state), TightModel(*model)
    sats, log = rows.Satellites(*sats), Log(*log)
    written = 0
    for j in range(times.shape[0]):
        a, e = starts[j], starts[j + 1]
        done = epoch(
            ins,
            count + a,
            state,
            model,
            dtheta[a:e],
            dv[a:e],
            times[j],
            flags[j],
            _satellites(sats, sat_starts[j], sat_starts[j + 1]),
            log,
            first + j,
            inn_start + written,
        )
        if done < 0:
            return -1 - j
        written += done
    return written
