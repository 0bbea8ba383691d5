"""GNSS solution readers: RTKLIB .pos (lat/lon/height and ECEF) and a named-column CSV."""

import math

import numpy as np
import pytest

from inins.core import earth
from inins.exceptions import InputError
from inins.gnss import gpstime
from inins.io import solution_files as sf

HEAD = (
    "%  GPST            latitude(deg) longitude(deg) height(m) Q ns sdn(m) sde(m) sdu(m)"
    " sdne(m) sdeu(m) sdun(m) age(s) ratio vn(m/s) ve(m/s) vu(m/s) sdvn sdve sdvu sdvne"
    " sdveu sdvun\n"
)
ROW = (
    "2025/07/08 19:34:{s:06.3f} 40.0966268 -105.1474483 1601.4740000 {q} 21 0.0098995"
    " 0.0098995 0.0100000 0 0 0 0 0 0.0100000 -0.0020000 0.0090000 0.0586899 0.0586899"
    " 0.0586899 0 0 0\n"
)


def _pos(tmp_path, rows, head=HEAD):
    p = tmp_path / "sol.pos"
    p.write_text("% program : RTKPOST\n" + head + "".join(rows))
    return p


def test_rtklib_pos_lat_lon_height_with_velocity(tmp_path):
    p = _pos(tmp_path, [ROW.format(s=18.499, q=1), ROW.format(s=18.749, q=2)])
    sol = sf.read_rtklib_pos(p)
    week, sow = gpstime.from_calendar(2025, 7, 8, 19, 34, 18.499)
    assert sol.time[0] == pytest.approx(week * gpstime.WEEK + sow, abs=1e-6)
    assert sol.time[1] - sol.time[0] == pytest.approx(0.25, abs=1e-9)
    np.testing.assert_allclose(np.degrees(sol.lla[0, :2]), [40.0966268, -105.1474483])
    assert sol.lla[0, 2] == 1601.474
    np.testing.assert_allclose(sol.vel_ned[0], [0.01, -0.002, -0.009])  # vu up -> down
    np.testing.assert_allclose(sol.sigma_ned[0], [0.0098995, 0.0098995, 0.01])
    assert list(sol.q) == [1, 2]
    assert list(sol.line) == [3, 4]


def test_rtklib_pos_ecef_matches_llh(tmp_path):
    lla = np.array([[math.radians(40.1), math.radians(-105.1), 1600.0]])
    r = earth.ecef_from_llh(*lla[0])
    head = (
        "%  GPST x-ecef(m) y-ecef(m) z-ecef(m) Q ns sdx(m) sdy(m) sdz(m) sdxy(m) sdyz(m)"
        " sdzx(m) age(s) ratio\n"
    )
    rows = [
        f"2367 243258.{k}00 {r[0]:.4f} {r[1]:.4f} {r[2]:.4f} 1 12 0.01 0.02 0.03 0 0 0 0 0\n"
        for k in (0, 5)
    ]
    sol = sf.read_rtklib_pos(_pos(tmp_path, rows, head))
    assert sol.time[0] == pytest.approx(2367 * gpstime.WEEK + 243258.0)
    np.testing.assert_allclose(sol.lla[0, :2], lla[0, :2], atol=1e-10)
    assert sol.lla[0, 2] == pytest.approx(1600.0, abs=1e-3)
    # the NED variance sum equals the ECEF one (a rotation keeps the trace)
    assert np.sum(sol.sigma_ned[0] ** 2) == pytest.approx(0.01**2 + 0.02**2 + 0.03**2)
    assert np.all(np.isnan(sol.vel_ned))


def test_real_rtklib_file_reads():
    """The lc-drive RTK solution (see data README): 2,197 epochs at 4 Hz, 2,189 fixed."""
    from pathlib import Path

    path = Path(__file__).parents[2] / "data" / "lc-drive" / "gnss_1934_sf.pos.gz"
    if not path.exists():
        pytest.skip("lc-drive data not packaged")
    sol = sf.read_rtklib_pos(path)
    assert len(sol) == 2197
    assert int(np.sum(sol.q == 1)) == 2189
    assert np.median(np.diff(sol.time)) == pytest.approx(0.25, abs=1e-3)


@pytest.mark.parametrize(
    ("rows", "head", "match", "line"),
    [
        ([ROW.format(s=18.5, q=1), ROW.format(s=18.25, q=1)], HEAD, "does not increase", 4),
        (
            [ROW.format(s=18.5, q=1).replace("0.0098995", "0.0", 1), ROW.format(s=18.75, q=1)],
            HEAD,
            "sigma",
            3,
        ),
        ([ROW.format(s=18.5, q=1)], HEAD.replace("ratio", "colour"), "unknown column", 2),
        ([ROW.format(s=18.5, q=1)[:-10] + "\n"], HEAD, "fields", 3),
    ],
)
def test_rtklib_bad_input_names_the_line(tmp_path, rows, head, match, line):
    with pytest.raises(InputError, match=match) as info:
        sf.read_rtklib_pos(_pos(tmp_path, rows, head))
    assert info.value.line == line
    assert info.value.source.endswith("sol.pos")


def test_csv_with_named_columns(tmp_path):
    p = tmp_path / "sol.csv"
    p.write_text(
        "t_ms,phi,lam,alt,sn,se,sd,vn,ve,vd\n"
        "1000,40.0,-105.0,1600,0.1,0.1,0.2,1,2,3\n"
        "1250,40.0,-105.0,1600,0.1,0.1,0.2,1,2,3\n"
    )
    cols = dict(
        time="t_ms",
        lat="phi",
        lon="lam",
        height="alt",
        sigma_n="sn",
        sigma_e="se",
        sigma_d="sd",
        vel_n="vn",
        vel_e="ve",
        vel_d="vd",
    )
    sol = sf.read_solution_csv(p, cols, time_scale=1e-3, time_offset=100.0)
    np.testing.assert_allclose(sol.time, [101.0, 101.25])
    assert sol.lla[0, 0] == pytest.approx(math.radians(40.0))
    assert np.all(np.isnan(sol.vel_ned))  # velocity without sigma: not used
    with pytest.raises(InputError, match="not in the header") as info:
        sf.read_solution_csv(p, {**cols, "sigma_d": "sdd"})
    assert info.value.key == "columns.sigma_d"
    with pytest.raises(InputError, match="unknown role"):
        sf.read_solution_csv(p, {**cols, "colour": "sd"})
