"""Commissioning trial: the scripted manoeuvres that `trackpilot tune` identifies the boat from.

Pure logic (no I/O, no clock): the application starts it (only on a person's TRIAL command from
STANDBY, through the mode machine) and calls `step` once per control epoch with the time and what
the boat measures; it answers with what the pilot and the motor must do and queues event marks
(`drain_marks`) that the log keeps as TRIAL events. docs/COMMISSIONING.md is the crew's procedure.

The script (each phase logged "TRIAL <phase> start/end ..." with its own numbers):
    speed     rpm_low; at rpm_high after a 180 deg course change (the boat comes back), or after the
              turn back that ends the optional low-speed circle
    straight  rpm_low, no keys for `straight_s`: compass offset, crab angle, current, RPM -> speed;
              at rpm_high too for `straight_high_s` (0: none) after the turn back, so the steps
              there begin with the pilot's auto-trim unwound
    steps     at rpm_low, then rpm_high: settle the speed, then course steps of STEPS_DEG by keystroke in the
              pilot's Auto, each held until the heading settles (or `step_max_s`)
    zigzag    after the steps at each speed: the locked course 2 x `zigzag_deg` to one side of the base course,
              switched to the other side when the heading passes `zigzag_deg` (a course
              just `zigzag_deg` off would be reached only asymptotically), `zigzag_legs` legs
    circle    the locked course kept `circle_lead_deg` ahead of the compass (full rudder). At
              rpm_high after its zig-zag: `circle_turns` turns to starboard, then to port, each at
              most `circle_max_s`; the lead is walked back to the compass before the port circle
              (mark "circle reversed in N s"). Optional (`circle_low_turns` >= 1, off by default): at rpm_low
              right after its zig-zag, that many turns to starboard ending on the reversed course
              (the turn back to the second speed), so the current that sets the zig-zag's water
              speed is measured within a minute of it; at most `circle_low_max_s`. It stays within
              10 minutes on slow-turning boats only with `straight_s` 30 and `circle_max_s` 60
              (measured: docs/COMMISSIONING.md)
Time budget: the script ends on its own `end_margin_s` before `max_duration_s`. Each step, zig-zag
and circle gets at most its own limit and at most what is left after the phases still to come take
their typical time (_PLAN_*_S); the two last circles share what is left. A slow boat with a ringing
pilot (boat 78 of the hidden boats: its second circle was cut at 600 s) then sails shorter circles
instead of losing the whole trial to the limit. Its floor (`_*_MIN_S`) keeps a phase long enough to
measure; only then can the limit still end it.
Limits (any one ends the trial and sends the boat to STANDBY): `max_distance_m` from the start
point, `max_duration_s`, water speed below `min_speed_mps` for `min_speed_grace_s` once under
way, any alarm (the mode machine aborts TRIAL on any alarm by itself).

Usage:
    tr = Trial(cfg["trial"])
    tr.start(t_ms, heading_deg)
    act = tr.step(t_ms, heading_deg, sog_mps, dist_m, pilot_err_deg)
    # act: None (go on) or ("end", reason) / ("abort", reason)
    tr.rpm, tr.course_delta_deg (a step of the locked course to send once, then 0), tr.lead_deg
    for text in tr.drain_marks(): log("TRIAL", text)
"""
from trackpilot.compat import const, ticks_diff, wrap180

STEPS_DEG = (10, -10, 20, -20)

# A phase's typical time (s), to budget the phases before it (the trials of the 200 hidden-boat
# sails: step at the low / high RPM median 18 / 25 s, zig-zag median 45 / 34 s, the turn back 45 s,
# circle at the high RPM median 65 s; docs/COMMISSIONING.md), and the floor of its limit.
# const with a leading underscore: no entry in the module's globals (RAM on the ESP32)
_PLAN_STEP_S = const(20)
_PLAN_ZIGZAG_S = const(45)
_PLAN_TURN_S = const(45)
_PLAN_CIRCLE_S = const(65)
_STEP_MIN_S = const(10)
_ZIGZAG_MIN_S = const(30)
_CIRCLE_MIN_S = const(40)
# the second circle's reversal: the locked course is walked back to the compass (keys against the
# turn) until it is within this of it, then set the lead the other way (see _begin_circle)
_REVERSE_NEAR_DEG = const(20)

