"""Discrete rate-table calibration: multi-position static tests and rate tests.

Each interval of the schedule gives one mean of the increments, gyro and accelerometer:

- a **hold** (static position, the table at rest): ``f_meas = M_a R^T f + b_a`` and
  ``w_meas = M_g R^T w + G R^T f + b_g`` with ``f = C_bn (-g_n)`` and ``w = C_bn w_ie``
  from the encoder angles (the reference), ``R`` the small mounting rotation of the
  triad (:mod:`inins.calibration.imu_model`);
- a **spin** (rate test, one gimbal at constant rate): the gyro equation with the
  interval means of ``w = a_b dtheta/dt + C_bn w_ie`` and ``f``, over the constant-rate
  part only (found from the encoders; the accelerometers are not used there).

The terms asked for are estimated by weighted least squares over those means (Gauss-
Newton on the model above, exact: no small-error approximation, so noise-free data
come back to rounding), the others held at zero. Weights: white noise (angle and
velocity random walk ``N / sqrt(T)`` over an interval of ``T`` s), quantization
(``q / (sqrt(6) T)``: the remainders at both ends) and encoder noise on a spin's
angle (``sqrt(2) sigma_enc / T``). Bias instability and disturbances are not in the
weights (a lab schedule is short against the correlation time); the reported 1-sigma
is from ``(J^T W J)^-1`` and the chi-square of the residuals says whether the data
agree with it.

The same Jacobian, built from the motion program alone (no data), is the planner:
which terms are observable, their predicted 1-sigma, and the combinations that stay
inseparable (the null space of the information matrix).
"""

from dataclasses import dataclass

import numpy as np

from inins.calibration import imu_model, verdict
from inins.core import earth, rotation
from inins.table import kinematics

ACCEL = slice(3, 6)
GYRO = slice(0, 3)


@dataclass(frozen=True)
class Interval:
    """One mean of the schedule.

    Attributes
    ----------
    kind : str
        ``hold`` or ``spin``.
    label : str
    start, stop : int
        IMU samples [start, stop).
    duration : float
        s.
    w_ref, f_ref : ndarray, shape (3,)
        Mean angular rate (rad/s) and specific force (m/s^2) in nominal body axes
        from the encoders.
    w_ref_sigma : float
        1-sigma of ``w_ref`` along the spin axis from encoder noise (rad/s).
    """

    kind: str
    label: str
    start: int
    stop: int
    duration: float
    w_ref: np.ndarray
    f_ref: np.ndarray
    w_ref_sigma: float = 0.0


@dataclass(frozen=True)
class Geometry:
    """What the reference needs of the table: gimbal axes, base, nominal mounting, site."""

    axes: np.ndarray
    mat_n_base: np.ndarray
    mat_tb: np.ndarray
    lla: np.ndarray

    def mat_nb(self, angles):
        """Nominal body -> NED from gimbal angles, shape (..., 3, 3)."""
        return kinematics.platform_matrix(self.axes, self.mat_n_base, angles) @ self.mat_tb

    def gimbal_axis_b(self, gimbal, angles):
        """Unit axis of ``gimbal`` in nominal body axes at ``angles`` (inner gimbals fixed)."""
        mat = np.eye(3)
        for g in range(gimbal + 1, self.axes.shape[0]):
            mat = mat @ rotation.mat_from_rotvec(angles[g] * self.axes[g])
        return self.mat_tb.T @ mat.T @ self.axes[gimbal]

    @property
    def f_n(self):
        return -earth.gravity_n(self.lla[0], self.lla[2])

    @property
    def w_ie_n(self):
        return earth.rate_ie_n(self.lla[0])


MIN_HOLD = 1.0
"""Shortest usable hold after the settling time (s)."""
MOVING = 5e-5
"""Encoder peak-to-peak (rad, 10 arcsec) beyond which a hold is moving (on top of six
times the encoder noise)."""


