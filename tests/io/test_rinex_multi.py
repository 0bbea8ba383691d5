"""Multi-system RINEX: GLONASS .g, mixed RINEX 3 navigation, RINEX 4 message records, mixed
RINEX 3 observations (written from the smartLoc RINEX 2.11 file and read back), and bad
input of each, through the reader and through ``inins import-flight``."""

import gzip
import json
import re
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from inins.cli import app
from inins.exceptions import InputError
from inins.io.flight_layout import read_flight
from inins.io.rinex_nav import read_nav, read_navigation
from inins.io.rinex_obs import read_obs, system_observable, write_obs_v3

DATA = Path(__file__).resolve().parents[2] / "data" / "smartloc"
MIXED = DATA / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz"
CONFIG = Path(__file__).resolve().parents[2] / "configs" / "import-flight"


def _lines(path):
    return gzip.decompress(path.read_bytes()).decode("ascii").splitlines()


def _rinex4(lines):
    """The mixed RINEX 3.03 file rewritten as RINEX 4.00 message records (plus an STO
    and an ION record, which are skipped)."""
    k = next(i for i, line in enumerate(lines) if "END OF HEADER" in line)
    head = [lines[0].replace("     3.03", "     4.00"), *lines[1:k]]
    head += [f"{'17':>6}{'':54}LEAP SECONDS", lines[k]]
    out = ["> STO GL SBAS", "    2016 06 06 00 00 00 GLUT", "     0.0 0.0 0.0 0.0"]
    klob = [f"{v:19.12e}" for v in (6.519e-9, 2.235e-8, -5.96e-8, -1.192e-7, 86020.0, 98300.0)]
    klob += [f"{v:19.12e}" for v in (-65540.0, -524300.0, 1.0)]
    out += ["> ION G01 LNAV", "    2016 06 06 00 00 00" + "".join(klob[:3])]
    out += ["    " + "".join(klob[3:7]), "    " + "".join(klob[7:9])]
    i = k + 1
    counts = {"G": 8, "E": 8, "C": 8, "R": 4}
    while i < len(lines):
        letter = lines[i][0]
        n = counts[letter]
        if letter == "E":
            source = int(float(lines[i + 5][23:42].replace("D", "E")))
            message = "INAV" if source & 1 or source & 4 else "FNAV"
        else:
            message = {"G": "LNAV", "C": "D1", "R": "FDMA"}[letter]
        out.append(f"> EPH {lines[i][:3]} {message}")
        out += lines[i : i + n]
        if letter == "R":  # RINEX 4 adds a fifth GLONASS line (status, delays, URAI)
            out.append("     0.000000000000e+00 0.000000000000e+00 0.000000000000e+00")
        i += n
    return head + out


def test_rinex4_message_records_read_as_rinex3(tmp_path):
    v3 = read_navigation(MIXED, leap_seconds=17)
    path = tmp_path / "mixed4.rnx"
    path.write_text("\n".join(_rinex4(_lines(MIXED))) + "\n")
    v4 = read_navigation(path)
    assert v4.version == 4.0 and v4.leap_seconds == 17
    assert v4.skipped == {"STO": 1}  # the ION record gives the Klobuchar coefficients
    np.testing.assert_allclose(v4.iono_alpha, [6.519e-9, 2.235e-8, -5.96e-8, -1.192e-7])
    np.testing.assert_allclose(v4.iono_beta, [86020.0, 98300.0, -65540.0, -524300.0])
    gps4 = read_nav(path)  # the GPS reader takes a RINEX 4 file's LNAV records
    assert gps4.version == 4.0 and (gps4.records["prn"] < 100).all()
    np.testing.assert_array_equal(gps4.records["toe"], v3.records["toe"][v3.records["prn"] < 100])
    for name in v3.records.dtype.names:
        if name != "line":
            np.testing.assert_array_equal(v4.records[name], v3.records[name])
    for name in ("sat", "toe", "pos", "vel", "acc", "channel", "health", "clock_bias"):
        np.testing.assert_array_equal(v4.glonass[name], v3.glonass[name])


def test_rinex4_unknown_records_are_refused_with_their_line(tmp_path):
    lines = _rinex4(_lines(MIXED))
    k = next(i for i, line in enumerate(lines) if line.startswith("> EPH E"))
    bad = list(lines)
    bad[k] = bad[k].replace("> EPH", "> XYZ")
    path = tmp_path / "bad4.rnx"
    path.write_text("\n".join(bad) + "\n")
    with pytest.raises(InputError, match="unknown RINEX 4 record type") as err:
        read_navigation(path)
    assert err.value.line == k + 1 and err.value.source == str(path)
    bad = list(lines)
    bad[k] = bad[k][:10] + " L5NAV"
    path.write_text("\n".join(bad) + "\n")
    with pytest.raises(InputError, match="unknown RINEX 4 ephemeris message 'L5NAV'") as err:
        read_navigation(path)
    assert err.value.line == k + 1


