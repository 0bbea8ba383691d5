"""Rauch-Tung-Striebel smoothing of a stored forward run, in error-state form.

Formulation. The forward filter (:mod:`inins.ekf.loose`, or the tight filter's store)
linearises about its INS trajectory. At epoch ``k`` it has the prediction ``x_k-``
with ``P_k-`` about the INS state ``N_k-`` before the update, the updated ``x_k`` with
``P_k``, and then resets by ``r_k`` (FB: ``r_k = x_k`` on the navigation and sensor states, the INS
state becomes ``N_k+ = N_k- (-) r_k`` and the compensation ``comp + r``; FF:
``r_k = 0``, ``N_k+ = N_k-``). The reset is part of the model: about ``N_k+`` the
estimate is ``e_k = x_k - r_k`` with the same ``P_k`` (to first order the reset
moves the linearisation point, not the uncertainty), and the prediction about
``N_{k+1}-``, which the INS integrates from ``N_k+``, is
``x_{k+1}- = Phi_{k+1} e_k``. A smoothed error ``s_{k+1}`` about ``N_{k+1}+`` is
``s_{k+1} + r_{k+1}`` about ``N_{k+1}-`` (first order: the ``(-)`` of a small
correction adds in NED metres, m/s, phi angles and sensor units). The RTS
recursion (Rauch, Tung & Striebel 1965) then reads::

    C_k  = P_k Phi_{k+1}^T (P_{k+1}-)^-1
    s_k  = e_k + C_k (s_{k+1} + r_{k+1} - Phi_{k+1} e_k)
    Ps_k = P_k + C_k (Ps_{k+1} - P_{k+1}-) C_k^T

from ``s_N = e_N``, ``Ps_N = P_N``. The smoothed solution is ``N_k+ (-) s_k``, the
smoothed sensor estimates ``comp_k + s_k`` (sensor states), their 1-sigma
``sqrt(diag Ps_k)``. In FF ``r = 0`` and this is the textbook RTS; in FB with
every state reset ``e_k = 0`` and ``s_k = C_k (s_{k+1} + r_{k+1})``.

The backward pass reads the store block by block (newest first) and writes
the smoothed arrays to the same kind of store: memory stays flat in run length.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import jit
from inins.ekf import step
from inins.ekf.kernels import NAV

BLOCK = 512


def default_store(name, shape, dtype=float):
    """The in-RAM store: a zero array (callers pass memory maps for long runs)."""
    return np.zeros(shape, dtype)


@dataclass(frozen=True, eq=False)
class ForwardRecord:
    """What the RTS pass reads of a forward run, per epoch (module docstring): the one
    protocol of the loosely coupled run (:class:`inins.ekf.loose.LooseRun`) and the
    tight filter's store (:class:`inins.ekf.tight_store.TightStore`).

    ``time`` (m,) s; the INS state after the reset ``N_k+``: ``quat`` (m, 4), ``vel``
    (m, 3), ``lla`` (m, 3); the sensor compensation after it ``comp`` (m, 15); ``x``,
    ``r`` (m, n) the updated state and the reset; ``P``, ``P_pred``, ``Phi``
    (m, n, n); ``n_sensors``: the states ``NAV:NAV + n_sensors`` are the sensor
    estimates of ``comp[:, :n_sensors]``.
    """

    time: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    lla: np.ndarray
    comp: np.ndarray
    x: np.ndarray
    r: np.ndarray
    P: np.ndarray
    P_pred: np.ndarray
    Phi: np.ndarray
    n_sensors: int

    def sensors(self, dx):
        """Sensor estimates ``comp + dx`` (m, n_sensors) of errors ``dx`` (m, n) about N+."""
        return self.comp[:, : self.n_sensors] + dx[:, NAV : NAV + self.n_sensors]


def correct_many(quat, vel, lla, dx):
    """``nav (-) dx`` of every epoch (:func:`inins.ekf.step.correct`): quat, vel, lla."""
    oq, ov, ol = np.empty_like(quat), np.empty_like(vel), np.empty_like(lla)
    _correct_all(
        np.ascontiguousarray(quat),
        np.ascontiguousarray(vel),
        np.ascontiguousarray(lla),
        np.ascontiguousarray(dx),
        oq,
        ov,
        ol,
    )
    return oq, ov, ol


@jit.njit(cache=True)
def _correct_all(quat, vel, lla, dx, oq, ov, ol):
    for k in range(quat.shape[0]):
        step.correct(quat[k], vel[k], lla[k], dx[k], oq[k], ov[k], ol[k])


@jit.njit(cache=True)
def _backward(x, r, P, P_pred_next, Phi_next, s_next, Ps_next, r_next, out_s, out_Ps):
    """Backward RTS over one block (epochs ``0..b-1`` of the block, newest last).

    ``P_pred_next[i]``, ``Phi_next[i]``, ``r_next[i]``: of epoch ``i + 1``; ``s_next``,
    ``Ps_next``: smoothed of the epoch after the block's last, updated in place to
    those of the block's first on return.
    """
    b = x.shape[0]
    for i in range(b - 1, -1, -1):
        e = x[i] - r[i]
        Pk = P[i]
        Phi = Phi_next[i]
        Pp = P_pred_next[i]
        # C^T = Pp^-1 Phi P
        CT = np.linalg.solve(Pp, Phi @ Pk)
        C = CT.T
        s = e + C @ (s_next + r_next[i] - Phi @ e)
        M = Pk + C @ (Ps_next - Pp) @ CT
        Ps = 0.5 * (M + M.T)
        out_s[i] = s
        out_Ps[i] = Ps
        s_next[:] = s
        Ps_next[:, :] = Ps


@dataclass(frozen=True, eq=False)
class Smoothed:
    """Smoothed run: ``s`` (m, n) error about ``N+``, ``Ps`` (m, n, n); the navigation
    solution ``quat``, ``vel``, ``lla``, sensor estimates ``sensors`` (m, n_base - 9)
    and ``sigma`` (m, n)."""

    time: np.ndarray
    s: np.ndarray
    Ps: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    lla: np.ndarray
    sensors: np.ndarray
    sigma: np.ndarray


def smooth(run, store=default_store):
    """RTS smoothing of a :class:`ForwardRecord` (module docstring)."""
    m, n = run.x.shape
    s_out = store("smooth_s", (m, n))
    Ps_out = store("smooth_P", (m, n, n))
    s_next = np.asarray(run.x[m - 1] - run.r[m - 1], float).copy()
    Ps_next = np.asarray(run.P[m - 1], float).copy()
    s_out[m - 1] = s_next
    Ps_out[m - 1] = Ps_next
    hi = m - 1
    while hi > 0:
        lo = max(hi - BLOCK, 0)
        bs, bP = np.empty((hi - lo, n)), np.empty((hi - lo, n, n))
        _backward(
            np.ascontiguousarray(run.x[lo:hi]),
            np.ascontiguousarray(run.r[lo:hi]),
            np.ascontiguousarray(run.P[lo:hi]),
            np.ascontiguousarray(run.P_pred[lo + 1 : hi + 1]),
            np.ascontiguousarray(run.Phi[lo + 1 : hi + 1]),
            s_next,
            Ps_next,
            np.ascontiguousarray(run.r[lo + 1 : hi + 1]),
            bs,
            bP,
        )
        s_out[lo:hi] = bs
        Ps_out[lo:hi] = bP
        hi = lo
    quat, vel, lla = correct_many(run.quat, run.vel, run.lla, np.asarray(s_out))
    sensors = run.sensors(np.asarray(s_out))
    sigma = np.sqrt(np.einsum("kii->ki", Ps_out))
    return Smoothed(run.time, s_out, Ps_out, quat, vel, lla, sensors, sigma)
