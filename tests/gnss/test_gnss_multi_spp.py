"""Multi-system SPP: the smartLoc drive (Berlin, GPS + GLONASS C1 at 5 Hz) against its
NovAtel reference; inter-system biases on simulated data; the ABPO single-frequency rows."""

from pathlib import Path

import numpy as np
import pytest

from inins.core import earth
from inins.exceptions import InputError
from inins.gnss import broadcast, measurements, spp, systems
from inins.gnss.spp import FixStatus
from inins.io.rinex_nav import read_navigation
from inins.io.rinex_obs import read_obs, system_observable
from inins.io.rinex_text import read_track

DATA = Path(__file__).resolve().parents[2] / "data" / "smartloc"
GT_OFFSET_S = 126641.7
"""GPS seconds of week minus the reference file's time (data/smartloc/README.md)."""


@pytest.fixture(scope="module")
def drive():
    obs_file = read_obs(DATA / "Berlin_Potsdamer_Platz.obs.gz", "GR")
    gps = read_navigation(DATA / "brdc1580.16n.gz")
    glo = read_navigation(DATA / "brdc1580.16g.gz")
    nav = broadcast.merge(
        [broadcast.from_records(gps.records), broadcast.from_records(glo.records, glo.glonass)]
    )
    nan = np.full(len(obs_file.prn), np.nan)
    obs = measurements.from_code(
        obs_file.week,
        obs_file.time,
        obs_file.start,
        obs_file.prn,
        nan,
        nan,
        system_observable(obs_file, "C1"),
        doppler_l1=system_observable(obs_file, "D1"),
        snr=system_observable(obs_file, "S1"),
        channel=broadcast.glonass_channels(nav, obs_file.prn),
    )
    return (
        obs,
        nav,
        (gps.iono_alpha, gps.iono_beta),
        read_track(DATA / "Berlin_Potsdamer_Platz_GT.txt.gz"),
    )


