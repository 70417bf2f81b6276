"""Reading ahead on a thread (``prefetch``): items in order, the reader's errors in the caller, and a
block left early (an error, an exit) stops the thread before the caller goes on."""

from __future__ import annotations

import subprocess
import sys
import threading
from collections.abc import Iterator

import pytest

from d2sr.frames.overlap import prefetch
from helpers import ROOT


def test_items_come_in_order_and_the_readers_error_in_the_caller():
    def items() -> Iterator[int]:
        yield from range(5)
        raise ValueError("frame 5 is damaged")

    got = []
    with pytest.raises(ValueError, match="frame 5"), prefetch(items(), depth=2) as frames:
        got.extend(frames)
    assert got == [0, 1, 2, 3, 4]


def test_leaving_the_block_early_stops_the_reader():
    produced = []

    def items() -> Iterator[int]:
        for i in range(10_000):
            produced.append(i)
            yield i

    before = threading.active_count()
    with pytest.raises(RuntimeError), prefetch(items(), depth=3) as frames:
        for i in frames:
            if i == 2:
                raise RuntimeError("the caller failed")
    assert threading.active_count() == before  # the reader's thread has ended
    n = len(produced)
    assert n <= 2 + 3 + 2  # what was taken, the queue's depth, the item in hand and the one it waited on
    assert len(produced) == n  # and it reads no more


# Decoding large PNGs on the reader's thread while the caller exits: a thread left inside OpenCV when the
# interpreter finalizes aborted the process (exit 134, "terminate called without an active exception").
_EXIT_WHILE_DECODING = """
import cv2, numpy as np
from d2sr.frames.overlap import prefetch
png = cv2.imencode('.png', (np.random.default_rng(0).random((1500, 1500)) * 65535).astype(np.uint16))[1]
def items():
    while True:
        yield cv2.imdecode(png, cv2.IMREAD_UNCHANGED)
with prefetch(items()) as frames:
    for i, _ in enumerate(frames):
        if i == 2:
            raise SystemExit(2)
"""


def test_exiting_while_the_reader_decodes_gives_the_callers_exit_code():
    for _ in range(3):
        r = subprocess.run(
            [sys.executable, "-c", _EXIT_WHILE_DECODING],
            capture_output=True, text=True, cwd=ROOT, timeout=120, check=False,
        )  # fmt: skip
        assert r.returncode == 2, r.stderr[-500:]
        assert "terminate called" not in r.stderr
