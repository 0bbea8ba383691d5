"""The HDF5 results writer, attribute encoding, readers and the streaming sink."""

import json
import threading
import time

import h5py
import numpy as np
import pytest

from inins.exceptions import InputError
from inins.io.atomic import AtomicFile
from inins.io.hdf5 import (
    CHUNK_BYTES,
    LONG_ROWS,
    ResultsWriter,
    encode_attrs,
    list_datasets,
    open_results,
    read_provenance,
    read_summary,
    storage_options,
)
from inins.io.hdf5_sink import H5SeriesSink
from inins.results import CommandResult, Series


def _result(n=100):
    return CommandResult(
        command="demo",
        results={"x_dph": 1.0},
        datasets={
            "a/short": Series(np.ones((n, 3)), "rad", "b", "short series"),
            "a/long": Series(np.arange((LONG_ROWS + 1) * 3.0).reshape(-1, 3), "m/s", "n"),
            "counts": Series(np.arange(20_000, dtype=np.int32), "count"),
            "labels": Series(np.array(["a", "bé"]), "1"),
            "kinds": Series(np.array(["hold", "rotate"], dtype="S8"), "1"),
            "scalar": Series(np.float64(3.5), "s"),
        },
        attrs={
            "a": {"k_s": 2.0, "nested": {"v": [1, 2]}, "none": None, "names": ["x", "y"]},
            "": {"method": "eq44"},
        },
    )


