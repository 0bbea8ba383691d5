"""Navigation error definitions and the INS error-state model library.

Error definitions (package docstring): estimated minus true; attitude error is
the phi angle, ``mat_nb_est = (I - [phi x]) @ mat_nb_true``; position error is
expressed in NED metres at the true position; sensor errors are measured minus
true.

Error-state model (phi angle, NED)
----------------------------------
Linearising the strapdown equations ``C' = C [w_ib x] - [w_in x] C``,
``v' = C f_b - (2 w_ie + w_en) x v + g`` and ``p' = v`` about the true
trajectory, with ``w_in = w_ie(L) + w_en(L, h, v)`` evaluated by the INS at its
own (erroneous) position and velocity, gives to first order::

    dr'  = dv - w_en x dr + dtheta x v                          (position, NED m)
    dv'  = f_n x phi + C_nb df - (2 w_ie + w_en) x dv
           + v x (2 dw_ie + dw_en) + dg                         (velocity)
    phi' = -w_in x phi + dw_ie + dw_en - C_nb dw                 (attitude)
    df   = ba + diag(f_b) sa + M_a f_b,  dw = bg + diag(w_ib_b) sg + M_g w_ib_b
    clock_bias' = clock_drift

Derivations. Attitude: with ``C_est = E C``, ``E = I - [phi x]``, subtracting
the true from the computed ``C_est' = C_est [(w + dw) x] - [(w_in + dw_in) x] C_est``
and multiplying by ``C^T`` on the right leaves
``-[phi' x] = [C dw x] - [dw_in x] + [w_in x][phi x] - [phi x][w_in x]``, and
``[a x][b x] - [b x][a x] = [(a x b) x]`` gives the attitude row. Velocity:
``C_est f_meas - C f = (I - [phi x]) C (f + df) - C f = f_n x phi + C df`` (the
sign 002's F12 = (a^n)x carries for our phi, with a^n = f_n the specific force),
and the Coriolis and gravity terms are differenced at the two positions.
Position: ``dr = C_ne (r_e_est - r_e)`` so
``dr' = -[w_en x] dr + C_ne (C_en(est) v_est - C_en v)`` with
``C_en(est) = C_en (I + [dtheta x])`` and ``dtheta = J_v dr`` the small
rotation of the NED frame between the two positions (same matrix ``J_v`` that
maps a velocity to a transport rate).

Perturbations (``dL = dr_N / (R_N + h)``, ``dh = -dr_D``):
``dw_ie = d w_ie/dL dL``; ``dw_en = J_v dv + d w_en/dL dL + d w_en/dh dh``
(the radii's latitude derivatives included); ``dg = [0, 0, dg/dL dL + dg/dh dh]``
(normal gravity of :func:`inins.core.earth.gravity`; the height gradient
``dg/dh ~ -2 g/R`` drives the unstable vertical channel). Nothing else is
dropped at first order: the model is the exact Jacobian of the nonlinear
error dynamics, which ``tests/core/test_error_model.py`` checks column by column.

Mapping to 002 (12 states, eq. 2; same state order as :data:`ALIGN12`).
F12 (dv <- phi) ``(a^n) x`` is ours ``[f_n x]`` with no sign change, ``a^n``
being the specific force ``f_n = C_nb f_b`` (``[0, 0, -g]`` at rest): the
physics above gives ``+f_n x phi`` for our tilt, so 002's tilt has our sign (a
tilt defined by ``C_est = (I + [phi x]) C`` would give ``-(f_n x)``); a flipped
F12 fails the strapdown comparison in the tests. F22 = ``-(w_ie + w_en) x`` as
ours. Sensor block T = [[C_nb, 0], [0, -C_nb]] for (ba, bg). 002's eq. 2 takes
``w_en`` as given: F11 = ``-(2 w_ie + w_en) x`` and a zero phi <- dv block,
which is ``system_matrix(..., transport_from_estimate=False)`` (also the model of
fixed-position navigation). With the INS computing ``w_en`` from its own
velocity (free navigation, the default) F11 gains ``[v x] J_v`` (O(v/R), zero
at rest) and phi <- dv is ``J_v``, the Schuler coupling.

References: 002 eqs. 1-2, 003 eqs. 1-5; Titterton & Weston, *Strapdown
Inertial Navigation Technology*, 2nd ed., ch. 12.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import earth, rotation

# --------------------------------------------------------------------------- errors


def attitude_error(mat_nb_est, mat_nb_true):
    """Phi-angle attitude error (rad), shape (..., 3), NED.

    ``mat_nb_est = (I - [phi x]) @ mat_nb_true`` to first order; exactly,
    ``mat_nb_est @ mat_nb_true.T = exp(-[phi x])``.
    """
    mat_nb_est = np.asarray(mat_nb_est, dtype=float)
    mat_nb_true = np.asarray(mat_nb_true, dtype=float)
    return -rotation.rotvec_from_mat(mat_nb_est @ np.swapaxes(mat_nb_true, -1, -2))


def position_error_ned(lla_est, lla_true):
    """Position error (m), shape (..., 3), NED at the true position.

    Parameters
    ----------
    lla_est, lla_true : array_like, shape (..., 3)
        ``[lat (rad), lon (rad), height (m)]``.
    """
    lla_est = np.asarray(lla_est, dtype=float)
    lla_true = np.asarray(lla_true, dtype=float)
    d_ecef = earth.ecef_from_llh(*np.moveaxis(lla_est, -1, 0)) - earth.ecef_from_llh(
        *np.moveaxis(lla_true, -1, 0)
    )
    mat_en = earth.mat_en(lla_true[..., 0], lla_true[..., 1])
    return np.einsum("...ji,...j->...i", mat_en, d_ecef)


def lla_offset(lla, dr_n):
    """Position displaced by ``dr_n`` (m, NED at ``lla``): inverse of :func:`position_error_ned`.

    ``position_error_ned(lla_offset(lla, dr_n), lla) == dr_n`` to rounding.
    Feedback correction of an INS position is ``lla_offset(lla_est, -dr_n)``
    (to first order in ``dr_n``).

    Parameters
    ----------
    lla : array_like, shape (..., 3)
        ``[lat (rad), lon (rad), height (m)]``.
    dr_n : array_like, shape (..., 3)
        NED displacement (m).

    Returns
    -------
    ndarray, shape (..., 3)
    """
    lla = np.asarray(lla, dtype=float)
    r_e = earth.ecef_from_llh(*np.moveaxis(lla, -1, 0))
    mat_en = earth.mat_en(lla[..., 0], lla[..., 1])
    return earth.llh_from_ecef(r_e + np.einsum("...ij,...j->...i", mat_en, dr_n))


# --------------------------------------------------------------------------- layouts

GROUPS = {
    "position": ("dr_N", "dr_E", "dr_D"),
    "velocity": ("dv_N", "dv_E", "dv_D"),
    "attitude": ("phi_N", "phi_E", "phi_D"),
    "accel_bias": ("ba_x", "ba_y", "ba_z"),
    "gyro_bias": ("bg_x", "bg_y", "bg_z"),
    "accel_scale": ("sa_x", "sa_y", "sa_z"),
    "gyro_scale": ("sg_x", "sg_y", "sg_z"),
    "accel_misalignment": ("ma_yx", "ma_zx", "ma_zy"),
    "gyro_misalignment": ("mg_xy", "mg_xz", "mg_yx", "mg_yz", "mg_zx", "mg_zy"),
    "clock": ("clock_bias", "clock_drift"),
}
"""Every state name the model knows, by group, in canonical order.

