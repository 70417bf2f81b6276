"""``d2sr trigger check|firmware``: try a trigger line without a camera; copy the board's firmware."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Annotated

import typer

from d2sr.cli.common import Overwrite, out_dir
from d2sr.desync.base import DEFAULT_ACTIVE
from d2sr.ui import print_line

__all__ = ["check", "firmware"]


def check(
    spec: Annotated[
        str, typer.Argument(help="serial:PORT[@INPUT] or gpio:CHIP:LINE[@INPUT].", metavar="SPEC")
    ],
    active_frames: Annotated[
        int, typer.Option(help="Window length the clock runs (slots of 30).")
    ] = DEFAULT_ACTIVE,
    seconds: Annotated[float, typer.Option(help="How long to run the clock.")] = 3.0,
    pings: Annotated[int, typer.Option(help="Round trips to time (serial).")] = 100,
) -> None:
    """Exercise a trigger line with no camera: the firmware's answer and round trip (serial), then the slot
    clock with a window, counting the pulses it reported.

    Example: d2sr trigger check serial:/dev/ttyACM0
    """
    from d2sr.jobs.trigger_check import check_trigger

    for line in check_trigger(spec, active_frames, seconds, pings).lines():
        print_line(line)


def firmware(
    out: Annotated[
        Path, typer.Option(help="Folder for d2sr_trigger.py and main.py (copy both to the board).")
    ],
    overwrite: Overwrite = False,
) -> None:
    """Write the serial trigger's MicroPython firmware to a folder, for `mpremote cp`.

    Example: d2sr trigger firmware --out fw/ && mpremote cp fw/d2sr_trigger.py fw/main.py :
    """
    from d2sr.triggers.firmware import FILES, FOLDER

    with out_dir(out, overwrite) as tmp:
        for name in FILES:
            shutil.copyfile(FOLDER / name, tmp / name)
    print_line(f"firmware ({', '.join(FILES)}) -> {out}; wiring: docs/hardware.md")
