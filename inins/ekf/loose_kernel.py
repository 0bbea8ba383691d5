"""The compiled epochs of the loosely coupled filter (:mod:`inins.ekf.loose`, module
docstring): per GNSS epoch the strapdown over the IMU chunk, the propagation with the
model at the mid-interval state, the update at the state after the epoch's IMU sample
boundary with the antenna position (and velocity) rows and the vehicle aiding, the FB
reset, and the epoch's record. :func:`run_block` runs a block of epochs in one call; it
takes a few packed records (named tuples of arrays: :data:`inins.ekf.step.Ins`,
:data:`LooseState`, :data:`LooseEpochs`, :data:`LooseModel`, :data:`LooseLog`); states
are addressed by the named blocks of :mod:`inins.ekf.kernels` and the time-offset state
``td`` of the layout.
"""

import math
from collections import namedtuple

import numpy as np

from inins.core import jit, strapdown
from inins.ekf import aiding, gate, kernels, step
from inins.ekf import rows as ekf_rows
from inins.ekf.kernels import BA, NAV, POS, VEL

LooseState = namedtuple("LooseState", "x P comp times count rejected")
"""The filter's state, updated in place: ``x`` (n,), ``P`` (n, n), the FB sensor
compensation ``comp`` (15,), ``times`` (2,) the time of the last epoch (``-inf`` before
the first: no propagation then) and of the block's sample 0 (s), ``count`` (1,) int the
IMU samples integrated, ``rejected`` (1,) int the consecutive epochs whose fix the
outlier gate rejected."""
LooseModel = namedtuple(
    "LooseModel",
    "dt window feedback threshold n_base td keep noise lever c_vb aid_sigma bound reinit_after",
)
"""Settings: IMU interval ``dt`` (s), ``window`` (samples averaged for ``f_b``,
``omega_b``), ``feedback``, the per-row gate ``threshold``, ``n_base`` (15 or 24), the
time-offset state ``td`` (-1: none), ``keep`` (n_base,) the states' indices in EKF26, the
``noise`` densities of :meth:`LooseConfig.noise` (the time offset's random walk last), the
``lever`` arm (3,) m, ``c_vb`` (3, 3), ``aid_sigma`` [nhc, zupt, zaru, odometer]
(:func:`inins.ekf.aiding.vehicle_update`), the outlier gate's ``bound`` on a fix's NIS
(inf: none) and ``reinit_after`` (epochs) (:mod:`inins.ekf.gate`)."""
LooseEpochs = namedtuple("LooseEpochs", "end frac pos var vel var_vel use stationary odometer")
"""A block's epochs (m,): ``end`` samples of the block up to the epoch's boundary
(increasing), ``frac`` ``t_k`` minus that boundary (s), the solution's ECEF ``pos`` (m, 3)
m and NED variances ``var`` (m^2), its NED ``vel`` (m, 3) (NaN: none) and ``var_vel``,
``use`` (bool: not coasted), ``stationary`` (bool), the ``odometer`` speed (m/s, NaN:
none)."""
LooseLog = namedtuple(
    "LooseLog", "quat vel lla comp x r P P_pred Phi y s acc aid nis rejected reinit"
)
"""Per epoch of a block (module docstring): ``N_k+`` (quat, vel, lla), ``comp``, ``x``,
``r``, ``P``, ``P_pred``, ``Phi``; the innovations ``y``, their variances ``s`` and
gate verdicts ``acc`` (m, 6) of the rows pos N, E, D, vel N, E, D (NaN / False when
unused); ``aid`` (m, 9) the accepted vehicle rows; the outlier gate's ``nis`` (m, 2) of
the position and velocity fixes (NaN: none), ``rejected`` (m, 2) the fixes it rejected
and ``reinit`` (m,) the epochs that re-initialised (:mod:`inins.ekf.gate`)."""


