"""The closed loop on a sensor's own computer, torch-free: the loop, its sources and sinks, run folders,
and the onnxruntime backend (``d2sr.runtime.backends.open_backend`` opens it, or torch's)."""

from d2sr.runtime.backends import Backend, OnnxBackend

__all__ = ["Backend", "OnnxBackend"]
