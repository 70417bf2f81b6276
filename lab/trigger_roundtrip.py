"""Benchmark: the serial trigger against its firmware's own protocol code on the far end of a pseudo-terminal
(tools/trigger_board.py; no board is plugged in here).

* ``round_trip``: ``--pings`` PING commands, each timed from the host's write to reading the reply the
  firmware writes once its line is up: the command-to-pulse round trip (median, p99, max).
* ``slots``: ``--seconds`` of the clock with a 6-slot window: how far each pulse's rising edge lies from its
  slot's ideal start (the board's own clock), and from the host's estimate of it (``SlotClock``), which
  decides each frame's slot.

A real board adds its USB CDC transfer (about 1 ms each way at full speed) and its MicroPython loop
(select.poll, up to 1 ms); docs/hardware.md says what was and was not measured on hardware.

Run:  python -m lab.trigger_roundtrip --json docs/results/trigger_roundtrip.json
"""

from __future__ import annotations

import argparse
import time

from bench.harness import check_output, output_args
from tools.trigger_board import Board

from d2sr.atomic import write_result
from d2sr.jobs.stats import median_p99_ms
from d2sr.triggers import open_trigger


def ms(values: list[float]) -> dict[str, float]:
    median, p99 = median_p99_ms(values)
    return {
        "n": len(values),
        "median_ms": round(median, 3),
        "p99_ms": round(p99, 3),
        "max_ms": round(max(values) * 1e3, 3),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pings", type=int, default=1000)
    ap.add_argument("--seconds", type=float, default=10.0)
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    board = Board()
    try:
        with open_trigger(f"serial:{board.path}@d400", active_frames=6) as act:
            trips = act.round_trips(args.pings)
            act.set_offset(0, 10)
            act.start()
            time.sleep(args.seconds)
            pulses = list(act.pulses)
            slot_s = act.clock.slot_s
            host_start = act.clock.start_s
        starts = [e for e in board.edges if e[1] == 1][args.pings :]  # after the PINGs' own pulses
        first = starts[0]
        board_err = [
            (t - first[0]) - ((p - first[2]) * 30 + (s - first[3])) * slot_s for t, _, p, s in starts
        ]
        host_err = [p.host_s - (host_start + (p.period * 30 + p.slot) * slot_s) for p in pulses]
    finally:
        board.close()
    result = {
        "transport": "pseudo-terminal (os.openpty + pyserial), firmware Core in a host thread",
        "round_trip": ms(trips),
        "pulse_late_vs_board_clock": ms([abs(e) for e in board_err]),
        "report_late_vs_host_estimate": ms(host_err),
        "pulses": len(starts),
    }
    print(write_result(result, args.json))


if __name__ == "__main__":
    main()