DEFAULTS = {
    "rpm_low": 600,
    "rpm_high": 1000,
    "straight_s": 45,
    "straight_high_s": 0,
    "speed_settle_s": 12,
    "step_settle_s": 4,
    "step_max_s": 25,
    "settle_err_deg": 3.0,
    "settle_rate_dps": 1.5,
    "zigzag_deg": 10,
    "zigzag_legs": 5,
    "zigzag_max_s": 90,
    "circle_lead_deg": 150,
    "circle_turns": 2,
    "circle_low_turns": 0,  # off: measured, not better yet (docs/COMMISSIONING.md)
    "circle_max_s": 90,
    "circle_low_max_s": 90,
    "max_distance_m": 600.0,
    "max_duration_s": 600,
    "end_margin_s": 10,
    "min_speed_mps": 0.5,
    "min_speed_grace_s": 10,
}

# phases
P_STRAIGHT = 0
P_SPEED = 1
P_STEP = 2
P_ZIGZAG = 3
P_CIRCLE = 4
P_DONE = 5
PHASE_NAMES = ("straight", "speed", "step", "zigzag", "circle", "done")


def trial_config(cfg):
    """The trial section with defaults filled in (unknown keys are the config schema's business)."""
    out = dict(DEFAULTS)
    if cfg:
        out.update(cfg)
    return out