@jit.njit(cache=True)
def _propagate(state, model, mid, rates, dt_k, Phi, work):
    """``F`` at the mid-interval INS state ``mid`` = (quat, vel, lla) with the averaged
    ``rates`` (2, 3) (:func:`inins.ekf.kernels.system_matrix26`, the clock states
    dropped: rows and columns ``model.keep``), the series ``Phi`` and ``Qd`` over
    ``dt_k``, the prediction (in place); ``work`` = (Ff, Qf, F, Qc, Qd) the block's
    work matrices (EKF26 or EKF17 size, then the filter's)."""
    x, nb, keep = state.x, model.n_base, model.keep
    Ff, Qf, F, Qc, Qd = work
    F.fill(0.0)
    Qc.fill(0.0)
    mq, mv, ml = mid
    mat_nb = step.mat_from_quat(mq)
    kernels.system_matrix26(ml[0], ml[2], mv, rates[1], mat_nb, rates[0], Ff)
    noise = model.noise
    kernels.noise26(mat_nb, noise[0:3], noise[3:6], noise[6:9], noise[9:12], 0.0, 0.0, Qf)
    for i in range(nb):
        for j in range(nb):
            F[i, j] = Ff[keep[i], keep[j]]
            Qc[i, j] = Qf[keep[i], keep[j]]
    if model.td >= 0:
        Qc[model.td, model.td] = noise[14] * noise[14]
    kernels.discretize(F, Qc, dt_k, Phi, Qd)
    kernels.predict(x, state.P, Phi, Qd)


@jit.njit(cache=True)
def _gnss_update(ins, state, model, ep, k, rates, log):
    """The solution of epoch ``k`` at the INS state after its boundary (``rates`` the
    averaged ``omega_b``, ``f_b`` there): antenna position rows, and velocity rows where
    it has a velocity (:mod:`inins.ekf.rows`); each fix through the outlier gate, then
    gated scalar updates; after ``reinit_after`` rejected epochs a failing epoch
    re-initialises the states its fixes measure (:mod:`inins.ekf.gate`)."""
    x, td = state.x, model.td
    ant = step.antenna(ins.quat, ins.vel, ins.lla, x, rates[0], model.lever)
    lag = ep.frac[k] + (x[td] if td >= 0 else 0.0)
    y, H, r = ekf_rows.antenna_position_rows(ant, ep.pos[k], ep.var[k], x, td, lag)
    log.nis[k, 0] = gate.nis(state.P, H, y, r)
    log.nis[k, 1] = np.nan
    fail = log.nis[k, 0] > model.bound
    log.rejected[k, 0] = fail
    log.rejected[k, 1] = False
    if math.isfinite(ep.vel[k, 0]):
        # the acceleration carries the velocity over the lag: C_nb (f_b - ba) + g
        f_n = ant.mat_nb @ (rates[1] - x[BA : BA + 3])
        yv, Hv, rv = ekf_rows.antenna_velocity_rows(ant, ep.vel[k], ep.var_vel[k], f_n, x, td, lag)
        log.nis[k, 1] = gate.nis(state.P, Hv, yv, rv)
        log.rejected[k, 1] = log.nis[k, 1] > model.bound
        y, H, r = np.concatenate((y, yv)), np.vstack((H, Hv)), np.concatenate((r, rv))
    m = y.shape[0]
    acc, yy, ss = np.zeros(m, np.bool_), np.empty(m), np.empty(m)
    if not (log.rejected[k, 0] or log.rejected[k, 1]):
        state.rejected[0] = 0
        kernels.sequential_update(x, state.P, H, y, r, model.threshold, acc, yy, ss)
    else:
        for i in range(m):  # the prior innovation of every row, for the record
            yy[i] = y[i]
            ss[i] = r[i] + H[i] @ state.P @ H[i]
        if state.rejected[0] >= model.reinit_after:
            states = np.empty(m, np.int64)
            for i in range(m):  # position rows on POS, velocity rows on VEL
                states[i] = POS + i if i < 3 else VEL + i - 3
            gate.reinitialise(x, state.P, log.P_pred[k], H, y, r, states)
            acc[:] = True
            log.rejected[k, 0] = False
            log.rejected[k, 1] = False
            log.reinit[k] = True
            state.rejected[0] = 0
        else:
            state.rejected[0] += 1
            keep = np.zeros(m, np.bool_)  # the rows of the fix that passed, if any
            for i in range(m):
                keep[i] = not log.rejected[k, 0 if i < 3 else 1]
            if keep.any():
                ok = np.flatnonzero(keep)
                a2, y2, s2 = np.zeros(ok.size, np.bool_), np.empty(ok.size), np.empty(ok.size)
                kernels.sequential_update(
                    x, state.P, H[ok], y[ok], r[ok], model.threshold, a2, y2, s2
                )
                for j in range(ok.size):
                    acc[ok[j]], yy[ok[j]], ss[ok[j]] = a2[j], y2[j], s2[j]
    log.y[k, :m] = yy
    log.s[k, :m] = ss
    log.acc[k, :m] = acc


