"""Scores of a filter run against a reference: outage drifts, attitude differences, and
what smoothing gains; plain functions of the runs' arrays (SI).

- Post-processing (:mod:`inins.ekf.post`): the antenna positions of the forward and
  smoothed solutions against the reference epochs of the solution file inside the
  outage windows (:func:`outage_scores`, :func:`inins.ekf.outages.score`), and their
  attitude against a reference attitude (:func:`attitude_differences`).
- The tight filter on a simulated flight: the output error, heading error and NEES of
  every epoch against truth (:func:`truth_errors`, after the run); the output against
  truth in the windows of ``filter.outages_s`` (:func:`tight_outage_scores`); with a smoother
  (:func:`smoothing_figures`) the smoothed 1-sigma and solution against the forward
  ones.
"""

import math
from dataclasses import dataclass

import numpy as np

from inins.core import error_model, rotation
from inins.core.satellites import LETTERS
from inins.ekf import gate, loose, outages, recorded
from inins.exceptions import InputError


def forward_heading(quat_nb, forward_b):
    """Heading (rad, clockwise from north) of the body axis ``forward_b`` (3,) at each
    attitude ``quat_nb`` (m, 4): the vehicle's heading when the IMU's x is not forward."""
    axis = rotation.mat_from_quat(quat_nb) @ forward_b
    return np.arctan2(axis[:, 1], axis[:, 0])


@dataclass(frozen=True)
class FixDifference:
    """A recorded run's solution against its single-point fixes: the largest and RMS
    antenna position difference (m) and velocity difference (m/s) over the epochs with a
    fix."""

    pos_max: float
    pos_rms: float
    vel_max: float
    vel_rms: float


def fix_differences(lla, quat_nb, vel_n, lever_b, fix_pos_e, fix_vel_n):
    """:class:`FixDifference` of a solution (``lla``, ``quat_nb``, ``vel_n``, each per epoch)
    whose antenna (:func:`inins.ekf.recorded.antenna_positions`, lever arm ``lever_b``)
    is compared with the SPP fixes ``fix_pos_e`` (m, 3) ECEF and ``fix_vel_n`` (m, 3)
    NED (NaN rows: no fix)."""
    r = recorded.antenna_positions(lla, quat_nb, lever_b)
    ok = np.isfinite(fix_pos_e[:, 0])
    dp = np.linalg.norm(r[ok] - fix_pos_e[ok], axis=1)
    dv = np.linalg.norm(vel_n[ok] - fix_vel_n[ok], axis=1)
    rms = lambda a: float(np.sqrt(np.mean(a**2)))  # noqa: E731
    return FixDifference(float(dp.max()), rms(dp), float(dv.max()), rms(dv))


def reference_hits(ref_time, time):
    """Index into ``ref_time`` (r,) of each of ``time`` (m,) and whether that reference
    epoch is at the same time (within 1 us)."""
    idx = np.minimum(np.searchsorted(ref_time, time), max(ref_time.size - 1, 0))
    if not ref_time.size:
        return idx, np.zeros(time.size, bool)
    return idx, np.abs(ref_time[idx] - time) < 1e-6


def outage_scores(time, solutions, lever_arm, ref_time, ref_lla, windows, t0=0.0, reference=None):
    """Drift of each solution's antenna in each outage window against the reference.

    Parameters
    ----------
    time : ndarray (m,)
        Epochs of the solutions (s).
    solutions : dict of str to inins.ekf.post.Solution
        E.g. ``{"fwd": ..., "sm": ...}``; the antenna is ``lla + C_nb l_b`` carried by
        ``v offset`` where the solution has a time-offset state
        (:func:`inins.ekf.loose.antenna_positions`).
    lever_arm : ndarray (3,)
        Antenna minus IMU, body axes (m).
    ref_time, ref_lla : ndarray (r,), (r, 3)
        Reference epochs (s) and antenna positions.
    windows : sequence of (float, float)
        Outage windows (s).
    t0 : float
        Run start (s): the windows' times in a message are from it.
    reference : (int, str), optional
        The reference's quality flag and file, for the message when a window has no
        reference epoch.

    Returns
    -------
    dict of str to inins.ekf.outages.OutageScore
        Empty without windows.
    """
    if not windows:
        return {}
    idx, hit = reference_hits(ref_time, time)
    for a, b in windows:
        if not np.any(hit & (time >= a) & (time < b)):
            q, source = reference if reference is not None else ("?", None)
            raise InputError(
                f"the reference (quality {q}) has no epoch in the outage "
                f"[{a - t0:g}, {b - t0:g}) s: it does not cover the run",
                source=source,
                key="post.reference_q",
            )
    ref = ref_lla[idx[hit]]
    out = {}
    for name, s in solutions.items():
        antenna = loose.antenna_positions(s.quat, s.lla, lever_arm, s.vel, s.offset)
        out[name] = outages.score(time[hit], antenna[hit], None, ref, None, windows)
    return out


