"""RINEX 2/3 readers on the packaged ABPO day, RINEX 3 copies of it, and bad input."""

import gzip
from pathlib import Path

import numpy as np
import pytest

from inins.exceptions import InputError
from inins.gnss import ephemeris, measurements
from inins.io.rinex_nav import read_nav
from inins.io.rinex_obs import observable, read_obs

ROOT = Path(__file__).resolve().parents[2]
OBS = ROOT / "data" / "abpo0080.15o.gz"
NAV = ROOT / "data" / "abpo0080.15n.gz"
SHARED = ROOT / ".." / "shared" / "data" / "gnss"


@pytest.fixture(scope="module")
def obs():
    return read_obs(OBS)


@pytest.fixture(scope="module")
def nav():
    return read_nav(NAV)


def _text(path):
    return gzip.decompress(path.read_bytes()).decode("ascii").splitlines()


def test_observation_file_contents(obs):
    assert obs.version == 2.11 and obs.marker == "ABPO" and obs.interval == 30.0
    assert obs.types == ("L1", "L2", "P1", "P2", "C1", "S1", "S2")
    assert len(obs.time) == 2727 and len(obs.prn) == 25956
    assert obs.week[0] == 1826 and obs.time[0] == 345600.0  # 2015-01-08 00:00:00 GPS
    assert list(obs.prn[:8]) == [2, 12, 5, 15, 18, 21, 24, 13]
    # first record, G02: L1 L2 P1 P2 C1 / S1 S2 (second line)
    np.testing.assert_array_equal(
        obs.values[0],
        [4696590.449, 3668584.547, 25127563.519, 25127563.538, 25127564.975, 41.0, 37.0],
    )
    assert np.isnan(obs.values).any()  # blank fields are NaN, not zero


def test_compressed_and_plain_files_read_the_same(obs, tmp_path):
    plain = SHARED / "abpo0080.15o"
    if not plain.is_file():
        plain = tmp_path / "abpo0080.15o"
        plain.write_bytes(gzip.decompress(OBS.read_bytes()))
    again = read_obs(plain)
    np.testing.assert_array_equal(again.values, obs.values)
    np.testing.assert_array_equal(again.time, obs.time)


def test_navigation_file_contents(nav):
    assert nav.version == 2.10 and len(nav.records) == 167
    first = nav.records[0]
    assert first["prn"] == 2 and first["week"] == 1826 and first["toe"] == 352800.0
    assert first["toc"] == 352800.0  # 2015-01-08 02:00:00
    assert first["af0"] == 5.405521951616e-04 and first["sqrt_a"] == 5.153748075485e03
    assert first["tgd"] == -2.048909664154e-08 and first["fit_interval"] == 4.0
    assert set(nav.records["prn"][nav.records["health"] != 0]) == {8}


def _hl(content, label):
    return content.ljust(60) + label


def _rinex3_obs(obs, n_epochs):
    lines = [
        _hl(f"{'3.04':>9s}{'':11s}{'OBSERVATION DATA':20s}M (MIXED)", "RINEX VERSION / TYPE"),
        _hl("ABPO", "MARKER NAME"),
        _hl(
            f"{4097216.6805:14.4f}{4429119.0287:14.4f}{-2065771.3676:14.4f}", "APPROX POSITION XYZ"
        ),
        _hl(f"G{5:5d} C1C C1W C2W L1C S1C", "SYS / # / OBS TYPES"),
        _hl(f"R{2:5d} C1C L1C", "SYS / # / OBS TYPES"),
        _hl("", "END OF HEADER"),
    ]
    cols = [obs.types.index(t) for t in ("C1", "P1", "P2", "L1", "S1")]
    for k in range(n_epochs):
        sec = obs.time[k] - 345600.0
        rows = range(obs.start[k], obs.start[k + 1])
        lines.append(
            f"> 2015 01 08 {int(sec // 3600):02d} {int(sec % 3600 // 60):02d}"
            f"{sec % 60:11.7f}  0{len(rows) + 1:3d}"
        )
        for r in rows:
            vals = "".join(
                "" if np.isnan(v) else f"{v:14.3f}  " if np.isfinite(v) else ""
                for v in obs.values[r, cols]
            )
            lines.append(f"G{obs.prn[r]:02d}{vals}")
        lines.append("R05  20000000.000    105000000.000  ")
    return "\n".join(lines) + "\n"


