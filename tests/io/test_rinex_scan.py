"""The two readers of a RINEX observation body: the array scan of
:mod:`inins.io.rinex_scan` (the fast path) and the line reader of
:mod:`inins.io.rinex_obs` it falls back to. On the shipped files the fast path is
taken; on mutated RINEX 2 and 3 files (fields, characters, lines duplicated, swapped,
cut or deleted, junk, truncation) ``read_obs`` returns exactly what the line reader
returns, or refuses with the same message and line; and the table reading of the
14-column values equals numpy's conversion of the text for any characters."""

import gzip
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from inins.exceptions import InputError
from inins.io import rinex_obs, rinex_scan
from inins.io.rinex_obs import read_obs, write_obs_v3
from tests.cli.test_fuzz_readers import SETTINGS, _mutate_text, text_edit

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"
BERLIN = DATA / "smartloc" / "Berlin_Potsdamer_Platz.obs.gz"


def _line_reader(path, systems):
    """``read_obs`` with the fast path switched off."""
    saved = rinex_scan.scan
    rinex_scan.scan = lambda *args: None
    try:
        return read_obs(path, systems)
    finally:
        rinex_scan.scan = saved


def _outcome(read, path, systems):
    try:
        return read(path, systems)
    except InputError as exc:
        return ("refused", str(exc), exc.line)


def _same(a, b):
    if isinstance(a, tuple) or isinstance(b, tuple):
        assert a == b
        return
    for key, x in vars(a).items():
        y = getattr(b, key)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, key
            assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), key
            if x.dtype.kind == "f":
                assert np.array_equal(np.signbit(x), np.signbit(y)), key
        elif isinstance(x, float) and np.isnan(x):
            assert np.isnan(y), key
        else:
            assert x == y, key


@pytest.mark.parametrize(
    ("path", "systems"), [(DATA / "abpo0080.15o.gz", "G"), (BERLIN, "GR"), (BERLIN, "R")]
)
def test_the_shipped_files_take_the_fast_path_and_read_the_same(path, systems, monkeypatch):
    calls = []
    scan = rinex_scan.scan
    monkeypatch.setattr(rinex_scan, "scan", lambda *a: calls.append(scan(*a)) or calls[-1])
    fast = read_obs(path, systems)
    assert calls and calls[0] is not None
    monkeypatch.undo()
    _same(fast, _line_reader(path, systems))


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A RINEX 2.11 file (the ABPO header and 40 epochs) and a RINEX 3.04 file (30
    epochs of the Berlin drive, GPS and GLONASS, with a Galileo record per epoch)."""
    out = tmp_path_factory.mktemp("scan")
    text = gzip.decompress((DATA / "abpo0080.15o.gz").read_bytes()).decode().splitlines()
    end = next(i for i, line in enumerate(text) if "END OF HEADER" in line) + 1
    epochs = [i for i in range(end, len(text)) if rinex_obs._V2_EPOCH.match(text[i])]
    body_end = epochs[40]  # 40 epochs
    v2 = out / "a.15o"
    v2.write_text("\n".join(text[:body_end]) + "\n")
    berlin = read_obs(BERLIN, "GR")
    k = 30
    rows = slice(0, berlin.start[k])
    prn = berlin.prn[rows].copy()
    prn[berlin.start[:k]] = 201  # the first record of each epoch becomes Galileo E01
    codes = {s: (("C1C", "L1C", "S1C", "D1C"), berlin.values[rows]) for s in "GRE"}
    v3 = out / "o.rnx"
    write_obs_v3(v3, berlin.week[:k], berlin.time[:k], berlin.start[: k + 1], prn, codes)
    return {"v2": (v2, end), "v3": (v3, None)}


@SETTINGS
@given(
    version=st.sampled_from(["v2", "v3"]),
    systems=st.sampled_from(["G", "GR", "R"]),
    edits=st.lists(text_edit(), max_size=2),
    fixed=st.booleans(),
)
def test_fast_and_line_readers_agree_on_mutated_files(small, tmp_path_factory, version, systems,
                                                      edits, fixed):  # fmt: skip
    source, first = small[version]
    path = tmp_path_factory.mktemp("m") / source.name
    path.write_bytes(source.read_bytes())
    if first is None:
        first = next(i for i, t in enumerate(path.read_text().splitlines()) if "END OF" in t) + 1
    for edit in edits:
        _mutate_text(path, edit, first, "fixed" if fixed else None)
    _same(_outcome(read_obs, path, systems), _outcome(_line_reader, path, systems))


def test_blocks_split_anywhere_read_the_same(small, monkeypatch):
    """Epochs cut by the end of a block of bytes are carried into the next block."""
    for path, _ in small.values():
        whole = read_obs(path, "GR")
        for size in (4097, 5000, 9999):
            monkeypatch.setattr(rinex_scan.textlines, "CHUNK", size)
            _same(read_obs(path, "GR"), whole)


ALPHABET = " 0123456789.-+eEnaN\t"


@SETTINGS
@given(fields=st.lists(st.text(ALPHABET, min_size=14, max_size=14), min_size=1, max_size=40))
def test_table_reading_of_values_equals_numpy_conversion(fields):
    raw = np.frombuffer("".join(fields).encode(), np.uint8).reshape(-1, 1, 14)
    blank = (raw == 32).all(axis=2)
    text = raw.copy()
    text[blank] = np.frombuffer(b"           nan", np.uint8)
    try:
        expected = text.view("S14")[..., 0].astype(float)
    except ValueError:
        with pytest.raises(rinex_scan.Fallback):
            rinex_scan._values(raw)
        return
    got = rinex_scan._values(raw)
    assert np.array_equal(got, expected, equal_nan=True)
    assert np.array_equal(np.signbit(got), np.signbit(expected))


def test_written_values_read_exactly():
    """Every value a writer prints with ``%14.3f`` reads back as ``float`` reads it."""
    rng = np.random.default_rng(1)
    v = np.concatenate([rng.uniform(-1e9, 1e10, 20000), rng.uniform(-1, 1, 2000), [0.0, -0.0]])
    text = np.char.mod("%14.3f", v).astype("S14")
    raw = np.frombuffer(b"".join(text.tolist()), np.uint8).reshape(-1, 1, 14)
    assert np.array_equal(rinex_scan._values(raw)[:, 0], text.astype(float))
