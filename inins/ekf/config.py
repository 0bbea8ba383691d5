"""Filter configuration and per-epoch inputs of :func:`inins.ekf.filter.run_filter` (SI units)."""

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from inins.core.error_model import EKF17, EKF26, SYSTEM_BIASES, StateLayout
from inins.core.satellites import LETTERS
from inins.ekf.measurements import GnssEpoch
from inins.exceptions import InputError
from inins.gnss.orbit import C


def clock_psd(h0, h_2):
    """Receiver clock white-noise densities of a TCXO with Allan coefficients ``h0`` (s)
    and ``h_-2`` (1/s): bias ``c^2 h0 / 2`` (m^2/s) and drift ``c^2 2 pi^2 h_-2``
    (m^2/s^3), the two-state clock model of spec §6a."""
    return C**2 * h0 / 2.0, C**2 * 2.0 * math.pi**2 * h_2


class Model(Enum):
    """003 §1: EKF1 has 17 states, EKF2 adds accel (3) and gyro (6) misalignments."""

    EKF1 = "ekf1"
    EKF2 = "ekf2"

    @property
    def layout(self):
        """:data:`inins.core.error_model.EKF17` or :data:`~inins.core.error_model.EKF26`."""
        return EKF17 if self is Model.EKF1 else EKF26


class Coupling(Enum):
    """FF: corrections applied at the output, the inertial solution stays pure.
    FB: corrections fed back into navigation and sensor compensation, states reset (003 §3.3.2)."""

    FF = "ff"
    FB = "fb"


def _vec(name, value, low, high):
    arr = np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
    if not np.all((arr >= low) & (arr <= high)):
        raise InputError(f"expected values in [{low:g}, {high:g}] (SI), got {arr}", key=name)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class InitialSigma:
    """Initial 1-sigma of the error states (SI: m, m/s, rad, m/s^2, rad/s, rad, m, m/s;
    ``system_bias`` m, each inter-system bias state)."""

    position: float = 5.0
    velocity: float = 0.1
    tilt: float = 1e-4
    heading: float = 1e-3
    accel_bias: float = 5e-4
    gyro_bias: float = 5e-8
    accel_misalignment: float = 5e-5
    gyro_misalignment: float = 2e-4
    clock_bias: float = 30.0
    clock_drift: float = 3.0
    system_bias: float = 100.0

    def covariance(self, n, n_bias=0):
        """Diagonal ``P0`` (n + n_bias, n + n_bias) for 17 or 26 states and ``n_bias``
        inter-system bias states after them."""
        s = [self.position] * 3 + [self.velocity] * 3 + [self.tilt] * 2 + [self.heading]
        s += [self.accel_bias] * 3 + [self.gyro_bias] * 3 + [self.clock_bias, self.clock_drift]
        s += [self.accel_misalignment] * 3 + [self.gyro_misalignment] * 6
        return np.diag(np.square(s[:n] + [self.system_bias] * n_bias))


