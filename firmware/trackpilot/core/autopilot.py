"""The decision core: every decision the firmware takes, in one plain class.

No asyncio, no clock reads, no files, no UARTs: each entry gets its inputs and the time as
arguments and leaves its outputs where the shell (app.py) picks them up. Its parts are the mode
machine (modes.py), the track progress and guidance law (nav/), dead reckoning, the commissioning
trial (trial.py), the ST2000+ driver (devices/st2000.py) on its SeaTalk link (stlink.py) and the
motor link (motor.py); who decides what is the table in docs/MODES.md ("Who decides what").

Inputs (one entry per kind):
    on_fix(t_ms, interval_ms, corr_age_s)   a completed GNSS epoch in `fix` (the control step)
    on_gnss_watch(t_ms, interval_ms, corr_age_s)  the supervisor's 100 ms look: gap timer, staleness
    on_seatalk_rx(buf, n, t_ms)             bytes read from the SeaTalk bus
    seatalk_tx(t_ms) / on_seatalk_tx_done(t_ms, now_ms)  the bus-access step: what to write, then its events
    on_pilot_tick(t_ms)                     the pilot driver's timers (every 100 ms)
    on_motor_rx(mv, n, t_ms) / motor_tick(t_ms)  the motor controller's replies / keep-alive frame
    on_wind_rx(mv, n, t_ms)                 bytes of the wind sensor
    on_estop(active, t_ms)                  the E-stop input's level
    on_key(name, source, t_ms, corr_age_s)  a person's command (ENGAGE, STANDBY, ACK, TRIAL, ...)
    set_track(...), restore_state(...)      a track the shell read; the state file it read
    settle(t_ms)                            a part was driven directly (test harness): its events
Outputs:
    pop_event() -> (kind, text, t_ms)       log events, in order
    rec / rec_ready                         the control record of the last step, to log
    state_due                               a state dict to save (the shell writes it atomically)
    throttle_duty, motor frame (motor_tick), SeaTalk bytes (seatalk_tx)
    wake_seatalk                            keys queued: the shell wakes its SeaTalk writer
The HMI reads the state attributes (mm, fix, progress, pilot, refusal, ...) through the app.

Usage:
    core = Autopilot(cfg, cfg_problems, fix, rand)
    core.on_fix(t_ms, gnss.interval_ms, corr_age_s)
    ev = core.pop_event()   # (kind, text, t_ms) until None; then core.rec if core.rec_ready
"""
from trackpilot.compat import ticks_diff, wrap180
from trackpilot.core import control
from trackpilot.core import modes as M
from trackpilot.devices import seatalk
from trackpilot.nav.fix import RTK_FIXED, RTK_FLOAT, RTK_NAMES, RTK_SINGLE
from trackpilot.record import logfmt

_RTK_BY_NAME = {"single": RTK_SINGLE, "float": RTK_FLOAT, "fixed": RTK_FIXED}
STATE_SAVE_MS = 10000  # the state file (leg, track) is rewritten at least this often


def _at_log_resolution(fix):
    """The control step's float inputs rounded to the log's resolution (0.01 deg, 1 mm/s ...),
    as a decoder gives them back: a replay of the log steers with exactly what the boat did."""
    q = logfmt.quantized
    fix.heading_deg = q("heading_deg", fix.heading_deg)
    fix.heading_acc_deg = q("heading_acc_deg", fix.heading_acc_deg)
    fix.sog_mps = q("sog_mps", fix.sog_mps)
    fix.cog_deg = q("cog_deg", fix.cog_deg)
    fix.h_acc_m = q("h_acc_m", fix.h_acc_m)


