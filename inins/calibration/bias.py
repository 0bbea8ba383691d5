"""calibrate-bias: horizontal gyro biases from a rate-table return sequence (000 §2-3).

Align at the first position, navigate (stationary: known position, 000 eqs. 9-10)
through the 000 Table 1 sequence, then evaluate the methods side by side
(:mod:`inins.calibration.methods`, :mod:`inins.calibration.velocity`) and choose
the valid return-sequence formula automatically. The tilt formulas are solved without
linearising in the gyrocompass heading error (:mod:`inins.calibration.exact_model`),
each chosen bias carries an uncertainty budget (:mod:`inins.calibration.budget`), and
free-inertial navigation and gyrocompassing where cos(lat) is too small for the bias are
refused (issue 7). The body axis that is vertical need not be z: a second, pitched
sequence gives beta_z the same way (:mod:`inins.calibration.three_axis`).
"""

import enum
from dataclasses import dataclass, field, replace

import numpy as np

from inins.calibration import budget, exact_model, methods, navigate, sequence
from inins.calibration.alignment import StationaryAlignment
from inins.calibration.ett import EttResult
from inins.calibration.methods import Estimator, Formula
from inins.calibration.tilt_model import Track
from inins.core import earth, error_model, rotation
from inins.core.units import DPH
from inins.exceptions import InputError


class HeadingMethod(enum.StrEnum):
    """Where the heading at the first position comes from."""

    GYROCOMPASS = "gyrocompass"
    KNOWN = "known"
    ETT = "ett"


@dataclass(frozen=True)
class Settings:
    """calibrate-bias settings in SI.

    Attributes
    ----------
    align_duration : float
        Alignment time at the start of position A (s).
    heading : float or None
        Known heading (rad) at A (``known`` or ETT alignment), None to gyrocompass.
    heading_method : HeadingMethod
    heading_sigma : float
        1-sigma of a given heading (rad).
    epoch_window, settle : float
        Epoch window and settling time after a rotation (s).
    labels : tuple of str or None
        Labels of holds at A, B, A'.
    output_rate : float
        Navigation output rate (Hz).
    free : bool
        Free-inertial instead of stationary navigation.
    arw, vrw : ndarray or None
        Angle and velocity random walk for the 1-sigma (rad/sqrt(s), m/s/sqrt(s)) per
        axis; None: estimated from the alignment window.
    accel_quantum : float
        Accelerometer pulse weight (m/s), for the quantization noise of the velocity.
    bias_z : float
        Vertical gyro bias taken as known (rad/s).
    k_sigma, floor : float
        Mount-rotation detection: residual above max(k_sigma * sigma, floor) (rad).
    bias_bound : float or None
        Largest gyro bias the unit may have (rad/s, the data sheet's); gyrocompassing is
        refused where it reaches :data:`exact_model.MAX_SIN_HEADING` of the horizontal
        Earth rate. None: checked on the calibrated biases instead.
    ett : inins.calibration.ett.EttResult or None
        ETT mounting (000 §3.1): the heading at the alignment window follows from the
        table's encoder angles there (``heading_method`` "ett").
    stated : inins.calibration.budget.StatedErrors
        1-sigma of the sensor errors not estimated, for the uncertainty budget.
    start_after : float
        Look for the return sequence from this time on (s).
    """

    align_duration: float = 300.0
    heading: float | None = None
    heading_method: HeadingMethod = HeadingMethod.GYROCOMPASS
    heading_sigma: float = 0.0
    epoch_window: float = 5.0
    settle: float = 2.0
    labels: tuple | None = None
    output_rate: float = 10.0
    free: bool = False
    arw: np.ndarray | None = None
    vrw: np.ndarray | float | None = None
    accel_quantum: float = 0.0
    bias_z: float = 0.0
    k_sigma: float = 4.0
    floor: float = 0.5 * np.pi / 180 / 3600
    ett: EttResult | None = None
    bias_bound: float | None = None
    stated: budget.StatedErrors = field(default_factory=budget.StatedErrors)
    start_after: float = -np.inf


@dataclass(frozen=True)
class CalibrationTruth:
    """Simulation truth of a calibration: the mean gyro bias over the navigation (rad/s,
    b frame), the true initial attitude error ``phi0`` (rad, NED), the error each
    estimate should carry by the linear model (``predicted``, by :class:`Estimator`)
    and the mount rotation on the output grid (rad, (m, 3))."""

    bias: np.ndarray
    phi0: np.ndarray
    predicted: dict
    mount: np.ndarray


