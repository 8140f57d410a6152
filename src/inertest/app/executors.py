"""The executors of a batch: a local process pool or a Dask client, and their failures.

Every parallel job goes through one seam: an executor with ``submit(fn, *args)`` returning
futures with ``.result()``. :class:`Fits` submits a batch's fits through a sliding window and
collects them in task order, never waiting on a future without a timeout. The reads of a
:class:`concurrent.futures.ProcessPoolExecutor`'s private state (is it broken, which workers
have exited, how to start an equal one) live here and only here: :func:`pool_broken`,
:func:`end_pool`, :func:`same_pool`, :func:`slots`.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from inertest.errors import InertestError


def local_pool(workers: int, *, at_most_cores: bool = True) -> Any:
    """A process pool of ``min(workers, cpu count)`` processes, safe in a threaded program.

    ``at_most_cores=False`` starts ``workers`` processes whatever the cores (for work that
    waits more than it computes, and for measuring the batch machinery itself).

    Workers start from a fork server (a clean single-threaded process that has imported
    inertest) where the platform has one, so a caller running threads (a Dask client, a GUI, a
    database driver) cannot deadlock them; elsewhere the platform's default start method. Each
    worker runs its BLAS single-threaded, as Dask's workers do: the parallelism is across fits,
    and n workers x n BLAS threads would oversubscribe the cores (about 2x slower on 2 cores).
    """
    from concurrent.futures import ProcessPoolExecutor

    n = max(1, min(workers, os.cpu_count() or 1) if at_most_cores else workers)
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["inertest.app.batch"])
        return ProcessPoolExecutor(max_workers=n, mp_context=ctx,
                                   initializer=_single_threaded_blas)
    return ProcessPoolExecutor(max_workers=n, initializer=_single_threaded_blas)


def _single_threaded_blas() -> None:
    """Pool-worker initialiser: one BLAS/OpenMP thread (threadpoolctl); Ctrl-C left to the driver.

    The terminal sends SIGINT to the whole process group: each worker printed a
    KeyboardInterrupt traceback; the driver stops the pool itself.
    """
    import signal

    from threadpoolctl import threadpool_limits

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threadpool_limits(1)


WORKER_DIED = "worker process died (killed or out of memory)"
_POLL_S = 0.5  # how often the driver looks at a pool while it waits for a fit [s]
#: Longest wait for finished Dask results [s]: longer, and the worker that holds them does not
#: answer (frozen, or its host gone without closing the connection); they are computed again.
_GATHER_S = 10.0
_WORKER_CHECK_S = 1.0  # how often it asks a Dask scheduler for its workers while it waits [s]
_MAX_BREAKS_IN_A_ROW = 3  # pool restarts with no fit finished in between, then give up
#: :meth:`Fits._failed`'s answer when a lost run was submitted again.
_RESUBMITTED = object()
#: :meth:`Fits._broken`'s answer when the unit waited on was split into single fits.
_SPLIT = object()
#: :meth:`Fits._gather_finished`'s answer when the unit waited on is not finished yet.
_NOT_YET = object()


def unit_sizes(n_tasks: int, workers: int, *, factor: float, most: int) -> list[int]:
    """Sizes of the units of a batch: large first, single fits at the end.

    Each unit takes ``ceil(remaining / (factor * workers))`` fits (at most ``most``, at
    least 1): few futures while there is much to do, and the last ones small, so that the
    workers finish together: guided self-scheduling (C. D. Polychronopoulos, D. J. Kuck,
    "Guided self-scheduling: a practical scheduling scheme for parallel supercomputers",
    IEEE Trans. Comput. C-36(12), 1987, doi:10.1109/TC.1987.5009495) for ``factor = 1``; a
    larger factor gives smaller units.
    """
    sizes, left = [], n_tasks
    while left > 0:
        size = max(1, min(most, math.ceil(left / (factor * max(1, workers)))))
        sizes.append(size)
        left -= size
    return sizes


def run_unit(fn: Callable[[Any], Any], tasks: Sequence[Any]) -> list[Any]:
    """Worker side of a unit: ``fn(task)`` for each task; a task's own error is its value."""
    out: list[Any] = []
    for task in tasks:
        try:
            out.append(fn(task))
        except (InertestError, OSError) as exc:
            out.append(exc)
    return out


class RunStoppedError(InertestError):
    """A run the batch stopped or lost: its worker died, it timed out, or it was never run."""


