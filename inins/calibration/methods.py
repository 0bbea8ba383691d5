"""Gyro-bias estimators of 000 on a navigated return sequence, and the automatic choice.

Epoch tilts eps(0..4) (:mod:`inins.calibration.sequence`, :mod:`.tilt_model`) per
horizontal body axis; T_A, T_B the navigation times between epochs at A and B:

- attitude-error two-position method (000 eqs. 28-29; eq. 44 is the same
  combination written with pitch):
  ``[(eps1 - eps0) / T_A + (eps3 - eps2) / T_B] / 2``
- return sequence (000 eqs. 38, 45): ``(eps1 + eps3 - eps2 - eps4) / (T_A + T_B)``
- return to start (000 eqs. 35, 43): ``eps4 - eps0``, the mount rotation over the
  sequence plus, about the axis that points east at A, twice the heading-error
  drift (000 eq. 26).

The heading error phi_D drives only the tilt about the axis pointing east at A
(000 eq. 14). About the north axis eq. 38 is therefore always valid; about the
east axis eq. 44 (attitude) is valid when the mount does not turn about that
axis (M3 + M4 = 0) and eq. 45 when the initial heading error is ~0 (ETT or a
known heading). Each estimate solves a pair of formulas (east axis, north axis)
with their exact gains (:func:`inins.calibration.tilt_model.formula_gain`), so the
rotation time and Earth-rate coupling that the paper's first-order formulas
neglect do not bias it.
"""

import enum
from dataclasses import dataclass, field, replace

import numpy as np

from inins.calibration import exact_model, tilt_model, velocity


class Estimator(enum.StrEnum):
    """The estimates calibrate-bias reports side by side (a pair of formulas each, for
    the east and north axes at A; :data:`COEFFICIENTS` names the per-axis formulas)."""

    ATTITUDE = "attitude"
    VELOCITY = "velocity"
    EQ44 = "eq44"
    EQ45 = "eq45"
    EQ38 = "eq38"  # eq. 38 alone (north), the east bias from the velocity method


class Formula(enum.StrEnum):
    """A per-axis linear combination of the epoch tilts."""

    ATTITUDE = "attitude"
    RETURN = "return"
    RETURN_TO_START = "return_to_start"


EQ38 = "eq38"
"""Name of the north-axis return-sequence formula (000 eq. 38) in the results."""

COEFFICIENTS = {
    Formula.ATTITUDE: lambda ta, tb: [-0.5 / ta, 0.5 / ta, -0.5 / tb, 0.5 / tb, 0.0],
    Formula.RETURN: lambda ta, tb: [
        0.0,
        1 / (ta + tb),
        -1 / (ta + tb),
        1 / (ta + tb),
        -1 / (ta + tb),
    ],
    Formula.RETURN_TO_START: lambda ta, tb: [-1.0, 0.0, 0.0, 0.0, 1.0],
}


@dataclass(frozen=True)
class Geometry:
    """Which horizontal body axis points east (and which north) at position A.

    ``aligned`` is False when neither horizontal axis is within 10 deg of east
    or west; the return-sequence formulas are then not applicable by axis.
    """

    horizontal: list
    east: int
    north: int
    aligned: bool

    @classmethod
    def at_start(cls, track):
        east_b = track.mat_nb[0].T @ [0.0, 1.0, 0.0]
        h = track.horizontal
        east = h[int(np.argmax(np.abs(east_b[h])))]
        north = h[0] if east == h[1] else h[1]
        return cls(h, east, north, bool(abs(east_b[east]) > np.cos(np.radians(10.0))))


@dataclass(frozen=True)
class Estimate:
    """A bias estimate for both horizontal axes (rad/s) from a pair of formulas.

    ``phi_gain`` (2, 3): sensitivity of the estimate to the initial attitude error
    phi0 (NED) beyond the heading error it assumes, ``heading_per_bias`` (3,): that
    assumption, ``phi_D0 = heading_per_bias . b`` (zero: a heading error of 0);
    ``weights`` (2, m, 3): its weights on the tilt samples (None if not a tilt formula).
    """

    value: np.ndarray
    sigma: np.ndarray
    phi_gain: np.ndarray
    heading_per_bias: np.ndarray
    weights: np.ndarray = field(repr=False)

    def error_from(self, bias, phi0, mount_weights_dot=0.0):
        """Error this estimate carries by the linear model (000 eqs. 26-45): from the
        initial attitude error beyond its assumption, and the mount term given."""
        assumed = np.array([0.0, 0.0, self.heading_per_bias @ bias])
        return self.phi_gain @ (phi0 - assumed) + mount_weights_dot