def test_glonass_rinex2_and_the_gps_reader_unchanged():
    g = read_navigation(DATA / "brdc1580.16g.gz")
    assert len(g.glonass) == 1169 and len(g.records) == 0 and g.systems == "R"
    first = g.glonass[0]
    assert first["sat"] == 101 and first["channel"] == 1
    np.testing.assert_allclose(first["pos"], [-6553426.26953, 22609128.9062, 9851016.60156])
    n = read_navigation(DATA / "brdc1580.16n.gz")
    old = read_nav(DATA / "brdc1580.16n.gz")
    for name in old.records.dtype.names:
        np.testing.assert_array_equal(n.records[name], old.records[name])
    np.testing.assert_array_equal(n.iono_alpha, old.iono_alpha)


def test_galileo_and_beidou_group_delays_and_weeks():
    v3 = read_navigation(MIXED, leap_seconds=17)
    gal = v3.records[v3.records["prn"] // 100 == 2]
    bds = v3.records[v3.records["prn"] // 100 == 3]
    assert (gal["week"] == 1900).all() and (bds["week"] == 544).all()  # GST = GPS weeks, BDT
    assert np.abs(gal["tgd"]).max() < 5e-8 and np.abs(bds["tgd"]).max() < 5e-8
    assert (bds["tgd"] != 0).any() and (gal["tgd"] != 0).any()


@pytest.fixture(scope="module")
def rinex2():
    return read_obs(DATA / "Berlin_Potsdamer_Platz.obs.gz", "GR")


def test_mixed_observations_rinex3_match_rinex2(rinex2, tmp_path):
    """The RINEX 2.11 GPS + GLONASS file written as RINEX 3.04 with per-system code lists in
    different orders reads back the same, code by code (priority lists per system)."""
    v = rinex2.values
    more = ("C2W", "L2W", "S2W", "D2W", "C5Q", "L5Q", "S5Q", "D5Q", "C1W", "L1W", "S1W")
    columns = {  # GPS with 15 codes: the header's SYS / # / OBS TYPES continues on a line
        "G": (("C1C", "L1C", "S1C", "D1C", *more), np.c_[v, np.full((len(v), 11), np.nan)]),
        "R": (("D1C", "C1C", "S1C", "L1C", "C2P"), np.c_[v[:, [3, 0, 2, 1]], v[:, :1] * np.nan]),
    }
    path = tmp_path / "mixed3.rnx"
    write_obs_v3(path, rinex2.week, rinex2.time, rinex2.start, rinex2.prn, columns)
    again = read_obs(path, "GR")
    np.testing.assert_array_equal(again.prn, rinex2.prn)
    np.testing.assert_array_equal(again.time, rinex2.time)
    assert again.system_types == {"G": columns["G"][0], "R": columns["R"][0]}
    for name in ("C1", "L1", "S1", "D1"):
        np.testing.assert_array_equal(
            system_observable(again, name), system_observable(rinex2, name)
        )
    assert np.isnan(system_observable(again, "P2")).all()
    gps = read_obs(path)  # the GPS-only reader keeps GPS rows under their RINEX 2 names
    assert (gps.prn < 100).all() and len(gps.prn) == np.count_nonzero(rinex2.prn < 100)


def test_a_system_the_file_does_not_have(rinex2, tmp_path):
    path = tmp_path / "gps3.rnx"
    gps = rinex2.prn < 100
    write_obs_v3(
        path, rinex2.week, rinex2.time, rinex2.start, rinex2.prn, {"G": (("C1C",), rinex2.values)}
    )
    with pytest.raises(InputError, match="no observation types of the systems 'E'"):
        read_obs(path, "E")
    assert gps.any()


def _run(*args):
    return CliRunner().invoke(app, ["import-flight", *map(str, args)])


def test_the_shipped_scenario_passes(tmp_path):
    result = _run(CONFIG / "smartloc-gps-glonass.yaml", "-o", tmp_path)
    assert result.exit_code == 0, result.output
    report = (tmp_path / "import-flight.txt").read_text()
    assert "against the reference trajectory: 1372 accepted fixes of 1372 epochs" in report
    # the GLONASS sets go into the recorded-flight layout beside the GPS table, so that
    # run-ekf can take the GLONASS rows of the recording
    flight = read_flight(tmp_path / "import-flight.h5")
    assert flight.glonass is not None and flight.glonass["pos"].shape[1] == 3
    slots = set(flight.glonass["sat"].tolist())
    observed = set(flight.gnss.prn[flight.gnss.prn // 100 == 1].tolist())
    assert observed <= slots and len(flight.glonass["sat"]) > len(slots)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("extra_nav_files=[]", "no navigation record of system R (GLONASS)"),
        ("systems=GX", "systems"),
        ("spp.system_mask_deg={E: 15}", "system ['E'] is not enabled"),
        ("systems=GE", "no navigation record of system E"),
    ],
)
def test_bad_multi_system_input(tmp_path, override, message):
    result = _run(CONFIG / "smartloc-gps-glonass.yaml", "-o", tmp_path, "--set", override)
    assert result.exit_code == 2, result.output
    assert message in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_glonass_from_the_mixed_file_needs_leap_seconds(tmp_path):
    nav = f"nav_file={MIXED}"
    result = _run(
        CONFIG / "smartloc-gps-glonass.yaml", "-o", tmp_path, "--set", nav,
        "--set", "extra_nav_files=[]",
    )  # fmt: skip
    assert result.exit_code == 2 and "LEAP SECONDS" in result.stderr
    assert "BRDC00WRD_U_20161580000_01D_MN.rnx.gz" in result.stderr and ":29" in result.stderr
    result = _run(
        CONFIG / "smartloc-gps-glonass.yaml", "-o", tmp_path, "--set", nav,
        "--set", "extra_nav_files=[]", "--set", "leap_seconds=17",
    )  # fmt: skip
    assert result.exit_code == 0, result.output


def test_a_glonass_channel_missing_is_bad_input(tmp_path):
    """R02 is observed; a GLONASS navigation file without its sets leaves its channel
    unknown (the observation file is RINEX 2.11: no SLOT / FRQ # header)."""
    lines = _lines(DATA / "brdc1580.16g.gz")
    k = next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1
    kept = lines[:k]
    for i in range(k, len(lines), 4):
        if int(lines[i][:2]) != 2:
            kept += lines[i : i + 4]
    path = tmp_path / "no-r02.16g"
    path.write_text("\n".join(kept) + "\n")
    out = tmp_path / "out"
    result = _run(
        CONFIG / "smartloc-gps-glonass.yaml", "-o", out, "--set", f"extra_nav_files=[{path}]"
    )
    assert result.exit_code == 2, result.output
    assert "GLONASS frequency channel missing for R02" in result.stderr
    assert "Berlin_Potsdamer_Platz.obs.gz" in result.stderr


def test_iono_free_drops_the_single_frequency_rows_instead_of_refusing(tmp_path):
    """ABPO with spp.ionosphere iono-free: the 46 C1-only rows are dropped and counted."""
    result = _run(CONFIG / "default.yaml", "-o", tmp_path, "--set", "spp.ionosphere=iono-free")
    assert result.exit_code == 0, result.output
    r = json.loads((tmp_path / "summary.json").read_text())["results"]
    assert r["single_frequency_rows_dropped"] == 46 and r["epochs_fault_excluded"] == 0
    assert r["err_3d_rms_m"] == pytest.approx(3.944, abs=2e-3)


# -- issue 31: systems asked and used, what is not read, impossible epochs, leap seconds --
def _v3(rinex2, tmp_path, edit=None):
    """The smartLoc file as RINEX 3.04 (30 epochs), its lines edited by ``edit``."""
    k = 30
    rows = slice(0, rinex2.start[k])
    codes = {s: (("C1C", "L1C", "S1C", "D1C"), rinex2.values[rows]) for s in "GR"}
    path = tmp_path / "o3.rnx"
    write_obs_v3(path, rinex2.week[:k], rinex2.time[:k], rinex2.start[: k + 1],
                 rinex2.prn[rows], codes)  # fmt: skip
    lines = path.read_text().splitlines()
    epochs = [i for i, line in enumerate(lines) if line.startswith(">")]
    if edit:
        edit(lines, epochs)
    path.write_text("\n".join(lines) + "\n")
    return path, epochs


def test_events_and_systems_not_asked_are_counted(rinex2, tmp_path):
    def edit(lines, epochs):
        lines[epochs[5]] = lines[epochs[5]][:31] + "5" + lines[epochs[5]][32:]  # event
        lines[epochs[7] + 1] = "X" + lines[epochs[7] + 1][1:]  # no RINEX system
        lines[epochs[7] + 2] = "S" + lines[epochs[7] + 2][1:]  # SBAS, not read

    path, _ = _v3(rinex2, tmp_path, edit)
    obs = read_obs(path, "G")
    n_glonass = int(np.count_nonzero(rinex2.prn[: rinex2.start[30]] // 100 == 1))
    assert obs.events == {5: 1}
    assert obs.skipped["unknown system 'X'"] == 1 and obs.skipped["S"] == 1
    assert obs.skipped["R"] >= n_glonass - 2 - (rinex2.start[6] - rinex2.start[5])
    assert len(obs.time) == 29


@pytest.mark.parametrize(
    ("edit", "match", "line"),
    [
        (lambda ln, ep: ln.__setitem__(ep[4], ln[ep[4]][:31] + "7" + ln[ep[4]][32:]),
         "epoch flag 7 is not a RINEX flag", 4),
        (lambda ln, ep: ln.__setitem__(ep[29], ln[ep[29]].replace("> 2016", "> 2026")),
         "3652 days after the epoch", 29),
        (lambda ln, ep: ln.__setitem__(ep[9], ln[ep[9]].replace(" 06 06 ", " 06 31 ")),
         "impossible day 31 of month 6", 9),
        (lambda ln, ep: ln.__setitem__(ep[3] + 1, "G" + "x1" + ln[ep[3] + 1][3:]),
         "unreadable satellite 'Gx1'", None),
    ],
)  # fmt: skip
def test_impossible_epochs_are_refused_at_their_line(rinex2, tmp_path, edit, match, line):
    path, epochs = _v3(rinex2, tmp_path, edit)
    with pytest.raises(InputError, match=match) as err:
        read_obs(path, "GR")
    if line is not None:
        assert err.value.line == epochs[line] + 1
    else:
        assert err.value.line is not None


def test_systems_g_on_a_mixed_file_with_glonass_navigation(tmp_path):
    """Formerly an internal error (the GPS-only observation file had no GLONASS channels):
    the smartLoc drive with GPS alone gives the figures the scenario's comment quotes for
    it (1,366 scored fixes, median 16.4 m, 95 % 67.7 m), so its GPS + GLONASS checks fail
    (exit 1)."""
    result = _run(CONFIG / "smartloc-gps-glonass.yaml", "-o", tmp_path, "--set", "systems=G")
    assert result.exit_code == 1, result.output
    report = (tmp_path / "import-flight.txt").read_text()
    assert "systems: asked G, used by the fixes G" in report
    counted = r"satellite records not read \(systems asked: G\): 10019 of GLONASS \(R\)"
    assert re.search(counted, report)
    r = json.loads((tmp_path / "summary.json").read_text())["results"]
    assert r["systems_used"] == 1 and r["epochs_scored"] == 1366
    assert r["err_h_median_m"] == pytest.approx(16.4, abs=0.05)
    assert r["err_h_p95_m"] == pytest.approx(67.7, abs=0.05)


def test_systems_asked_that_the_file_does_not_have_are_said(tmp_path):
    result = _run(
        CONFIG / "smartloc-gps-glonass.yaml", "-o", tmp_path, "--set", f"nav_file={MIXED}",
        "--set", "extra_nav_files=[]", "--set", "leap_seconds=17", "--set", "systems=GREC",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    report = (tmp_path / "import-flight.txt").read_text()
    assert "systems: asked GREC, used by the fixes GR" in report
    assert "no Galileo (E), BeiDou (C) observation in the file, solved with GR" in report
    assert "33 of SBAS (S)" in report  # S20, in the file, not read
    assert report.count("no Galileo (E), BeiDou (C) observation") == 2  # a warning too
    with h5py.File(tmp_path / "import-flight.h5") as f:
        assert f["spp"].attrs["systems_asked"] == "GREC"
        assert f["spp"].attrs["systems_used"] == "GR"


def test_leap_seconds_wrong_for_the_date_are_refused(tmp_path):
    lines = _rinex4(_lines(MIXED))
    k = next(i for i, line in enumerate(lines) if "LEAP SECONDS" in line)
    lines[k] = f"{'18':>6}{'':54}LEAP SECONDS"
    path = tmp_path / "mixed4.rnx"
    path.write_text("\n".join(lines) + "\n")
    nav = f"nav_file={path}"
    result = _run(CONFIG / "smartloc-gps-glonass.yaml", "-o", tmp_path / "a", "--set", nav,
                  "--set", "extra_nav_files=[]")  # fmt: skip
    assert result.exit_code == 2, result.output
    assert f"mixed4.rnx:{k + 1}: the header's LEAP SECONDS is 18 s" in result.stderr
    assert "GPS - UTC was 17 s on 2016-06-06" in result.stderr
    given = ("--set", f"nav_file={MIXED}", "--set", "extra_nav_files=[]")
    given += ("--set", "leap_seconds=18")
    result = _run(CONFIG / "smartloc-gps-glonass.yaml", "-o", tmp_path / "b", *given)
    assert result.exit_code == 2, result.output
    assert "leap_seconds: leap_seconds is 18 s, but GPS - UTC was 17 s" in result.stderr
