"""Measurement rows ``z = H x + v`` of the aiding measurements, per segment.

Sign convention: the measurement residual is *INS-predicted minus measured*,
so with errors defined as estimated minus true (package docstring) ``dz = H x``.
Satellite geometry arrives as arrays of unit lines of sight ``e_k`` (receiver
to satellite, NED) so a GNSS layer can feed it later.

Rows (spec §6a; 002 §3)
-----------------------
velocity    ``dz = dv`` (the velocity states present in the layout).
position    ``dz = dr`` (NED m).
DD phase    antennas A and B = A + b, ``b_n = C_nb b_b``, satellites i, j:
            ``lambda DD phi = -(e_i - e_j)^T b_n + lambda DD N`` (the range from
            B is shorter by ``e^T b``). With ``C_est = (I - [phi x]) C``,
            ``b_n,est = b_n + [b_n x] phi``, so the row in phi is
            ``-(e_i - e_j)^T [b_n x]`` and zero elsewhere (the short-baseline
            double difference cancels position and clock errors).
pseudorange ``rho = |r_sat - r_ant| + c dt``; antenna ``r_ant = r + C_nb l_b``,
            ``dr_ant = dr + [(C_nb l_b) x] phi``; row ``-e_k^T`` on dr,
            ``-e_k^T [(C_nb l_b) x]`` on phi, ``+1`` on clock_bias.
range rate  ``rho' = (v_sat - v_ant) . e_k + c dt'`` (positive when the range
            grows); ``v_ant = v + C_nb (w_eb_b x l_b)``, the antenna's velocity over
            the Earth, with the INS forming ``w_eb_b = w_ib_b - C_nb^T w_ie``, so
            ``dv_ant = dv + ([(C_nb u) x] - C_nb [l_b x] C_nb^T [w_ie x]) phi
            - C_nb [l_b x] bg``, ``u = w_eb_b x l_b``; row ``-e_k^T`` on that, ``+1``
            on clock_drift (design.md §6b).
"""

import enum
from dataclasses import dataclass

import numpy as np

from inins.core import earth, rotation
from inins.exceptions import InputError


class Kind(enum.Enum):
    """Measurement types."""

    VELOCITY = "velocity"
    POSITION = "position"
    DD_PHASE = "dd_phase"
    PSEUDORANGE = "pseudorange"
    RANGE_RATE = "range_rate"


@dataclass(frozen=True)
class Measurement:
    """One aiding measurement (a block of rows).

    Attributes
    ----------
    kind : Kind
    sigma : float
        1-sigma noise of each row (m/s, m, m, m, m/s).
    baseline_b : tuple of float, optional
        DD phase: antenna B minus antenna A in the body frame (m).
    lever_arm_b : tuple of float
        Pseudorange / range rate: antenna minus IMU in the body frame (m).
    los_n : ndarray, shape (k, 3), optional
        Unit lines of sight receiver -> satellite (NED). None: the segment's.
    reference : int
        DD phase: index of the reference satellite; pairs are (reference, k).
    key : str
        Where it came from, for error messages.
    """

    kind: Kind
    sigma: float
    baseline_b: tuple | None = None
    lever_arm_b: tuple = (0.0, 0.0, 0.0)
    los_n: np.ndarray | None = None
    reference: int = 0
    key: str = "measurement"

    def __post_init__(self):
        if not isinstance(self.kind, Kind):
            try:
                object.__setattr__(self, "kind", Kind(self.kind))
            except ValueError:
                known = [k.value for k in Kind]
                raise InputError(
                    f"unknown measurement {self.kind!r}; known: {known}", key=f"{self.key}.kind"
                ) from None
        if not self.sigma > 0.0:
            raise InputError(f"sigma must be > 0, got {self.sigma}", key=f"{self.key}.sigma")
        if self.kind is Kind.DD_PHASE:
            b = np.asarray(self.baseline_b if self.baseline_b is not None else np.zeros(3), float)
            if b.shape != (3,) or not np.linalg.norm(b) > 0.0:
                raise InputError(
                    f"baseline must be a non-zero 3-vector (m), got {self.baseline_b}",
                    key=f"{self.key}.baseline_b",
                )
            object.__setattr__(self, "baseline_b", tuple(b))
        if self.los_n is not None:
            los = np.array(self.los_n, dtype=float)
            unit = los.ndim == 2 and los.shape[1] == 3 and len(los) > 0
            if not unit or np.abs(np.linalg.norm(los, axis=1) - 1.0).max() > 1e-6:
                raise InputError(
                    "lines of sight must be unit 3-vectors, shape (k, 3)", key=f"{self.key}.los_n"
                )
            los.setflags(write=False)
            object.__setattr__(self, "los_n", los)


