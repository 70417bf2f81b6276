"""Stage 2: decentralized de-synchronization controllers (numpy only).

```python
from d2sr.desync import make_controller, DEFAULT_CONTROLLER
c = make_controller(name, total_frames=30, active_frames=n, seed=0)
c.offset        # first active slot of the next period, 0 <= offset < total_frames
c.update(flags) # the n detections (bools, time order) of the period that ended -> new offset
```
"""

from __future__ import annotations

from typing import Any

from d2sr.desync.base import DEFAULT_ACTIVE, TOTAL_FRAMES, Controller, check_window
from d2sr.desync.damped import DampedController
from d2sr.desync.oracle import OracleController
from d2sr.desync.paper import PaperController
from d2sr.desync.robust import RobustController
from d2sr.desync.static import StaticController
from d2sr.errors import ConfigError

__all__ = [
    "CONTROLLERS",
    "DEFAULT_ACTIVE",
    "DEFAULT_CONTROLLER",
    "TOTAL_FRAMES",
    "Controller",
    "make_controller",
]

#: Every controller by name. "oracle" needs the timing world (global knowledge); the rest are decentralized.
CONTROLLERS: dict[str, type[Controller]] = {
    c.name: c
    for c in (StaticController, PaperController, RobustController, DampedController, OracleController)
}

#: The project's best decentralized controller: at or below the paper's Algorithm 1 across deployment
#: assumptions (d2sr desync grid), better where Algorithm 1 stalls.
DEFAULT_CONTROLLER = RobustController.name


def make_controller(
    name: str, total_frames: int = TOTAL_FRAMES, active_frames: int = 15, seed: int | None = 0, **options: Any
) -> Controller:
    """Build a controller by registry name; ``options`` go to its constructor (e.g. ``setup=2``)."""
    cls = CONTROLLERS.get(name)
    if cls is None:
        raise ConfigError(f"unknown controller {name!r}; choose one of: {', '.join(CONTROLLERS)}")
    check_window(total_frames, active_frames)
    try:
        return cls(total_frames, active_frames, seed, **options)
    except TypeError as exc:
        raise ConfigError(f"controller {name!r}: {exc}") from None
