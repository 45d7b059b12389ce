"""A realistic 5 Hz sailing sequence for log-format tests: a boat on a Middelburg-like loop with
RTK noise, float episodes, wave yaw, speed noise, 1 Hz pilot/wind/battery updates, keystrokes.

Usage: for rec, events in sailing_records(n=18000, seed=1): ...  (rec is a fresh ControlRecord)
"""
import math
import random

from trackpilot.record.logfmt import ControlRecord

LAT0_E7 = 514950000
LON0_E7 = 36100000
M_PER_E7_LAT = 0.0111195  # metres per 1e-7 deg of latitude
M_PER_E7_LON = 0.0111195 * math.cos(math.radians(51.495))


def sailing_records(n, seed=1, t0_ms=(1 << 30) - 60000):
    rnd = random.Random(seed)
    east = north = 0.0
    course = 45.0
    speed = 1.8
    legs = [(b, length, v) for (b, length), v in zip(LEGS, (2.0, 1.5, 2.2, 1.0, 0.5, 2.5))]
    leg = 0
    leg_left = legs[0][1]
    t_ms = t0_ms
    itow = 345600000
    yaw_phase = 0.0
    float_left = 0
    corr_age = 0.0
    rpm = 0
    keys = 0
    keys_net = 0
    locked = 40
    compass = 42.0
    rudder = 0
    wind_a = 80.0
    wind_s = 4.0
    batt = 50.8
    nsv = 24
    hacc = 0.014
    alarms = 0
    for k in range(n):
        target, _, v_cmd = legs[leg]
        err = (target - course + 540.0) % 360.0 - 180.0
        course += max(-4.0, min(4.0, 0.3 * err)) + rnd.gauss(0, 0.15)
        speed += 0.04 * (v_cmd - speed) + rnd.gauss(0, 0.01)
        dist = speed * 0.2
        east += dist * math.sin(math.radians(course))
        north += dist * math.cos(math.radians(course))
        leg_left -= dist
        if leg_left <= 0:
            leg = (leg + 1) % len(legs)
            leg_left = legs[leg][1]
        # GNSS: RTK fixed 1.5 cm noise, sometimes a float episode (0.3 m noise) for 10-30 s.
        if float_left == 0 and rnd.random() < 1 / 3000:
            float_left = rnd.randint(50, 150)
        rtk = 2 if float_left else 3
        if float_left:
            float_left -= 1
        sd = 0.3 if rtk == 2 else 0.015
        lat_e9 = LAT0_E7 * 100 + round((north + rnd.gauss(0, sd)) / M_PER_E7_LAT * 100)
        lon_e9 = LON0_E7 * 100 + round((east + rnd.gauss(0, sd)) / M_PER_E7_LON * 100)
        yaw_phase += 2 * math.pi * 0.3 * 0.2
        heading = (course + 3.0 + 2.0 * math.sin(yaw_phase) + rnd.gauss(0, 0.1)) % 360.0
        t_ms = (t_ms + 200 + rnd.choice((0, 0, 0, 1, -1, 2))) & ((1 << 30) - 1)
        itow = (itow + 200) % 604800000
        corr_age = 0.0 if k % 5 == 0 else corr_age + 0.2
        if k % 50 == 0:
            nsv = max(12, min(30, nsv + rnd.choice((-1, 0, 1))))
        hacc = max(0.008, hacc + rnd.gauss(0, 0.0005)) if rtk == 3 else 0.35
        r = ControlRecord()
        r.t_ms = t_ms
        r.itow_ms = itow
        r.pos_valid = True
        r.lat_e7, r.lat_hp = divmod(lat_e9, 100)
        r.lon_e7, r.lon_hp = divmod(lon_e9, 100)
        if r.lat_hp > 50:  # u-blox style: hp part in -99..99, either sign
            r.lat_e7 += 1
            r.lat_hp -= 100
        r.rtk = rtk
        r.num_sv = nsv
        r.h_acc_m = hacc
        r.heading_valid = True
        r.heading_deg = heading
        r.heading_acc_deg = 0.2 + abs(rnd.gauss(0, 0.02))
        r.vel_valid = True
        r.sog_mps = max(0.0, speed + rnd.gauss(0, 0.03))
        r.cog_deg = (course + rnd.gauss(0, 0.03 / max(speed, 0.2) * 57.3)) % 360.0
        r.corr_age_s = corr_age
        r.leg = leg
        r.xte_m = 0.4 * math.sin(k / 150.0) + rnd.gauss(0, 0.02)
        r.path_xte_m = 0.8 * r.xte_m + rnd.gauss(0, 0.01)  # against the rounded corners
        r.heading_cmd_deg = (target + 3.0 + 5.0 * math.sin(k / 150.0) + rnd.gauss(0, 0.3)) % 360.0
        r.speed_cmd_mps = v_cmd
        r.pilot_mode = 1
        if k % 5 == 0:  # 0x84 at 1 Hz: whole-degree compass, rudder
            compass = round((heading + 2.0 + rnd.gauss(0, 0.5)) % 360.0)
            rudder = round(max(-30, min(30, 0.5 * err + rnd.gauss(0, 2))))
        events = []
        want = round(target + 5.0 + 5.0 * math.sin(k / 150.0)) % 360  # cmd on the pilot's compass
        step = (want - locked + 540) % 360 - 180
        if abs(step) >= 2 and k % 2 == 0:  # the driver steps the course in 1 deg keys
            s = 1 if step > 0 else -1
            locked = (locked + s) % 360
            keys += 1
            keys_net += s
            events.append(("KEY", "%+d" % s))
        r.compass_deg = compass
        r.locked_deg = locked
        r.rudder_deg = rudder
        r.keys_sent = keys
        r.keys_net_deg = keys_net
        r.rpm_set = int(v_cmd * 400)
        rpm += (r.rpm_set - rpm) // 8 + rnd.randint(-3, 3)
        r.rpm = rpm
        if k % 5 == 2:  # battery and wind at 1 Hz
            batt = batt - 0.0003 + rnd.gauss(0, 0.01)
            wind_a = (wind_a + rnd.gauss(0, 3.0)) % 360.0
            wind_s = max(0.0, wind_s + rnd.gauss(0, 0.2))
        r.battery_v = round(batt, 2)
        r.wind_angle_deg = round(wind_a, 1)
        r.wind_speed_mps = round(round(wind_s / 0.5144, 1) * 0.5144, 2)
        if k % 3000 == 1500:
            alarms ^= 64
            events.append(("ALARM" if alarms else "ALARM_CLEAR", "xte: test"))
        r.alarms = alarms
        r.mode = 0 if (k < 25 or 2000 <= k < 2100) else 1
        if k == 25 or k == 2100:
            events.append(("MODE", "STANDBY->AUTO: engaged from HMI"))
        if k == 2000:
            events.append(("MODE", "AUTO->STANDBY: person pressed a key on the pilot"))
        yield r, events