class Autopilot:
    def __init__(self, cfg, cfg_problems, fix, rand, rec=None):
        from trackpilot.config import rejected
        from trackpilot.devices import motor, mwv, st2000, stlink
        from trackpilot.nav import deadreckon, guidance

        self.cfg = cfg
        self.fix = fix  # filled by the GNSS parser (the shell's), read here once per epoch
        mcfg = cfg["modes"]
        self.mm = M.ModeMachine(mcfg)
        self.engage_min_rtk = _RTK_BY_NAME[mcfg["engage_min_rtk"]]
        self.steer_min_rtk = _RTK_BY_NAME[mcfg["steer_min_rtk"]]
        self.gnss_stale_ms = mcfg["gnss_stale_ms"]
        bcfg = cfg["boat"]
        self.dr = deadreckon.DeadReckoner()  # the position through GNSS gaps inside AUTO
        self.gnss_quality_name = "none"  # fixed / float / single / none / dead-reckoning (logged)
        self.rate_reported_ms = 0  # the receiver's epoch interval last reported
        self.interval_ms = 0  # the receiver's measured epoch interval (0: not known yet)
        self.dr_step_ms = None  # the last control step run by the gap timer
        self.dr_gap_s = 0.0  # the last dead-reckoned step: time since the fix, 1-sigma
        self.dr_sigma_m = 0.0
        self.wind = mwv.MwvParser()
        pcfg = cfg["pilot"]
        odd = seatalk.ODD_KNAUF if pcfg["odd_rule"] == "knauf" else seatalk.ODD_DOTNET
        self.framer = seatalk.Framer()
        self.stlink = stlink.StLink.from_config(pcfg, framer=self.framer, rand=rand)
        self.st_health = stlink.LinkHealth.from_config(pcfg)
        self.pilot = st2000.St2000.from_config(self.stlink.send, pcfg)
        self.pilot.odd_rule = odd
        self.stlink.on_datagram = self.pilot.on_datagram
        self.stlink.on_sent = self.pilot.on_sent
        self.motor = motor.MotorLink.from_config(cfg["motor"])
        self.alarm_reason = ""
        self._pilot_action = None
        self.law = guidance.make_law(cfg["guidance"], bcfg)
        self.track = None
        self.progress = None
        self.track_id = ""
        self.events = []  # (kind, text, t_ms) for the log, oldest first
        self.now_ms = 0  # the time of the entry being run (events of this call carry it)
        # the last control step's record (rec_ready: to log); the logger's own, filled in place
        self.rec = rec if rec is not None else logfmt.ControlRecord()
        self.rec_ready = False
        self.state_due = None  # a state to save: {"track_id", "leg", "mode"}
        self.wake_seatalk = False
        self.throttle_duty = 0.0
        if rejected(cfg_problems):
            # a person must know the boat runs on other settings than the file says: ENGAGE is
            # refused until they acknowledge (ACK) or the file is fixed (preconditions)
            # short: the HMI's status datagram carries 60 bytes of text
            fallback = "last good" if any("last good" in p for p in cfg_problems) else "defaults"
            self.mm.raise_alarm(M.AL_CONFIG, "config rejected: on %s; ACK to accept" % fallback)
        self.last_epoch_ms = None
        self.epochs = 0
        self.rpm_cmd = 0
        self.heading_cmd_deg = None
        self.relative_cmd_deg = 0.0
        self.compass_offset_deg = None  # pilot compass - true heading, filtered
        self.seed_baseline = cfg["guidance"]["law"] == "seed"
        self._offset_status_ms = None
        self._offset_n = 0
        self._prev_heading = None
        from trackpilot.core.pilotwatch import PilotWatch

        self._bus_errs = 0  # the framer's broken + the driver's implausible datagrams so far
        self.pilot_watch = PilotWatch()  # does the pilot's own loop hunt?
        self.pilot_db = None  # the pilot's deadband (core/pilotdb.py): made on the first los straight
        self._watch_status_ms = None
        self.refusal = ""
        self.corr_age_s = None  # age of the last RTK correction frame (the shell's reading)
        self.estop_input = False
        self.last_state_save_ms = None
        self.ref_lat_e7 = 0  # the boat's reference point (lever arm applied), last epoch
        self.ref_lon_e7 = 0
        from trackpilot.core import trial

        self.trial = trial.Trial(cfg.get("trial"))  # commissioning trial (docs/COMMISSIONING.md)
        self.trial_start_e7 = (0, 0)
        self._trial_prev = None  # (t_ms, heading_deg) of the last trial epoch

    # ------------------------------------------------------------------ outputs
    def event(self, kind, text):
        self.events.append((kind, text, self.now_ms))

    def pop_event(self):
        return self.events.pop(0) if self.events else None

    # ------------------------------------------------------------------ track and state
    def track_refusal(self):
        """Why a new track may not be activated now, or None (only in STANDBY)."""
        if self.mm.mode == M.AUTO:
            return "track not changed: only in STANDBY"
        return None

    def progress_for(self, new):
        """The progress along a new track, with the leg-advance rule of the configured law (the
        seed baseline keeps the plain seed rule, BOAT_AND_BENCHMARK.md)."""
        from trackpilot.nav import progress

        rule = progress.RULE_SEED if self.seed_baseline else progress.RULE_ROBUST
        return progress.Progress(new, rule)

    def set_track(self, new, new_id, prog, t_ms):
        self.now_ms = t_ms
        self.track = new
        self.progress = prog
        self.track_id = new_id

    def restore_state(self, st, t_ms):
        """After a reset: know where we were (leg), but stay in STANDBY. st: the state file's dict."""
        self.now_ms = t_ms
        if st.get("track_id") == self.track_id and self.progress is not None:
            leg = int(st.get("leg", 0))
            if 0 <= leg < len(self.track.waypoints) - 1:
                self.progress.set_leg(leg)
                self.event("STATE", "restored: leg %d of track %s (mode was %s); staying in STANDBY" % (
                    leg, self.track_id, st.get("mode", "?")))

    def save_state(self, t_ms):
        if self.progress is None:
            return
        self.state_due = {"track_id": self.track_id, "leg": self.progress.leg, "mode": M.MODE_NAMES[self.mm.mode]}
        self.last_state_save_ms = t_ms

    # ------------------------------------------------------------------ events of the parts
    def settle(self, t_ms):
        """The parts' pending events, handled now (after a part was driven directly: the device
        harness engages the mode machine itself)."""
        self.now_ms = t_ms
        self.drain_events()

    def drain_events(self):
        for kind, text in self.mm.drain_events():
            self.event(kind, text)
            if kind == "ALARM":
                self.alarm_reason = text
        while True:
            ev = self.pilot.pop_event()
            if ev is None:
                break
            self.on_pilot_event(ev[0], ev[1], ev[2])
        while True:
            ev = self.motor.pop_event()
            if ev is None:
                break
            self.on_motor_event(ev[0], ev[1], ev[2])
        for kind, text in self.mm.drain_events():  # reactions above may have changed modes
            self.event(kind, text)
            if kind == "ALARM":
                self.alarm_reason = text
        if self.trial.active and self.mm.mode != M.TRIAL:  # STANDBY, a person's key, an alarm
            self.trial.stop("mode %s" % self.mm.state_text())
        for text in self.trial.drain_marks():
            self.event("TRIAL", text)

    def on_pilot_event(self, kind, t, text):
        self.event("PILOT", "%s: %s" % (kind, text))
        if kind == "TAKEOVER":
            self.mm.takeover(t, text)
        elif kind == "HANG":
            self.mm.pilot_hang(t, text)
        elif kind == "RECOVERED":
            self.mm.pilot_recovered(t)
        elif kind == "OWN_AUTO_UNDONE":
            self.mm.raise_alarm(M.AL_TAKEOVER, text)  # sounds again: our key had undone theirs
        elif kind in ("UNRECOVERABLE", "ENGAGE_FAILED"):
            if self.mm.mode == M.AUTO:
                self.mm.pilot_lost(t, text)

    def on_link_health(self, h, t, text=""):
        """The SeaTalk link's verdict (stlink.LinkHealth): it cannot send keys, so the firmware
        cannot steer. Alarm, then ALARM mode (the pilot keeps its last course in Auto); the
        alarm clears when a datagram goes out again, AUTO only comes back by a person."""
        from trackpilot.devices import stlink

        if h == stlink.H_NONE:
            return
        why = self.st_health.reason(t) + (("; last: " + text) if text else "")
        if h == stlink.H_ALARM:
            self.mm.set_alarm(M.AL_SEATALK, True, why)
        elif h == stlink.H_LOST:
            self.event("SEATALK", "cannot send keys: " + why)
            self.mm.seatalk_lost(t, why)
        else:
            self.mm.set_alarm(M.AL_SEATALK, False, "SeaTalk datagram sent again")
        self.drain_events()
        self.apply_pilot(t)

    def on_motor_event(self, kind, t, text):
        self.event("MOTOR", "%s: %s" % (kind, text))
        if kind == "MOTOR_LINK_LOST":
            self.mm.motor_link(t, False, text)
        elif kind == "MOTOR_LINK_OK":
            self.mm.motor_link(t, True, text)
        elif kind == "LOW_BATTERY":
            self.mm.set_alarm(M.AL_LOW_BATTERY, True, text)
        elif kind == "BATTERY_OK":
            self.mm.set_alarm(M.AL_LOW_BATTERY, False, text)

    # ------------------------------------------------------------------ the person's commands
    def preconditions(self, t_ms, need_track=True):
        """The first engage precondition that fails, or None (a trial needs no track)."""
        if self.mm.alarms & M.AL_CONFIG and not self.mm.acked & M.AL_CONFIG:
            return "config rejected: ACK to sail on fallback"
        if need_track and self.track is None:
            return "no valid track loaded"
        fix = self.fix
        if self.last_epoch_ms is None or ticks_diff(t_ms, self.last_epoch_ms) > self.gnss_stale_ms:
            return "no GNSS fix (stale)"
        if not fix.pos_valid:
            return "no GNSS position"
        if fix.rtk < self.engage_min_rtk:
            return "RTK %s, need %s" % (RTK_NAMES[fix.rtk], RTK_NAMES[self.engage_min_rtk])
        if not fix.heading_valid:
            return "no valid dual-antenna heading"
        if not self.pilot.status_fresh(t_ms):
            return "tiller pilot not answering on SeaTalk"
        if self.pilot.mode not in (seatalk.MODE_STANDBY, seatalk.MODE_AUTO):
            return "tiller pilot in %s mode" % seatalk.MODE_NAMES[self.pilot.mode]
        if self.cfg["motor"]["link"] == "rs232" and self.cfg["motor"]["expect_replies"] and self.motor.link_ok is not True:
            return "motor link down"
        max_age = self.cfg["modes"]["correction_max_age_s"]
        if max_age > 0:
            age = self.corr_age_s
            if age is None:
                return "no RTK corrections received"
            if age > max_age:
                return "RTK corrections %.0f s old (limit %.0f s)" % (age, max_age)
        return None

    def on_key(self, name, source, t, corr_age_s):
        """A person's command (HMI button, remote box, host). PAGE is the display's own (the shell
        turns the page); unknown names do nothing."""
        self.now_ms = t
        self.corr_age_s = corr_age_s
        if name == "STANDBY":
            self.mm.standby(t, source)
            self.apply_pilot(t)
        elif name == "ENGAGE":
            if self.progress is not None and self.fix.pos_valid and self.progress.finished:
                self.progress.restart()
            refusal = self.preconditions(t)
            ok, why = self.mm.engage(t, refusal, source)
            self.refusal = why
            if ok:
                self.progress.join_nearest(self.ref_lat_e7, self.ref_lon_e7)
                self.law.reset()
                self._pilot_action = None
                self.apply_pilot(t)
                self.event("NAV", "joined leg %d" % self.progress.leg)
        elif name == "TRIAL":
            ok, why = self.mm.start_trial(t, self.preconditions(t, need_track=False), source)
            self.refusal = why
            if ok:
                self.trial_start_e7 = (self.fix.lat_e7, self.fix.lon_e7)
                self._trial_prev = None
                self.trial.start(t, self.fix.heading_deg, self.pilot.rudder_sign)
                self._pilot_action = None
                self.apply_pilot(t)
        elif name in ("NEXT_WP", "PREV_WP"):
            if self.progress is not None:
                if name == "NEXT_WP":
                    self.progress.skip()
                else:
                    self.progress.back()
                self.law.reset()
                self.event("NAV", "%s by %s: leg %d" % (name, source, self.progress.leg))
        elif name == "ACK":
            if self.mm.estop_latched:
                self.mm.estop_clear(t, self.estop_input, source)
            self.mm.ack(t, source)
        self.drain_events()

    def on_estop(self, active, t):
        """The E-stop input, sampled: its rising edge stops the boat (latched until ACK)."""
        self.now_ms = t
        if active and not self.estop_input:
            self.mm.estop(t, True)
            self.apply_pilot(t)
            self.drain_events()
        self.estop_input = active

    # ------------------------------------------------------------------ the control step
    def on_fix(self, t_ms, interval_ms, corr_age_s):
        """A completed GNSS epoch (self.fix): the control step."""
        self.interval_ms = interval_ms
        self.corr_age_s = corr_age_s
        self.control_step(t_ms)

    def on_gnss_watch(self, t_ms, interval_ms, corr_age_s):
        """The supervisor's look at the GNSS (every 100 ms): the gap timer in AUTO, staleness
        outside it."""
        from trackpilot.nav.deadreckon import gap_step_due

        self.now_ms = t_ms
        self.interval_ms = interval_ms
        self.corr_age_s = corr_age_s
        # the gap timer: once epochs stopped, the control step runs on the dead-reckoned position
        # (motor slowed at once), one step per epoch interval (deadreckon.gap_step_due)
        if self.mm.mode == M.AUTO and gap_step_due(t_ms, self.last_epoch_ms, interval_ms, self.dr_step_ms):
            self.control_step(t_ms, epoch=False)
        if self.mm.mode != M.AUTO and (self.last_epoch_ms is None or
                                       ticks_diff(t_ms, self.last_epoch_ms) > self.gnss_stale_ms):
            self.mm.gnss_quality(t_ms, False, "GNSS stale (no epoch for %d ms)" % self.gnss_stale_ms)
            self.drain_events()
            self.apply_pilot(t_ms)

    def control_step(self, t_ms, epoch=True):
        """Once per GNSS epoch: navigate, guide, command the pilot and the motor, log. With
        epoch=False, run by the gap timer when epochs stopped: the same step on the dead-reckoned
        position."""
        self.now_ms = t_ms
        fix = self.fix
        dt_s = control.epoch_dt_s(self.interval_ms)
        if epoch:
            self.last_epoch_ms = t_ms
            self.dr_step_ms = None
            self.epochs += 1
            _at_log_resolution(fix)
            ok, why = control.gnss_ok(fix, self.steer_min_rtk)
            self.check_rate()
        else:
            ok, why = False, "no GNSS epoch for %d ms" % ticks_diff(t_ms, self.last_epoch_ms)
            self.dr_step_ms = t_ms
        nav = self.navigation_fix(t_ms, ok, epoch, dt_s)
        dr = nav is not fix
        if dr:
            _at_log_resolution(nav)  # the dead-reckoned heading is logged as steered by, too
        self.mm.gnss_quality(t_ms, ok, why, dr=dr, bad_s=self.dr.hold_s if dr else None)
        self.note_quality(t_ms, ok, dr)
        mm = self.mm
        guiding = mm.mode == M.AUTO and not mm.holding and (not mm.degraded or mm.dead_reckoning)
        leg_before = self.progress.leg if self.progress is not None else 0
        if guiding and hasattr(self.law, "pilot_heading_deg"):
            self.law.pilot_heading_deg = self.dr_heading(t_ms)  # the frame its clip works in
        ref, out = control.guide_epoch(nav, self.progress, self.law, self.cfg["boat"], guiding, dt_s)
        if ref is not None:
            self.ref_lat_e7 = ref[0]
            self.ref_lon_e7 = ref[1]
            if self.progress.leg != leg_before:
                self.event("NAV", "leg %d -> %d" % (leg_before, self.progress.leg))
                self.save_state(t_ms)
        if out is not None:
            self.heading_cmd_deg = out.heading_cmd_deg
            if getattr(out, "note", ""):  # the los swing watch changed its tuning
                self.event("GUIDE", out.note)
            mm.xte(t_ms, self.progress.xte_m, 2.0 if fix.rtk == RTK_FLOAT else 1.0)
            if self.progress.finished:
                mm.arrived(t_ms, self.progress.finish_reason)
        self.drain_events()
        # the pilot; the true heading and speed let it tell a pilot that stopped steering
        if epoch:
            self.pilot.note_motion(t_ms, fix.heading_deg if fix.heading_valid else None,
                                   fix.sog_mps if fix.vel_valid else None)
        self.apply_pilot(t_ms)
        if epoch:
            self.update_compass_offset(t_ms)
            self.watch_pilot(t_ms)
            if hasattr(self.law, "heading_response"):
                # the closed heading response, fitted to the locked course (nav/tauest.py);
                # any epoch not steering on good GNSS drops the fitting window
                p = self.pilot
                note = self.law.heading_response(
                    t_ms, p.course_deg, fix.heading_deg,
                    out is not None and ok and guiding and mm.pilot == M.PILOT_STEER
                    and p.commanding() and fix.heading_valid and p.status_fresh(t_ms))
                if note:
                    self.event("GUIDE", note)
            if hasattr(self.law, "rudder_report"):  # the ram's rate from the reported rudder (los)
                p = self.pilot
                note = self.law.rudder_report(
                    p.last_heading_ms, p.rudder_deg,
                    guiding and mm.pilot == M.PILOT_STEER and p.commanding() and p.status_fresh(t_ms))
                if note:
                    self.event("GUIDE", note)
        fix = nav
        if mm.pilot == M.PILOT_STEER and out is not None and fix.heading_valid and self.pilot.commanding():
            # in the pilot's own compass frame: cancels its compass error (seed report 4.7)
            # the seed baseline keeps its pinned form: course = pilot compass + relative setpoint
            if self.compass_offset_deg is not None and not self.seed_baseline:
                target = out.heading_cmd_deg + self.compass_offset_deg
                # the pilot's deadband (core/pilotdb.py): only on a los straight in AUTO, the law at
                # its own tuning (a boat its swing watch retuned gets no relay on top)
                law, db = self.law, self.pilot_db
                active = (mm.mode == M.AUTO and getattr(law, "on_straight", False) and law.la_scale == 1.0
                          and law.lead_scale == 1.0 and law.clip_scale == 1.0)
                if active and db is None:
                    from trackpilot.core.pilotdb import PilotDeadband

                    pc = self.cfg["pilot"]
                    db = self.pilot_db = PilotDeadband(pc["deadband_deg"], pc["deadband_comp_frac"])
                if db is not None:
                    target = db.deadband_course(t_ms, target, fix.heading_deg + self.compass_offset_deg,
                                                self.pilot.course_deg, active)
                    if db.db_note:
                        self.event("PILOT", db.db_note)
                self.relative_cmd_deg = wrap180(target - self.pilot.heading_deg)
            else:
                self.relative_cmd_deg = wrap180(out.heading_cmd_deg - fix.heading_deg)
            self.pilot.steer_to(self.relative_cmd_deg, t_ms)
        elif self.pilot_db is not None:
            self.pilot_db.deadband_reset()
        if mm.mode == M.TRIAL and epoch:
            self.trial_epoch(t_ms)
        # the motor
        self.rpm_cmd = self.motor_rpm(out)
        self.motor.set_rpm(self.rpm_cmd)
        self.drain_events()
        self.fill_record(t_ms, out, nav)
        if self.last_state_save_ms is None or ticks_diff(t_ms, self.last_state_save_ms) > STATE_SAVE_MS:
            self.save_state(t_ms)
        self.wake_seatalk = True

    def trial_epoch(self, t_ms):
        """One epoch of the commissioning trial: the script decides, the pilot driver keys."""
        from trackpilot.nav import geo

        fix = self.fix
        p = self.pilot
        tr = self.trial
        prev = self._trial_prev
        rate = 0.0
        if prev is not None and ticks_diff(t_ms, prev[0]) > 0:
            rate = wrap180(fix.heading_deg - prev[1]) * 1000.0 / ticks_diff(t_ms, prev[0])
        self._trial_prev = (t_ms, fix.heading_deg)
        dist = geo.dist_bearing(self.trial_start_e7[0], self.trial_start_e7[1], fix.lat_e7, fix.lon_e7)[0]
        err = 0.0
        if p.course_deg is not None and p.heading_deg is not None:
            err = wrap180(p.course_deg - p.heading_deg)
        act = tr.step(t_ms, fix.heading_deg, fix.sog_mps if fix.vel_valid else 0.0, dist, err, rate)
        if act is not None:
            self.mm.end_trial(t_ms, "%s: %s" % act)
            self.drain_events()
            self.apply_pilot(t_ms)
            return
        if not p.commanding() or p.heading_deg is None:
            return
        if tr.lead_deg:
            p.steer_to(tr.lead_deg, t_ms)  # the locked course kept this far ahead: full rudder
        elif tr.course_delta_deg:
            base = p.target_course_deg if p.target_course_deg is not None else p.course_deg
            if base is not None:
                p.steer_to(wrap180(base + tr.course_delta_deg - p.heading_deg), t_ms)
        self.drain_events()

    def water_speed_cmd_mps(self):
        """Speed through water the motor is set for (the RPM map inverted; measured RPM if the
        controller reports it)."""
        mc = self.cfg["motor"]
        rpm = self.motor.rpm if self.motor.rpm is not None else self.rpm_cmd
        return max(0.0, (rpm - mc["rpm_offset"]) / mc["rpm_per_mps"])

    def dr_heading(self, t_ms):
        """True heading from the pilot's compass and the learnt offset, or None."""
        p = self.pilot
        if self.compass_offset_deg is None or p.heading_deg is None or not p.status_fresh(t_ms):
            return None
        return (p.heading_deg - self.compass_offset_deg) % 360.0

    def navigation_fix(self, t_ms, ok, epoch, dt_s):
        """The epoch to steer by: the GNSS fix when it is steerable (and the dead reckoner is
        anchored to it), else the dead-reckoned one, else the GNSS fix (not steerable)."""
        fix = self.fix
        dr = self.dr
        if ok:
            dr.good_fix(t_ms, fix, self.water_speed_cmd_mps(), dt_s)
            return fix
        if self.mm.mode != M.AUTO or not dr.valid:
            return fix
        h = self.dr_heading(t_ms)
        if h is None:
            return fix
        if epoch and fix.pos_valid and fix.rtk >= self.steer_min_rtk:
            # only the dual-antenna heading is missing: the RTK position with the compass heading
            dr.good_fix(t_ms, fix, self.water_speed_cmd_mps(), dt_s)
        # a degraded epoch's own Doppler velocity (a single fix has it to a few cm/s) beats the
        # water speed and current; its 1-2 m position does not beat dead reckoning (docs/GNSS.md)
        vel = (fix.sog_mps, fix.cog_deg) if epoch and fix.vel_valid and fix.pos_valid else None
        if not dr.predict(t_ms, h, self.water_speed_cmd_mps(), vel):
            return fix
        self.dr_gap_s = dr.gap_s(t_ms)
        self.dr_sigma_m = dr.sigma_m
        return dr.fix

    def note_quality(self, t_ms, ok, dead_reckoning):
        """The quality state steered by, logged on each change (with the DR uncertainty)."""
        fix = self.fix
        if dead_reckoning:
            name = "dead-reckoning"
        elif not fix.pos_valid or self.last_epoch_ms is None:
            name = "none"
        else:
            name = RTK_NAMES[fix.rtk]
        if name != self.gnss_quality_name:
            extra = ""
            if name == "dead-reckoning":
                extra = " (from the fix %.1f s ago, 1-sigma %.1f m, growing %.2f m/s)" % (
                    self.dr.gap_s(t_ms), self.dr.sigma_m, self.dr.sigma_rate_mps)
            elif self.gnss_quality_name == "dead-reckoning":
                extra = " (dead reckoning ended: %.1f s, 1-sigma %.1f m)" % (
                    self.dr_gap_s, self.dr_sigma_m)
            if name == "float":
                extra += " (steering with the XTE alarm limit doubled)"
            self.event("GNSS", "quality %s -> %s%s" % (self.gnss_quality_name, name, extra))
            self.gnss_quality_name = name

    def check_rate(self):
        """The receiver's measured epoch interval against the configured one (ubxcfg, 5 Hz)."""
        from trackpilot.devices import gnss

        iv = self.interval_ms
        if iv and iv != self.rate_reported_ms:
            self.rate_reported_ms = iv
            self.event("GNSS", "receiver epoch interval %d ms (%.1f Hz)%s" % (
                iv, 1000.0 / iv, "" if iv == gnss.EPOCH_MS else
                ", configured %d ms: the control step uses the measured one" % gnss.EPOCH_MS))

    def apply_pilot(self, t_ms):
        """Turn the mode machine's pilot decision into driver commands, once per change."""
        want = self.mm.pilot
        key = want * 8 + self.mm.mode  # AUTO(degraded) -> ALARM keeps PILOT_HOLD: still a change
        if key == self._pilot_action:
            return
        self._pilot_action = key
        if want == M.PILOT_STANDBY:
            self.pilot.standby(t_ms)
        elif want == M.PILOT_STEER:
            if not self.pilot.commanding():
                self.pilot.engage(t_ms)
        elif want == M.PILOT_LEAVE:
            if self.pilot.watching():
                self.pilot.let_go(t_ms, "mode %s" % self.mm.state_text())
        elif want == M.PILOT_HOLD and self.mm.mode != M.AUTO:
            # ALARM: the pilot keeps its course in Auto; the driver sends nothing on its own
            self.pilot.hold(t_ms, "mode %s" % self.mm.state_text())
        # PILOT_HOLD in AUTO(degraded/hold): no new steps; hang recovery stays allowed (AUTO).
        # PILOT_RECOVER: the driver runs Standby -> Auto -> re-step itself (st2000.py).
        self.wake_seatalk = True

    def watch_pilot(self, t_ms):
        """Feed each new pilot status to the pilot watch while we steer (AUTO) or sail the
        commissioning trial (TRIAL: its course steps are the plainest test of the pilot's own
        loop); log when the pilot starts or stops hunting (a person must lower its gain: shown on
        the HMI; `tune` refuses a trial in which it hunted)."""
        p = self.pilot
        st_ms = p.last_status_ms
        if self.mm.mode not in (M.AUTO, M.TRIAL) or st_ms is None or st_ms == self._watch_status_ms:
            return
        dt_s = 0.5 if self._watch_status_ms is None else ticks_diff(st_ms, self._watch_status_ms) / 1000.0
        self._watch_status_ms = st_ms
        text = self.pilot_watch.step(st_ms, dt_s, p.heading_deg, p.course_deg)
        if self.mm.mode == M.AUTO and hasattr(self.law, "pilot_rudder"):  # los: a ram at its stop in the approach's overshoot
            self.law.pilot_rudder(dt_s, p.rudder_deg)
        if (self.mm.mode == M.AUTO and self.mm.pilot == M.PILOT_STEER and p.commanding()
                and hasattr(self.law, "pilot_status")):  # los: the pilot's own gain (nav/pilotgain.py)
            note = self.law.pilot_status(st_ms, p.heading_deg, p.course_deg, p.rudder_deg,
                                         self.cfg["pilot"]["deadband_deg"])
            if note:
                self.event("GUIDE", note)
        if text:
            self.event("PILOT", text)
            if self.pilot_watch.hunting and self.mm.mode == M.AUTO and hasattr(self.law, "pilot_hunts"):
                note = self.law.pilot_hunts()  # steer it gently (the los law)
                if note:
                    self.event("GUIDE", note)

    def update_compass_offset(self, t_ms):
        """Low-pass estimate of (pilot compass - true heading). Steering to command + offset in the
        pilot's frame cancels its compass error like the instantaneous difference did, without
        feeding wave yaw and the compass's lag and 2 Hz sampling into every course step (which
        cost keystrokes and ~0.1 m RMS). New compass readings only, and only while the boat is not
        turning fast (the compass lags the true heading in a turn)."""
        p = self.pilot
        fix = self.fix
        tc_s = self.cfg["pilot"]["compass_offset_tc_s"]
        rate_dps = None
        if fix.heading_valid:
            if self._prev_heading is not None:
                dt_s = ticks_diff(t_ms, self._prev_heading[0]) / 1000.0
                if dt_s > 0:
                    rate_dps = wrap180(fix.heading_deg - self._prev_heading[1]) / dt_s
            self._prev_heading = (t_ms, fix.heading_deg)
        else:
            self._prev_heading = None
        if tc_s <= 0:
            self.compass_offset_deg = None  # switched off: the seed report's method
            return
        if p.heading_deg is None or not p.status_fresh(t_ms):
            return
        if p.last_status_ms == self._offset_status_ms or rate_dps is None:
            return
        self._offset_status_ms = p.last_status_ms
        if abs(rate_dps) > self.cfg["pilot"]["compass_offset_max_rate_dps"]:
            return
        sample = wrap180(p.heading_deg - fix.heading_deg)
        if self.compass_offset_deg is None:
            self.compass_offset_deg = sample
            self._offset_n = 1
            return
        self._offset_n += 1
        # a plain mean over the first samples, then an exponential filter (one sample a second)
        alpha = max(1.0 / self._offset_n, 1.0 / tc_s)
        self.compass_offset_deg = wrap180(self.compass_offset_deg + alpha * wrap180(sample - self.compass_offset_deg))

    def motor_rpm(self, out):
        mc = self.cfg["motor"]
        pol = self.mm.motor
        if pol == M.MOTOR_TRACK and self.mm.mode == M.TRIAL:
            return int(max(0, min(mc["rpm_max"], self.trial.rpm)))
        if pol == M.MOTOR_TRACK and out is not None:
            rpm = mc["rpm_offset"] + mc["rpm_per_mps"] * out.speed_cmd_mps
            if mc["sog_loop"] and self.fix.vel_valid:
                corr = mc["sog_loop_gain_rpm_per_mps"] * (out.speed_cmd_mps - self.fix.sog_mps)
                lim = mc["sog_loop_limit_rpm"]
                rpm += max(-lim, min(lim, corr))
            return int(max(0, min(mc["rpm_max"], rpm)))
        if pol == M.MOTOR_TRACK:  # AUTO without a guidance output this epoch: keep the last
            return self.rpm_cmd
        if pol == M.MOTOR_SLOW:
            return mc["slow_rpm"]
        if pol == M.MOTOR_HOLD_CAPPED:
            return min(self.rpm_cmd, mc["slow_rpm"])
        if pol == M.MOTOR_ZERO:
            return 0
        return mc["release_rpm"]

    def fill_record(self, t_ms, out, fix=None):
        """The control record of this step (rec_ready). fix: the position steered by (the
        dead-reckoned one in a gap: rtk none, h_acc its growing 1-sigma uncertainty); default the
        last GNSS epoch."""
        rec = self.rec
        if fix is None:
            fix = self.fix
        rec.fill_fix(fix)
        rec.t_ms = t_ms
        age = self.corr_age_s
        rec.corr_age_s = -1.0 if age is None else age
        p = self.progress
        rec.leg = p.leg if p else 0
        rec.xte_m = p.xte_m if p else 0.0
        rec.heading_cmd_deg = out.heading_cmd_deg if out else (self.heading_cmd_deg or 0.0)
        rec.speed_cmd_mps = out.speed_cmd_mps if out else 0.0
        rec.path_xte_m = getattr(out, "path_xte_m", rec.xte_m) if out else rec.xte_m
        ps = self.pilot
        rec.pilot_mode = ps.mode if ps.mode is not None else seatalk.MODE_UNKNOWN
        rec.compass_deg = ps.heading_deg or 0.0
        rec.locked_deg = ps.course_deg or 0.0
        rec.rudder_deg = ps.rudder_deg or 0.0
        rec.keys_sent = ps.keys_sent
        rec.keys_net_deg = getattr(ps, "keys_net_deg", 0)
        rec.rpm_set = self.rpm_cmd
        rec.rpm = self.motor.rpm or 0
        rec.battery_v = self.motor.battery_v or 0.0
        rec.wind_angle_deg = self.wind.angle_deg
        rec.wind_speed_mps = self.wind.speed_mps
        rec.alarms = self.mm.alarms
        rec.mode = self.mm.mode
        rec.guided = 1 if out is not None else 0
        # the compass's own time (it comes at 1-2 Hz): tune fits the compass lag with it
        rec.compass_age_ms = -1 if ps.last_heading_ms is None else ticks_diff(t_ms, ps.last_heading_ms)
        self.rec_ready = True

    # ------------------------------------------------------------------ SeaTalk, pilot, motor, wind
    def on_seatalk_rx(self, buf, n, t):
        """Bytes read from the SeaTalk bus: echo check, framing, the pilot driver."""
        self.now_ms = t
        for i in range(n):
            self.stlink.on_rx(buf[i], t)  # echo check; other bytes -> framer -> pilot
        f = self.framer
        errs = f.dropped_gap + self.pilot.bad_datagrams
        if errs != self._bus_errs:
            self._bus_errs = errs
            if self.pilot.bus_noise(t):
                self.event("SEATALK", "bus errors (%d gaps, %d implausible): noisy" % (
                    f.dropped_gap, self.pilot.bad_datagrams))
        self.pilot.poll(t)
        self.wake_seatalk = True
        self.drain_events()

    def seatalk_tx(self, t):
        """The bus-access step: the pilot's timers queue keystrokes, the link says what to do now:
        (stlink.WRITE, byte, parity) / (stlink.WAIT, until_ms) / idle."""
        self.now_ms = t
        self.pilot.poll(t)  # stepping, confirmations, timers: queues keystrokes on the link
        return self.stlink.poll(t)

    def pilot_next_due_ms(self, t):
        return self.pilot.next_due_ms(t)

    def on_seatalk_tx_done(self, t, now_ms):
        """The link's events after a bus-access step begun at t (the write or wait is over at
        now_ms, the time its events carry): failures and sends to the link health."""
        from trackpilot.devices import stlink

        self.now_ms = now_ms
        while True:
            ev = self.stlink.pop_event()
            if ev is None:
                break
            if ev[0] != stlink.EV_SENT:
                self.event("SEATALK", "%s: %s" % (stlink.EV_NAMES[ev[0]], ev[2]))
            if ev[0] == stlink.EV_FAILED:
                self.pilot.on_send_failed(ev[3], t)
                self.on_link_health(self.st_health.on_failed(ev[1]), t, ev[2])
            elif ev[0] == stlink.EV_SENT:
                self.on_link_health(self.st_health.on_sent(ev[1]), t)

    def on_pilot_tick(self, t):
        """Timers of the pilot driver: confirmations, hang detection, status timeout."""
        self.now_ms = t
        self.pilot.poll(t)
        self.drain_events()
        self.on_link_health(self.st_health.poll(t), t)  # failures going on for too long
        self.apply_pilot(t)
        self.wake_seatalk = True

    def on_motor_rx(self, mv, n, t):
        self.now_ms = t
        self.motor.feed(mv[:n], t)

    def motor_tick(self, t):
        """The motor link's timers (link loss, battery) and keep-alive: the frame to send or None;
        throttle_duty for a PWM throttle."""
        self.now_ms = t
        frame = self.motor.poll(t)
        self.throttle_duty = self.motor.duty_u16() / 65535.0
        self.drain_events()
        return frame

    def on_wind_rx(self, mv, n, t):
        self.wind.feed(mv, n, t)
