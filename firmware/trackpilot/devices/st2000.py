"""Raymarine ST2000+ tiller-pilot driver over SeaTalk1: state, commands, takeover and hang handling.

Pure logic: datagrams and t_ms in, keystroke datagrams (through the injected `send`) and events out.

Usage (the shell wires it to a StLink):
    pilot = St2000(send=link.send, sender_id=1)
    link.on_datagram = pilot.on_datagram          # every framed non-echo datagram
    link.on_sent = pilot.on_sent                  # each of our datagrams, once its echo is complete
    pilot.engage(t_ms)        # sends Auto only now: never at boot, never by itself
    pilot.steer_to(-4.0, t_ms)  # locked course := pilot compass - 4 deg, by +-10/+-1 keystrokes
    pilot.standby(t_ms)
    pilot.poll(t_ms)          # stepping, confirmations, timeouts, recovery: call after each
                              # datagram and when pilot.next_due_ms(t_ms) has passed (or ~50 ms)
    ev = pilot.pop_event()    # (name, t_ms, reason) or None; names are the EV_* strings below
    # on a link EV_FAILED for one of our datagrams: pilot.on_send_failed(dg, t_ms)

Control states (`state`): IDLE (not commanding; the pilot is left as found), ENGAGING, ENGAGED
(commanding), STANDING_BY, RECOVERING, TAKEN_OVER (a person acted; no keys until engage()),
FAILED (unrecoverable hang; no keys until engage()), HOLDING (the firmware is in ALARM: the pilot
keeps its course in Auto; nothing is sent, no hang check, no recovery; a person's key or mode
change is still a takeover).

The driver's rule: keys go out on its own (course steps, hang recovery, re-sends of an asked mode)
only in ENGAGING/ENGAGED/RECOVERING/STANDING_BY, i.e. while the firmware is in AUTO or has just
been asked for Standby. The one exception is the takeover race below.

Keystroke stepping: keys at least `key_interval_ms` apart; a key waits for the one before to be
confirmed (a later 0x84 shows the course expected after it) for `inflight_wait_ms`, and after
that is sent anyway, up to `keys_in_flight` not yet confirmed, each reckoned from the course
expected once those land. A status confirms every key up to the latest whose expected course
its locked course equals (the pilot applies them in order); the oldest key not confirmed within
`confirm_timeout_ms` times out with all after it, and stepping starts again from the next
status. A pilot that answers each key with an 0x84 (BOAT_AND_BENCHMARK.md) confirms within the
wait, one key at a time; one that sends its 0x84 only once a second would otherwise get one key
a second (docs/SEATALK.md "Keys in flight"). +-10 is used when |error| >= `ten_from_deg`
(default 7: at most 3 deg of overshoot; 17 deg takes 5 keys, not 8).

A person taking over: any keystroke datagram that reaches on_datagram -> EV_TAKEOVER at once
(0x86 carries its own check byte). Our own keystrokes never get here: StLink consumes their echo
byte by byte (it writes a byte only after the previous one's echo), so a hand remote with our
sender id still wins. Sender 0 (the pilot's own keypad) is refused as our id by the config schema.
The takeover race: our Auto (recovery or engage) may reach the pilot just after a person's
Standby (the pilot acts on its own keypad at once and tells the bus later, so bus order does not
say which came first). When the pilot goes to Auto unasked after a takeover, our last key was Auto
(its echo complete within `mode_confirm_ms`, see on_sent) and the person's key was not Auto, it is
answered with Standby and EV_OWN_AUTO_UNDONE: a person always wins. A mode
change we did not ask for, while commanding, is believed only when the next 0x84/0x95 shows the
same mode (SeaTalk has no checksum: one flipped bit in the mode byte must not end AUTO). Until then
the datagram is set aside and no keys are sent, so a person still wins within one status period.

The hung pilot (ARCHITECTURE.md), while ENGAGED:
  (a) `hang_unconfirmed_n` keystroke timeouts in a row (keys in flight that time out together are
      one), twice that within _NOISE_MS of a bus error the app reported (bus_noise: a corrupt key
      is lost, not ignored by a hung pilot);
  (b) no 0x84/0x95 status for `status_timeout_ms`;
  (c) in Auto, |locked course - heading| above `converge_err_deg` for a whole window of
      `converge_window_ms` in which the heading moved towards the locked course by less than
      `converge_progress_deg`. This measures the pilot's turning, not the error, so new commands
      (which move the locked course) cannot hide a pilot that keeps talking but stops steering.
      A window whose reported rudder came over by 10 deg or more to the side that turns towards
      the course (and stands at least 5 deg there) is extended once: the pilot steers, its slow
      ram is still reversing; the progress is then counted over both windows.
      The heading is the GNSS heading when the app feeds it (`note_motion`: checksummed, 5 Hz),
      else the pilot's compass; below `converge_min_speed_mps` (when known) the window restarts.
Recovery: Standby (confirmed), pause `recover_pause_ms`, Auto (confirmed), then the course is
re-stepped to compass + the last relative setpoint; each step is an EV_RECOVER event. After
`recover_retries` failed attempts: EV_UNRECOVERABLE, state FAILED.
"""
from trackpilot.compat import const, ticks_diff, wrap180, wrap360
from trackpilot.devices import seatalk as st

