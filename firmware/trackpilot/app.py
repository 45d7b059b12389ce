"""The application: the asyncio shell around the functional core.

One GNSS epoch (5 Hz, or the receiver's measured rate) is the clock of the control loop: the GNSS
task feeds bytes to the parser and runs `control_step` once per completed epoch; in AUTO, when
epochs stop, the supervisor's gap timer runs it on the dead-reckoned position instead
(docs/MODES.md "GNSS gaps"). Other tasks run the SeaTalk link, the motor link, the
wind sensor, the inputs (buttons, E-stop, remote), the logger, telemetry and the supervisor that feeds
the watchdog only while every task is alive.

Everything that decides lives in the core (parsers, progress, guidance, mode machine, drivers); this
module wires it together and owns no logic of its own beyond the order of calls. The wiring object
(`wiring_esp32.Wiring` or `wiring_sim.Wiring`) provides streams, pins, clock and storage paths, so
the same App runs on the ESP32 and in the simulator.

Usage:
    app = App(wiring, cfg, cfg_problems)
    app.load_track(path)
    asyncio.run(app.run())
"""
import gc

from trackpilot import VERSION
from trackpilot import modes as M
from trackpilot import control, logfmt, seatalk
from trackpilot.compat import ticks_add, ticks_diff, wrap180
from trackpilot.fix import RTK_FIXED, RTK_FLOAT, RTK_NAMES, RTK_SINGLE, Fix

try:
    import asyncio
except ImportError:  # pragma: no cover
    import uasyncio as asyncio

_RTK_BY_NAME = {"single": RTK_SINGLE, "float": RTK_FLOAT, "fixed": RTK_FIXED}

TASKS = ("gnss", "seatalk_rx", "seatalk_tx", "pilot", "motor", "wind", "inputs", "logger", "telemetry")


def _error_text(e):
    """An exception as one line for an event: the message, else the exception's type."""
    text = str(e)
    return text if text else type(e).__name__


def _at_log_resolution(fix):
    """The control step's float inputs rounded to the log's resolution (0.01 deg, 1 mm/s ...),
    as a decoder gives them back: a replay of the log steers with exactly what the boat did."""
    q = logfmt.quantized
    fix.heading_deg = q("heading_deg", fix.heading_deg)
    fix.heading_acc_deg = q("heading_acc_deg", fix.heading_acc_deg)
    fix.sog_mps = q("sog_mps", fix.sog_mps)
    fix.cog_deg = q("cog_deg", fix.cog_deg)
    fix.h_acc_m = q("h_acc_m", fix.h_acc_m)