``ma_ij`` / ``mg_ij``: accelerometer / gyro ``i`` tilted toward body axis ``j``
(003 eqs. 2-3), so ``meas_i = true_i + sum_j m_ij true_j``; the accelerometer
misalignments ``ma_xy, ma_xz, ma_yz`` are zero by the body-frame definition.
``sa_i`` / ``sg_i``: scale-factor errors (dimensionless).
"""

_GROUP_UNITS = (
    ("position", "m"),
    ("velocity", "m/s"),
    ("attitude", "rad"),
    ("accel_bias", "m/s^2"),
    ("gyro_bias", "rad/s"),
    ("accel_scale", "1"),
    ("gyro_scale", "1"),
    ("accel_misalignment", "rad"),
    ("gyro_misalignment", "rad"),
)
UNITS = {n: u for g, u in _GROUP_UNITS for n in GROUPS[g]} | {
    "clock_bias": "m",
    "clock_drift": "m/s",
}
"""SI unit of every state name."""

SYSTEM_BIASES = ("isb_R", "isb_E", "isb_C", "isb_J")
"""Receiver inter-system code bias (m) of GLONASS, Galileo, BeiDou and QZSS pseudoranges
against the reference system's clock: the tightly coupled filter appends one per further
system it uses (:class:`inins.ekf.config.FilterConfig`). Filter states only, outside
:data:`GROUPS` (the error model of :func:`system_matrix` has no use for them)."""
UNITS |= dict.fromkeys(SYSTEM_BIASES, "m")
TIME_OFFSET = "dt_g"
"""GNSS-minus-IMU time offset (s) of the loosely coupled filter: a solution tagged ``t``
was taken at IMU time ``t + dt_g`` (:mod:`inins.ekf.loose`). A filter state only, outside
:data:`GROUPS`."""
UNITS[TIME_OFFSET] = "s"

_ALL = tuple(name for names in GROUPS.values() for name in names)
_POS = {name: i for i, name in enumerate(_ALL)}
_GROUP_OF = {name: group for group, names in GROUPS.items() for name in names}
_GROUP_OF |= dict.fromkeys(SYSTEM_BIASES, "inter_system_bias")
_GROUP_OF[TIME_OFFSET] = "time_offset"


@dataclass(frozen=True)
class StateLayout:
    """An ordered tuple of error-state names (see :data:`GROUPS`).

    Parameters
    ----------
    names : tuple of str
        Unique, known state names in filter order.
    """

    names: tuple[str, ...]

    def __post_init__(self):
        names = tuple(self.names)
        object.__setattr__(self, "names", names)
        unknown = [n for n in names if n not in _GROUP_OF]
        if unknown:
            raise ValueError(f"unknown state names {unknown}; known: {list(_ALL)}")
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate state names in {names}")

    def __len__(self):
        return len(self.names)

    @property
    def size(self):
        """Number of states."""
        return len(self.names)

    def index(self, name):
        """Position of state ``name`` in the state vector."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"state {name!r} not in layout {self.names}") from None

    def groups(self):
        """Groups present, in layout order."""
        return tuple(dict.fromkeys(_GROUP_OF[n] for n in self.names))

    def slice(self, group):
        """Slice of the states of ``group`` (they must be present and contiguous)."""
        idx = [i for i, n in enumerate(self.names) if _GROUP_OF[n] == group]
        if not idx:
            raise KeyError(f"group {group!r} not in layout {self.names}")
        if idx != list(range(idx[0], idx[-1] + 1)):
            raise ValueError(f"group {group!r} is not contiguous in {self.names}")
        return slice(idx[0], idx[-1] + 1)

    def unit(self, name):
        """SI unit of state ``name``."""
        return UNITS[self.names[self.index(name)]]

    def __add__(self, other):
        return StateLayout(self.names + tuple(other.names))


