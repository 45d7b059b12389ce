"""The simulated Raymarine ST2000+ tiller pilot.

- Its own fluxgate compass: true heading + offset + deviation (sin/cos of heading) + slow drift
  (Gauss-Markov) + noise, lagged.
- Auto: heading hold on that compass, P-D on the course error with a deadband and a slow
  auto-trim; the ram moves the rudder at a fixed rate up to the limit, with a ram deadband.
  Standby: the tiller is free (rudder back to centre).
- Keystrokes 0x86 from any sender, framed from the 9th bit as the wire carries it: a character
  with the command bit starts a datagram, data characters complete it, a datagram that is cut short
  or malformed is ignored. +-1/+-10 change the locked course after `key_delay_ms`; Auto locks the
  current compass heading; Standby frees the tiller.
- Status: 0x84 every `status_period_ms` and, with `status_after_key` (default), once right after
  each accepted key; 0x9C every period (unless `status_9c` is 0).
- Hang faults: "steer" (keeps talking and taking keys, the rudder stops tracking) and "keys"
  (ignores course keys). Standby then Auto clears either.
- A person pressing a key on the unit: sends 0x86 with sender 0 on the bus and acts on it.
"""
import math

from . import stcodec
from .randproc import GaussMarkov


def wrap180(a):
    return (a + 180.0) % 360.0 - 180.0