class Fits:
    """The batch's fits on an executor: submitted in a window, collected in task order.

    ``fn(task)`` is the work of one task, run on the executor (a picklable module function).
    Tasks travel in units of ``chunk`` consecutive tasks (one future each): a Dask client
    spends about 1.5 ms of this process's time on every future, a fit 30-60 ms on its worker,
    so one future per fit would make the driver the bottleneck of a large cluster. A unit's
    tasks fail one by one (a task's own error is its value), never together, except when the
    executor loses the unit.

    A process pool that breaks (a worker killed, out of memory, or gone without a word) is
    restarted with the same settings; the units that were in flight are split into single
    fits and run again one at a time, and the fit that kills its worker alone fails with
    :data:`WORKER_DIED` (never retried again). After ``_MAX_BREAKS_IN_A_ROW`` restarts with no
    fit finished in between the pool is given up and the runs not yet done fail. The driver
    never waits on a future without a timeout: every ``_POLL_S`` it checks the pool's health
    and the run's ``timeout`` (a unit is one fit when there is a timeout).
    """

    def __init__(self, todo: Sequence[Any], executor: Any, *, own: bool,
                 timeout: float | None, fn: Callable[[Any], Any],
                 chunk: int | Sequence[int] = 1, worker_wait: float = 60.0) -> None:
        self.todo, self.executor, self.timeout, self.fn = todo, executor, timeout, fn
        #: Dask: the longest the scheduler may be without a worker while fits are pending [s]
        #: (its futures would wait for ever); then the runs not done are stopped.
        self.worker_wait = worker_wait
        self._no_worker_since: float | None = None
        self._scheduler_answers = True
        self._next_worker_check = 0.0
        self._gather_together = True  # off once a gather got stuck: fetched one by one then
        #: The scheduler's address, for messages (the client forgets it when it is lost).
        self._address = str(getattr(getattr(executor, "scheduler", None), "address", None)
                           or "the scheduler")
        self.owned: list[Any] = [executor] if own and executor is not None else []
        if timeout is not None:
            sizes = [1] * len(todo)
        elif isinstance(chunk, int):
            sizes = [max(1, chunk)] * len(todo)
        else:
            sizes = list(chunk)
        #: Task indices of each unit; split units' single fits are appended at the end.
        self.units: list[list[int]] = []
        start = 0
        for size in sizes:
            if start >= len(todo):
                break
            self.units.append(list(range(start, min(start + size, len(todo)))))
            start += size
        if start < len(todo):
            self.units += [[i] for i in range(start, len(todo))]
        self.first_units = len(self.units)
        self.unit_of = {i: u for u, unit in enumerate(self.units) for i in unit}
        self.pending: dict[int, Any] = {}  # unit -> future
        self.ready: dict[int, Any] = {}  # unit -> values (or its error), collected early
        self.done: dict[int, Any] = {}  # task -> value or error, not yet collected
        self.submitted = 0  # units submitted, in order
        self.breaks_in_a_row = 0
        self.gave_up: str | None = None
        self.resubmitted: set[int] = set()  # units lost once on the executor and sent again
        self._finished = threading.Event()  # a Dask unit ended (set from the client's thread)

    # -- submitting -----------------------------------------------------------------------

    def _submit(self, u: int) -> Any:
        tasks = [self.todo[i] for i in self.units[u]]
        if self.executor is None:
            return Immediate(run_unit, self.fn, tasks)
        try:
            if hasattr(self.executor, "gather"):  # Dask
                # pure=False: a fresh key, not a hash of the arguments (tokenising a unit's
                # tasks cost this process 1.4 ms a unit, and a unit submitted again after
                # its worker was lost must not find the lost future under the same key)
                fut = self.executor.submit(run_unit, self.fn, tasks, pure=False)
                fut.add_done_callback(lambda _: self._finished.set())  # see _wait_dask
            else:
                fut = self.executor.submit(run_unit, self.fn, tasks)
            return fut
        except Exception as exc:  # noqa: BLE001 - a pool that broke since: handled on collect
            if not is_broken_pool(exc):
                raise
            from concurrent.futures import Future

            failed: Future[Any] = Future()
            failed.set_exception(exc)
            return failed

    def submit_up_to(self, n: int) -> None:
        """Submit units until every task before ``n`` has been (or the pool was given up)."""
        while (self.submitted < self.first_units and self.units[self.submitted][0] < n
               and self.gave_up is None):
            self.pending[self.submitted] = self._submit(self.submitted)
            self.submitted += 1

    # -- collecting -----------------------------------------------------------------------

    def collect(self, k: int) -> Any:
        """Task ``k``'s computed value; raises its error, or :class:`RunStoppedError`."""
        while k not in self.done:
            u = self.unit_of[k]
            if u in self.ready:
                self._deliver(u, self.ready.pop(u))
            elif u in self.pending:
                got = self._wait(u)
                if got is not _SPLIT:
                    self._deliver(u, got)
            else:
                raise RunStoppedError(self.gave_up or "not run")
        got = self.done.pop(k)
        if isinstance(got, BaseException):
            raise got
        return got

    def _deliver(self, u: int, got: Any) -> None:
        """Unit ``u``'s values (or the one error of all its tasks) to its tasks."""
        for j, i in enumerate(self.units[u]):
            self.done[i] = got if isinstance(got, BaseException) else got[j]

    def _wait(self, k: int) -> Any:
        """Wait for unit ``k`` (pending): its values or its error, never forever."""
        fut = self.pending[k]
        if self.executor is None:  # serial: computed here and now
            del self.pending[k]
            return fut.result()
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        if hasattr(self.executor, "gather"):  # a Dask client
            got = self._wait_dask(k, deadline)
            if got is not _NOT_YET:
                return got
            fut = self.pending[k]
        while True:
            try:
                value = self._result(fut)
            except TimeoutError:
                if not fut.done():
                    if pool_broken(self.executor):
                        return self._broken(k)
                    if deadline is not None and time.monotonic() > deadline:
                        return self._timed_out(k)
                    if self._no_worker_left():
                        return self._give_up_dask(k)
                    continue
                # Done by now: finished just after the wait timed out (a Dask future's result
                # is then ready).
                err = None if fut.cancelled() else fut.exception()
                if err is None and not fut.cancelled():
                    value = self._result(fut)
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

    def _result(self, fut: Any) -> Any:
        """``fut.result(timeout=_POLL_S)``; a Dask result not fetched within ``_GATHER_S``: None.

        None is a result lost on the way: the unit is computed again.

        A finished Dask future's result is fetched from the worker that holds it, and that
        fetch has no end when the worker is frozen (SIGSTOP, a hung host): not even the
        client's own timeout stops it. It runs on a thread of its own here.
        """
        try:
            if hasattr(self.executor, "gather") and getattr(fut, "status", "") == "finished":
                try:
                    return within(fut.result, _GATHER_S)
                except TimeoutError:
                    self._gather_together = False
                    return None
            return fut.result(timeout=_POLL_S)
        except Exception:
            # The fetch of a finished Dask result failed, not the fit (its status would say
            # "error"): Dask's result() raises an UnboundLocalError when the fetch from a
            # frozen worker is cancelled inside it. A result lost on the way: computed again.
            if hasattr(self.executor, "gather") and getattr(fut, "status", "") == "finished":
                return None
            raise

    def _wait_dask(self, k: int, deadline: float | None) -> Any:
        """Wait for Dask unit ``k`` without a round trip per future.

        :data:`_NOT_YET` when it failed (the caller's one-by-one path sorts that out). Each
        Dask future tells :attr:`_finished` when it ends (a callback, no round trip
        through the client's event loop); the finished ones are then fetched together.
        """
        fut = self.pending[k]
        while True:
            self._finished.clear()  # before looking: a unit that ends after this wakes us
            got = self._gather_finished(k)
            if got is not _NOT_YET:
                return got
            if getattr(fut, "status", "finished") != "pending":  # failed, lost, or empty
                return _NOT_YET
            if deadline is not None and time.monotonic() > deadline:
                return self._timed_out(k)
            if self._no_worker_left():
                return self._give_up_dask(k)
            self._finished.wait(_POLL_S)

    def _gather_finished(self, k: int) -> Any:
        """Fetch every finished Dask unit in one call; unit ``k``'s values, or :data:`_NOT_YET`.

        Each ``result()`` of a Dask future is a round trip through the client's event loop
        (about 1 ms of this process's time); one ``gather`` of all the finished ones costs a
        fraction of that per future. A future that failed, or is not finished, is left to the
        waiting below.
        """
        done = [u for u, f in self.pending.items() if getattr(f, "status", "") == "finished"]
        if not done or not self._gather_together:
            return _NOT_YET
        futures = [self.pending[u] for u in done]
        try:
            values = within(lambda: self.executor.gather(futures, errors="skip"), _GATHER_S)
        except TimeoutError:  # a worker holding some does not answer: one by one from now
            self._gather_together = False
            return _NOT_YET
        except Exception:  # noqa: BLE001 - any trouble: the one-by-one path below sorts it
            return _NOT_YET
        if len(values) != len(done):  # one failed meanwhile: which is not known here
            return _NOT_YET
        for u, value in zip(done, values, strict=True):
            if value is not None:  # a result lost on the way is left to the path below
                del self.pending[u]
                self.resubmitted.discard(u)
                self.ready[u] = value
        if k not in self.ready:
            return _NOT_YET
        self.breaks_in_a_row = 0
        return self.ready.pop(k)

    def _no_worker_left(self) -> bool:
        """A Dask scheduler that has had no worker for :attr:`worker_wait` seconds.

        Its queued futures would wait for ever (every worker lost mid-batch, or the last one
        gone just after the start while the scheduler still listed it). Asked at most every
        ``_WORKER_CHECK_S`` while the driver waits; a scheduler that does not answer counts
        as one without workers.
        """
        nthreads = getattr(self.executor, "nthreads", None)
        now = time.monotonic()
        if not callable(nthreads) or not hasattr(self.executor, "gather"):
            return False
        if now < self._next_worker_check:
            return False
        self._next_worker_check = now + _WORKER_CHECK_S
        try:
            workers = len(within(nthreads, min(_GATHER_S, self.worker_wait)))
            self._scheduler_answers = True
        except Exception:  # noqa: BLE001 - the scheduler unreachable or frozen: no worker
            workers, self._scheduler_answers = 0, False
        if workers:
            self._no_worker_since = None
            return False
        if self._no_worker_since is None:
            self._no_worker_since = now  # when asked: an unanswered question counts
        return time.monotonic() - self._no_worker_since >= self.worker_wait

    def _give_up_dask(self, k: int) -> RunStoppedError:
        """Stop every pending Dask unit (no worker to run them): ``k``'s error."""
        address = self._address
        if self._scheduler_answers:
            self.gave_up = (f"not run: no Dask worker on the scheduler at {address} for "
                            f"{self.worker_wait:g} s (every worker lost); start workers with "
                            f"`dask worker {address}` and run the batch again (the runs filed "
                            "so far are kept)")
        else:
            self.gave_up = (f"not run: the Dask scheduler at {address} has not answered for "
                            f"{self.worker_wait:g} s (stopped, or its host lost); start it "
                            "again and run the batch again (the runs filed so far are kept)")
        cancel_dask(list(self.pending.values()))
        self.pending.clear()
        return RunStoppedError(self.gave_up)

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
            cancel_dask([fut])
        return stopped

    def _broken(self, k: int) -> Any:
        """The pool died under unit ``k`` (or another): rerun the suspects' fits alone.

        Returns ``k``'s values, or :data:`_SPLIT` when ``k`` was split into single fits
        (their values are then in :attr:`ready` under their own units).
        """
        suspects = []
        for i in sorted(u for u, f in self.pending.items() if not finished(f)):
            del self.pending[i]
            suspects += self._split(i)
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
        return self.ready.pop(k) if k in self.ready else _SPLIT

    def _split(self, u: int) -> list[int]:
        """Unit ``u`` as units of one fit each (itself when it holds one)."""
        if len(self.units[u]) == 1:
            return [u]
        singles = []
        for i in self.units[u]:
            self.units.append([i])
            self.unit_of[i] = len(self.units) - 1
            singles.append(len(self.units) - 1)
        return singles

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

    def close(self, abort: bool = False) -> None:
        """Cancel what is pending and shut the pools this object started.

        ``abort`` (the batch interrupted, Ctrl-C): the pools' workers are killed, not waited
        for, and a second Ctrl-C meanwhile is ignored. A second Ctrl-C that broke into a
        graceful shutdown left idle workers that Python's exit then joined for ever.
        """
        with _uninterrupted(abort):
            pending = [f for f in self.pending.values() if getattr(f, "cancel", None)]
            if hasattr(self.executor, "gather"):
                cancel_dask(pending)
            else:
                for fut in pending:
                    fut.cancel()
            for pool in self.owned:
                if abort or pool_broken(pool):
                    end_pool(pool)
                else:
                    pool.shutdown(wait=True, cancel_futures=True)


