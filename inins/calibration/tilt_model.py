"""Tilt observables and the linear error model behind the bias formulas of 000 §2-3.

Navigation on the table is "stationary" (:func:`inins.core.strapdown.integrate`
with ``fixed_position``): the position is known, the transport rate is zero and
the velocity error does not feed back into attitude, so 000 eqs. 9-10 hold
exactly. In our conventions (phi angle, NED; 000's psi is an ENU angle whose
signs 000 states loosely) the attitude error obeys::

    dphi/dt = -omega_ie_n x phi - mat_nb(t) b                          (1)
    phi(t)  = Phi(t) phi0 - G(t) b,   Phi(t) = exp(-[omega_ie_n x] (t - t0)),
    G(t)    = Phi(t) int_t0^t Phi(s)^T mat_nb(s) ds

with ``b`` the gyro bias (b frame).

Tilt observable. Let ``d0`` be the body axis that is nominally down at the
calibration positions (+z or -z). The tilt of the computed attitude is
``eps = down_b x d0`` with ``down_b = mat_nb_est^T e_D``: the components, about
the two horizontal body axes, of the small body rotation from exact level
(000's roll R and pitch P are these two components). With a true mount
rotation ``m`` (b frame) on top of a constant level offset per position::

    eps(t) = m(t) - P_h mat_bn(t) phi(t) + const                       (2)

so over a hold ``d eps / dt = b_h + (mat_bn (omega_ie_n x phi))_h + dm/dt``:
the gyro bias appears directly, and the heading error phi_D enters through the
east component of ``omega_ie_n x phi`` (000 eq. 14).

Every method is a linear combination ``F = sum_j c_j . eps_j`` of tilt samples
(epoch windows). By (1)-(2) its response is ``F = S_b b + S_phi phi0 +
sum_j c_j . m_j``; :func:`formula_gain` evaluates ``S_b`` and ``S_phi`` along the
computed attitude history. The paper's formulas assume ``S_b = I`` (first order
in T, rotation time Delta -> 0); the exact gains remove the Delta/T and
Earth-rate coupling terms (several per cent for 000's numbers), and ``S_phi``
is the predicted sensitivity to the initial heading error (000 eqs. 26-45).

Noise. Angle random walk N (rad/sqrt(s)) enters (1) as ``-mat_nb n`` with white
``n``; :func:`arw_sigma` integrates the weight of ``n`` in F exactly along the
attitude history.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import earth, rotation
from inins.exceptions import InputError


@dataclass(frozen=True)
class Track:
    """The computed navigation through the sequence, on the output grid.

    Attributes
    ----------
    time : ndarray, shape (m,)
        Output times (s); ``time[0]`` is the start of navigation.
    mat_nb : ndarray, shape (m, 3, 3)
        Computed attitude.
    vel_n : ndarray, shape (m, 3)
        Computed velocity (m/s): the velocity error, the table being at rest.
    lat : float
        Latitude (rad).
    down_axis : int
        Body axis nominally along the vertical (0, 1, 2).
    down_sign : float
        +1 if that axis points down at the calibration positions, -1 if up.
    """

    time: np.ndarray
    mat_nb: np.ndarray
    vel_n: np.ndarray
    lat: float
    down_axis: int
    down_sign: float

    @property
    def horizontal(self):
        """The two horizontal body axes, in increasing order."""
        return [i for i in range(3) if i != self.down_axis]

    @property
    def d0(self):
        """Nominal down direction in the b frame, shape (3,)."""
        d0 = np.zeros(3)
        d0[self.down_axis] = self.down_sign
        return d0


def vertical_axis(mat_nb):
    """Body axis (index, sign) nearest to the local down direction."""
    down_b = np.asarray(mat_nb)[2]
    axis = int(np.argmax(np.abs(down_b)))
    return axis, float(np.sign(down_b[axis]))


def tilts(track):
    """Tilt observable ``eps = down_b x d0`` (rad), shape (m, 3); zero about the vertical."""
    return np.cross(track.mat_nb[:, 2, :], track.d0)


def earth_transition(track):
    """``Phi(t) = exp(-[omega_ie_n x] (t - t0))`` on the grid, shape (m, 3, 3)."""
    w = earth.rate_ie_n(track.lat)
    return rotation.mat_from_rotvec(-np.outer(track.time - track.time[0], w))


def bias_response(track, phi_t=None):
    """``G(t)`` of eq. (1) on the grid, shape (m, 3, 3): ``phi(t) = Phi phi0 - G b``;
    ``phi_t`` is :func:`earth_transition` if already formed."""
    phi_t = earth_transition(track) if phi_t is None else phi_t
    inner = np.swapaxes(phi_t, 1, 2) @ track.mat_nb
    dt = np.diff(track.time)[:, None, None]
    integral = np.concatenate(
        [np.zeros((1, 3, 3)), np.cumsum(0.5 * (inner[1:] + inner[:-1]) * dt, axis=0)]
    )
    return phi_t @ integral


@dataclass(frozen=True)
class Gain:
    """Response of a formula to the gyro bias and to the initial attitude error.

    ``s_bias`` (k, 3): d F / d b; ``s_phi`` (k, 3): d F / d phi0 (NED), for k
    formulas evaluated together.
    """

    s_bias: np.ndarray
    s_phi: np.ndarray


@dataclass(frozen=True)
class Response:
    """Products along the track that the gains and the noise need, formed once.

    ``bn_g = mat_bn G``, ``bn_phi = mat_bn Phi``, ``phit_nb = Phi^T mat_nb``, each (m, 3, 3).
    """

    bn_g: np.ndarray
    bn_phi: np.ndarray
    phit_nb: np.ndarray

    @classmethod
    def of(cls, track, phi_t=None, g=None):
        """From the track; ``phi_t`` (:func:`earth_transition`) and ``g``
        (:func:`bias_response`) if already formed."""
        phi_t = earth_transition(track) if phi_t is None else phi_t
        g = bias_response(track, phi_t) if g is None else g
        mat_bn = np.swapaxes(track.mat_nb, 1, 2)
        return cls(mat_bn @ g, mat_bn @ phi_t, np.swapaxes(phi_t, 1, 2) @ track.mat_nb)


def formula_gain(weights, response):
    """Exact gains of formulas ``F_i = sum_j weights[i, j] . eps_j`` by eqs. (1)-(2).

    ``eps_j = -P_h mat_bn_j phi_j`` with ``phi_j = Phi_j phi0 - G_j b`` (the weights are
    zero on the vertical), so ``S_b = sum_j w_j mat_bn_j G_j`` and
    ``S_phi = -sum_j w_j mat_bn_j Phi_j``.

    Parameters
    ----------
    weights : ndarray, shape (k, m, 3)
        Weight of each tilt sample in each formula (b frame components).
    response : Response

    Returns
    -------
    Gain
    """
    axes = ([1, 2], [0, 1])
    return Gain(
        np.tensordot(weights, response.bn_g, axes), -np.tensordot(weights, response.bn_phi, axes)
    )


def arw_sigma(track, weights, arw, response=None):
    """1-sigma of formulas from angle random walk, along the attitude history.

    ``F = sum_j w_j . eps_j`` with ``eps_j = -P_h mat_bn_j phi_j`` and the noise part
    of (1), ``phi(t) = -Phi(t) int Phi(s)^T mat_nb(s) n(s) ds``, gives
    ``F = int R(s)^T Phi(s)^T mat_nb(s) n(s) ds`` with
    ``R(s) = sum_{t_j > s} Phi_j^T mat_nb_j w_j``; the variance is
    ``sum_axes N_a^2 int ((mat_bn Phi R)_a)^2 ds``.

    Parameters
    ----------
    track : Track
    weights : ndarray, shape (k, m, 3)
    arw : array_like, shape (3,) or scalar
        Angle random walk per gyro (rad/sqrt(s)).
    response : Response, optional

    Returns
    -------
    ndarray, shape (k,)
    """
    response = Response.of(track) if response is None else response
    r = (response.phit_nb @ weights[..., None])[..., 0]
    # R on interval (t_{j-1}, t_j]: sum of r over samples j, j+1, ...
    tail = np.cumsum(r[:, ::-1], axis=1)[:, ::-1][:, 1:]
    w_body = (np.swapaxes(response.phit_nb[1:], 1, 2) @ tail[..., None])[..., 0]
    arw2 = np.broadcast_to(np.asarray(arw, float) ** 2, (3,))
    return np.sqrt(np.einsum("kmi,i,m->k", w_body**2, arw2, np.diff(track.time)))


def window_weights(track, windows, coefficients):
    """Weights of ``sum_e coefficients[e] * mean(eps over window e)``, shape (m, 3).

    Parameters
    ----------
    windows : ndarray, shape (e, 2)
        Start and end time (s) of each window.
    coefficients : ndarray, shape (e, 3)
        Coefficient of each window's mean tilt per body axis.
    """
    weights = np.zeros((track.time.size, 3))
    for (start, end), coef in zip(windows, coefficients, strict=True):
        inside = (track.time >= start - 1e-9) & (track.time <= end + 1e-9)
        count = np.count_nonzero(inside)
        if count == 0:
            raise InputError(
                f"no navigation output in the epoch window {start:g}-{end:g} s: "
                "lengthen sequence.epoch_window_s or raise "
                "navigation.output_rate_hz",
                key="sequence.epoch_window_s",
            )
        weights[inside] += coef / count
    return weights
