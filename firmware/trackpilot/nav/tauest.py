"""TauEstimate: the closed heading response (pilot + boat + keys) measured on line from steps.

Fed once per control step (t_ms, locked course in the true frame, true heading, ok). A *step* is a
move of the locked course by at least step_min_deg, gathered over gather_ms (several 1 deg keys
land one after the other), that starts from quiet: the locked course unchanged for quiet_ms before
it. From the step on, the heading's progress p = (heading - heading at the step) / (step of the
locked course) is bias-free (the pilot's deadband and the compass offset shift both ends alike).
The two-point rule on a first order plus dead time (Smith): t28 and t63 at p = 0.283 and 0.632,
time constant T = 1.5 (t63 - t28), dead time L = t63 - T; the sample of tau is t63 (= T + L, the
lag the guidance loop sees). A step is dropped when the locked course moves again by more than
max(1 deg, 25 % of the step), when ok goes false (a turn, a gap, not steering), or when 63 % is not
reached within timeout_ms (a deadband can stop the heading short: not a slow pilot).
The estimate is the median of the last three samples (the dead time likewise), the slots starting at the prior (two
samples that agree move it), bounded to lo_s..hi_s. The largest progress seen before the next step
or 3 x t63 is the overshoot (an under-damped pilot).

A few floats, ticks only through ticks_diff, nothing allocated per step (MicroPython)."""

from trackpilot.compat import ticks_diff, wrap180


class TauEstimate:
    def __init__(self, prior_s, lo_s=1.0, hi_s=20.0, step_min_deg=4.0, quiet_ms=2000,
                 gather_ms=1500, timeout_ms=25000):
        self.prior_s = prior_s
        self.lo_s = lo_s
        self.hi_s = hi_s
        self.step_min_deg = step_min_deg
        self.quiet_ms = quiet_ms
        self.gather_ms = gather_ms
        self.timeout_ms = timeout_ms
        self.restart()

    def restart(self):
        """Back to the prior (a power cycle or a new configuration)."""
        self.tau_s = self.prior_s
        self.dead_s = 0.0
        self.overshoot = 0.0
        self.s0 = self.prior_s
        self.s1 = self.prior_s
        self.s2 = self.prior_s
        self.d0 = self.d1 = self.d2 = 0.0  # the dead times of the same samples
        self.samples = 0
        self.reset()

    def reset(self):
        """Drop the step under way (a turn, a gap, a new engage); the estimate stays."""
        self.state = 0  # 0 idle, 1 gathering keys, 2 measuring, 3 after 63 %: the overshoot
        self.t_step = 0
        self.t_quiet = None  # when the locked course last moved
        self.c_prev = None  # the locked course last seen
        self.c0 = 0.0  # before the step
        self.c1 = 0.0  # after it
        self.h0 = 0.0
        self.t28_s = 0.0
        self.t63_s = 0.0
        self.peak = 0.0

    def step(self, t_ms, locked_deg, heading_deg, ok):
        """One control step. Returns True when the estimate (tau_s, dead_s) changed."""
        if not ok or locked_deg is None or heading_deg is None:
            self.reset()
            return False
        moved = self.c_prev is not None and wrap180(locked_deg - self.c_prev) != 0.0
        changed = False
        st = self.state
        if st == 2 or st == 3:
            d = wrap180(locked_deg - self.c1)
            tol = 0.25 * abs(wrap180(self.c1 - self.c0))
            if st == 2 and (d > tol or -d > tol) and (d > 1.0 or d < -1.0):
                st = 0  # a new command before 63 %: not a clean step
            elif st == 3 and moved:
                st = 0  # the next step: the overshoot is what it was
            else:
                el_s = ticks_diff(t_ms, self.t_step) / 1000.0
                p = wrap180(heading_deg - self.h0) / wrap180(self.c1 - self.c0)
                if st == 2:
                    if self.t28_s == 0.0 and p >= 0.283:
                        self.t28_s = el_s
                    if p >= 0.632:
                        self.t63_s = el_s
                        self.peak = p
                        changed = self._sample()
                        st = 3
                    elif el_s * 1000.0 > self.timeout_ms:
                        st = 0
                else:
                    if p > self.peak:
                        self.peak = p
                    if el_s > 3.0 * self.t63_s:
                        self.overshoot = self.peak - 1.0 if self.peak > 1.0 else 0.0
                        st = 0
        if st == 1:
            if moved:
                self.c1 = locked_deg
            s = wrap180(self.c1 - self.c0)
            if s != 0.0:
                p = wrap180(heading_deg - self.h0) / s
                el_s = ticks_diff(t_ms, self.t_step) / 1000.0
                if self.t28_s == 0.0 and p >= 0.283:
                    self.t28_s = el_s
                if self.t63_s == 0.0 and p >= 0.632:
                    self.t63_s = el_s
            if ticks_diff(t_ms, self.t_step) > self.gather_ms:
                st = 2 if (s >= self.step_min_deg or -s >= self.step_min_deg) else 0
                if st == 2 and self.t63_s > 0.0:  # a fast pilot: 63 % while the keys landed
                    self.peak = 0.632
                    changed = self._sample()
                    st = 3
        if st == 0 and moved:
            quiet = self.t_quiet is not None and ticks_diff(t_ms, self.t_quiet) >= self.quiet_ms
            if quiet:
                st = 1
                self.t_step = t_ms
                self.c0 = self.c_prev
                self.c1 = locked_deg
                self.h0 = heading_deg
                self.t28_s = 0.0
                self.t63_s = 0.0
        if moved or self.c_prev is None:
            self.t_quiet = t_ms
        self.c_prev = locked_deg
        self.state = st
        return changed

    def _sample(self):
        t63 = self.t63_s
        t_s = 1.5 * (t63 - self.t28_s)
        if t_s > t63:
            t_s = t63
        self.s0 = self.s1
        self.s1 = self.s2
        self.s2 = t63
        self.d0 = self.d1
        self.d1 = self.d2
        self.d2 = t63 - t_s
        self.samples += 1
        med = _median3(self.s0, self.s1, self.s2)
        med = self.lo_s if med < self.lo_s else (self.hi_s if med > self.hi_s else med)
        old = self.tau_s
        self.tau_s = med
        self.dead_s = _median3(self.d0, self.d1, self.d2)
        return med != old


def _median3(a, b, c):
    return max(min(a, b), min(max(a, b), c))