@contextlib.contextmanager
def _uninterrupted(on: bool) -> Any:
    """Ignore SIGINT and SIGTERM inside (when ``on``, in the main thread)."""
    import signal

    if not on or threading.current_thread() is not threading.main_thread():
        yield
        return
    kept = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in kept.items():
            signal.signal(s, handler)


def cancel_dask(futures: list[Any]) -> None:
    """Cancel Dask futures; a scheduler that does not answer within ``_GATHER_S`` is left."""
    with contextlib.suppress(Exception):
        within(lambda: [f.cancel() for f in futures], _GATHER_S)


def within(call: Callable[[], Any], timeout_s: float) -> Any:
    """``call()`` on a thread of its own: its value (or error), or ``TimeoutError``.

    After ``timeout_s`` the thread is left to end when it can (a daemon: never waited for).

    For the Dask client's calls that can wait for ever: fetching a result from a frozen
    worker, asking a frozen scheduler.
    """
    box: dict[str, Any] = {}
    ended = threading.Event()

    def run() -> None:
        try:
            box["value"] = call()
        except BaseException as exc:  # noqa: BLE001 - handed to the caller
            box["error"] = exc
        finally:
            ended.set()

    threading.Thread(target=run, name="inertest-dask-call", daemon=True).start()
    if not ended.wait(timeout_s):
        raise TimeoutError(f"no answer within {timeout_s:g} s")
    if "error" in box:
        raise box["error"]
    return box["value"]


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
