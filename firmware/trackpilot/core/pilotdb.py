"""The pilot's deadband: an on-line estimate and the compensation in the command -> locked course step.

Pure logic: floats and t_ms in, the locked course to ask for (whole degrees) out.

The ST2000+ ignores a course error inside its deadband (0.5-3 deg): the heading rests anywhere
within +-deadband of the locked course, and a 1 deg key moves it only once the course has crossed
the band (a backlash of 2 x deadband between course and heading). On a straight the heading
wanders inside it and the cross-track error with it (docs/NAVIGATION.md "The pilot's deadband").

Compensation (only on a straight in AUTO under `los`; the caller decides): the locked course is
put `frac` x the estimate beyond the wanted heading, on the side the heading must move:
    course = wanted + side * frac * db_est
side turns to +1 / -1 only when the heading is more than `hys_deg` short of / past the wanted one
(hysteresis: no flip on every wave). The pilot then drives the heading to the wanted one and
holds it against drift to that side. A whole-degree quantiser with hysteresis (`round_hys_deg`)
stops the +1/-1 key dither of a target that sits near a half degree.

Estimate: at rest (the course unchanged for `rest_ms`, the heading turning slower than
`rest_rate_dps`), the course error the pilot tolerates, |course - heading| in its own frame,
tracked by a quantile step (up `up_deg`, down `down_deg`: the 80th percentile). At rest the heading
sits at the edge of the band or inside it, never beyond (the pilot would act), so the upper
quantile of those samples is the deadband. Starts at the configured `pilot.deadband_deg`.
No allocation per step.
"""
from trackpilot.compat import ticks_diff, wrap180


class DeadbandComp:
    def __init__(self, prior_deg=1.0, frac=0.8, hys_deg=1.0, round_hys_deg=0.0, rest_ms=2000,
                 rest_rate_dps=0.5, up_deg=0.04, down_deg=0.01, max_deg=4.0, log_step_deg=0.25,
                 calm_err_deg=3.0, calm_rate_dps=2.0, e_alpha=0.1, compensate=True):
        self.db_est_deg = float(prior_deg)
        self.frac = frac
        self.hys_deg = hys_deg
        self.round_hys_deg = round_hys_deg
        self.rest_ms = rest_ms
        self.rest_rate_dps = rest_rate_dps
        self.up_deg = up_deg
        self.down_deg = down_deg
        self.max_deg = max_deg
        self.log_step_deg = log_step_deg
        self.compensate = compensate
        self.calm_err_deg = calm_err_deg
        self.calm_rate_dps = calm_rate_dps
        self.e_alpha = e_alpha  # per epoch: 0.1 at 5 Hz is a 2 s time constant
        self._e_f = None
        self.side = 0  # +1: the course is put beyond the wanted heading to starboard, -1 to port
        self.course_int = None  # the quantised course last asked for
        self.samples = 0
        self._logged_deg = self.db_est_deg
        self._course_seen = None  # the pilot's locked course at the last epoch
        self._course_t = 0  # when it last changed
        self._h_prev = None
        self._t_prev = 0
        self.rate_dps = 0.0  # the heading's rate, low-passed

    def reset(self):
        """Off a straight, out of AUTO, a new engage: no side, no held course (the estimate stays:
        it belongs to the pilot)."""
        self.side = 0
        self.course_int = None
        self._h_prev = None
        self._e_f = None

    def _observe(self, t_ms, course_deg, heading_p_deg):
        """Heading rate and, at rest, one sample of the tolerated error. Returns a note when the
        estimate moved by log_step_deg since it was last logged."""
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
        if ticks_diff(t_ms, self._course_t) < self.rest_ms or abs(self.rate_dps) > self.rest_rate_dps:
            return ""
        err = abs(wrap180(course_deg - heading_p_deg))
        if err > self.max_deg + 2.0:
            return ""  # not resting in the band: a turn the pilot is still making, a bad reading
        self.samples += 1
        d = self.db_est_deg + (self.up_deg if err > self.db_est_deg else -self.down_deg)
        self.db_est_deg = min(self.max_deg, max(0.0, d))
        if abs(self.db_est_deg - self._logged_deg) >= self.log_step_deg:
            self._logged_deg = self.db_est_deg
            return "pilot deadband estimate %.1f deg (%d samples at rest)" % (self.db_est_deg, self.samples)
        return ""

    def course(self, t_ms, wanted_deg, heading_p_deg, course_deg, active):
        """The locked course to ask for (whole degrees, pilot frame) for the wanted heading
        `wanted_deg` (pilot frame, float); heading_p_deg: the heading now in the pilot's frame
        (GNSS heading + compass offset); course_deg: the pilot's locked course as last reported
        (None if unknown); active: on a straight in AUTO under los. Returns (course, note)."""
        note = self._observe(t_ms, course_deg, heading_p_deg) if active else ""
        if not active:
            self.reset()
            return wanted_deg, note
        x = wanted_deg
        if self.compensate:
            # the heading error, low-passed: a wave's yaw must not turn the side over
            e = wrap180(wanted_deg - heading_p_deg)
            if self._e_f is None:
                self._e_f = e
            self._e_f += (e - self._e_f) * self.e_alpha
            e = self._e_f
            if abs(e) > self.db_est_deg + self.calm_err_deg or abs(self.rate_dps) > self.calm_rate_dps:
                # swinging or turning: a relay on the heading error would feed the swing
                self.side = 0
            elif e > self.hys_deg:
                self.side = 1
            elif e < -self.hys_deg:
                self.side = -1
            x = wanted_deg + self.side * self.frac * self.db_est_deg
        c = self.course_int
        if c is None or abs(wrap180(x - c)) > 0.5 + self.round_hys_deg:
            c = float(int(x + 360.5) - 360)
            self.course_int = c
        return c, note
