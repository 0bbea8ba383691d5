"""Single-point positioning on a real IGS station day (ABPO, 2015-01-08), against the
station coordinates in the RINEX header."""

import numpy as np

from inins.core import earth
from inins.gnss import measurements, spp
from inins.gnss.spp import FixStatus
from tests.gnss.conftest import code_observations


def _errors(solution, truth):
    err = np.linalg.norm(solution.pos - truth, axis=1)
    return err[np.isfinite(err)]


def test_the_packaged_day(abpo_obs, abpo_nav):
    assert len(abpo_obs.time) == 2727
    gap = np.diff(abpo_obs.time)
    k = int(np.argmax(gap))
    assert (abpo_obs.time[k] - 345600.0, abpo_obs.time[k + 1] - 345600.0) == (
        14 * 3600 + 59 * 60 + 30.0,
        16 * 3600 + 16 * 60 + 30.0,
    )
    assert abpo_nav.iono_alpha is None and abpo_nav.iono_beta is None  # no Klobuchar
    np.testing.assert_allclose(abpo_obs.approx_pos_e, [4097216.6805, 4429119.0287, -2065771.3676])


def test_iono_free_spp_against_the_station_coordinates(abpo_obs, abpo_spp):
    """P1/P2 ionosphere-free, 10 deg mask, elevation weights, Saastamoinen: the whole day."""
    err = _errors(abpo_spp, abpo_obs.approx_pos_e)
    assert len(err) == 2726  # one epoch tracks a single satellite: no fix, recorded
    assert np.sqrt(np.mean(err**2)) <= 4.5  # 3.96 m measured
    assert np.percentile(err, 95) <= 8.0  # 7.47 m
    assert err.max() <= 15.0  # 12.24 m
    assert np.count_nonzero(abpo_spp.status == FixStatus.NO_FIX) == 1
    assert np.nanmedian(abpo_spp.pdop) < 2.5
    ned = spp.errors_ned(abpo_spp, abpo_obs.approx_pos_e)
    np.testing.assert_allclose(np.linalg.norm(ned, axis=1)[np.isfinite(ned[:, 0])], err)
    assert np.nanstd(ned[:, 2]) > np.nanstd(ned[:, 0])  # height is the weak direction
    used_el = abpo_spp.elevation[abpo_spp.used]
    assert used_el.min() >= np.radians(10.0)


def test_unhealthy_g08_is_never_used(abpo_obs, abpo_epochs):
    assert (abpo_obs.prn == 8).any()
    assert not (abpo_epochs.obs.prn == 8).any()
    dropped = dict(zip(abpo_epochs.dropped_prn, abpo_epochs.dropped_count, strict=True))
    assert dropped.pop(8) == np.count_nonzero(abpo_obs.prn == 8)
    # the others: one row each at 00:00:00, sent 70 ms before their first set's 2 h limit
    assert set(dropped.values()) == {1}
    first = abpo_obs.prn[: abpo_obs.start[1]]
    assert set(dropped) <= set(first)


def test_a_real_faulty_pseudorange_is_excluded_and_named(abpo_obs, abpo_epochs, abpo_spp):
    """G01 right after acquisition at 10:24 carries ~26 m: the residual test names it."""
    named = abpo_spp.excluded_prn > 0
    assert set(abpo_spp.excluded_prn[named]) == {1}
    hours = (abpo_obs.time[named] - 345600.0) / 3600.0
    assert hours.min() > 10.39 and hours.max() < 10.44
    k = np.flatnonzero(named)
    assert (abpo_spp.status[k] == FixStatus.FAULT_EXCLUDED).all()
    # without the exclusion those epochs are the worst of the day (up to 15.3 m)
    kept = spp.solve(abpo_epochs.take_epochs(k), spp.SppOptions(exclude_faults=False))
    assert np.linalg.norm(kept.pos - abpo_obs.approx_pos_e, axis=1).max() > 14.0


def test_single_frequency_without_ionosphere_is_worse(abpo_obs, abpo_eph, abpo_spp):
    """C1 with TGD and no ionosphere model: several metres of vertical ionosphere error."""
    c1 = measurements.attach_satellites(code_observations(abpo_obs, p1=False), abpo_eph)
    assert (c1.obs.signal == measurements.Signal.L1).all()
    err = _errors(spp.solve(c1), abpo_obs.approx_pos_e)
    rms = np.sqrt(np.mean(err**2))
    assert 8.0 < rms < 15.0  # 11.0 m measured (11.3 m by the independent implementation)
    lla = earth.llh_from_ecef(abpo_obs.approx_pos_e)
    up = -np.einsum(
        "j,nj->n", earth.mat_en(lla[0], lla[1])[:, 2], abpo_spp.pos - abpo_obs.approx_pos_e
    )
    assert abs(np.nanmean(up)) < 3.0  # iono-free: no large height bias


def test_the_day_is_unchanged_by_the_multi_system_solver(abpo_spp):
    """Positions of the GPS-only solver before the inter-system biases, the per-system
    options and the successive exclusions were added (same data, same options): the mean
    of all fixes and three single epochs, to 1 mm."""
    pos = abpo_spp.pos[np.isfinite(abpo_spp.pos[:, 0])]
    assert len(pos) == 2726
    np.testing.assert_allclose(
        pos.mean(axis=0), [4097217.4189, 4429119.3755, -2065771.7926], atol=1e-3
    )
    np.testing.assert_allclose(pos[0], [4097219.3967, 4429120.8913, -2065770.3306], atol=1e-3)
    np.testing.assert_allclose(pos[1000], [4097217.1664, 4429121.4609, -2065771.1435], atol=1e-3)
    np.testing.assert_allclose(pos[-1], [4097222.2641, 4429124.4380, -2065772.4903], atol=1e-3)
    assert abpo_spp.isb.shape == (2727, 0) and abpo_spp.isb_systems == ()
