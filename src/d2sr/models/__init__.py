"""Torch models: the frame-level interference detector (stage 1) and the two-head recovery UNet (stage 3).

Every model takes depth in metres, shape (N, 1, H, W), float32, 0 = no return, and normalises inside, so an
exported ONNX file needs no preprocessing beyond the depth scale.
"""

from d2sr.models.detector import FastDetector, PaperDetector
from d2sr.models.registry import MODELS, build, check_input_size, describe
from d2sr.models.unet import UNet

__all__ = [
    "MODELS",
    "FastDetector",
    "PaperDetector",
    "UNet",
    "build",
    "check_input_size",
    "describe",
]
