"""The model catalogue (d2sr.contract.catalog): sizes and padding, the files a model is made of, the temporal
detector's gate."""

from __future__ import annotations

import numpy as np
import pytest

from d2sr.contract.catalog import (
    CATALOG,
    PAD,
    REPAIR_MODELS,
    WEIGHTS,
    check_size,
    gate,
    model_files,
    padded,
    pair_path,
)
from d2sr.errors import InputError


def test_padding_reaches_the_stride_with_no_return_and_sizes_are_checked():
    x = np.ones((1, 240, 330), np.float32)
    p = padded(x)
    assert p.shape[-2] % PAD == 0 and p.shape[-1] % PAD == 0
    assert (p[..., :240, :330] == 1).all() and (p[..., 240:, :] == 0).all() and (p[..., :, 330:] == 0).all()
    check_size(64, 96, 32, None, "unet8")
    with pytest.raises(InputError, match="unet8"):
        check_size(65, 96, 32, None, "unet8")


def test_a_model_is_its_weights_its_export_and_a_streaming_model_s_second_file(tmp_path):
    assert model_files(tmp_path, "detector") == []
    for f in ("detector.safetensors", "detector.onnx"):
        (tmp_path / f).write_bytes(b"x")
    pair_path(tmp_path / "detector.onnx").write_bytes(b"x")
    names = [f.name for f in model_files(tmp_path, "detector")]
    assert names == ["detector.safetensors", "detector.onnx", "detector.pair.onnx"]
    shipped = {n for n, e in CATALOG.items() if e.shipped}
    assert all((WEIGHTS / f"{n}.onnx").is_file() for n in shipped)
    assert "auto" in REPAIR_MODELS and all(CATALOG[n].kind == "recovery" for n in REPAIR_MODELS[1:])


def test_the_gate_scores_the_pair_only_where_the_frame_alone_reaches_the_cut():
    alone = np.array([0.9, 0.2, 0.7], np.float32)
    asked = []

    def pair(rows: np.ndarray) -> np.ndarray:
        asked.append(rows.copy())
        return np.full(int(rows.sum()), 0.4, np.float32)

    out = gate(alone, 0.5, pair)
    assert np.array_equal(asked[0], [True, False, True])
    assert np.allclose(out, [0.4, 0.2, 0.4])  # lowered where asked, below the cut either way elsewhere
    assert np.allclose(gate(alone, None, pair), [0.4, 0.2, 0.4])  # exact: every frame with its pair