def screen_references(time, solution, lever_arm, ref_time, ref_lla, ref_var, limit, rejected):
    """Reference epochs fit to score against: those the outlier gate would pass
    (:func:`inins.ekf.gate.screen`).

    A reference epoch at a solution epoch is tested against that epoch's antenna position
    (``solution``, :class:`inins.ekf.post.Solution`: the smoothed one where there is one,
    which no unused epoch has moved), with the variance of both per axis; one whose
    position fix the filter's gate rejected (``rejected`` (m,) bool at ``time``) fails
    too. ``limit`` the gate's bound on the NIS (inf: nothing screened).

    Parameters
    ----------
    time : ndarray (m,)
        Solution epochs (s).
    solution : inins.ekf.post.Solution
    lever_arm : ndarray (3,)
        Antenna minus IMU, body axes (m).
    ref_time, ref_lla, ref_var : ndarray (r,), (r, 3), (r, 3)
        Reference epochs (s), antenna positions and NED variances (m^2).
    limit : float
    rejected : ndarray (m,) bool

    Returns
    -------
    ndarray (r,) bool
        True for the reference epochs kept.
    """
    keep = np.ones(ref_time.size, bool)
    if not math.isfinite(limit) or not ref_time.size or not time.size:
        return keep
    idx, hit = reference_hits(time, ref_time)
    at = idx[hit]
    antenna = loose.antenna_positions(
        solution.quat[at],
        solution.lla[at],
        lever_arm,
        solution.vel[at],
        None if solution.offset is None else solution.offset[at],
    )
    diff = error_model.position_error_ned(ref_lla[hit], antenna)
    var = ref_var[hit] + solution.sigma[at, :3] ** 2
    keep[hit] = ~(gate.screen(diff, var, limit) | rejected[at])
    return keep


@dataclass(frozen=True)
class AttitudeDifference:
    """Attitude minus the reference over the scored epochs (rad): heading mean and
    standard deviation, and the larger of the mean roll and pitch differences; ``time``
    (k,) s and ``euler`` (k, 3) rad the roll, pitch and heading differences at each
    scored epoch."""

    heading_mean: float
    heading_std: float
    tilt_mean_max: float
    time: np.ndarray
    euler: np.ndarray


def attitude_differences(time, quats, ref_time, ref_mat_nb, t_from):
    """Each solution's Euler angles minus the reference's at the epochs they share from
    ``t_from`` (s) on.

    Parameters
    ----------
    time : ndarray (m,)
        Solution epochs (s).
    quats : dict of str to ndarray (m, 4)
        Attitude of each solution.
    ref_time, ref_mat_nb : ndarray (r,), (r, 3, 3)
        Reference epochs (s) and attitudes.
    t_from : float

    Returns
    -------
    dict of str to AttitudeDifference
    """
    idx = np.clip(np.searchsorted(ref_time, time), 0, ref_time.size - 1)
    ok = (np.abs(ref_time[idx] - time) < 1e-6) & (time >= t_from)
    if not ok.any():
        raise InputError("no reference attitude epoch to score", key="post.score_from_s")
    ref = np.array([rotation.euler_from_mat(m) for m in ref_mat_nb[idx[ok]]])
    out = {}
    for name, q in quats.items():
        e = np.array([rotation.euler_from_mat(m) for m in rotation.mat_from_quat(q[ok])]) - ref
        e = (e + math.pi) % (2 * math.pi) - math.pi
        tilt = float(np.abs(e[:, :2].mean(0)).max())
        out[name] = AttitudeDifference(
            float(e[:, 2].mean()), float(e[:, 2].std()), tilt, time[ok], e
        )
    return out


def _yaw_mat(yaw):
    zero = np.zeros_like(yaw)
    return rotation.mat_from_euler(zero, zero, yaw)


