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

The arrays come from a ``store(name, shape, dtype)`` callable
(:func:`inins.ekf.smoother.default_store` in RAM; the command passes memory maps,
:func:`inins.io.scratch.memmap_store`: 1 h of 26 states is 3600 x 3 x 26 x 26 doubles,
58 MB, a day 1.4 GB), sized for ``capacity`` epochs and grown by doubling into new
ones; :meth:`TightStore.run` hands the filled rows over as the smoother's
:class:`~inins.ekf.smoother.ForwardRecord`.
"""

import numpy as np

from inins.ekf.smoother import ForwardRecord, default_store

_ROWS = ("time", "quat", "vel", "lla", "comp", "x", "r", "P", "P_pred", "Phi")


class TightStore:
    """Per-epoch recorder (module docstring).

    Parameters
    ----------
    store : callable, optional
        ``store(name, shape, dtype=float) -> array`` (zeros in RAM by default).
    capacity : int
        Epochs the first arrays hold.
    """

    def __init__(self, store=default_store, capacity=1024):
        self._store, self._capacity = store, max(int(capacity), 1)
        self.rows = None  # name -> array, allocated at the first epoch (n known)
        self.m = 0  # epochs recorded
        self._grown = 0
        self._pred = None
        self._phi = None

    def _allocate(self, n, capacity):
        shapes = {"time": (), "quat": (4,), "vel": (3,), "lla": (3,), "comp": (15,)}
        shapes |= {"x": (n,), "r": (n,), "P": (n, n), "P_pred": (n, n), "Phi": (n, n)}
        suffix = f"_{self._grown}" if self._grown else ""
        rows = {k: self._store(f"tight_{k}{suffix}", (capacity, *shapes[k])) for k in _ROWS}
        if self.rows is not None:  # grown: the epochs so far copied over
            for k in _ROWS:
                rows[k][: self.m] = self.rows[k][: self.m]
        self.rows, self._capacity = rows, capacity
        self._grown += 1

    def predicted(self, P, Phi):
        """After the propagation: ``P_k-`` and the interval's ``Phi_k``."""
        self._pred = P.copy()
        self._phi = Phi.copy()

    def updated(self, time, x, P, reset_index, feedback, nominal, corrected, comp_after):
        """After the update (before the reset): ``x_k``, ``P_k``; ``reset_index`` the states
        the feedback zeroes; ``nominal`` / ``corrected`` (quat, vel, lla) at the PPS;
        ``comp_after`` the compensation after the reset (15,)."""
        if self.rows is None:
            self._allocate(len(x), self._capacity)
        elif self.m == self._capacity:
            self._allocate(len(x), 2 * self._capacity)
        r = np.zeros_like(x)
        if feedback:
            r[reset_index] = x[reset_index]
        nav = corrected if feedback else nominal
        k = self.m
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
            self.rows[key][k] = value
        self.m = k + 1

    def run(self):
        """The record as a :class:`~inins.ekf.smoother.ForwardRecord` (the smoothed sensor
        estimates: the accelerometer and gyro biases, which follow the navigation states
        in both models): views of the filled rows."""
        if self.rows is None:
            raise ValueError("the store has no epoch")
        return ForwardRecord(**{k: self.rows[k][: self.m] for k in _ROWS}, n_sensors=6)