def _columns(layout, names, kind, key):
    missing = [n for n in names if n not in layout.names]
    if missing:
        raise InputError(
            f"{kind.value} measurement needs states {missing} the model lacks", key=key
        )
    return [layout.index(n) for n in names]


def _los(measurement, segment, needed):
    los = measurement.los_n if measurement.los_n is not None else segment.los_n
    if los is None or len(los) < needed:
        raise InputError(
            f"{measurement.kind.value} needs at least {needed} satellite lines of "
            "sight; none given by the measurement or the segment",
            key=f"{measurement.key}.los_n",
        )
    return los


def dd_pairs(n_sat, reference=0):
    """Satellite pairs ``(reference, k)`` for every ``k != reference``, shape (n_sat - 1, 2)."""
    others = [k for k in range(n_sat) if k != reference]
    return np.array([(reference, k) for k in others], dtype=int).reshape(-1, 2)


def dd_phase(mat_nb, baseline_b, los_n, pairs):
    """Nonlinear double-differenced carrier phase without ambiguity (m), shape (p,).

    ``lambda DD phi_ij = -(e_i - e_j)^T C_nb b_b`` (spec §6a), for a short baseline
    (one line of sight per satellite for both antennas).
    """
    b_n = np.asarray(mat_nb, float) @ np.asarray(baseline_b, float)
    los_n = np.asarray(los_n, float)
    return -(los_n[pairs[:, 0]] - los_n[pairs[:, 1]]) @ b_n


def rows(layout, segment, measurement):
    """Rows ``H`` (shape (m, n)) and noise ``R`` (shape (m, m)) of one measurement.

    Parameters
    ----------
    layout : StateLayout
    segment : Segment
    measurement : Measurement
    """
    kind, key = measurement.kind, measurement.key
    if kind is Kind.VELOCITY or kind is Kind.POSITION:
        group = "dv" if kind is Kind.VELOCITY else "dr"
        present = [n for n in (f"{group}_N", f"{group}_E", f"{group}_D") if n in layout.names]
        H = np.zeros((len(present), len(layout)))
        H[np.arange(len(present)), _columns(layout, present or [f"{group}_N"], kind, key)] = 1.0
    elif kind is Kind.DD_PHASE:
        los = _los(measurement, segment, 2)
        pairs = dd_pairs(len(los), measurement.reference)
        b_n = segment.mat_nb @ np.asarray(measurement.baseline_b)
        H = np.zeros((len(pairs), len(layout)))
        H[:, _columns(layout, ("phi_N", "phi_E", "phi_D"), kind, key)] = -(
            los[pairs[:, 0]] - los[pairs[:, 1]]
        ) @ rotation.skew(b_n)
    else:
        H = _range_rows(layout, segment, measurement, _los(measurement, segment, 1))
    return H, measurement.sigma**2 * np.eye(len(H))


def _range_rows(layout, segment, measurement, los):
    kind, key = measurement.kind, measurement.key
    lever_n = segment.mat_nb @ np.asarray(measurement.lever_arm_b, float)
    H = np.zeros((len(los), len(layout)))
    if kind is Kind.PSEUDORANGE:
        H[:, _columns(layout, ("dr_N", "dr_E", "dr_D"), kind, key)] = -los
        phi_term = rotation.skew(lever_n)
        clock = "clock_bias"
    else:
        H[:, _columns(layout, ("dv_N", "dv_E", "dv_D"), kind, key)] = -los
        w_ie = earth.rate_ie_n(segment.lla[0])
        w_eb_b = segment.omega_ib_b - segment.mat_nb.T @ w_ie
        lever_x = rotation.skew(measurement.lever_arm_b)
        phi_term = rotation.skew(segment.mat_nb @ np.cross(w_eb_b, measurement.lever_arm_b)) - (
            segment.mat_nb @ lever_x @ segment.mat_nb.T @ rotation.skew(w_ie)
        )
        if "bg_x" in layout.names:
            bg = _columns(layout, ("bg_x", "bg_y", "bg_z"), kind, key)
            H[:, bg] = los @ segment.mat_nb @ lever_x
        clock = "clock_drift"
    if "phi_N" in layout.names:
        H[:, _columns(layout, ("phi_N", "phi_E", "phi_D"), kind, key)] = -los @ phi_term
    if clock in layout.names:
        H[:, layout.index(clock)] = 1.0
    return H


def measurement_matrix(layout, segment, measurements):
    """Stacked ``H`` (shape (m, n)) and block-diagonal ``R`` (shape (m, m)) of a list."""
    if not measurements:
        raise InputError("at least one measurement is needed", key="measurements")
    blocks = [rows(layout, segment, m) for m in measurements]
    H = np.vstack([b[0] for b in blocks])
    R = np.zeros((len(H), len(H)))
    k = 0
    for _, r in blocks:
        R[k : k + len(r), k : k + len(r)] = r
        k += len(r)
    return H, R
