"""White-noise figures of IMU data at rest: block-mean scatter and Allan deviation.

A white noise of density N (angle or velocity random walk, unit/sqrt(s)) makes
the mean rate over a block of length tau scatter with the standard deviation
``N / sqrt(tau)``. Two estimators use that:

- :func:`noise_density` -- one block length: ``std(block means) sqrt(tau)`` over
  :data:`BLOCKS` blocks of a window (the 1-sigma of calibrate-bias and align-ett
  when the scenario states no noise). Block sums carry the quantization
  remainder, so pulse quantization adds only ``~q / tau`` per block.
- :func:`random_walk` -- the minimum over octave-spaced tau of
  ``sigma_A(tau) sqrt(tau)``, the overlapping Allan deviation
  (:func:`allan_deviation`). Where the Allan slope is -1/2 that product is flat and
  equals the random-walk coefficient; quantization (slope -1) raises it at short
  tau and bias instability at long tau, so the minimum sits on the -1/2 part
  (import-log's stationary check, which may see both).

IEEE Std 952-1997 Annex C (Allan variance).
"""

import numpy as np

BLOCKS = 50
"""Blocks :func:`noise_density` splits a window into."""


def noise_density(increments, dt, blocks=BLOCKS):
    """White-noise density (unit/sqrt(s)) per axis from the scatter of block means.

    Parameters
    ----------
    increments : ndarray, shape (n, 3)
        Increments (rad or m/s) of a window at rest.
    dt : float
        Sample interval (s).
    blocks : int
        Number of blocks.

    Returns
    -------
    ndarray, shape (3,)
        rad/sqrt(s) (or m/s/sqrt(s)).
    """
    size = max(1, increments.shape[0] // blocks)
    count = increments.shape[0] // size
    means = increments[: count * size].reshape(count, size, 3).sum(axis=1) / (size * dt)
    return means.std(axis=0, ddof=1) * np.sqrt(size * dt)


def _allan_variance(cum, k):
    """Overlapping Allan variance at cluster size k from the cumulative sums of rates."""
    means = (cum[k:] - cum[:-k]) / k
    return 0.5 * np.mean((means[k:] - means[:-k]) ** 2, axis=0)


def _cumulative(rates):
    return np.vstack([np.zeros(rates.shape[1]), np.cumsum(rates, axis=0)])


def allan_deviation(rates, tau0):
    """Overlapping Allan deviation at octave-spaced tau (at least 8 clusters each).

    Parameters
    ----------
    rates : ndarray, shape (m, 3)
        Mean rates (rad/s or m/s^2) of consecutive intervals of ``tau0`` s.
    tau0 : float

    Returns
    -------
    tau : ndarray, shape (j,)
        s.
    adev : ndarray, shape (j, 3)
        Same unit as ``rates``.
    """
    cum = _cumulative(rates)
    ks = [2**i for i in range(64) if rates.shape[0] >= 8 * 2**i]
    return (
        np.array(ks, dtype=float) * tau0,
        np.array([np.sqrt(_allan_variance(cum, k)) for k in ks]).reshape(-1, rates.shape[1]),
    )


def random_walk(rates, tau0):
    """Random-walk coefficient per axis: ``min over tau of sigma_A(tau) sqrt(tau)``.

    Parameters
    ----------
    rates : ndarray, shape (m, 3)
        Block mean rates (rad/s or m/s^2), one block every ``tau0`` s; tau runs over
        octaves ``k tau0``, k = 1, 2, 4, ... with at least 8 clusters.

    Returns
    -------
    ndarray, shape (3,)
        rad/sqrt(s) (or m/s/sqrt(s)); NaN with fewer than 16 blocks.
    """
    m = rates.shape[0]
    best = np.full(3, np.inf)
    cum = _cumulative(rates)
    k = 1
    while m >= 8 * k and m >= 16:
        best = np.minimum(best, np.sqrt(_allan_variance(cum, k) * k * tau0))
        k *= 2
    return np.where(np.isfinite(best), best, np.nan)
