# Types of the firmware's protocol core (the .py stays plain for MicroPython).
from collections.abc import Callable

VERSION: int

class Core:
    slots: int
    slot_us: int
    pulse_us: int
    windows: dict[int, tuple[int, int]]
    running: bool
    period: int
    slot: int
    t0: int
    level: int
    def __init__(
        self,
        write: Callable[[int], object],
        now: Callable[[], int],
        send: Callable[[str], object],
        diff: Callable[[int, int], int] | None = ...,
        add: Callable[[int, int], int] | None = ...,
        slots: int = ...,
        slot_us: int = ...,
        pulse_us: int = ...,
    ) -> None: ...
    def line(self, text: str) -> None: ...
    def active(self, period: int, slot: int) -> bool: ...
    def poll(self) -> int: ...
