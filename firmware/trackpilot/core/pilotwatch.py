"""PilotWatch: does the tiller pilot's own heading loop hunt? Seen from its status datagrams.

Fed each new pilot status (0x84, about 2 Hz: its compass and its locked course). The pilot hunts
when its heading keeps swinging about a steady locked course at a regular period: its gain is too
high for its compass lag and ram speed (docs/BENCHMARK_ROBUST.md "pilot alone": about a fifth of
the random boats at 3 m/s). No keystroke law steers that boat straight; a person must turn the
pilot's response or rudder gain down. step() reports it once (an event for the log, the text for
the HMI), and again when it stops. The swing must be the pilot's, not the track loop's: a half
cycle in which the locked course moved by more than half the heading's swing does not count.

A few floats and one SwingWatch (nav/swing.py): nothing allocated per step."""
from trackpilot.compat import wrap180
from trackpilot.nav.swing import SwingWatch

HUNT_TEXT = "pilot hunts: lower its response/rudder gain"


class PilotWatch:
    def __init__(self, hunt_amp_deg=2.5, hunt_need=6):
        # pilot hunting: 3 periods of half cycles of 1..20 s (a pilot loop, not the track loop),
        # +-hunt_amp_deg, each keeping 70 % of the one before (sustained: the ringing after a
        # large course step decays faster)
        self.hunt = SwingWatch(0.5, hunt_amp_deg, hunt_need, min_half_s=1.0, max_half_s=20.0, keep_ratio=0.7)
        self.hunting = False
        self.hunt_amp_deg = 0.0
        self.hunt_period_s = 0.0
        self._status_ms = None
        self._course0 = None  # locked course at the start of the current half cycle
        self._course_moved = 0.0  # largest |locked course change| within it
        self._quiet_s = 0.0

    def step(self, status_ms, dt_s, compass_deg, course_deg):
        """One new pilot status (status_ms: its arrival; repeated calls with the same one are
        ignored). Returns "" or a text to log when hunting starts or stops."""
        if status_ms is None or status_ms == self._status_ms or compass_deg is None or course_deg is None:
            return ""
        self._status_ms = status_ms
        err = wrap180(compass_deg - course_deg)
        if self._course0 is None:
            self._course0 = course_deg
        moved = wrap180(course_deg - self._course0)
        if moved < 0:
            moved = -moved
        if moved > self._course_moved:
            self._course_moved = moved
        side = self.hunt.side
        fired = self.hunt.step(dt_s, err)
        if self.hunt.side != side:  # a new half cycle: was the locked course steady in the last?
            if self._course_moved > 0.5 * self.hunt.amp and self.hunt.counted:
                self.hunt.row = 0  # the course moved as much as the heading: the track loop, not the pilot
                fired = False
            self._course0 = course_deg
            self._course_moved = 0.0
        if fired and not self.hunting:
            self.hunting = True
            self.hunt_amp_deg = self.hunt.amp
            self.hunt_period_s = 2.0 * self.hunt.first_s
            self._quiet_s = 0.0
            return "%s (heading +-%.0f deg, period %.0f s)" % (HUNT_TEXT, self.hunt_amp_deg, self.hunt_period_s)
        if self.hunting:
            if fired or (self.hunt.t_half_s < 20.0 and self.hunt.amp >= self.hunt.amp_min):
                self._quiet_s = 0.0
            else:
                self._quiet_s += dt_s
            if self._quiet_s > 60.0:
                self.hunting = False
                return "pilot steady again"
        return ""