def intervals(
    steps, enc_time, enc, geometry, t0, dt, n_samples, settle, encoder_sigma=0.0, flags=None
):
    """The holds and spins of a schedule as :class:`Interval` s.

    Parameters
    ----------
    steps : sequence of inins.core.records.Step
    enc_time, enc : ndarray, shape (m,), (m, g)
        Encoder readings (s, rad), or the motion program's angles on a grid (planning).
    geometry : Geometry
    t0, dt : float
        Start of the first sample and the sample interval (s).
    n_samples : int
    settle : float
        Time skipped at the start of each hold (s).
    encoder_sigma : float
        White noise of one encoder reading (rad).
    flags : list, optional
        Receives a message for every hold left out: shorter than :data:`MIN_HOLD` after
        the settling time, or moving (encoder peak-to-peak beyond :data:`MOVING`).
    """
    out = []
    flags = [] if flags is None else flags
    for k, s in enumerate(steps):
        kind = str(s.kind)
        if kind == "hold":
            i0 = min(s.start_index + int(np.ceil(settle / dt - 1e-9)), s.stop_index)
            i1 = s.stop_index
            if (i1 - i0) * dt < MIN_HOLD:
                flags.append(
                    f"step {k} (hold {s.label or '-'}): {(i1 - i0) * dt:g} s after the "
                    f"settling time, shorter than {MIN_HOLD:g} s: not used"
                )
                continue
            ta, tb = t0 + i0 * dt, t0 + i1 * dt
            sel = (enc_time >= ta) & (enc_time <= tb)
            if sel.any():
                spread = float(np.max(np.ptp(enc[sel], axis=0)))
                if spread > MOVING + 6.0 * encoder_sigma:
                    flags.append(
                        f"step {k} (hold {s.label or '-'}): the table moves by "
                        f"{np.degrees(spread) * 3600:.1f} arcsec during the hold: not used"
                    )
                    continue
            angles = enc[sel].mean(axis=0) if sel.any() else np.asarray(s.angles_end, float)
            mat_bn = geometry.mat_nb(angles).T
            out.append(
                Interval(
                    "hold",
                    s.label,
                    i0,
                    i1,
                    (i1 - i0) * dt,
                    mat_bn @ geometry.w_ie_n,
                    mat_bn @ geometry.f_n,
                )
            )
        elif kind == "spin":
            spin = _spin_interval(s, enc_time, enc, geometry, t0, dt, n_samples, encoder_sigma)
            if spin is not None:
                out.append(spin)
    return tuple(out)


def _spin_interval(s, enc_time, enc, geometry, t0, dt, n_samples, encoder_sigma):
    """The constant-rate part of a spin step (None if the encoders show none)."""
    g = s.axis
    sel = np.flatnonzero((enc_time >= s.start_time) & (enc_time <= s.end_time))
    if sel.size < 6:
        return None
    t, a = enc_time[sel], enc[sel, g]
    rate = np.diff(a) / np.diff(t)
    cruise = np.median(rate)
    good = np.flatnonzero(np.abs(rate - cruise) <= 0.01 * abs(cruise))
    if good.size < 5 or cruise == 0.0:
        return None
    ta, tb = t[good[0] + 2], t[good[-1] - 1]  # two encoder intervals inside the cruise
    i0 = int(np.ceil((ta - t0) / dt - 1e-9))
    i1 = min(int(np.floor((tb - t0) / dt + 1e-9)), n_samples)
    if i1 - i0 < 2:
        return None
    ta, tb = t0 + i0 * dt, t0 + i1 * dt
    # the spinning gimbal at the ends; the others (at rest) as their mean over the
    # interval, so that encoder noise does not tilt the spin axis
    inside = sel[(enc_time[sel] >= ta) & (enc_time[sel] <= tb)]
    still = enc[inside].mean(axis=0) if inside.size else enc[sel].mean(axis=0)
    ang_a, ang_b = still.copy(), still.copy()
    ang_a[g] = np.interp(ta, enc_time[sel], enc[sel, g])
    ang_b[g] = np.interp(tb, enc_time[sel], enc[sel, g])
    duration = tb - ta
    # the angle is linear in time over the cruise: Simpson on a fine grid is exact to
    # far below the noise for the mean attitude
    m = 4097
    frac = np.linspace(0.0, 1.0, m)
    grid = ang_a + frac[:, None] * (ang_b - ang_a)
    mat_bn = np.swapaxes(geometry.mat_nb(grid), -1, -2)
    wts = np.ones(m)
    wts[1:-1:2], wts[2:-1:2] = 4.0, 2.0
    mean_bn = np.einsum("k,kij->ij", wts, mat_bn) / wts.sum()
    axis_b = geometry.gimbal_axis_b(g, ang_a)
    w_ref = axis_b * (ang_b[g] - ang_a[g]) / duration + mean_bn @ geometry.w_ie_n
    return Interval(
        "spin",
        s.label,
        i0,
        i1,
        duration,
        w_ref,
        mean_bn @ geometry.f_n,
        np.sqrt(2.0) * encoder_sigma / duration,
    )