def tight_outage_scores(result, smoothed, windows):
    """Outage protocol of a tight run against truth (:func:`inins.ekf.outages.score`).

    Per window of ``filter.outages_s`` (the filter coasts there) the largest horizontal
    and 3D drift and the heading error at its last epoch, for the forward output of
    ``result`` (:class:`inins.ekf.result.EkfResult`) and the ``smoothed`` solution
    (:class:`inins.ekf.smoother.Smoothed`, or None). Truth is the forward output minus
    its recorded error (position ``nav_error[:, 0:3]``, heading ``heading_error``); the
    smoothed heading error is the smoothed minus the forward heading plus the forward
    error.

    Returns
    -------
    (OutageScore, OutageScore or None) or None
        None without truth or windows.
    """
    if not windows or result.nav_error.shape[0] != result.time.size or result.time.size == 0:
        return None
    true_lla = error_model.lla_offset(result.lla, -result.nav_error[:, 0:3])
    fwd_yaw = rotation.euler_from_mat(rotation.mat_from_quat(result.quat_nb))[:, 2]
    ref = _yaw_mat(fwd_yaw - result.heading_error)
    fwd = outages.score(result.time, result.lla, _yaw_mat(fwd_yaw), true_lla, ref, windows)
    if smoothed is None:
        return fwd, None
    sm_yaw = rotation.euler_from_mat(rotation.mat_from_quat(smoothed.quat))[:, 2]
    sm = outages.score(result.time, smoothed.lla, _yaw_mat(sm_yaw), true_lla, ref, windows)
    return fwd, sm


@dataclass(frozen=True)
class SmoothingFigures:
    """What smoothing a tight run gains: median horizontal 1-sigma forward and smoothed
    (m), the smoothed heading 1-sigma at the start (rad), the largest horizontal
    forward-smoothed difference (m), and the smoothed position error RMS against truth
    (m, None without truth)."""

    forward_hor_sigma_median: float
    smoothed_hor_sigma_median: float
    smoothed_heading_sigma_start: float
    hor_diff_max: float
    smoothed_pos_err_rms: float | None


def smoothing_figures(result, smoothed):
    """:class:`SmoothingFigures` of a tight ``result`` and its ``smoothed`` solution."""
    fwd_h = np.hypot(result.sigma[:, 0], result.sigma[:, 1])
    sm_h = np.hypot(smoothed.sigma[:, 0], smoothed.sigma[:, 1])
    diff = error_model.position_error_ned(result.lla, smoothed.lla)
    err_rms = None
    if result.nav_error.shape[0]:
        true = error_model.lla_offset(result.lla, -result.nav_error[:, 0:3])
        err = error_model.position_error_ned(smoothed.lla, true)
        err_rms = float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
    return SmoothingFigures(
        forward_hor_sigma_median=float(np.median(fwd_h)),
        smoothed_hor_sigma_median=float(np.median(sm_h)),
        smoothed_heading_sigma_start=float(smoothed.sigma[0, result.layout.index("phi_D")]),
        hor_diff_max=float(np.hypot(diff[:, 0], diff[:, 1]).max()),
        smoothed_pos_err_rms=err_rms,
    )


def _bias_names(layout):
    """The inter-system bias states of a layout (the last states)."""
    return tuple(n for n in layout.names if n in error_model.SYSTEM_BIASES)


def _true_biases(truths, names, systems):
    """(m, 1 + len(names)) true biases: the reference system's (the clock carries it),
    then each bias state's (its system's minus the reference's); None if no truth
    carries a ``system_bias`` (one without counts as no bias)."""
    if all(t.system_bias is None for t in truths):
        return None
    index = [LETTERS.index(systems[0])] + [LETTERS.index(n[-1]) for n in names]
    zero = np.zeros(len(LETTERS))
    b = np.array([zero if t.system_bias is None else t.system_bias for t in truths])
    b = b.reshape(-1, len(LETTERS))[:, index]
    b[:, 1:] -= b[:, :1]
    return b


def truth_errors(result, log, true_sensor=None, *, pps_storage=True, systems="G"):
    """The result with its errors against truth (:func:`epoch_errors` over all its epochs).

    Parameters
    ----------
    result : inins.ekf.result.EkfResult
    log
        With ``truth``, one :class:`~inins.ekf.config.TruthEpoch` per epoch, and
        ``covariance``, the ``P`` of each (m, n, n).
    true_sensor, pps_storage, systems
        As :func:`epoch_errors`.

    Returns
    -------
    inins.ekf.result.EkfResult
    """
    err, heading, nees = epoch_errors(
        (result.quat_nb, result.vel_n, result.lla, result.state),
        log.truth,
        log.covariance,
        true_sensor,
        layout=result.layout,
        pps_storage=pps_storage,
        systems=systems,
    )
    return result.with_truth(err, heading, nees)


