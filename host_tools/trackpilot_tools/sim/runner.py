"""The lockstep driver: starts the firmware (`firmware/sim_main.py`) under the MicroPython unix port
and steps it through docs/SIM_PROTOCOL.md against the simulated boat and devices.

Event-driven: the simulator runs its internal events (GNSS epochs, pilot status, bus characters,
wind, scenario and faults) in time order and steps the firmware only when it has bytes to deliver
or when the firmware's own timer is due (never past `wake_ms`). Physics advances lazily in fixed
steps to whatever time is needed. Everything random comes from per-component generators derived
from the run seed, so a seed gives the same truth trace.

Usage:
    run = SimRun(track_path, out_dir, seed=1, law="los", scenario="calm", faults=["rtk_float@60:20"])
    result = run.run()      # dict; truth.csv, firmware log and stderr in out_dir
"""
import csv
import heapq
import json
import math
import os
import shutil
import sys
import time
from pathlib import Path

from ..mpy import FIRMWARE_DIR, ROOT, popen_script
from . import params as params_mod
from . import protocol as P
from . import scenarios, stcodec
from .boat import Boat, Environment
from .events import Scheduler
from .f9p import F9P
from .geodesy import LocalFrame
from .randproc import component_rng
from .seatalk_bus import SeaTalkBus
from .st2000_sim import ST2000Sim
from .truth import TrackGeom
from .wind_sensor import WindSensor

SIM_MAIN = FIRMWARE_DIR / "sim_main.py"

TRUTH_FIELDS = ("t_s", "east_m", "north_m", "lat_deg", "lon_deg", "heading_deg", "cog_deg", "sog_mps",
                "water_speed_mps", "yaw_rate_degps", "rudder_deg", "rpm", "pilot_mode",
                "pilot_course_deg", "compass_deg", "pilot_hang", "current_e_mps", "current_n_mps",
                "wind_mps", "wind_from_deg", "gnss", "heading_valid", "fw_mode", "leg", "xte_m",
                "track_m")


def _fw_import():
    if str(FIRMWARE_DIR) not in sys.path:
        sys.path.insert(0, str(FIRMWARE_DIR))


class FirmwareDied(Exception):
    pass


