"""Inertial sensor error model and its application to ideal increments.

Error model (000 eq. 2, 003 eqs. 2-5), per sample ``k`` of length ``dt``::

    dtheta_meas = Q_g( M_g @ dtheta + b_g[k] * dt + n_g[k] )
    dv_meas     = Q_a( M_a @ dv     + b_a[k] * dt + n_a[k] )

Scale factor and misalignment (sensor errors are measured minus true)::

          [1 + s_x   b_xy     b_xz  ]           [1 + s_x   0        0      ]
    M_g = [b_yx      1 + s_y  b_yz  ]     M_a = [a_yx      1 + s_y  0      ]
          [b_zx      b_zy     1 + s_z]          [a_zx      a_zy     1 + s_z]

``b_ij`` (``a_ij``) is the angle by which sensor ``i`` is tilted toward body
axis ``j``: the sensor measures ``w_i + b_ij w_j``. The body frame is the
accelerometer triad, so ``a_xy = a_xz = a_yz = 0`` by definition (000 Fig. 1).

Total bias per sample (``k`` indexes samples; ``T`` is the temperature offset
from the reference temperature, K)::

    b[k] = b0 + c[k] + k_T * T[k] + b_extra[k]

``c`` is a first-order Gauss-Markov process with stationary sigma ``sigma`` and
correlation time ``tau``, propagated with the exact discrete recursion at the
sample boundaries, ``rho = exp(-dt / tau)``::

    c(t_{k+1}) = rho c(t_k) + sigma sqrt(1 - rho^2) w_k,   w_k ~ N(0, 1)

and started from a stationary draw ``c(t_0) ~ N(0, sigma^2)``. Its contribution
to an increment, ``int c dt`` over the sample, is taken by the trapezoid rule,
``c[k] = (c(t_k) + c(t_{k+1})) / 2``. What this neglects is the fluctuation of
the process between the two boundary values (an Ornstein-Uhlenbeck bridge),
whose standard deviation in the increment is ``sigma dt sqrt(dt / (6 tau))``
(2e-4 of ``sigma dt`` at 1 kHz and tau = 1 h, 4e-3 at tau = 10 s); the mean of the bridge
differs from the trapezoid by a relative ``O((dt / tau)^2)``. ``tau = inf``
gives a random constant (turn-on bias).

White noise: ``n[k] ~ N(0, (N sqrt(dt))^2)`` per axis, ``N`` the angle (velocity)
random walk in rad/sqrt(s) (m/s/sqrt(s)).

Quantization ``Q`` to the pulse weight ``q`` keeps the remainder for the next
sample, as a ring-laser gyro or a pulse-rebalanced accelerometer does::

    r_0 = 0,   u_k = y_k + r_k,   out_k = q round(u_k / q),   r_{k+1} = u_k - out_k

so ``sum(out) = sum(y) - r_n`` with ``|r_n| <= q / 2``: the quantization error of
the accumulated output never grows. ``q = 0`` disables it.
"""

import math
from dataclasses import dataclass, field, fields
from typing import NamedTuple

import numpy as np

from inins.core import jit

__all__ = [
    "BiasTruth",
    "ImuState",
    "SensorErrors",
    "apply_errors",
]

# name -> (size, constraint); size 3 fields also accept a scalar (same on all axes)
_SPEC = {
    "gyro_bias": (3, "any"),
    "gyro_scale": (3, "scale"),
    "gyro_misalignment": (6, "any"),
    "accel_bias": (3, "any"),
    "accel_scale": (3, "scale"),
    "accel_misalignment": (3, "any"),
    "gyro_arw": (3, "nonneg"),
    "accel_vrw": (3, "nonneg"),
    "gyro_bias_instability": (3, "nonneg"),
    "gyro_bias_corr_time_s": (3, "time"),
    "accel_bias_instability": (3, "nonneg"),
    "accel_bias_corr_time_s": (3, "time"),
    "gyro_temp_sensitivity": (3, "any"),
    "accel_temp_sensitivity": (3, "any"),
    "gyro_pulse_weight": (3, "nonneg"),
    "accel_pulse_weight": (3, "nonneg"),
}


