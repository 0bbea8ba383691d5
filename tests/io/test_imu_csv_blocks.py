"""A block of IMU CSV rows is read by numpy's compiled text reader first and, where that
refuses it, field by field: on any fields, the result is the one of ``float`` on each
field (the same array, or the same refusal naming the same line)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from inins.exceptions import InputError
from inins.io import imu_files
from tests.cli.test_fuzz_readers import SETTINGS

FIELDS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["1_0", " 1.5 ", "", "nan", "-inf", "1e400", "0x10", "1.5e", "#1", "١"]),
    st.text(" 0123456789.-+eE", max_size=6),
)


def _by_float(block, width):
    """The reading of every field by ``float`` (the reference)."""
    rows = []
    for n, text in block:
        parts = text.split(",")
        if len(parts) != width:
            return ("refused", n)
        try:
            rows.append([float(p) for p in parts])
        except ValueError:
            return ("refused", n)
    return np.array(rows)


@SETTINGS
@given(rows=st.lists(st.lists(FIELDS, min_size=2, max_size=4), min_size=1, max_size=6))
def test_a_block_reads_as_float_reads_each_field(rows):
    width = len(rows[0])
    block = [(10 + i, ",".join(r)) for i, r in enumerate(rows)]
    expected = _by_float(block, width)
    try:
        got = imu_files._parse_block(block, width, "imu.csv")
    except InputError as exc:
        assert isinstance(expected, tuple) and exc.line == expected[1]
        return
    assert not isinstance(expected, tuple)
    assert np.array_equal(got, expected, equal_nan=True)
    assert np.array_equal(np.signbit(got), np.signbit(expected))


def test_the_compiled_reader_takes_a_plain_block(monkeypatch):
    block = [(1, "0.119,0.027,1.013,-0.671,3.082,0.198,261906"), (2, "1e-3,-0,7,8,9,10,11")]
    monkeypatch.setattr(imu_files.np, "array", _refuse)  # the field-by-field path unused
    got = imu_files._parse_block(block, 7, "imu.csv")
    assert got.shape == (2, 7) and got[1, 0] == 1e-3 and np.signbit(got[1, 1])


def _refuse(*args, **kwargs):
    pytest.fail("the block was read field by field")
