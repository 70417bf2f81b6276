"""Work beside the caller's thread: reading ahead and writing behind on threads of their own, so that
decoding and encoding frames (OpenCV releases the GIL) overlap the work on the frame in between; and pools of
worker processes that end with the caller (``processes``)."""

from __future__ import annotations

import contextlib
import queue
import signal
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor, ThreadPoolExecutor
from contextlib import contextmanager
from typing import Any, TypeVar

from d2sr.config import check_whole

__all__ = ["MAX_WORKERS", "Behind", "prefetch", "processes"]

T = TypeVar("T")


# How long a stopped reader or worker may take to finish what it is doing (a frame's decode) before the
# caller goes on without it.
STOP_S = 10.0
MAX_WORKERS = 256  # processes one job starts, at most (a hundred thousand asked took the machine's memory)


@contextmanager
def processes(workers: int) -> Iterator[ProcessPoolExecutor]:
    """A pool of ``workers`` processes that ends with its caller: when the block is left by an error or an
    interrupt, the work not started is cancelled and the workers are ended. ProcessPoolExecutor's own exit
    waits for every task queued, so a Ctrl-C on a long simulation ran on for hours."""
    check_whole("workers", workers, 1, MAX_WORKERS)
    pool = ProcessPoolExecutor(workers, initializer=_worker_signals)
    try:
        yield pool
    except BaseException:
        workers_now = list((getattr(pool, "_processes", None) or {}).values())  # no public way before 3.14
        pool.shutdown(wait=False, cancel_futures=True)
        for proc in workers_now:
            proc.terminate()
        for proc in workers_now:
            proc.join(STOP_S)
        raise
    pool.shutdown(wait=True)


def _worker_signals() -> None:
    """A worker leaves Ctrl-C to its caller, which ends it, and ends at once when told to (forked, it would
    otherwise raise the caller's KeyboardInterrupt and print a traceback of its own)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


@contextmanager
def prefetch(items: Iterable[T], depth: int = 4) -> Iterator[Iterator[T]]:
    """``items``, produced on a thread ``depth`` ahead (PNG decoding releases the GIL, so reading overlaps
    inference), its errors re-raised in the caller. Leaving the block stops the thread and waits for it:
    a thread still inside a decoder when the interpreter exits (an error, Ctrl-C) aborts the process
    ("terminate called without an active exception", exit 134) instead of the exit code d2sr gives."""
    q: queue.Queue[Any] = queue.Queue(depth)
    done = object()
    stop = threading.Event()

    def run() -> None:
        try:
            for it in items:
                q.put(it)
                if stop.is_set():
                    return
        except BaseException as exc:
            q.put(exc)
        q.put(done)

    def produced() -> Iterator[T]:
        while (it := q.get()) is not done:
            if isinstance(it, BaseException):
                raise it
            yield it

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    try:
        yield produced()
    finally:
        stop.set()
        end = time.monotonic() + STOP_S
        while thread.is_alive() and time.monotonic() < end:
            with contextlib.suppress(queue.Empty):  # make room for the put it may be waiting on
                while True:
                    q.get_nowait()
            thread.join(0.02)


class Behind:
    """Work on a thread of its own, at most ``depth`` items behind the caller: PNG encoding overlaps the
    next frame's inference, and a slow disk cannot pile frames up in memory."""

    def __init__(self, depth: int = 4) -> None:
        self._pool = ThreadPoolExecutor(1)
        self._pending: deque[Future[None]] = deque()
        self._depth = depth

    def submit(self, fn: Callable[..., None], *args: Any, **kwargs: Any) -> None:
        self._pending.append(self._pool.submit(fn, *args, **kwargs))
        while len(self._pending) > self._depth:
            self._pending.popleft().result()

    def drain(self) -> None:
        """Wait for everything handed over (re-raising its errors)."""
        while self._pending:
            self._pending.popleft().result()

    def close(self) -> None:
        self._pool.shutdown(wait=True)