def measured_means(record, ivs):
    """Mean gyro rate and specific force over each interval, shape (n, 6) (rad/s, m/s^2)."""
    out = np.empty((len(ivs), 6))
    for k, iv in enumerate(ivs):
        dtheta, dv = record.imu(iv.start, iv.stop)
        out[k, GYRO] = dtheta.sum(axis=0) / iv.duration
        out[k, ACCEL] = dv.sum(axis=0) / iv.duration
    return out


# ----------------------------------------------------------------------------- model


def predict(values, names, ivs):
    """Model means (n, 6) for term values ``values`` (SI) of ``names`` (others zero)."""
    terms = imu_model.ImuTerms(dict(zip(names, values, strict=True)))
    r_t = terms.mount_matrix().T
    w = np.array([iv.w_ref for iv in ivs]) @ r_t.T
    f = np.array([iv.f_ref for iv in ivs]) @ r_t.T
    out = np.empty((len(ivs), 6))
    out[:, GYRO] = w @ terms.gyro_matrix().T + f @ terms.g_sensitivity().T + terms.gyro_bias()
    out[:, ACCEL] = f @ terms.accel_matrix().T + terms.accel_bias()
    return out


def _scales(names):
    """Typical magnitude of each term, for finite differences, conditioning and the
    verdict (:func:`inins.calibration.verdict.typical_scale`)."""
    return verdict.typical_scale(names)


def jacobian(values, names, ivs):
    """d predict / d values, shape (n, 6, p); central differences (the model is a
    polynomial of degree <= 3 in the terms: a step of 1e-4 of a typical size is exact
    to ~1e-13)."""
    h = 1e-4 * _scales(names)
    cols = []
    for k in range(len(names)):
        e = np.zeros(len(names))
        e[k] = h[k]
        cols.append(
            (predict(values + e, names, ivs) - predict(values - e, names, ivs)) / (2 * h[k])
        )
    return np.stack(cols, axis=-1)


