"""Per-epoch GNSS measurement input of the tightly coupled filter, and its nonlinear model.

The GNSS layer (or a recording) delivers, per 1PPS epoch, one :class:`GnssEpoch`.
Models (spec §6a, clock terms in metres)::

    rho    = |r_sat - r_ant| + b + b_s - sat_clock + delay + noise
    rhodot = (v_sat - v_ant) . e + d - sat_clock_drift + noise,   e = (r_sat - r_ant) / |.|

with the receiver clock bias ``b`` (m) and drift ``d`` (m/s), ``b_s`` the inter-system
bias (m) of the satellite's system (zero for the filter's reference system), the antenna at
``r_ant = r_imu + mat_en mat_nb l_b`` and moving at
``v_ant = mat_en (v_n + mat_nb (omega_eb_b x l_b))`` (003 eqs. 8-9).
"""

from dataclasses import dataclass, field

import numpy as np

from inins.exceptions import InputError
from inins.gnss.orbit import C as C_LIGHT
from inins.gnss.simulate import antenna_states

__all__ = ["C_LIGHT", "GnssEpoch", "antenna", "predict"]


def _array(name, value, shape):
    arr = np.ascontiguousarray(value, dtype=float)
    if arr.shape != shape or not np.all(np.isfinite(arr)):
        raise InputError(f"expected finite values of shape {shape}, got {arr.shape}", key=name)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class GnssEpoch:
    """Measurements of ``k`` satellites at one receiver epoch (the 1PPS instant).

    Attributes
    ----------
    time : float
        Receiver time of the epoch on the IMU time axis (s).
    prn : ndarray, shape (k,)
        Satellite numbers (int, ``100 * system + number``: GPS PRN 5 is 5, GLONASS slot
        9 is 109; :attr:`system` gives the system index).
    sat_pos, sat_vel : ndarray, shape (k, 3)
        Satellite ECEF position (m) and velocity (m/s) at transmit time, already
        rotated into the ECEF frame of the receive time (Sagnac).
    sat_clock : ndarray, shape (k,)
        ``c dt_sat`` (m), relativistic term and TGD included.
    sat_clock_drift : ndarray, shape (k,)
        ``c dt_sat'`` (m/s).
    pseudorange : ndarray, shape (k,)
        m.
    range_rate : ndarray, shape (k,)
        m/s, positive when the range grows (``-lambda_L1 * Doppler_Hz``).
    sigma_pr, sigma_rr : ndarray, shape (k,)
        1-sigma noise of each (m, m/s).
    delay : ndarray, shape (k,)
        Modelled ionosphere + troposphere delay (m), default zero.
    arrival : float
        Time the data reach the INS (s), ``>= time``; the filter updates at
        ``time`` with the INS state stored at the 1PPS (003 §2.1).
    """

    time: float
    prn: np.ndarray
    sat_pos: np.ndarray
    sat_vel: np.ndarray
    sat_clock: np.ndarray
    sat_clock_drift: np.ndarray
    pseudorange: np.ndarray
    range_rate: np.ndarray
    sigma_pr: np.ndarray
    sigma_rr: np.ndarray
    delay: np.ndarray = field(default=None)
    arrival: float = field(default=None)

    def __post_init__(self):
        prn = np.asarray(self.prn, dtype=np.int64).reshape(-1)
        prn.setflags(write=False)  # read-only like the other fields (one kernel specialisation)
        k = prn.size
        object.__setattr__(self, "prn", prn)
        for name in ("sat_pos", "sat_vel"):
            object.__setattr__(self, name, _array(name, getattr(self, name), (k, 3)))
        if self.delay is None:
            object.__setattr__(self, "delay", np.zeros(k))
        for name in (
            "sat_clock",
            "sat_clock_drift",
            "pseudorange",
            "range_rate",
            "sigma_pr",
            "sigma_rr",
            "delay",
        ):
            object.__setattr__(self, name, _array(name, getattr(self, name), (k,)))
        if np.any(self.sigma_pr <= 0.0) or np.any(self.sigma_rr <= 0.0):
            raise InputError("measurement sigmas must be > 0", key="sigma")
        arrival = self.time if self.arrival is None else float(self.arrival)
        if not arrival >= self.time:
            raise InputError(f"arrival {arrival} s before the epoch {self.time} s", key="arrival")
        object.__setattr__(self, "time", float(self.time))
        object.__setattr__(self, "arrival", arrival)

    @classmethod
    def unchecked(cls, time, *arrays, delay, arrival):
        """An epoch of arrays its caller has checked (a simulated block, checked as a
        whole by :func:`inins.ekf.sources.filter_epochs`): the types, shapes, values and
        read-only flags ``__post_init__`` would ensure, without checking them again.
        ``arrays``: the fields from ``prn`` to ``sigma_rr`` in order (int64 and float,
        C-contiguous, read-only: slices of read-only block arrays)."""
        epoch = object.__new__(cls)
        vars(epoch).update(zip(_FIELDS, (time, *arrays, delay, arrival), strict=True))
        return epoch

    def __len__(self):
        return self.prn.size

    @property
    def system(self):
        """System index of each satellite (k,) int64, ``prn // 100``
        (:data:`inins.core.satellites.LETTERS`: 0 GPS, 1 GLONASS, 2 Galileo, 3 BeiDou)."""
        return self.prn // 100


_FIELDS = (
    "time",
    "prn",
    "sat_pos",
    "sat_vel",
    "sat_clock",
    "sat_clock_drift",
    "pseudorange",
    "range_rate",
    "sigma_pr",
    "sigma_rr",
    "delay",
    "arrival",
)


def antenna(lla, vel_n, mat_nb, omega_eb_b, lever_b):
    """Antenna ECEF position (m) and velocity (m/s), each (3,), from the IMU state.

    ``r_ant = r_imu + mat_en mat_nb l_b``, ``v_ant = mat_en (v_n + mat_nb (omega_eb_b x l_b))``
    (:func:`inins.gnss.simulate.antenna_states` for one state; the filter's compiled
    form is :func:`inins.ekf.step.update`, tested equal).
    """
    r, v = antenna_states(
        np.asarray(lla, float)[None],
        np.asarray(vel_n, float)[None],
        np.asarray(mat_nb, float)[None],
        np.asarray(omega_eb_b, float)[None],
        np.asarray(lever_b, float),
    )
    return r[0], v[0]


def predict(epoch, r_ant, v_ant, clock_bias, clock_drift, system_bias=0.0):
    """Predicted pseudoranges (m) and range rates (m/s), each (k,), of an epoch;
    ``system_bias`` (scalar or (k,), m) the inter-system bias of each row."""
    d = epoch.sat_pos - r_ant
    rho = np.linalg.norm(d, axis=1)
    e = d / rho[:, None]
    rr = np.einsum("ij,ij->i", epoch.sat_vel - v_ant, e)
    return (
        rho + clock_bias + system_bias - epoch.sat_clock + epoch.delay,
        rr + clock_drift - epoch.sat_clock_drift,
    )
