"""The 000 Table 1 return sequence in a table record: positions, alignment window, epochs.

000 Table 1: position A (yaw 0) for T, a 180 deg turn about the vertical in Delta,
position B for T, the turn back, position A again. Consecutive holds at the same
table angles form one position; the sequence is the first run of three positions
A, B, A' with B = A turned 180 deg about the local vertical and A' = A.

Epochs (000 Table 1, t = 0, T, T + Delta, 2T + Delta, 2T + 2 Delta) are short
windows: epoch 0 at the start of navigation (end of the alignment window), 1 at
the end of A, 2 at the start of B, 3 at the end of B, 4 at the start of A'. A
settling time is skipped after each rotation.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import rotation
from inins.exceptions import InputError
from inins.table.kinematics import platform_matrix

ANGLE_TOL = 1e-4  # rad: holds closer than this are at the same table angles


@dataclass(frozen=True)
class Position:
    """Consecutive holds at the same table angles (times in s)."""

    start: float
    end: float
    angles: np.ndarray
    labels: tuple


@dataclass(frozen=True)
class Sequence:
    """Times (s) that the methods use.

    Attributes
    ----------
    positions : tuple of Position
        A, B, A' (A' is None when the record does not return to A).
    align : (float, float)
        Alignment window at A.
    epochs : ndarray, shape (5, 2) or (4, 2)
        Start and end time of each epoch window (no epoch 4 without A').
    """

    positions: tuple
    align: tuple
    epochs: np.ndarray

    @property
    def has_return(self):
        """True if the record returns to A (000 Table 1): needed by eqs. 35-45."""
        return self.positions[2] is not None

    @property
    def epoch_times(self):
        """Window centres (s), shape (5,)."""
        return self.epochs.mean(axis=1)

    @property
    def hold_times(self):
        """Navigation time at A and at B between epoch centres (s): T_A, T_B."""
        t = self.epoch_times
        return t[1] - t[0], t[3] - t[2]

    @property
    def nav_start(self):
        """Start of free-inertial navigation (s), the end of the alignment window."""
        return self.align[1]

    @property
    def nav_end(self):
        """End of the last epoch window (s)."""
        return float(self.epochs[-1, 1])


def positions(steps):
    """Group consecutive holds at the same table angles into positions."""
    found = []
    for step in steps:
        if step.kind != "hold":
            continue
        last = found[-1] if found else None
        if (
            last is not None
            and abs(last.end - step.start_time) < 1e-9
            and np.allclose(last.angles, step.angles_end, atol=ANGLE_TOL)
        ):
            found[-1] = Position(last.start, step.end_time, last.angles, (*last.labels, step.label))
        else:
            found.append(
                Position(
                    step.start_time,
                    step.end_time,
                    np.asarray(step.angles_end, float),
                    (step.label,),
                )
            )
    return found


def _is_half_turn(mat_a, mat_b):
    """True if platform b is platform a turned 180 deg about the local vertical."""
    rv = rotation.rotvec_from_mat(mat_b @ mat_a.T)  # rotation in the n frame
    angle = np.linalg.norm(rv)
    return abs(angle - np.pi) < 1e-3 and abs(abs(rv[2]) / angle - 1.0) < 1e-3


def find_return_sequence(record, labels=None, start_after=-np.inf):
    """Positions A, B, A' of the 000 Table 1 sequence.

    Parameters
    ----------
    record : inins.core.records.TableRecord
    labels : sequence of 3 str, optional
        Labels of a hold in A, B and A'; default: the first matching triple.
    start_after : float, optional
        Only positions starting at or after this time (s) are considered (the second,
        pitched sequence of a three-axis calibration).

    Raises
    ------
    InputError
        No such triple (the message lists the positions found).
    """
    pos = [p for p in positions(record.steps) if p.start >= start_after - 1e-9]
    mats = [platform_matrix(record.axes, record.mat_n_base, p.angles) for p in pos]
    for i in range(len(pos) - 2):
        a, b, c = pos[i : i + 3]
        if labels is not None and not all(
            lab in p.labels for lab, p in zip(labels, (a, b, c), strict=True)
        ):
            continue
        if _is_half_turn(mats[i], mats[i + 1]) and np.allclose(
            mats[i], mats[i + 2], atol=ANGLE_TOL
        ):
            return a, b, c
    for i in range(len(pos) - 1):  # without the return: the two-position methods still run
        a, b = pos[i : i + 2]
        if labels is not None and not (labels[0] in a.labels and labels[1] in b.labels):
            continue
        if _is_half_turn(mats[i], mats[i + 1]):
            return a, b, None
    listing = (
        "; ".join(
            f"{'/'.join(p.labels) or '?'} at {np.degrees(p.angles).round(3).tolist()} deg "
            f"({p.start:g}-{p.end:g} s)"
            for p in pos
        )
        or "no holds"
    )
    wanted = f" labelled {list(labels)}" if labels is not None else ""
    raise InputError(
        "gyro-bias calibration needs two positions 180 deg apart about the vertical (000 "
        f"§2), and the return-sequence method a hold back at the first (000 Table 1){wanted}; "
        f"positions found: {listing}",
        source=record.source,
        key="steps",
    )


def build_sequence(record, align_duration, epoch_window, settle, labels=None, start_after=-np.inf):
    """Alignment window and epoch windows of the return sequence.

    Parameters
    ----------
    record : inins.core.records.TableRecord
    align_duration : float
        Alignment time at the start of A (s).
    epoch_window : float
        Length of each epoch window (s).
    settle : float
        Time skipped after a rotation before a window starts (s).
    labels : sequence of 3 str, optional
    start_after : float, optional
        See :func:`find_return_sequence`.
    """
    a, b, c = find_return_sequence(record, labels, start_after)
    align = (a.start + settle, a.start + settle + align_duration)
    needs = {"A": (a, align[1] + 2 * epoch_window), "B": (b, b.start + settle + 2 * epoch_window)}
    if c is not None:
        needs["A'"] = (c, c.start + settle + epoch_window)
    for name, (p, latest) in needs.items():
        if p.end < latest - 1e-9:
            raise InputError(
                f"position {name} ({'/'.join(p.labels)}) lasts {p.end - p.start:g} s, too "
                f"short for the alignment ({align_duration:g} s), the settling ({settle:g} s) "
                f"and the epoch windows ({epoch_window:g} s)",
                source=record.source,
                key="steps",
            )
    epochs = np.array(
        [
            [align[1], align[1] + epoch_window],
            [a.end - epoch_window, a.end],
            [b.start + settle, b.start + settle + epoch_window],
            [b.end - epoch_window, b.end],
            *([[c.start + settle, c.start + settle + epoch_window]] if c is not None else []),
        ]
    )
    return Sequence((a, b, c), align, epochs)
