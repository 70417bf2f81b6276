"""The node's own start-up (d2sr.ros2.node), apart from DDS."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from d2sr.ros2.node import Ros2Node


def test_the_node_runs_every_model_once_before_its_first_frame():
    """A model's first run at a size costs many times a later one: the detector alone, the temporal
    detector's second model (with a frame before) and the recovery model all run once before the node
    reads, so the first frames do not pay it (the second frame took 65 ms where its neighbours took 30)."""
    calls: list[tuple[str, bool]] = []

    class Net:
        def scores(self, metres: np.ndarray, previous: np.ndarray | None, cut: float | None = None) -> None:
            calls.append(("scores", previous is not None))

        def recover(self, metres: np.ndarray, previous: np.ndarray | None) -> None:
            calls.append(("recover", previous is not None))

    node = SimpleNamespace(cameras=[SimpleNamespace(pipeline=SimpleNamespace(backend=Net()))])
    Ros2Node._warm_up(node)  # type: ignore[arg-type]
    assert ("scores", True) in calls and any(c[0] == "recover" for c in calls)
