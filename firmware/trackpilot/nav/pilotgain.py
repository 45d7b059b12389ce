"""PilotGain: the tiller pilot's own rudder gain, estimated while it steers.

A pilot whose gain (rudder degrees per degree of course error) is high drives its rudder to the
stop on a large course step, and then its ram's rate limit turns the step into a swing it cannot
damp. A clip of the law's course error near 20 deg / gain keeps the rudder off the stop
(docs/NAVIGATION.md "Twelfth round"), so the law wants the gain, and the gain is not on any
label: it is learnt from what the pilot reports.

Observable: each pilot status (0x84) carries its compass, its locked course and its rudder. The
pilot's loop is taken as the simulator's and the ST2000+'s kind: rudder command = gain x (error
beyond the deadband) - damping x compass rate, the rudder moving toward it at the ram's rate
(whole-degree reports; the ram's own deadband 1 deg). A regression of rudder on error fails in
closed loop: the ram is nearly always moving, so the rudder is almost never where the command is.
Instead a bank of such pilot models (gains 0.5-3.1 deg/deg in steps of x1.2, five dampings) is
driven by the reported error and compass rate; each predicts the next rudder report from the
last one (half the model's own state, half the report, so no model drifts away), and the
squared prediction errors are summed while the rudder is off its stop. The gain of the best model
(interpolated on the log of the gain) is the estimate once enough reports had an error
well beyond the deadband and the models two steps of gain away predict clearly worse.

State: two arrays of 32-bit integers (55 models, 440 bytes) and a few numbers; per report about
55 x 12 small-integer operations: the models allocate nothing (the ESP32 boxes floats, so they
work in tenths of a degree); the error and the rate allocate a few hundred bytes (365 measured on
the 32-bit build). Times come as ticks and differences (ticks wrap)."""

import math
from array import array

from trackpilot.compat import ticks_diff, wrap180

GAINS = (0.5, 0.6, 0.72, 0.864, 1.037, 1.244, 1.493, 1.792, 2.15, 2.58, 3.096)  # x1.2 steps
DAMPINGS = (0.3, 0.7, 1.2, 1.8, 2.6)  # s: rudder deg per deg/s of compass rate
# the bank works in small integers (tenths of a degree; gains in thousandths, dampings in tenths
# of a second): nothing is boxed per model on the ESP32, and every sum stays below 2^30
_GAINS_M = tuple(int(g * 1000 + 0.5) for g in GAINS)
_DAMPINGS_D = tuple(int(d * 10 + 0.5) for d in DAMPINGS)
_SSE_HALVE = 1 << 28  # a sum this large halves every sum (and the count): the ratios stay
_RAM_DB = 10  # the ram's own deadband, 1 deg (the reports' resolution too)
_RATE_TC_S = 0.7  # the compass rate's low-pass (the pilot filters its own)
_GAP_S = 2.0  # reports further apart start the models again from the report
_EXCITE_DEG = 3.0  # a report informs the gain once its error is this far beyond the deadband
NEED_REPORTS = 40  # informative reports before an estimate
SEPARATION = 1.15  # RMS of the best model two gain steps away / the best model's RMS