class SimRun:
    def __init__(self, track_path, out_dir, seed=1, law="los", scenario="calm", faults=(),
                 params=None, param_file=None, overrides=None, duration_s=None, realtime=False,
                 realtime_speed=1.0, fw_config=None, reengage_s=0.0, quiet=True,
                 stop_after_finish_s=5.0, max_xte_stop_m=80.0, fw_script=None, udp_out=None,
                 fw_config_bytes=None, trial=False, journal=False, start_state=None):
        self.track_path = Path(track_path)
        self.journal = journal  # the firmware writes every input of its decision core (replay_core)
        self.udp_out = None
        if udp_out:  # (host, status port, NMEA port), as the boat would send them; (ports) = localhost
            import socket

            if len(udp_out) == 2:
                udp_out = ("127.0.0.1",) + tuple(udp_out)
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)  # x.x.x.255 for OpenCPN on the LAN
            self.udp_out = (sock, udp_out[1], udp_out[2])
            self.udp_host = udp_out[0]
        self.fw_script = Path(fw_script) if fw_script else SIM_MAIN
        self.out = Path(out_dir).absolute()  # the firmware runs with ROOT as its working directory
        self.seed = seed
        self.law = law
        self.scenario = scenario
        self.realtime = realtime
        self.realtime_speed = realtime_speed
        self.reengage_s = reengage_s
        self.quiet = quiet
        self.stop_after_finish_s = stop_after_finish_s
        self.max_xte_stop_m = max_xte_stop_m if not trial else 1e9  # a trial sails off the track
        self.trial = trial  # press TRIAL (commissioning trial) instead of ENGAGE; end when it ends
        self.trial_seen = False
        if params is None:
            preset = scenarios.PRESETS.get(scenario)
            if preset is None:
                raise ValueError("unknown scenario %r (one of %s)" % (scenario, ", ".join(scenarios.PRESETS)))
            params = params_mod.load(param_file)
            params_mod.merge(params, preset)
            if overrides:
                params_mod.merge(params, overrides)
        self.p = params
        self.faults = [scenarios.parse_fault(f) if isinstance(f, str) else f for f in faults]
        self.fw_config_extra = fw_config or {}
        # the firmware's config.json exactly as given, not validated here (bad-config tests: the
        # firmware must reject it itself); the simulated motor then uses the defaults
        self.fw_config_bytes = fw_config_bytes

        _fw_import()
        from trackpilot.nav.track import parse_track_csv

        self.track = parse_track_csv(self.track_path.read_text())
        wps = [(w.lat_e7 * 1e-7, w.lon_e7 * 1e-7) for w in self.track.waypoints]
        self.frame = LocalFrame(*wps[0])
        self.geom = TrackGeom(self.frame, wps)
        est = sum(l.length_m / max(l.speed_mps, 0.2) for l in self.track.legs)
        self.duration_s = duration_s if duration_s else 1.5 * est + 120.0

        # components, each with its own random generator
        sp = self.p["sim"]
        self.sched = Scheduler()
        self.env = Environment(self.p["water"], self.p["wind"], component_rng(seed, "environment"))
        brg0 = self.geom.bearing_deg(0)
        off = sp["start_offset_m"]
        e0 = off * math.cos(math.radians(brg0))  # + = starboard of the first leg
        n0 = -off * math.sin(math.radians(brg0))
        h0, u0 = brg0 + sp["start_heading_err_deg"], 0.0
        if start_state:  # replay --closed-loop: a logged run's state {lat_deg, lon_deg, heading_deg, u_mps}
            e0, n0 = self.frame.from_latlon(start_state["lat_deg"], start_state["lon_deg"])
            h0, u0 = start_state["heading_deg"], start_state.get("u_mps", 0.0)
        self.boat = Boat(self.p["boat"], self.env, e0, n0, h0, u_mps=u0)
        self.bus = SeaTalkBus(self.p["seatalk"], component_rng(seed, "seatalk"), self.sched,
                              self._fw_rx_seatalk)
        self.pilot = ST2000Sim(self.p["pilot"], component_rng(seed, "pilot"), self.sched, self.bus)
        self.f9p = F9P(self.p["gnss"], component_rng(seed, "gnss"), self.frame)
        self.wind_sensor = WindSensor(self.p["wind_sensor"], component_rng(seed, "wind_sensor"))
        self.rng_scn = component_rng(seed, "scenario")
        self.dt_ms = sp["physics_dt_ms"]
        self.phys_ms = 0
        self.conv_deg = 0.0
        self.motor = None  # created with the firmware config in run()

        # deliveries to the firmware: heap of (t_ms, seq, dev, bytes)
        self.deliv = []
        self.deliv_seq = 0
        self._st_rx_buf = bytearray()
        self._st_rx_last = None
        self.proc = None
        self.fw_t0_ms = 0  # sim time at which the current firmware process started (resets)
        self.fw_wake_ms = None  # sim time
        self.fw_last_ms = 0
        self.fw_outputs = {}
        self.output_log = []  # (t_s, name, value) from device 5
        self.telemetry_bytes = 0
        self.mode = None
        self.auto_seen = False
        self.finished_ms = None
        self.engage_tries = 0
        self.engage_pending_since = None
        self.left_auto_ms = None
        self.truth_rows = []
        self.events = []  # (t_s, kind, text): faults, inputs, pilot events
        self.steps = 0
        self.resets = 0
        self.stop_reason = None
        self.failure = None
        self.truth_xte = []  # (t_s, xte_m, track_m, dist_sailed_m, straight)
        self.dist_sailed_m = 0.0
        self._last_pos = (e0, n0)
        self.keys_fw = 0

    # ------------------------------------------------------------------ deliveries
    def deliver(self, dev, t_us, data):
        t_ms = -(-int(t_us) // 1000)  # ceil: bytes are there at the first ms they are complete
        self.deliv_seq += 1
        heapq.heappush(self.deliv, (t_ms, self.deliv_seq, dev, data))

    def _fw_rx_seatalk(self, t_us, byte):
        tout = self.p["seatalk"]["rx_timeout_chars"]
        if not tout:
            self.deliver(P.DEV_SEATALK, t_us, bytes((byte,)))
            return
        # ESP-IDF style: bytes reach the driver once the line has been idle `tout` characters
        self._st_rx_buf.append(byte)
        self._st_rx_last = t_us
        self.sched.at(t_us + tout * self.bus.char_us, self._st_rx_flush, t_us)

    def _st_rx_flush(self, t_us, stamp):
        if stamp == self._st_rx_last and self._st_rx_buf:
            self.deliver(P.DEV_SEATALK, t_us, bytes(self._st_rx_buf))
            self._st_rx_buf = bytearray()

    def send_input(self, t_ms, line):
        self.events.append((t_ms / 1000.0, "input", line))
        self.deliver(P.DEV_IO, t_ms * 1000, (line + "\n").encode())

    # ------------------------------------------------------------------ physics
    def advance_physics(self, t_ms):
        dt_ms = self.dt_ms
        dt_s = dt_ms / 1000.0
        boat = self.boat
        truth_ms = self.p["sim"]["truth_period_ms"]
        while self.phys_ms + dt_ms <= t_ms:
            true_hdg = boat.heading_deg() + self.conv_deg
            rudder = self.pilot.control_step(dt_s, true_hdg)
            if self.motor is not None:
                self.motor.advance(self.phys_ms)
                rpm = self.motor.rpm
            else:
                rpm = 0.0
            boat.step(dt_s, rudder, rpm)
            self.phys_ms += dt_ms
            if self.phys_ms % truth_ms == 0:
                self._record_truth()

    def _record_truth(self):
        b = self.boat
        t_s = self.phys_ms / 1000.0
        lat, lon, conv = self.frame.to_latlon(b.east_m, b.north_m)
        self.conv_deg = conv
        sog, cog = b.sog_cog()
        ce, cn = self.env.current_en()
        ws, wd = self.env.wind_speed_dir()
        leg, xte, track_m = self.geom.update(b.east_m, b.north_m)
        le, ln = self._last_pos
        self.dist_sailed_m += math.hypot(b.east_m - le, b.north_m - ln)
        self._last_pos = (b.east_m, b.north_m)
        auto = self.mode is not None and self.mode.startswith("AUTO")
        if auto:
            self.truth_xte.append((t_s, xte, track_m, self.dist_sailed_m, self.geom.is_straight(track_m)))
            if abs(xte) > self.max_xte_stop_m and self.stop_reason is None:
                self.stop_reason = "failure: |xte| %.1f m > %.0f m" % (abs(xte), self.max_xte_stop_m)
        pl = self.pilot
        self.truth_rows.append((
            "%.2f" % t_s, "%.4f" % b.east_m, "%.4f" % b.north_m, "%.9f" % lat, "%.9f" % lon,
            "%.3f" % ((b.heading_deg() + conv) % 360.0), "%.2f" % ((cog + conv) % 360.0), "%.3f" % sog,
            "%.3f" % b.u_mps, "%.3f" % b.r_degps, "%.2f" % b.rudder_deg, "%.0f" % b.rpm,
            "auto" if pl.mode == stcodec.MODE_AUTO else "standby", "%.1f" % pl.course_deg,
            "%.2f" % (pl.compass_deg or 0.0), pl.hang or "", "%.3f" % ce, "%.3f" % cn, "%.2f" % ws,
            "%.1f" % wd, self.f9p.quality, int(self.f9p.heading_valid), self.mode or "", leg,
            "%.4f" % xte, "%.2f" % track_m))

    # ------------------------------------------------------------------ periodic device events
    def _gnss_epoch(self, t_us):
        t_ms = t_us // 1000
        self.advance_physics(t_ms)
        b = self.boat
        truth = {"east_m": b.east_m, "north_m": b.north_m, "heading_grid_deg": b.heading_deg(),
                 "vel_e": b.vel_e, "vel_n": b.vel_n}
        got = self.f9p.epoch(t_ms, truth)
        if got:
            self.deliver(P.DEV_GNSS, got[0] * 1000, got[1])
        self.sched.at(t_us + self.f9p.period_ms * 1000, self._gnss_epoch)

    def _wind_sample(self, t_us):
        t_ms = t_us // 1000
        self.advance_physics(t_ms)
        spd, ang = self.boat.apparent_wind()
        t_out, data = self.wind_sensor.sample(t_ms, spd, ang)
        self.deliver(P.DEV_WIND, t_out * 1000, data)
        self.sched.at(t_us + self.wind_sensor.period_ms * 1000, self._wind_sample)

    def _other_talker(self, t_us, end_us, polite):
        if t_us >= end_us:
            return
        ang = self.rng_scn.randrange(0, 720)
        d = bytes((0x10, 0x01, ang >> 8, ang & 0xFF))
        self.bus.send("other", d, t_us, polite=polite)
        per = self.p["seatalk"]["other_talker_period_ms"] or 200
        self.sched.at(t_us + per * 1000 * self.rng_scn.uniform(0.5, 1.5), self._other_talker, end_us, polite)

    def _scenario_tick(self, t_us):
        """The person at the HMI: ENGAGE once the fix is RTK fixed and the pilot answers."""
        t_ms = t_us // 1000
        sp = self.p["sim"]
        mode = self.mode or ""
        auto = mode.startswith("AUTO")
        if self.trial:
            self._trial_tick(t_ms, mode)
        elif auto:
            self.auto_seen = True
            self.engage_pending_since = None
            self.left_auto_ms = None
        elif self.finished_ms is None and self.proc is not None:
            want = False
            if not self.auto_seen:
                want = t_ms >= sp["engage_delay_s"] * 1000
            elif self.reengage_s > 0:
                if self.left_auto_ms is None:
                    self.left_auto_ms = t_ms
                want = t_ms - self.left_auto_ms >= self.reengage_s * 1000
            ready = (self.f9p.quality == "fixed" and self.f9p.heading_valid and self.pilot.started
                     and mode.startswith("STANDBY"))
            if want and ready and self.engage_tries < sp["engage_max_tries"]:
                if (self.engage_pending_since is None
                        or t_ms - self.engage_pending_since >= sp["engage_retry_s"] * 1000):
                    self.engage_pending_since = t_ms
                    self.engage_tries += 1
                    self.send_input(t_ms, "button=ENGAGE")
        self.sched.at(t_us + 250_000, self._scenario_tick)

    def _trial_tick(self, t_ms, mode):
        """The person at the HMI presses TRIAL once ready; the run ends when the trial has ended."""
        sp = self.p["sim"]
        if mode.startswith("TRIAL"):
            self.trial_seen = True
            return
        if self.trial_seen:
            if self.finished_ms is None:
                self.finished_ms = t_ms
            return
        ready = (self.f9p.quality == "fixed" and self.f9p.heading_valid and self.pilot.started
                 and mode.startswith("STANDBY") and t_ms >= sp["engage_delay_s"] * 1000)
        if ready and self.engage_tries < sp["engage_max_tries"]:
            if self.engage_pending_since is None or t_ms - self.engage_pending_since >= sp["engage_retry_s"] * 1000:
                self.engage_pending_since = t_ms
                self.engage_tries += 1
                self.send_input(t_ms, "button=TRIAL")

    # ------------------------------------------------------------------ faults
    def _fault(self, t_us, name, on, dur_s):
        t_ms = t_us // 1000
        self.advance_physics(t_ms)
        self.events.append((t_ms / 1000.0, "fault", "%s %s" % (name, "on" if on else "off")))
        g = {"rtk_float": "float", "rtk_single": "single", "heading_loss": "heading_loss",
             "gnss_dropout": "dropout"}
        if name in g:
            self.f9p.set_fault(g[name], on, t_ms)
        elif name == "compass_bend":
            self.pilot.bend_deg = 6.0 if on else 0.0
        elif name == "pilot_hang_steer":
            self.pilot.set_hang("steer")
        elif name == "pilot_hang_keys":
            self.pilot.set_hang("keys")
        elif name == "pilot_key_standby_on_auto":
            self.pilot.standby_on_auto = True
        elif name.startswith("pilot_key_"):
            key = {"standby": "standby", "auto": "auto", "minus10": "-10", "plus10": "+10",
                   "minus1": "-1", "plus1": "+1"}[name[len("pilot_key_"):]]
            self.pilot.person_key(t_us, key)
        elif name == "pilot_silent":
            self.pilot.silent = on
        elif name == "st_noise":
            self.bus.noise_corrupt_p = 0.03 if on else self.p["seatalk"]["noise_corrupt_p"]
            self.bus.noise_drop_p = 0.01 if on else self.p["seatalk"]["noise_drop_p"]
        elif name == "st_tx_lost":
            self.bus.fw_tx_lost = on
        elif name == "st_rx_lost":
            self.bus.fw_rx_lost = on
        elif name == "st_other_talker":
            if on:
                self._other_talker(t_us, t_us + int(dur_s * 1e6), False)
        elif name == "motor_link_loss":
            self.motor.link_lost = on
        elif name == "estop":
            self.estop_on = on
            self.send_input(t_ms, "estop=%d" % (1 if on else 0))
        elif name == "reset":
            self._reset_pending = True
        elif name == "button_standby":
            self.send_input(t_ms, "button=STANDBY")
        elif name == "button_engage":
            self.send_input(t_ms, "button=ENGAGE")
        elif name == "button_trial":
            self.send_input(t_ms, "button=TRIAL")
        elif name == "button_ack":
            self.send_input(t_ms, "button=ACK")
        elif name == "remote_key_echo":
            self._remote_echo(t_us, self.pilot.keys_by_sender.get(self._fw_sender_id(), 0))
        if on and dur_s:
            self.sched.at(t_us + int(dur_s * 1e6), self._fault, name, False, None)

    def _fw_sender_id(self):
        return self.fw_config_extra.get("pilot", {}).get("sender_id", 1)

    def _remote_echo(self, t_us, seen):
        """Wait for the firmware's next keystroke, then the hand remote sends the same key with the
        same sender id 0.1 s later."""
        sid = self._fw_sender_id()
        if self.pilot.keys_by_sender.get(sid, 0) > seen and getattr(self.pilot, "last_key", None):
            _, key, _ = self.pilot.last_key
            self.sched.at(t_us + 100_000, lambda t: self.bus.send("remote", stcodec.encode_86(sid, key), t))
            self.events.append((t_us / 1e6, "fault", "hand remote repeats key %d as sender %d" % (key, sid)))
            return
        if t_us < (self.duration_s + 1) * 1e6:
            self.sched.at(t_us + 10_000, self._remote_echo, seen)

    # ------------------------------------------------------------------ firmware process
    def _fw_config(self):
        _fw_import()
        from trackpilot import config as fwconfig

        g = self.p["gnss"]
        cfg = {"guidance": {"law": self.law},
               "boat": {"antenna_fwd_m": g["antenna_fwd_m"], "antenna_stbd_m": g["antenna_stbd_m"],
                        "heading_offset_deg": -g["heading_mount_offset_deg"]}}
        for sec, body in self.fw_config_extra.items():
            cfg.setdefault(sec, {}).update(body)
        errors = fwconfig.validate(cfg)
        if errors:
            raise ValueError("firmware configuration: " + "; ".join(errors))
        return cfg, fwconfig.merged(cfg)

    def _start_fw(self, t_ms, reset_cause):
        args = ["--config", self.out / "config.json", "--track", self.track_path.resolve(),
                "--data", self.data_dir, "--seed", str(self.seed), "--reset-cause", reset_cause]
        if self.quiet:
            args.append("--quiet")
        if self.journal:
            args += ["--journal", Path(self.data_dir) / "journal.txt"]
        self.proc = popen_script(self.fw_script, args, stderr=self.stderr_f, cwd=str(ROOT))
        self.fw_t0_ms = t_ms
        self.fw_last_ms = t_ms
        rep = P.read_report(self.proc.stdout)
        if rep is None:
            raise FirmwareDied("firmware exited before its first report")
        self._on_report(t_ms, rep)

    def _stop_fw(self):
        if self.proc is None:
            return
        try:
            self.proc.stdin.close()
        except OSError:
            pass
        try:
            self.proc.stdout.read()
            self.proc.wait(timeout=20)
        except Exception:
            self.proc.kill()
            self.proc.wait()
        self.fw_exit = self.proc.returncode
        self.proc = None

    def _on_report(self, t_ms, rep):
        _t, wake, chunks = rep
        self.fw_wake_ms = None if wake == P.NO_WAKE else wake + self.fw_t0_ms
        if self.fw_wake_ms is not None and self.fw_wake_ms < t_ms:
            self.fw_wake_ms = t_ms
        for dev, data in chunks.items():
            if dev == P.DEV_SEATALK:
                pairs = [(data[i], chr(data[i + 1])) for i in range(0, len(data) - 1, 2)]
                self.bus.write_fw(t_ms * 1000, pairs)
            elif dev == P.DEV_GNSS:  # receiver configuration (CFG-VALSET)
                got = self.f9p.on_rx(t_ms, data)
                if got:
                    self.deliver(P.DEV_GNSS, got[0] * 1000, got[1])
            elif dev == P.DEV_MOTOR:
                got = self.motor.feed(t_ms, data)
                if got:
                    self.deliver(P.DEV_MOTOR, got[0] * 1000, got[1])
            elif dev == P.DEV_IO:
                for line in data.decode(errors="replace").splitlines():
                    name, _, value = line.partition("=")
                    self.output_log.append((t_ms / 1000.0, name, value))
                    self.fw_outputs[name] = value
                    if name == "mode":
                        if self.mode and self.mode.startswith("AUTO") and not value.startswith("AUTO"):
                            self.left_auto_ms = t_ms
                        self.mode = value
                    elif name == "finished" and value == "1" and self.finished_ms is None:
                        self.finished_ms = t_ms
            elif dev == P.DEV_TELEMETRY:
                self.telemetry_bytes += len(data)
                if self.udp_out is not None:  # live view: `trackpilot monitor` on this machine
                    self._udp_send(data, self.udp_out[1])
            elif dev == 7 and self.udp_out is not None:  # NMEA for a chart plotter (OpenCPN)
                self._udp_send(data, self.udp_out[2])

    def _udp_send(self, data, port):
        try:
            self.udp_out[0].sendto(data, (self.udp_host, port))
        except OSError:
            pass  # nobody listening is fine

    def _step(self, t_ms):
        chunks = {}
        d = self.deliv
        while d and d[0][0] <= t_ms:
            _, _, dev, data = heapq.heappop(d)
            chunks[dev] = chunks.get(dev, b"") + data
        self.proc.stdin.write(P.encode_step(t_ms - self.fw_t0_ms, chunks))
        self.proc.stdin.flush()
        rep = P.read_report(self.proc.stdout)
        if rep is None:
            raise FirmwareDied("firmware exited at t=%.3f s" % (t_ms / 1000.0))
        self.steps += 1
        self.fw_last_ms = t_ms
        self._on_report(t_ms, rep)

    # ------------------------------------------------------------------ main loop
    def run(self):
        self.out.mkdir(parents=True, exist_ok=True)
        self.data_dir = self.out / "fw"
        if self.data_dir.exists():
            shutil.rmtree(self.data_dir)
        self.data_dir.mkdir()
        if self.fw_config_bytes is not None:
            _fw_import()
            from trackpilot import config as fwconfig

            cfg_full = fwconfig.defaults()
            (self.out / "config.json").write_bytes(self.fw_config_bytes)
        else:
            cfg_partial, cfg_full = self._fw_config()
            (self.out / "config.json").write_text(json.dumps(cfg_partial, indent=2))
        (self.out / "sim_params.json").write_text(json.dumps(self.p, indent=2))
        from .motor_dev import MotorDevice

        self.motor = MotorDevice(cfg_full["motor"], component_rng(self.seed, "motor"))
        self._reset_pending = False
        self.estop_on = False  # the E-stop input level, as the board's pin holds it
        self.pilot.silent = False

        self.sched.at(0, self._gnss_epoch)
        self.sched.at(137_000, self._wind_sample)
        self.pilot.start(self.sched.now_us, phase_us=310_000)
        self.sched.at(0, self._scenario_tick)
        for name, t_s, d_s in self.faults:
            self.sched.at(int(t_s * 1e6), self._fault, name, True, d_s)
        po = self.p["seatalk"]["other_talker_period_ms"]
        if po:
            self.sched.at(50_000, self._other_talker, 1 << 62, self.p["seatalk"]["other_talker_polite"])

        end_ms = int(self.duration_s * 1000)
        wall0 = time.perf_counter()
        self.stderr_f = open(self.out / "firmware_stderr.txt", "wb")
        try:
            self._start_fw(0, "power-on")
            self._loop(end_ms, wall0)
        except FirmwareDied as e:
            self.failure = str(e)
            self.stop_reason = "failure: " + str(e)
        finally:
            self._stop_fw()
            self.stderr_f.close()
        self.wall_s = time.perf_counter() - wall0
        self.sim_s = self.fw_last_ms / 1000.0
        self._write_truth()
        return self.result()

    def _loop(self, end_ms, wall0):
        sched = self.sched
        while True:
            if self.stop_reason:
                return
            if self.finished_ms is not None and self.fw_last_ms - self.finished_ms >= self.stop_after_finish_s * 1000:
                self.stop_reason = "finished"
                return
            # the next time the firmware must be stepped
            t_step = self.fw_wake_ms
            if self.deliv and (t_step is None or self.deliv[0][0] < t_step):
                t_step = self.deliv[0][0]
            t_int = sched.next_us()
            if t_int is not None and (t_step is None or t_int <= t_step * 1000):
                if t_int > end_ms * 1000:
                    self.stop_reason = "time limit"
                    return
                self.advance_physics(t_int // 1000)
                sched.run_until(t_int)
                if self._reset_pending:
                    self._do_reset(t_int // 1000)
                continue
            if t_step is None:
                self.stop_reason = "nothing to do"
                return
            if t_step > end_ms:
                self.stop_reason = "time limit"
                return
            t_step = max(t_step, self.fw_last_ms)
            self.advance_physics(t_step)
            if self.realtime:
                lag = t_step / 1000.0 / self.realtime_speed - (time.perf_counter() - wall0)
                if lag > 0:
                    time.sleep(lag)
            self._step(t_step)

    def _do_reset(self, t_ms):
        self._reset_pending = False
        self.resets += 1
        self._stop_fw()
        self.events.append((t_ms / 1000.0, "reset", "firmware restarted (exit %s)" % self.fw_exit))
        # bytes in flight to the old process are lost, as on a real reset
        self.deliv = []
        self.mode = None
        self._start_fw(t_ms, "soft")
        if self.estop_on:  # the pin is still held: the new process reads it like the board would
            self.send_input(t_ms, "estop=1")

    # ------------------------------------------------------------------ results
    def _write_truth(self):
        with open(self.out / "truth.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(TRUTH_FIELDS)
            w.writerows(self.truth_rows)

    def result(self):
        return {
            "stop_reason": self.stop_reason, "failure": self.failure, "sim_s": self.sim_s,
            "wall_s": self.wall_s, "speedup": self.sim_s / self.wall_s if self.wall_s else None,
            "steps": self.steps, "resets": self.resets, "finished_s": (
                None if self.finished_ms is None else self.finished_ms / 1000.0),
            "outputs": self.output_log, "events": self.events + [
                (t / 1000.0, "pilot", txt) for t, txt in self.pilot.log],
            "bus": dict(self.bus.stats), "pilot_keys_accepted": self.pilot.keys_accepted,
            "pilot_keys_ignored": self.pilot.keys_ignored,
            "pilot_keys_by_sender": dict(self.pilot.keys_by_sender), "pilot_bad_datagrams": self.pilot.bad_datagrams,
            "gnss_epochs": self.f9p.epochs, "gnss_valsets": self.f9p.valsets,
            "motor_setpoints": list(self.motor.setpoints) if self.motor else [], "telemetry_bytes": self.telemetry_bytes,
            "truth_xte": self.truth_xte, "geom": self.geom, "out": str(self.out),
        }
