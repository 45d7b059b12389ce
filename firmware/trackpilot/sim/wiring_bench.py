"""Wiring for a board on the bench: the unix port with nothing attached.

The devices are streams that never deliver a byte and swallow what is written; the clock is the
real one. The App runs exactly as on a boat with every cable unplugged: STANDBY, GNSS stale,
pilot silent. Used to test the maintenance state and transfers against the real application
under the unix port (tests/host/_device_main.py).
"""
import time

from trackpilot.compat import TICKS_MASK
from trackpilot.sim.simio import SimLink
from trackpilot.sim.wiring_sim import Wiring as _SimWiring


class BenchLink:
    """What wiring_sim needs from a link: streams and a clock, here without a simulator."""

    def __init__(self):
        self.streams = {}
        self.t0 = time.ticks_ms()

    @property
    def t_ms(self):
        return time.ticks_diff(time.ticks_ms(), self.t0)

    def ticks_ms(self):
        return time.ticks_ms() & TICKS_MASK

    stream = SimLink.stream  # the same lazily created SimStreams as in simulation


class Wiring(_SimWiring):
    def __init__(self, data_dir, quiet=True):
        _SimWiring.__init__(self, BenchLink(), data_dir, seed=time.ticks_ms() & 0xFFFF, quiet=quiet)