def _layout(*groups):
    return StateLayout(tuple(n for g in groups for n in GROUPS[g]))


ALIGN12 = _layout("velocity", "attitude", "accel_bias", "gyro_bias")
"""002 in-flight alignment model: dv 3, phi 3, accel bias 3, gyro bias 3."""
NAV15 = _layout("position", "velocity", "attitude", "accel_bias", "gyro_bias")
"""Free-inertial navigation errors with constant sensor biases."""
EKF17 = _layout("position", "velocity", "attitude", "accel_bias", "gyro_bias", "clock")
"""003 EKF1: NAV15 + receiver clock bias (m) and drift (m/s)."""
EKF26 = EKF17 + _layout("accel_misalignment", "gyro_misalignment")
"""003 EKF2: EKF17 + accel misalignment 3 + gyro misalignment 6."""
FULL = StateLayout(_ALL)
"""Every state the model knows (:data:`GROUPS` order), 32 states."""


# --------------------------------------------------------------------------- system matrix


def _outer(a, b):
    return a[..., :, None] * b[..., None, :]


def _earth_jacobians(lat, height, vel_n):
    """Jacobians of w_ie, w_en and g with respect to dr (NED m) and dv.

    Returns ``(j_v, jie_r, jen_r, jg_r)``, each shape (..., 3, 3):
    ``dw_en = j_v dv + jen_r dr``, ``dw_ie = jie_r dr``, ``dg = jg_r dr``.
    """
    rn, re = earth.principal_radii(lat)
    rn_h, re_h = rn + height, re + height
    s, c = np.sin(lat), np.cos(lat)
    t = s / c
    w2 = 1.0 - earth.E2 * s * s
    drn = 3.0 * rn * earth.E2 * s * c / w2  # d R_N / d lat
    dre = re * earth.E2 * s * c / w2  # d R_E / d lat
    v_n, v_e = vel_n[..., 0], vel_n[..., 1]
    zero = np.zeros_like(rn_h)

    j_v = np.zeros((*rn_h.shape, 3, 3))
    j_v[..., 0, 1] = 1.0 / re_h
    j_v[..., 1, 0] = -1.0 / rn_h
    j_v[..., 2, 1] = -t / re_h

    dlat_dr = np.stack([1.0 / rn_h, zero, zero], -1)  # dL = dr_N / (R_N + h)
    dh_dr = np.stack([zero, zero, -np.ones_like(zero)], -1)  # dh = -dr_D
    den_dlat = np.stack(
        [
            -v_e * dre / re_h**2,
            v_n * drn / rn_h**2,
            -v_e / (c * c * re_h) + v_e * t * dre / re_h**2,
        ],
        -1,
    )
    den_dh = np.stack([-v_e / re_h**2, v_n / rn_h**2, v_e * t / re_h**2], -1)
    jen_r = _outer(den_dlat, dlat_dr) + _outer(den_dh, dh_dr)
    jie_r = _outer(earth.RATE * np.stack([-s, zero, -c], -1), dlat_dr)

    # normal gravity is quadratic in h: the central difference is exact
    dg_dh = 0.5 * (earth.gravity(lat, height + 1.0) - earth.gravity(lat, height - 1.0))
    step = 1e-5
    dg_dlat = (earth.gravity(lat + step, height) - earth.gravity(lat - step, height)) / (2 * step)
    jg_r = np.zeros_like(j_v)
    jg_r[..., 2, :] = dg_dlat[..., None] * dlat_dr + dg_dh[..., None] * dh_dr
    return j_v, jie_r, jen_r, jg_r


