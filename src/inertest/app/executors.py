"""The executors of a batch: a local process pool or a Dask client, and their failures.

Every parallel job goes through one seam: an executor with ``submit(fn, *args)`` returning
futures with ``.result()``. :class:`Fits` submits a batch's fits through a sliding window and
collects them in task order, never waiting on a future without a timeout. The reads of a
:class:`concurrent.futures.ProcessPoolExecutor`'s private state (is it broken, which workers
have exited, how to start an equal one) live here and only here: :func:`pool_broken`,
:func:`end_pool`, :func:`same_pool`, :func:`slots`.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

from inertest.errors import InertestError


def local_pool(workers: int) -> Any:
    """A process pool of ``min(workers, cpu count)`` processes, safe in a threaded program.

    Workers start from a fork server (a clean single-threaded process that has imported
    inertest) where the platform has one, so a caller running threads (a Dask client, a GUI, a
    database driver) cannot deadlock them; elsewhere the platform's default start method. Each
    worker runs its BLAS single-threaded, as Dask's workers do: the parallelism is across fits,
    and n workers x n BLAS threads would oversubscribe the cores (about 2x slower on 2 cores).
    """
    from concurrent.futures import ProcessPoolExecutor

    n = max(1, min(workers, os.cpu_count() or 1))
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["inertest.app.batch"])
        return ProcessPoolExecutor(max_workers=n, mp_context=ctx,
                                   initializer=_single_threaded_blas)
    return ProcessPoolExecutor(max_workers=n, initializer=_single_threaded_blas)


def _single_threaded_blas() -> None:
    """Pool-worker initialiser: one BLAS/OpenMP thread (threadpoolctl, via scikit-learn)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - scikit-learn brings it
        return
    threadpool_limits(1)


WORKER_DIED = "worker process died (killed or out of memory)"
_POLL_S = 0.5  # how often the driver looks at a pool while it waits for a fit [s]
_MAX_BREAKS_IN_A_ROW = 3  # pool restarts with no fit finished in between, then give up
#: :meth:`Fits._failed`'s answer when a lost run was submitted again.
_RESUBMITTED = object()


class RunStoppedError(InertestError):
    """A run the batch stopped or lost: its worker died, it timed out, or it was never run."""