@dataclass(frozen=True)
class Context:
    """What every estimator needs, computed once."""

    track: tilt_model.Track
    windows: np.ndarray
    t_hold: tuple
    eps: np.ndarray
    response: tilt_model.Response
    phi_response: np.ndarray
    arw: np.ndarray
    bias_z: float
    heading_per_bias: np.ndarray
    exact: exact_model.ExactModel
    gyrocompass: bool

    @classmethod
    def build(cls, track, windows, t_hold, arw, bias_z=0.0, gyrocompass=False):
        """``gyrocompass``: the initial heading error follows the biases through the
        gyrocompass equilibrium ``phi_D = (mat_nb b)_E / (W cos lat)`` (000 §3.2:
        "heading error = beta_x / (Omega cos lambda)"); otherwise it is ~0."""
        w_h = np.linalg.norm(tilt_model.earth.rate_ie_n(track.lat)[:2])
        heading = track.mat_nb[0][1] / w_h if gyrocompass else np.zeros(3)
        phi_t = tilt_model.earth_transition(track)
        g = tilt_model.bias_response(track, phi_t)
        phi_response = np.concatenate([-g, phi_t], axis=2)
        response = tilt_model.Response.of(track, phi_t, g)
        return cls(
            track,
            np.asarray(windows),
            t_hold,
            tilt_model.tilts(track),
            response,
            phi_response,
            np.broadcast_to(np.asarray(arw, float), (3,)),
            bias_z,
            heading,
            exact_model.ExactModel.of(track, phi_t, response.phit_nb),
            bool(gyrocompass),
        )

    def full_bias(self, horizontal_bias):
        """Body-frame bias (3,) from the horizontal pair, the vertical one taken as known."""
        b = np.full(3, float(self.bias_z))
        b[self.track.horizontal] = horizontal_bias
        return b

    def weights(self, kinds):
        """Weights (2, m, 3) of one formula per horizontal axis: ``kinds[axis] -> name``."""
        out = []
        for axis in self.track.horizontal:
            terms = COEFFICIENTS[kinds[axis]](*self.t_hold)
            if any(terms[len(self.windows) :]):
                raise ValueError(f"{kinds[axis]} needs epoch 4: the return to the first position")
            coef = np.zeros((len(self.windows), 3))
            coef[:, axis] = terms[: len(self.windows)]
            out.append(tilt_model.window_weights(self.track, self.windows, coef))
        return np.array(out)

    def evaluate(self, weights):
        """Formula values (k,) from the tilt samples."""
        return np.einsum("kmi,mi->k", weights, self.eps)

    def gain(self, weights):
        return tilt_model.formula_gain(weights, self.response)

    def sigma(self, weights):
        return tilt_model.arw_sigma(self.track, weights, self.arw, self.response)


JACOBIAN_TOL = 1e-2
"""Where the exact model's gain differs from the linear one by more than this (relative;
biases above ~0.1 deg/h after gyrocompassing), the 1-sigma and the attitude-error gains
are formed with it; below, the linear ones are within 1 %."""


def _with_heading(gain, heading_per_bias):
    """Bias gains with the assumed heading error ``phi_D0 = heading_per_bias . b`` folded in."""
    return gain.s_bias + np.outer(gain.s_phi[:, 2], heading_per_bias)


def _estimate(ctx, values, s_bias, s_phi, weights, heading, gain_h=None):
    """Solve ``values = s_bias b`` for the horizontal biases, b_z taken as known;
    ``gain_h`` (2, 2): the gain through which the formulas' noise and the initial attitude
    error reach the estimate (default ``s_bias`` on the horizontal axes)."""
    h, v = ctx.track.horizontal, ctx.track.down_axis
    inv = np.linalg.inv(s_bias[:, h] if gain_h is None else gain_h)
    rhs = values - s_bias[:, v] * ctx.bias_z
    combined = None if weights is None else np.einsum("ak,kmi->ami", inv, weights)
    sigma = None if weights is None else ctx.sigma(combined)
    value = np.linalg.inv(s_bias[:, h]) @ rhs if gain_h is not None else inv @ rhs
    return Estimate(value, sigma, inv @ s_phi, heading, combined)