@dataclass(frozen=True)
class Outcome:
    """Everything calibrate-bias found (SI; biases in rad/s on the body axes x, y, z);
    ``vertical_bias`` is the bias of the vertical body axis taken as known (rad/s)."""

    seq: sequence.Sequence
    geometry: methods.Geometry
    align: StationaryAlignment
    track: Track
    eps: np.ndarray
    epoch_tilts: np.ndarray
    estimates: dict
    check: methods.MountCheck
    threshold: np.ndarray
    choice: methods.Choice
    chosen: dict
    noise: tuple = ()
    truth: CalibrationTruth | None = None
    warnings: tuple = ()
    budgets: dict = field(default_factory=dict)
    vertical_bias: float = 0.0


MIN_BIAS_BOUND = 1e-4 * np.pi / 180 / 3600
"""rad/s (1e-4 deg/h): the bias bound assumed when none is stated, so that gyrocompassing
is refused where cos(lat) vanishes (the pole) whatever the bias."""


def _hold_windows(seq):
    e = seq.epochs
    return (e[0, 0], e[1, 1]), (e[2, 0], e[3, 1])


def calibrate_bias(record, settings, progress=None):
    """Run calibrate-bias on a table record.

    Parameters
    ----------
    record : inins.core.records.TableRecord
    settings : Settings
    progress : callable, optional

    Returns
    -------
    Outcome
    """
    if settings.free:
        raise InputError(
            "navigation.mode free is not supported by calibrate-bias: every method here "
            "(attitude, velocity, eqs. 38/44/45) assumes the known position and zero "
            "velocity of the table (000 eqs. 9-10), and free-inertial navigation adds the "
            "Schuler feedback of the velocity error on the tilt (-12 % on beta_x, -41 % on "
            "beta_y at T = 600 s). Use navigation.mode: stationary",
            source=record.source,
            key="navigation.mode",
        )
    seq = sequence.build_sequence(
        record,
        settings.align_duration,
        settings.epoch_window,
        settings.settle,
        settings.labels,
        settings.start_after,
    )
    lat = float(record.lla[0])
    gyrocompass = settings.heading_method == HeadingMethod.GYROCOMPASS
    if gyrocompass:
        _check_gyrocompass(settings.bias_bound, lat, record.source)
    if settings.ett is not None:
        settings = replace(
            settings,
            heading=_ett_heading(record, settings.ett, seq.align),
            heading_sigma=settings.ett.heading_sigma,
        )
    align, arw, vrw = navigate.align(
        record, seq.align, lat, settings.heading, settings.arw, settings.vrw
    )
    estimated = settings.arw is None, settings.vrw is None
    settings = replace(settings, arw=arw, vrw=vrw)
    track = navigate.navigate(
        record,
        align.mat_nb,
        seq.nav_start,
        seq.nav_end,
        settings.output_rate,
        settings.free,
        progress,
        min_points_per_s=3.0 / settings.epoch_window,
    )
    ctx = methods.Context.build(
        track, seq.epochs, seq.hold_times, settings.arw, settings.bias_z, gyrocompass
    )
    geometry = methods.Geometry.at_start(track)
    e, n = geometry.east, geometry.north
    est = {
        Estimator.ATTITUDE: methods.solve(ctx, dict.fromkeys(track.horizontal, Formula.ATTITUDE)),
        Estimator.VELOCITY: methods.solve_velocity(
            ctx, _hold_windows(seq), float(np.mean(vrw)), settings.accel_quantum
        ),
    }
    if seq.has_return:
        est[Estimator.EQ44] = methods.solve(ctx, {e: Formula.ATTITUDE, n: Formula.RETURN})
        est[Estimator.EQ45] = methods.solve(
            ctx, {e: Formula.RETURN, n: Formula.RETURN}, heading_known=True
        )
    velocity = est[Estimator.VELOCITY]
    heading_sigma = align.heading_sigma if gyrocompass else settings.heading_sigma
    est = {k: _with_alignment_noise(v, align.tilt_sigma, heading_sigma) for k, v in est.items()}
    if seq.has_return:
        check, threshold, choice = _mount_choice(
            ctx, est, geometry, settings, heading_sigma, seq.align
        )
        if choice.east_formula is None:  # eq. 38 must not borrow from the rejected pair
            est[Estimator.EQ38] = _with_alignment_noise(
                methods.solve_north(ctx, geometry, velocity), align.tilt_sigma, heading_sigma
            )
            check, threshold = _recheck_north(
                ctx, est[Estimator.EQ38], check, geometry, settings, heading_sigma, seq.align
            )
    else:
        check = methods.MountCheck(np.full(2, np.nan), np.full(2, np.nan))
        threshold, choice = np.full(2, np.nan), methods.NO_RETURN
    chosen = _chosen(est, geometry, choice)
    warnings = _heading_warnings(gyrocompass, chosen, geometry, track, record.source)
    outcome = Outcome(
        seq,
        geometry,
        align,
        track,
        ctx.eps,
        _epoch_tilts(ctx),
        est,
        check,
        threshold,
        choice,
        chosen,
        noise=(arw, vrw, estimated),
        warnings=warnings,
        vertical_bias=float(settings.bias_z),
        budgets={
            k: budget.budget(ctx, v, settings.stated, seq.align)
            for k, v in est.items()
            if k in (Estimator.EQ44, Estimator.EQ45, Estimator.EQ38)
        },
    )
    if record.truth is not None:
        outcome = _with_truth(outcome, record, ctx)
    return outcome