def _misalignment_columns(mat_nb, u_b, group):
    """``d (C_nb M u_b) / d m_ij = C_nb[:, i] u_b[j]`` for each ``m_ij`` of ``group``."""
    pairs = [("xyz".index(n[-2]), "xyz".index(n[-1])) for n in GROUPS[group]]
    return np.stack([mat_nb[..., :, i] * u_b[..., j, None] for i, j in pairs], -1)


def system_matrix(
    layout, lat, height, vel_n, f_n, mat_nb, omega_ib_b=None, *, transport_from_estimate=True
):
    """Continuous-time error-state matrix F at one operating point (or a stack).

    ``x' = F x`` for the states of ``layout``, with the first-order model of the
    module docstring; states absent from the layout are held at zero (their
    rows and columns are dropped).

    Parameters
    ----------
    layout : StateLayout
    lat, height : float or array_like, shape (...)
        Geodetic latitude (rad) and height (m) of the true trajectory.
    vel_n : array_like, shape (..., 3)
        NED velocity (m/s) of the true trajectory.
    f_n : array_like, shape (..., 3)
        Specific force in NED (m/s^2); ``[0, 0, -g]`` at rest.
    mat_nb : array_like, shape (..., 3, 3)
        True body-to-NED attitude.
    omega_ib_b : array_like, shape (..., 3), optional
        Body angular rate (rad/s); required for gyro scale-factor or
        misalignment states.
    transport_from_estimate : bool
        True (free navigation): the INS computes ``w_en`` from its own
        velocity and position, so ``dw_en = J_v dv + ...`` (the Schuler
        coupling phi <- dv). False: ``w_en`` is supplied from truth, as in
        fixed-position (stationary) navigation, so ``dw_en = 0``; this is
        002's eq. 2 literally (phi <- dv block zero, F11 = -(2 w_ie + w_en)x).

    Returns
    -------
    ndarray, shape (..., n, n)
    """
    lat = np.asarray(lat, dtype=float)
    height = np.asarray(height, dtype=float)
    vel_n = np.asarray(vel_n, dtype=float)
    f_n = np.asarray(f_n, dtype=float)
    mat_nb = np.asarray(mat_nb, dtype=float)
    needs_rate = any(g in layout.groups() for g in ("gyro_scale", "gyro_misalignment"))
    if omega_ib_b is None and needs_rate:
        raise ValueError("omega_ib_b is required for gyro scale-factor/misalignment states")
    omega_ib_b = np.zeros(3) if omega_ib_b is None else np.asarray(omega_ib_b, dtype=float)
    shape = np.broadcast_shapes(
        lat.shape,
        height.shape,
        vel_n.shape[:-1],
        f_n.shape[:-1],
        mat_nb.shape[:-2],
        omega_ib_b.shape[:-1],
    )
    lat, height = np.broadcast_to(lat, shape), np.broadcast_to(height, shape)
    vel_n = np.broadcast_to(vel_n, (*shape, 3))
    f_n = np.broadcast_to(f_n, (*shape, 3))
    mat_nb = np.broadcast_to(mat_nb, (*shape, 3, 3))
    omega_ib_b = np.broadcast_to(omega_ib_b, (*shape, 3))

    j_v, jie_r, jen_r, jg_r = _earth_jacobians(lat, height, vel_n)
    theta_r = j_v  # nav-frame misplacement dtheta = J_v dr: geometry, always present
    if not transport_from_estimate:
        j_v, jen_r = np.zeros_like(j_v), np.zeros_like(jen_r)
    w_ie = earth.rate_ie_n(lat)
    w_en = earth.rate_en_n(lat, height, vel_n)
    v_x = rotation.skew(vel_n)
    f_b = np.einsum("...ji,...j->...i", mat_nb, f_n)

    big = np.zeros((*shape, len(_ALL), len(_ALL)))

    def block(rows, cols, value):
        r, c = _POS[GROUPS[rows][0]], _POS[GROUPS[cols][0]]
        value = np.asarray(value)
        big[..., r : r + value.shape[-2], c : c + value.shape[-1]] = value

    block("position", "position", -rotation.skew(w_en) - v_x @ theta_r)
    block("position", "velocity", np.eye(3))
    block("velocity", "position", v_x @ (2.0 * jie_r + jen_r) + jg_r)
    block("velocity", "velocity", -rotation.skew(2.0 * w_ie + w_en) + v_x @ j_v)
    block("velocity", "attitude", rotation.skew(f_n))
    block("velocity", "accel_bias", mat_nb)
    block("velocity", "accel_scale", mat_nb * f_b[..., None, :])
    block(
        "velocity", "accel_misalignment", _misalignment_columns(mat_nb, f_b, "accel_misalignment")
    )
    block("attitude", "position", jie_r + jen_r)
    block("attitude", "velocity", j_v)
    block("attitude", "attitude", -rotation.skew(w_ie + w_en))
    block("attitude", "gyro_bias", -mat_nb)
    block("attitude", "gyro_scale", -mat_nb * omega_ib_b[..., None, :])
    block(
        "attitude",
        "gyro_misalignment",
        -_misalignment_columns(mat_nb, omega_ib_b, "gyro_misalignment"),
    )
    big[..., _POS["clock_bias"], _POS["clock_drift"]] = 1.0

    idx = np.array([_POS[n] for n in layout.names])
    return big[..., idx[:, None], idx[None, :]]