def epoch_errors(solution, truths, covariance, true_sensor=None, *, layout, pps_storage, systems):
    """Output error, heading error and NEES of ``k`` epochs against their truth.

    Vectorised over the epochs: :func:`inins.ekf.filter.run_filter` calls it on each
    batch of epochs as the run goes (their ``P`` then dropped), so that no epoch's
    ``P`` is kept. The navigation truth is the one at the logged time (the PPS, or the
    arrival with the naive pairing: the truth's ``at_arrival``); the clock truth the
    one at the measurement epoch. The navigation states estimate the INS error: their
    estimation error is minus the output error; sensor and clock states estimate the
    quantity itself. ``NEES = e^T P^-1 e`` over all ``n`` states.

    Parameters
    ----------
    solution : (ndarray (k, 4), ndarray (k, 3), ndarray (k, 3), ndarray (k, n))
        Output ``quat_nb``, ``vel_n`` (m/s), ``lla`` (rad, rad, m) and the error-state
        estimate (sensor totals) of each epoch.
    truths : sequence of inins.ekf.config.TruthEpoch
        One per epoch.
    covariance : ndarray (k, n, n)
        ``P`` after each epoch's update.
    true_sensor : inins.core.imu.SensorErrors, optional
        Constant true sensor errors: with them the NEES of all states.
    layout : inins.core.error_model.StateLayout
        The filter's states.
    pps_storage : bool
    systems : str
        The filter's systems (:class:`~inins.ekf.config.FilterConfig`), the first the
        reference of the inter-system biases.

    Returns
    -------
    nav_error : ndarray (k, 9)
        Position (NED m), velocity (m/s), phi (rad): output minus truth.
    heading_error : ndarray (k,)
        Heading minus true heading (rad), wrapped to [-pi, pi).
    nees : ndarray (k,) or (0,)
        (0,) without ``true_sensor``.
    """
    quat, vel, lla, state = solution
    if not pps_storage:
        if any(t.at_arrival is None for t in truths):
            raise ValueError("the naive pairing is scored with the truth at the data arrival")
        nav = [t.at_arrival for t in truths]
    else:
        nav = [(t.mat_nb, t.vel_n, t.lla) for t in truths]
    mat_true = np.array([v[0] for v in nav]).reshape(-1, 3, 3)
    vel_true = np.array([v[1] for v in nav]).reshape(-1, 3)
    lla_true = np.array([v[2] for v in nav]).reshape(-1, 3)
    mat_est = rotation.mat_from_quat(quat)
    err = np.concatenate(
        [
            error_model.position_error_ned(lla, lla_true),
            vel - vel_true,
            error_model.attitude_error(mat_est, mat_true),
        ],
        axis=1,
    )
    heading = rotation.euler_from_mat(mat_est)[:, 2] - rotation.euler_from_mat(mat_true)[:, 2]
    nees = np.zeros(0)
    if true_sensor is not None:
        true = _true_states(truths, true_sensor, layout, systems)
        e = state - true
        e[:, :9] = -err
        nees = np.einsum("mi,mi->m", e, np.linalg.solve(covariance, e[..., None])[..., 0])
    return err, rotation.wrap_angle(heading), nees


def _true_states(truths, true_sensor, layout, systems):
    """(k, n) true values of the filter's states: zero navigation error, the constant
    sensor errors, the clock (with the reference system's bias) and the inter-system
    biases of each epoch."""
    n = len(layout.names)
    clock = np.array([[t.clock_bias, t.clock_drift] for t in truths]).reshape(-1, 2)
    base = n - len(_bias_names(layout))
    biases = _true_biases(truths, _bias_names(layout), systems)
    if biases is not None:
        clock[:, 0] += biases[:, 0]  # the clock carries the reference system's bias
    true = np.concatenate(
        [
            np.zeros((len(truths), 9)),
            np.tile(
                np.concatenate([true_sensor.accel_bias, true_sensor.gyro_bias]),
                (len(truths), 1),
            ),
            clock,
            np.tile(
                np.concatenate([true_sensor.accel_misalignment, true_sensor.gyro_misalignment]),
                (len(truths), 1),
            ),
        ],
        axis=1,
    )[:, :base]
    if biases is not None:
        true = np.concatenate([true, biases[:, 1:]], axis=1)
    return true
