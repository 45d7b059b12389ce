"""The pilot's deadband: seen, estimated and compensated in the command -> locked course step.

Pure logic: floats and t_ms in, the locked course to ask for (pilot frame, float) out. Made by the
autopilot on the first los straight in AUTO (never under the seed law), called each control step
(docs/NAVIGATION.md "The pilot's deadband").

The ST2000+ ignores a course error inside its deadband: the heading rests
anywhere within +-deadband of the locked course. On a straight the heading can then sit on one side
of the wanted one for a long time and the cross-track error with it.
- Estimate: at rest (the locked course unchanged for 2 s, the heading turning slower than
  0.5 deg/s) one sample of |course - heading| in the pilot's frame, tracked by a quantile step (up
  0.04, down 0.01 deg: the 80th percentile), from the configured pilot.deadband_deg.
- Signature: the compensation starts only once the heading error (wanted - heading, low-passed over
  2 s) has stayed beyond 1 deg (and within 6 deg: not a turn) on one side for 5 s: a pilot that
  lets the heading sit off, not one whose own loop hunts (its error changes side or passes 6 deg
  sooner; without the wait a relay on top of such a hunt made it swing: docs/NAVIGATION.md,
  "Eighth round"). Until then the locked course is the wanted heading, bit for bit. Seen once, it
  belongs to the pilot.
- Compensation: course = wanted + side * frac * estimate, side +1 / -1 once the low-passed error is
  beyond 1 deg to that side (kept inside it), 0 while the boat swings or turns (error beyond the
  estimate + 3 deg, or turning faster than 2 deg/s: a relay on the heading error would feed the
  swing).

A few attributes and no buffers; a string only for a note.
"""
from trackpilot.compat import const, ticks_diff, wrap180

_REST_MS = const(2000)  # the course unchanged this long ...
_SIGN_MS = const(5000)  # the deadband's signature: the heading off on one side this long (not a hunt)
# The float thresholds are literals in the code (a module-level float costs heap on the board):
# at rest: the heading turning slower than 0.5 deg/s; the quantile step up 0.04 / down 0.01 deg
# (the 80th percentile), bounded to 4 deg; a note each 0.25 deg the estimate moves; the error
# low-pass 0.1 per epoch (2 s at 5 Hz); the side beyond 1 deg; the signature within 6 deg; no relay
# while the error exceeds the estimate + 3 deg or the heading turns faster than 2 deg/s.


class PilotDeadband:
    def __init__(self, prior_deg=1.0, frac=0.8):
        self.db_est_deg = float(prior_deg)
        self.db_frac = frac
        self.db_seen = False  # the signature seen: the compensation may act
        self.db_side = 0  # +1: the course is put beyond the wanted heading to starboard, -1 to port
        self.db_note = ""  # a text to log after deadband_course, else ""
        self.db_samples = 0  # samples at rest
        self._db_logged = self.db_est_deg
        self._db_course = None  # the pilot's locked course at the last call ...
        self._db_course_t = 0  # ... and when it last changed
        self._db_rate = 0.0  # the heading's rate, low-passed, deg/s
        self._db_h = None  # the heading (pilot frame) at the last call; None: (re)start
        self._db_t = 0
        self._db_e = None  # the heading error, low-passed, deg
        self._db_off_t = None  # since when that error is beyond 1 deg on one side ...
        self._db_off_side = 0  # ... this one

    def deadband_reset(self):
        """Off a straight, out of AUTO, a new engage: no side (the estimate and the signature stay:
        they belong to the pilot)."""
        self.db_side = 0
        self._db_h = None  # the rate, the filtered error and the signature's clock start afresh

    def _db_observe(self, t_ms, course_deg, heading_p_deg):
        """Heading rate and, at rest, one sample of the tolerated error."""
        if self._db_h is None:  # a start: the first straight, or after a reset
            self._db_e = None
            self._db_off_t = None
        else:
            dt_ms = ticks_diff(t_ms, self._db_t)
            if dt_ms > 0:
                r = wrap180(heading_p_deg - self._db_h) * 1000.0 / dt_ms
                self._db_rate += (r - self._db_rate) * 0.3
        self._db_h = heading_p_deg
        self._db_t = t_ms
        if course_deg is None:
            return
        if self._db_course is None or course_deg != self._db_course:
            self._db_course = course_deg
            self._db_course_t = t_ms
            return
        if ticks_diff(t_ms, self._db_course_t) < _REST_MS or abs(self._db_rate) > 0.5:
            return
        err = abs(wrap180(course_deg - heading_p_deg))
        if err > 6.0:
            return  # not resting in the band: a turn the pilot is still making, a bad reading
        self.db_samples += 1
        d = self.db_est_deg + (0.04 if err > self.db_est_deg else -0.01)
        self.db_est_deg = min(4.0, max(0.0, d))
        if abs(self.db_est_deg - self._db_logged) >= 0.25:
            self._db_logged = self.db_est_deg
            self.db_note = "pilot deadband estimate %.1f deg (%d samples at rest)" % (self.db_est_deg, self.db_samples)

    def deadband_course(self, t_ms, wanted_deg, heading_p_deg, course_deg, active):
        """The locked course to ask for (pilot frame, float; the driver rounds it to whole degrees)
        for the wanted heading (pilot frame). heading_p_deg: the heading now in the pilot's frame
        (GNSS heading + compass offset); course_deg: the pilot's locked course as last reported
        (None if unknown); active: on a los straight in AUTO, the law at its own tuning. db_note
        holds a text to log, else ""."""
        self.db_note = ""
        if not active:
            self.deadband_reset()
            return wanted_deg
        self._db_observe(t_ms, course_deg, heading_p_deg)
        if self.db_frac <= 0.0:
            return wanted_deg
        e = wrap180(wanted_deg - heading_p_deg)
        if self._db_e is None:
            self._db_e = e
        self._db_e += (e - self._db_e) * 0.1
        e = self._db_e
        side = 1 if e > 1.0 else (-1 if e < -1.0 else 0)
        if not self.db_seen:
            if side == 0 or abs(e) > 6.0:
                self._db_off_t = None  # not resting off: on the wanted heading, or turning to it
            elif self._db_off_t is None or side != self._db_off_side:
                self._db_off_side = side
                self._db_off_t = t_ms
            elif ticks_diff(t_ms, self._db_off_t) >= _SIGN_MS:
                self.db_seen = True
                self.db_note = "pilot deadband: heading %.1f deg off the wanted one for %d s: compensated" % (
                    e, _SIGN_MS // 1000)
            if not self.db_seen:
                return wanted_deg
        if abs(e) > self.db_est_deg + 3.0 or abs(self._db_rate) > 2.0:
            self.db_side = 0  # swinging or turning: no relay on the heading error
            return wanted_deg
        if side:
            self.db_side = side
        if not self.db_side:
            return wanted_deg
        return wanted_deg + self.db_side * self.db_frac * self.db_est_deg
