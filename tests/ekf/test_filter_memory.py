"""The tight filter keeps no ``P`` per epoch (issue 34: memory flat in flight length).

:func:`inins.ekf.filter.run_filter` scores each batch of epochs against its truth as the
run goes (:func:`inins.ekf.scoring.epoch_errors` on the batch's ``P``, then dropped).
Two code paths in one process: the NEES streamed batch by batch against the NEES of
every epoch at once from the ``P`` the run hands a caller's array
(:func:`inins.ekf.scoring.truth_errors`, the stored-covariance path the filter used
before); and the run's own arrays hold no ``(epochs, n, n)`` one and do not grow by a
``P`` an epoch.
"""

import math
import tracemalloc
from types import SimpleNamespace

import numpy as np
import pytest
from ekf_sim import Receiver, epoch_stream

from inins.core import imu, strapdown
from inins.core.units import DEG, DEG_RTH, DPH, UG
from inins.ekf import epoch_log, scoring
from inins.ekf import filter as ekf_filter
from inins.ekf.config import Coupling, FilterConfig, InitialSigma, Model
from inins.ekf.flight import FlightPlan, Leg, LegKind, flight_trajectory, gyrocompass_attitude
from inins.ekf.tight_store import TightStore

DT = 0.01
ERRORS = imu.SensorErrors(
    gyro_bias=np.array([0.01, -0.01, 0.0]) * DPH,
    accel_bias=np.array([50, -40, 30]) * UG,
    gyro_misalignment=np.array([-30, 20, 50, 200, -40, 200]) * 1e-6,
    accel_misalignment=np.array([20, -30, 10]) * 1e-6,
    gyro_arw=0.002 * DEG_RTH,
    accel_vrw=20 * UG,
)


@pytest.fixture(scope="module")
def flight():
    """130 s (wait, take-off, straight): 130 epochs, five batches, the last short."""
    plan = FlightPlan(
        37 * DEG,
        127 * DEG,
        100.0,
        math.pi,
        (Leg(LegKind.WAIT, 30), Leg(LegKind.TAKEOFF, 40, speed=80.0), Leg(LegKind.STRAIGHT, 60)),
    )
    truth = flight_trajectory(plan)
    rx = Receiver()
    epochs = list(epoch_stream(truth, truth, ERRORS, DT, plan.duration, rx, seed=4))
    mat0, vel0, lla0 = truth.state([0.0])
    aligned = gyrocompass_attitude(mat0[0], lla0[0, 0], lla0[0, 2], ERRORS)
    initial = strapdown.NavState.from_attitude(aligned, vel0[0], lla0[0])
    config = FilterConfig(
        Model.EKF2,
        Coupling.FB,
        DT,
        lever_arm=rx.lever_arm,
        arw=np.full(3, 0.002 * DEG_RTH),
        vrw=np.full(3, 20 * UG),
        initial_sigma=InitialSigma(heading=0.1 * DEG, gyro_bias=0.02 * DPH, clock_bias=1e4),
    )
    return config, initial, epochs


def test_streamed_nees_equals_the_nees_of_the_stored_covariances(flight):
    config, initial, epochs = flight
    n = len(config.layout)
    assert len(epochs) % ekf_filter.BATCH != 0 and len(epochs) > 3 * ekf_filter.BATCH
    cov = np.full((len(epochs), n, n), np.nan)
    streamed = ekf_filter.run_filter(config, initial, 0.0, epochs, ERRORS)
    kept = ekf_filter.run_filter(config, initial, 0.0, epochs, ERRORS, covariance=cov)
    assert np.isfinite(cov).all()
    np.testing.assert_array_equal(kept.state, streamed.state)  # storing P changes nothing
    # sigma is the root of P's diagonal of the same epoch
    np.testing.assert_array_equal(streamed.sigma, np.sqrt(np.diagonal(cov, axis1=1, axis2=2)))
    log = SimpleNamespace(truth=[e.truth for e in epochs], covariance=cov)
    stored = scoring.truth_errors(streamed, log, ERRORS, pps_storage=True, systems="G")
    assert streamed.nees.shape == (len(epochs),)
    np.testing.assert_allclose(streamed.nees, stored.nees, rtol=1e-12, atol=0)
    np.testing.assert_allclose(streamed.nav_error, stored.nav_error, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(streamed.heading_error, stored.heading_error, rtol=0, atol=1e-15)
    # a consistent filter: the NEES of 26 states averages near 26 (chi-square, 26 dof),
    # far from what a P of another epoch or a lost sign would give
    assert 10.0 < np.mean(streamed.nees) < 60.0


def test_a_too_short_covariance_array_is_refused(flight):
    config, initial, epochs = flight
    n = len(config.layout)
    with pytest.raises(ValueError, match="covariance holds 40 epochs"):
        ekf_filter.run_filter(config, initial, 0.0, epochs, ERRORS, covariance=np.zeros((40, n, n)))


def _arrays(obj, seen=None):
    """Every ndarray an object's attributes (and their tuples and lists) hold."""
    values = obj if isinstance(obj, tuple | list) else vars(obj).values()
    for value in values:
        if isinstance(value, np.ndarray):
            yield value
        elif isinstance(value, tuple | list):
            yield from _arrays(value)


def test_the_run_holds_no_covariance_per_epoch(flight, monkeypatch):
    config, initial, epochs = flight
    n = len(config.layout)
    made = []
    for name in ("Log", "Buffers"):
        cls = getattr(epoch_log, name)
        monkeypatch.setattr(
            epoch_log, name, lambda *a, cls=cls, **k: made.append(cls(*a, **k)) or made[-1]
        )
    result = ekf_filter.run_filter(config, initial, 0.0, epochs, ERRORS)
    assert result.nees.size == len(epochs) and len(made) == 2
    for array in (a for obj in made for a in _arrays(obj)):
        assert array.ndim < 3 or array.shape[0] <= ekf_filter.BATCH, array.shape
    # nor does memory grow by a P an epoch: a run three times as long allocates no more
    peaks = []
    ekf_filter.run_filter(config, initial, 0.0, epochs[:40], ERRORS)  # one-time set-up
    for count in (40, 120):
        tracemalloc.start()
        ekf_filter.run_filter(config, initial, 0.0, epochs[:count], ERRORS)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert peaks[1] - peaks[0] < 0.25 * 80 * n * n * 8, peaks


def test_a_smoothers_store_grows_into_new_arrays_of_its_store(flight):
    config, initial, epochs = flight
    made = {}

    def store(name, shape, dtype=float):
        made[name] = np.full(shape, np.nan, dtype)
        return made[name]

    small, large = TightStore(store, capacity=5), TightStore(capacity=len(epochs))
    ekf_filter.run_filter(config, initial, 0.0, epochs[:40], store=small)
    ekf_filter.run_filter(config, initial, 0.0, epochs[:40], store=large)
    assert {"tight_P", "tight_P_1", "tight_P_2", "tight_P_3"} <= set(made)  # 5, 10, 20, 40
    got, want = small.run(), large.run()
    for name in ("time", "quat", "vel", "lla", "comp", "x", "r", "P", "P_pred", "Phi"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    assert got.P.shape == (40, len(config.layout), len(config.layout))
