"""Run many independent tasks on a Dask cluster and stream their outcomes as they finish.

The engine knows nothing of what a task does: it calls ``fn(task)`` on a worker for every
task and yields an :class:`Outcome` per task, in completion order, with the value or the
error. One task that raises does not stop the others.

By default a local cluster is started, sized to the machine: one worker process per CPU, one
thread each (the filters are CPU-bound Python and numpy, and the GIL would serialise threads).
``scheduler="tcp://host:port"`` sends the same tasks to an existing cluster instead.

Tasks are submitted in chunks whose size adapts to the measured task time: a first wave of
single tasks measures how long one takes, then chunks grow (at most twofold each time) until
they last about ``chunk_target_s`` each (never more than ``max_chunk`` tasks, and small enough
near the end that every worker keeps a share). Slow tasks (a replay of a log) thus go one
by one, with the best load balance, while trivial tasks pay Dask's scheduling cost once per
chunk, not once per task.

Usage::

    from lgvtool.fleet.engine import run_tasks

    for out in run_tasks(evaluate_one, paths, workers=2):
        if out.ok:
            documents[out.index] = out.value
        else:
            print(out.task, out.error)
"""

from __future__ import annotations

import logging
import math
import os
import socket
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from lgvtool.errors import InputError, LgvError
from lgvtool.fleet.connect import SchedulerSpec
from lgvtool.progress import Progress

if TYPE_CHECKING:
    from distributed import Client

T = TypeVar("T")
R = TypeVar("R")

CHUNK_TARGET_S = 0.2
"""Aimed-for run time of one chunk of tasks on a worker, s."""
MAX_CHUNK = 256
"""Most tasks in one chunk."""
CONNECT_TIMEOUT_S = 20.0
"""How long to try to reach a remote scheduler, s."""
WORKER_TIMEOUT_S = 60.0
"""How long to wait for the first worker to join a remote scheduler, s."""


@dataclass(frozen=True)
class Outcome(Generic[T, R]):
    """What became of one task."""

    index: int
    """Position of the task in the sequence given to :func:`run_tasks`."""
    task: T
    value: R | None
    """What ``fn(task)`` returned (None when it failed)."""
    error: str | None = None
    """One line, ``ExceptionType: message``; None on success."""
    input_error: bool = False
    """True when the task raised a :class:`~lgvtool.errors.LgvError` (bad input: a corrupt
    log, missing channels, a bad setting): running it again gives the same error."""
    elapsed_s: float = 0.0
    """Wall time ``fn`` ran on the worker, s."""
    cpu_s: float = 0.0
    """Processor time of the worker process while ``fn`` ran, s (below ``elapsed_s`` when
    the machine is shared or the task waits on I/O)."""
    worker: str = ""
    """Host and process id of the worker that ran it."""
    detail: str | None = None
    """Traceback text of an unexpected error (not of an input error)."""

    @property
    def ok(self) -> bool:
        """True when the task returned a value."""
        return self.error is None