def test_rinex3_observations_match_rinex2(obs, tmp_path):
    path = tmp_path / "ABPO00XXX_R_20150080000_01D_30S_MO.rnx.gz"
    path.write_bytes(gzip.compress(_rinex3_obs(obs, 40).encode()))
    obs3 = read_obs(path)
    assert obs3.version == 3.04 and obs3.types == ("C1C", "C1W", "C2W", "L1C", "S1C")
    np.testing.assert_array_equal(obs3.time, obs.time[:40])
    np.testing.assert_array_equal(obs3.prn, obs.prn[: obs.start[40]])  # GLONASS skipped
    for name in ("C1", "P1", "P2", "L1", "S1"):
        np.testing.assert_array_equal(
            observable(obs3, name), observable(obs, name)[: obs.start[40]]
        )


def _d19(v):
    return f"{v:19.12E}".replace("E", "D")


def _rinex3_nav(nav):
    lines = [
        _hl(f"{'3.04':>9s}{'':11s}{'N: GNSS NAV DATA':20s}G: GPS", "RINEX VERSION / TYPE"),
        _hl("GPSA   1.1176D-08  7.4506D-09 -5.9605D-08 -5.9605D-08", "IONOSPHERIC CORR"),
        _hl("GPSB   9.0112D+04  4.9152D+04 -1.3107D+05 -3.2768D+05", "IONOSPHERIC CORR"),
        _hl("", "END OF HEADER"),
    ]
    order = (
        "iode crs delta_n m0 cuc e cus sqrt_a toe cic omega0 cis i0 crc omega omega_dot "
        "idot - week - ura health tgd - - fit_interval"
    ).split()
    for r in nav.records:
        sec = r["toc"] - 345600.0 if r["toc"] >= 345600.0 else r["toc"] - 259200.0
        day = 8 if r["toc"] >= 345600.0 else 7
        lines.append(
            f"G{r['prn']:02d} 2015 01 {day:02d} {int(sec // 3600):02d} "
            f"{int(sec % 3600 // 60):02d} {int(sec % 60):02d}"
            + "".join(_d19(r[k]) for k in ("af0", "af1", "af2"))
        )
        vals = [0.0 if k == "-" else float(r[k]) for k in order] + [0.0, 0.0]
        lines += ["    " + "".join(_d19(v) for v in vals[i : i + 4]) for i in range(0, 28, 4)]
    lines += ["R01 2015 01 08 00 15 00" + _d19(0.0) * 3] + ["    " + _d19(0.0) * 4] * 3
    return "\n".join(lines) + "\n"


def test_rinex3_navigation_matches_rinex2(nav, tmp_path):
    path = tmp_path / "BRDC00XXX_R_20150080000_01D_GN.rnx"
    path.write_text(_rinex3_nav(nav))
    nav3 = read_nav(path)
    assert len(nav3.records) == len(nav.records)
    for name, *_ in ephemeris.FIELDS:
        np.testing.assert_allclose(nav3.records[name], nav.records[name], rtol=1e-12, err_msg=name)
    np.testing.assert_allclose(nav3.iono_alpha, [1.1176e-8, 7.4506e-9, -5.9605e-8, -5.9605e-8])
    assert nav3.iono_beta[0] == 9.0112e4


