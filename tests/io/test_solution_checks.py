"""One rule set for every solution epoch (inins.io.solution_checks): the same bad value
in a .pos line, a CSV line, a .mat row and a recorded-solution dataset row is refused
with the same message, naming the file and the line (or the row)."""

import math

import h5py
import numpy as np
import pytest
import scipy.io

from inins.exceptions import InputError
from inins.io import solution_files as sf
from inins.io import solution_layout
from inins.io.imu_files import ImuRates

# lat, lon, height, sigma n e d, velocity n e d, Q: a valid epoch
GOOD = [40.0966268, -105.1474483, 1601.474, 0.01, 0.01, 0.02, 0.5, -0.2, 0.1, 1]
FIELDS = ["lat", "lon", "height", "sn", "se", "sd", "vn", "ve", "vd", "q"]
BAD = [
    ("lat", 91.0, r"latitude 91 deg is not within ±90"),
    ("lat", math.nan, "latitude NaN deg"),
    ("lon", 400.0, r"longitude 400 deg is not within -180..360"),
    ("height", 1e9, r"height 1000000000 m is not within -1000..100000 m"),
    ("height", -1e6, r"height -1000000 m"),
    ("height", math.inf, "height infinity m"),
    ("sn", 1e30, r"position sigma must be > 0 and at most 10000 m: reads 1e\+30"),
    ("se", 0.0, "position sigma must be > 0"),
    ("vn", 1e6, r"velocity 1000000, .* beyond 10000 m/s"),
    ("q", 9.0, "quality flag 9 is not an integer 0-7"),
    ("q", 1.5, "quality flag 1.5 is not an integer"),
    ("q", -1.0, "quality flag -1"),
]
ROW = 3
"""The 0-based row made bad (of six)."""


def _table(field=None, value=None):
    rows = np.array([GOOD] * 6, float)
    rows[:, 0] += np.arange(6) * 1e-6
    if field is not None:
        rows[ROW, FIELDS.index(field)] = value
    return rows


def _pos(path, rows):
    head = (
        "%  GPST latitude(deg) longitude(deg) height(m) Q ns sdn(m) sde(m) sdu(m) sdne(m)"
        " sdeu(m) sdun(m) age(s) ratio vn(m/s) ve(m/s) vu(m/s) sdvn sdve sdvu sdvne sdveu"
        " sdvun\n"
    )
    text = "% a comment line\n" + head
    for k, r in enumerate(rows.tolist()):
        text += (
            f"2025/07/08 19:34:{18 + 0.25 * k:06.3f} {r[0]!r} {r[1]!r} {r[2]!r} {r[9]!r} 21 "
            f"{r[3]!r} {r[4]!r} {r[5]!r} 0 0 0 0 0 {r[6]!r} {r[7]!r} {-r[8]!r} 0.05 0.05 0.05"
            " 0 0 0\n"
        )
    path.write_text(text)
    return sf.read_rtklib_pos(path)


def _csv(path, rows):
    lines = ["t," + ",".join(FIELDS) + ",svn,sve,svd"]
    rows = rows.tolist()
    lines += [",".join(map(repr, [k * 0.25, *r, 0.05, 0.05, 0.05])) for k, r in enumerate(rows)]
    path.write_text("\n".join(lines) + "\n")
    cols = dict(time="t", lat="lat", lon="lon", height="height", sigma_n="sn", sigma_e="se",
                sigma_d="sd", vel_n="vn", vel_e="ve", vel_d="vd", sigma_vn="svn",
                sigma_ve="sve", sigma_vd="svd", q="q")  # fmt: skip
    return sf.read_solution_csv(path, cols)


def _mat(path, rows):
    a = np.column_stack([np.arange(len(rows)) * 0.25, rows])
    a[:, 1:3] = np.radians(a[:, 1:3])
    scipy.io.savemat(path, {"sol": a})
    cols = dict(time=0, lat=1, lon=2, height=3, sigma_n=4, sigma_e=5, sigma_d=6, vel_n=7,
                vel_e=8, vel_d=9, q=10)  # fmt: skip
    return sf.read_solution_mat(path, "sol", cols, "rad", sigma_vel=0.05)