class ST2000Sim:
    def __init__(self, params, rng, sched, bus, talker="pilot"):
        self.p = params
        self.rng = rng
        self.sched = sched
        self.bus = bus
        self.talker = talker
        bus.add_receiver(talker, self.rx_char)
        bus.retry_limit = params["retry_limit"]
        self.mode = stcodec.MODE_AUTO if params["initial_mode"] == "auto" else stcodec.MODE_STANDBY
        self.course_deg = 0.0
        self.compass_deg = None  # lagged compass reading (float), set on the first step
        self.bend_deg = 0.0  # deviation by nearby steel (fault compass_bend), deg
        self.compass_rate = 0.0
        self.drift = GaussMarkov(rng, params["compass_drift_sd_deg"], params["compass_drift_tau_s"])
        self.rudder_deg = 0.0
        self.trim_deg = 0.0
        self.hang = None  # None, "steer", "keys"
        self.rx_buf = None
        self.rx_last_us = 0
        self.off_course_s = 0.0
        self.log = []  # (t_ms, what) events: keys accepted/ignored, mode changes
        self.last_course_key_ms = None  # the last course change by a key
        self.keys_accepted = 0
        self.keys_ignored = 0
        self.bad_datagrams = 0
        self.started = False
        self.silent = False  # fault: no status datagrams
        self.keys_by_sender = {}
        self.standby_on_auto = False  # fault armed: a person's Standby races our next Auto
        self.standby_on_auto_us = None  # when that person pressed it

    # ---------------------------------------------------------------- periodic status
    def start(self, t_us, phase_us=0):
        self.started = True
        per = self.p["status_period_ms"] * 1000
        self.sched.at(t_us + phase_us, self._status_84)
        if self.p.get("status_9c", 1):
            self.sched.at(t_us + phase_us + self.p["status_9c_phase_ms"] * 1000, self._status_9c)
        self._period_us = per

    def _status_84(self, t_us):
        self.send_84(t_us)
        self.sched.at(t_us + self._period_us, self._status_84)

    def _status_9c(self, t_us):
        h = self.compass_int()
        if not self.silent:
            self.bus.send(self.talker, stcodec.encode_9c(h, self._rudder_report(), self.p["odd_rule"],
                                                         self.compass_rate > 0.5), t_us)
        self.sched.at(t_us + self._period_us, self._status_9c)

    def send_84(self, t_us):
        if self.silent:
            return
        alarms = 0x04 if self.off_course_s > 20.0 else 0
        d = stcodec.encode_84(self.compass_int(), self.course_deg, self.mode, alarms,
                              self._rudder_report(), self.p["tt_byte"], self.p["odd_rule"],
                              self.compass_rate > 0.5)
        self.bus.send(self.talker, d, t_us)

    def _rudder_report(self):
        return self.rudder_deg * self.p.get("rudder_report_sign", 1)

    def compass_int(self):
        return int(math.floor((self.compass_deg or 0.0) + 0.5)) % 360

    # ---------------------------------------------------------------- control (every physics step)
    def control_step(self, dt_s, true_heading_deg):
        p = self.p
        self.drift.step(dt_s)
        h = math.radians(true_heading_deg)
        dev = p.get("compass_dev_sin_deg", 0.0) * math.sin(h) + p.get("compass_dev_cos_deg", 0.0) * math.cos(h)
        meas = (true_heading_deg + p["compass_offset_deg"] + dev + self.bend_deg + self.drift.x
                + self.rng.gauss(0, p["compass_noise_deg"]))
        if self.compass_deg is None:
            self.compass_deg = meas % 360.0
        a = 1.0 - math.exp(-dt_s / p["compass_lag_s"]) if p["compass_lag_s"] > 0 else 1.0
        step = a * wrap180(meas - self.compass_deg)
        self.compass_deg = (self.compass_deg + step) % 360.0
        rate = step / dt_s
        self.compass_rate += (rate - self.compass_rate) * min(1.0, dt_s / 0.5)

        if self.mode == stcodec.MODE_AUTO:
            err = wrap180(self.course_deg - self.compass_deg)
            self.off_course_s = self.off_course_s + dt_s if abs(err) > p["off_course_alarm_deg"] else 0.0
            if self.hang == "steer":
                return self.rudder_deg  # keeps talking, the ram stops tracking
            db = p["deadband_deg"]
            # shifted (default): the error beyond the deadband; plain: the whole error once outside
            shift = db if p.get("deadband_shift", 1) else 0.0
            e = 0.0 if abs(err) <= db else err - math.copysign(shift, err)
            self.trim_deg += p["ki_rudder_per_degs"] * e * dt_s
            lim = p["trim_limit_deg"]
            self.trim_deg = max(-lim, min(lim, self.trim_deg))
            cmd = p["kp_rudder_per_deg"] * e - p["kd_rudder_s"] * self.compass_rate + self.trim_deg
        else:
            self.off_course_s = 0.0
            cmd = 0.0  # free tiller
        lim = p["rudder_limit_deg"]
        cmd = max(-lim, min(lim, cmd))
        diff = cmd - self.rudder_deg
        if self.mode != stcodec.MODE_AUTO or abs(diff) > p["rudder_deadband_deg"]:
            mv = p["rudder_rate_degps"] * dt_s
            self.rudder_deg += max(-mv, min(mv, diff))
        return self.rudder_deg

    # ---------------------------------------------------------------- SeaTalk receive
    def rx_char(self, t_us, value, bit9):
        gap = self.p["rx_gap_timeout_ms"]
        if gap and self.rx_buf is not None and t_us - self.rx_last_us > gap * 1000:
            self.rx_buf = None
            self.bad_datagrams += 1
        self.rx_last_us = t_us
        if bit9:
            if self.rx_buf is not None:
                self.bad_datagrams += 1  # cut short by a new command byte
            self.rx_buf = bytearray((value,))
            return
        if self.rx_buf is None:
            return  # data byte outside a datagram: ignored
        self.rx_buf.append(value)
        if self.standby_on_auto and len(self.rx_buf) == 3:
            self._race_auto(t_us)
        if len(self.rx_buf) >= 2 and len(self.rx_buf) == stcodec.datagram_len(self.rx_buf[1]):
            d = bytes(self.rx_buf)
            self.rx_buf = None
            self.on_datagram(t_us, d)

    def on_datagram(self, t_us, d):
        if d[0] != 0x86:
            return  # other traffic: not for the pilot
        k = stcodec.decode_86(d)
        if k is None:
            self.bad_datagrams += 1
            return
        sender, key = k
        self.keys_by_sender[sender] = self.keys_by_sender.get(sender, 0) + 1
        self.last_key = (sender, key, t_us)
        self.sched.at(t_us + self.p["key_delay_ms"] * 1000, self._apply_key, key, sender, False)

    # ---------------------------------------------------------------- keys
    def person_key(self, t_us, key_name):
        """Someone presses a key on the unit: it goes out on the bus (sender 0) and acts here."""
        key = stcodec.KEY_NAMES[key_name]
        self.bus.send(self.talker, stcodec.encode_86(0, key), t_us)
        self.sched.at(t_us + self.p["key_delay_ms"] * 1000, self._apply_key, key, 0, True)

    def _race_auto(self, t_us):
        """The takeover race at its tightest: an Auto keystroke from another sender has its key
        byte on the wire (its last byte still to come) and a person presses Standby on the unit
        now, so the pilot acts on the person's key first and on the Auto one character later."""
        b = self.rx_buf
        if b[0] != 0x86 or (b[1] & 0x0F) != 1 or b[1] >> 4 == 0 or b[2] != stcodec.KEY_AUTO:
            return
        self.standby_on_auto = False
        self.standby_on_auto_us = t_us
        why = "person presses standby as an auto from sender %d arrives" % (b[1] >> 4)
        self.log.append((t_us // 1000, why))
        self.person_key(t_us, "standby")

    def _apply_key(self, t_us, key, sender, local):
        t_ms = t_us // 1000
        accepted = False
        if key == stcodec.KEY_STANDBY:
            if self.mode != stcodec.MODE_STANDBY:
                self.mode = stcodec.MODE_STANDBY
                self.log.append((t_ms, "standby (sender %d)" % sender))
            accepted = True
        elif key == stcodec.KEY_AUTO:
            if self.mode == stcodec.MODE_STANDBY:
                self.mode = stcodec.MODE_AUTO
                self.course_deg = float(self.compass_int())
                self.trim_deg = 0.0
                if self.hang:
                    self.log.append((t_ms, "hang %s cleared by standby->auto" % self.hang))
                self.hang = None
                self.log.append((t_ms, "auto, course %.1f (sender %d)" % (self.course_deg, sender)))
            accepted = True
        elif key in stcodec.COURSE_KEYS:
            if self.mode == stcodec.MODE_AUTO and (self.hang != "keys" or local):
                self.course_deg = (self.course_deg + stcodec.COURSE_KEYS[key]) % 360.0
                self.last_course_key_ms = t_ms
                accepted = True
        if accepted:
            self.keys_accepted += 1
            if self.p.get("status_after_key", 1):
                self.send_84(t_us)
        else:
            self.keys_ignored += 1

    def set_hang(self, form):
        self.hang = form