class Fits:
    """The batch's fits on an executor: submitted in a window, collected in task order.

    ``fn(task)`` is the work of one task, run on the executor (a picklable module function).

    A process pool that breaks (a worker killed, out of memory, or gone without a word) is
    restarted with the same settings; the fits that were in flight are run again one at a time,
    and the one that kills its worker alone fails with :data:`WORKER_DIED` (never retried
    again). After ``_MAX_BREAKS_IN_A_ROW`` restarts with no fit finished in between the pool is
    given up and the runs not yet done fail. The driver never waits on a future without a
    timeout: every ``_POLL_S`` it checks the pool's health and the run's ``timeout``.
    """

    def __init__(self, todo: Sequence[Any], executor: Any, *, own: bool,
                 timeout: float | None, fn: Callable[[Any], Any]) -> None:
        self.todo, self.executor, self.timeout, self.fn = todo, executor, timeout, fn
        self.owned: list[Any] = [executor] if own and executor is not None else []
        self.pending: dict[int, Any] = {}
        self.ready: dict[int, Any] = {}  # results (or RunStoppedError) of runs collected early
        self.submitted = 0
        self.breaks_in_a_row = 0
        self.gave_up: str | None = None
        self.resubmitted: set[int] = set()  # runs lost once on the executor and sent again

    # -- submitting -----------------------------------------------------------------------

    def _submit(self, k: int) -> Any:
        task = self.todo[k]
        if self.executor is None:
            return Immediate(self.fn, task)
        try:
            return self.executor.submit(self.fn, task)
        except Exception as exc:  # noqa: BLE001 - a pool that broke since: handled on collect
            if not is_broken_pool(exc):
                raise
            from concurrent.futures import Future

            fut: Future[Any] = Future()
            fut.set_exception(exc)
            return fut

    def submit_up_to(self, n: int) -> None:
        """Submit tasks until ``n`` have been (or the pool was given up)."""
        while self.submitted < min(n, len(self.todo)) and self.gave_up is None:
            self.pending[self.submitted] = self._submit(self.submitted)
            self.submitted += 1

    # -- collecting -----------------------------------------------------------------------

    def collect(self, k: int) -> tuple[Any, ...]:
        """Run ``k``'s computed tuple; raises its error, or :class:`RunStoppedError`."""
        if k not in self.ready and k not in self.pending:
            raise RunStoppedError(self.gave_up or "not run")
        if k not in self.ready:
            self.ready[k] = self._wait(k)
        got = self.ready.pop(k)
        if isinstance(got, BaseException):
            raise got
        return got

    def _wait(self, k: int) -> Any:
        """Wait for run ``k`` (pending): its tuple or its exception, never forever."""
        fut = self.pending[k]
        if self.executor is None:  # serial: computed here and now
            del self.pending[k]
            try:
                return fut.result()
            except (InertestError, OSError) as exc:
                return exc
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        while True:
            try:
                value = fut.result(timeout=_POLL_S)
            except TimeoutError:
                if not fut.done():
                    if pool_broken(self.executor):
                        return self._broken(k)
                    if deadline is not None and time.monotonic() > deadline:
                        return self._timed_out(k)
                    continue
                # Done by now: finished just after the wait timed out (a Dask future's result
                # is then ready), or the computation's own TimeoutError (an OSError).
                err = None if fut.cancelled() else fut.exception()
                if err is None and not fut.cancelled():
                    value = fut.result()
                else:
                    got = self._failed(k, err)
                    if got is not _RESUBMITTED:
                        return got
                    fut = self.pending[k]
                    continue
            except Exception as exc:  # noqa: BLE001 - sorted in _failed; the unknown re-raised
                got = self._failed(k, exc)
                if got is not _RESUBMITTED:
                    return got
                fut = self.pending[k]
                continue
            if value is None:  # a result lost on the way (a Dask future with nothing in it)
                got = self._failed(k, None)
                if got is not _RESUBMITTED:
                    return got
                fut = self.pending[k]
                continue
            del self.pending[k]
            self.breaks_in_a_row = 0
            self.resubmitted.discard(k)
            return value

    def _failed(self, k: int, exc: BaseException | None) -> Any:
        """Run ``k`` failed with ``exc``: its error, a restart, or resubmitted once when lost.

        A run lost on the executor (a cancelled future, a Dask worker gone with it, or a future
        that finished without a result) is submitted again once; lost twice, it fails alone.
        """
        if exc is not None and is_broken_pool(exc):
            return self._broken(k)
        from concurrent.futures import CancelledError

        lost = "lost on the executor (no result came back)" if exc is None else worker_lost(exc)
        again = exc is None or isinstance(exc, CancelledError)  # not a task that kills workers
        if again and k not in self.resubmitted and not self._restartable():
            self.resubmitted.add(k)
            self.pending[k] = self._submit(k)
            return _RESUBMITTED
        del self.pending[k]
        if lost is not None:
            self.breaks_in_a_row = 0
            return RunStoppedError(lost)
        if isinstance(exc, InertestError | OSError):
            self.breaks_in_a_row = 0
            return exc
        raise exc  # type: ignore[misc]

    def _timed_out(self, k: int) -> RunStoppedError:
        fut = self.pending.pop(k)
        stopped = RunStoppedError(f"fit took longer than the {self.timeout:g} s timeout; stopped")
        if self._restartable():  # the only way to stop a fit in a pool worker: end the worker
            innocent = sorted(i for i, f in self.pending.items() if not finished(f))
            for i in innocent:
                del self.pending[i]
            self._restart()
            for i in innocent:
                self.pending[i] = self._submit(i)
        else:
            fut.cancel()
        return stopped

    def _broken(self, k: int) -> Any:
        """The pool died under run ``k`` (or another): rerun the suspects alone, return ``k``'s."""
        suspects = sorted(i for i, f in self.pending.items() if not finished(f))
        for i in suspects:
            del self.pending[i]
        self.breaks_in_a_row += 1
        while suspects:
            if self.breaks_in_a_row > _MAX_BREAKS_IN_A_ROW:
                self.gave_up = (f"not run: the worker pool broke {self.breaks_in_a_row - 1} "
                                f"times in a row without finishing a fit ({WORKER_DIED})")
                for i in suspects:
                    self.ready[i] = RunStoppedError(self.gave_up)
                break
            if pool_broken(self.executor):
                self._restart()
            i = suspects.pop(0)
            self.pending[i] = self._submit(i)
            got = self._wait_alone(i)
            self.ready[i] = got
        return self.ready.pop(k)

    def _wait_alone(self, i: int) -> Any:
        """Run ``i`` as the only fit on a fresh pool: if the pool breaks, ``i`` broke it."""
        fut = self.pending[i]
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        while not finished(fut) and not pool_broken(self.executor):
            if deadline is not None and time.monotonic() > deadline:
                return self._timed_out(i)
            try:
                fut.result(timeout=_POLL_S)
            except Exception:  # noqa: BLE001, S110 - read below, once finished
                pass
        if finished(fut):
            return self._wait(i)
        del self.pending[i]
        self.breaks_in_a_row += 1  # a restart that found its culprit; the next run resets it
        return RunStoppedError(WORKER_DIED)

    # -- the pool ---------------------------------------------------------------------------

    def _restartable(self) -> bool:
        from concurrent.futures import ProcessPoolExecutor

        return isinstance(self.executor, ProcessPoolExecutor)

    def _restart(self) -> None:
        """End the current process pool's workers and start one with the same settings."""
        old = self.executor
        end_pool(old)
        new = same_pool(old)
        self.owned.append(new)
        self.executor = new

    def close(self) -> None:
        """Cancel what is pending and shut the pools this object started."""
        for fut in self.pending.values():
            cancel = getattr(fut, "cancel", None)
            if cancel is not None:
                cancel()
        for pool in self.owned:
            if pool_broken(pool):
                end_pool(pool)
            else:
                pool.shutdown(wait=True, cancel_futures=True)


