"""The simulated u-blox ZED-F9P (dual antenna, moving base): epochs at `rate_hz` (1-25 Hz) of
NAV-RELPOSNED, NAV-HPPOSLLH, NAV-PVT (`order` relpos_first, NAV-PVT last) or NAV-PVT first
(`pvt_first`), optionally NAV-EOE after them (`eoe`) and NMEA GGA/RMC before them, with RTK
noise, float/single episodes, heading loss, dropouts and latency. CFG-VALSET frames written to it
(`on_rx`) are answered with ACK-ACK unless `answer_valset` is false.

`epoch(t_ms, truth)` is called at each epoch instant with the truth there; it returns
(delivery_t_ms, bytes) or None during a dropout. Fault episodes are switched with `set_fault`.
"""
import datetime
import math
import struct

from . import nmea_enc, ubx_enc
from .geodesy import deg_to_e7_hp
from .randproc import GaussMarkov

GPS_EPOCH = datetime.datetime(1980, 1, 6)
LEAP_S = 18  # GPS - UTC since 2017


class F9P:
    def __init__(self, params, rng, frame):
        self.p = params
        self.rng = rng
        self.frame = frame
        self.period_ms = int(round(1000 / params["rate_hz"]))
        self.start_utc = datetime.datetime.fromisoformat(params["start_utc"])
        gps = self.start_utc - GPS_EPOCH + datetime.timedelta(seconds=LEAP_S)
        self.start_tow_ms = int(gps.total_seconds() * 1000) % (604800 * 1000)
        self.err = {  # position error processes per solution type (east, north)
            "fixed": (GaussMarkov(rng, params["fixed_sd_m"], params["fixed_tau_s"]),
                      GaussMarkov(rng, params["fixed_sd_m"], params["fixed_tau_s"])),
            "float": (GaussMarkov(rng, params["float_sd_m"], params["float_tau_s"]),
                      GaussMarkov(rng, params["float_sd_m"], params["float_tau_s"])),
            "single": (GaussMarkov(rng, params["single_sd_m"], params["single_tau_s"]),
                       GaussMarkov(rng, params["single_sd_m"], params["single_tau_s"])),
        }
        self.jump_e = self.jump_n = 0.0
        self.faults = set()  # "float", "single", "heading_loss", "dropout"
        self.reacquire_until_ms = {"single": -1, "float": -1}
        self.was_dropped = False
        self.quality = "fixed"
        self.heading_valid = True
        self.last_tx_end_ms = 0
        self.num_sv = params["num_sv"]
        self.epochs = 0
        self.valsets = 0  # CFG-VALSET frames received
        self._rx = bytearray()

    def on_rx(self, t_ms, data):
        """Bytes the firmware wrote to the receiver; returns (delivery_t_ms, answer) or None.
        Each CFG-VALSET frame gets an ACK-ACK (if `answer_valset`); other bytes are ignored."""
        self._rx += data
        out = bytearray()
        buf = self._rx
        while True:
            i = buf.find(b"\xb5\x62")
            if i < 0:
                del buf[:max(0, len(buf) - 1)]
                break
            del buf[:i]
            if len(buf) < 8:
                break
            n = buf[4] | (buf[5] << 8)
            if len(buf) < n + 8:
                break
            cls, mid = buf[2], buf[3]
            del buf[:n + 8]
            if cls == 0x06 and mid == 0x8A:
                self.valsets += 1
                if self.p.get("answer_valset", True):
                    out += ubx_enc.frame(0x05, 0x01, bytes((cls, mid)))
        if not out:
            return None
        return t_ms + 10, bytes(out)

    def set_fault(self, name, on, t_ms):
        if on:
            self.faults.add(name)
        else:
            self.faults.discard(name)
            if name == "dropout":
                self.reacquire_until_ms["single"] = t_ms + int(self.p["reacquire_single_s"] * 1000)
                self.reacquire_until_ms["float"] = (self.reacquire_until_ms["single"]
                                                    + int(self.p["reacquire_float_s"] * 1000))

    def _solution(self, t_ms):
        if "single" in self.faults or t_ms < self.reacquire_until_ms["single"]:
            return "single"
        if "float" in self.faults or t_ms < self.reacquire_until_ms["float"]:
            return "float"
        return "fixed"

    def utc_at(self, t_ms):
        d = self.start_utc + datetime.timedelta(milliseconds=t_ms)
        return (d.year, d.month, d.day, d.hour, d.minute, d.second, d.microsecond * 1000)

    def itow_at(self, t_ms):
        return (self.start_tow_ms + t_ms) % (604800 * 1000)

    def epoch(self, t_ms, truth):
        """truth: dict with east_m, north_m (reference point), heading_grid_deg, vel_e, vel_n.
        Returns (delivery_t_ms, bytes) or None (no output)."""
        p = self.p
        dt_s = self.period_ms / 1000.0
        for e, n in self.err.values():
            e.step(dt_s)
            n.step(dt_s)
        if "dropout" in self.faults:
            self.was_dropped = True
            self.quality = "none"
            self.heading_valid = False
            return None
        sol = self._solution(t_ms)
        if sol == "float":
            if self.quality != "float" or self.rng.random() < p["float_jump_rate_hz"] * dt_s:
                a = self.rng.uniform(0, 2 * math.pi)
                j = self.rng.uniform(*p["float_jump_m"])
                self.jump_e, self.jump_n = j * math.sin(a), j * math.cos(a)
        else:
            self.jump_e = self.jump_n = 0.0
        self.quality = sol
        ee, en = self.err[sol]
        err_e = ee.x + (self.jump_e if sol == "float" else 0.0)
        err_n = en.x + (self.jump_n if sol == "float" else 0.0)

        # antenna position: reference point + lever arm along the hull heading
        h = math.radians(truth["heading_grid_deg"])
        fwd, stbd = p["antenna_fwd_m"], p["antenna_stbd_m"]
        ant_e = truth["east_m"] + fwd * math.sin(h) + stbd * math.cos(h) + err_e
        ant_n = truth["north_m"] + fwd * math.cos(h) - stbd * math.sin(h) + err_n
        lat, lon, conv = self.frame.to_latlon(ant_e, ant_n)
        lat_e7, lat_hp = deg_to_e7_hp(lat)
        lon_e7, lon_hp = deg_to_e7_hp(lon)

        # velocity against true north at the antenna, with noise
        c = math.radians(conv)
        ve0, vn0 = truth["vel_e"], truth["vel_n"]
        vel_e = ve0 * math.cos(c) - vn0 * math.sin(c) + self.rng.gauss(0, p["vel_sd_mps"])
        vel_n = ve0 * math.sin(c) + vn0 * math.cos(c) + self.rng.gauss(0, p["vel_sd_mps"])
        vel_d = self.rng.gauss(0, p["vel_sd_mps"])
        g_speed = math.hypot(vel_e, vel_n)
        head_mot = math.degrees(math.atan2(vel_e, vel_n)) % 360.0

        # dual-antenna heading: base -> rover antenna bearing (true), with mounting offset
        heading_sd = p["heading_sd_deg_at_1m"] / max(p["baseline_m"], 0.1)
        hv = "heading_loss" not in self.faults and sol != "single"
        self.heading_valid = hv
        heading = (truth["heading_grid_deg"] + conv + p["heading_mount_offset_deg"]
                   + self.rng.gauss(0, heading_sd if hv else 20.0)) % 360.0
        B = p["baseline_m"] + self.rng.gauss(0, 0.005)
        rel_n = B * math.cos(math.radians(heading))
        rel_e = B * math.sin(math.radians(heading))
        rel_d = self.rng.gauss(0, 0.01)

        itow = self.itow_at(t_ms)
        utc = self.utc_at(t_ms)
        hmsl_mm = int(round(p["hmsl_m"] * 1000))
        height_mm = int(round((p["hmsl_m"] + p["geoid_sep_m"]) * 1000))
        h_acc_mm = {"fixed": 14, "float": 350, "single": 1600}[sol]
        carr = {"fixed": 2, "float": 1, "single": 0}[sol]
        pvt_flags = 0x01 | (0x02 if carr else 0) | (carr << 6)
        rp_flags = ubx_enc.RP_GNSS_FIX_OK | ubx_enc.RP_DIFF_SOLN | ubx_enc.RP_IS_MOVING
        if hv:
            rp_flags |= ubx_enc.RP_REL_POS_VALID | ubx_enc.RP_CARR_FIXED | ubx_enc.RP_HEADING_VALID
        elif sol != "single":
            rp_flags |= ubx_enc.RP_REL_POS_VALID | ubx_enc.RP_CARR_FLOAT
        self.num_sv = max(8, min(32, self.num_sv + self.rng.choice((-1, 0, 0, 0, 0, 1))))

        out = bytearray()
        if p["nmea"]:
            out += nmea_enc.gga(utc, lat_e7, lat_hp, lon_e7, lon_hp, sol, self.num_sv, 0.6,
                                p["hmsl_m"], p["geoid_sep_m"], 1.0 if carr else None)
            out += nmea_enc.rmc(utc, lat_e7, lat_hp, lon_e7, lon_hp, sol, g_speed, head_mot)
        if p["ubx"]:
            rel = ubx_enc.nav_relposned(
                itow, rel_n, rel_e, rel_d, B, int(round(heading * 1e5)) if hv else 0,
                100, 100, 150, 100, int(heading_sd * 1e5) if hv else 18000000, rp_flags)
            hp = ubx_enc.nav_hpposllh(itow, lon_e7, lat_e7, lon_hp, lat_hp, height_mm, hmsl_mm,
                                        h_acc_01mm=h_acc_mm * 10, v_acc_01mm=h_acc_mm * 15)
            pvt = ubx_enc.nav_pvt(
                itow, utc, 3, pvt_flags, self.num_sv, lon_e7, lat_e7, height_mm, hmsl_mm, h_acc_mm,
                int(h_acc_mm * 1.5), int(round(vel_n * 1000)), int(round(vel_e * 1000)),
                int(round(vel_d * 1000)), int(round(g_speed * 1000)), int(round(head_mot * 1e5)),
                int(p["vel_sd_mps"] * 1000), 500000 if g_speed > 0.2 else 18000000)
            out += (pvt + rel + hp) if p.get("order") == "pvt_first" else (rel + hp + pvt)
            if p.get("eoe"):
                out += ubx_enc.frame(0x01, 0x61, struct.pack("<I", itow))
        self.epochs += 1
        lat_ms = self.rng.uniform(*p["latency_ms"])
        tx_ms = len(out) * 10 * 1000.0 / p["baud"]
        t_out = int(math.ceil(t_ms + lat_ms + tx_ms))
        t_out = max(t_out, self.last_tx_end_ms + 1)
        self.last_tx_end_ms = t_out
        return t_out, bytes(out)
