"""Running the learned stages on frames: inference backends (onnxruntime without torch, or torch)."""

from d2sr.runtime.backends import Backend, OnnxBackend, open_backend

__all__ = ["Backend", "OnnxBackend", "open_backend"]
