"""d2sr's version, a leaf: provenance stamps it on every output, the CLI prints it, the wheel takes it."""

__version__ = "0.10.0"
