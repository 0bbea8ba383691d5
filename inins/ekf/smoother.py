"""Rauch-Tung-Striebel smoothing of a stored forward run, in error-state form.

Formulation. The forward filter (:mod:`inins.ekf.loose`) linearises about its INS
trajectory. At epoch ``k`` it has the prediction ``x_k-`` with ``P_k-`` about the
INS state ``N_k-`` before the update, the updated ``x_k`` with ``P_k``, and then
resets by ``r_k`` (FB: ``r_k = x_k`` on the navigation and sensor states, the INS
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
from inins.ekf import loose

BLOCK = 512


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


def smooth(run, store=loose.default_store):
    """RTS smoothing of a :class:`inins.ekf.loose.LooseRun` (module docstring)."""
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
    quat, vel, lla = loose._correct_many(run.quat, run.vel, run.lla, np.asarray(s_out))
    nb = run.config.n_base
    sensors = run.comp[:, : nb - 9] + s_out[:, 9:nb]
    sigma = np.sqrt(np.einsum("kii->ki", Ps_out))
    return Smoothed(run.time, s_out, Ps_out, quat, vel, lla, sensors, sigma)