def noise_from_holds(record, spans):
    """Angle and velocity random walk (rad/sqrt(s), m/s/sqrt(s), each (3,)) from the
    scatter of 1-s block means within the holds ``spans`` (samples [start, stop)) of a
    record: ``N = sd(block means) sqrt(T_block)`` (white noise; a hold shorter than four
    blocks is left out).

    Raises
    ------
    ValueError
        No hold of four blocks.
    """
    block = max(1, round(1.0 / record.dt))
    parts = ([], [])
    for start, stop in spans:
        if stop - start < 4 * block:
            continue
        dtheta, dv = record.imu(start, stop)
        m = (dtheta.shape[0] // block) * block
        for k, x in enumerate((dtheta, dv)):
            means = x[:m].reshape(-1, block, 3).sum(axis=1) / (block * record.dt)
            parts[k].append(means - means.mean(axis=0))
    if not parts[0]:
        raise ValueError("no hold long enough (4 s) to estimate the noise")
    t_block = block * record.dt
    return tuple(np.sqrt(np.mean(np.vstack(p) ** 2, axis=0) * t_block) for p in parts)


@dataclass(frozen=True)
class Noise:
    """White-noise figures per axis (SI): ARW (rad/sqrt(s)), VRW (m/s/sqrt(s)), pulse
    weights (rad, m/s; 0 = none)."""

    arw: np.ndarray
    vrw: np.ndarray
    gyro_quantum: np.ndarray
    accel_quantum: np.ndarray


def sigmas(ivs, noise, names=None, values=None):
    """1-sigma (n, 6) of every interval mean; NaN where a mean is not used (accelerometers
    during spins)."""
    out = np.full((len(ivs), 6), np.nan)
    gain = np.ones(3) if values is None else 1.0
    if values is not None:
        gain = np.abs(
            np.diag(imu_model.ImuTerms(dict(zip(names, values, strict=True))).gyro_matrix())
        )
    for k, iv in enumerate(ivs):
        t = iv.duration
        g = np.hypot(noise.arw / np.sqrt(t), noise.gyro_quantum / (np.sqrt(6.0) * t))
        out[k, GYRO] = np.hypot(g, gain * iv.w_ref_sigma)
        if iv.kind == "hold":
            out[k, ACCEL] = np.hypot(
                noise.vrw / np.sqrt(t), noise.accel_quantum / (np.sqrt(6.0) * t)
            )
    return out


Plan = verdict.Verdict
"""What a schedule can give, from its design alone (:class:`inins.calibration.verdict.Verdict`)."""


def plan(ivs, names, noise, values=None):
    """Observability and predicted 1-sigma of ``names`` over the intervals ``ivs``.

    Information ``J^T W J`` with ``J`` the model Jacobian at ``values`` (default zero:
    the nominal unit); a direction of eigenvalue below 1e-10 of the largest (after
    scaling each term to its typical size) is inseparable, and a term with any weight on
    such a direction is not separable (:func:`inins.calibration.verdict.from_information`).
    """
    names = tuple(names)
    values = np.zeros(len(names)) if values is None else np.asarray(values, float)
    jac = jacobian(values, names, ivs)
    sig = sigmas(ivs, noise, names, values)
    use = np.isfinite(sig)
    rows = jac[use] / sig[use][:, None]
    return verdict.from_information(rows.T @ rows, names, _scales(names))


@dataclass(frozen=True)
class Fit:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    names : tuple of str
    values, sigma : ndarray, shape (p,)
        Estimates and 1-sigma (SI).
    covariance : ndarray, shape (p, p)
    measured, predicted, sigma_means : ndarray, shape (n, 6)
        Interval means, the fitted model's means and their 1-sigma (NaN: not used).
    chi2 : float
        Sum of squared normalised residuals; ``dof`` its degrees of freedom.
    dof : int
    plan : Plan
        The observability of the schedule at the estimate.
    iterations : int
    """

    names: tuple
    values: np.ndarray
    sigma: np.ndarray
    covariance: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    sigma_means: np.ndarray
    chi2: float
    dof: int
    plan: Plan
    iterations: int

    @property
    def residuals(self):
        return self.measured - self.predicted

    @property
    def terms(self):
        return imu_model.ImuTerms(dict(zip(self.names, self.values, strict=True)))

    def correlation(self):
        d = np.sqrt(np.diag(self.covariance))
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.covariance / np.outer(d, d)


def calibrate(ivs, measured, names, noise, *, max_iter=10):
    """Weighted least squares of the terms ``names`` from the interval means.

    Gauss-Newton from the nominal unit (all terms zero); the minimum-norm step where the
    schedule leaves a combination free (those terms have ``inf`` sigma, see
    ``fit.plan``).
    """
    names = tuple(names)
    x = np.zeros(len(names))
    scale = _scales(names)
    iterations = 0
    for iterations in range(1, max_iter + 1):  # noqa: B007 - reported
        sig = sigmas(ivs, noise, names, x)
        use = np.isfinite(sig)
        jac = jacobian(x, names, ivs)[use] / sig[use][:, None]
        res = (measured - predict(x, names, ivs))[use] / sig[use]
        # singular values below 1e-5 of the largest: the directions the plan calls
        # inseparable (eigenvalues of the information below 1e-10), left unchanged
        step, *_ = np.linalg.lstsq(jac * scale, res, rcond=1e-5)
        step = step * scale
        x = x + step
        if np.all(np.abs(step) <= 1e-9 * scale):  # 1e-12 rad, 1e-12 of a scale factor
            break
    found = plan(ivs, names, noise, x)
    sig = sigmas(ivs, noise, names, x)
    use = np.isfinite(sig)
    pred = predict(x, names, ivs)
    chi2 = float((((measured - pred)[use] / sig[use]) ** 2).sum())
    ok = found.separable
    return Fit(
        names,
        x,
        found.sigma,
        found.covariance,
        measured,
        pred,
        sig,
        chi2,
        int(use.sum() - ok.sum()),
        found,
        iterations,
    )


MAX_MOUNT = np.radians(1.0)
"""Largest mounting rotation from the nominal IMU axes the small-angle model takes (rad)."""


def check_mounting(fit):
    """Raise ValueError when the fit did not converge to a small mounting rotation (the
    nominal IMU axes on the table are wrong: gravity and rates do not fit them)."""
    terms = dict(zip(fit.names, fit.values, strict=True))
    mount = np.array([terms.get(n, 0.0) for n in imu_model.MOUNT_TERMS])
    if not np.all(np.isfinite(fit.values)) or np.linalg.norm(mount) > MAX_MOUNT:
        raise ValueError(
            "the measured gravity and rates do not fit the nominal IMU axes on the table "
            f"(mounting rotation {np.degrees(np.linalg.norm(mount)):.3g} deg, chi-square "
            f"{fit.chi2:.3g} on {fit.dof} degrees of freedom)"
        )