def solve(ctx, kinds, heading_known=False):
    """Bias estimate from one formula per horizontal axis, with exact gains.

    ``heading_known``: take the initial heading error as zero (eq. 45's assumption)
    instead of the one the gyrocompass equilibrium implies.
    """
    weights = ctx.weights(kinds)
    gain = ctx.gain(weights)
    heading = np.zeros(3) if heading_known else ctx.heading_per_bias
    s_bias = _with_heading(gain, heading)
    est = _estimate(ctx, ctx.evaluate(weights), s_bias, gain.s_phi, weights, heading)
    h, gyro = ctx.track.horizontal, ctx.gyrocompass and not heading_known
    exact = exact_model.refine(ctx.exact, weights, s_bias, ctx.full_bias(est.value), h, gyro)
    if np.all(np.isfinite(exact)):  # noise propagates through the exact model's gain
        jac = exact_model.jacobian(ctx.exact, weights, exact, h, gyro)
        if np.max(np.abs(jac - s_bias[:, h])) > JACOBIAN_TOL * np.max(np.abs(s_bias[:, h])):
            est = _estimate(ctx, ctx.evaluate(weights), s_bias, gain.s_phi, weights, heading, jac)
    return replace(est, value=exact[h])


def solve_north(ctx, geometry, east):
    """eq. 38 alone for the axis pointing north at A, the east bias taken from ``east``.

    Used where the east formulas are rejected (mount rotation about east after a
    gyrocompass alignment): eq. 38 then must not borrow the east bias from a pair that
    the mount spoils. The north formula responds to the east bias only through the two
    turns, ``2 Delta / (pi T)`` (~4 % for 18 s turns and T = 300 s); ``east`` is the
    velocity-error estimate, which a mount rotation does not reach (the computed
    attitude follows the IMU), and its 1-sigma enters through that coupling.

    Parameters
    ----------
    ctx : Context
    geometry : Geometry
    east : Estimate
        Supplies the east-axis bias and 1-sigma.

    Returns
    -------
    Estimate
        North: eq. 38; east: ``east``'s value and 1-sigma (tilt weights zero).
    """
    h = ctx.track.horizontal
    ie, in_ = h.index(geometry.east), h.index(geometry.north)
    weights = ctx.weights(dict.fromkeys(h, Formula.RETURN))[in_ : in_ + 1]
    gain = ctx.gain(weights)
    s = _with_heading(gain, ctx.heading_per_bias)[0]
    s_nn, coupling = s[geometry.north], s[geometry.east] / s[geometry.north]
    b = ctx.full_bias(east.value)
    known = [a for a in range(3) if a != geometry.north]
    b[geometry.north] = (ctx.evaluate(weights)[0] - s[known] @ b[known]) / s_nn
    b = exact_model.refine(ctx.exact, weights, s[None], b, [geometry.north], ctx.gyrocompass)
    row = weights[0] / s_nn
    value, sigma = np.array(east.value, float), np.array(east.sigma, float)
    value[in_] = b[geometry.north]
    sigma[in_] = np.hypot(ctx.sigma(row[None])[0], coupling * east.sigma[ie])
    phi_gain = np.array(east.phi_gain, float)
    phi_gain[in_] = gain.s_phi[0] / s_nn - coupling * east.phi_gain[ie]
    combined = np.zeros((2, *row.shape))
    combined[in_] = row
    return Estimate(value, sigma, phi_gain, ctx.heading_per_bias, combined)


def solve_velocity(ctx, windows, vrw=0.0, quantum=0.0):
    """Velocity-error method (000 eq. 12): mean of the two holds' tilt rates from the
    velocity curvature, with exact gains (:func:`inins.calibration.velocity.fit_gain`)."""
    track, h = ctx.track, ctx.track.horizontal
    fits = [velocity.fit_hold(track, w, float(np.mean(ctx.arw)), vrw, quantum) for w in windows]
    values = 0.5 * sum(velocity.tilt_rate(f, h) for f in fits)
    gain = 0.5 * sum(velocity.fit_gain(track, f, h, ctx.phi_response) for f in fits)
    gain = tilt_model.Gain(gain[:, :3], gain[:, 3:])
    s_bias = _with_heading(gain, ctx.heading_per_bias)
    est = _estimate(ctx, values, s_bias, gain.s_phi, None, ctx.heading_per_bias)
    inv = np.linalg.inv(s_bias[:, h])
    sigma = 0.5 * np.hypot(fits[0].sigma, fits[1].sigma) * np.sqrt(np.sum(inv**2, axis=1))
    return Estimate(est.value, sigma, est.phi_gain, est.heading_per_bias, None)


