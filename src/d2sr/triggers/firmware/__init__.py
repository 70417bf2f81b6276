"""The reference firmware of the ``serial`` trigger (MicroPython): ``d2sr_trigger.py`` is the protocol and
slot clock, ``main.py`` the board's entry point. The host's own actuators run the same ``Core``."""

from pathlib import Path

FOLDER = Path(__file__).parent
FILES = ("d2sr_trigger.py", "main.py")
