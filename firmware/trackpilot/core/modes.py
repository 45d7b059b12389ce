"""The mode machine: what each event does to the mode, the tiller pilot and the motor.

Pure logic (no I/O, no clock): the application feeds it events with the time `t_ms` and reads back
the mode, what the pilot and the motor must do, the active alarms, and a queue of log events.
Every mode change goes through `_set_mode`, which records the reason; nothing changes mode silently.

The table it implements (ARCHITECTURE.md "Modes and safety"; docs/MODES.md says where and why it
differs):

    event                              mode after          pilot            motor
    STANDBY (HMI/remote/host)          STANDBY             send Standby     release (or slow RPM)
    person keys the pilot / unasked    STANDBY + alarm     leave as set     hold, capped at slow
    E-stop input                       ESTOP (latched)     send Standby     0 RPM
    GNSS bad < hold time, dead reckoning AUTO (dead-reckoning) steer on DR   slow
    GNSS bad < hold time, no DR        AUTO (degraded)     hold course      slow
    ... beyond hold time               ALARM               keeps course     slow
    pilot unrecoverable, motor lost    ALARM               keeps course     slow
    SeaTalk cannot send (seatalk_lost) ALARM               keeps course     slow
    pilot hang                         AUTO (recovering)   Standby, Auto    slow
    last waypoint                      STANDBY + arrival   Standby (or hold, configurable)
    reset / watchdog                   STANDBY             leave as found   release / 0

Usage:
    mm = ModeMachine(cfg)
    ok, why = mm.engage(t_ms, refusal=None, source="HMI")    # refusal: first failed precondition
    mm.gnss_quality(t_ms, ok=False, reason="RTK float")
    for kind, text in mm.drain_events(): log(kind, text)
"""
from trackpilot.compat import const, ticks_diff

STANDBY = const(0)
AUTO = const(1)
ALARM = const(2)
ESTOP = const(3)
TRIAL = const(4)  # commissioning trial (trial.py): started only by a person from STANDBY
MODE_NAMES = ("STANDBY", "AUTO", "ALARM", "ESTOP", "TRIAL")

# What the pilot must do (the application turns this into ST2000+ commands).
PILOT_LEAVE = const(0)  # touch nothing: a person has it, or we just booted
PILOT_STANDBY = const(1)  # send Standby (tiller free for a person)
PILOT_STEER = const(2)  # Auto, steer the guidance command
PILOT_HOLD = const(3)  # Auto, keep the last course (no new steps)
PILOT_RECOVER = const(4)  # Standby then Auto, then re-step (hung pilot)
PILOT_NAMES = ("leave", "standby", "steer", "hold", "recover")

# What the motor must do.
MOTOR_RELEASE = const(0)  # hand the throttle back to the lever (or the configured release RPM)
MOTOR_TRACK = const(1)  # the guidance speed command
MOTOR_SLOW = const(2)  # the configured slow RPM
MOTOR_HOLD_CAPPED = const(3)  # keep the current RPM, capped at the slow RPM
MOTOR_ZERO = const(4)
MOTOR_NAMES = ("release", "track", "slow", "hold_capped", "zero")

# Alarm bits (also logged as a bitfield).
AL_TAKEOVER = const(1)
AL_GNSS = const(2)  # GNSS lost / RTK lost / heading invalid
AL_GNSS_TIMEOUT = const(4)  # ... beyond the hold time
AL_PILOT_HANG = const(8)
AL_PILOT_LOST = const(16)  # unrecoverable or not answering
AL_MOTOR_LINK = const(32)
AL_XTE = const(64)
AL_ARRIVAL = const(128)
AL_ESTOP = const(256)
AL_LOW_BATTERY = const(512)
AL_SEATALK = const(1024)  # SeaTalk bus errors (collisions, lost echo) beyond a limit
AL_CONFIG = const(2048)
ALARM_NAMES = (
    (AL_TAKEOVER, "takeover"),
    (AL_GNSS, "gnss"),
    (AL_GNSS_TIMEOUT, "gnss_timeout"),
    (AL_PILOT_HANG, "pilot_hang"),
    (AL_PILOT_LOST, "pilot_lost"),
    (AL_MOTOR_LINK, "motor_link"),
    (AL_XTE, "xte"),
    (AL_ARRIVAL, "arrival"),
    (AL_ESTOP, "estop"),
    (AL_LOW_BATTERY, "low_battery"),
    (AL_SEATALK, "seatalk"),
    (AL_CONFIG, "config"),
)


def alarm_text(bits):
    out = []
    for bit, name in ALARM_NAMES:
        if bits & bit:
            out.append(name)
    return ",".join(out)