IDLE = const(0)
ENGAGING = const(1)
ENGAGED = const(2)
STANDING_BY = const(3)
RECOVERING = const(4)
TAKEN_OVER = const(5)
FAILED = const(6)
HOLDING = const(7)
STATE_NAMES = ("idle", "engaging", "engaged", "standing_by", "recovering", "taken_over", "failed",
               "holding")

EV_MODE = "MODE"  # the pilot's mode changed (reason says asked/unasked)
EV_ENGAGED = "ENGAGED"
EV_ENGAGE_FAILED = "ENGAGE_FAILED"
EV_STANDBY = "STANDBY"  # standby confirmed
EV_STANDBY_FAILED = "STANDBY_FAILED"
EV_TAKEOVER = "TAKEOVER"
EV_PERSON_KEY = "PERSON_KEY"  # a keystroke that is not ours (also when not commanding)
EV_KEY_UNCONFIRMED = "KEY_UNCONFIRMED"
EV_HANG = "HANG"
EV_RECOVER = "RECOVER"
EV_RECOVERED = "RECOVERED"
EV_UNRECOVERABLE = "UNRECOVERABLE"
EV_STATUS_LOST = "STATUS_LOST"
EV_STATUS_BACK = "STATUS_BACK"
EV_OWN_AUTO_UNDONE = "OWN_AUTO_UNDONE"  # our Auto landed after a takeover: Standby sent back

_NOISE_MS = const(30000)  # the bus counts as noisy this long after its last error
_R_STANDBY_SEND = const(0)
_R_STANDBY_WAIT = const(1)
_R_AUTO_SEND = const(2)
_R_AUTO_WAIT = const(3)