class App:
    def __init__(self, wiring, cfg, cfg_problems=(), reset_cause="unknown"):
        from trackpilot import logger

        # the largest buffers first (the log's 2 KB write buffer and 2 KB header frame), while the
        # heap is still one block; the other modules are imported after them
        self.log = logger.Logger(
            wiring.log_dir,
            max_file_bytes=cfg["log"]["max_file_bytes"],
            min_free_bytes=cfg["log"]["min_free_bytes"],
            flush_ms=cfg["log"]["flush_ms"],
            statvfs=wiring.statvfs,
        )
        from trackpilot import gnss, guidance, motor, mwv, seatalk, st2000, stlink

        self.w = wiring
        self.cfg = cfg
        self.clock = wiring.ticks_ms
        self.fix = Fix()
        mcfg = cfg["modes"]
        self.mm = M.ModeMachine(mcfg)
        self.engage_min_rtk = _RTK_BY_NAME[mcfg["engage_min_rtk"]]
        self.steer_min_rtk = _RTK_BY_NAME[mcfg["steer_min_rtk"]]
        self.gnss_stale_ms = mcfg["gnss_stale_ms"]
        bcfg = cfg["boat"]
        self.gnss = gnss.GnssParser(self.fix, heading_offset_deg=bcfg["heading_offset_deg"])
        from trackpilot import deadreckon

        self.dr = deadreckon.DeadReckoner()  # the position through GNSS gaps inside AUTO
        self.gnss_quality_name = "none"  # fixed / float / single / none / dead-reckoning (logged)
        self.rate_reported_ms = 0  # the receiver's epoch interval last reported
        self.dr_step_ms = None  # the last control step run by the gap timer
        self.dr_gap_s = 0.0  # the last dead-reckoned step: time since the fix, 1-sigma
        self.dr_sigma_m = 0.0
        self.wind = mwv.MwvParser()
        pcfg = cfg["pilot"]
        odd = seatalk.ODD_KNAUF if pcfg["odd_rule"] == "knauf" else seatalk.ODD_DOTNET
        self.framer = seatalk.Framer()
        self.stlink = stlink.StLink.from_config(pcfg, framer=self.framer, rand=wiring.rand)
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
        self.reset_cause = reset_cause
        self.cfg_problems = list(cfg_problems)
        from trackpilot.config import rejected

        if rejected(self.cfg_problems):
            # a person must know the boat runs on other settings than the file says: ENGAGE is
            # refused until they acknowledge (ACK) or the file is fixed (preconditions)
            # short: the HMI's status datagram carries 60 bytes of text
            fallback = "last good" if any("last good" in p for p in self.cfg_problems) else "defaults"
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
        self.refusal = ""
        self.alive = {}
        self.stop_event = asyncio.Event()
        self.peak_heap = 0  # largest live heap (bytes, right after a collection)
        self._st_wake = asyncio.Event()
        self.last_state_save_ms = None
        self._empty = bytearray(0)
        self._last_gc_ms = self.clock()
        self.gc_max_us = 0
        self.gc_runs = 0
        try:
            from time import ticks_us

            self.us = ticks_us  # only for measuring GC pauses (wall time, also in simulation)
        except ImportError:  # pragma: no cover
            self.us = lambda: 0
        self.input_period_ms = getattr(wiring, "input_period_ms", 50)  # button sampling
        self.ref_lat_e7 = 0  # the boat's reference point (lever arm applied), last epoch
        self.ref_lon_e7 = 0
        self.profile = False  # measure each control epoch (profiled_feed); sim_main --profile
        self.profile_out = None  # an open file for the samples (else they stay in prof_us/prof_alloc)
        self.prof_us = []
        self.prof_alloc = []
        self._prof_acc = [0, 0]
        self.on_stable = None  # called once after bootguard.STABLE_MS with every task alive
        self._stable_due_ms = None
        from trackpilot import trial

        self.trial = trial.Trial(cfg.get("trial"))  # commissioning trial (docs/COMMISSIONING.md)
        self.trial_start_e7 = (0, 0)
        self._trial_prev = None  # (t_ms, heading_deg) of the last trial epoch

    # ------------------------------------------------------------------ track and state
    def load_track(self, path):
        """Validate and activate a track file; only in STANDBY. Never raises: a bad or too large
        file, or one that does not fit in memory, is refused with a TRACK event and the active
        track stays. Returns (ok, message)."""
        from trackpilot import progress, track

        if self.mm.mode == M.AUTO:
            return False, "track not changed: only in STANDBY"
        new = None
        try:
            new, new_id = track.load_file(path)
            warnings = track.validate(new, self.cfg["boat"])
            # the seed baseline uses the plain seed leg-advance rule (BOAT_AND_BENCHMARK.md)
            rule = progress.RULE_SEED if self.cfg["guidance"]["law"] == "seed" else progress.RULE_ROBUST
            prog = progress.Progress(new, rule)
        except MemoryError:
            new = None
            gc.collect()
            msg = "track %s rejected: not enough memory to load it (%d B free); the previous track stays" % (
                path, gc.mem_free())
            self.event("TRACK", msg)
            return False, msg
        except Exception as e:  # a file error, a bad track, anything: the app goes on without it
            msg = "track %s rejected: %s" % (path, _error_text(e))
            self.event("TRACK", msg)
            return False, msg
        self.track = new
        self.progress = prog
        self.track_id = new_id
        self.event("TRACK", "loaded %s: %d waypoints, id %s" % (path, len(new.waypoints), self.track_id))
        for w in warnings:
            self.event("TRACK", "warning: " + w)
        self.log.track(new)
        self.restore_state()
        return True, "ok"

    def restore_state(self):
        """After a reset: know where we were (leg), but stay in STANDBY."""
        import json

        try:
            with open(self.w.state_path) as f:
                st = json.loads(f.read())
        except (OSError, ValueError):
            return
        if st.get("track_id") == self.track_id and self.progress is not None:
            leg = int(st.get("leg", 0))
            if 0 <= leg < len(self.track.waypoints) - 1:
                self.progress.set_leg(leg)
                self.event("STATE", "restored: leg %d of track %s (mode was %s); staying in STANDBY" % (
                    leg, self.track_id, st.get("mode", "?")))

    def save_state(self, t_ms):
        import json

        from trackpilot.config import write_atomic

        if self.progress is None:
            return
        st = {"track_id": self.track_id, "leg": self.progress.leg, "mode": M.MODE_NAMES[self.mm.mode]}
        try:
            write_atomic(self.w.state_path, json.dumps(st))
        except OSError as e:
            self.event("FAULT", "state not saved: %s" % e)
        self.last_state_save_ms = t_ms

    # ------------------------------------------------------------------ events and logging
    def event(self, kind, text):
        t = self.clock()
        self.log.event(kind, text, t)
        self.w.debug("%s %s" % (kind, text))

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
        hmi = getattr(self.w, "hmi", None)
        if hmi is not None:
            for kind, text in hmi.drain_events():
                self.event(kind, text)
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
        from trackpilot import stlink

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
            age = self.correction_age_s(t_ms)
            if age is None:
                return "no RTK corrections received"
            if age > max_age:
                return "RTK corrections %.0f s old (limit %.0f s)" % (age, max_age)
        return None

    def correction_age_s(self, t_ms):
        """Age of the last RTCM frame forwarded to the receiver, None if none (or no NTRIP)."""
        if not self.cfg["ntrip"]["enabled"]:
            return self.w.correction_age_s(t_ms)
        from trackpilot import ntrip  # imported only with NTRIP on (docs/MEMORY.md)

        s = ntrip.current_session()
        return s.age_s(t_ms) if s is not None else None

    def gga_bytes(self):
        from trackpilot import nmea_out

        return nmea_out.gga(self.fix) if self.fix.pos_valid else None

    def command(self, name, source="HMI"):
        """A person's command (HMI button, remote box, host)."""
        t = self.clock()
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
                self.trial.start(t, self.fix.heading_deg)
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
                self.mm.estop_clear(t, self.w.estop_active(), source)
            self.mm.ack(t, source)
        elif name == "PAGE":
            self.w.next_page()
        self.drain_events()

    # ------------------------------------------------------------------ the control step
    def control_step(self, t_ms, epoch=True):
        """Once per GNSS epoch: navigate, guide, command the pilot and the motor, log. With
        epoch=False, run by the gap timer (gnss_watch) when epochs stopped: the same step on the
        dead-reckoned position."""
        fix = self.fix
        dt_s = control.epoch_dt_s(self.gnss.interval_ms)
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
        self.note_quality(ok, dr)
        mm = self.mm
        guiding = mm.mode == M.AUTO and not mm.holding and (not mm.degraded or mm.dead_reckoning)
        leg_before = self.progress.leg if self.progress is not None else 0
        ref, out = control.guide_epoch(nav, self.progress, self.law, self.cfg["boat"], guiding, dt_s)
        if ref is not None:
            self.ref_lat_e7 = ref[0]
            self.ref_lon_e7 = ref[1]
            if self.progress.leg != leg_before:
                self.event("NAV", "leg %d -> %d" % (leg_before, self.progress.leg))
                self.save_state(t_ms)
        if out is not None:
            self.heading_cmd_deg = out.heading_cmd_deg
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
        fix = nav
        if mm.pilot == M.PILOT_STEER and out is not None and fix.heading_valid and self.pilot.commanding():
            # in the pilot's own compass frame: cancels its compass error (seed report 4.7)
            # the seed baseline keeps its pinned form: course = pilot compass + relative setpoint
            if self.compass_offset_deg is not None and not self.seed_baseline:
                target = out.heading_cmd_deg + self.compass_offset_deg
                self.relative_cmd_deg = wrap180(target - self.pilot.heading_deg)
            else:
                self.relative_cmd_deg = wrap180(out.heading_cmd_deg - fix.heading_deg)
            self.pilot.steer_to(self.relative_cmd_deg, t_ms)
        if mm.mode == M.TRIAL and epoch:
            self.trial_epoch(t_ms)
        # the motor
        self.rpm_cmd = self.motor_rpm(out)
        self.motor.set_rpm(self.rpm_cmd)
        self.drain_events()
        self.log_control(t_ms, out, nav)
        if self.last_state_save_ms is None or ticks_diff(t_ms, self.last_state_save_ms) > 10000:
            self.save_state(t_ms)
        self._st_wake.set()

    def trial_epoch(self, t_ms):
        """One epoch of the commissioning trial: the script decides, the pilot driver keys."""
        from trackpilot import geo

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

    def note_quality(self, ok, dead_reckoning):
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
                    self.dr.gap_s(self.clock()), self.dr.sigma_m, self.dr.sigma_rate_mps)
            elif self.gnss_quality_name == "dead-reckoning":
                extra = " (dead reckoning ended: %.1f s, 1-sigma %.1f m)" % (
                    self.dr_gap_s, self.dr_sigma_m)
            if name == "float":
                extra += " (steering with the XTE alarm limit doubled)"
            self.event("GNSS", "quality %s -> %s%s" % (self.gnss_quality_name, name, extra))
            self.gnss_quality_name = name

    def check_rate(self):
        """The receiver's measured epoch interval against the configured one (ubxcfg, 5 Hz)."""
        from trackpilot import gnss

        iv = self.gnss.interval_ms
        if iv and iv != self.rate_reported_ms:
            self.rate_reported_ms = iv
            self.event("GNSS", "receiver epoch interval %d ms (%.1f Hz)%s" % (
                iv, 1000.0 / iv, "" if iv == gnss.EPOCH_MS else
                ", configured %d ms: the control step uses the measured one" % gnss.EPOCH_MS))

    def gnss_watch(self, t_ms):
        """The gap timer (every 100 ms, AUTO only): once epochs stopped, the control step runs on
        the dead-reckoned position (motor slowed at once), one step per epoch interval
        (deadreckon.gap_step_due)."""
        from trackpilot.deadreckon import gap_step_due

        if self.mm.mode == M.AUTO and gap_step_due(t_ms, self.last_epoch_ms, self.gnss.interval_ms,
                                                   self.dr_step_ms):
            self.control_step(t_ms, epoch=False)

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
        self._st_wake.set()

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

    def log_control(self, t_ms, out, fix=None):
        """fix: the position steered by (the dead-reckoned one in a gap: rtk none, h_acc its
        growing 1-sigma uncertainty); default the last GNSS epoch."""
        rec = self.log.rec
        if fix is None:
            fix = self.fix
        rec.fill_fix(fix)
        rec.t_ms = t_ms
        age = self.correction_age_s(t_ms)
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
        self.log.control(rec)

    # ------------------------------------------------------------------ tasks
    def grid_ms(self, period_ms):
        """Sleep so that periodic tasks wake on a common grid of the clock: they then run in the
        same scheduler pass (fewer wake-ups on the ESP32, fewer lockstep steps in simulation)."""
        return period_ms - (self.clock() % period_ms)

    def beat(self, name):
        self.alive[name] = self.clock()

    def _on_gnss_msg(self, kind):
        from trackpilot import gnss

        if kind == gnss.K_ACK_ACK or kind == gnss.K_ACK_NAK:
            r = self.gnss.ack
            out = self.gnss_cfg.on_ack(r.cls, r.id, kind == gnss.K_ACK_ACK, self.clock())
            if out:
                self.w.gnss_uart.write(out)

    def gnss_config_poll(self, t_ms):
        """Receiver configuration (CFG-VALSET, 5 Hz, our messages): resend on timeout, log the end."""
        from trackpilot import ubxcfg

        s = self.gnss_cfg
        out = s.poll(t_ms)
        if out:
            self.w.gnss_uart.write(out)
        if s.state != ubxcfg.BUSY and not self._gnss_cfg_reported:
            self._gnss_cfg_reported = True
            self.gnss_cfg_failed = s.state != ubxcfg.DONE  # shown on the HMI's GNSS page
            self.event("GNSS", "receiver configuration %s: %s" % (
                "done" if s.state == ubxcfg.DONE else "FAILED (running with what it sends)",
                s.log[-1][1] if s.log else ""))

    async def task_gnss(self):
        from trackpilot import ubxcfg

        self.gnss_cfg = ubxcfg.ConfigSession(ubxcfg.valset_frames(ubxcfg.rover_items()))
        self._gnss_cfg_reported = False
        self.gnss_cfg_failed = False
        self.gnss.on_msg = self._on_gnss_msg
        first = self.gnss_cfg.start(self.clock())
        if first:
            self.w.gnss_uart.write(first)
        reader = asyncio.StreamReader(self.w.gnss_uart)
        buf = bytearray(256)
        mv = memoryview(buf)
        while True:
            n = await reader.readinto(mv)
            self.beat("gnss")
            if not n:
                continue
            t = self.clock()
            if self.profile:
                self.profiled_feed(mv, n, t)
                continue
            epochs = self.gnss.feed(mv, n, t)
            if epochs:
                self.control_step(t)

    def profiled_feed(self, mv, n, t):
        """The GNSS feed and the control step with CPU time (ticks_us) and bytes allocated
        (gc.mem_alloc, collector off meanwhile) measured; summed over the feeds of an epoch and
        recorded when it completes (prof_us, prof_alloc). Only with `profile` set (sim_main
        --profile, the benchmark); the normal path above has no measuring in it."""
        from time import ticks_diff as us_diff

        if gc.mem_free() < 32768:
            gc.collect()  # outside the window: with the collector off, a full heap cannot be reclaimed
        gc.disable()
        try:
            a0 = gc.mem_alloc()
            t0 = self.us()
            epochs = self.gnss.feed(mv, n, t)
            if epochs:
                self.control_step(t)
            dt = us_diff(self.us(), t0)
            da = gc.mem_alloc() - a0
        finally:
            gc.enable()
        self._prof_acc[0] += dt
        self._prof_acc[1] += da
        if epochs:
            self.prof_us.append(self._prof_acc[0])
            self.prof_alloc.append(self._prof_acc[1])
            self._prof_acc[0] = 0
            self._prof_acc[1] = 0
            if len(self.prof_us) >= 250:
                self.profile_flush()

    def profile_flush(self):
        """Write the collected samples to `profile_out` ("us bytes" a line) so that a long run
        does not keep them on the heap it measures."""
        f = self.profile_out
        if f is not None:
            for i in range(len(self.prof_us)):
                f.write("%d %d\n" % (self.prof_us[i], self.prof_alloc[i]))
            self.prof_us = []
            self.prof_alloc = []

    async def task_seatalk_rx(self):
        reader = asyncio.StreamReader(self.w.seatalk_uart)
        buf = bytearray(32)
        mv = memoryview(buf)
        while True:
            n = await reader.readinto(mv)
            self.beat("seatalk_rx")
            if not n:
                continue
            t = self.clock()
            for i in range(n):
                self.stlink.on_rx(buf[i], t)  # echo check; other bytes -> framer -> pilot
            self.pilot.poll(t)
            self._st_wake.set()
            self.drain_events()

    async def task_seatalk_tx(self):
        """Drive the SeaTalk bus-access state machine; one byte at a time with its parity."""
        from trackpilot import stlink

        uart = self.w.seatalk_uart
        one = bytearray(1)
        while True:
            self.beat("seatalk_tx")
            t = self.clock()
            self.pilot.poll(t)  # stepping, confirmations, timers: queues keystrokes on the link
            act = self.stlink.poll(t)
            kind = act[0]
            if kind == stlink.WRITE:
                one[0] = act[1]
                uart.init(parity=0 if act[2] == "E" else 1)  # waits for TX to drain on the ESP32
                uart.write(one)
                await asyncio.sleep_ms(0)
            elif kind == stlink.WAIT:
                self._st_wake.clear()
                # at least 1 ms: defence in depth. A wait that is already due must still let time
                # pass, or this task spins without the clock (and the bus) moving on; that once
                # happened when st2000.next_due_ms said "now" for a key poll() held back.
                dt = max(1, ticks_diff(act[1], t))
                try:
                    await asyncio.wait_for_ms(self._st_wake.wait(), dt)
                except asyncio.TimeoutError:
                    pass
            else:  # idle: wake on a new epoch, a received byte or the pilot's own timers
                self._st_wake.clear()
                wait_ms = max(1, self.pilot.next_due_ms(t))  # >= 1 ms: see above
                try:
                    await asyncio.wait_for_ms(self._st_wake.wait(), wait_ms)
                except asyncio.TimeoutError:
                    pass
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

    async def task_pilot(self):
        """Timers of the pilot driver: confirmations, hang detection, status timeout."""
        while True:
            self.beat("pilot")
            t = self.clock()
            self.pilot.poll(t)
            self.drain_events()
            self.on_link_health(self.st_health.poll(t), t)  # failures going on for too long
            self.apply_pilot(t)
            self._st_wake.set()
            await asyncio.sleep_ms(self.grid_ms(100))

    async def task_motor(self):
        uart = self.w.motor_uart
        reader = asyncio.StreamReader(uart) if uart is not None else None
        period = self.cfg["motor"]["keepalive_ms"]

        async def rx():
            buf = bytearray(64)
            mv = memoryview(buf)
            while True:
                n = await reader.readinto(mv)
                if n:
                    self.motor.feed(mv[:n], self.clock())

        if reader is not None:
            asyncio.create_task(rx())
        while True:
            self.beat("motor")
            t = self.clock()
            frame = self.motor.poll(t)  # also runs the link-loss and battery timers
            if frame and uart is not None:
                uart.write(frame)
            self.w.set_throttle(self.motor.duty_u16() / 65535.0)
            self.drain_events()
            await asyncio.sleep_ms(self.grid_ms(period))

    async def task_wind(self):
        if self.w.wind_uart is None:
            return
        reader = asyncio.StreamReader(self.w.wind_uart)
        buf = bytearray(128)
        mv = memoryview(buf)
        while True:
            n = await reader.readinto(mv)
            self.beat("wind")
            if n:
                self.wind.feed(mv, n, self.clock())

    async def task_inputs(self):
        """Buttons, E-stop, remote commands; LEDs and buzzer; display."""
        estop_was = False
        while True:
            self.beat("inputs")
            t = self.clock()
            active = self.w.estop_active()
            if active and not estop_was:
                self.mm.estop(t, True)
                self.apply_pilot(t)
                self.drain_events()
            estop_was = active
            for name, source in self.w.poll_commands(t):
                self.command(name, source)
            self.w.show(self, t)
            await asyncio.sleep_ms(self.grid_ms(self.input_period_ms))

    async def task_logger(self):
        while True:
            self.beat("logger")
            self.log.tick(self.clock())
            await asyncio.sleep_ms(self.grid_ms(200))

    def nmea_sentences(self):
        """GGA, RMC, HDT, XTE, RMB and APB for chart plotters (UDP 10110 on the boat)."""
        from trackpilot import nmea_out

        fix = self.fix
        out = nmea_out.gga(fix) + nmea_out.rmc(fix) + nmea_out.hdt(fix)
        p = self.progress
        if p is not None and fix.pos_valid:
            auto = self.mm.mode == M.AUTO
            out += nmea_out.xte(p.xte_m, valid=auto)
            out += nmea_out.route(fix, p, valid=auto, heading_cmd_deg=self.heading_cmd_deg if auto else None)
        return out

    async def task_telemetry(self):
        period = self.cfg["telemetry"]["period_ms"]
        while True:
            self.beat("telemetry")
            self.w.send_status(self, self.clock())
            self.w.send_nmea(self.nmea_sentences())
            await asyncio.sleep_ms(self.grid_ms(period))

    async def task_supervisor(self):
        """GNSS staleness, task heartbeats, watchdog, heap watermark."""
        while True:
            t = self.clock()
            if self.gnss.feed(self._empty, 0, t):  # an epoch closed by its timeout (no more bytes)
                self.control_step(t)
            if hasattr(self, "gnss_cfg"):
                self.gnss_config_poll(t)
            self.gnss_watch(t)
            if self.mm.mode != M.AUTO and (self.last_epoch_ms is None or
                                           ticks_diff(t, self.last_epoch_ms) > self.gnss_stale_ms):
                self.mm.gnss_quality(t, False, "GNSS stale (no epoch for %d ms)" % self.gnss_stale_ms)
                self.drain_events()
                self.apply_pilot(t)
            self.watch_ntrip()
            dead = self.dead_tasks(t)
            if dead:
                self.event("FAULT", "task not alive: %s; watchdog not fed" % ",".join(dead))
            else:
                self.w.feed_watchdog()
                self._check_stable(t)
            if ticks_diff(t, self._last_gc_ms) >= 1000:
                # collect once a second between control epochs: short, predictable pauses instead
                # of one long one whenever the heap runs full; the live heap after it is the
                # figure that says whether the app fits
                self._last_gc_ms = t
                t0 = self.us()
                gc.collect()
                pause_us = self.us() - t0
                if pause_us > self.gc_max_us:
                    self.gc_max_us = pause_us
                self.gc_runs += 1
                live = gc.mem_alloc()
                if live > self.peak_heap:
                    self.peak_heap = live
            await asyncio.sleep_ms(self.grid_ms(100))  # the GNSS gap timer needs < 0.5 s

    def start_ntrip(self):
        """RTK corrections: caster -> GNSS UART (with Wi-Fi: once the link is first up, task_wifi)."""
        from trackpilot import ntrip  # imported only when it starts (docs/MEMORY.md)

        self.ntrip_task = asyncio.create_task(ntrip.run_client(
            self.cfg["ntrip"], self.w.gnss_uart.write, self.clock, gga=self.gga_bytes, events=self.event))

    def watch_ntrip(self):
        """The NTRIP client never ends by itself; if it did (a bug), log it and start it again."""
        task = getattr(self, "ntrip_task", None)
        if task is not None and task.done() and not self.stop_event.is_set():
            self.ntrip_restarts += 1
            self.event("FAULT", "NTRIP task ended (restart %d)" % self.ntrip_restarts)
            self.start_ntrip()

    async def task_wifi(self):
        """Wi-Fi (wifi.WifiLink, built by the board's wiring): start, then poll; its state goes
        to the HMI and the status datagram; NTRIP waits for the first link."""
        link = self.w.wifi
        for text in link.start(self.clock()):
            self.event("WIFI", text)
        while True:
            for text in link.poll(self.clock()):
                self.event("WIFI", text)
            if link.is_up() and self.cfg["ntrip"]["enabled"] and self.ntrip_task is None:
                self.start_ntrip()  # once; the client reconnects by itself, watch_ntrip restarts it
            await asyncio.sleep_ms(500)

    def _check_stable(self, t):
        """Tell the boot-loop guard once the app has run stably (bootguard.py)."""
        if self.on_stable is None:
            return
        if self._stable_due_ms is None:
            from trackpilot.bootguard import STABLE_MS

            self._stable_due_ms = ticks_add(t, STABLE_MS)
        elif ticks_diff(t, self._stable_due_ms) >= 0:
            cb = self.on_stable
            self.on_stable = None
            cb()
            self.event("BOOT", "running stably: boot-loop count cleared")

    def dead_tasks(self, t):
        # input-driven tasks only beat when bytes arrive; they are checked against their data
        out = []
        for name in ("inputs", "logger", "pilot", "motor", "telemetry"):
            last = self.alive.get(name)
            if last is None or ticks_diff(t, last) > 5000:
                out.append(name)
        return out

    async def run(self):
        t = self.clock()
        self.runs = getattr(self, "runs", 0) + 1
        cause = self.reset_cause if self.runs == 1 else "restart after maintenance (no reset)"
        self.log.open_session(VERSION, self.cfg_hash(), self.track_id, cause, t)
        self.event("BOOT", "trackpilot %s, %s, mode %s (never engages by itself)" % (
            VERSION, cause, M.MODE_NAMES[self.mm.mode]))
        for p in self.cfg_problems:
            self.event("CONFIG", p)
        for coro in (
            self.task_gnss(),
            self.task_seatalk_rx(),
            self.task_seatalk_tx(),
            self.task_pilot(),
            self.task_motor(),
            self.task_wind(),
            self.task_inputs(),
            self.task_logger(),
            self.task_telemetry(),
            self.task_supervisor(),
        ):
            asyncio.create_task(coro)
        self.ntrip_task = None
        self.ntrip_restarts = 0
        if getattr(self.w, "wifi", None) is not None:
            asyncio.create_task(self.task_wifi())  # starts NTRIP once the link is up
        elif self.cfg["ntrip"]["enabled"]:
            self.start_ntrip()
        await self.stop_event.wait()
        self.event("STOP", "application stopped")
        self.log.close()

    def cfg_hash(self):
        """An id of the configuration for the log header, one setting at a time (a JSON dump of
        the whole configuration was the largest allocation at start-up)."""
        h = 0
        for sec in sorted(self.cfg):
            body = self.cfg[sec]
            for key in sorted(body):
                for b in ("%s.%s=%r;" % (sec, key, body[key])).encode():
                    h = (h * 31 + b) & 0xFFFFFFFF
        return h