@dataclass(frozen=True, eq=False)
class FilterConfig:
    """Tightly coupled filter settings (SI units inside).

    Attributes
    ----------
    model : Model
    coupling : Coupling
    dt : float
        IMU sample interval (s).
    lever_arm : ndarray, shape (3,)
        GPS antenna relative to the IMU, body axes (m), each within 100 m.
    arw : ndarray, shape (3,)
        Gyro angle random walk (rad/sqrt(s)).
    vrw : ndarray, shape (3,)
        Accelerometer velocity random walk (m/s/sqrt(s)).
    gyro_bias_rw, accel_bias_rw : ndarray, shape (3,)
        Bias random walks (rad/s/sqrt(s), m/s^2/sqrt(s)).
    clock_bias_psd, clock_drift_psd : float
        Receiver clock white-noise densities (m^2/s, m^2/s^3).
    initial_sigma : InitialSigma
    gate_probability : float
        Chi-square(1) gate of each scalar measurement (003 §2; 0.9999 ~ 3.9 sigma).
    dither_window : int
        Moving-average length (samples) of ``f_b``, ``omega_b`` for the model and the
        lever-arm rate (003 §2.2); 1 = no filtering.
    outages : tuple of (float, float)
        GPS outage windows ``[start, end)`` (s): epochs inside are coasted.
    use_range_rate : bool
        Use the range rates as well as the pseudoranges.
    pps_storage : bool
        True: the update uses the INS state stored at the 1PPS epoch (003 §2.1).
        False: the naive pairing with the INS state at the data's arrival (for study).
    systems : str
        RINEX letters of the systems whose pseudoranges the filter takes (``"GR"``): the
        first carries the receiver clock alone, each further one adds an inter-system
        bias state (m) after the 17 or 26 states (:data:`SYSTEM_BIASES` order of the
        letters R E C J). An epoch with a satellite of another system is refused.
    system_bias_psd : float
        Random-walk density of each inter-system bias state (m^2/s); 0: constant.
    """

    model: Model
    coupling: Coupling
    dt: float
    lever_arm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    arw: np.ndarray = field(default_factory=lambda: np.full(3, 1e-6))
    vrw: np.ndarray = field(default_factory=lambda: np.full(3, 1e-4))
    gyro_bias_rw: np.ndarray = field(default_factory=lambda: np.zeros(3))
    accel_bias_rw: np.ndarray = field(default_factory=lambda: np.zeros(3))
    clock_bias_psd: float = 0.1
    clock_drift_psd: float = 0.01
    initial_sigma: InitialSigma = field(default_factory=InitialSigma)
    gate_probability: float = 0.9999
    dither_window: int = 1
    outages: tuple = ()
    use_range_rate: bool = True
    pps_storage: bool = True
    systems: str = "G"
    system_bias_psd: float = 0.0

    def __post_init__(self):
        if not isinstance(self.model, Model) or not isinstance(self.coupling, Coupling):
            raise InputError("model must be a Model and coupling a Coupling", key="model")
        if not (math.isfinite(self.dt) and 0.0 < self.dt <= 0.1):
            raise InputError(f"IMU interval must be in (0, 0.1] s, got {self.dt}", key="dt")
        object.__setattr__(self, "lever_arm", _vec("lever_arm", self.lever_arm, -100.0, 100.0))
        object.__setattr__(self, "arw", _vec("arw", self.arw, 0.0, 1e-2))
        object.__setattr__(self, "vrw", _vec("vrw", self.vrw, 0.0, 1.0))
        object.__setattr__(self, "gyro_bias_rw", _vec("gyro_bias_rw", self.gyro_bias_rw, 0, 1e-3))
        object.__setattr__(self, "accel_bias_rw", _vec("accel_bias_rw", self.accel_bias_rw, 0, 1))
        for name in ("clock_bias_psd", "clock_drift_psd"):
            if not 0.0 <= getattr(self, name) < 1e6:
                raise InputError(f"must be in [0, 1e6), got {getattr(self, name)}", key=name)
        if not 0.5 < self.gate_probability <= 1.0:
            raise InputError("gate probability must be in (0.5, 1]", key="gate_probability")
        if int(self.dither_window) != self.dither_window or self.dither_window < 1:
            raise InputError(
                "dither window must be a positive number of samples", key="dither_window"
            )
        outages = tuple((float(a), float(b)) for a, b in self.outages)
        for i, (a, b) in enumerate(outages):
            if not b > a:
                raise InputError(f"outage end {b} s not after start {a} s", key=f"outages.{i}")
        object.__setattr__(self, "outages", outages)
        systems = str(self.systems)
        if not systems or len(set(systems)) != len(systems) or set(systems) - set("GRECJ"):
            raise InputError(
                f"systems must be distinct letters of G R E C J, got {systems!r}", key="systems"
            )
        if not 0.0 <= self.system_bias_psd < 1e6:
            raise InputError(
                f"must be in [0, 1e6), got {self.system_bias_psd}", key="system_bias_psd"
            )
        object.__setattr__(self, "systems", systems)

    @property
    def bias_names(self):
        """Names of the inter-system bias states, in state order (empty for one system)."""
        others = set(self.systems[1:])
        return tuple(n for n in SYSTEM_BIASES if n[-1] in others)

    @property
    def layout(self):
        """State layout: the model's 17 or 26 states, then the inter-system biases."""
        if len(self.systems) == 1:
            return self.model.layout
        return self.model.layout + StateLayout(self.bias_names)

    def bias_columns(self):
        """State column of each satellite system's inter-system bias (int64 array over the
        system indices of :data:`inins.core.satellites.LETTERS`): -1 for the reference
        system (the receiver clock alone), -2 for a system the filter does not take."""
        out = np.full(len(LETTERS), -2, np.int64)
        out[LETTERS.index(self.systems[0])] = -1
        base = len(self.model.layout)
        for j, name in enumerate(self.bias_names):
            out[LETTERS.index(name[-1])] = base + j
        return out

    def in_outage(self, time):
        """True if ``time`` (s) falls in a configured outage window."""
        return any(a <= time < b for a, b in self.outages)


@dataclass(frozen=True, eq=False)
class TruthEpoch:
    """Truth at a 1PPS epoch (simulation only): IMU ``mat_nb`` (3, 3), ``vel_n`` (3) m/s,
    ``lla`` (3) rad, rad, m, receiver clock bias (m) and drift (m/s); ``at_arrival``
    the IMU ``(mat_nb, vel_n, lla)`` at the data arrival, which scores the naive
    pairing (optional: None where the source gives none); ``system_bias`` the bias (m)
    the receiver adds to each system's pseudoranges, over the system indices of
    :data:`inins.core.satellites.LETTERS` (None: none; the filter's clock then
    estimates ``clock_bias`` plus its reference system's bias, and each bias state the
    difference to the reference)."""

    mat_nb: np.ndarray
    vel_n: np.ndarray
    lla: np.ndarray
    clock_bias: float
    clock_drift: float
    at_arrival: tuple | None = None
    system_bias: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class EpochInput:
    """What the filter consumes per GPS epoch (a stream of these keeps memory flat).

    Attributes
    ----------
    dtheta, dv : ndarray, shape (n, 3)
        Measured IMU increments (rad, m/s) from the previous epoch's data arrival
        (or the start) up to this epoch's arrival.
    pps_index : int
        Samples of this chunk before the 1PPS instant ``gnss.time`` (0..n): the INS
        state after them is the one stored at the PPS (003 §2.1).
    gnss : GnssEpoch
        Measurements of the epoch (may hold no satellite: coasted).
    truth : TruthEpoch, optional
    """

    dtheta: np.ndarray
    dv: np.ndarray
    pps_index: int
    gnss: GnssEpoch
    truth: TruthEpoch | None = None

    def __post_init__(self):
        n = np.shape(self.dtheta)[0]
        if np.shape(self.dtheta) != (n, 3) or np.shape(self.dv) != (n, 3):
            raise InputError("IMU chunk must be (n, 3) increments", key="imu")
        if not 0 <= self.pps_index <= n:
            raise InputError(
                f"pps_index {self.pps_index} outside the chunk of {n}", key="pps_index"
            )