def _score(drive, systems_kept, **options):
    obs, nav, klobuchar, (t_ref, p_ref) = drive
    obs = obs.take_rows(np.isin(obs.prn // 100, systems_kept))
    epochs = measurements.attach_satellites(obs, nav)
    sol = spp.solve(epochs, spp.SppOptions(klobuchar=klobuchar, **options))
    t = sol.time - GT_OFFSET_S
    inside = (t >= t_ref[0]) & (t <= t_ref[-1])
    ref = np.stack([np.interp(t, t_ref, p_ref[:, i]) for i in range(3)], axis=1)
    lla = earth.llh_from_ecef(p_ref[0])
    ned = (sol.pos - ref) @ earth.mat_en(lla[0], lla[1])
    accepted = np.isin(sol.status, [FixStatus.FIX, FixStatus.FAULT_EXCLUDED]) & inside
    err = np.hypot(ned[accepted, 0], ned[accepted, 1])
    return int(accepted.sum()), float(np.median(err)), float(np.percentile(err, 95)), sol


URBAN = {"sigma_zenith_m": 2.0, "max_exclusions": 5, "snr_reference_dbhz": 45.0}
"""The shipped scenario's settings (configs/import-flight/smartloc-gps-glonass.yaml)."""


def test_gps_glonass_beats_gps_alone_in_the_city(drive):
    """1,372 epochs inside the reference. Measured (C/N0 weights below 45 dB-Hz, 2 m at
    zenith, up to five exclusions): GPS alone 1,366 accepted fixes, median horizontal error
    16.4 m, 95 % 67.7 m; GPS + GLONASS all 1,372, 13.9 m, 51.4 m. (RTKLIB 2.4.3 with its
    defaults: GPS 777 epochs at 20.7 m, GPS + GLONASS 180 at 13 m: its residual test, with
    no exclusion, rejects most epochs that GLONASS makes redundant.)"""
    n_g, med_g, p95_g, _ = _score(drive, [0], **URBAN)
    n_gr, med_gr, p95_gr, sol = _score(drive, [0, 1], **URBAN)
    assert n_gr > n_g and med_gr <= med_g
    assert (n_g, n_gr) == (1366, 1372)
    assert med_gr == pytest.approx(13.9, abs=0.3) and med_g == pytest.approx(16.4, abs=0.3)
    assert p95_gr < p95_g
    # one GLONASS bias column, estimated where both systems are used (a few metres)
    assert sol.isb_systems == (systems.GLONASS,)
    assert np.isfinite(sol.isb[:, 0]).sum() > 1300 and abs(np.nanmedian(sol.isb[:, 0])) < 20.0


def test_carrier_to_noise_weights_help_in_the_city(drive):
    """Without C/N0 weights (3 m at zenith, five exclusions): GPS + GLONASS 1,369 fixes at
    21.0 m, GPS 1,362 at 23.4 m: still better together, and both worse than weighted."""
    n_g, med_g, _, _ = _score(drive, [0], sigma_zenith_m=3.0, max_exclusions=5)
    n_gr, med_gr, _, _ = _score(drive, [0, 1], sigma_zenith_m=3.0, max_exclusions=5)
    assert (n_g, n_gr) == (1362, 1369)
    assert med_gr == pytest.approx(21.0, abs=0.3) and med_g == pytest.approx(23.4, abs=0.3)


def test_one_exclusion_reproduces_rtklib_on_gps(drive):
    """A single exclusion, as RTKLIB's SPP: GPS median 20.7 m (RTKLIB 20.7 m); GPS +
    GLONASS passes the residual test in far fewer epochs (323; RTKLIB 180) at 13.6 m
    (RTKLIB 13 m)."""
    n_g, med_g, _, _ = _score(drive, [0], sigma_zenith_m=3.0)
    n_gr, med_gr, _, _ = _score(drive, [0, 1], sigma_zenith_m=3.0)
    assert med_g == pytest.approx(20.7, abs=0.3) and n_g > 1000
    assert n_gr < 400 and med_gr == pytest.approx(13.6, abs=0.5)


def test_per_system_mask_and_weight(drive):
    obs, nav, klobuchar, _ = drive
    first = obs.take_epochs(np.arange(300))
    epochs = measurements.attach_satellites(first, nav)
    glo = systems.system_of(epochs.obs.prn) == systems.GLONASS
    base = spp.solve(epochs, spp.SppOptions(klobuchar=klobuchar, exclude_faults=False))
    masked = spp.solve(
        epochs,
        spp.SppOptions(
            klobuchar=klobuchar, system_mask_rad=((1, np.radians(30.0)),), exclude_faults=False
        ),
    )
    assert masked.elevation[masked.used & glo].min() >= np.radians(30.0)
    assert base.elevation[base.used & glo].min() < np.radians(20.0)  # 17 deg
    assert masked.elevation[masked.used & ~glo].min() < np.radians(20.0)  # GPS keeps 10 deg
    # a GLONASS sigma 4x larger: GLONASS residuals grow relative to GPS's
    down = spp.solve(
        epochs,
        spp.SppOptions(klobuchar=klobuchar, system_sigma_scale=((1, 4.0),), exclude_faults=False),
    )
    rms = lambda s, m: np.sqrt(np.mean(s.residual[s.used & m] ** 2))  # noqa: E731
    assert rms(down, glo) / rms(down, ~glo) > rms(base, glo) / rms(base, ~glo)


def test_inter_system_bias_on_simulated_ranges(drive):
    """Exact ranges from the real GPS + GLONASS geometry, a 7 m GLONASS bias and a 30 m
    clock: recovered to 1 mm, position to 1 mm (the bias column's sign: flip it and the
    solution is 14 m off)."""
    obs, nav, _, (t_ref, p_ref) = drive
    first = obs.take_epochs(np.arange(5))
    epochs = measurements.attach_satellites(first, nav)
    t = first.time - GT_OFFSET_S
    truth = np.stack([np.interp(t, t_ref, p_ref[:, i]) for i in range(3)], axis=1)
    rx = truth[epochs.obs.epoch]
    from inins.gnss import propagation

    rho, *_ = propagation.geometry(epochs.sat_pos, epochs.sat_vel, rx, np.zeros_like(rx))
    glo = systems.system_of(epochs.obs.prn) == systems.GLONASS
    pr = rho + 30.0 + np.where(glo, 7.0, 0.0) - epochs.sat_clock
    sim = measurements.GnssEpochs(
        obs=measurements.make_observations(
            epochs.obs.week, epochs.obs.time, epochs.obs.start, epochs.obs.prn, pr
        ),
        eph_index=epochs.eph_index,
        sat_pos=epochs.sat_pos,
        sat_vel=epochs.sat_vel,
        sat_clock=epochs.sat_clock,
        sat_drift=epochs.sat_drift,
    )
    sol = spp.solve(sim, spp.SppOptions(troposphere=False, mask_rad=0.0))
    np.testing.assert_allclose(sol.pos, truth, atol=1e-3)
    np.testing.assert_allclose(sol.clock, 30.0, atol=1e-3)
    np.testing.assert_allclose(sol.isb[:, 0], 7.0, atol=1e-3)


def test_glonass_doppler_without_a_channel_is_refused(drive):
    obs, *_ = drive
    prn = obs.prn[:20]
    assert (prn // 100 == 1).any()
    with pytest.raises(InputError, match="GLONASS frequency channel missing for R"):
        measurements.from_code(
            obs.week[:1], obs.time[:1], [0, 20], prn, *(np.full(20, np.nan),) * 2,
            obs.pseudorange[:20], doppler_l1=np.ones(20),
        )  # fmt: skip


def test_glonass_range_rate_uses_the_channel_wavelength(drive):
    obs, nav, _, _ = drive
    channel = broadcast.glonass_channels(nav, obs.prn)
    glo = obs.prn // 100 == 1
    lam = systems.l1_wavelength(obs.prn, channel)
    assert np.isfinite(channel[glo]).all() and np.isnan(channel[~glo]).all()
    assert np.unique(np.round(lam[glo], 6)).size > 3  # several channels, several wavelengths
    np.testing.assert_allclose(lam[~glo], systems.C / 1575.42e6)


def test_navigation_without_the_observed_system(drive):
    obs, nav, _, _ = drive
    gps_only = broadcast.Navigation(kepler=nav.kepler)
    glo_rows = obs.take_rows(obs.prn // 100 == 1)
    with pytest.raises(InputError, match=r"no usable navigation data .*R0") as err:
        measurements.attach_satellites(glo_rows, gps_only, source="brdc1580.16n")
    assert err.value.source == "brdc1580.16n"


def test_ionosphere_rows_on_the_abpo_day(abpo_obs):
    """ABPO: 46 C1-only rows (P2 missing after acquisition), no Klobuchar in the header. In
    auto and iono-free they are dropped and counted; they are no longer refused."""
    from tests.gnss.conftest import code_observations

    obs = code_observations(abpo_obs)
    for choice in ("auto", "iono-free"):
        rows = measurements.ionosphere_rows(obs.signal, choice, has_klobuchar=False)
        assert rows.dropped == 46 and rows.keep.sum() == len(obs.prn) - 46
        assert not rows.klobuchar
    kept = measurements.ionosphere_rows(obs.signal, "auto", has_klobuchar=True)
    assert kept.dropped == 0 and kept.klobuchar
    with pytest.raises(InputError, match="no row has both"):
        measurements.ionosphere_rows(
            np.full(3, measurements.Signal.L1), "iono-free", has_klobuchar=False
        )


def test_dropping_the_uncorrected_rows_on_the_abpo_day(abpo_obs, abpo_eph, abpo_spp):
    """Without the 46 rows: no "fault excluded" epoch is left (all 5 were those rows), 7
    epochs move (by up to 7.9 m), 3D RMS 3.958 -> 3.944 m, 95 % 7.467 -> 7.453 m; every
    other epoch is unchanged to 1 mm."""
    from tests.gnss.conftest import code_observations

    obs = code_observations(abpo_obs)
    rows = measurements.ionosphere_rows(obs.signal, "auto", has_klobuchar=False)
    sol = spp.solve(measurements.attach_satellites(obs.take_rows(rows.keep), abpo_eph))
    assert np.count_nonzero(abpo_spp.status == FixStatus.FAULT_EXCLUDED) == 5
    assert np.count_nonzero(sol.status == FixStatus.FAULT_EXCLUDED) == 0
    moved = np.linalg.norm(sol.pos - abpo_spp.pos, axis=1) > 1e-3
    assert np.count_nonzero(moved) == 7
    err = np.linalg.norm(sol.pos - abpo_obs.approx_pos_e, axis=1)
    assert np.sqrt(np.nanmean(err**2)) == pytest.approx(3.944, abs=2e-3)


def test_four_systems_simulated_from_the_mixed_file_and_solved():
    """The receiver simulation on the mixed RINEX 3 file (GPS, GLONASS, Galileo, BeiDou) in
    Berlin for 2 h, with inter-system biases of 5, -3 and 8 m and 1 cm noise: SPP recovers
    position to 5 cm and each bias to 5 cm; the Galileo BGD and BeiDou TGD1 enter the
    simulated L1 clock and the solution alike."""
    from inins.gnss import simulate

    mixed = read_navigation(DATA / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz", leap_seconds=17)
    nav = broadcast.from_records(mixed.records, mixed.glonass)
    time = 86400.0 + 10 * 3600.0 + np.arange(0.0, 7200.0, 60.0)
    lla = earth.llh_from_ecef(np.array([3785108.11, 899901.49, 5037234.46]))
    pos, vel = simulate.static_receiver(lla[0], lla[1], lla[2], len(time))
    bias = ((1, 5.0), (2, -3.0), (3, 8.0))
    options = simulate.SimulationOptions(
        mask_rad=np.radians(5.0), sigma_pr_m=0.01, troposphere=False, system_bias_m=bias
    )
    rng = np.random.default_rng(7)
    obs, _ = simulate.simulate(
        nav, 1900, time, pos, vel, np.full(len(time), 30.0), np.zeros(len(time)), rng, options
    )
    assert set(np.unique(obs.prn // 100)) == {0, 1, 2, 3}
    sol = spp.solve(
        measurements.attach_satellites(obs, nav),
        spp.SppOptions(troposphere=False, mask_rad=np.radians(5.0)),
    )
    assert (sol.status == FixStatus.FIX).all()
    assert np.abs(sol.pos - pos).max() < 0.05
    assert sol.isb_systems == (1, 2, 3)
    for k, (_, value) in enumerate(bias):  # NaN where the system is not in view (Galileo 2016)
        seen = np.isfinite(sol.isb[:, k])
        assert seen.sum() >= 20 and np.abs(sol.isb[seen, k] - value).max() < 0.05


def test_rows_of_chosen_systems(drive):
    obs = drive[0]
    gps = measurements.gps_rows(obs)
    assert (gps.prn < 100).all() and len(gps.prn) == np.count_nonzero(obs.prn < 100)
    assert gps.n_epochs == obs.n_epochs
    glo = measurements.system_rows(obs, [1])
    assert (glo.prn // 100 == 1).all() and len(glo.prn) == np.count_nonzero(obs.prn // 100 == 1)
    assert measurements.system_rows(obs, [0, 1]) is obs  # nothing else in the drive
