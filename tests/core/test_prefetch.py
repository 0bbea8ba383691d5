"""The generator run ahead in a second thread (inins.core.prefetch.ahead)."""

import threading

import numpy as np
import pytest

from inins.core import imu, prefetch
from inins.ekf.flight import (
    Dither,
    Dithered,
    FlightPlan,
    Leg,
    LegKind,
    flight_trajectory,
    imu_stream,
)


def test_the_items_in_order_and_the_thread_gone_after():
    before = threading.active_count()
    assert list(prefetch.ahead(iter(range(1000)), 3)) == list(range(1000))
    assert list(prefetch.ahead([], 1)) == []
    assert threading.active_count() == before


def test_an_error_in_the_generator_is_raised_at_its_item():
    def items():
        yield 1
        yield 2
        raise ValueError("the third")

    got = []
    with pytest.raises(ValueError, match="the third"):
        for item in prefetch.ahead(items(), 1):
            got.append(item)
    assert got == [1, 2]


def test_a_consumer_that_stops_early_stops_the_thread():
    made = []

    def endless():
        k = 0
        while True:
            made.append(k)
            yield k
            k += 1

    stream = prefetch.ahead(endless(), 2)
    assert [next(stream) for _ in range(5)] == [0, 1, 2, 3, 4]
    stream.close()
    threads = [t for t in threading.enumerate() if t.name == "inins-ahead"]
    for t in threads:
        t.join(timeout=30)  # a hang guard: it stops within its 0.1 s put timeout
    assert not any(t.is_alive() for t in threads)
    assert len(made) <= 5 + 2 + 2  # taken, queued, and at most one more being put


def test_a_flight_imu_stream_computed_ahead_is_the_plain_one_bit_for_bit():
    plan = FlightPlan(
        0.65, 2.2, 100.0, 0.5, (Leg(LegKind.WAIT, 3), Leg(LegKind.TAKEOFF, 5, speed=60.0))
    )
    truth = Dithered(flight_trajectory(plan), Dither(2.9e-4, 40.0))
    errors = imu.SensorErrors(gyro_bias=np.full(3, 1e-7), gyro_arw=1e-5, accel_vrw=1e-4)
    edges = np.r_[0, np.arange(1, 8) * 200 + 30]  # one chunk per second, 30 samples late
    streams = [
        list(imu_stream(truth, errors, 0.005, edges, np.random.default_rng(4), block=300, **k))
        for k in ({}, {"ahead": True})
    ]
    assert len(streams[0]) == len(streams[1]) == 7
    for (a_theta, a_v), (b_theta, b_v) in zip(*streams, strict=True):
        assert np.array_equal(a_theta, b_theta) and np.array_equal(a_v, b_v)