class Trial:
    def __init__(self, cfg=None):
        c = trial_config(cfg)
        self.c = c
        self.rpms = (int(c["rpm_low"]), int(c["rpm_high"]))
        self.active = False
        self.rpm = 0
        self.course_delta_deg = 0  # locked-course change to send now (consumed by the app)
        self.lead_deg = 0  # >0/<0: keep the locked course this far ahead of the compass (circle)
        self._marks = []
        self.phase = P_DONE
        self.result = ""

    # ---------------------------------------------------------------- helpers
    def _mark(self, text):
        if len(self._marks) < 16:
            self._marks.append(text)

    def drain_marks(self):
        m = self._marks
        self._marks = []
        return m

    def _enter(self, phase, t_ms, text=""):
        self.phase = phase
        self.phase_t = t_ms
        self.settled_since = None
        self.limit_s, own = self._limit_s(phase, t_ms)
        if self.limit_s is not None:
            # "budget": the time left, not the phase's own limit, set it (tune tells the crew)
            text += " max=%d%s" % (self.limit_s, " budget" if self.limit_s < own else "")
        self._mark("%s start%s" % (PHASE_NAMES[phase], (" " + text) if text else ""))

    def _plan_after_s(self, phase):
        """Typical seconds of the phases after `phase` (entered now) until the script's end."""
        last_speed = self.rpm_i + 1 >= len(self.rpms)
        rest = 0
        if phase == P_STEP:  # the steps after this one, and the zig-zag at this speed
            rest += (len(STEPS_DEG) - 1 - self.step_i) * _PLAN_STEP_S + _PLAN_ZIGZAG_S
        if not last_speed:
            if phase != P_CIRCLE and self.c["circle_low_turns"] >= 1:
                rest += _PLAN_CIRCLE_S  # the optional circle at the low speed
            # the next speed: the turn back, its straight (if any), its steps and zig-zag
            rest += _PLAN_TURN_S + self.c["straight_high_s"] + len(STEPS_DEG) * _PLAN_STEP_S + _PLAN_ZIGZAG_S
        return rest + 2 * _PLAN_CIRCLE_S  # the last two circles

    def _limit_s(self, phase, t_ms):
        """(The time limit of a step, zig-zag or circle entered now, the phase's own limit);
        (None, None) for the others."""
        c = self.c
        left_s = c["max_duration_s"] - c["end_margin_s"] - ticks_diff(t_ms, self.t0) / 1000.0
        if phase == P_STEP:
            own, floor = c["step_max_s"], _STEP_MIN_S
        elif phase == P_ZIGZAG:
            own, floor = c["zigzag_max_s"], _ZIGZAG_MIN_S
        elif phase == P_CIRCLE:
            floor = _CIRCLE_MIN_S
            if self.rpm_i + 1 < len(self.rpms):
                own = c["circle_low_max_s"]
            else:
                own = c["circle_max_s"]
                # the last two circles share what is left
                return int(min(own, max(floor, left_s / (2 if self.circ_dir > 0 else 1)))), own
        else:
            return None, None
        return int(min(own, max(floor, left_s - self._plan_after_s(phase)))), own

    # ---------------------------------------------------------------- control
    def start(self, t_ms, heading_deg, rudder_sign=1):
        """Begin the script (the mode machine has accepted a person's TRIAL command). rudder_sign:
        the configured sign of the pilot's rudder report, in the begin mark for `tune`."""
        self.active = True
        self.t0 = t_ms
        self.rpm_i = 0
        self.step_i = 0
        self.rpm = int(self.rpms[0])
        self.course_delta_deg = 0
        self.lead_deg = 0
        self.slow_since = None
        self.rate_f = 0.0
        self.base_deg = heading_deg
        self.result = ""
        self._mark("begin rpms=%d,%d heading=%.1f rudder_sign=%d" % (
            self.rpms[0], self.rpms[1], heading_deg, rudder_sign))
        self._enter(P_SPEED, t_ms, "rpm=%d" % self.rpm)

    def stop(self, reason):
        """Ended from outside (STANDBY, a person's key, an alarm): nothing more is commanded."""
        if self.active:
            self.active = False
            self.lead_deg = 0
            self.course_delta_deg = 0
            self.result = "stopped: " + reason
            self._mark("end stopped: %s" % reason)

    def _finish(self, kind, reason):
        self.active = False
        self.lead_deg = 0
        self.course_delta_deg = 0
        self.phase = P_DONE
        self.result = "%s: %s" % (kind, reason)
        self._mark("end %s: %s" % (kind, reason))
        return (kind, reason)

    def _settled(self, t_ms, pilot_err_deg, hold_s):
        c = self.c
        if abs(pilot_err_deg) <= c["settle_err_deg"] and abs(self.rate_f) <= c["settle_rate_dps"]:
            if self.settled_since is None:
                self.settled_since = t_ms
            return ticks_diff(t_ms, self.settled_since) >= hold_s * 1000
        self.settled_since = None
        return False

    def step(self, t_ms, heading_deg, sog_mps, dist_m, pilot_err_deg, rate_dps):
        """One control epoch. heading_deg: true (GNSS) heading; pilot_err_deg: locked course -
        pilot compass; rate_dps: yaw rate. Returns None, or ("end"|"abort", reason) once."""
        if not self.active:
            return None
        c = self.c
        self.course_delta_deg = 0
        self.rate_f += (rate_dps - self.rate_f) * 0.1  # ~2 s at 5 Hz: wave yaw is not turning
        el_s = ticks_diff(t_ms, self.t0) / 1000.0
        if el_s > c["max_duration_s"]:
            return self._finish("abort", "longer than %d s" % c["max_duration_s"])
        if dist_m > c["max_distance_m"]:
            return self._finish("abort", "%.0f m from the start (limit %.0f m)" % (dist_m, c["max_distance_m"]))
        if el_s > c["min_speed_grace_s"] and sog_mps < c["min_speed_mps"]:
            if self.slow_since is None:
                self.slow_since = t_ms
            elif ticks_diff(t_ms, self.slow_since) > c["min_speed_grace_s"] * 1000:
                return self._finish("abort", "speed %.2f m/s below %.2f m/s" % (sog_mps, c["min_speed_mps"]))
        else:
            self.slow_since = None
        in_s = ticks_diff(t_ms, self.phase_t) / 1000.0
        ph = self.phase
        if ph == P_SPEED:
            # the second speed starts with a turn back (keeps the trial within a few hundred
            # metres): it ends once the heading has settled on the reversed course, at most 45 s
            # (the pilot's auto-trim winds up in the long full-rudder turn and unwinds slowly)
            turned = self.rpm_i == 0 or self._settled(t_ms, pilot_err_deg, c["step_settle_s"]) or in_s >= 45
            if in_s >= c["speed_settle_s"] and turned:
                self._mark("speed end rpm=%d sog=%.2f" % (self.rpm, sog_mps))
                if (self.rpm_i == 0 and self.step_i == 0) or (self.rpm_i > 0 and c["straight_high_s"] > 0):
                    self._enter(P_STRAIGHT, t_ms, "rpm=%d heading=%.1f" % (self.rpm, heading_deg))
                else:
                    self._begin_step(t_ms, heading_deg)
        elif ph == P_STRAIGHT:
            # at the second speed: time for the pilot's auto-trim, wound up in the turn back, to
            # unwind before the steps (docs/COMMISSIONING.md "The closed heading response ...")
            if in_s >= (c["straight_s"] if self.rpm_i == 0 else c["straight_high_s"]):
                self._mark("straight end sog=%.2f" % sog_mps)
                self._begin_step(t_ms, heading_deg)
        elif ph == P_STEP:
            if self._settled(t_ms, pilot_err_deg, c["step_settle_s"]) or in_s >= self.limit_s:
                self._mark("step end %s after %.1f s" % (
                    "settled" if in_s < self.limit_s else "NOT settled", in_s))
                self.step_i += 1
                if self.step_i < len(STEPS_DEG):
                    self._begin_step(t_ms, heading_deg)
                else:
                    self.step_i = 0
                    self.base_deg = heading_deg
                    self.zz_side = 1
                    self.zz_leg = 1
                    self.course_delta_deg = 2 * c["zigzag_deg"]
                    self._enter(P_ZIGZAG, t_ms, "deg=%d base=%.1f rpm=%d" % (c["zigzag_deg"], heading_deg, self.rpm))
        elif ph == P_ZIGZAG:
            off = wrap180(heading_deg - self.base_deg)
            if self.zz_side * off >= c["zigzag_deg"]:
                if self.zz_leg >= c["zigzag_legs"]:
                    self.course_delta_deg = -self.zz_side * 2 * c["zigzag_deg"]  # back to the base
                    self._mark("zigzag end legs=%d" % self.zz_leg)
                    self._after_zigzag(t_ms)
                else:
                    self.zz_side = -self.zz_side
                    self.zz_leg += 1
                    self.course_delta_deg = 4 * self.zz_side * c["zigzag_deg"]
                    self._mark("zigzag switch %+d at %.1f" % (self.zz_side * c["zigzag_deg"], heading_deg))
            elif in_s >= self.limit_s:
                self._mark("zigzag end timeout legs=%d" % self.zz_leg)
                self._after_zigzag(t_ms)
        elif ph == P_CIRCLE:
            d = 0.0 if self.circ_prev is None else wrap180(heading_deg - self.circ_prev)
            self.circ_prev = heading_deg
            if self.circ_back:
                # reversing: the locked course still leads the old way; the new lead once it has
                # come back to the compass (the turn before that is not this circle's)
                if -self.circ_dir * pilot_err_deg <= _REVERSE_NEAR_DEG:
                    self.circ_back = False
                    self.lead_deg = self.circ_dir * c["circle_lead_deg"]
                    self._mark("circle reversed in %.1f s" % in_s)
            else:
                self.circ_turned += d * self.circ_dir
            low = self.rpm_i + 1 < len(self.rpms)  # the optional circle after the low-speed zig-zag
            if low:
                # whole turns, then on until the locked course (lead ahead) is the reversed course:
                # the pilot finishes the turn back on its own
                goal = 360.0 * c["circle_low_turns"] + 180.0 - c["circle_lead_deg"]
            else:
                goal = 360.0 * c["circle_turns"]
            if self.circ_turned >= goal or in_s >= self.limit_s:
                self._mark("circle end dir=%+d turned=%.0f in %.1f s" % (self.circ_dir, self.circ_turned, in_s))
                if low:
                    self.lead_deg = 0
                    self._next_speed(t_ms)
                elif self.circ_dir > 0:
                    self._begin_circle(t_ms, -1)
                else:
                    return self._finish("end", "complete in %.0f s" % el_s)
        return None

    def _begin_step(self, t_ms, heading_deg):
        d = STEPS_DEG[self.step_i]
        self.course_delta_deg = d
        self._enter(P_STEP, t_ms, "%+d rpm=%d heading=%.1f" % (d, self.rpm, heading_deg))

    def _after_zigzag(self, t_ms):
        """The zig-zag at each speed (T = T' L / u changes with speed, the rudder's flow lag does
        not: two speeds tell them apart); after each, a circle at its speed (the current next to
        it, if `circle_low_turns`); the first circle ends in the turn back to the second speed."""
        if self.rpm_i + 1 < len(self.rpms) and self.c["circle_low_turns"] < 1:
            self.course_delta_deg += 180  # the turn back, then the next speed
            self._next_speed(t_ms)
        else:
            self._begin_circle(t_ms, 1)

    def _next_speed(self, t_ms):
        """On to the next RPM, the pilot finishing the turn back (P_SPEED waits for it to settle)."""
        self.rpm_i += 1
        self.rpm = int(self.rpms[self.rpm_i])
        self._enter(P_SPEED, t_ms, "rpm=%d turn=180" % self.rpm)

    def _begin_circle(self, t_ms, direction):
        """A circle, the locked course `circle_lead_deg` ahead. After a circle the other way the
        lead is first walked back to the compass (a lead of 1 deg the new way): set at once, the
        new lead is 300 deg from the old one, which the driver takes the short way round, with the
        turn, and a pilot slow to answer keys then chases its own compass for most of a minute
        (a 600 ms key reply: 34 s more to starboard; docs/COMMISSIONING.md)."""
        self.circ_dir = direction
        self.circ_turned = 0.0
        self.circ_prev = None
        self.circ_back = self.lead_deg * direction < 0
        self.lead_deg = direction * (1 if self.circ_back else self.c["circle_lead_deg"])
        self._enter(P_CIRCLE, t_ms, "dir=%+d lead=%d rpm=%d" % (direction, self.c["circle_lead_deg"], self.rpm))
