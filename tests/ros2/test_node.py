"""The node's own start-up (d2sr.ros2.node), apart from DDS."""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor
from types import SimpleNamespace

import numpy as np

from d2sr.ros2.node import Ros2Node


def test_the_node_runs_every_model_once_before_its_first_frame_on_the_thread_that_runs_it():
    """A model's first run at a size, and a thread's first frame-size buffers, cost many times a later
    frame's: the detector alone and the temporal detector's second model (with a frame before) run once
    on the node's thread, which judges, and the recovery model once on each worker, which repairs, before
    the node reads (the stream's second frame took 65 ms where its neighbours took 30)."""
    calls: list[tuple[str, bool, str]] = []

    class Net:
        def scores(self, metres: np.ndarray, previous: np.ndarray | None, cut: float | None = None) -> None:
            calls.append(("scores", previous is not None, threading.current_thread().name))

        def recover(self, metres: np.ndarray, previous: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
            calls.append(("recover", previous is not None, threading.current_thread().name))
            return metres.copy(), np.zeros(metres.shape, bool)

    with ThreadPoolExecutor(2, thread_name_prefix="worker") as pool:
        node = SimpleNamespace(
            cameras=[SimpleNamespace(pipeline=SimpleNamespace(backend=Net()))], _pool=pool, _workers=2
        )
        Ros2Node._warm_up(node)  # type: ignore[arg-type]
    here = threading.current_thread().name
    assert calls.count(("scores", True, here)) == 2  # onnxruntime's second run is the first at full speed
    repaired_on = [t for kind, _, t in calls if kind == "recover"]
    assert len(set(repaired_on)) == 2 and here not in repaired_on and len(repaired_on) == 4