LEGS = ((45.0, 120.0), (135.0, 60.0), (225.0, 150.0), (315.0, 80.0), (200.0, 40.0), (20.0, 200.0))


class Wp:
    def __init__(self, lat_e7, lon_e7, speed_mps, name, radius_m=None):
        self.lat_e7 = lat_e7
        self.lon_e7 = lon_e7
        self.speed_mps = speed_mps
        self.name = name
        self.radius_m = radius_m


def track_waypoints():
    """The nominal path of sailing_records as waypoints (first loop)."""
    east = north = 0.0
    out = [Wp(LAT0_E7, LON0_E7, 2.0, "start")]
    for i, (brg, length) in enumerate(LEGS):
        east += length * math.sin(math.radians(brg))
        north += length * math.cos(math.radians(brg))
        out.append(Wp(LAT0_E7 + round(north / M_PER_E7_LAT), LON0_E7 + round(east / M_PER_E7_LON),
                      1.5, "wp%d" % (i + 1), 3.0 if i == 2 else None))
    return out


def write_log(root, n, seed=1, **logger_kw):
    """Sail n records into a Logger session under root; returns the Logger."""
    from trackpilot.record.logger import Logger

    lg = Logger(root, fw_version="test", **logger_kw)
    t0 = (1 << 30) - 60000
    lg.start(t0, reset_cause="power_on", config_hash="0123abcd", track_id="logseq")
    lg.track(track_waypoints(), "logseq")
    for r, events in sailing_records(n, seed=seed, t0_ms=t0):
        lg.control(r)
        for kind, text in events:
            lg.event(kind, text, r.t_ms)
        lg.tick(r.t_ms)
    lg.close()
    return lg
