"""Pulse counts: how quantized IMU increments are stored, like a ring-laser-gyro log.

An RLG (and a pulse-rebalanced accelerometer) outputs integer pulses; the
increment is ``counts * pulse_weight``. The table-data layout keeps counts as
int32 with a ``pulse_weight`` attribute (:mod:`inins.io.tabledata`).
"""

import numpy as np

from inins.core import jit


def _pulse_weight(pulse_weight):
    weight = np.asarray(pulse_weight, dtype=float)
    if not (np.all(np.isfinite(weight)) and np.all(weight > 0.0)):
        raise ValueError(f"pulse_weight: must be finite and > 0, got {weight}")
    return weight


def counts_from_increments(values, pulse_weight):
    """Integer pulse counts of quantized increments, as an RLG log stores them.

    Parameters
    ----------
    values : array_like, shape (..., 3)
        Quantized increments (rad or m/s), integer multiples of ``pulse_weight``.
    pulse_weight : array_like, shape (3,) or scalar
        Pulse weight (rad or m/s), > 0; broadcast against ``values``.

    Returns
    -------
    ndarray of int32, shape (..., 3)
        ``values / pulse_weight``. ValueError if a value is more than 1e-6 pulse
        from an integer count or a count does not fit in int32.
    """
    weight = np.broadcast_to(_pulse_weight(pulse_weight), (3,)).astype(float)
    values = np.ascontiguousarray(values, dtype=np.float64)
    counts = np.empty(values.shape, dtype=np.int32)
    problem = _counts_kernel(values.reshape(-1, 3), 1.0 / weight, counts.reshape(-1, 3))
    if problem == 1:
        raise ValueError("values: not integer multiples of pulse_weight (within 1e-6 pulse)")
    if problem == 2:
        raise ValueError("values: pulse counts overflow int32")
    return counts


@jit.njit(cache=True, nogil=True, error_model="numpy")
def _counts_kernel(values, inv_weight, counts):
    """counts = rint(values / weight) in one pass; 1 if not integral, 2 if out of int32."""
    limit = 2147483647.0
    for k in range(values.shape[0]):
        for i in range(3):
            ratio = values[k, i] * inv_weight[i]
            count = np.rint(ratio)
            if abs(ratio - count) > 1e-6:
                return 1
            if count > limit or count < -limit - 1.0:
                return 2
            counts[k, i] = np.int32(count)
    return 0


def increments_from_counts(counts, pulse_weight):
    """Increments (rad or m/s) from integer pulse counts: ``counts * pulse_weight``.

    Parameters
    ----------
    counts : array_like of int, shape (..., 3)
    pulse_weight : array_like, shape (3,) or scalar
        Pulse weight (rad or m/s), > 0.

    Returns
    -------
    ndarray of float64, shape (..., 3)
        Bit-identical to the output of :func:`apply_errors` the counts came from.
    """
    counts = np.asarray(counts)
    if not np.issubdtype(counts.dtype, np.integer):
        raise ValueError(f"counts: expected an integer array, got dtype {counts.dtype}")
    return counts.astype(np.float64) * _pulse_weight(pulse_weight)


def warm_up():
    """Compile (or load from the on-disk cache) the pulse-count kernel on one sample."""
    counts_from_increments(np.zeros((1, 3)), 1.0)