class ModeMachine:
    """Modes and safety reactions. All methods take the time `t_ms` (ticks domain)."""

    def __init__(self, cfg=None):
        cfg = cfg or {}
        self.gnss_hold_ms = int(cfg.get("gnss_hold_s", 40) * 1000)
        self.xte_alarm_m = cfg.get("xte_alarm_m", 5.0)
        self.on_arrival = cfg.get("on_arrival", "standby")  # or "hold"
        self.release_motor = cfg.get("motor_release_on_standby", True)
        self.mode = STANDBY
        self.degraded = False  # AUTO without steerable GNSS: dead reckoning or holding course
        self.dead_reckoning = False  # degraded, but steering on the dead-reckoned position
        self.recovering = False  # AUTO, pilot hang recovery in progress
        self.holding = False  # AUTO after arrival with on_arrival == "hold"
        self.pilot = PILOT_LEAVE  # boot: leave the pilot exactly as found
        self.motor = MOTOR_RELEASE
        self.alarms = 0
        self.acked = 0  # alarm bits a person has acknowledged (muted)
        self.estop_latched = False
        self.gnss_bad_since = None
        self.gnss_reason = ""
        self.mode_changes = 0
        self._events = []

    # ----------------------------------------------------------------- internals
    def _log(self, kind, text):
        if len(self._events) < 32:  # bounded: the app drains every epoch
            self._events.append((kind, text))

    def _set_mode(self, mode, reason, t_ms):
        if mode == self.mode:
            return
        self._log("MODE", "%s->%s: %s" % (MODE_NAMES[self.mode], MODE_NAMES[mode], reason))
        self.mode = mode
        self.mode_changes += 1
        if mode != AUTO:
            self.degraded = False
            self.dead_reckoning = False
            self.recovering = False
            self.holding = False
            self.gnss_bad_since = None

    def raise_alarm(self, bit, reason):
        if not self.alarms & bit:
            self._log("ALARM", "%s: %s" % (alarm_text(bit), reason))
        self.alarms |= bit
        self.acked &= ~bit  # a new occurrence sounds again
        if self.mode == TRIAL:  # any alarm ends a trial: tiller and throttle back to the crew
            self.end_trial(0, "aborted by alarm %s: %s" % (alarm_text(bit), reason))

    def clear_alarm(self, bit, reason):
        if self.alarms & bit:
            self._log("ALARM_CLEAR", "%s: %s" % (alarm_text(bit), reason))
        self.alarms &= ~bit
        self.acked &= ~bit

    def drain_events(self):
        ev = self._events
        self._events = []
        return ev

    def sounding(self):
        """Alarm bits that are active and not acknowledged (the buzzer sounds for these)."""
        return self.alarms & ~self.acked

    def state_text(self):
        s = MODE_NAMES[self.mode]
        if self.mode == AUTO:
            if self.degraded:
                s += "(dead-reckoning)" if self.dead_reckoning else "(degraded)"
            elif self.recovering:
                s += "(recovering)"
            elif self.holding:
                s += "(hold)"
        return s

    # ----------------------------------------------------------------- person's commands
    def engage(self, t_ms, refusal=None, source="HMI"):
        """A person asks for AUTO. `refusal` is the first failed precondition (None = all hold).
        Returns (accepted, reason)."""
        if self.estop_latched:
            refusal = "E-stop latched: clear it first"
        if refusal:
            self._log("REFUSED", "engage from %s: %s" % (source, refusal))
            return False, refusal
        was = self.mode
        self._set_mode(AUTO, "engaged by a person (%s)" % source, t_ms)
        self.degraded = self.recovering = self.holding = self.dead_reckoning = False
        self.gnss_bad_since = None
        self.pilot = PILOT_STEER
        self.motor = MOTOR_TRACK
        for bit in (AL_TAKEOVER, AL_ARRIVAL, AL_GNSS, AL_GNSS_TIMEOUT, AL_PILOT_LOST, AL_PILOT_HANG):
            self.clear_alarm(bit, "engaged")
        if was == AUTO:
            self._log("MODE", "AUTO re-engaged (%s)" % source)
        return True, ""

    def standby(self, t_ms, source="HMI"):
        """STANDBY always works, from any mode except the E-stop latch (which is already stopped)."""
        if self.mode == ESTOP:
            self._log("INFO", "standby from %s while E-stop latched" % source)
            self.pilot = PILOT_STANDBY
            return
        self._set_mode(STANDBY, "standby by a person (%s)" % source, t_ms)
        self.pilot = PILOT_STANDBY
        self.motor = MOTOR_RELEASE if self.release_motor else MOTOR_SLOW

    def start_trial(self, t_ms, refusal=None, source="HMI"):
        """A person asks for a commissioning trial (docs/COMMISSIONING.md). Only from STANDBY,
        with no alarm sounding. Returns (accepted, reason)."""
        if self.estop_latched:
            refusal = "E-stop latched: clear it first"
        elif self.mode != STANDBY:
            refusal = "trial only from STANDBY (now %s)" % MODE_NAMES[self.mode]
        elif not refusal and self.sounding():
            refusal = "alarm sounding (%s): ACK first" % alarm_text(self.sounding())
        if refusal:
            self._log("REFUSED", "trial from %s: %s" % (source, refusal))
            return False, refusal
        self._set_mode(TRIAL, "trial started by a person (%s)" % source, t_ms)
        self.pilot = PILOT_STEER
        self.motor = MOTOR_TRACK
        return True, ""

    def end_trial(self, t_ms, reason):
        """The trial script ended or was aborted (limit, alarm): STANDBY, tiller free."""
        if self.mode != TRIAL:
            return
        self._set_mode(STANDBY, "trial " + reason, t_ms)
        self.pilot = PILOT_STANDBY
        self.motor = MOTOR_RELEASE if self.release_motor else MOTOR_SLOW

    def ack(self, t_ms, source="HMI"):
        """Acknowledge (mute) every sounding alarm; clears alarms whose cause is gone."""
        if self.alarms & ~self.acked:
            self._log("ACK", "%s by %s" % (alarm_text(self.alarms & ~self.acked), source))
        self.acked |= self.alarms
        # Arrival and takeover are information once seen; clear them on acknowledgement.
        for bit in (AL_ARRIVAL, AL_TAKEOVER):
            if self.alarms & bit:
                self.clear_alarm(bit, "acknowledged")

    def estop(self, t_ms, active):
        """The E-stop input (hardware has already cut motor power)."""
        if active:
            if not self.estop_latched:
                self.estop_latched = True
                self._set_mode(ESTOP, "E-stop input", t_ms)
                self.raise_alarm(AL_ESTOP, "E-stop pressed")
            self.pilot = PILOT_STANDBY
            self.motor = MOTOR_ZERO

    def estop_clear(self, t_ms, input_active, source="HMI"):
        """A person clears the latch (only once the input is released). Lands in STANDBY."""
        if not self.estop_latched:
            return True, ""
        if input_active:
            self._log("REFUSED", "E-stop clear from %s: input still active" % source)
            return False, "E-stop input still active"
        self.estop_latched = False
        self.clear_alarm(AL_ESTOP, "cleared by %s" % source)
        self._set_mode(STANDBY, "E-stop cleared by a person (%s)" % source, t_ms)
        self.pilot = PILOT_LEAVE
        self.motor = MOTOR_ZERO
        return True, ""

    # ----------------------------------------------------------------- what the boat reports
    def takeover(self, t_ms, reason):
        """A person pressed a key on the pilot, or it left Auto unasked: a person wins."""
        if self.mode in (AUTO, ALARM, TRIAL):
            self._set_mode(STANDBY, "takeover: " + reason, t_ms)
            self.raise_alarm(AL_TAKEOVER, reason)
            self.pilot = PILOT_LEAVE  # exactly as the person set it
            self.motor = MOTOR_HOLD_CAPPED
        else:
            self._log("INFO", "pilot key/mode change while %s: %s" % (MODE_NAMES[self.mode], reason))

    def gnss_quality(self, t_ms, ok, reason="", dr=False, bad_s=None):
        """Once per control epoch (and on a GNSS gap, by timer): is the fix good enough to steer
        by? `dr`: a dead-reckoned position is available (docs/MODES.md "GNSS gaps"). Inside the
        hold time the same AUTO goes on: steering on the dead-reckoned position (or holding
        course without one) at slow RPM, and guidance resumes by itself on a good fix. This is
        not an engagement: it only continues what a person engaged. Past the hold time: ALARM.
        bad_s: the gap as the dead reckoner counts it (seconds with the receiver's velocity weigh
        less); None: the clock since the fix went bad."""
        if ok:
            if self.gnss_bad_since is not None:
                self.gnss_bad_since = None
                if self.mode == AUTO and self.degraded:
                    self.degraded = False
                    self.dead_reckoning = False
                    self.pilot = PILOT_STEER
                    self.motor = MOTOR_TRACK
                    self._log("MODE", "AUTO: GNSS good again, guidance resumed")
                self.clear_alarm(AL_GNSS, "GNSS good")
            return
        if self.gnss_bad_since is None:
            self.gnss_bad_since = t_ms
            self.gnss_reason = reason
            if self.mode == AUTO:
                self.degraded = True
                self.dead_reckoning = dr
                self.pilot = PILOT_STEER if dr else PILOT_HOLD
                self.motor = MOTOR_SLOW
                self._log("MODE", "AUTO(%s): %s; %s" % (
                    "dead-reckoning" if dr else "degraded", reason,
                    "steering on the dead-reckoned position, slow" if dr else "holding course, slow"))
            self.raise_alarm(AL_GNSS, reason)
            return
        if self.mode == AUTO and self.degraded:
            bad_ms = ticks_diff(t_ms, self.gnss_bad_since) if bad_s is None else int(bad_s * 1000)
            if bad_ms > self.gnss_hold_ms:
                self._set_mode(ALARM, "GNSS bad for more than %d s (%s)" % (self.gnss_hold_ms // 1000, reason), t_ms)
                self.raise_alarm(AL_GNSS_TIMEOUT, reason)
                self.pilot = PILOT_HOLD  # the pilot keeps its last course in Auto
                self.motor = MOTOR_SLOW
            elif dr != self.dead_reckoning and not self.recovering:
                self.dead_reckoning = dr
                self.pilot = PILOT_STEER if dr else PILOT_HOLD
                self._log("MODE", "AUTO(%s): %s" % (
                    "dead-reckoning" if dr else "degraded",
                    "dead reckoning available" if dr else "no dead reckoning (%s); holding course" % reason))

    def pilot_hang(self, t_ms, reason):
        if self.mode == AUTO and not self.recovering:
            self.recovering = True
            self.pilot = PILOT_RECOVER
            self.motor = MOTOR_SLOW
            self._log("MODE", "AUTO(recovering): pilot hang: %s" % reason)
        self.raise_alarm(AL_PILOT_HANG, reason)

    def pilot_recovered(self, t_ms):
        if self.recovering:
            self.recovering = False
            if self.mode == AUTO:
                self.pilot = PILOT_HOLD if self.degraded and not self.dead_reckoning else PILOT_STEER
                self.motor = MOTOR_SLOW if self.degraded else MOTOR_TRACK
                self._log("MODE", "AUTO: pilot recovered")
        self.clear_alarm(AL_PILOT_HANG, "recovered")

    def pilot_lost(self, t_ms, reason):
        """The pilot cannot be recovered or does not answer."""
        if self.mode == AUTO:
            self._set_mode(ALARM, "pilot: " + reason, t_ms)
            self.pilot = PILOT_HOLD
            self.motor = MOTOR_SLOW
        self.raise_alarm(AL_PILOT_LOST, reason)

    def motor_link(self, t_ms, ok, reason=""):
        if ok:
            self.clear_alarm(AL_MOTOR_LINK, "motor link back")
            return
        if not self.alarms & AL_MOTOR_LINK and self.mode == AUTO:
            self._set_mode(ALARM, "motor link lost: " + reason, t_ms)
            self.pilot = PILOT_HOLD
            self.motor = MOTOR_SLOW
        self.raise_alarm(AL_MOTOR_LINK, reason)

    def seatalk_lost(self, t_ms, reason):
        """The SeaTalk link cannot send keys (lost echo, collisions or noise beyond the retries):
        the firmware can no longer steer. The pilot keeps its last course in Auto; the alarm
        clears when a datagram goes out again (set_alarm), but AUTO never comes back by itself."""
        if self.mode == AUTO:
            self._set_mode(ALARM, "SeaTalk cannot send: " + reason, t_ms)
            self.pilot = PILOT_HOLD
            self.motor = MOTOR_SLOW
        self.raise_alarm(AL_SEATALK, reason)

    def xte(self, t_ms, xte_m, tolerance=1.0):
        """tolerance: factor on the alarm limit (RTK float positions are good to decimetres with
        jumps of up to half a metre, so the app widens it there)."""
        if self.mode != AUTO or self.degraded:
            return
        lim = self.xte_alarm_m * tolerance
        if abs(xte_m) > lim:
            self.raise_alarm(AL_XTE, "cross-track error %.1f m beyond %.1f m" % (xte_m, lim))
        elif self.alarms & AL_XTE and abs(xte_m) < 0.8 * lim:
            self.clear_alarm(AL_XTE, "back within limit")

    def arrived(self, t_ms, reason):
        """The last waypoint is reached."""
        if self.mode != AUTO or self.holding:
            return
        self.raise_alarm(AL_ARRIVAL, reason)
        if self.on_arrival == "hold":
            self.holding = True
            self.pilot = PILOT_HOLD
            self.motor = MOTOR_SLOW
            self._log("MODE", "AUTO(hold): end of track (%s); holding last heading at slow RPM" % reason)
        else:
            self._set_mode(STANDBY, "end of track: " + reason, t_ms)
            self.pilot = PILOT_STANDBY
            self.motor = MOTOR_RELEASE if self.release_motor else MOTOR_SLOW

    def set_alarm(self, bit, active, reason=""):
        """Alarms without a mode change (low battery, SeaTalk errors, config)."""
        if active:
            self.raise_alarm(bit, reason)
        else:
            self.clear_alarm(bit, reason)
