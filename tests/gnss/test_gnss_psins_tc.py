"""SPP on the real pseudoranges and range rates of the PSINS tc drive (no reference
trajectory: convergence, residuals, static scatter, track)."""

from dataclasses import replace

import numpy as np

from inins.core import earth
from inins.gnss import spp
from inins.gnss.spp import FixStatus


def test_spp_converges_at_every_epoch_with_five_satellites(tc_flight, tc_spp):
    assert len(tc_flight.gnss.time) == 1707  # epochs with data over 1,801 s
    assert tc_flight.gnss.time[-1] - tc_flight.gnss.time[0] == 1800.0
    five = tc_spp.n_used >= 5
    assert 1540 <= five.sum() <= 1590  # 1,566 at the 10 deg mask
    assert (tc_spp.status[five] == FixStatus.FIX).all()
    assert np.isfinite(tc_spp.pos[five]).all()
    assert np.nanmedian(tc_spp.residual_rms[five]) < 1.0  # 0.27 m measured
    # fewer than four above the mask: recorded as no fix, not an error
    assert (tc_spp.status[tc_spp.n_used < 4] == FixStatus.NO_FIX).all()


def _imu_span(flight, solution, stop):
    t = solution.time - flight.imu_t0_sow
    return (t >= 0.0) & (t <= stop)


def test_static_start_scatter_and_velocity(tc_flight, tc_spp):
    """IMU t 0-69.5 s: the vehicle stands; SPP scatter and range-rate velocity."""
    still = _imu_span(tc_flight, tc_spp, 69.5) & (tc_spp.n_used >= 5)
    assert still.sum() >= 60
    centre = np.mean(tc_spp.pos[still], axis=0)
    lla = earth.llh_from_ecef(centre)
    ned = (tc_spp.pos[still] - centre) @ earth.mat_en(lla[0], lla[1])
    assert np.std(ned[:, 0]) < 0.5 and np.std(ned[:, 1]) < 0.5  # 0.05, 0.06 m measured
    speed = np.linalg.norm(tc_spp.vel[still], axis=1)
    assert np.sqrt(np.mean(speed**2)) < 0.1  # 0.04 m/s (3D) measured


def test_column_six_is_the_negative_range_rate(tc_flight, tc_epochs):
    """Read as a range rate with the other sign, the standing vehicle would race at km/s."""
    obs = replace(tc_epochs.obs, range_rate=-tc_epochs.obs.range_rate)
    wrong = spp.solve(replace(tc_epochs, obs=obs))
    still = _imu_span(tc_flight, wrong, 69.5) & (wrong.n_used >= 5)
    assert np.median(np.linalg.norm(wrong.vel[still], axis=1)) > 100.0


def test_track_length_and_speed_profile(tc_flight, tc_spp):
    trk = spp.track(tc_spp)
    t = tc_spp.time - tc_flight.imu_t0_sow
    before = trk.distance[np.searchsorted(t, 0.0)] - trk.distance[0]
    during = trk.distance[-1] - trk.distance[np.searchsorted(t, 0.0)]
    assert 6500.0 < before < 7100.0  # 6,770 m measured (about 6.8 km)
    assert 240.0 < during < 290.0  # 266 m measured (about 264 m)
    imu = t >= 0
    assert 4.0 < np.nanmax(trk.speed[imu]) < 8.0  # "up to 6 m/s" (7.3 m/s peak from SPP)
    # distance from integrating the range-rate speed agrees with the position track
    dt = np.diff(tc_spp.time, append=tc_spp.time[-1] + 1.0)
    integrated = np.nansum((trk.speed * dt)[t < 0])
    assert abs(integrated - before) < 0.03 * before
