"""The trigger firmware's protocol: a 30-slot clock that pulses a camera's sync input on the active slots
of the window the host sets. Pure Python that runs unchanged on MicroPython (RP2040, ESP32) and on the host,
where the tests drive it through a pseudo-terminal.

Lines, ASCII, ending in a newline. Host to device:
  HELLO                        -> D2SR <version> <slots> <slot_us> <pulse_us>
  CFG <slots> <slot_us> <pulse_us>  -> OK CFG ...   (stops the clock; pulse_us 0: the line is held
                                                   high through the window, as the L515 needs)
  START <period>               -> OK START <period> (slot 0 of that period begins now)
  WIN <period> <offset> <active>    -> OK WIN ...   (the window from that period on)
  STOP                         -> OK STOP           (no more pulses; the line rests low)
  PING <tag>                   -> pulses once now, then PONG <tag> <t_us> (for checks, while stopped)
Device to host, unasked:
  P <period> <slot> <t_us>     a pulse began (an active slot)
  E <period>                   that period's last slot is over
  ERR <text>                   a line it could not take
"""

VERSION = 1


class Core:
    """The clock and the protocol. ``write(v)`` sets the sync line (1 = pulse), ``now()`` gives
    microseconds, ``diff(a, b)`` and ``add(a, b)`` are ``a - b`` and ``a + b`` on a clock that may wrap
    (MicroPython's ticks_diff and ticks_add), ``send(text)`` writes one line to the host."""

    def __init__(self, write, now, send, diff=None, add=None, slots=30, slot_us=33333, pulse_us=1000):
        self.write = write
        self.now = now
        self.send = send
        self.diff = diff if diff is not None else (lambda a, b: a - b)
        self.add = add if add is not None else (lambda a, b: a + b)
        self.slots = slots
        self.slot_us = slot_us
        self.pulse_us = pulse_us
        self.windows = {}  # period -> (offset, active), the latest at or before a period applies
        self.running = False
        self.period = 0
        self.slot = 0
        self.t0 = 0  # when the current slot began
        self.high_since = None  # when a pulse began
        self.level = 0
        write(0)

    # -- commands --
    def line(self, text):
        words = text.strip().split()
        if not words:
            return
        cmd, args = words[0].upper(), words[1:]
        try:
            nums = [int(a) for a in args]
        except ValueError:
            self.send("ERR not a number: " + text.strip())
            return
        if cmd == "HELLO" and not nums:
            self.send("D2SR %d %d %d %d" % (VERSION, self.slots, self.slot_us, self.pulse_us))
        elif cmd == "CFG" and len(nums) == 3 and nums[0] > 0 and 0 <= nums[2] < nums[1]:
            self.slots, self.slot_us, self.pulse_us = nums
            self.running = False
            self._low()
            self.send("OK CFG %d %d %d" % (self.slots, self.slot_us, self.pulse_us))
        elif cmd == "START" and len(nums) == 1:
            self.period, self.slot, self.t0, self.running = nums[0], 0, self.now(), True
            self.send("OK START %d" % nums[0])
            self._slot_began(self.t0)
        elif cmd == "WIN" and len(nums) == 3 and 0 <= nums[1] < self.slots and 0 <= nums[2] <= self.slots:
            self.windows[nums[0]] = (nums[1], nums[2])
            self._prune()
            self.send("OK WIN %d %d %d" % tuple(nums))
        elif cmd == "STOP" and not nums:
            self.running = False
            self._low()
            self.send("OK STOP")
        elif cmd == "PING" and len(nums) == 1:
            t = self.now()
            self._high(t)
            self.send("PONG %d %d" % (nums[0], t))
        else:
            self.send("ERR bad command: " + text.strip())

    def active(self, period, slot):
        """Whether ``slot`` of ``period`` lies in the window set for that period (none set: off)."""
        known = [p for p in self.windows if p <= period]
        if not known:
            return False
        offset, n = self.windows[max(known)]
        return (slot - offset) % self.slots < n

    # -- the clock --
    def poll(self):
        """Advance the clock to now; returns the microseconds until the next thing to do."""
        t = self.now()
        wait = self.slot_us
        if self.high_since is not None:
            left = (self.pulse_us or 100) - self.diff(t, self.high_since)
            if left <= 0:
                self._low()
            else:
                wait = left
        if not self.running:
            return wait
        while self.diff(t, self.t0) >= self.slot_us:
            self.t0 = self.add(self.t0, self.slot_us)
            if self.slot == self.slots - 1:
                self.send("E %d" % self.period)
                self.period, self.slot = self.period + 1, 0
                self._prune()
            else:
                self.slot += 1
            self._slot_began(self.t0)
        return min(wait, self.slot_us - self.diff(t, self.t0))

    def _prune(self):
        """Forget windows that no period from now on can use (a board has little memory)."""
        known = [p for p in self.windows if p <= self.period]
        for p in known:
            if p != max(known):
                del self.windows[p]

    def _slot_began(self, t):
        on = self.active(self.period, self.slot)
        if self.pulse_us == 0:  # level: up through the window, written on change only
            if on != self.level:
                self.level = 1 if on else 0
                self.write(self.level)
        elif on:
            self._high(t)
        if on:
            self.send("P %d %d %d" % (self.period, self.slot, t))

    def _high(self, t):
        self.write(1)
        self.level = 1
        self.high_since = t

    def _low(self):
        self.write(0)
        self.level = 0
        self.high_since = None
