"""Processes a test starts: each ends with the test, whatever happens in it."""

from __future__ import annotations

import multiprocessing as mp
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, suppress
from typing import Any

import pytest

#: ``inertest ARGV`` as a user runs it, in a fresh process.
INERTEST = [sys.executable, "-c",
            "import sys; from inertest.cli import main; sys.exit(main(sys.argv[1:]))"]


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


def run_inertest(argv: Sequence[str], *, cwd: Any, env: dict[str, str],
                 timeout_s: float = 300.0) -> subprocess.CompletedProcess:
    """``inertest ARGV`` in a fresh process, its output captured.

    One still running after ``timeout_s`` is made to print where it is (Python's
    faulthandler, on SIGABRT) and the test fails with that stack, instead of waiting for it.
    """
    proc = subprocess.Popen([*INERTEST, *argv], cwd=cwd, env={**env, "PYTHONFAULTHANDLER": "1"},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGABRT)
        err = ""
        with suppress(subprocess.TimeoutExpired):
            err = proc.communicate(timeout=30)[1]
        proc.kill()
        proc.wait()
        pytest.fail(f"inertest {' '.join(map(str, argv))} still ran after {timeout_s:g} s; "
                    f"where it was:\n{err[-8000:]}")
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