class PilotGain:
    def __init__(self):
        n = len(GAINS) * len(DAMPINGS)
        self._pred = array("i", [0] * n)  # each model's rudder, tenths of a degree
        self._sse = array("i", [0] * n)  # its summed squared prediction error, (tenths of a degree)^2
        self.reset()

    def reset(self):
        """Forget everything (a different pilot, or its gain changed by a person)."""
        for i in range(len(self._sse)):
            self._sse[i] = 0
            self._pred[i] = 0
        self.scored = 0  # reports scored
        self._count = 0  # ... as the sums count them (halved with them)
        self.informative = 0  # ... with a large error
        self.gain = 0.0  # deg of rudder per deg of error; 0.0: not known
        self.damping_s = 0.0
        self.rms_deg = 0.0  # the best model's RMS prediction error
        self.separation = 0.0
        self.clip_deg = 0.0  # the clip the los law set from the gain (0.0: none), and ...
        self.told = 0.0  # ... the gain it was set from
        self._t_ms = None
        self._compass = 0.0
        self._rate = 0.0

    def step(self, t_ms, compass_deg, course_deg, rudder_deg, deadband_deg, ram_dps, stop_deg):
        """One new pilot status while the pilot steers: its compass, locked course and rudder
        (deg), t_ms when it came; the pilot's deadband, the ram's rate (deg/s) and its stop (deg),
        as known. Returns True when the estimate is (re)computed."""
        if self._t_ms is None:
            dt_s = 0.0
        else:
            dt_s = ticks_diff(t_ms, self._t_ms) / 1000.0
        rud = int(rudder_deg * 10.0)
        pred, sse = self._pred, self._sse
        n = len(pred)
        if dt_s <= 0.0 or dt_s > _GAP_S:
            # a start or a gap: each model starts from the report, the rate from scratch
            self._t_ms = t_ms
            self._compass = compass_deg
            self._rate = 0.0
            for i in range(n):
                pred[i] = rud
            return False
        w = wrap180(compass_deg - self._compass) / dt_s
        self._rate += (w - self._rate) * min(1.0, dt_s / _RATE_TC_S)
        self._t_ms = t_ms
        self._compass = compass_deg
        e = wrap180(course_deg - compass_deg)
        ae = e if e >= 0.0 else -e
        ee = 0 if ae <= deadband_deg else int(10.0 * (e - deadband_deg if e > 0.0 else e + deadband_deg))
        mv = int(ram_dps * dt_s * 10.0 + 0.5)
        lim = int(stop_deg * 10.0)
        score = -lim + 20 < rud < lim - 20  # at the stop the gain is hidden
        rate = int(self._rate * 10.0)  # tenths of a deg/s
        halve = False
        i = 0
        for gm in _GAINS_M:
            ge = gm * ee // 1000
            for dd in _DAMPINGS_D:
                cmd = ge - dd * rate // 10
                if cmd > lim:
                    cmd = lim
                elif cmd < -lim:
                    cmd = -lim
                p = pred[i]
                diff = cmd - p
                if diff > _RAM_DB or diff < -_RAM_DB:
                    p += mv if diff > mv else (-mv if diff < -mv else diff)
                if score:
                    r = p - rud
                    v = sse[i] + r * r
                    sse[i] = v
                    if v > _SSE_HALVE:
                        halve = True
                pred[i] = (p + rud) // 2  # half the report: no model drifts away
                i += 1
        if not score:
            return False
        self.scored += 1
        self._count += 1
        if halve:
            for i in range(n):
                sse[i] //= 2
            self._count = (self._count + 1) // 2
        if ae >= deadband_deg + _EXCITE_DEG:
            self.informative += 1
        if self.informative < NEED_REPORTS or self.scored % 5:
            return False
        self._estimate()
        return True

    def _estimate(self):
        """Compute the estimate from the sums now (step() does it every 5 scored reports once
        NEED_REPORTS informative ones were seen)."""
        nd = len(DAMPINGS)
        sse = self._sse
        best = []  # per gain: the best damping's sum
        kb = jb = 0
        for k in range(len(GAINS)):
            m, j0 = sse[k * nd], 0
            for j in range(1, nd):
                if sse[k * nd + j] < m:
                    m, j0 = sse[k * nd + j], j
            best.append(m)
            if m < best[kb]:
                kb, jb = k, j0
        far = -1
        for k in range(len(GAINS)):
            if (k <= kb - 2 or k >= kb + 2) and (far < 0 or best[k] < far):
                far = best[k]
        b = best[kb] if best[kb] > 0 else 1
        self.rms_deg = math.sqrt(b / self._count) / 10.0
        self.separation = math.sqrt(far / b) if far >= 0 else 9.9
        self.damping_s = DAMPINGS[jb]
        lg = math.log(GAINS[kb])
        if 0 < kb < len(GAINS) - 1:
            # a parabola through the three sums about the best, on the log of the gain
            a, c = best[kb - 1], best[kb + 1]
            den = a - 2 * best[kb] + c
            if den > 0:
                off = 0.5 * (a - c) / den
                lg += max(-0.5, min(0.5, off)) * math.log(1.2)
        self.gain = math.exp(lg) if self.separation >= SEPARATION else 0.0
