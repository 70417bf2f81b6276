"""What this installation is, a leaf: d2sr's version (provenance stamps it on every output, the CLI prints
it, the wheel takes it) and where its shipped weights lie."""

from pathlib import Path

__version__ = "0.10.0"
WEIGHTS = Path(__file__).resolve().parent / "models" / "weights"  # the shipped weights, ONNX and cards
