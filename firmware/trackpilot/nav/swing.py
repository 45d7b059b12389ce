"""SwingWatch: does a signal keep swinging about zero with a regular period?

Fed one sample per step (dt_s, x); x is already centred by the caller (the cross-track error
against the path, or the heading's error against the pilot's locked course). A half cycle runs from
one crossing of zero to the next; crossings are counted only when x leaves a band of +-band (noise
makes none). The first half cycle after a reset is not counted (it starts wherever x was). A half
cycle *qualifies* when its largest |x| is at least amp_min, it lasts min_half_s..max_half_s, it keeps
at least keep_ratio of the previous half cycle's amplitude (it decays by less than 1 - keep_ratio)
and its duration stays within period_ratio of the first one in the row (a regular period).
step() returns True once `need` half cycles in a row qualified (then the row starts again): the
same rule as the robustness benchmark's oscillation metric (docs/BENCHMARK_ROBUST.md), on line.
overshoot(ratio) asks about the half cycle after the first one (an approach's overshoot of the path,
while it is still open): does its peak so far reach ratio x the first one's?

A few floats, no history, nothing allocated per step (MicroPython, small heap)."""


class SwingWatch:
    def __init__(self, band, amp_min, need, min_half_s=1.0, max_half_s=60.0, keep_ratio=0.5, period_ratio=2.0):
        self.band = band
        self.amp_min = amp_min
        self.need = need
        self.min_half_s = min_half_s
        self.max_half_s = max_half_s
        self.keep_ratio = keep_ratio
        self.period_ratio = period_ratio
        self.reset()

    def reset(self):
        self.side = 0  # +1 / -1: the side of the band x was last outside of; 0: not yet
        self.counted = False  # the current half cycle started at a crossing (not at a reset)
        self.t_half_s = 0.0
        self.peak = 0.0
        self.row = 0  # qualifying half cycles in a row
        self.first_s = 0.0  # duration of the first half cycle of the row
        self.prev_amp = 0.0
        self.amp = 0.0  # amplitude of the last closed half cycle
        self.half_s = 0.0  # duration of the last closed half cycle
        self.closed = 0  # half cycles closed since the reset (the first one uncounted)

    def step(self, dt_s, x):
        self.t_half_s += dt_s
        ax = x if x >= 0.0 else -x
        if ax > self.peak:
            self.peak = ax
        if self.t_half_s > self.max_half_s:
            self.row = 0  # no crossing for too long: not a swing
        s = 1 if x > self.band else (-1 if x < -self.band else 0)
        if s == 0 or s == self.side:
            return False
        fired = False
        if self.side != 0:
            self.closed += 1
        if self.side != 0 and self.counted:
            fired = self._close(self.t_half_s, self.peak)
        elif self.side != 0:
            self.prev_amp = self.peak  # the first half cycle: not counted, but the next must keep half of it
        self.counted = self.side != 0
        self.side = s
        self.t_half_s = 0.0
        self.peak = ax
        return fired

    def overshoot(self, ratio):
        """True while the second half cycle since the reset is open (the first ran from the reset to
        a crossing: an approach) and its peak so far is at least amp_min and ratio x the first one's
        (the overshoot's share of the approach; ratio <= 0: never)."""
        return (ratio > 0.0 and self.closed == 1 and self.peak >= self.amp_min
                and self.peak >= ratio * self.prev_amp)

    def _close(self, dur_s, amp):
        self.amp = amp
        self.half_s = dur_s
        ok = amp >= self.amp_min and self.min_half_s <= dur_s <= self.max_half_s
        if ok and self.row > 0:
            ok = (amp >= self.keep_ratio * self.prev_amp
                  and self.first_s <= dur_s * self.period_ratio and dur_s <= self.first_s * self.period_ratio)
            if not ok and amp >= self.amp_min and self.min_half_s <= dur_s <= self.max_half_s:
                self.row = 0  # this one starts a new row
                ok = True
        self.prev_amp = amp
        if not ok:
            self.row = 0
            return False
        if self.row == 0:
            self.first_s = dur_s
        self.row += 1
        if self.row >= self.need:
            self.row = 0
            return True
        return False