def _check_gyrocompass(bound, lat, source):
    """Refuse gyrocompassing where the stated bias reaches
    :data:`exact_model.MAX_SIN_HEADING` of the horizontal Earth rate ``W cos lat``."""
    w_h = earth.RATE * np.cos(lat)
    if bound is None or bound < MIN_BIAS_BOUND:
        bound = MIN_BIAS_BOUND
    if bound >= exact_model.MAX_SIN_HEADING * w_h:
        raise InputError(
            f"gyrocompass alignment cannot work at latitude {np.degrees(lat):.4g} deg for a "
            f"gyro bias of {bound / DPH:.3g} deg/h: the horizontal Earth rate there is "
            f"{w_h / DPH:.3g} deg/h, so the initial heading error "
            f"asin(bias / (W cos lat)) would reach 30 deg or more. Use alignment.method: "
            "ett (the heading from the pitch-90/0 positions, inins align-ett) or known "
            "(with alignment.heading_deg from the table's north reference)",
            source=source,
            key="alignment.method",
        )


def _heading_warnings(gyrocompass, chosen, geometry, track, source):
    """Refuse (calibrated bias too large for gyrocompassing) or warn (heading error large
    enough that the linear tilt model would be off by ~10 %)."""
    if not gyrocompass or chosen.get(geometry.east) is None:
        return ()
    b = np.zeros(3)
    for axis in geometry.horizontal:
        b[axis] = chosen[axis][0]
    sin_heading = abs((track.mat_nb[0] @ b)[1]) / (earth.RATE * np.cos(track.lat))
    if not np.isfinite(sin_heading) or sin_heading >= exact_model.MAX_SIN_HEADING:
        _check_gyrocompass(
            float(np.linalg.norm(b)) if np.all(np.isfinite(b)) else np.inf, track.lat, source
        )
    if sin_heading >= exact_model.WARN_SIN_HEADING:
        return (
            f"the gyrocompass heading error is {np.degrees(np.arcsin(sin_heading)):.3g} deg "
            "(bias east / (W cos lat)): the linear tilt model of 000 is off by about that "
            "fraction; the estimates rest on the exact rotation model. An ETT or known "
            "heading (alignment.method) avoids the heading error",
        )
    return ()


def _with_instability(ctx, check, settings, window):
    """The mount check's 1-sigma with the stated bias instability: a wandering bias
    leaves a return-to-start residual that a constant one does not."""
    stated = settings.stated
    if stated.bias_instability == 0.0:
        return check
    w = budget.interval_weights(ctx.response, check.weights)
    extra = budget.instability_sigma(
        ctx, w, check.heading_gain, window, stated.bias_instability, stated.corr_time, False
    )
    return replace(check, sigma=np.hypot(check.sigma, extra))


def _mount_choice(ctx, est, geometry, settings, heading_sigma, window):
    """Mount check and the choice of the east formula (000 §3.2)."""
    gyrocompass = settings.heading_method == HeadingMethod.GYROCOMPASS
    reference = est[Estimator.EQ44] if gyrocompass else est[Estimator.EQ45]
    check = _with_instability(
        ctx, methods.mount_check(ctx, reference, heading_sigma), settings, window
    )
    threshold = np.maximum(settings.k_sigma * check.sigma, settings.floor)
    return check, threshold, methods.choose(geometry, check, not gyrocompass, threshold)


