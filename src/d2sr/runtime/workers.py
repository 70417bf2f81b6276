"""Frames repaired on several threads while the next are judged in order: how many at once on this machine
(``repair_workers``) and the loop's results in order (``in_order``). ``d2sr recover`` and the ROS 2 node
both run it."""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor

from d2sr.runtime.loop import Capture, Result, SensorLoop

__all__ = ["in_order", "repair_workers"]


def in_order(loop: SensorLoop, captures: Iterable[Capture], workers: int) -> Iterator[Result]:
    """``loop``'s results for ``captures``, in order. Frames are decided in order (``SensorLoop.decide``)
    and repaired on ``workers`` threads while the next are decided; at most 2 x ``workers`` wait."""
    if workers <= 1:
        yield from map(loop.process, captures)
        return
    with ThreadPoolExecutor(workers) as pool:
        running: deque[Future[Result]] = deque()
        for cap in captures:
            running.append(pool.submit(loop.finish, loop.decide(cap)))
            if len(running) >= 2 * workers:
                yield running.popleft().result()
        while running:
            yield running.popleft().result()


def repair_workers(cores: int | None = None) -> tuple[int, int | None]:
    """(frames repaired at once, onnxruntime threads each) on ``cores`` (default: the machine's): on 2
    cores, two frames on one thread each repair more frames a second than one frame on two (the guard and
    write-back run on one core, and the model scales poorly). torch has threads of its own: one frame at
    a time."""
    cores = cores if cores is not None else os.cpu_count() or 1
    workers = min(cores, 4)
    return workers, (cores // workers if workers > 1 else None)
