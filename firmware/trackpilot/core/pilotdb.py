"""The pilot's deadband: an on-line estimate and the compensation in the command -> locked course step.

Pure logic: floats and t_ms in, the locked course to ask for (pilot frame, float) out.

The ST2000+ ignores a course error inside its deadband (0.5-3 deg): the heading rests anywhere
within +-deadband of the locked course, and a 1 deg key moves it only once the course has crossed
the band (a backlash of 2 x deadband between course and heading). On a straight the heading
wanders inside it and the cross-track error with it (docs/NAVIGATION.md "The pilot's deadband").

Compensation (only on a straight in AUTO under `los`; the caller decides): the locked course is
put `frac` x the estimate beyond the wanted heading, on the side the heading must move:
    course = wanted + side * frac * db_est
side turns to +1 / -1 only when the heading error (low-passed, 2 s) is more than `hys_deg`
(hysteresis: no flip on every wave), and back to 0 while the boat swings or turns (error beyond
the estimate + 3 deg, or turning faster than 2 deg/s: a relay on the heading error would feed the
swing). The pilot then drives the heading to the wanted one and holds it against drift to that side.

Estimate: at rest (the course unchanged for 2 s, the heading turning slower than 0.5 deg/s), the
course error the pilot tolerates, |course - heading| in its own frame, tracked by a quantile step
(up 0.04, down 0.01 deg: the 80th percentile). At rest the heading sits at the edge of the band or
inside it, never beyond (the pilot would act), so the upper quantile of those samples is the
deadband. Starts at the configured `pilot.deadband_deg`. No allocation per step (a note string
only when the estimate moved by 0.25 deg).
"""
from trackpilot.compat import const, ticks_diff, wrap180

_REST_MS = const(2000)  # the course unchanged this long ...
_REST_RATE_DPS = 0.5  # ... and the heading this still: a sample of the tolerated error
_UP_DEG = 0.04  # quantile step up / down: the 80th percentile of the samples
_DOWN_DEG = 0.01
_MAX_DEG = 4.0  # the estimate's bound (the spread's 3 deg and a margin)
_LOG_STEP_DEG = 0.25  # a note when the estimate moved this much since the last one
_CALM_ERR_DEG = 3.0  # no compensation while the heading error exceeds the estimate + this
_CALM_RATE_DPS = 2.0  # ... or the heading turns faster than this
_E_ALPHA = 0.1  # low-pass of the heading error per epoch (2 s at 5 Hz)


class DeadbandComp:
    def __init__(self, prior_deg=1.0, frac=0.8, hys_deg=1.0):
        self.db_est_deg = float(prior_deg)
        self.frac = frac
        self.hys_deg = hys_deg
        self.side = 0  # +1: the course is put beyond the wanted heading to starboard, -1 to port
        self.samples = 0
        self._logged_deg = self.db_est_deg
        self._course_seen = None  # the pilot's locked course at the last epoch
        self._course_t = 0  # when it last changed
        self._h_prev = None
        self._t_prev = 0
        self.rate_dps = 0.0  # the heading's rate, low-passed
        self._e_f = None  # the heading error, low-passed

    def reset(self):
        """Off a straight, out of AUTO, a new engage: no side (the estimate stays: it belongs to
        the pilot)."""
        self.side = 0
        self._h_prev = None
        self._e_f = None

    def _observe(self, t_ms, course_deg, heading_p_deg):
        """Heading rate and, at rest, one sample of the tolerated error. Returns a note when the
        estimate moved by _LOG_STEP_DEG since it was last logged."""
        if self._h_prev is not None:
            dt_ms = ticks_diff(t_ms, self._t_prev)
            if dt_ms > 0:
                r = wrap180(heading_p_deg - self._h_prev) * 1000.0 / dt_ms
                self.rate_dps += (r - self.rate_dps) * 0.3
        self._h_prev = heading_p_deg
        self._t_prev = t_ms
        if course_deg is None:
            return ""
        if self._course_seen is None or course_deg != self._course_seen:
            self._course_seen = course_deg
            self._course_t = t_ms
            return ""
        if ticks_diff(t_ms, self._course_t) < _REST_MS or abs(self.rate_dps) > _REST_RATE_DPS:
            return ""
        err = abs(wrap180(course_deg - heading_p_deg))
        if err > _MAX_DEG + 2.0:
            return ""  # not resting in the band: a turn the pilot is still making, a bad reading
        self.samples += 1
        d = self.db_est_deg + (_UP_DEG if err > self.db_est_deg else -_DOWN_DEG)
        self.db_est_deg = min(_MAX_DEG, max(0.0, d))
        if abs(self.db_est_deg - self._logged_deg) >= _LOG_STEP_DEG:
            self._logged_deg = self.db_est_deg
            return "pilot deadband estimate %.1f deg (%d samples at rest)" % (self.db_est_deg, self.samples)
        return ""

    def course(self, t_ms, wanted_deg, heading_p_deg, course_deg, active):
        """The locked course to ask for (pilot frame, float; the driver rounds it to whole degrees)
        for the wanted heading `wanted_deg` (pilot frame); heading_p_deg: the heading now in the
        pilot's frame (GNSS heading + compass offset); course_deg: the pilot's locked course as last
        reported (None if unknown); active: on a straight in AUTO under los. Returns (course, note)."""
        if not active:
            self.reset()
            return wanted_deg, ""
        note = self._observe(t_ms, course_deg, heading_p_deg)
        if self.frac <= 0.0:
            return wanted_deg, note
        e = wrap180(wanted_deg - heading_p_deg)
        if self._e_f is None:
            self._e_f = e
        self._e_f += (e - self._e_f) * _E_ALPHA
        e = self._e_f
        if abs(e) > self.db_est_deg + _CALM_ERR_DEG or abs(self.rate_dps) > _CALM_RATE_DPS:
            self.side = 0
        elif e > self.hys_deg:
            self.side = 1
        elif e < -self.hys_deg:
            self.side = -1
        return wanted_deg + self.side * self.frac * self.db_est_deg, note