def _vector(name, value, size, allow_scalar=True):
    """Float copy of ``value`` with shape ``(size,)``, read-only; ValueError names the field."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0 and allow_scalar:
        arr = np.full(size, float(arr))
    if arr.shape != (size,):
        scalar = " or a scalar" if allow_scalar else ""
        raise ValueError(f"{name}: expected shape ({size},){scalar}, got {arr.shape}")
    arr = arr.copy()
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, eq=False)
class SensorErrors:
    """Errors of a gyro triad and an accelerometer triad, SI units (000 eq. 2, 003 eqs. 2-5).

    Every per-axis field takes a scalar (the same value on x, y, z) or shape (3,);
    misalignments need their full shape. Defaults are zero (an ideal IMU).

    Attributes
    ----------
    gyro_bias : ndarray, shape (3,)
        Constant gyro bias (rad/s).
    gyro_scale : ndarray, shape (3,)
        Gyro scale-factor error (dimensionless, > -1).
    gyro_misalignment : ndarray, shape (6,)
        ``[b_xy, b_xz, b_yx, b_yz, b_zx, b_zy]`` (rad): gyro i tilted toward axis j.
    accel_bias : ndarray, shape (3,)
        Constant accelerometer bias (m/s^2).
    accel_scale : ndarray, shape (3,)
        Accelerometer scale-factor error (dimensionless, > -1).
    accel_misalignment : ndarray, shape (3,)
        ``[a_yx, a_zx, a_zy]`` (rad); ``a_xy = a_xz = a_yz = 0`` define the body frame.
    gyro_arw : ndarray, shape (3,)
        Angle random walk (rad/sqrt(s)), >= 0.
    accel_vrw : ndarray, shape (3,)
        Velocity random walk (m/s/sqrt(s)), >= 0.
    gyro_bias_instability : ndarray, shape (3,)
        Stationary sigma of the Gauss-Markov gyro bias (rad/s), >= 0. This is the
        process sigma, not the flicker floor of an Allan deviation plot.
    gyro_bias_corr_time_s : ndarray, shape (3,)
        Its correlation time (s); must be > 0 (``inf`` allowed: random constant)
        on axes with a non-zero instability, ignored elsewhere.
    accel_bias_instability : ndarray, shape (3,)
        Stationary sigma of the Gauss-Markov accelerometer bias (m/s^2), >= 0.
    accel_bias_corr_time_s : ndarray, shape (3,)
        Its correlation time (s), as for the gyro.
    gyro_temp_sensitivity : ndarray, shape (3,)
        Gyro bias change per kelvin of temperature offset (rad/s/K).
    accel_temp_sensitivity : ndarray, shape (3,)
        Accelerometer bias change per kelvin (m/s^2/K); ~10 ug/K in 000 §2.
    gyro_pulse_weight : ndarray, shape (3,)
        Gyro output quantum (rad), >= 0; 0 means no quantization.
    accel_pulse_weight : ndarray, shape (3,)
        Accelerometer output quantum (m/s), >= 0; 0 means no quantization.
    """

    gyro_bias: np.ndarray = field(default=0.0)
    gyro_scale: np.ndarray = field(default=0.0)
    gyro_misalignment: np.ndarray = field(default_factory=lambda: np.zeros(6))
    accel_bias: np.ndarray = field(default=0.0)
    accel_scale: np.ndarray = field(default=0.0)
    accel_misalignment: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gyro_arw: np.ndarray = field(default=0.0)
    accel_vrw: np.ndarray = field(default=0.0)
    gyro_bias_instability: np.ndarray = field(default=0.0)
    gyro_bias_corr_time_s: np.ndarray = field(default=0.0)
    accel_bias_instability: np.ndarray = field(default=0.0)
    accel_bias_corr_time_s: np.ndarray = field(default=0.0)
    gyro_temp_sensitivity: np.ndarray = field(default=0.0)
    accel_temp_sensitivity: np.ndarray = field(default=0.0)
    gyro_pulse_weight: np.ndarray = field(default=0.0)
    accel_pulse_weight: np.ndarray = field(default=0.0)

    def __post_init__(self):
        for name, (size, kind) in _SPEC.items():
            arr = _vector(name, getattr(self, name), size, allow_scalar=size == 3)
            if kind == "time":
                if np.any(np.isnan(arr)) or np.any(arr < 0.0):
                    raise ValueError(f"{name}: must be >= 0 (inf allowed), got {arr}")
            elif not np.all(np.isfinite(arr)):
                raise ValueError(f"{name}: must be finite, got {arr}")
            if kind == "nonneg" and np.any(arr < 0.0):
                raise ValueError(f"{name}: must be >= 0, got {arr}")
            if kind == "scale" and np.any(arr <= -1.0):
                raise ValueError(f"{name}: must be > -1, got {arr}")
            object.__setattr__(self, name, arr)
        for sensor in ("gyro", "accel"):
            sigma = getattr(self, f"{sensor}_bias_instability")
            tau = getattr(self, f"{sensor}_bias_corr_time_s")
            if np.any((sigma > 0.0) & (tau <= 0.0)):
                raise ValueError(
                    f"{sensor}_bias_corr_time_s: must be > 0 where "
                    f"{sensor}_bias_instability > 0, got {tau}"
                )

    @classmethod
    def none(cls):
        """An ideal IMU: every error zero."""
        return cls()

    def __eq__(self, other):
        if not isinstance(other, SensorErrors):
            return NotImplemented
        return all(
            np.array_equal(getattr(self, f.name), getattr(other, f.name)) for f in fields(self)
        )

    __hash__ = None

    def gyro_matrix(self):
        """``M_g = I + S_g + B_g`` (dimensionless), shape (3, 3): ``w_meas = M_g @ w``."""
        bxy, bxz, byx, byz, bzx, bzy = self.gyro_misalignment
        sx, sy, sz = self.gyro_scale
        return np.array([[1.0 + sx, bxy, bxz], [byx, 1.0 + sy, byz], [bzx, bzy, 1.0 + sz]])

    def accel_matrix(self):
        """``M_a = I + S_a + A_a`` (dimensionless), shape (3, 3), lower triangular."""
        ayx, azx, azy = self.accel_misalignment
        sx, sy, sz = self.accel_scale
        return np.array([[1.0 + sx, 0.0, 0.0], [ayx, 1.0 + sy, 0.0], [azx, azy, 1.0 + sz]])


@dataclass(frozen=True, eq=False)
class ImuState:
    """What :func:`apply_errors` carries from one chunk of a record to the next.

    Attributes
    ----------
    gyro_gm, accel_gm : ndarray, shape (3,)
        Gauss-Markov bias at the end of the last sample (rad/s, m/s^2).
    gyro_residual, accel_residual : ndarray, shape (3,)
        Quantization remainder not yet output (rad, m/s), ``|r| <= q / 2``.
    """

    gyro_gm: np.ndarray
    accel_gm: np.ndarray
    gyro_residual: np.ndarray
    accel_residual: np.ndarray

    def __post_init__(self):
        for f in fields(self):
            arr = _vector(f.name, getattr(self, f.name), 3, allow_scalar=False)
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{f.name}: must be finite, got {arr}")
            object.__setattr__(self, f.name, arr)

    @classmethod
    def stationary(cls, errors, rng):
        """Start of a record: Gauss-Markov biases drawn from N(0, sigma^2), zero remainders.

        Draws one standard normal per axis with a non-zero instability, in the order
        gyro x, y, z, accel x, y, z.
        """
        sigma = np.concatenate([errors.gyro_bias_instability, errors.accel_bias_instability])
        active = sigma > 0.0
        gm = np.zeros(6)
        gm[active] = sigma[active] * rng.standard_normal(int(active.sum()))
        return cls(gm[:3], gm[3:], np.zeros(3), np.zeros(3))


class BiasTruth(NamedTuple):
    """Total bias actually applied, per sample (the mean over the sample).

    An immutable pair: ``truth.gyro`` or ``truth[0]``, ``truth.accel`` or ``truth[1]``.

    Attributes
    ----------
    gyro : ndarray, shape (n, 3)
        ``b0 + c[k] + k_T T[k] + b_extra[k]`` (rad/s).
    accel : ndarray, shape (n, 3)
        The same for the accelerometers (m/s^2).
    """

    gyro: np.ndarray
    accel: np.ndarray


@jit.njit(cache=True, nogil=True, error_model="numpy")
def _kernel(
    ideal_g, ideal_a, dt, mat_g, mat_a, par, temp, extra_g, extra_a, carry, gen, out, every, work
):
    """One pass over the samples.

    ``par`` (6, 6) rows: bias, white sigma, rho, GM drive, k_T, pulse weight per
    channel (gyro x, y, z, accel x, y, z). ``carry`` (2, 6): GM value and
    quantization remainder, updated in place. ``out``: (n, 3) gyro and accel
    outputs and (n // every, 3) gyro and accel truth (means over ``every``
    samples, accumulated into zeros), filled in place. ``work`` (3, 6): zeros,
    scratch for the white noise, the bias and the output of each channel (allocated
    by the caller: an allocation inside the kernel compiles numba's array
    constructors too).
    """
    bias, white, rho, drive, k_temp, pulse = par[0], par[1], par[2], par[3], par[4], par[5]
    gm, resid = carry[0], carry[1]
    out_g, out_a, truth_g, truth_a = out
    n = ideal_g.shape[0]
    has_temp = temp.shape[0] == n
    has_xg = extra_g.shape[0] == n
    has_xa = extra_a.shape[0] == n
    noise, b, y = work[0], work[1], work[2]
    weight = 1.0 / every
    for k in range(n):
        row = k // every
        # draw order: white gyro xyz, white accel xyz, GM gyro xyz, GM accel xyz
        for c in range(6):
            if white[c] > 0.0:
                noise[c] = white[c] * gen.standard_normal()
        for c in range(6):
            c_next = rho[c] * gm[c]
            if drive[c] > 0.0:
                c_next += drive[c] * gen.standard_normal()
            b[c] = bias[c] + 0.5 * (gm[c] + c_next)
            gm[c] = c_next
            if has_temp:
                b[c] += k_temp[c] * temp[k]
        for i in range(3):
            if has_xg:
                b[i] += extra_g[k, i]
            if has_xa:
                b[3 + i] += extra_a[k, i]
            truth_g[row, i] += weight * b[i]
            truth_a[row, i] += weight * b[3 + i]
            y[i] = b[i] * dt + noise[i]
            y[3 + i] = b[3 + i] * dt + noise[3 + i]
            for j in range(3):
                y[i] += mat_g[i, j] * ideal_g[k, j]
                y[3 + i] += mat_a[i, j] * ideal_a[k, j]
        for c in range(6):
            if pulse[c] > 0.0:
                u = y[c] + resid[c]
                y[c] = math.floor(u / pulse[c] + 0.5) * pulse[c]
                resid[c] = u - y[c]
        for i in range(3):
            out_g[k, i] = y[i]
            out_a[k, i] = y[3 + i]


def _series(name, value, n, row_shape):
    """Contiguous float64 array of shape ``(n, *row_shape)`` or a 0-row placeholder."""
    if value is None:
        return np.zeros((0, *row_shape))
    arr = np.ascontiguousarray(value, dtype=np.float64)
    if arr.shape != (n, *row_shape):
        raise ValueError(f"{name}: expected shape {(n, *row_shape)}, got {arr.shape}")
    return arr


def apply_errors(
    dtheta,
    dv,
    dt,
    errors,
    rng,
    state=None,
    *,
    temperature_delta=None,
    gyro_bias_extra=None,
    accel_bias_extra=None,
    truth_every=1,
):
    """Turn ideal increments into measured ones (model in the module docstring).

    Parameters
    ----------
    dtheta : array_like, shape (n, 3)
        Ideal angle increments ``int omega_ib_b dt`` per sample (rad), body frame.
    dv : array_like, shape (n, 3)
        Ideal velocity increments ``int f_b dt`` per sample (m/s), body frame.
    dt : float
        Sample interval (s), > 0.
    errors : SensorErrors
    rng : numpy.random.Generator
        Source of all random draws; advanced in place.
    state : ImuState, optional
        From the previous chunk of the same record; ``None`` starts a record with
        :meth:`ImuState.stationary` (draws the initial Gauss-Markov biases).
    temperature_delta : array_like, shape (n,), optional
        Temperature offset from the reference per sample (K).
    gyro_bias_extra : array_like, shape (n, 3), optional
        Additional gyro bias per sample (rad/s), e.g. a step or drift.
    accel_bias_extra : array_like, shape (n, 3), optional
        Additional accelerometer bias per sample (m/s^2), e.g. the step after a
        table rotation (000 Fig. 2).
    truth_every : int
        Keep the bias truth as means over blocks of this many samples (``n``
        must be a multiple), to save memory and time on long records.

    Returns
    -------
    dtheta_meas : ndarray, shape (n, 3)
        Measured angle increments (rad), multiples of the pulse weight where set.
    dv_meas : ndarray, shape (n, 3)
        Measured velocity increments (m/s).
    new_state : ImuState
        Pass to the call for the next chunk.
    bias_truth : BiasTruth
        Total bias applied per sample, so that
        ``dtheta_meas = Q(M_g @ dtheta + bias_truth.gyro * dt + white noise)``;
        with ``truth_every > 1`` its means over blocks, shape (n // truth_every, 3).

    Notes
    -----
    Random draws, per sample in order: white noise gyro x, y, z, accel x, y, z,
    then Gauss-Markov innovations gyro x, y, z, accel x, y, z, each only where its
    sigma is non-zero (``K`` channels). The draws are exactly those of
    ``rng.standard_normal((n, K))`` row by row, preceded at the start of a record
    by those of :meth:`ImuState.stationary`. Hence, for the same ``errors`` and
    ``dt``, splitting a record into chunks (of any lengths, including zero)
    processed in order with one Generator, each call given the previous call's
    ``new_state`` and nothing else drawing from the Generator in between, gives
    bit-identical outputs, truth, final state and Generator state to one call.
    Non-finite input increments are not checked; they propagate.

    The work is one compiled pass (numba, cached on disk) that draws from ``rng``
    inside the loop; any BitGenerator works. Memory is the four (n, 3) float64
    outputs; stream long records in chunks to bound it.
    """
    if not isinstance(errors, SensorErrors):
        raise TypeError(f"errors: expected SensorErrors, got {type(errors).__name__}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng: expected numpy.random.Generator, got {type(rng).__name__}")
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt: must be finite and > 0, got {dt}")
    dtheta = np.ascontiguousarray(dtheta, dtype=np.float64)
    if dtheta.ndim != 2 or dtheta.shape[1] != 3:
        raise ValueError(f"dtheta: expected shape (n, 3), got {dtheta.shape}")
    n = dtheta.shape[0]
    truth_every = int(truth_every)
    if truth_every < 1 or n % truth_every:
        raise ValueError(f"truth_every: must be >= 1 and divide n = {n}, got {truth_every}")
    dv = _series("dv", dv, n, (3,))
    temp = _series("temperature_delta", temperature_delta, n, ())
    extra_g = _series("gyro_bias_extra", gyro_bias_extra, n, (3,))
    extra_a = _series("accel_bias_extra", accel_bias_extra, n, (3,))
    if state is None:
        state = ImuState.stationary(errors, rng)
    elif not isinstance(state, ImuState):
        raise TypeError(f"state: expected ImuState or None, got {type(state).__name__}")

    sigma = np.concatenate([errors.gyro_bias_instability, errors.accel_bias_instability])
    tau = np.concatenate([errors.gyro_bias_corr_time_s, errors.accel_bias_corr_time_s])
    active = sigma > 0.0
    ratio = dt / np.where(active, tau, 1.0)
    par = np.stack(
        [
            np.concatenate([errors.gyro_bias, errors.accel_bias]),
            np.concatenate([errors.gyro_arw, errors.accel_vrw]) * math.sqrt(dt),
            np.where(active, np.exp(-ratio), 0.0),
            np.where(active, sigma * np.sqrt(-np.expm1(-2.0 * ratio)), 0.0),
            np.concatenate([errors.gyro_temp_sensitivity, errors.accel_temp_sensitivity]),
            np.concatenate([errors.gyro_pulse_weight, errors.accel_pulse_weight]),
        ]
    )
    carry = np.array(
        [
            np.concatenate([state.gyro_gm, state.accel_gm]),
            np.concatenate([state.gyro_residual, state.accel_residual]),
        ]
    )
    m = n // truth_every
    out = (np.empty((n, 3)), np.empty((n, 3)), np.zeros((m, 3)), np.zeros((m, 3)))
    if n:
        mats = errors.gyro_matrix(), errors.accel_matrix()
        _kernel(
            dtheta,
            dv,
            dt,
            *mats,
            par,
            temp,
            extra_g,
            extra_a,
            carry,
            rng,
            out,
            truth_every,
            np.zeros((3, 6)),
        )
    gm, resid = carry
    new_state = ImuState(gm[:3], gm[3:], resid[:3], resid[3:])
    return out[0], out[1], new_state, BiasTruth(out[2], out[3])


def warm_up():
    """Compile (or load from the on-disk cache) the error kernel on two samples.

    Every call of :func:`apply_errors` passes the kernel the same argument types,
    so that later calls run without compiling.
    """
    errors = SensorErrors(gyro_arw=1e-6, gyro_bias_instability=1e-7, gyro_bias_corr_time_s=1.0)
    apply_errors(np.zeros((2, 3)), np.zeros((2, 3)), 0.01, errors, np.random.default_rng(0))
