"""The no-D2SR baseline: a random offset that never moves."""

from __future__ import annotations

from d2sr.desync.base import Controller

__all__ = ["StaticController"]


class StaticController(Controller):
    """Keeps its random initial offset forever."""

    name = "static"

    def _shift(self, flags: list[bool]) -> int:
        return 0