class St2000:
    def __init__(self, send, sender_id=1, odd_rule=st.ODD_DOTNET, key_interval_ms=250,
                 confirm_timeout_ms=1500, mode_confirm_ms=2000, mode_resends=2,
                 status_timeout_ms=3500, hang_unconfirmed_n=3, converge_err_deg=15.0,
                 converge_window_ms=15000, converge_progress_deg=8.0, converge_min_speed_mps=0.8,
                 recover_retries=3,
                 recover_pause_ms=1000, ten_from_deg=7.0, tolerance_deg=0.5, keys_in_flight=3,
                 inflight_wait_ms=600, rudder_sign=1, events_len=32):
        if isinstance(odd_rule, str):
            odd_rule = st.ODD_KNAUF if odd_rule == "knauf" else st.ODD_DOTNET
        self.send = send
        self.sender_id = sender_id
        self.odd_rule = odd_rule
        self.key_interval_ms = key_interval_ms
        self.confirm_timeout_ms = confirm_timeout_ms
        self.mode_confirm_ms = mode_confirm_ms
        self.mode_resends = mode_resends
        self.status_timeout_ms = status_timeout_ms
        self.hang_unconfirmed_n = hang_unconfirmed_n
        self.converge_err_deg = converge_err_deg
        self.converge_window_ms = converge_window_ms
        self.converge_progress_deg = converge_progress_deg
        self.converge_min_speed_mps = converge_min_speed_mps
        self.recover_retries = recover_retries
        self.recover_pause_ms = recover_pause_ms
        self.ten_from_deg = ten_from_deg
        self.tolerance_deg = tolerance_deg
        self.keys_in_flight = max(1, int(keys_in_flight))
        # the rudder report's sign: 1 as PROTOCOLS.md (+ = steer right), -1 reversed, 0 not used
        # (to be confirmed on the boat: `trackpilot tune` finds it from the trial's circles)
        self.rudder_sign = int(rudder_sign)
        self.inflight_wait_ms = inflight_wait_ms
        self._evmax = events_len
        self._ev = []
        # what the pilot reports (None until seen)
        self.mode = None  # seatalk.MODE_*
        self.mode_raw = None
        self.heading_deg = None  # the pilot's own compass, whole degrees
        self.course_deg = None  # locked course (0.5 deg steps)
        self.rudder_deg = None
        self.turning_stbd = False
        self.off_course = False
        self.setting_mode = False  # last status was 0x95
        self.last_status_ms = None  # last 0x84/0x95
        self.last_heading_ms = None  # last 0x84/0x95/0x9C
        self.status_lost = False
        # what we command
        self.state = IDLE
        self.target_course_deg = None
        self.last_relative_deg = None
        self._want = None  # mode asked for (MODE_AUTO / MODE_STANDBY) or None
        self._want_t = 0
        self._want_sends = 0
        self._fl = []  # keys awaiting confirmation, oldest first: [key, t_ms sent, course expected after it]
        self._sync_ms = None  # keys timed out or failed then: no key until a status newer than that
        self._last_key_t = None
        self._sent_key = None  # our last keystroke on the bus (on_sent), for the takeover race
        self._sent_key_t = 0
        self._person_key = None  # the last keystroke not ours
        self._unconf = 0
        self._conv_t0 = None  # start of the convergence window (None: not armed)
        self._conv_h0 = 0.0  # heading at its start
        self._conv_side = 0  # +1: locked course to starboard of the heading, -1: to port
        self._conv_src = 0  # 1: GNSS heading, 0: pilot compass
        self._conv_r0 = None  # the reported rudder at the window's start (None: not reported)
        self._conv_ext = False  # the window was extended once: the pilot was reversing its rudder
        self._gh_deg = None  # GNSS heading and speed from note_motion()
        self._gh_t = 0
        self._sog_mps = None
        self._mode_suspect = None  # an unasked mode seen once, waiting for the next status
        self.mode_glitches = 0  # unasked modes not repeated by the next status (bus noise)
        self._rstage = _R_STANDBY_SEND
        self._rattempt = 0
        self._rt = 0
        # counters (HMI and log)
        self.keys_sent = 0
        self.keys_confirmed = 0
        self.keys_unconfirmed = 0
        self.send_blocked = 0
        self.hangs = 0
        self.recoveries = 0
        self.recover_attempts = 0
        self.takeovers = 0
        self.bad_datagrams = 0
        self.noise_ms = None  # the last bus error the app reported (bus_noise); None: quiet

    @classmethod
    def from_config(cls, send, pilot_cfg):
        """Build from the config's "pilot" section; keys this driver does not use are skipped
        (e.g. deadband_deg, a setting of the pilot itself)."""
        names = ("sender_id", "odd_rule", "key_interval_ms", "confirm_timeout_ms", "mode_confirm_ms",
                 "mode_resends", "status_timeout_ms", "hang_unconfirmed_n", "converge_err_deg",
                 "converge_window_ms", "converge_progress_deg", "converge_min_speed_mps",
                 "recover_retries", "recover_pause_ms", "ten_from_deg", "tolerance_deg", "keys_in_flight",
                 "inflight_wait_ms", "rudder_sign")
        kw = {}
        for k in names:
            if k in pilot_cfg:
                kw[k] = pilot_cfg[k]
        return cls(send, **kw)

    # ---- events ----
    def pop_event(self):
        return self._ev.pop(0) if self._ev else None

    def _event(self, name, t_ms, reason):
        if len(self._ev) >= self._evmax:
            self._ev.pop(0)
        self._ev.append((name, t_ms, reason))

    def status_fresh(self, t_ms):
        return self.last_status_ms is not None and ticks_diff(t_ms, self.last_status_ms) <= self.status_timeout_ms

    def commanding(self):
        return self.state == ENGAGING or self.state == ENGAGED or self.state == RECOVERING

    def watching(self):
        """A person's key or an unasked mode change ends what we do (commanding or holding)."""
        return self.commanding() or self.state == HOLDING

    # ---- sending ----
    def _send_key(self, key, t_ms):
        if not self.send(st.encode_86(key, self.sender_id)):
            self.send_blocked += 1
            return False
        self.keys_sent += 1
        self._last_key_t = t_ms
        return True

    def on_sent(self, dg, t_ms):
        """The link saw the whole echo of one of our datagrams (StLink.on_sent): it is on the bus
        now, in order with the datagrams delivered to on_datagram."""
        if len(dg) == 4 and dg[0] == 0x86:
            self._sent_key = dg[2]
            self._sent_key_t = t_ms

    def _ask_mode(self, mode, t_ms):
        self._want = mode
        self._want_t = t_ms
        self._want_sends = 1
        del self._fl[:]
        self._send_key(st.KEY_AUTO if mode == st.MODE_AUTO else st.KEY_STANDBY, t_ms)

    def on_send_failed(self, dg, t_ms):
        """The link gave up on one of our datagrams (bus fault): a keystroke that never went out
        does not count as unconfirmed by the pilot."""
        if len(dg) == 4 and dg[0] == 0x86 and self._fl and dg[2] in st.KEY_DELTA_DEG:
            del self._fl[:]  # the expectations after it are off: start again from the next status
            self._sync_ms = t_ms

    # ---- commands ----
    def engage(self, t_ms):
        """Put the pilot in Auto (only when asked). False (+ EV_ENGAGE_FAILED) if the pilot is
        silent or in a mode a person chose (wind, track, calibration)."""
        if not self.status_fresh(t_ms):
            self._event(EV_ENGAGE_FAILED, t_ms, "no status from the pilot")
            return False
        self._reset_hang()
        self._person_key = None
        if self.mode == st.MODE_AUTO:
            self.state = ENGAGED
            self._want = None
            self.target_course_deg = None
            self._event(EV_ENGAGED, t_ms, "pilot already in auto")
            return True
        if self.mode != st.MODE_STANDBY:
            self._event(EV_ENGAGE_FAILED, t_ms, "pilot in %s mode" % st.MODE_NAMES[self.mode])
            return False
        self.state = ENGAGING
        self.target_course_deg = None
        self._ask_mode(st.MODE_AUTO, t_ms)
        return True

    def standby(self, t_ms):
        """Send Standby (always allowed: it frees the tiller), confirm it, re-send bounded."""
        self.target_course_deg = None
        del self._fl[:]
        if self.status_fresh(t_ms) and self.mode == st.MODE_STANDBY:
            self.state = IDLE
            self._want = None
            self._event(EV_STANDBY, t_ms, "pilot already in standby")
            return
        self.state = STANDING_BY
        self._ask_mode(st.MODE_STANDBY, t_ms)

    def hold(self, t_ms, reason="alarm"):
        """The firmware is in ALARM: leave the pilot in Auto on its course and send nothing more
        (no steps, no hang recovery, no re-sends); a person's key is still a takeover."""
        if not self.commanding():
            return  # idle, taken over or failed: already sending nothing
        self.state = HOLDING
        self._want = None
        del self._fl[:]
        self.target_course_deg = None
        self._event(EV_MODE, t_ms, "driver holding, sends nothing: " + reason)

    def let_go(self, t_ms, reason="released"):
        """Stop commanding without sending anything (leave the pilot as it is)."""
        self.state = IDLE
        self._want = None
        del self._fl[:]
        self.target_course_deg = None
        self._event(EV_MODE, t_ms, "driver idle: " + reason)

    def steer_to(self, relative_deg, t_ms):
        """Set the locked course to (pilot compass + relative_deg), whole degrees. Returns False
        when not commanding (nothing is sent). ValueError on a non-finite or absurd value."""
        r = float(relative_deg)
        if not (-180.0 <= r <= 180.0):  # also false for NaN
            raise ValueError("relative course %r outside -180..180" % (relative_deg,))
        self.last_relative_deg = r
        if self.state != ENGAGED or self.heading_deg is None:
            return False
        self.target_course_deg = wrap360(float(int(self.heading_deg + r + 360.5) - 360))
        return True

    # ---- input ----
    def on_datagram(self, dg, t_ms):
        cmd = dg[0] if len(dg) else -1
        if cmd not in (0x84, 0x95, 0x9C, 0x86):
            return
        if not st.plausible(dg):
            self.bad_datagrams += 1
            return
        d = st.decode(dg, self.odd_rule)
        if cmd == 0x86:
            self._on_key(d, t_ms)
            return
        if cmd != 0x9C and self._unasked_once(d["mode"], t_ms):
            return  # set aside until the next status says the same
        self.heading_deg = d["heading_deg"]
        self.rudder_deg = d["rudder_deg"] * self.rudder_sign if self.rudder_sign else None
        self.turning_stbd = d["turning_stbd"]
        self.last_heading_ms = t_ms
        if cmd == 0x9C:
            return
        self.setting_mode = cmd == 0x95
        self.course_deg = d["course_deg"]
        self.off_course = d["off_course"]
        self.mode_raw = d["mode_raw"]
        self.last_status_ms = t_ms
        if self.status_lost:
            self.status_lost = False
            self._event(EV_STATUS_BACK, t_ms, "pilot status back")
        old = self.mode
        self.mode = d["mode"]
        if old != self.mode:
            self._on_mode_change(old, t_ms)
        fl = self._fl
        for k in range(len(fl) - 1, -1, -1):
            # the latest key whose expected course this status shows: it and all before it landed
            if ticks_diff(t_ms, fl[k][1]) >= 0 and abs(wrap180(self.course_deg - fl[k][2])) < 0.25:
                self.keys_confirmed += k + 1
                self._unconf = 0
                del fl[:k + 1]
                break

    def _unasked_once(self, new, t_ms):
        """True when this status shows, for the first time, a mode we did not ask for while
        commanding: the whole datagram is then held back (it may be corrupt) and keys stop
        until the next status confirms or contradicts it."""
        old = self.mode
        if old is None or new == old or new == self._want or not self.watching():
            if self._mode_suspect is not None and new == old:
                self.mode_glitches += 1
                self._event(EV_MODE, t_ms, "status read %s once, not repeated: ignored (bus noise?)" % (
                    st.MODE_NAMES[self._mode_suspect]))
            self._mode_suspect = None
            return False
        if self._mode_suspect == new:
            self._mode_suspect = None  # second status in a row: real
            return False
        self._mode_suspect = new
        self.last_status_ms = t_ms  # the pilot is talking, even if this reading is doubtful
        self._event(EV_MODE, t_ms, "status reads %s while %s, unasked: waiting for the next status" % (
            st.MODE_NAMES[new], st.MODE_NAMES[old]))
        return True

    def _on_key(self, d, t_ms):
        # never our own: the link consumed our echo (see the module doc)
        self._person_key = d["key"]
        why = "key %s from sender %d" % (d["key_name"], d["sender"])
        self._event(EV_PERSON_KEY, t_ms, why)
        if self.watching() or self.state == STANDING_BY:
            self._takeover(t_ms, why)

    def _on_mode_change(self, old, t_ms):
        new = self.mode
        asked = self._want is not None and new == self._want
        if old is None:
            self._event(EV_MODE, t_ms, "pilot found in %s" % st.MODE_NAMES[new])
        else:
            self._event(EV_MODE, t_ms, "%s -> %s (%s)" % (
                st.MODE_NAMES[old], st.MODE_NAMES[new], "asked" if asked else "unasked"))
        if asked:
            self._mode_confirmed(t_ms)
        elif (self.state == TAKEN_OVER and new == st.MODE_AUTO and self._person_key != st.KEY_AUTO
              and self._sent_key == st.KEY_AUTO
              and ticks_diff(t_ms, self._sent_key_t) <= self.mode_confirm_ms):
            # our Auto landed after the person's key: the person wins
            self._event(EV_OWN_AUTO_UNDONE, t_ms, "pilot went to auto on our own key after a takeover: "
                        "standby sent back")
            self.standby(t_ms)
        elif self.watching() and old is not None:
            # a person (or the pilot itself) changed the mode while we were commanding
            if not (self.state == RECOVERING and self._rstage == _R_STANDBY_WAIT and new == st.MODE_STANDBY):
                self._takeover(t_ms, "pilot left %s unasked: now %s" % (
                    st.MODE_NAMES[old], st.MODE_NAMES[new]))

    def _mode_confirmed(self, t_ms):
        want = self._want
        self._want = None
        if self.state == ENGAGING:
            self.state = ENGAGED
            self._reset_hang()
            self._event(EV_ENGAGED, t_ms, "auto confirmed")
        elif self.state == STANDING_BY:
            self.state = IDLE
            self._event(EV_STANDBY, t_ms, "standby confirmed")
        elif self.state == RECOVERING:
            if want == st.MODE_STANDBY:
                self._rstage = _R_AUTO_SEND
                self._rt = t_ms
                self._event(EV_RECOVER, t_ms, "attempt %d: standby confirmed" % (self._rattempt + 1))
            else:
                self.state = ENGAGED
                self.recoveries += 1
                self._reset_hang()
                if self.last_relative_deg is not None:
                    self.steer_to(self.last_relative_deg, t_ms)
                self._event(EV_RECOVERED, t_ms, "auto confirmed; re-stepping to %s" % (
                    "none" if self.target_course_deg is None else "%d" % self.target_course_deg))

    def _takeover(self, t_ms, why):
        self.takeovers += 1
        self.state = TAKEN_OVER
        self._want = None
        del self._fl[:]
        self.target_course_deg = None
        self._event(EV_TAKEOVER, t_ms, why)

    def _reset_hang(self):
        self._unconf = 0
        self._conv_t0 = None
        del self._fl[:]
        self._sync_ms = None
        self._mode_suspect = None

    def note_motion(self, t_ms, heading_deg=None, speed_mps=None):
        """Optional, once per GNSS epoch: the boat's true heading (None when invalid) and speed
        over ground (None when unknown) for hang check (c)."""
        self._gh_deg = heading_deg
        self._gh_t = t_ms
        self._sog_mps = speed_mps

    # ---- time ----
    def next_due_ms(self, t_ms, cap_ms=1000):
        """Milliseconds until poll() has something to do (0 = now), at most cap_ms; for a shell
        that sleeps between polls. A received datagram or a command can make it sooner."""
        due = [cap_ms]
        if self.last_status_ms is not None and not self.status_lost:
            due.append(ticks_diff(self.last_status_ms, t_ms) + self.status_timeout_ms + 1)
        s = self.state
        if self._want is not None:
            due.append(ticks_diff(self._want_t, t_ms) + self.mode_confirm_ms)
        if s == RECOVERING and (self._rstage == _R_STANDBY_SEND or self._rstage == _R_AUTO_SEND):
            due.append(ticks_diff(self._rt, t_ms) + self.recover_pause_ms if self._rattempt or
                       self._rstage == _R_AUTO_SEND else 0)
        if s == ENGAGED:
            if self._fl:
                due.append(ticks_diff(self._fl[0][1], t_ms) + self.confirm_timeout_ms)
            if (self.target_course_deg is not None and self.course_deg is not None and self._sync_ms is None
                    and len(self._fl) < self.keys_in_flight and self._keys_allowed() and abs(
                        wrap180(self.target_course_deg - self._expected_course())) > self.tolerance_deg):
                d = 0 if self._last_key_t is None else ticks_diff(self._last_key_t, t_ms) + self.key_interval_ms
                if self._fl:
                    w = ticks_diff(self._fl[0][1], t_ms) + self.inflight_wait_ms
                    d = w if w > d else d
                due.append(d)
            if self._conv_t0 is not None:
                due.append(ticks_diff(self._conv_t0, t_ms) + self.converge_window_ms)
        d = min(due)
        return d if d > 0 else 0

    def poll(self, t_ms):
        if self.last_status_ms is not None and not self.status_lost and not self.status_fresh(t_ms):
            self.status_lost = True
            self._event(EV_STATUS_LOST, t_ms, "no 0x84 for %d ms" % ticks_diff(t_ms, self.last_status_ms))
            if self.state == ENGAGED:
                self._hang(t_ms, "status stopped arriving")
        s = self.state
        if s == ENGAGING or s == STANDING_BY:
            self._poll_want(t_ms)
        elif s == ENGAGED:
            self._poll_engaged(t_ms)
        elif s == RECOVERING:
            self._poll_recover(t_ms)

    def _want_timed_out(self, t_ms):
        """True when the asked mode did not come and the re-sends are used up."""
        if ticks_diff(t_ms, self._want_t) < self.mode_confirm_ms:
            return False
        if self._want_sends <= self.mode_resends:
            self._want_sends += 1
            self._want_t = t_ms
            self._send_key(st.KEY_AUTO if self._want == st.MODE_AUTO else st.KEY_STANDBY, t_ms)
            return False
        return True

    def _poll_want(self, t_ms):
        if self._want is None or not self._want_timed_out(t_ms):
            return
        name = EV_ENGAGE_FAILED if self.state == ENGAGING else EV_STANDBY_FAILED
        self._event(name, t_ms, "%s not confirmed after %d sends" % (
            st.MODE_NAMES[self._want], self._want_sends))
        self._want = None
        self.state = IDLE

    def _keys_allowed(self):
        """May a course key go out now? (poll() and next_due_ms() must agree, or a shell that
        sleeps on next_due_ms() would be woken "now" for a key that poll() will not send.)"""
        # a doubtful mode: maybe a person; no keys until the next status tells
        return self.mode == st.MODE_AUTO and not self.status_lost and self._mode_suspect is None

    def _poll_engaged(self, t_ms):
        if not self._keys_allowed():
            return
        if self._converge_check(t_ms):
            return
        # (a) keystrokes not followed: the oldest timed out, and every key sent after it (one
        # missing confirmation: a single lost status must not count as several keys ignored)
        fl = self._fl
        if fl and ticks_diff(t_ms, fl[0][1]) >= self.confirm_timeout_ms:
            n = len(fl)
            self.keys_unconfirmed += n
            self._unconf += 1
            self._event(EV_KEY_UNCONFIRMED, t_ms, "key %s%s: course %s, expected %s" % (
                st.KEY_NAMES[fl[0][0]], " and %d after it" % (n - 1) if n > 1 else "", self.course_deg,
                fl[0][2]))
            del fl[:]
            self._sync_ms = t_ms  # the reported course may not show keys that landed since
            need = self.hang_unconfirmed_n
            if self.bus_noisy(t_ms):
                need *= 2  # a noisy bus loses keys (no checksum but the 0x86 complement)
            if self._unconf >= need:
                self._hang(t_ms, "%d keystrokes in a row not followed%s" % (
                    self._unconf, " (bus noisy)" if need != self.hang_unconfirmed_n else ""))
                return
        if self.target_course_deg is None or len(fl) >= self.keys_in_flight:
            return
        if self._sync_ms is not None:
            if self.last_status_ms is None or ticks_diff(self.last_status_ms, self._sync_ms) <= 0:
                return  # wait for a status that shows what landed
            self._sync_ms = None
        if fl and ticks_diff(t_ms, fl[0][1]) < self.inflight_wait_ms:
            return  # its confirmation may be on the way
        if self._last_key_t is not None and ticks_diff(t_ms, self._last_key_t) < self.key_interval_ms:
            return
        base = self._expected_course()
        e = wrap180(self.target_course_deg - base)
        if abs(e) <= self.tolerance_deg:
            return
        if e >= self.ten_from_deg:
            key = st.KEY_PLUS_10
        elif e <= -self.ten_from_deg:
            key = st.KEY_MINUS_10
        elif e > 0:
            key = st.KEY_PLUS_1
        else:
            key = st.KEY_MINUS_1
        if self._send_key(key, t_ms):
            fl.append([key, t_ms, wrap360(base + st.KEY_DELTA_DEG[key])])

    def _expected_course(self):
        """The locked course once the keys in flight have landed (the reported one if none)."""
        return self._fl[-1][2] if self._fl else self.course_deg

    def bus_noise(self, t_ms):
        """The app saw a bus error (a corrupt or broken datagram). Returns True when the bus was
        quiet before (worth a log line)."""
        was = self.bus_noisy(t_ms)
        self.noise_ms = t_ms
        return not was

    def bus_noisy(self, t_ms):
        """A bus error within the last _NOISE_MS: hang rule (a) then needs twice the lost keys."""
        if self.noise_ms is None:
            return False
        d = ticks_diff(t_ms, self.noise_ms)
        if 0 <= d < _NOISE_MS:
            return True
        self.noise_ms = None  # quiet again (or so old that the tick difference wrapped)
        return False

    def _converge_check(self, t_ms):
        """Hang check (c): True when it fired. The window measures how far the heading moved
        towards the locked course, whatever the locked course did meanwhile."""
        err = wrap180(self.course_deg - self.heading_deg)
        sog = self._sog_mps
        if abs(err) <= self.converge_err_deg or (sog is not None and sog < self.converge_min_speed_mps):
            self._conv_t0 = None  # converged, or too slow for the rudder to bite
            return False
        if self._gh_deg is not None and ticks_diff(t_ms, self._gh_t) <= 1000:
            h, src = self._gh_deg, 1
        else:
            h, src = float(self.heading_deg), 0
        side = 1 if err > 0 else -1
        if self._conv_t0 is None or side != self._conv_side or src != self._conv_src:
            self._conv_t0 = t_ms
            self._conv_h0 = h
            self._conv_moved = 0.0
            self._conv_side = side
            self._conv_src = src
            self._conv_r0 = self.rudder_deg
            self._conv_ext = False
            return False
        # summed step by step: a turn of more than 180 deg in a window (a turning circle) is progress
        self._conv_moved += side * wrap180(h - self._conv_h0)
        self._conv_h0 = h
        dt_ms = ticks_diff(t_ms, self._conv_t0)
        if dt_ms < self.converge_window_ms:
            return False
        moved_deg = self._conv_moved
        if moved_deg < self.converge_progress_deg:
            r0, r1 = self._conv_r0, self.rudder_deg
            if (not self._conv_ext and r0 is not None and r1 is not None
                    and side * r1 >= 5 and side * (r1 - r0) >= 10):
                # the pilot is steering: its rudder came over to the side that turns towards the
                # course (a slow ram reversing after an overshoot takes most of a window): one more
                # window, the progress counted over both (docs/SEATALK.md, "Hang, while ENGAGED")
                self._conv_ext = True
                self._conv_t0 = t_ms
                return False
            self._hang(t_ms, "heading %d not turning towards course %s: %.1f deg towards it in %d s, error %d deg" % (
                self.heading_deg, self.course_deg, moved_deg,
                (dt_ms + (self.converge_window_ms if self._conv_ext else 0)) // 1000, int(abs(err))))
            return True
        self._conv_t0 = t_ms  # turning well enough: next window
        self._conv_moved = 0.0
        self._conv_r0 = self.rudder_deg
        self._conv_ext = False
        return False

    def _hang(self, t_ms, why):
        self.hangs += 1
        self._event(EV_HANG, t_ms, why)
        self.state = RECOVERING
        self._rattempt = 0
        self._rstage = _R_STANDBY_SEND
        self._rt = t_ms
        del self._fl[:]
        self._want = None

    def _attempt_failed(self, t_ms, why):
        self._rattempt += 1
        self._want = None
        if self._rattempt >= self.recover_retries:
            self.state = FAILED
            self.target_course_deg = None
            self._event(EV_UNRECOVERABLE, t_ms, "%d recovery attempts failed; last: %s; pilot mode %s" % (
                self._rattempt, why, "unknown" if self.mode is None else st.MODE_NAMES[self.mode]))
            return
        self._event(EV_RECOVER, t_ms, "attempt %d failed: %s" % (self._rattempt, why))
        self._rstage = _R_STANDBY_SEND
        self._rt = t_ms

    def _poll_recover(self, t_ms):
        r = self._rstage
        if r == _R_STANDBY_SEND:
            if self._rattempt and ticks_diff(t_ms, self._rt) < self.recover_pause_ms:
                return
            self.recover_attempts += 1
            self._ask_mode(st.MODE_STANDBY, t_ms)
            self._rstage = _R_STANDBY_WAIT
            self._event(EV_RECOVER, t_ms, "attempt %d: standby sent" % (self._rattempt + 1))
            if self.mode == st.MODE_STANDBY and self.status_fresh(t_ms):
                self._mode_confirmed(t_ms)  # already there (e.g. it dropped out by itself)
        elif r == _R_AUTO_SEND:
            if ticks_diff(t_ms, self._rt) < self.recover_pause_ms:
                return
            self._ask_mode(st.MODE_AUTO, t_ms)
            self._rstage = _R_AUTO_WAIT
            self._event(EV_RECOVER, t_ms, "attempt %d: auto sent" % (self._rattempt + 1))
        elif self._want_timed_out(t_ms):
            self._attempt_failed(t_ms, "%s not confirmed" % st.MODE_NAMES[self._want])
