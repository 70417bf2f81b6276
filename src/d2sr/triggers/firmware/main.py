"""MicroPython entry point for the d2sr trigger (RP2040 / ESP32): copy this file and d2sr_trigger.py to the
board (e.g. ``mpremote cp main.py d2sr_trigger.py :``). The host talks to it over USB serial; see
docs/hardware.md for the wiring of each camera's sync input."""

import select
import sys
import time

import machine
from d2sr_trigger import Core

SYNC_PIN = 15  # GPIO driving the camera's sync input (through a level shifter where it needs 1.8 V)

pin = machine.Pin(SYNC_PIN, machine.Pin.OUT, value=0)


def send(text):
    sys.stdout.write(text + "\n")


core = Core(pin.value, time.ticks_us, send, diff=time.ticks_diff, add=time.ticks_add)

stdin = select.poll()
stdin.register(sys.stdin, select.POLLIN)
buf = ""
while True:
    wait_us = core.poll()
    if stdin.poll(max(0, min(wait_us // 1000, 5))):
        ch = sys.stdin.read(1)
        if ch in "\r\n":
            core.line(buf)
            buf = ""
        elif len(buf) < 64:
            buf += ch
