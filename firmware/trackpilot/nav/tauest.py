"""TauEstimate: the closed heading response (pilot + boat + keys) measured on line.

The law's locked course moves with nearly every epoch (1 deg keys, the lead term), so clean steps
from a quiet course are rare (none on the nominal boat's straights): the estimate fits a first-order
response to whatever the course did. A bank of N first-order models, time constants lo_s..2 hi_s
spaced by a constant ratio, each driven by the locked course and started at the measured heading
at the start of a window of window_s; each model's squared error against the GNSS heading is summed
over the window. The pilot's deadband, weather helm and its compass offset shift the heading
against the locked course without a turn: each model's residual is taken after the best constant
offset of the course and of the heading over the window (least squares on five sums a model).
A window counts when the heading moved at least step_min_deg in it and the course spanned as much
(else nothing tells a fast pilot from a slow one, and a heading moved by waves with the course
still reads as a slow pilot), the course no more than step_max_deg, not the first window after a
reset (the engage: the pilot's own start-up, seconds without a response), and the best model explains it (residual RMS at most fit_max of
the heading's largest move, at most half the slowest model's squared error, not the slowest
itself); its sample is the best time constant, refined by a parabola in log tau
through its neighbours. The estimate is the median of the last three samples, the slots starting
at the prior (two samples that agree move it), bounded to lo_s..hi_s. A time constant fitted this
way includes the dead time (keys, reply, compass lag): the lag the guidance loop sees.
A turn, a gap or not steering (ok false) drops the window; the estimate stays.

Floats and one small preallocated list, ticks only through ticks_diff, nothing allocated per step."""

import math
from array import array

from trackpilot.compat import ticks_diff, wrap180

N_MODELS = 9


