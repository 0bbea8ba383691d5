"""The fused epoch kernel (:func:`inins.ekf.fused.epoch`, run in batches by
:func:`inins.ekf.fused.epochs`) against the filter loop it replaced
(``stepwise_filter.run_stepwise``: the Python loop as it was, calling the
building-block kernels one by one): EKF2-FB with a GPS outage, an epoch without
satellites and a bank turn whose roll-in and roll-out split the propagation; EKF1-FF
on pseudoranges alone; the naive pairing; the smoother's store.

With the package's propagation and update kernels in the loop every output array is
equal bit for bit: the fused kernel composes the steps as the loop did. With their
first form (``frozen_kernels``: dense 26 x 26 products and BLAS for the 3 x 3 ones,
where the package now multiplies only the rows the model moves and writes the small
products out) the outputs agree to rounding, carried through a minute of feedback
(:func:`test_the_rewritten_arithmetic_agrees_with_its_first_form`).

The reference is recomputed in the test from the same epochs, so nothing here is a
stored number: a change to how the fused kernel composes the steps, or to the
arithmetic of a rewritten kernel beyond rounding, fails.
"""

import math
from dataclasses import replace

import numpy as np
import pytest
from ekf_sim import Receiver, epoch_stream
from stepwise_filter import package_kernels, run_stepwise

from inins.core import imu, strapdown
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, UG
from inins.ekf.config import Coupling, FilterConfig, InitialSigma, Model
from inins.ekf.filter import run_filter
from inins.ekf.flight import (
    Dither,
    Dithered,
    FlightPlan,
    Leg,
    LegKind,
    dither_window,
    flight_trajectory,
    gyrocompass_attitude,
)
from inins.ekf.measurements import GnssEpoch
from inins.ekf.tight_store import TightStore
from inins.exceptions import InputError

DT = 0.005
ERRORS = imu.SensorErrors(
    gyro_bias=np.array([0.01, -0.01, 0.0]) * DPH,
    accel_bias=np.array([50, -40, 30]) * UG,
    gyro_misalignment=np.array([-30, 20, 50, 200, -40, 200]) * 1e-6,
    accel_misalignment=np.array([20, -30, 10]) * 1e-6,
    gyro_arw=0.002 * DEG_RTH,
    accel_vrw=20 * UG,
)
DITHER = Dither(60 * ARCSEC, 40.0)
EMPTY_EPOCH = 7
"""Index of the epoch whose satellites are removed (coasted: no measurement)."""


def _no_satellites(index, epoch):
    if index != EMPTY_EPOCH:
        return epoch
    none = np.zeros(0)
    return GnssEpoch(
        epoch.time,
        np.zeros(0, np.int64),
        np.zeros((0, 3)),
        np.zeros((0, 3)),
        *([none] * 6),
        arrival=epoch.arrival,
    )


@pytest.fixture(scope="module")
def flight():
    """64 s: wait, take-off, a 1-deg turn at 30 deg bank (rolled in and out within half
    a second), straight; dithered IMU."""
    plan = FlightPlan(
        37 * DEG,
        127 * DEG,
        100.0,
        math.pi,
        (
            Leg(LegKind.WAIT, 10),
            Leg(LegKind.TAKEOFF, 40, speed=80.0),
            Leg(LegKind.STRAIGHT, 5.45),
            Leg(LegKind.TURN, bank=30 * DEG, angle=1 * DEG),
            Leg(LegKind.STRAIGHT, 8),
        ),
    )
    base = flight_trajectory(plan)
    truth = Dithered(base, DITHER)
    rx = Receiver()
    epochs = list(
        epoch_stream(truth, base, ERRORS, DT, plan.duration, rx, seed=3, on_gnss=_no_satellites)
    )
    mat0, vel0, lla0 = truth.state([0.0])
    mat_base, _, _ = base.state([0.0])
    aligned = gyrocompass_attitude(mat_base[0], lla0[0, 0], lla0[0, 2], ERRORS)
    initial = strapdown.NavState.from_attitude(aligned @ mat_base[0].T @ mat0[0], vel0[0], lla0[0])
    config = FilterConfig(
        Model.EKF2,
        Coupling.FB,
        DT,
        lever_arm=rx.lever_arm,
        arw=np.full(3, 0.002 * DEG_RTH),
        vrw=np.full(3, 20 * UG),
        dither_window=dither_window(DITHER, DT),
        initial_sigma=InitialSigma(heading=0.1 * DEG, gyro_bias=0.02 * DPH, clock_bias=1e4),
        outages=((30.0, 34.0),),
    )
    return config, initial, epochs


def _assert_same(name, got, want):
    got, want = np.asarray(got), np.asarray(want)
    assert got.dtype == want.dtype, name
    np.testing.assert_array_equal(got, want, err_msg=name, strict=True)


def _assert_results_agree(got, want):
    for name in (
        "time",
        "gnss_time",
        "quat_nb",
        "vel_n",
        "lla",
        "state",
        "sigma",
        "cumulative",
        "nav_error",
        "heading_error",
        "nees",
        "n_sats",
        "n_used",
        "n_rejected",
        "coasted",
        "nis",
    ):
        _assert_same(name, getattr(got, name), getattr(want, name))
    for name in ("epoch", "prn", "kind", "value", "variance", "accepted"):
        _assert_same(
            f"innovations.{name}", getattr(got.innovations, name), getattr(want.innovations, name)
        )
    assert got.flight_time == want.flight_time
    assert got.update_time.shape == want.update_time.shape
    assert got.model == want.model and got.coupling == want.coupling


