from pathlib import Path

import pytest
import torch
from hypothesis import settings

settings.register_profile("ci", max_examples=60, deadline=None)
settings.load_profile("ci")


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
