"""Reading a reference trajectory (:mod:`inins.io.reference_files`): CSV with LLH or ECEF,
velocity and attitude columns, a .mat array, an RTKLIB .pos with its flags, each
against the values written; bad rows named by file, line and column."""

import math
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.io

from inins.core import earth
from inins.exceptions import InputError
from inins.io import reference_files as rf
from inins.io import solution_files as sf

LAT, LON, H = 45.0, 7.5, 300.0


def _csv(path, rows, header):
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _section(file, **kw):
    base = dict(
        file=file,
        format="csv",
        mat_variable="",
        columns={},
        angle_unit="deg",
        time_scale_s=1.0,
        time_system="gps",
        time_offset_s=0.0,
        lever_arm_m=(0.0, 0.0, 0.0),
        q_flags=None,
    )
    return SimpleNamespace(**(base | kw))


def test_csv_ecef_with_attitude_in_utc_and_an_offset(tmp_path):
    """ECEF rows of a point at 45 N 7.5 E 300 m read back within 1 mm of it; the tags
    in UTC on the GPS grid (``time_system`` utc, the leap seconds added later), scaled
    from ms and ``time_offset_s`` 2.5 s added; roll, pitch, heading deg -> rad."""
    xyz = earth.ecef_from_llh(math.radians(LAT), math.radians(LON), H)
    rows = [f"{1000 * t:.0f},{xyz[0]:.4f},{xyz[1]:.4f},{xyz[2]:.4f},1,-2,359" for t in (10, 11, 12)]
    path = _csv(tmp_path / "r.csv", rows, "t,x,y,z,r,p,y_deg")
    cols = dict(time="t", x="x", y="y", z="z", roll="r", pitch="p", heading="y_deg")
    ref = rf.read_reference(
        _section(path, columns=cols, time_scale_s=1e-3, time_system="utc", time_offset_s=2.5)
    )
    s = ref.solution
    np.testing.assert_allclose(s.time, [12.5, 13.5, 14.5])
    assert s.time_system == "utc"
    assert abs(s.lla[0, 0] - math.radians(LAT)) * 6.4e6 < 1e-3 and abs(s.lla[0, 2] - H) < 1e-3
    np.testing.assert_allclose(np.degrees(ref.euler[0]), [1.0, -2.0, 359.0])
    assert np.isnan(s.vel_ned).all()


def test_csv_velocity_up_is_kept_without_sigmas(tmp_path):
    """vel_u 0.5 m/s up is vel_d -0.5 m/s, kept although the file has no velocity sigma;
    heading alone leaves roll and pitch NaN."""
    rows = [f"{t},{LAT},{LON},{H},1,2,0.5,90" for t in (1, 2)]
    path = _csv(tmp_path / "r.csv", rows, "t,lat,lon,h,vn,ve,vu,hdg")
    cols = dict(time="t", lat="lat", lon="lon", height="h", vel_n="vn", vel_e="ve")
    ref = rf.read_reference(_section(path, columns=cols | {"vel_u": "vu", "heading": "hdg"}))
    np.testing.assert_allclose(ref.solution.vel_ned, [[1, 2, -0.5]] * 2)
    assert np.isnan(ref.euler[:, :2]).all() and ref.euler[0, 2] == pytest.approx(math.pi / 2)


@pytest.mark.parametrize(
    ("row", "expect"),
    [
        (f"3,{LAT},{LON},{H},95", ("r.csv", 4, "pitch 95 deg is not finite within ±90 deg")),
        (f"3,{LAT},{LON},nan,0", ("r.csv", 4, "height NaN m")),
        (f"1.5,{LAT},{LON},{H},0", ("r.csv", 4, "does not increase")),
    ],
)
def test_csv_bad_rows_name_file_and_line(tmp_path, row, expect):
    rows = [f"{t},{LAT},{LON},{H},0" for t in (1, 2)] + [row]
    path = _csv(tmp_path / "r.csv", rows, "t,lat,lon,h,p")
    cols = dict(time="t", lat="lat", lon="lon", height="h", pitch="p", roll="p2", heading="p3")
    cols = {k: v for k, v in cols.items() if k not in ("roll", "heading")}
    with pytest.raises(InputError) as e:
        rf.read_reference_csv(path, cols)
    assert str(e.value.source).endswith(expect[0]) and e.value.line == expect[1]
    assert expect[2] in e.value.message


def test_mat_rows_and_attitude(tmp_path):
    """A .mat array: time (ms), lat/lon rad, height, heading rad; a heading beyond 360
    deg is refused naming the 1-based row."""
    a = np.array([[0.0, 0.8, 0.1, 10.0, 0.2], [1000.0, 0.8, 0.1, 10.0, 0.3]])
    path = tmp_path / "r.mat"
    scipy.io.savemat(path, {"ref": a})
    cols = dict(time=0, lat=1, lon=2, height=3, heading=4)
    ref = rf.read_reference(
        _section(path, format="mat", mat_variable="ref", columns=cols, angle_unit="rad",
                 time_scale_s=1e-3)
    )  # fmt: skip
    np.testing.assert_allclose(ref.solution.time, [0.0, 1.0])
    np.testing.assert_allclose(ref.euler[:, 2], [0.2, 0.3])
    a[1, 4] = 7.0
    scipy.io.savemat(path, {"ref": a})
    with pytest.raises(InputError, match=r"heading 401\.07 deg is not finite"):
        rf.read_reference_mat(path, "ref", cols, "rad", 1e-3)


_HEAD = "%  GPST latitude(deg) longitude(deg) height(m) Q ns sdn(m) sde(m) sdu(m) sdne(m) sdeu(m)"
POS = "\n".join(
    ["% program : test", _HEAD + " sdun(m) age(s) ratio"]
    + [
        f"2024/07/08 19:34:0{k}.000 {45 + 1e-5 * k:.9f} 7.5 300.0 {q} 20 0.01 0.01 0.02 0 0 0 0 9.9"
        for k, q in enumerate((1, 2, 1, 1))
    ]
)


def test_rtklib_pos_with_its_flags(tmp_path):
    """An RTKLIB .pos: every epoch by default, the fixed ones (Q 1) with ``q_flags``
    [1]; too few epochs of the flags is bad input naming the key."""
    path = tmp_path / "r.pos"
    path.write_text(POS)
    assert len(rf.read_reference(_section(path, format="rtklib")).solution) == 4
    ref = rf.read_reference(_section(path, format="rtklib", q_flags=[1], time_offset_s=-1.0))
    first = sf.read_rtklib_pos(path).time[0]
    np.testing.assert_allclose(ref.solution.time - first, [-1.0, 1.0, 2.0])
    with pytest.raises(InputError) as e:
        rf.read_reference(_section(path, format="rtklib", q_flags=[5]))
    assert e.value.key == "post.reference.q_flags"
