"""Which colour frames the laser skipped: a duty-cycled depth camera keeps streaming colour while its laser is
off, so a colour frame that no depth frame of its stamp joins is a slot to synthesize. One rule for every
path that meets both streams (the ROS 2 node, a live RealSense, a bag): a colour frame waits ``wait_s`` for
its depth frame, then comes due unless a depth frame of its stamp came or synthesis already has a newer
source. Torch-free."""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from d2sr.errors import InputError
from d2sr.frames.base import Frame
from d2sr.frames.colour import PAIR_NS

__all__ = ["PAIR_NS", "WAIT_S", "ColourFrame", "ColourGaps", "interleave"]

WAIT_S = 0.1  # how long a colour frame waits for its depth frame before the laser is taken to be off
KEEP = 90  # frames remembered of each stream (3 s at 30 Hz)


@dataclass(frozen=True)
class ColourFrame:
    """A colour frame: its stamp (ns), image, when it reached the host (s, any clock that ``due`` gets) and
    whatever the caller carries with it (a message header)."""

    stamp: int
    image: np.ndarray
    arrival: float
    extra: Any = None


class ColourGaps:
    """Pairs a depth stream with its colour stream by stamp and says which colour frames have no depth frame.

    Feed ``colour`` and ``depth`` as frames arrive (``depth`` returns the colour frames it leaves unjoined;
    ``coming`` says a depth frame arrived that ``depth`` will see later, so its colour frame waits for it),
    ``real`` when a depth frame becomes synthesis's source, and ask ``due(now)`` for the colour frames that
    waited long enough, oldest first; ``flush`` ends a stream. ``colour_at`` gives a depth frame its
    colour."""

    def __init__(self, pair_ns: int = PAIR_NS, wait_s: float = WAIT_S, keep: int = KEEP) -> None:
        self.pair_ns, self.wait_s = pair_ns, wait_s
        self._colours: deque[ColourFrame] = deque(maxlen=keep)  # recent ones, for pairing
        self._pending: deque[ColourFrame] = deque(maxlen=keep)  # not yet paired nor synthesized
        self._depths: deque[int] = deque(maxlen=keep)  # arrived (``coming``) or paired (``depth``)
        self._source = -1  # stamp of the newest depth frame synthesis starts from

    def colour(self, frame: ColourFrame) -> None:
        self._colours.append(frame)
        self._pending.append(frame)

    def depth(self, stamp: int) -> list[ColourFrame]:
        """A depth frame of ``stamp`` came (depth frames come in time order). Returns the colour frames
        older than it still waiting: no depth frame can join them now, so they are due, before this frame
        becomes synthesis's source."""
        if stamp not in self._depths:  # not already said to be ``coming``
            self._depths.append(stamp)
        out = []
        while self._pending and self._pending[0].stamp < stamp - self.pair_ns:
            out.extend(self._take())
        return out

    def coming(self, stamp: int) -> None:
        """A depth frame of ``stamp`` arrived but waits its turn: its colour frame is joined, not due, however
        long the wait."""
        self._depths.append(stamp)

    def real(self, stamp: int) -> None:
        self._source = max(self._source, stamp)

    def colour_at(self, stamp: int) -> np.ndarray | None:
        """The colour image taken with the depth frame of ``stamp``, if it came."""
        c = self.joined(stamp)
        return None if c is None else c.image

    def joined(self, stamp: int) -> ColourFrame | None:
        """The colour frame taken with the depth frame of ``stamp``, if it came."""
        for c in self._colours:
            if abs(c.stamp - stamp) <= self.pair_ns:
                return c
        return None

    def newest(self) -> int | None:
        """The newest colour frame's stamp."""
        return self._colours[-1].stamp if self._colours else None

    def due(self, now: float) -> list[ColourFrame]:
        """Colour frames that waited ``wait_s`` with no depth frame of their stamp: the laser skipped them."""
        out = []
        while self._pending and now - self._pending[0].arrival >= self.wait_s:
            out.extend(self._take())
        return out

    def flush(self) -> list[ColourFrame]:
        """Every colour frame still waiting, judged now (the end of a stream)."""
        out = []
        while self._pending:
            out.extend(self._take())
        return out

    def _take(self) -> list[ColourFrame]:
        c = self._pending.popleft()
        paired = any(abs(s - c.stamp) <= self.pair_ns for s in self._depths)
        # a colour frame older than synthesis's source would be made from the future: skipped
        return [] if paired or c.stamp < self._source else [c]


def interleave(
    depths: Iterable[Frame], colours: Iterable[tuple[int, np.ndarray]], pair_ns: int = PAIR_NS
) -> Iterator[tuple[Frame | None, np.ndarray | None, int]]:
    """A recording's depth and colour streams in time order, the ``ColourGaps`` rule applied offline:
    ``(depth frame, its colour or None, stamp)`` for each depth frame, ``(None, colour image, stamp)`` for
    each colour frame no depth frame joins (a slot the laser skipped). Each stream in its own time order,
    with stamps (ns)."""
    gaps = ColourGaps(pair_ns)
    it = iter(colours)
    ahead = next(it, None)
    for frame in depths:
        t = frame.timestamp_ns
        if t is None:
            raise InputError(f"{frame.name}: no timestamp to pair its colour frame by")
        while ahead is not None and ahead[0] <= t + pair_ns:
            gaps.colour(ColourFrame(ahead[0], ahead[1], ahead[0] / 1e9))
            ahead = next(it, None)
        for c in gaps.depth(t):  # colour frames before this moment that no depth frame joined
            yield None, c.image, c.stamp
        yield frame, gaps.colour_at(t), t
        gaps.real(t)
    for c in gaps.flush():
        yield None, c.image, c.stamp
    while ahead is not None:  # after the last depth frame
        yield None, ahead[1], ahead[0]
        ahead = next(it, None)
