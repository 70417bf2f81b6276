"""The trigger firmware's Core on the far end of a pseudo-terminal, as a microcontroller on USB would run it:
what the serial trigger's tests and bench talk to where no board is plugged in."""

from __future__ import annotations

import os
import select
import threading
import time
import tty
from collections.abc import Callable

from d2sr.triggers.firmware.d2sr_trigger import Core


class Board:
    """The firmware's Core on the far end of a pseudo-terminal, as a microcontroller on USB would run it;
    ``on_edge(level, period, slot)`` is the camera's sync input."""

    def __init__(self, on_edge: Callable[[int, int, int], object] | None = None, answer: bool = True) -> None:
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self.edges: list[tuple[float, int, int, int]] = []
        self.on_edge = on_edge
        self.answer = answer
        self._stop = threading.Event()
        self.core = Core(self._write, lambda: time.monotonic_ns() // 1000, self._send)
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _write(self, level: int) -> None:
        if not hasattr(self, "core"):
            return  # the Core's own line reset in its constructor
        edge = (time.monotonic(), level, self.core.period, self.core.slot)
        self.edges.append(edge)
        if self.on_edge is not None:
            self.on_edge(*edge[1:])

    def _send(self, text: str) -> None:
        os.write(self.master, (text + "\n").encode())

    def _run(self) -> None:
        buf = b""
        while not self._stop.is_set():
            wait = self.core.poll()
            ready, _, _ = select.select([self.master], [], [], min(wait, 5000) / 1e6)
            if ready:
                buf += os.read(self.master, 1024)
                *lines, buf = buf.split(b"\n")
                for line in lines:
                    if self.answer:
                        self.core.line(line.decode())

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        os.close(self.master)
        os.close(self._slave)