class TauEstimate:
    def __init__(self, prior_s, lo_s=1.0, hi_s=20.0, step_min_deg=4.0, window_s=10.0, fit_max=0.35,
                 step_max_deg=45.0):
        self.prior_s = prior_s
        self.lo_s = lo_s
        self.hi_s = hi_s
        self.step_min_deg = step_min_deg
        self.window_s = window_s
        self.fit_max = fit_max
        self.step_max_deg = step_max_deg
        # float32 arrays, not lists: a list re-boxes 63 floats every epoch, long-lived and scattered
        # over the heap (the ESP32's largest free block fell from 18.9 to 13.5 KB)
        self.tau_k = array("f", bytes(4 * N_MODELS))
        self.h_k = array("f", bytes(4 * N_MODELS))
        self.e_k = array("f", bytes(4 * N_MODELS))  # sum of r^2 dt, r = heading - model
        self.g_k = array("f", bytes(4 * N_MODELS))  # each model's response to a unit offset of the course
        self.a_k = array("f", bytes(4 * N_MODELS))  # sum of r g dt
        self.b_k = array("f", bytes(4 * N_MODELS))  # sum of g^2 dt
        self.c_k = array("f", bytes(4 * N_MODELS))  # sum of r dt
        self.d_k = array("f", bytes(4 * N_MODELS))  # sum of g dt
        self.restart()

    def restart(self):
        """Back to the prior (a power cycle or a new configuration)."""
        r = (2.0 * self.hi_s / self.lo_s) ** (1.0 / (N_MODELS - 1))  # up to 2 hi_s: a slow
        # pilot is told from one that does not respond at all (the slowest model)
        for k in range(N_MODELS):
            self.tau_k[k] = self.lo_s * r ** k
        self.log_r = math.log(r)
        self.tau_s = self.prior_s
        self.s0 = self.prior_s
        self.s1 = self.prior_s
        self.s2 = self.prior_s
        self.samples = 0
        self.windows = 0  # windows that ended (counted or not)
        self.reset()

    def reset(self):
        """Drop the window under way (a turn, a gap, a new engage); the estimate stays."""
        self.t_prev = None
        self.t_win_s = -1.0  # < 0: no window open
        self.skip = True  # the first window after a reset: the engage (the pilot's own start-up), a turn's end

    def _open(self, locked_deg, heading_deg):
        self.h0 = heading_deg
        self.c0 = locked_deg
        self.t_win_s = 0.0
        self.y_max = 0.0
        self.u_max = 0.0
        self.u_lo = 0.0
        self.u_hi = 0.0
        for k in range(N_MODELS):
            self.h_k[k] = 0.0
            self.e_k[k] = 0.0
            self.g_k[k] = 0.0
            self.a_k[k] = 0.0
            self.b_k[k] = 0.0
            self.c_k[k] = 0.0
            self.d_k[k] = 0.0

    def step(self, t_ms, locked_deg, heading_deg, ok):
        """One control step. Returns True when the estimate tau_s changed."""
        if not ok or locked_deg is None or heading_deg is None:
            self.reset()
            return False
        if self.t_prev is None:
            self.t_prev = t_ms
            self._open(locked_deg, heading_deg)
            return False
        dt_s = ticks_diff(t_ms, self.t_prev) / 1000.0
        self.t_prev = t_ms
        if dt_s <= 0.0 or dt_s > 2.0:
            self._open(locked_deg, heading_deg)  # a hole in the feed: start again
            return False
        u = wrap180(locked_deg - self.c0)
        y = wrap180(heading_deg - self.h0)
        ay = y if y >= 0.0 else -y
        if ay > self.y_max:
            self.y_max = ay
        au = u if u >= 0.0 else -u
        if au > self.u_max:
            self.u_max = au
        if u > self.u_hi:
            self.u_hi = u
        if u < self.u_lo:
            self.u_lo = u
        for k in range(N_MODELS):
            f = dt_s / (self.tau_k[k] + dt_s)
            h = self.h_k[k] + (u - self.h_k[k]) * f
            g = self.g_k[k] + (1.0 - self.g_k[k]) * f
            self.h_k[k] = h
            self.g_k[k] = g
            r = y - h
            self.e_k[k] += r * r * dt_s
            self.a_k[k] += r * g * dt_s
            self.b_k[k] += g * g * dt_s
            self.c_k[k] += r * dt_s
            self.d_k[k] += g * dt_s
        self.t_win_s += dt_s
        if self.t_win_s < self.window_s:
            return False
        changed = self._close()
        self._open(locked_deg, heading_deg)
        return changed

    def _close(self):
        self.windows += 1
        if self.skip:
            self.skip = False
            return False
        if (self.y_max < self.step_min_deg or self.u_max > self.step_max_deg
                or self.u_hi - self.u_lo < self.step_min_deg):
            return False
        w = self.t_win_s
        for k in range(N_MODELS):
            # the residual after the best constant offset of the course (regressor g) and of the
            # heading (regressor 1: the noise on the start, the dead time's carry-over)
            a, b, c, d = self.a_k[k], self.b_k[k], self.c_k[k], self.d_k[k]
            det = w * b - d * d
            if det > 1e-6 * w * b:
                # least squares of r on (1, g): explained = [c a] M^-1 [c a]^T, M = [[w d] [d b]]
                self.e_k[k] -= (b * c * c - 2.0 * d * a * c + w * a * a) / det
        best = 0
        for k in range(1, N_MODELS):
            if self.e_k[k] < self.e_k[best]:
                best = k
        rms = math.sqrt(self.e_k[best] / self.t_win_s)
        if (rms > self.fit_max * self.y_max or best == N_MODELS - 1
                or self.e_k[best] > 0.5 * self.e_k[N_MODELS - 1]):
            return False  # the slowest model (nearly no response) does about as well: the heading
            # moved by the waves, not by the course
        x = 0.0  # the parabola's vertex, in steps of the grid from the best
        if 0 < best < N_MODELS - 1:
            a = self.e_k[best - 1]
            b = self.e_k[best]
            c = self.e_k[best + 1]
            d = a - 2.0 * b + c
            if d > 0.0:
                x = 0.5 * (a - c) / d
        sample = self.tau_k[best] * math.exp(x * self.log_r)
        self.s0 = self.s1
        self.s1 = self.s2
        self.s2 = sample
        self.samples += 1
        med = max(min(self.s0, self.s1), min(max(self.s0, self.s1), self.s2))
        med = self.lo_s if med < self.lo_s else (self.hi_s if med > self.hi_s else med)
        old = self.tau_s
        self.tau_s = med
        return med != old
