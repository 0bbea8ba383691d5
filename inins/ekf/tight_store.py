"""Forward store of the tightly coupled filter for RTS smoothing (:mod:`inins.ekf.smoother`).

:func:`inins.ekf.filter.run_filter` given ``store=TightStore(...)`` records per epoch
what the error-state RTS pass needs, in the formulation of :mod:`inins.ekf.smoother`:
the prediction ``P_k-`` and the transition ``Phi_k`` of the interval (the product
over its sub-intervals when the model is re-linearised inside it), the updated
``x_k`` and ``P_k``, the reset ``r_k`` (FB: the navigation and sensor states, which
the feedback zeroes; the clock states are values, never reset; FF: zero), the INS
state ``N_k+`` at the 1PPS instant after the reset (FB: the corrected output; FF:
the free INS) and the sensor compensation after it. The FB correction is applied
at the data's arrival, carried there by ``I + F tau`` (003 §2.1): about ``N_k+`` at
the PPS instant that is the same reset to first order.

Arrays grow in RAM lists (a tight run has one epoch a second: 1 h of 26 states is
3600 x 3 x 26 x 26 doubles, 58 MB) and are handed over as the smoother's
:class:`~inins.ekf.smoother.ForwardRecord` by :meth:`TightStore.run`.
"""

import numpy as np

from inins.ekf.smoother import ForwardRecord


class TightStore:
    """Per-epoch recorder (module docstring)."""

    def __init__(self):
        self.rows = {
            k: [] for k in ("time", "quat", "vel", "lla", "comp", "x", "r", "P", "P_pred", "Phi")
        }
        self._pred = None
        self._phi = None

    def predicted(self, P, Phi):
        """After the propagation: ``P_k-`` and the interval's ``Phi_k``."""
        self._pred = P.copy()
        self._phi = Phi.copy()

    def updated(self, time, x, P, reset_index, feedback, nominal, corrected, comp_after):
        """After the update (before the reset): ``x_k``, ``P_k``; ``reset_index`` the states
        the feedback zeroes; ``nominal`` / ``corrected`` (quat, vel, lla) at the PPS;
        ``comp_after`` the compensation after the reset (15,)."""
        r = np.zeros_like(x)
        if feedback:
            r[reset_index] = x[reset_index]
        nav = corrected if feedback else nominal
        for key, value in (
            ("time", time),
            ("quat", nav[0]),
            ("vel", nav[1]),
            ("lla", nav[2]),
            ("comp", comp_after),
            ("x", x),
            ("r", r),
            ("P", P),
            ("P_pred", self._pred),
            ("Phi", self._phi),
        ):
            self.rows[key].append(np.array(value, dtype=float, copy=True))

    def run(self):
        """The record as a :class:`~inins.ekf.smoother.ForwardRecord` (the smoothed sensor
        estimates: the accelerometer and gyro biases, which follow the navigation states
        in both models)."""
        return ForwardRecord(**{k: np.array(v) for k, v in self.rows.items()}, n_sensors=6)