def noise_matrix(
    layout,
    mat_nb,
    arw,
    vrw,
    *,
    accel_bias_rw=0.0,
    gyro_bias_rw=0.0,
    clock_bias_psd=0.0,
    clock_drift_psd=0.0,
):
    """Process-noise spectral density ``Qc = G Q G^T`` of the error state.

    White sensor noise enters as ``dv' += C_nb w_a`` and ``phi' -= C_nb w_g``
    with ``E[w_a w_a^T] = diag(vrw^2) delta(t)`` and ``E[w_g w_g^T] = diag(arw^2)
    delta(t)``, so ``Qc_vv = C_nb diag(vrw^2) C_nb^T`` and
    ``Qc_phiphi = C_nb diag(arw^2) C_nb^T``. Bias random walks drive ``ba``,
    ``bg``; the clock bias and drift take white noise of the given densities.
    Discretise with :func:`inins.core.kalman.discretize`.

    Parameters
    ----------
    layout : StateLayout
    mat_nb : array_like, shape (..., 3, 3)
    arw : float or array_like, shape (3,)
        Gyro angle random walk (rad/sqrt(s)).
    vrw : float or array_like, shape (3,)
        Accelerometer velocity random walk (m/s/sqrt(s)).
    accel_bias_rw, gyro_bias_rw : float or array_like, shape (3,)
        Bias random walks (m/s^2/sqrt(s), rad/s/sqrt(s)).
    clock_bias_psd, clock_drift_psd : float
        White-noise densities of clock bias (m^2/s) and drift (m^2/s^3).

    Returns
    -------
    ndarray, shape (..., n, n)
    """
    mat_nb = np.asarray(mat_nb, dtype=float)

    def rotated(density):
        d = np.broadcast_to(np.asarray(density, dtype=float) ** 2, (3,))
        value = (mat_nb * d) @ np.swapaxes(mat_nb, -1, -2)
        return 0.5 * (value + np.swapaxes(value, -1, -2))

    big = np.zeros((*mat_nb.shape[:-2], len(_ALL), len(_ALL)))
    for group, value in (
        ("velocity", rotated(vrw)),
        ("attitude", rotated(arw)),
        ("accel_bias", np.diag(np.broadcast_to(accel_bias_rw, 3) ** 2.0)),
        ("gyro_bias", np.diag(np.broadcast_to(gyro_bias_rw, 3) ** 2.0)),
    ):
        k = _POS[GROUPS[group][0]]
        big[..., k : k + 3, k : k + 3] = value
    big[..., _POS["clock_bias"], _POS["clock_bias"]] = clock_bias_psd
    big[..., _POS["clock_drift"], _POS["clock_drift"]] = clock_drift_psd
    idx = np.array([_POS[n] for n in layout.names])
    return big[..., idx[:, None], idx[None, :]]