def _recheck_north(ctx, eq38, check, geometry, settings, heading_sigma, window):
    """With the east axis rejected, the north residual is checked again against eq. 38
    alone (the east bias from the velocity method): the rejected pair must not speak for
    the north axis (issue 7 item 2)."""
    north = geometry.horizontal.index(geometry.north)
    again = _with_instability(ctx, methods.mount_check(ctx, eq38, heading_sigma), settings, window)
    residual, sigma = check.residual.copy(), check.sigma.copy()
    residual[north], sigma[north] = again.residual[north], again.sigma[north]
    check = methods.MountCheck(residual, sigma)
    return check, np.maximum(settings.k_sigma * check.sigma, settings.floor)


def _ett_heading(record, ett, window):
    """IMU heading (rad) at the alignment window from the ETT mounting and the encoders."""
    inside = (record.encoder_time >= window[0]) & (record.encoder_time <= window[1])
    if not np.any(inside):
        raise InputError(
            "alignment method ett needs encoder readings in the alignment "
            f"window {window[0]:g}-{window[1]:g} s",
            source=record.source,
            key="table/encoder",
        )
    return float(ett.heading_at(record.encoder[inside].mean(axis=0)))


def _with_alignment_noise(est, tilt_sigma, heading_sigma):
    """Add the alignment's own noise (levelling, heading) through the estimate's
    sensitivity to the initial attitude error; independent of the noise after it."""
    sigma_phi0 = np.nan_to_num(np.array([tilt_sigma, tilt_sigma, heading_sigma]))
    extra = np.sqrt((est.phi_gain**2) @ sigma_phi0**2)
    return replace(est, sigma=np.hypot(est.sigma, extra))


def _epoch_tilts(ctx):
    """Mean tilt of each epoch window (rad), shape (5, 3)."""
    return np.array(
        [
            ctx.eps[(ctx.track.time >= a - 1e-9) & (ctx.track.time <= b + 1e-9)].mean(axis=0)
            for a, b in ctx.windows
        ]
    )


def _chosen(est, geometry, choice):
    """Automatic choice per body axis: (value, sigma, formula name) or None."""
    if Estimator.EQ44 not in est:
        return dict.fromkeys(geometry.horizontal)
    h = geometry.horizontal
    pair = est[choice.east_formula or Estimator.EQ38]
    north = h.index(geometry.north)
    east = h.index(geometry.east)
    out = {geometry.north: (pair.value[north], pair.sigma[north], methods.EQ38)}
    if choice.east_formula is None:
        out[geometry.east] = None
    else:
        out[geometry.east] = (pair.value[east], pair.sigma[east], choice.east_formula)
    return out


def _with_truth(outcome, record, ctx):
    """True mean biases over the navigation, true initial attitude error, and the
    biases each formula should carry by eqs. (1)-(2) of :mod:`.tilt_model` (000 eqs. 26-45)."""
    truth = record.truth
    track = ctx.track
    t0, t1 = outcome.seq.nav_start, outcome.seq.nav_end
    inside = (truth.time > t0) & (truth.time <= t1)
    bias = truth.gyro_bias[inside].mean(axis=0)
    quat0 = _interp_quat(truth.time, truth.quat_nb, t0)
    phi0 = error_model.attitude_error(outcome.align.mat_nb, rotation.mat_from_quat(quat0))
    mount = np.stack(
        [np.interp(track.time, truth.time, truth.mount_rotvec[:, i]) for i in range(3)], axis=1
    )
    predicted = {}
    for name, est in outcome.estimates.items():
        mount_term = 0.0 if est.weights is None else np.einsum("ami,mi->a", est.weights, mount)
        predicted[name] = est.error_from(bias, phi0, mount_term)
    return replace(outcome, truth=CalibrationTruth(bias, phi0, predicted, mount))


def _interp_quat(time, quat, t):
    k = int(np.clip(np.searchsorted(time, t), 1, len(time) - 1))
    w = (t - time[k - 1]) / (time[k] - time[k - 1])
    q = (1 - w) * quat[k - 1] + w * quat[k]
    return q / np.linalg.norm(q)
