"""Property tests of every reader of the newest paths (issue 31): a valid file of each
kind (RTKLIB .pos, CSV solution, .mat solution and IMU increments, IMU CSV, the
recorded-solution layout, RINEX 3 observations, RINEX 3 and 4 navigation) is mutated
(a field made NaN, infinite, out of range or of the wrong type, a line duplicated,
swapped, cut, removed, or junk inserted, the file truncated) and read again.

Each read either refuses with :class:`InputError` naming the file and the line (text),
row (arrays) or key it is about, or returns data that meets the same rules again; the
commands on mutated files end with exit 0, 1 or 2 only, every exit 2 naming the file
and its line, and import-flight never writes what run-ekf's readers refuse.

``make test`` runs :data:`EXAMPLES` examples of each, derandomized; ``make fuzz`` sets
``ININS_FUZZ_EXAMPLES`` for more, with a random seed (as tests/cli/test_fuzz.py).
"""

import gzip
import math
import os
import re
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from inins.cli._runner import guarded
from inins.commands import find_command
from inins.commands.execute import execute
from inins.exceptions import InputError
from inins.io import solution_checks, solution_layout
from inins.io import solution_files as sf
from inins.io.rinex_nav import read_navigation
from inins.io.rinex_obs import read_obs, write_obs_v3

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"
EXAMPLES = max(1, int(os.environ.get("ININS_FUZZ_EXAMPLES", "150")) // 5)
"""Examples of each reader test: 30 in ``make test``."""
SETTINGS = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize="ININS_FUZZ_EXAMPLES" not in os.environ,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
CLI_SETTINGS = settings(SETTINGS, max_examples=max(1, EXAMPLES // 3))
TOKENS = [
    "nan", "inf", "-inf", "NaN", "1e9", "-1e9", "91", "400", "1e30", "-5", "0", "1.5", "9",
    "abc", "", "1.5.5", "0x10", "1e400", "-0.0", "99999999999999999999",
]  # fmt: skip


def _lines(path):
    data = path.read_bytes()
    if data[:2] == b"\x1f\x8b":
        data = gzip.decompress(data)
    return data.decode("ascii").splitlines()


# -- the valid files -------------------------------------------------------------------
@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Small valid files of every kind (cut from the packaged data)."""
    out = tmp_path_factory.mktemp("valid")
    pos = _lines(DATA / "lc-drive" / "gnss_1934_sf.pos.gz")
    head = [i for i, line in enumerate(pos) if line.startswith("%")][-1] + 1
    made = {"pos": out / "sol.pos"}
    made["pos"].write_text("\n".join(pos[: head + 240]) + "\n")
    rows = ["t,lat,lon,h,sn,se,sd,q"]
    for line in pos[head : head + 240]:
        p = line.split()
        hh, mm, ss = p[1].split(":")
        t = int(hh) * 3600 + int(mm) * 60 + float(ss)
        rows.append(",".join([f"{t:.3f}", p[2], p[3], p[4], p[7], p[8], p[9], p[5]]))
    made["csv"] = out / "sol.csv"
    made["csv"].write_text("\n".join(rows) + "\n")
    imu = _lines(DATA / "lc-drive" / "imu_1934.csv.gz")
    made["imu"] = out / "imu.csv"
    made["imu"].write_text("\n".join(imu[:3000]) + "\n")
    fog = scipy.io.loadmat(DATA / "transfer_align_fog_mems.mat")
    made["mat"] = out / "f.mat"
    scipy.io.savemat(made["mat"], {"mimu": fog["mimu"][:2000], "fogavp": fog["fogavp"][:200]})
    made["recorded"] = out / "rec.h5"
    _write_recorded(made["recorded"], made["pos"], made["imu"])
    obs = read_obs(DATA / "smartloc" / "Berlin_Potsdamer_Platz.obs.gz", "GR")
    k = 30
    rows_k = slice(0, obs.start[k])
    codes = {s: (("C1C", "L1C", "S1C", "D1C"), obs.values[rows_k]) for s in "GR"}
    made["obs3"] = out / "o.rnx"
    write_obs_v3(made["obs3"], obs.week[:k], obs.time[:k], obs.start[: k + 1],
                 obs.prn[rows_k], codes)  # fmt: skip
    nav3 = _lines(DATA / "smartloc" / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz")
    end = next(i for i, line in enumerate(nav3) if "END OF HEADER" in line) + 1
    made["nav3"] = out / "n3.rnx"
    made["nav3"].write_text("\n".join(nav3[: end + 400]) + "\n")
    made["nav4"] = out / "n4.rnx"
    made["nav4"].write_text("\n".join(_rinex4(nav3, end, 60)) + "\n")
    return made


def _write_recorded(path, pos, imu):
    sol = sf.read_rtklib_pos(pos)
    rates = sf.read_imu_rates_csv(pos.with_name("imu.csv"), *_IMU_ARGS)
    with h5py.File(path, "w") as f:
        for key, (value, _, _) in solution_layout.solution_arrays(sol, rates).items():
            f[key] = value
        for key, value in solution_layout.solution_attrs(sol, rates).items():
            f.attrs[key] = value


_IMU_ARGS = ((0, 1, 2), (3, 4, 5), 6, 1e-3, "g", "dps", ("-x", "y", "-z"))


def _rinex4(lines, end, records):
    """The mixed RINEX 3.03 navigation lines as RINEX 4.00 message records."""
    head = [lines[0].replace("     3.03", "     4.00"), *lines[1 : end - 1]]
    head += [f"{'17':>6}{'':54}LEAP SECONDS", lines[end - 1]]
    out, i = [], end
    counts = {"G": 8, "E": 8, "C": 8, "R": 4}
    while i < len(lines) and records:
        letter = lines[i][0]
        n = counts[letter]
        message = {"G": "LNAV", "C": "D1", "R": "FDMA", "E": "INAV"}[letter]
        out.append(f"> EPH {lines[i][:3]} {message}")
        out += lines[i : i + n]
        if letter == "R":
            out.append("     0.000000000000e+00 0.000000000000e+00 0.000000000000e+00")
        i += n
        records -= 1
    return head + out


# -- mutations ---------------------------------------------------------------------------
@st.composite
def text_edit(draw):
    how = draw(
        st.sampled_from(
            [
                "field",
                "field",
                "field",
                "chars",
                "duplicate",
                "swap",
                "cut-line",
                "delete",
                "junk",
                "truncate",
                "long-line",
            ]
        )
    )
    return (
        how,
        draw(st.integers(0, 10**6)),
        draw(st.integers(0, 10**6)),
        draw(st.sampled_from(TOKENS)),
    )


def _mutate_text(path, edit, first, sep):
    """Apply a text edit to the lines of ``path`` from line ``first`` (0-based) on;
    fields split at ``sep`` (None: whitespace; "fixed": 16-column RINEX fields)."""
    how, a, b, token = edit
    lines = path.read_text().splitlines()
    data = range(first, len(lines))
    if not data:
        return
    i = data[a % len(data)]
    line = lines[i]
    if how == "field":
        if sep == "fixed":
            start = 3 + 16 * (b % max(1, (len(line) - 3) // 16))
            lines[i] = line[:start] + f"{token:>14.14}" + line[start + 14 :]
        else:
            parts = line.split(sep) or [""]
            parts[b % len(parts)] = token
            lines[i] = (sep or " ").join(parts)
    elif how == "chars":
        j = b % max(1, len(line))
        lines[i] = line[:j] + token[:3] + line[j + 3 :]
    elif how == "duplicate":
        lines.insert(i, line)
    elif how == "swap" and i + 1 < len(lines):
        lines[i], lines[i + 1] = lines[i + 1], lines[i]
    elif how == "cut-line":
        lines[i] = line[: b % max(1, len(line))]
    elif how == "delete":
        del lines[i]
    elif how == "junk":
        lines.insert(i, "".join(chr(33 + (b * 7 + k * 13) % 90) for k in range(60)))
    elif how == "long-line":
        lines.insert(i, "1," * 5000)
    text = "\n".join(lines) + "\n"
    if how == "truncate":
        text = text[: len(text) * (b % 100) // 100]
    path.write_text(text)


def _copy(files, key, tmp_path_factory):
    path = tmp_path_factory.mktemp("fz") / files[key].name
    path.write_bytes(files[key].read_bytes())
    return path


def _named(exc, path):
    """An InputError names its file and a line, a row or a key."""
    text = str(exc)
    assert path.name in text, text
    assert exc.line is not None or "row " in exc.message or exc.key, text


def _header_end(path, marker):
    lines = path.read_text().splitlines()
    return next((i + 1 for i, line in enumerate(lines) if marker(line)), 0)


def _solution_meets_the_rules(sol, path):
    rows = solution_checks.RowNames(path, line=sol.line)
    solution_checks.check_rows(sol, rows)  # what was accepted passes the rules again
    assert sol.q.dtype.kind == "i"


# -- the reader tests --------------------------------------------------------------------
@SETTINGS
@given(edits=st.lists(text_edit(), min_size=1, max_size=2))
def test_pos_reader(files, tmp_path_factory, edits):
    path = _copy(files, "pos", tmp_path_factory)
    first = _header_end(path, lambda line: line.startswith("%  GPST"))
    for edit in edits:
        _mutate_text(path, edit, first, None)
    try:
        sol = sf.read_rtklib_pos(path)
    except InputError as exc:
        _named(exc, path)
        return
    _solution_meets_the_rules(sol, path)


CSV_COLUMNS = dict(time="t", lat="lat", lon="lon", height="h", sigma_n="sn", sigma_e="se",
                   sigma_d="sd", q="q")  # fmt: skip


@SETTINGS
@given(edits=st.lists(text_edit(), min_size=1, max_size=2))
def test_csv_solution_reader(files, tmp_path_factory, edits):
    path = _copy(files, "csv", tmp_path_factory)
    for edit in edits:
        _mutate_text(path, edit, 1, ",")
    try:
        sol = sf.read_solution_csv(path, CSV_COLUMNS)
    except InputError as exc:
        _named(exc, path)
        return
    _solution_meets_the_rules(sol, path)


@SETTINGS
@given(edits=st.lists(text_edit(), min_size=1, max_size=2))
def test_imu_csv_reader(files, tmp_path_factory, edits):
    path = _copy(files, "imu", tmp_path_factory)
    for edit in edits:
        _mutate_text(path, edit, 0, ",")
    try:
        imu = sf.read_imu_rates_csv(path, *_IMU_ARGS)
    except InputError as exc:
        _named(exc, path)
        return
    assert np.isfinite(imu.gyro).all() and np.isfinite(imu.accel).all()
    step = np.diff(imu.time)
    assert (step > 0).all() and step.max() <= max(2.5 * np.median(step), 0.1)


MAT_VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([math.nan, math.inf, -math.inf, 1e30, -1e9, 91.0, 7.0, 0.0, -1.0]),
)


@SETTINGS
@given(
    variable=st.sampled_from(["fogavp", "mimu"]),
    how=st.sampled_from(["value", "value", "rows", "columns", "complex", "text", "shape"]),
    row=st.integers(0, 10**6),
    col=st.integers(0, 20),
    value=MAT_VALUES,
)
def test_mat_readers(files, tmp_path_factory, variable, how, row, col, value):
    path = _copy(files, "mat", tmp_path_factory)
    m = scipy.io.loadmat(path)
    a = m[variable].copy()
    if how == "value":
        a[row % a.shape[0], col % a.shape[1]] = value
    elif how == "rows":
        a = a[: row % 4]
    elif how == "columns":
        a = a[:, : col % a.shape[1]]
    elif how == "complex":
        a = a + 1e-6j
    elif how == "text":
        a = np.array(["x" * (col + 1)])
    else:
        a = a.reshape(-1)
    m[variable] = a
    scipy.io.savemat(path, {k: v for k, v in m.items() if not k.startswith("__")})
    try:
        sol = sf.read_solution_mat(
            path, "fogavp", dict(time=9, lat=6, lon=7, height=8, vel_e=3, vel_n=4, vel_u=5),
            "rad", 0.05, 0.02,
        )  # fmt: skip
        imu = sf.read_imu_increments_mat(path, "mimu", (0, 1, 2), (3, 4, 5), 6, ("y", "x", "-z"))
    except InputError as exc:
        _named(exc, path)
        return
    _solution_meets_the_rules(sol, path)
    assert np.isfinite(imu.gyro).all() and (np.diff(imu.time) > 0).all()


@SETTINGS
@given(
    key=st.sampled_from(
        [
            "solution/time",
            "solution/lla",
            "solution/sigma_ned",
            "solution/vel_ned",
            "solution/sigma_vel",
            "solution/q",
            "solution/line",
            "imu/time",
            "imu/gyro",
            "imu/accel",
        ]
    ),
    how=st.sampled_from(["value", "value", "rows", "delete", "dtype", "transpose", "swap"]),
    row=st.integers(0, 10**6),
    value=MAT_VALUES,
)
def test_recorded_solution_reader(files, tmp_path_factory, key, how, row, value):
    path = _copy(files, "recorded", tmp_path_factory)
    with h5py.File(path, "r+") as f:
        old = f[key][()]
        new = old.astype(float)
        if how == "value":
            new.reshape(-1)[row % new.size] = value
        elif how == "rows":
            new = new[: row % len(new)]
        elif how == "dtype":
            new = old.astype("S8")
        elif how == "transpose":
            new = new.T
        elif how == "swap":
            i = row % (len(new) - 1)
            new[[i, i + 1]] = new[[i + 1, i]]
        del f[key]
        if how != "delete":
            f[key] = new
    try:
        sol = solution_layout.read_recorded_solution(path)
        imu = solution_layout.read_recorded_imu(path)
    except InputError as exc:
        _named(exc, path)
        return
    _solution_meets_the_rules(sol, path)
    assert np.isfinite(imu.accel).all() and (np.diff(imu.time) > 0).all()


@SETTINGS
@given(edits=st.lists(text_edit(), min_size=1, max_size=2))
def test_rinex3_observation_reader(files, tmp_path_factory, edits):
    path = _copy(files, "obs3", tmp_path_factory)
    first = _header_end(path, lambda line: "END OF HEADER" in line)
    for edit in edits:
        _mutate_text(path, edit, first, "fixed")
    try:
        obs = read_obs(path, "GR")
    except InputError as exc:
        _named(exc, path)
        return
    t = obs.week * 604800.0 + obs.time
    assert np.isfinite(t).all() and (np.diff(t) > 0).all()
    assert (np.diff(obs.start) >= 0).all() and obs.start[-1] == len(obs.prn)
    assert np.isin(obs.prn // 100, [0, 1]).all()


@SETTINGS
@given(version=st.sampled_from(["nav3", "nav4"]), edits=st.lists(text_edit(), max_size=2))
def test_rinex_navigation_reader(files, tmp_path_factory, version, edits):
    path = _copy(files, version, tmp_path_factory)
    first = _header_end(path, lambda line: "END OF HEADER" in line)
    for edit in edits:
        _mutate_text(path, edit, first, None)
    try:
        nav = read_navigation(path, leap_seconds=17)
    except InputError as exc:
        _named(exc, path)
        return
    assert len(nav.records) + len(nav.glonass) > 0


# -- the commands on mutated files -------------------------------------------------------
def _exit(command, scenario, outdir):
    def body():
        done = execute(find_command(command), scenario, (), None, outdir)
        return 0 if done.summary["passed"] else 1

    return guarded(f"inins {command}", False, body)


IMPORT = """format: solution
solution_imu:
  file: {imu}
  accel_columns: [0, 1, 2]
  gyro_columns: [3, 4, 5]
  time_column: 6
  time_scale_s: 0.001
  accel_unit: g
  gyro_unit: dps
  axes: [-x, y, -z]
solution_gnss: {{file: {pos}, format: rtklib}}
"""


@CLI_SETTINGS
@given(which=st.sampled_from(["pos", "imu"]), edits=st.lists(text_edit(), min_size=1, max_size=2))
def test_import_flight_never_writes_what_run_ekf_refuses(
    files, tmp_path_factory, capsys, which, edits
):
    folder = tmp_path_factory.mktemp("fzcli")
    paths = {k: folder / files[k].name for k in ("pos", "imu")}
    for k, p in paths.items():
        p.write_bytes(files[k].read_bytes())
    first = (
        _header_end(paths["pos"], lambda line: line.startswith("%  GPST")) if which == "pos" else 0
    )
    for edit in edits:
        _mutate_text(paths[which], edit, first, None if which == "pos" else ",")
    scenario = folder / "s.yaml"
    scenario.write_text(IMPORT.format(imu=paths["imu"], pos=paths["pos"]))
    code = _exit("import-flight", scenario, folder / "out")
    err = capsys.readouterr().err
    assert code in (0, 1, 2), err
    if code == 2:
        assert re.search(rf"{re.escape(paths[which].name)}(:\d+|: [\w/.]+:)", err), err
        return
    h5 = folder / "out" / "import-flight.h5"
    solution_layout.read_recorded_solution(h5)  # run-ekf's readers take what was written
    solution_layout.read_recorded_imu(h5)


@CLI_SETTINGS
@given(edits=st.lists(text_edit(), min_size=1, max_size=2))
def test_import_flight_on_mutated_rinex(files, tmp_path_factory, capsys, edits):
    folder = tmp_path_factory.mktemp("fzrnx")
    obs = folder / "o.rnx"
    obs.write_bytes(files["obs3"].read_bytes())
    first = _header_end(obs, lambda line: "END OF HEADER" in line)
    for edit in edits:
        _mutate_text(obs, edit, first, "fixed")
    smart = DATA / "smartloc"
    scenario = folder / "s.yaml"
    scenario.write_text(
        f"format: rinex\nobs_file: {obs}\nnav_file: {smart / 'brdc1580.16n.gz'}\n"
        f"extra_nav_files: [{smart / 'brdc1580.16g.gz'}]\nsystems: GR\n"
    )
    code = _exit("import-flight", scenario, folder / "out")
    err = capsys.readouterr().err
    assert code in (0, 1, 2), err
    if code == 2:
        assert re.search(r"o\.rnx(:\d+|: [\w/.]+:)", err), err
