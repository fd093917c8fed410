"""Invalid markers and the streamed checks, across chunk boundaries, by hand."""

from __future__ import annotations

import numpy as np
import pytest

from bench.ingest.scrub import NanRunCheck, TimeCheck, scrub
from kernel.errors import InputError

N = np.nan


def test_scrub_markers():
    x = np.array([1.0, 9.91e37, -9.9e37, np.inf, -np.inf, N, -2.5])
    np.testing.assert_array_equal(scrub(x), [1.0, N, N, N, N, N, -2.5])


def _nan_runs(chunks, max_run=3):
    chk = NanRunCheck("f.csv", "x", line_of_row=lambda r: r + 2, max_run=max_run)
    row0 = 0
    for c in chunks:
        chk.feed(np.array(c, dtype=float), row0)
        row0 += len(c)
    chk.finish()


@pytest.mark.parametrize("chunks", [[[1, N, N, N, 2]], [[N, N], [N]], [[1, N], [2, N, N, N]]])
def test_nan_runs_up_to_the_limit_pass(chunks):
    _nan_runs(chunks)


@pytest.mark.parametrize(("chunks", "line"), [
    ([[1, N, N, N, N, 2]], 3),  # run starts at row 1 -> line 3
    ([[1, N, N], [N, N, 1]], 3),  # a run across a chunk edge
    ([[N, N], [N], [N]], 2),  # chunks of nothing but NaN, open to the end
    ([[5, N], [N, N, N]], 3),  # open at the end of the file
])
def test_long_nan_runs_fail_at_their_first_line(chunks, line):
    with pytest.raises(InputError) as e:
        _nan_runs(chunks)
    assert e.value.line == line and "consecutive invalid values" in e.value.problem


def test_time_check_across_chunks_and_nan():
    chk = TimeCheck("f.csv", "Time [s]", line_of_row=lambda r: r + 2)
    chk.feed(np.array([0.0, 0.1, N, 0.3]), 0)
    chk.feed(np.array([N, 0.4, 0.5]), 4)  # NaN times are skipped, not compared
    with pytest.raises(InputError) as e:
        chk.feed(np.array([0.6, N, 0.45]), 7)  # row 9 goes back to 0.45 s
    assert e.value.line == 11 and "goes backwards" in e.value.problem
    chk = TimeCheck("f.csv", "Time [s]", line_of_row=lambda r: r + 2)
    chk.feed(np.array([0.0, 0.1]), 0)
    with pytest.raises(InputError, match="time repeats: 0.1 s after 0.1 s"):
        chk.feed(np.array([0.1, 0.2]), 2)