def _write(tmp_path, name, lines):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def test_another_version_or_system_is_refused(tmp_path):
    lines = _text(OBS)[:300]
    v4 = _write(tmp_path, "v4.15o", [lines[0].replace("2.11", "4.00"), *lines[1:]])
    with pytest.raises(InputError, match="RINEX 2 or 3") as err:
        read_obs(v4)
    assert err.value.line == 1 and err.value.source == str(v4)
    glo = _write(tmp_path, "glo.15o", [lines[0].replace("G (GPS)", "R (GLO)"), *lines[1:]])
    with pytest.raises(InputError, match="system 'R'"):
        read_obs(glo)
    nav = _text(NAV)
    gnav = _write(tmp_path, "x.15g", [nav[0][:20] + "G: GLONASS NAV DATA " + nav[0][40:], *nav[1:]])
    with pytest.raises(InputError, match="navigation file"):
        read_nav(gnav)
    with pytest.raises(InputError, match="navigation file"):
        read_nav(OBS)


def test_truncated_epoch_record_names_the_line(tmp_path):
    lines = _text(OBS)
    # header 27 lines; epoch 1: 1 + 8 x 2 lines; cut inside epoch 2 (10 satellites)
    cut = _write(tmp_path, "cut.15o", lines[: 27 + 17 + 1 + 5])
    with pytest.raises(InputError, match="truncated epoch record") as err:
        read_obs(cut)
    assert err.value.line == 27 + 17 + 2
    assert "cut.15o" in str(err.value)
    nav = _text(NAV)
    with pytest.raises(InputError, match="truncated navigation record") as err:
        read_nav(_write(tmp_path, "cut.15n", nav[: 13 + 8 * 3 + 5]))
    assert err.value.line == 13 + 8 * 3 + 1  # 13 header lines, 3 records, the 4th cut


def test_unreadable_values_and_headers(tmp_path):
    lines = _text(OBS)[: 27 + 17 * 3]  # header and three epochs of 8 satellites
    bad = list(lines)
    bad[30] = bad[30][:20] + "x" + bad[30][21:]
    with pytest.raises(InputError, match="unreadable observation value") as err:
        read_obs(_write(tmp_path, "bad.15o", bad))
    assert err.value.line == 31  # the record of G12 (lines 31-32) holds the bad character
    with pytest.raises(InputError, match="END OF HEADER"):
        read_obs(_write(tmp_path, "nohdr.15o", lines[:20]))
    with pytest.raises(InputError, match="cannot read"):
        read_obs(tmp_path / "missing.15o")


def test_event_records_are_skipped(obs, tmp_path):
    lines = _text(OBS)
    event = [
        " 15  1  8  0  0 30.0000000  4  2",
        f"{'inserted comment':60s}COMMENT",
        f"{'another':60s}COMMENT",
    ]
    cut = 27 + 17
    path = _write(tmp_path, "event.15o", lines[:cut] + event + lines[cut : cut + 17])
    again = read_obs(path)
    np.testing.assert_array_equal(again.time, obs.time[:2])


def test_no_navigation_data_for_the_observed_satellites(obs, nav):
    other = nav.records[np.isin(nav.records["prn"], [3, 26])]  # not seen at the start
    first = np.arange(10)
    raw = measurements.make_observations(
        obs.week[first],
        obs.time[first],
        obs.start[:11],
        obs.prn[: obs.start[10]],
        observable(obs, "C1")[: obs.start[10]],
    )
    assert not np.isin(raw.prn, [3, 26]).any()
    with pytest.raises(InputError, match="no usable navigation data") as err:
        measurements.attach_satellites(raw, ephemeris.from_columns(other), source="abpo.15n")
    assert err.value.source == "abpo.15n"


def test_more_than_twelve_satellites_continue_on_the_next_line(obs, tmp_path):
    lines = _text(OBS)
    header, record = lines[:27], lines[28:30]  # the first record of G02 (two lines)
    ids = "".join(f"G{p:02d}" for p in range(1, 15))
    epoch = [f" 15  1  8  0  0  0.0000000  0 14{ids[:36]}", f"{'':32s}{ids[36:]}"]
    path = _write(tmp_path, "many.15o", header + epoch + record * 14)
    many = read_obs(path)
    np.testing.assert_array_equal(many.prn, np.arange(1, 15))
    np.testing.assert_array_equal(many.values, np.tile(obs.values[0], (14, 1)))
