"""Tighten: a shorter lookahead once the boat has shown that it holds the line.

The los law's lookahead (6 s x U) is set for the slowest heading response over the spread of
boats and pilots we have not modelled (docs/NAVIGATION.md "Robust over boats we have not
modelled"). On a boat whose pilot holds the line that long loop is what lets the 1-degree keys,
the pilot's deadband and the waves wander: at 3 m/s one degree of heading is 5 cm/s across, for
6 s. So the law starts loose and tightens only after the boat has proved itself, and goes back
at the first sign that the tight loop does not suit it (docs/NAVIGATION.md "Tenth round").

- Armed on a straight: after `wait_s` within `band_m` of the path (the command not clipped, the
  swing watch not acting), the lookahead and the lead are multiplied by `scale`.
- A turn suspends it (the factor is 1 on arcs and in a corner's preview) and the wait starts
  again on the next straight.
- Tightened, |xte| beyond `exit_m` or an act of the swing watch sets it back at once, and it stays
  off until the next engage (reset): that boat at that speed swings on the tight loop.

Four numbers of state, nothing allocated per step (MicroPython, small heap)."""


class Tighten:
    def __init__(self):
        self.reset()

    def reset(self):
        self.held_s = 0.0  # seconds within the band on this straight
        self.on = False
        self.blocked = False  # it went back on this engage: not again
        self.note = ""

    def step(self, dt_s, y_m, straight, calm, scale, wait_s, band_m, exit_m):
        """One epoch: y_m the path xte; straight: on a straight (not an arc or a corner's
        preview); calm: the command not clipped and the swing watch not acting. Returns the factor
        for the lookahead and the lead (1.0 or scale); self.note says what changed."""
        self.note = ""
        if scale >= 1.0 or self.blocked:
            return 1.0
        ay = y_m if y_m >= 0.0 else -y_m
        if self.on:
            if not straight:
                self.on = False  # a turn: the wait starts again on the next straight
                self.held_s = 0.0
                return 1.0
            if calm and ay <= exit_m:
                return scale
            self.on = False
            self.blocked = True
            why = "xte %.2f m" % ay if ay > exit_m else "the command clipped or the swing watch acting"
            self.note = why + " on the tight lookahead: x1 until the next engage"
            return 1.0
        if straight and calm and ay <= band_m:
            self.held_s += dt_s
            if self.held_s >= wait_s - 0.5 * dt_s:  # the epoch nearest the wait (sums of dt_s)
                self.on = True
                self.note = "held within %.1f m for %.0f s: lookahead x%.2f" % (band_m, self.held_s, scale)
                return scale
        else:
            self.held_s = 0.0
        return 1.0