def test_ekf2_fb_with_outage_empty_epoch_and_split_propagation(flight):
    config, initial, epochs = flight
    want, splits = run_stepwise(config, initial, 0.0, epochs, ERRORS, kernels=package_kernels)
    got = run_filter(config, initial, 0.0, epochs, ERRORS)
    assert splits >= 1  # the interval of the roll was propagated in sub-intervals
    assert want.coasted[EMPTY_EPOCH] and want.n_sats[EMPTY_EPOCH] == 0
    assert want.coasted[(want.time >= 30.0) & (want.time < 34.0)].all()
    assert want.nees.size == want.time.size  # scored with truth
    _assert_results_agree(got, want)


def test_ekf1_ff_pseudoranges_alone(flight):
    config, initial, epochs = flight
    config = replace(config, model=Model.EKF1, coupling=Coupling.FF, use_range_rate=False)
    want, _ = run_stepwise(config, initial, 0.0, epochs, ERRORS, kernels=package_kernels)
    got = run_filter(config, initial, 0.0, epochs, ERRORS)
    assert want.state.shape[1] == 17 and not np.any(want.innovations.kind)
    _assert_results_agree(got, want)


def test_naive_pairing(flight):
    config, initial, epochs = flight
    config = replace(config, pps_storage=False)
    want, _ = run_stepwise(config, initial, 0.0, epochs, ERRORS, kernels=package_kernels)
    got = run_filter(config, initial, 0.0, epochs, ERRORS)
    assert np.all(want.time > want.gnss_time)  # the state at the arrival
    _assert_results_agree(got, want)


@pytest.mark.parametrize("coupling", [Coupling.FB, Coupling.FF])
def test_smoother_store(flight, coupling):
    config, initial, epochs = flight
    config = replace(config, coupling=coupling)
    store_want, store_got = TightStore(), TightStore()
    want, splits = run_stepwise(
        config, initial, 0.0, epochs, store=store_want, kernels=package_kernels
    )
    got = run_filter(config, initial, 0.0, epochs, store=store_got)
    assert splits >= 1  # a Phi_k the product over sub-intervals
    _assert_results_agree(got, want)
    run_want, run_got = store_want.run(), store_got.run()
    for name in ("time", "quat", "vel", "lla", "comp", "x", "r", "P", "P_pred", "Phi"):
        _assert_same(f"store.{name}", getattr(run_got, name), getattr(run_want, name))


def test_log_grown_by_doubling(flight, monkeypatch):
    """A log that starts with room for one epoch (and 8 innovation rows) doubles its
    arrays as the run goes: the result is the one of a log with room from the start
    (the epochs given as its capacity)."""
    from inins.ekf import epoch_log

    config, initial, epochs = flight
    want = run_filter(config, initial, 0.0, epochs, ERRORS, capacity=len(epochs))
    monkeypatch.setattr(epoch_log, "LOG_CAPACITY", 1)
    got = run_filter(config, initial, 0.0, epochs, ERRORS)
    _assert_results_agree(got, want)


def test_epochs_consumed_as_a_stream(flight):
    """A generator of epochs (consumed once) gives the run of the list."""
    config, initial, epochs = flight
    want = run_filter(config, initial, 0.0, epochs)
    got = run_filter(config, initial, 0.0, (e for e in epochs))
    _assert_results_agree(got, want)


def test_the_rewritten_arithmetic_agrees_with_its_first_form(flight):
    """Each output column within 1e-6 of its largest magnitude over the run (measured:
    1e-9 to 1e-12; the position estimates follow pseudoranges of 2e7 m whose last bit is
    4e-9 m). A wrong term of the rewritten propagation or update (a row the model moves
    left out, a sign, a missing half of ``F Qc + Qc F^T``) changes them by 1e-3 or more.

    The filter is run without its lever arm: the first form's range-rate rows had no
    share of the Earth rate and the gyro bias in the lever arm's velocity, which the
    package's rows carry (design.md §6b; ``tests/ekf/test_jacobians.py``)."""
    config, initial, epochs = flight
    config = replace(config, lever_arm=np.zeros(3))
    want, _ = run_stepwise(config, initial, 0.0, epochs, ERRORS)
    got = run_filter(config, initial, 0.0, epochs, ERRORS)
    for name in ("quat_nb", "vel_n", "lla", "state", "sigma", "cumulative", "nav_error", "nis"):
        a, b = getattr(got, name), getattr(want, name)
        scale = np.abs(b).max(axis=0)
        assert np.all(np.abs(a - b) <= 1e-6 * scale), name
    assert np.array_equal(got.innovations.accepted, want.innovations.accepted)


def test_a_satellite_of_a_system_not_taken_is_refused_at_its_epoch(flight):
    """An epoch inside a batch (not its first) with a GLONASS satellite in a GPS-only
    filter: the error names that epoch's time."""
    config, initial, epochs = flight
    bad = 40  # the ninth epoch of the second batch
    gnss = epochs[bad].gnss
    glonass = replace(gnss, prn=np.r_[101, gnss.prn[1:]])
    epochs = [*epochs[:bad], replace(epochs[bad], gnss=glonass), *epochs[bad + 1 :]]
    with pytest.raises(InputError, match=rf"system R at t = {gnss.time:.3f} s") as info:
        run_filter(config, initial, 0.0, epochs)
    assert info.value.key == "systems"
