"""PilotWatch: does the tiller pilot's own heading loop hunt? Seen from its status datagrams.

Fed each new pilot status (0x84, about 2 Hz: its compass and its locked course). The pilot hunts
when its heading keeps swinging about a steady locked course at a regular period: its gain is too
high for its compass lag and ram speed (docs/BENCHMARK_ROBUST.md "pilot alone": about a fifth of
the random boats at 3 m/s). No keystroke law steers that boat straight; a person must turn the
pilot's response or rudder gain down. step() reports it once (an event for the log, the text for
the HMI), and again when it stops. The swing must be the pilot's, not the track loop's: a half
cycle in which the locked course moved by more than half the heading's swing does not count.

The same object also watches the pilot's deadband and compensates it in the command -> locked
course step (deadband_course, called by the autopilot each control step; docs/NAVIGATION.md "The
pilot's deadband"). The ST2000+ ignores a course error inside its deadband: the heading rests
anywhere within +-deadband of the locked course. On a straight the heading can then sit on one side
of the wanted one for a long time and the cross-track error with it.
- Estimate: at rest (the locked course unchanged for 2 s, the heading turning slower than
  0.5 deg/s) one sample of |course - heading| in the pilot's frame, tracked by a quantile step (up
  0.04, down 0.01 deg: the 80th percentile), from the configured pilot.deadband_deg.
- Signature: the compensation starts only once the heading error (wanted - heading, low-passed over
  2 s) has stayed beyond 1 deg (and within 6 deg: not a turn) on one side for 22 s: a pilot that
  lets the heading sit off. On the nominal pilot (1 deg) the longest such stretch measured was 19 s
  (docs/NAVIGATION.md): there the locked course stays the wanted heading, bit for bit. Seen once,
  it belongs to the pilot.
- Compensation: course = wanted + side * frac * estimate, side +1 / -1 once the low-passed error is
  beyond 1 deg to that side (kept inside it), 0 while the boat swings or turns (error beyond the
  estimate + 3 deg, or turning faster than 2 deg/s: a relay on the heading error would feed the
  swing).

A few floats and one SwingWatch (nav/swing.py): nothing allocated per step but the notes."""
from trackpilot.compat import const, ticks_diff, wrap180
from trackpilot.nav.swing import SwingWatch

_REST_MS = const(2000)  # the course unchanged this long ...
_REST_RATE_DPS = 0.5  # ... and the heading this still: a sample of the tolerated error
_UP_DEG = 0.04  # quantile step up / down: the 80th percentile of the samples
_DOWN_DEG = 0.01
_MAX_DEG = 4.0  # the estimate's bound (the spread's 3 deg and a margin)
_LOG_STEP_DEG = 0.25  # a note when the estimate moved this much since the last one
_CALM_ERR_DEG = 3.0  # no compensation while the heading error exceeds the estimate + this
_CALM_RATE_DPS = 2.0  # ... or the heading turns faster than this
_E_ALPHA = 0.1  # low-pass of the heading error per epoch (2 s at 5 Hz)
_HYS_DEG = 1.0  # the side: the low-passed heading error beyond this
_SIGN_MS = const(22000)  # ... held on one side this long: the deadband's signature (nominal: <= 19 s)
_SIGN_MAX_DEG = 6.0  # ... and within this (beyond: a turn, the approach, not a rest in the band)

HUNT_TEXT = "pilot hunts: lower its response/rudder gain"


class PilotWatch:
    def __init__(self, hunt_amp_deg=2.5, hunt_need=6, db_prior_deg=1.0, db_frac=0.8):
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
        # the deadband (deadband_course)
        self.db_est_deg = float(db_prior_deg)
        self.db_frac = db_frac
        self.db_samples = 0
        self.db_seen = False  # the signature seen: the compensation may act
        self.db_side = 0  # +1: the course is put beyond the wanted heading to starboard, -1 to port
        self.db_note = ""  # a text to log after deadband_course, else ""
        self._db_logged = self.db_est_deg
        self._db_course = None  # the pilot's locked course at the last call
        self._db_course_t = 0  # when it last changed
        self._db_h = None  # the heading (pilot frame) at the last call
        self._db_t = 0
        self._db_rate = 0.0  # the heading's rate, low-passed, deg/s
        self._db_e = None  # the heading error, low-passed, deg
        self._db_off_t = None  # since when the low-passed error is beyond _HYS_DEG on one side ...
        self._db_off_side = 0  # ... this one

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

    def deadband_reset(self):
        """Off a straight, out of AUTO, a new engage: no side (the estimate and the signature stay:
        they belong to the pilot)."""
        self.db_side = 0
        self._db_h = None
        self._db_e = None
        self._db_off_t = None

    def _db_observe(self, t_ms, course_deg, heading_p_deg):
        """Heading rate and, at rest, one sample of the tolerated error."""
        if self._db_h is not None:
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
        if ticks_diff(t_ms, self._db_course_t) < _REST_MS or abs(self._db_rate) > _REST_RATE_DPS:
            return
        err = abs(wrap180(course_deg - heading_p_deg))
        if err > _MAX_DEG + 2.0:
            return  # not resting in the band: a turn the pilot is still making, a bad reading
        self.db_samples += 1
        d = self.db_est_deg + (_UP_DEG if err > self.db_est_deg else -_DOWN_DEG)
        self.db_est_deg = min(_MAX_DEG, max(0.0, d))
        if abs(self.db_est_deg - self._db_logged) >= _LOG_STEP_DEG:
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
        self._db_e += (e - self._db_e) * _E_ALPHA
        e = self._db_e
        side = 1 if e > _HYS_DEG else (-1 if e < -_HYS_DEG else 0)
        if not self.db_seen:
            if side == 0 or abs(e) > _SIGN_MAX_DEG:
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
        if abs(e) > self.db_est_deg + _CALM_ERR_DEG or abs(self._db_rate) > _CALM_RATE_DPS:
            self.db_side = 0  # swinging or turning: no relay on the heading error
            return wanted_deg
        if side:
            self.db_side = side
        if not self.db_side:
            return wanted_deg
        return wanted_deg + self.db_side * self.db_frac * self.db_est_deg
