"""Junk after a valid header is refused at its first line, in memory bounded by the rows
before it (issue 31: a 2 GB file of junk peaked at 4-6 GB before exit 2). Each reader
is given a valid start and 8 MB of junk (one long line, or lines of 60 characters) and
must refuse at the first junk line having read at most a few chunks of the file
(counted by wrapping the file the readers open), never the whole of it."""

import gzip

import numpy as np
import pytest

from inins.exceptions import InputError
from inins.io import imu_files, rinex_nav, rinex_obs, textlines
from inins.io import solution_files as sf
from tests.io.test_rinex import NAV, OBS

JUNK_MB = 8
CHUNK = 1 << 16


def _junk(lines):
    rng = np.random.default_rng(7)
    block = "".join(chr(c) for c in rng.integers(33, 126, 1 << 20))
    if lines:
        block = "\n".join(block[i : i + 60] for i in range(0, len(block), 61))
    return block * JUNK_MB


@pytest.fixture
def counted(monkeypatch):
    """Bytes the readers take from their files (chunks of 64 KiB)."""
    total = {"bytes": 0}
    opener = textlines.open_binary

    class Counting:
        def __init__(self, f):
            self.f = f

        def read(self, n=-1):
            data = self.f.read(n)
            total["bytes"] += len(data)
            return data

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.f.close()

        def close(self):
            self.f.close()

    monkeypatch.setattr(textlines, "CHUNK", CHUNK)
    monkeypatch.setattr(imu_files, "BLOCK", 1024)  # lines the IMU CSV parses at a time
    monkeypatch.setattr(textlines, "open_binary", lambda path: Counting(opener(path)))
    return total


def _text(path):
    return gzip.decompress(path.read_bytes()).decode("ascii").splitlines()


POS_HEAD = [
    "%  GPST latitude(deg) longitude(deg) height(m) Q ns sdn(m) sde(m) sdu(m) sdne(m) sdeu(m)"
    " sdun(m) age(s) ratio",
    *(
        f"2025/07/08 19:34:{18 + k * 0.25:06.3f} 40.1 -105.1 1601.4 1 21 0.01 0.01 0.01 0 0 0 0 0"
        for k in range(5)
    ),
]
IMU_ROWS = [f"0.1,0.0,1.0,0.5,0.2,0.1,{261906 + 10 * k}" for k in range(100)]


def _readers():
    obs2 = _text(OBS)
    obs3_head = [
        f"{'3.04':>9}{'':11}{'OBSERVATION DATA':20}{'M':20}RINEX VERSION / TYPE",
        f"{'G    1 C1C':60}SYS / # / OBS TYPES",
        f"{'':60}END OF HEADER",
    ]
    nav2 = _text(NAV)
    return {
        ".pos": (POS_HEAD, len(POS_HEAD) + 1, sf.read_rtklib_pos),
        "imu.csv": (
            IMU_ROWS,
            len(IMU_ROWS) + 1,
            lambda p: sf.read_imu_rates_csv(
                p, (0, 1, 2), (3, 4, 5), 6, 1e-3, "g", "dps", ("x", "y", "z")
            ),
        ),
        ".15o": (obs2[: 27 + 17], 27 + 17 + 1, rinex_obs.read_obs),
        ".rnx": (obs3_head, 4, rinex_obs.read_obs),
        ".15n": (nav2[:13], 14, rinex_nav.read_nav),
    }


@pytest.mark.parametrize("lines", [False, True], ids=["one-line", "lines"])
@pytest.mark.parametrize("kind", sorted(_readers()))
def test_junk_is_refused_at_its_first_line(tmp_path, counted, kind, lines):
    head, first_junk, read = _readers()[kind]
    path = tmp_path / f"junk{kind}"
    path.write_text("\n".join(head) + "\n" + _junk(lines))
    size = path.stat().st_size
    with pytest.raises(InputError) as err:
        read(path)
    assert err.value.line == first_junk, str(err.value)
    assert err.value.source == str(path)
    assert counted["bytes"] <= 4 * CHUNK < size / 10, (counted["bytes"], size)