def propagate(
    layout,
    x0,
    dt,
    lat,
    height,
    vel_n,
    f_n,
    mat_nb,
    omega_ib_b=None,
    *,
    transport_from_estimate=True,
):
    """Propagate the noise-free linear error model over a trajectory of operating points.

    ``x_{k+1} = expm(F_k dt_k) x_k`` with ``F_k`` from :func:`system_matrix` at
    operating point ``k`` (take it at the middle of the step for second-order
    accuracy on a time-varying trajectory).

    Parameters
    ----------
    layout : StateLayout
    x0 : array_like, shape (n,)
        Initial error state (SI units of :meth:`StateLayout.unit`).
    dt : float or array_like, shape (m,)
        Step lengths (s).
    lat, height, vel_n, f_n, mat_nb, omega_ib_b
        Operating points stacked on a leading axis of length ``m``, as in
        :func:`system_matrix`; a constant operating point with ``dt`` of
        shape (m,) gives ``m`` steps of the same transition matrix.
    transport_from_estimate : bool
        As in :func:`system_matrix`.

    Returns
    -------
    ndarray, shape (m + 1, n)
        Error state at the step boundaries, ``x0`` first.
    """
    from scipy.linalg import expm  # scipy is slow to import; only this needs it

    F = system_matrix(
        layout,
        lat,
        height,
        vel_n,
        f_n,
        mat_nb,
        omega_ib_b,
        transport_from_estimate=transport_from_estimate,
    )
    dt = np.asarray(dt, dtype=float)
    steps = np.broadcast_shapes(F.shape[:-2], dt.shape) or (1,)
    if len(steps) != 1:
        raise ValueError("give the steps as a 1-D stack of operating points or of dt")
    shape = (*steps, *F.shape[-2:])
    if F.ndim == 2 and np.all(dt == dt.flat[0]):  # one transition matrix for every step
        Phi = np.broadcast_to(expm(F * dt.flat[0]), shape)
    else:
        Phi = expm(np.broadcast_to(F, shape) * np.broadcast_to(dt, steps)[:, None, None])
    x = np.empty((len(Phi) + 1, len(layout)))
    x[0] = x0
    for k, phi_k in enumerate(Phi):
        x[k + 1] = phi_k @ x[k]
    return x
