"""Units of several fits on a process pool (issue 31): a fit that kills its worker fails alone.

A batch sends several fits as one unit (one future) when there are many per worker; when the
pool breaks under a unit, its fits are run again one at a time, so only the fit that kills
its worker fails, exactly as with one fit per future.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor

import pytest

from inertest.app.executors import WORKER_DIED, Fits, RunStoppedError, run_unit
from inertest.errors import DataError


def _work(t: int) -> int:
    if t == 5:
        os._exit(3)  # the worker dies (as when killed, or out of memory)
    if t == 9:
        raise DataError("bad data in run 9")
    return 2 * t


def _collect(fits: Fits, n: int) -> list[object]:
    out: list[object] = []
    for k in range(n):
        try:
            out.append(fits.collect(k))
        except (RunStoppedError, DataError) as exc:
            out.append(str(exc))
    return out


@pytest.mark.parametrize("chunk", [1, 4])
def test_a_fit_that_kills_its_worker_fails_alone_whatever_its_unit(chunk):
    pool = ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork"))
    fits = Fits(list(range(16)), pool, own=True, timeout=None, fn=_work, chunk=chunk)
    try:
        fits.submit_up_to(16)
        out = _collect(fits, 16)
    finally:
        fits.close()
    want: list[object] = [2 * t for t in range(16)]
    want[5], want[9] = WORKER_DIED, "bad data in run 9"
    assert out == want
    if chunk > 1:  # the units in flight when the pool broke were split into single fits
        assert [5] in fits.units[4:]


def test_units_are_consecutive_tasks_and_a_tasks_error_is_its_own():
    got = run_unit(_work, [8, 9, 10])
    assert got[0] == 16 and isinstance(got[1], DataError) and got[2] == 20
    pool_fits = Fits(list(range(10)), object(), own=False, timeout=None, fn=_work, chunk=4)
    assert pool_fits.units == [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9]]
    timed = Fits(list(range(3)), object(), own=False, timeout=5.0, fn=_work, chunk=4)
    assert timed.units == [[0], [1], [2]]  # a timeout is per fit: one fit a unit


def test_unit_sizes_are_guided_self_scheduling():
    """Polychronopoulos & Kuck (1987): each unit ceil(R / P) of the R fits left, P workers."""
    from inertest.app.executors import unit_sizes

    sizes = unit_sizes(100, 4, factor=1.0, most=1000)
    left, want = 100, []
    while left:
        want.append(-(-left // 4))
        left -= want[-1]
    assert sizes == want and sizes[:3] == [25, 19, 14] and sizes[-1] == 1
    assert max(unit_sizes(320, 16, factor=1.0, most=16)) == 16
    assert unit_sizes(3, 16, factor=4.0, most=16) == [1, 1, 1]
    assert sum(unit_sizes(12345, 7, factor=2.0, most=9)) == 12345