@dataclass(frozen=True)
class MountCheck:
    """Return-to-start residual (000 eqs. 35, 43) per horizontal axis (rad).

    ``residual = eps4 - eps0 - predicted``, where ``predicted`` is what the
    biases (and, for a gyrocompass alignment, the heading error they imply)
    produce: the mount rotation over the sequence, if the prediction holds.
    ``weights`` (2, m, 3): the residual's weights on the tilt samples; ``heading_gain``
    (2,): its sensitivity to an initial heading error the biases do not explain (both for
    the noise of a wandering bias, :func:`inins.calibration.budget.instability_sigma`).
    """

    residual: np.ndarray
    sigma: np.ndarray
    weights: np.ndarray | None = field(default=None, repr=False)
    heading_gain: np.ndarray | None = None


def mount_check(ctx, reference, heading_sigma=0.0):
    """Mount rotation over the sequence from the return to the start attitude.

    Parameters
    ----------
    ctx : Context
        Its heading model (gyrocompass or not) gives the heading error predicted
        from the biases.
    reference : Estimate
        Biases used for the prediction; the caller picks one that does not rely
        on the mount staying still about the east axis (eq. 44 after a
        gyrocompass alignment, eq. 45 with a known heading).
    heading_sigma : float
        1-sigma noise of the alignment heading (rad).
    """
    track = ctx.track
    h = track.horizontal
    weights = ctx.weights(dict.fromkeys(h, Formula.RETURN_TO_START))
    gain = ctx.gain(weights)
    k = _with_heading(gain, ctx.heading_per_bias)
    predicted = ctx.exact.evaluate(weights, ctx.full_bias(reference.value), ctx.gyrocompass)
    residual = ctx.evaluate(weights) - predicted
    resid_weights = weights - np.einsum("ak,kmi->ami", k[:, h], reference.weights)
    heading_gain = gain.s_phi[:, 2] - k[:, h] @ reference.phi_gain[:, 2]
    sigma = np.hypot(ctx.sigma(resid_weights), gain.s_phi[:, 2] * heading_sigma)
    return MountCheck(residual, sigma, resid_weights, heading_gain)


@dataclass(frozen=True)
class Choice:
    """The automatic choice for the east axis and why (000 §3.2)."""

    east_formula: Estimator | None
    reason: str


NO_RETURN = Choice(
    None,
    "the record does not return to the first position (000 Table 1): "
    "the mount rotation cannot be checked and eqs. 38, 44-45 are not "
    "applicable; the attitude- and velocity-error methods are given, "
    "unverified against mount rotation and accelerometer changes",
)


def choose(geometry, check, heading_trusted, threshold):
    """Pick the valid formula for the axis that points east at A.

    ``threshold`` (2,) rad: a residual above it means the mount turned.
    """
    h = geometry.horizontal
    east = h.index(geometry.east)
    moved = abs(check.residual[east]) > threshold[east]
    if heading_trusted:
        if moved:
            return Choice(
                Estimator.EQ45,
                "mount rotation about the east axis detected from the return "
                "to the start attitude (000 eq. 43) and the initial heading is known "
                "(ETT or given): eq. 45 is valid, eq. 44 is not",
            )
        return Choice(
            Estimator.EQ44,
            "no mount rotation about the east axis (000 eq. 43): eq. 44 "
            "(the attitude-error combination, lower noise than eq. 45) is valid",
        )
    if moved:
        return Choice(
            None,
            "the return to the start attitude (000 eq. 43) disagrees with the "
            "heading error of the gyrocompass alignment: the mount turned about the "
            "east axis, and with an initial heading error this cannot be separated "
            "from the bias (000 §3.2). No valid formula for this axis: align with "
            "ETT (inins align-ett) or give a known heading, and repeat",
        )
    return Choice(
        Estimator.EQ44,
        "no mount rotation about the east axis detected (the return to the "
        "start attitude matches the gyrocompass heading error, 000 eqs. 26, 43): "
        "eq. 44 is valid; eq. 45 carries the heading error",
    )