@jit.njit(cache=True)
def _reset(ins, state, model, r):
    """FB: the correction into the INS state and the sensor compensation, the states
    reset (the time offset is a parameter, never reset); ``r`` the reset."""
    x = state.x
    for i in range(NAV):
        r[i] = x[i]
    step.correct(ins.quat, ins.vel, ins.lla, x, ins.quat, ins.vel, ins.lla)
    for i in range(NAV):
        x[i] = 0.0
    for j in range(model.n_base - NAV):
        state.comp[j] += x[NAV + j]
        r[NAV + j] = x[NAV + j]
        x[NAV + j] = 0.0


@jit.njit(cache=True)
def run_block(dtheta, dv, ins, state, ep, model, log):
    """Run the epochs of one block (module docstring); the state updated in place.

    ``dtheta``, ``dv`` (s, 3) the block's increments; ``ins`` the INS
    (:data:`inins.ekf.step.Ins`); ``state`` :data:`LooseState`, ``ep``
    :data:`LooseEpochs`, ``model`` :data:`LooseModel`, ``log`` :data:`LooseLog`.
    """
    n = state.x.shape[0]
    nf = 26 if model.n_base == 24 else 17
    Phi = np.zeros((n, n))
    work = (np.zeros((nf, nf)), np.zeros((nf, nf)), np.zeros((n, n)), np.zeros((n, n)))
    work = (*work, np.zeros((n, n)))
    rates = np.zeros((2, 3))
    start, dt = 0, model.dt
    for k in range(ep.end.shape[0]):
        hi = ep.end[k]
        m = hi - start
        if model.feedback:
            dth, dvv = step.compensate(dtheta[start:hi], dv[start:hi], dt, state.comp)
        else:
            dth, dvv = dtheta[start:hi].copy(), dv[start:hi].copy()
        begin = (ins.quat.copy(), ins.vel.copy(), ins.lla.copy())
        oq, ov, ol = np.empty((m, 4)), np.empty((m, 3)), np.empty((m, 3))
        if m > 0:
            strapdown._navigate(
                ins.quat,
                ins.vel,
                ins.lla,
                ins.prev,
                state.count[0],
                dth,
                dvv,
                dt,
                0,
                True,
                True,
                1,
                ins.home,
                np.empty(m, np.int64),
                oq,
                ov,
                ol,
            )
            state.count[0] += m
        t_k = state.times[1] + hi * dt + ep.frac[k]
        dt_k = t_k - state.times[0]
        for i in range(n):
            for j in range(n):
                Phi[i, j] = 1.0 if i == j else 0.0
        if math.isfinite(state.times[0]) and dt_k > 0.0:
            mid = m - math.floor(0.5 * dt_k / dt + 0.5)
            if mid <= 0 or m == 0:
                mid, middle = 0, begin
            else:
                middle = (oq[mid - 1], ov[mid - 1], ol[mid - 1])
            step.mean_rates(dth, dvv, mid, model.window, dt, rates)
            _propagate(state, model, middle, rates, dt_k, Phi, work)
        log.Phi[k] = Phi
        log.P_pred[k] = state.P
        state.times[0] = t_k
        # INS state at t_k: after the boundary, carried by v * frac
        step.mean_rates(dth, dvv, m, model.window, dt, rates)
        log.y[k].fill(np.nan)
        log.s[k].fill(np.nan)
        log.acc[k].fill(False)
        log.nis[k].fill(np.nan)
        log.rejected[k].fill(False)
        log.reinit[k] = False
        if ep.use[k]:
            _gnss_update(ins, state, model, ep, k, rates, log)
        sig = model.aid_sigma
        if sig[0] > 0.0 or ep.stationary[k] or (sig[3] > 0.0 and math.isfinite(ep.odometer[k])):
            omega = np.zeros(3)
            for j in range(m):
                for i in range(3):
                    omega[i] += dth[j, i]
            if m > 0:
                omega /= m * dt
            aiding.vehicle_update(
                state.x,
                state.P,
                ins,
                omega,
                model.c_vb,
                ep.stationary[k],
                ep.odometer[k],
                sig,
                model.threshold,
                log.aid[k],
            )
        else:
            log.aid[k].fill(False)
        log.x[k] = state.x
        log.r[k].fill(0.0)
        if model.feedback:
            _reset(ins, state, model, log.r[k])
        log.quat[k] = ins.quat
        log.vel[k] = ins.vel
        log.lla[k] = ins.lla
        log.comp[k] = state.comp
        log.P[k] = state.P
        start = hi
