"""Processes a test starts: each ends with the test, whatever happens in it."""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any


@contextmanager
def processes(target: Callable[..., None], args: Sequence[tuple[Any, ...]],
              wait_s: float = 120.0) -> Iterator[list[Any]]:
    """Start one spawned process per ``args``; on leaving, join each (``wait_s`` in all) and
    kill what is still running.

    A child still alive when the test's process exits would hold it there for good
    (multiprocessing joins its children at exit, with no timeout): a failed test must not
    turn into a hung test run. The exit codes are read after the ``with`` block.
    """
    ctx = mp.get_context("spawn")
    procs = [ctx.Process(target=target, args=a) for a in args]
    try:
        for p in procs:
            p.start()
        yield procs
    finally:
        import time

        end = time.monotonic() + wait_s
        for p in procs:
            if p.pid is not None:
                p.join(max(0.0, end - time.monotonic()))
        for p in procs:
            if p.is_alive():
                p.kill()
                p.join(10)


def barrier(parties: int) -> Any:
    """A spawn-context barrier (its ``wait`` is given a timeout by the children)."""
    return mp.get_context("spawn").Barrier(parties)


def queue() -> Any:
    """A spawn-context queue."""
    return mp.get_context("spawn").Queue()
