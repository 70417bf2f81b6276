import os
import sys
from pathlib import Path

import pytest
import torch
from hypothesis import settings

settings.register_profile("ci", max_examples=60, deadline=None)
settings.load_profile("ci")

_VERDICT: list[int] = []


def pytest_sessionfinish(session, exitstatus) -> None:
    _VERDICT.append(int(exitstatus))


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config) -> None:
    """Leave with the suite's verdict, without the interpreter's teardown. Native libraries this suite loads
    in-process (onnxruntime, librealsense's software device, Cyclone DDS, torch) keep threads of their own,
    and once in four full runs here one aborted that teardown after every test had passed ("terminate
    called without an active exception", exit 134). The verdict is in by then. Not under mutmut, which runs
    the suite in its own process and goes on after it (``make mutation``)."""
    # an xdist worker leaves as xdist says
    if _VERDICT and not hasattr(config, "workerinput") and "mutmut" not in sys.modules:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_VERDICT[0])


@pytest.fixture(scope="session")
def weights(tmp_path_factory) -> Path:
    """Random-weight models in a folder laid out like the shipped one (safetensors + onnx)."""
    from d2sr.models import build
    from d2sr.models.onnx.export import export
    from d2sr.models.store import save_model

    root = tmp_path_factory.mktemp("weights")
    torch.manual_seed(0)
    for name in ("detector", "unet8"):
        save_model(build(name).eval(), name, root / f"{name}.safetensors")
        export(root / f"{name}.safetensors", root / f"{name}.onnx")
    return root