def finished(fut: Any) -> bool:
    """Done, with a result or the computation's own error (a broken pool is not finished)."""
    if not fut.done():
        return False
    if fut.cancelled():
        return True
    return not is_broken_pool(fut.exception())


def is_broken_pool(exc: BaseException | None) -> bool:
    """True when ``exc`` says the process pool broke (a worker died)."""
    from concurrent.futures.process import BrokenProcessPool

    return isinstance(exc, BrokenProcessPool)


def worker_lost(exc: BaseException) -> str | None:
    """Why a Dask worker lost under the run (KilledWorker) or a cancelled future failed it."""
    from concurrent.futures import CancelledError

    if isinstance(exc, CancelledError):
        return "cancelled on the executor (its worker or the scheduler was lost)"
    distributed = sys.modules.get("distributed")
    killed = getattr(distributed, "KilledWorker", None)
    if killed is not None and isinstance(exc, killed):
        tries = getattr(exc, "allowed_failures", None)
        return (f"{WORKER_DIED}, on {tries + 1} Dask workers in turn" if isinstance(tries, int)
                else f"{WORKER_DIED}, on Dask")
    return None


def pool_broken(executor: Any) -> bool:
    """A process pool that broke, or one of whose workers has exited (not yet noticed)."""
    from concurrent.futures import ProcessPoolExecutor

    if not isinstance(executor, ProcessPoolExecutor):
        return False
    if getattr(executor, "_broken", False):
        return True
    processes = getattr(executor, "_processes", None) or {}
    return any(p.exitcode is not None for p in list(processes.values()))


def end_pool(pool: Any) -> None:
    """Kill a process pool's workers and shut it down without waiting on them.

    A worker killed while it wrote its result leaves half a message in the result pipe; the
    pool's manager thread then reads forever (this process holds the pipe's write end too), and
    the interpreter hangs at exit joining it (CPython 3.11). With every worker dead nothing
    writes there any more: closing our write end turns the wait into end-of-file, and the
    manager thread ends as for any broken pool.
    """
    processes = list((getattr(pool, "_processes", None) or {}).values())
    writer = getattr(getattr(pool, "_result_queue", None), "_writer", None)  # gone on shutdown
    for p in processes:
        if p.exitcode is None:
            p.kill()
    for p in processes:
        p.join(timeout=5)
    pool.shutdown(wait=False, cancel_futures=True)
    if writer is not None and all(p.exitcode is not None for p in processes):
        writer.close()


def same_pool(old: Any) -> Any:
    """A new process pool with ``old``'s size, start method and initializer."""
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(max_workers=old._max_workers, mp_context=old._mp_context,
                               initializer=old._initializer, initargs=old._initargs)


def slots(executor: Any) -> int:
    """Worker slots of a process pool or a Dask client (1 when unknown or serial)."""
    if executor is None:
        return 1
    n = getattr(executor, "_max_workers", None)
    if isinstance(n, int) and n > 0:
        return n
    nthreads = getattr(executor, "nthreads", None)
    if callable(nthreads):  # dask.distributed.Client: {worker address: threads}
        return max(1, sum(nthreads().values()))
    return 4


class Immediate:
    """A future computed on demand (serial batches)."""

    def __init__(self, fn: Any, *args: Any) -> None:
        self._fn, self._args = fn, args

    def result(self, timeout: float | None = None) -> Any:
        """Compute the result now (``timeout`` is not used)."""
        return self._fn(*self._args)

    def cancel(self) -> bool:
        """Nothing to cancel: computed on demand."""
        return False


def wait_for_a_worker(executor: Any, timeout_s: float) -> None:
    """A Dask client: wait until a worker has joined its scheduler (others: nothing to wait).

    Submitting to a scheduler without workers leaves the fits queued forever.
    """
    wait = getattr(executor, "wait_for_workers", None)
    if wait is None:
        return
    try:
        wait(1, timeout=timeout_s)
    except TimeoutError:
        address = getattr(getattr(executor, "scheduler", None), "address", "the scheduler")
        raise InertestError(
            f"no Dask worker joined the scheduler at {address} within {timeout_s:g} s; start "
            f"one with `dask worker {address}` (or wait longer: --worker-wait SECONDS)"
        ) from None
