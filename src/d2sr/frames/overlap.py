"""Reading ahead and writing behind on threads of their own, so that decoding and encoding frames (OpenCV
releases the GIL) overlap the work on the frame in between."""

from __future__ import annotations

import queue
import threading
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, TypeVar

__all__ = ["Behind", "prefetch"]

T = TypeVar("T")


def prefetch(items: Iterable[T], depth: int = 4) -> Iterator[T]:
    """Produce ``items`` on a thread, ``depth`` ahead (PNG decoding releases the GIL, so reading overlaps
    inference), re-raising its errors here."""
    q: queue.Queue[Any] = queue.Queue(depth)
    done = object()

    def run() -> None:
        try:
            for it in items:
                q.put(it)
        except BaseException as exc:
            q.put(exc)
        q.put(done)

    threading.Thread(target=run, daemon=True).start()
    while (it := q.get()) is not done:
        if isinstance(it, BaseException):
            raise it
        yield it


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
