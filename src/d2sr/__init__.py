"""d2sr: decentralized detection, de-synchronization and recovery of depth-sensor interference."""

__version__ = "0.10.0"

__all__ = ["__version__"]