def default_workers() -> int:
    """Worker processes of the local cluster: the CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def _lgvtool_version() -> str:
    """Run on a worker: the lgvtool version installed there."""
    from lgvtool import __version__

    return __version__


@contextmanager
def open_client(
    scheduler: str | SchedulerSpec | None = None,
    workers: int | None = None,
    *,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
    worker_timeout_s: float = WORKER_TIMEOUT_S,
    check_version: bool = True,
) -> Iterator[Client]:
    """A Dask client: on a new local cluster (``workers`` processes, one thread each; default
    one per CPU), or connected to the running scheduler at ``scheduler`` (``tcp://host:port``).

    With a remote scheduler, waits up to ``worker_timeout_s`` for a worker, and with
    ``check_version`` checks that every worker runs this lgvtool version.
    The local cluster listens on 127.0.0.1 only (its HTTP server on a free port) and has no
    dashboard. Closed on exit.

    :raises InputError: both ``scheduler`` and ``workers`` given, ``workers`` < 1, the
        scheduler unreachable, no worker, or a worker without the same lgvtool.
    """
    from distributed import Client, LocalCluster

    from lgvtool import __version__

    if scheduler is not None and workers is not None:
        raise InputError("give either a scheduler address or a number of local workers, not both")
    if workers is not None and workers < 1:
        raise InputError(f"the number of workers must be at least 1, got {workers}")
    with ExitStack() as stack:
        if scheduler is None:
            cluster = stack.enter_context(LocalCluster(
                n_workers=workers or default_workers(), threads_per_worker=1, processes=True,
                host="127.0.0.1", dashboard_address=None, silence_logs=logging.CRITICAL,
                # the scheduler's HTTP server (health routes; the dashboard is off) on a free
                # port of the loopback interface, not on 8787 (which a dashboard of the user's
                # own may hold)
                scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}))
            client = stack.enter_context(Client(cluster))
        else:
            spec = scheduler if isinstance(scheduler, SchedulerSpec) else SchedulerSpec(scheduler)
            try:
                client = stack.enter_context(Client(spec.address, timeout=connect_timeout_s,
                                                    security=spec.security()))
            except (OSError, TimeoutError, ValueError, TypeError) as exc:
                raise InputError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
            except Exception as exc:  # not a Dask scheduler (its bytes make no Dask message)
                raise InputError(f"{scheduler} does not answer as a Dask scheduler "
                                 f"({type(exc).__name__})") from None
            try:
                client.wait_for_workers(1, timeout=worker_timeout_s)
            except TimeoutError:
                raise InputError(f"no Dask worker joined the scheduler at {scheduler} within "
                                 f"{worker_timeout_s:g} s") from None
            if check_version:
                try:
                    versions = client.run(_lgvtool_version)
                except Exception as exc:
                    raise InputError(f"a Dask worker of {scheduler} cannot run lgvtool "
                                     f"({type(exc).__name__}: {exc}); install lgvtool there") from None
                wrong = {w: v for w, v in versions.items() if v != __version__}
                if wrong:
                    listed = ", ".join(f"{w} has {v}" for w, v in sorted(wrong.items()))
                    raise InputError(f"Dask workers run another lgvtool version than {__version__}: "
                                     f"{listed}")
        yield client


#: what a worker reports of one task: (index, value, error, input_error, elapsed_s, cpu_s,
#: worker, detail)
ChunkRow = tuple[int, R | None, str | None, bool, float, float, str, str | None]


def _run_chunk(fn: Callable[[T], R], items: Sequence[tuple[int, T]]) -> list[ChunkRow[R]]:
    """Run on a worker: ``fn`` over each (index, task); never raises for a task's error.

    Returns one tuple per task:
    (index, value, error, input_error, elapsed_s, cpu_s, worker, detail).
    """
    worker = f"{socket.gethostname()}:{os.getpid()}"
    out: list[ChunkRow[R]] = []
    for index, task in items:
        t0, c0 = time.perf_counter(), time.process_time()
        value, error, input_error, detail = None, None, False, None
        try:
            value = fn(task)
        except LgvError as exc:
            error, input_error = f"{type(exc).__name__}: {exc}", True
        except Exception as exc:
            error, detail = f"{type(exc).__name__}: {exc}", traceback.format_exc(limit=-8)
        out.append((index, value, error, input_error, time.perf_counter() - t0,
                    time.process_time() - c0, worker, detail))
    return out


class _Chunker:
    """Chooses the size of the next chunk from the task times seen so far.

    The time of one task is a moving average over chunks (each chunk's mean, weight
    :attr:`ALPHA`), so a change of task time (a run of fast failures, then slow logs) is
    followed within a chunk; a chunk is at most twice the size of the one before.
    """

    ALPHA = 0.5

    def __init__(self, target_s: float, max_chunk: int) -> None:
        self.target_s = target_s
        self.max_chunk = max(1, max_chunk)
        self.per_task_s: float | None = None
        self.last = 1

    def observe(self, elapsed_s: Iterable[float]) -> None:
        """Take in the task times of one finished chunk, s."""
        times = list(elapsed_s)
        if not times:
            return
        mean = sum(times) / len(times)
        self.per_task_s = (mean if self.per_task_s is None
                           else self.ALPHA * mean + (1.0 - self.ALPHA) * self.per_task_s)

    def size(self, pending: int, slots: int) -> int:
        """Tasks in the next chunk, with ``pending`` left and ``slots`` worker threads."""
        if self.per_task_s is None:
            return 1
        wanted = math.floor(self.target_s / max(self.per_task_s, 1e-6) + 1e-9)
        size = min(self.max_chunk, 2 * self.last, max(1, wanted))
        fair = max(1, math.ceil(pending / (2 * max(slots, 1))))
        self.last = max(1, min(size, fair, pending))
        return self.last


def run_tasks(
    fn: Callable[[T], R],
    tasks: Iterable[T],
    *,
    scheduler: str | SchedulerSpec | None = None,
    workers: int | None = None,
    progress: bool = True,
    client: Client | None = None,
    label: str = "tasks",
    chunk_target_s: float = CHUNK_TARGET_S,
    max_chunk: int = MAX_CHUNK,
) -> Iterator[Outcome[T, R]]:
    """Run ``fn(task)`` for every task on a Dask cluster; yield an :class:`Outcome` per task as
    it finishes (completion order; ``Outcome.index`` is the task's position).

    ``fn`` and the tasks travel to the workers by pickle: keep tasks small (a path, settings,
    a seed), never the data itself. ``fn`` must be importable on the workers (a function of an
    installed module) or defined in a script (then it is shipped by value).

    :param scheduler: ``tcp://host:port`` of a running Dask scheduler; None: a local cluster.
    :param workers: processes of the local cluster (default one per CPU).
    :param progress: draw a progress bar on stderr.
    :param client: an open Dask client to use (then ``scheduler`` and ``workers`` are ignored
        and the client is left open).
    :param label: the word shown on the progress bar.
    :param chunk_target_s: aimed-for run time of one chunk, s (0: one task per chunk).
    :param max_chunk: most tasks in one chunk.
    """
    items = list(tasks)
    if not items:
        return
    with ExitStack() as stack:
        if client is None:
            client = stack.enter_context(open_client(scheduler, workers))
        bar = Progress(len(items), label) if progress else None
        if bar is not None:
            stack.callback(bar.close)
        yield from _drive(client, fn, items, bar, chunk_target_s, max_chunk)


def run_in_order(
    fn: Callable[[T], R],
    tasks: Sequence[T],
    *,
    scheduler: SchedulerSpec | None,
    workers: int | None,
    in_process: Callable[[T], R] | None = None,
    progress: bool = False,
    path_of: Callable[[T], str] = str,
) -> list[R]:
    """``fn(task)`` for every task, the results in the tasks' order: in this process
    (``in_process``, default ``fn``, one task after the other) when neither ``scheduler`` nor
    ``workers`` is given and there is one task or no fleet extra, else on the fleet engine
    (:func:`run_tasks`, a local Dask cluster or ``scheduler``).

    :raises InputError: the first task that failed, with its error (a bad-input error as it was,
        which names its log already; any other prefixed with ``path_of(task)``).
    """
    from lgvtool.fleet.connect import fleet_available

    if scheduler is None and workers is None and (len(tasks) <= 1 or not fleet_available()):
        one = fn if in_process is None else in_process
        return [one(t) for t in tasks]
    results: list[R | None] = [None] * len(tasks)
    for out in run_tasks(fn, tasks, scheduler=scheduler, workers=workers, progress=progress,
                         label="logs"):
        if not out.ok:
            error = out.error or "failed"
            if out.input_error:  # "LogFormatError: <path>: ..." already names the log
                raise InputError(error.split(": ", 1)[-1])
            raise InputError(f"{path_of(out.task)}: {error}")
        results[out.index] = out.value
    return [r for r in results if r is not None]


def _slots(client: Client) -> int:
    try:
        return max(1, int(sum(client.nthreads().values())))
    except Exception:
        return 1


def _drive(
    client: Client,
    fn: Callable[[T], R],
    tasks: list[T],
    bar: Progress | None,
    chunk_target_s: float,
    max_chunk: int,
) -> Iterator[Outcome[T, R]]:
    from distributed import as_completed

    pending: deque[tuple[int, T]] = deque(enumerate(tasks))
    chunker = _Chunker(chunk_target_s, max_chunk if chunk_target_s > 0 else 1)
    submitted: dict[Any, list[tuple[int, T]]] = {}
    live: dict[Any, Any] = {}
    queue = as_completed()
    slots = _slots(client)
    slots_checked = time.monotonic()

    def top_up() -> None:
        limit = 2 * slots + 2
        while pending and len(submitted) < limit:
            n = chunker.size(len(pending), slots)
            chunk = [pending.popleft() for _ in range(n)]
            future = client.submit(_run_chunk, fn, chunk, pure=False)
            submitted[future.key] = chunk
            live[future.key] = future
            queue.add(future)

    try:
        top_up()
        while not queue.is_empty():
            batch = queue.next_batch(block=True)
            finished = [f for f in batch if f.status == "finished"]
            results = client.gather(finished) if finished else []
            for future, rows in zip(finished, results, strict=True):
                chunk = submitted.pop(future.key)
                by_index = dict(chunk)
                chunker.observe(r[4] for r in rows)
                for index, value, error, input_error, elapsed, cpu, worker, detail in rows:
                    if bar is not None:
                        bar.advance(failed=error is not None)
                    yield Outcome(index, by_index[index], value, error, input_error, elapsed,
                                  cpu, worker, detail)
            for future in batch:
                if future.status == "finished":
                    continue
                chunk = submitted.pop(future.key)
                exc = future.exception() if future.status == "error" else None
                error = (f"{type(exc).__name__}: {exc}" if exc is not None
                         else f"task {future.status}")
                for index, task in chunk:
                    if bar is not None:
                        bar.advance(failed=True)
                    yield Outcome(index, task, None, error)
            for future in batch:
                live.pop(future.key, None)
                future.release()
            if time.monotonic() - slots_checked > 2.0:
                slots = _slots(client)
                slots_checked = time.monotonic()
            top_up()
    finally:
        if live:
            client.cancel(list(live.values()), force=True)
