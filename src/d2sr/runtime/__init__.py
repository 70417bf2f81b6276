"""The core on a sensor's own computer, torch-free: one run's settings, the sensor's loop, the library's
``Pipeline`` and ``repair``, the frames repaired on several threads, and the onnxruntime backend
(``d2sr.runtime.backends.open_backend`` opens it, or torch's). The jobs that use it are ``d2sr.jobs``."""

from d2sr.runtime.backends import Backend, OnnxBackend

__all__ = ["Backend", "OnnxBackend"]