def test_storage_options():
    assert storage_options((3,), np.float64, LONG_ROWS) == {}
    opts = storage_options((3,), np.float64, 1_000_000)
    assert opts["compression"] == "gzip" and opts["compression_opts"] == 1 and opts["shuffle"]
    assert opts["chunks"] == (CHUNK_BYTES // 24, 3)
    assert storage_options((6,), np.int32, 7_200_000)["shuffle"] is False
    assert storage_options((3,), np.float64, None)["chunks"][0] == CHUNK_BYTES // 24
    assert storage_options((2,), np.float64, 12_000)["chunks"] == (12_000, 2)


def test_encode_attrs():
    enc = encode_attrs(
        {
            "a": 1,
            "d": {"e": {"f": "x"}},
            "l": [1.0, 2.0],
            "s": ["p", "q"],
            "n": None,
            "m": [{"k": 1}],
            "r": [[1], [1, 2]],
            "np": np.float32(1.5),
            "arr": np.zeros(2),
        }
    )
    assert enc["a"] == 1 and enc["d.e.f"] == "x"
    assert enc["l"].dtype == float and list(enc["s"]) == ["p", "q"]
    assert json.loads(enc["n"]) is None and json.loads(enc["m"]) == [{"k": 1}]
    assert json.loads(enc["r"]) == [[1], [1, 2]]


def test_write_result(tmp_path):
    path = tmp_path / "demo.h5"
    with ResultsWriter(path) as w:
        w.set_attrs("", {"command": "demo", "summary_json": json.dumps({"passed": True})})
        w.write_result(_result())
    assert not list(tmp_path.glob(".*partial*"))
    with h5py.File(path) as f:
        short, long = f["a/short"], f["a/long"]
        assert short.chunks is None and short.compression is None
        assert (short.attrs["units"], short.attrs["frame"]) == ("rad", "b")
        assert short.attrs["description"] == "short series"
        assert long.compression == "gzip" and long.shuffle and long.chunks[1] == 3
        assert f["counts"].compression == "gzip" and not f["counts"].shuffle
        assert [s.decode() for s in f["labels"][()]] == ["a", "bé"]
        assert list(f["kinds"][()]) == [b"hold", b"rotate"]
        assert f["scalar"][()] == 3.5
        assert f["a"].attrs["k_s"] == 2.0 and list(f["a"].attrs["nested.v"]) == [1, 2]
        assert f.attrs["method"] == "eq44"
    assert read_summary(path) == {"passed": True}
    assert read_provenance(path)["command"] == "demo"
    listing = {d["path"]: d for d in list_datasets(path)}
    assert listing["a/short"]["shape"] == (100, 3) and listing["a/long"]["units"] == "m/s"


def test_write_result_rejects_reserved_root_attrs(tmp_path):
    result = CommandResult("demo", {}, attrs={"": {"seed": 1}})
    with pytest.raises(ValueError, match="reserved"), ResultsWriter(tmp_path / "r.h5") as w:
        w.write_result(result)
    assert list(tmp_path.iterdir()) == []


def test_unstorable_dataset(tmp_path):
    with pytest.raises(TypeError, match="cannot store"), ResultsWriter(tmp_path / "r.h5") as w:
        w.write_series("x", Series(np.array([{"a": 1}]), "1"))
    assert list(tmp_path.iterdir()) == []


def test_dataset_written_twice(tmp_path):
    with pytest.raises(ValueError, match="written twice"), ResultsWriter(tmp_path / "r.h5") as w:
        w.write_series("x", Series(np.ones(2), "m"))
        w.write_series("x", Series(np.ones(2), "m"))


def test_abort_keeps_previous_file(tmp_path):
    path = tmp_path / "demo.h5"
    with ResultsWriter(path) as w:
        w.set_attrs("", {"version": 1})
    before = path.read_bytes()
    with pytest.raises(RuntimeError), ResultsWriter(path) as w:
        w.set_attrs("", {"version": 2})
        w.write_result(_result())
        raise RuntimeError("mid-write")
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.h5"]


def test_writer_on_atomic_file_does_not_commit(tmp_path):
    target = AtomicFile(tmp_path / "x.h5")
    with ResultsWriter(target) as w:
        w.set_attrs("", {"a": 1})
    assert target.tmp.exists() and not target.path.exists()
    target.commit()
    assert target.path.exists() and not target.tmp.exists()


def test_readers_reject_bad_files(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        open_results(tmp_path / "none.h5")
    (tmp_path / "t.h5").write_text("text")
    with pytest.raises(InputError, match="cannot read as HDF5"):
        read_summary(tmp_path / "t.h5")
    with h5py.File(tmp_path / "plain.h5", "w"):
        pass
    with pytest.raises(InputError, match="not an inins results file"):
        read_summary(tmp_path / "plain.h5")


def _stream(sink, n, block, seed=0):
    rng = np.random.default_rng(seed)
    data = rng.normal(size=(n, 3))
    sink.create("imu/x", (3,), np.float64, "rad", "b", "rates", attrs={"dt_s": 0.01})
    sink.create("imu/k", (), np.int32, "count")
    for k0 in range(0, n, block):
        rows = data[k0 : k0 + block].copy()
        sink.append("imu/x", rows)
        rows[:] = np.nan  # the caller reuses its buffer
        sink.append("imu/k", np.arange(k0, min(n, k0 + block), dtype=np.int32))
    sink.set_attrs("imu", {"rate_hz": 100.0})
    return data


@pytest.mark.parametrize("threaded", [False, True])
@pytest.mark.parametrize(("n", "block"), [(100_000, 7_777), (50_000, 150_000), (5, 2)])
def test_sink_round_trip(tmp_path, threaded, n, block):
    path = tmp_path / "s.h5"
    with ResultsWriter(path) as w, w.sink(threaded=threaded) as sink:
        data = _stream(sink, n, block)
        assert sink.rows_written("imu/x") == n
    with h5py.File(path) as f:
        np.testing.assert_array_equal(f["imu/x"][()], data)
        np.testing.assert_array_equal(f["imu/k"][()], np.arange(n))
        x = f["imu/x"]
        assert x.compression == "gzip" and x.shuffle and x.maxshape == (None, 3)
        assert x.chunks[0] * 24 <= CHUNK_BYTES
        assert (x.attrs["units"], x.attrs["frame"], x.attrs["dt_s"]) == ("rad", "b", 0.01)
        assert f["imu"].attrs["rate_hz"] == 100.0


def test_sink_small_expected_rows_uncompressed(tmp_path):
    with ResultsWriter(tmp_path / "s.h5") as w, w.sink() as sink:
        sink.create("t", (), float, "s", expected_rows=50)
        sink.append("t", np.arange(50.0))
    with h5py.File(tmp_path / "s.h5") as f:
        assert f["t"].compression is None and f["t"].shape == (50,)


def test_sink_rejects_bad_rows(tmp_path):
    with ResultsWriter(tmp_path / "s.h5") as w, w.sink() as sink:
        sink.create("x", (3,), np.int32, "count")
        with pytest.raises(ValueError, match="rows of shape"):
            sink.append("x", np.zeros((2, 4), np.int32))
        with pytest.raises(TypeError, match="cannot store float64"):
            sink.append("x", np.zeros((2, 3)))
        with pytest.raises(KeyError, match="not created"):
            sink.append("y", np.zeros((2, 3)))
        with pytest.raises(ValueError, match="created twice"):
            sink.create("x", (3,), np.int32, "count")


class _SlowFile:
    """An h5py.File stand-in whose writes are slow or fail."""

    def __init__(self, fail_at=None, delay=0.0):
        self.fail_at, self.delay, self.writes = fail_at, delay, 0
        self.thread_ids = set()

    def create_dataset(self, path, **kwargs):
        return _SlowDataset(self)

    def __getitem__(self, path):
        return _SlowDataset(self)

    def __contains__(self, path):
        return True


class _SlowDataset:
    def __init__(self, owner):
        self.owner, self.attrs = owner, {}

    def resize(self, n, axis):
        pass

    def __setitem__(self, index, block):
        self.owner.thread_ids.add(threading.get_ident())
        time.sleep(self.owner.delay)
        self.owner.writes += 1
        if self.owner.fail_at is not None and self.owner.writes >= self.owner.fail_at:
            raise OSError("disk full")


def test_threaded_sink_bounds_memory_and_runs_off_thread():
    fake = _SlowFile(delay=0.002)
    sink = H5SeriesSink(fake, threaded=True, max_pending=3)
    sink.create("x", (16,), np.float64, "m")
    rows = np.zeros((8192 * 40, 16))  # 40 chunks of 1 MiB
    sink.append("x", rows)
    sink.close()
    assert fake.writes == 40
    assert sink.peak_pending <= 3
    assert threading.get_ident() not in fake.thread_ids


def test_threaded_sink_error_reaches_caller():
    sink = H5SeriesSink(_SlowFile(fail_at=2), threaded=True, max_pending=2)
    sink.create("x", (16,), np.float64, "m")
    with pytest.raises(OSError, match="disk full"):
        for _ in range(100):
            sink.append("x", np.zeros((8192, 16)))
            time.sleep(0.001)
    sink.abort()


def test_threaded_sink_error_raised_at_close():
    sink = H5SeriesSink(_SlowFile(fail_at=1), threaded=True)
    sink.create("x", (16,), np.float64, "m")
    sink.append("x", np.zeros((10, 16)))  # buffered; written at close
    with pytest.raises(OSError, match="disk full"):
        sink.close()


def test_sink_error_aborts_the_file(tmp_path):
    path = tmp_path / "s.h5"
    with pytest.raises(RuntimeError, match="producer"), ResultsWriter(path) as w:
        sink = w.sink(threaded=True)
        sink.create("x", (3,), float, "m")
        sink.append("x", np.zeros((100_000, 3)))
        raise RuntimeError("producer failed")
    assert list(tmp_path.iterdir()) == []