def _recorded(path, rows):
    good = _pos(path.with_suffix(".pos"), _table())
    lla = np.column_stack([np.radians(rows[:, 0]), np.radians(rows[:, 1]), rows[:, 2]])
    sol = sf.SolutionFile(
        str(path), good.time, lla, rows[:, 3:6], rows[:, 6:9], good.sigma_vel, rows[:, 9],
        good.line,
    )  # fmt: skip
    t = np.arange(200) * 0.01
    imu = ImuRates("imu.csv", t, np.random.default_rng(0).normal(size=(200, 3)), np.ones((200, 3)))
    with h5py.File(path, "w") as f:
        for key, (value, _, _) in solution_layout.solution_arrays(sol, imu).items():
            f[key] = value
        for key, value in solution_layout.solution_attrs(sol, imu).items():
            f.attrs[key] = value
    return solution_layout.read_recorded_solution(path)


READERS = {
    ".pos": (_pos, lambda err: err.line == 3 + ROW and err.key is not None),
    ".csv": (_csv, lambda err: err.line == 2 + ROW),
    ".mat": (_mat, lambda err: err.message.startswith(f"row {ROW + 1}:") and err.key == "sol"),
    ".h5": (_recorded, lambda err: err.message.startswith(f"row {ROW}:")),
}


@pytest.mark.parametrize("suffix", sorted(READERS))
def test_a_valid_file_reads(tmp_path, suffix):
    read, _ = READERS[suffix]
    sol = read(tmp_path / f"sol{suffix}", _table())
    assert len(sol) == 6 and sol.q.dtype.kind == "i"
    np.testing.assert_allclose(np.degrees(sol.lla[ROW, 0]), GOOD[0] + ROW * 1e-6, atol=1e-9)


@pytest.mark.parametrize("suffix", sorted(READERS))
@pytest.mark.parametrize(("field", "value", "match"), BAD)
def test_the_same_rule_on_every_reader(tmp_path, suffix, field, value, match):
    read, where = READERS[suffix]
    path = tmp_path / f"sol{suffix}"
    with pytest.raises(InputError, match=match) as err:
        read(path, _table(field, value))
    assert err.value.source == str(path)
    assert where(err.value), str(err.value)


def test_time_duplicated_or_swapped_and_too_few_epochs(tmp_path):
    rows = _table()
    with pytest.raises(InputError, match="at least 2 needed"):
        _csv(tmp_path / "one.csv", rows[:1])
    path = tmp_path / "dup.csv"
    _csv(path, rows)
    lines = path.read_text().splitlines()
    lines[3] = lines[2]
    path.write_text("\n".join(lines) + "\n")
    cols = dict(time="t", lat="lat", lon="lon", height="height", sigma_n="sn", sigma_e="se",
                sigma_d="sd")  # fmt: skip
    with pytest.raises(InputError, match="duplicated or out of order") as err:
        sf.read_solution_csv(path, cols)
    assert err.value.line == 4


def test_ecef_rows_that_are_no_point_near_the_earth(tmp_path):
    path = tmp_path / "xyz.mat"
    a = np.zeros((4, 7))
    a[:, 0] = np.arange(4)
    a[:, 1:4] = [4.0e6, 3.0e6, 3.9e6]  # 6.3e6 m from the centre
    a[2, 1:4] = [172.0, 1.9, 0.6]  # geodetic numbers given ECEF roles
    a[:, 4:] = 0.1
    scipy.io.savemat(path, {"sol": a})
    cols = dict(time=0, x=1, y=2, z=3, sigma_n=4, sigma_e=5, sigma_d=6)
    with pytest.raises(InputError, match=r"row 3: ECEF position .* from the Earth's centre"):
        sf.read_solution_mat(path, "sol", cols)


@pytest.mark.parametrize(
    ("columns", "key", "match"),
    [
        ({"time": 0, "lat": 1, "lon": 2, "height": 3, "vel_n": 4}, "vel_e", "vel_e missing"),
        ({"lat": 1, "lon": 2, "height": 3}, "time", "time column is required"),
        ({"time": 0, "lat": 1, "lon": 2}, "height", "position columns incomplete"),
        ({"time": 0, "x": 1, "y": 2, "z": 3, "lat": 4, "lon": 5, "height": 6}, "x", "not both"),
        ({"time": 0, "lat": 1, "lon": 2, "height": 3, "colour": 4}, "colour", "unknown role"),
    ],
)
def test_column_roles_complete_or_refused(tmp_path, columns, key, match):
    path = tmp_path / "s.mat"
    scipy.io.savemat(path, {"sol": np.ones((3, 8))})
    with pytest.raises(InputError, match=match) as err:
        sf.read_solution_mat(path, "sol", columns, sigma=1.0)
    assert err.value.key == f"post.gnss.columns.{key}"
