"""HmiStatus: what the HMI shows, filled by the app once per epoch; also the telemetry status datagram.

The app fills one HmiStatus in place each GNSS epoch; the pages render from it, the indicators derive
LEDs/buzzer from it, and `encode_status` packs it into the UDP status datagram (docs/TELEMETRY.md)
that the remote HMI box and the host monitor decode with `decode_status`.

Usage:
    from tphmi.status import HmiStatus, encode_status, decode_status
    st = HmiStatus()
    st.mode = 1; st.xte_m = -1.5; st.rtk = 3
    pkt = encode_status(st)            # bytes, 80..200 long
    st2 = decode_status(pkt)           # raises ValueError on garbage
"""
import struct

from trackpilot.compat import const

# Modes (same numbers as trackpilot.core.modes).
MODE_STANDBY = const(0)
MODE_AUTO = const(1)
MODE_ALARM = const(2)
MODE_ESTOP = const(3)
MODE_TRIAL = const(4)  # commissioning trial (docs/COMMISSIONING.md)
MODE_NAMES = ("STANDBY", "AUTO", "ALARM", "E-STOP", "TRIAL")

# GNSS quality (same numbers as trackpilot.nav.fix.RTK_*).
RTK_NAMES = ("none", "single", "float", "fixed")

# Tiller pilot mode as the pilot reports it: the same codes as trackpilot.devices.seatalk.MODE_* (and the log).
PM_STANDBY = const(0)
PM_AUTO = const(1)
PM_WIND = const(2)
PM_TRACK = const(3)
PM_CAL = const(4)
PM_UNKNOWN = const(5)
PILOT_MODE_NAMES = ("standby", "auto", "wind", "track", "calibration", "unknown")

# Wi-Fi station state (same numbers as trackpilot.board.wifi): flags2 bits 1-2; bit 3 access point on.
WIFI_NAMES = ("off", "connecting", "up", "retry")

# Alarm bits (same as trackpilot.core.modes.AL_*), short names for the 16-column display.
ALARM_BITS = (
    (1, "takeover"),
    (2, "gnss"),
    (4, "gnss timeout"),
    (8, "pilot hang"),
    (16, "pilot lost"),
    (32, "motor link"),
    (64, "xte"),
    (128, "arrival"),
    (256, "e-stop"),
    (512, "low battery"),
    (1024, "seatalk"),
    (2048, "config"),
)
AL_TAKEOVER = const(1)

TEXT_MAX = const(60)  # longest alarm_reason / refusal carried in the datagram (bytes, UTF-8)
STATUS_MAGIC = b"TPS\x01"  # "TPS" + format version 1

# Fixed part of the datagram after the magic; see docs/TELEMETRY.md for the table.
_FMT = "<HHBBBBHHBBHHHHiiHiHhhHHIHHIHI"
_FIXED_LEN = 4 + struct.calcsize(_FMT)

# Field list (name, default) in one place: __init__, to_dict and from_dict use it.
FIELDS = (
    ("boat_id", 0),  # per-boat id (also in authenticated commands)
    ("seq", 0),  # status sequence number, wraps at 65536
    # modes and alarms
    ("mode", MODE_STANDBY),  # MODE_* above
    ("degraded", False),  # AUTO holding course without GNSS guidance
    ("recovering", False),  # AUTO, hung-pilot recovery in progress
    ("holding", False),  # AUTO after arrival, holding the last heading
    ("estop_input", False),  # the E-stop input is active right now
    ("alarms", 0),  # active alarm bits (ALARM_BITS)
    ("sounding", 0),  # active and not acknowledged (buzzer sounds)
    ("alarm_reason", ""),  # text of the latest alarm, for the alarms page
    ("refusal", ""),  # why the last ENGAGE was refused ("" = none; the app clears it)
    ("cmd_counter", 0),  # counter of the last accepted remote command
    # GNSS
    ("rtk", 0),  # 0 none, 1 single, 2 float, 3 fixed (RTK_NAMES)
    ("pos_valid", False),
    ("lat_e7", 0),  # 1e-7 deg (ints: never a float)
    ("lon_e7", 0),
    ("num_sv", 0),
    ("h_acc_m", 99.0),  # horizontal accuracy (1 sigma)
    ("heading_valid", False),
    ("heading_deg", 0.0),  # true heading of the bow from the dual antenna, 0..360
    ("heading_acc_deg", 180.0),
    ("corr_age_s", -1.0),  # age of the RTK corrections, -1 unknown
    ("sog_mps", 0.0),  # speed over ground
    # navigation and guidance
    ("nav_valid", False),  # a track is loaded and the progress below is valid
    ("xte_m", 0.0),  # cross-track error, positive = boat starboard (right) of the leg
    ("leg", 0),  # current leg, 0-based (wp[leg] -> wp[leg+1]); shown 1-based
    ("legs", 0),  # number of legs in the track
    ("to_wp_m", 0.0),  # distance to the next waypoint
    ("cmd_valid", False),
    ("heading_cmd_deg", 0.0),  # guidance heading command, true, 0..360
    # motor
    ("rpm_cmd", 0),  # commanded RPM
    ("rpm", -1),  # RPM reported by the controller, -1 unknown
    # tiller pilot (ST2000+)
    ("pilot_ok", False),  # pilot status datagrams arriving
    ("pilot_mode", PM_UNKNOWN),  # PM_* above (= seatalk.MODE_*)
    ("compass_deg", 0.0),  # the pilot's own compass heading
    ("locked_deg", 0.0),  # the pilot's locked course
    ("keystrokes", 0),  # course keystrokes sent since boot
    ("hang_recoveries", 0),  # Standby-Auto recoveries since boot
    ("pilot_hunts", False),  # the pilot's own loop hunts: lower its response/rudder gain (core/pilotwatch.py)
    # Wi-Fi (trackpilot.board.wifi): station state and access point
    ("wifi", 0),  # 0 off, 1 connecting, 2 up, 3 retry (WIFI_NAMES)
    ("wifi_ap", False),  # the access point is on
    ("gnss_cfg_failed", False),  # the receiver's CFG-VALSET session failed (it runs on what it sends)
    # environment and power (the datagram's trailer)
    ("wind_angle_deg", -1.0),  # apparent wind angle from the bow, 0..360, -1 unknown
    ("wind_speed_mps", -1.0),  # apparent wind speed, -1 unknown
    ("battery_v", -1.0),  # battery voltage from the motor controller, -1 unknown
)

_TRAILER_LEN = 6  # u16 wind angle (0.1 deg), u16 wind speed (cm/s), u16 battery (10 mV); 65535 = unknown


def _u16_or_unknown(v, scale):
    return 65535 if v is None or v < 0 else _clamp(int(v * scale + 0.5), 0, 65534)


class HmiStatus:
    """Everything the HMI shows; see FIELDS for names, units and defaults."""

    def __init__(self):
        for name, default in FIELDS:
            setattr(self, name, default)

    def to_dict(self):
        d = {}
        for name, _ in FIELDS:
            d[name] = getattr(self, name)
        return d

    def update(self, d):
        """Set fields from a dict (JSON). Unknown keys raise ValueError (no silent typos)."""
        known = {}
        for name, default in FIELDS:
            known[name] = default
        for k in d:
            if k not in known:
                raise ValueError("unknown status field %r" % k)
            v = d[k]
            default = known[k]
            if isinstance(default, bool):
                v = bool(v)
            elif isinstance(default, float):
                v = float(v)
            elif isinstance(default, int):
                v = int(v)
            else:
                v = str(v)
            setattr(self, k, v)
        return self

    def flags(self):
        return (
            (1 if self.degraded else 0)
            | (2 if self.recovering else 0)
            | (4 if self.holding else 0)
            | (8 if self.estop_input else 0)
            | (16 if self.pos_valid else 0)
            | (32 if self.heading_valid else 0)
            | (64 if self.cmd_valid else 0)
            | (128 if self.nav_valid else 0)
        )


def _clamp(v, lo, hi):
    return lo if v < lo else hi if v > hi else v


def _cdeg(a_deg):
    """Angle to centidegrees 0..35999."""
    return int(a_deg * 100.0 + 0.5) % 36000


def _text(s):
    b = s.encode() if isinstance(s, str) else bytes(s)
    return b[:TEXT_MAX]


def encode_status(st):
    """Pack an HmiStatus into the status datagram (bytes)."""
    ra = _text(st.alarm_reason)
    rf = _text(st.refusal)
    corr = st.corr_age_s
    corr_ds = 65535 if corr < 0 else _clamp(int(corr * 10.0 + 0.5), 0, 65534)
    fixed = struct.pack(
        _FMT,
        st.boat_id & 0xFFFF,
        st.seq & 0xFFFF,
        _clamp(st.mode, 0, 255),
        st.flags(),
        (1 if st.pilot_ok else 0) | ((st.wifi & 3) << 1) | (8 if st.wifi_ap else 0)
        | (16 if st.gnss_cfg_failed else 0) | (32 if st.pilot_hunts else 0),
        _clamp(st.rtk, 0, 255),
        st.alarms & 0xFFFF,
        st.sounding & 0xFFFF,
        _clamp(st.num_sv, 0, 255),
        _clamp(st.pilot_mode, 0, 255),
        _clamp(int(st.h_acc_m * 100.0 + 0.5), 0, 65535),
        _cdeg(st.heading_deg),
        _clamp(int(st.heading_acc_deg * 100.0 + 0.5), 0, 65535),
        corr_ds,
        st.lat_e7,
        st.lon_e7,
        _cdeg(st.heading_cmd_deg),
        _clamp(int(st.xte_m * 100.0 + (0.5 if st.xte_m >= 0 else -0.5)), -2147483647, 2147483647),
        _clamp(int(st.sog_mps * 100.0 + 0.5), 0, 65535),
        _clamp(st.rpm_cmd, -32768, 32767),
        _clamp(st.rpm, -32768, 32767),
        _clamp(st.leg, 0, 65535),
        _clamp(st.legs, 0, 65535),
        _clamp(int(st.to_wp_m * 100.0 + 0.5), 0, 4294967295),
        _cdeg(st.compass_deg),
        _cdeg(st.locked_deg),
        st.keystrokes & 0xFFFFFFFF,
        _clamp(st.hang_recoveries, 0, 65535),
        st.cmd_counter & 0xFFFFFFFF,
    )
    trailer = struct.pack("<HHH", _u16_or_unknown(st.wind_angle_deg, 10.0),
                          _u16_or_unknown(st.wind_speed_mps, 100.0), _u16_or_unknown(st.battery_v, 100.0))
    return STATUS_MAGIC + fixed + bytes((len(ra),)) + ra + bytes((len(rf),)) + rf + trailer


def decode_status(pkt, st=None):
    """Unpack a status datagram into `st` (or a new HmiStatus). Raises ValueError on bad input."""
    n = len(pkt)
    if n < _FIXED_LEN + 2:
        raise ValueError("status datagram too short (%d bytes)" % n)
    if bytes(pkt[:4]) != STATUS_MAGIC:
        raise ValueError("not a status datagram (magic)")
    v = struct.unpack(_FMT, bytes(pkt[4:_FIXED_LEN]))
    i = _FIXED_LEN
    la = pkt[i]
    if la > TEXT_MAX or i + 1 + la + 1 > n:
        raise ValueError("bad alarm_reason length")
    ra = bytes(pkt[i + 1 : i + 1 + la])
    i += 1 + la
    lf = pkt[i]
    end = i + 1 + lf
    if lf > TEXT_MAX or (end != n and end + _TRAILER_LEN != n):
        raise ValueError("bad refusal length")
    rf = bytes(pkt[i + 1 : end])
    trailer = struct.unpack("<HHH", bytes(pkt[end:n])) if n == end + _TRAILER_LEN else (65535,) * 3
    if st is None:
        st = HmiStatus()
    st.boat_id, st.seq, st.mode, flags, flags2, st.rtk = v[0:6]
    st.alarms, st.sounding, st.num_sv, st.pilot_mode = v[6:10]
    st.h_acc_m = v[10] / 100.0
    st.heading_deg = v[11] / 100.0
    st.heading_acc_deg = v[12] / 100.0
    st.corr_age_s = -1.0 if v[13] == 65535 else v[13] / 10.0
    st.lat_e7, st.lon_e7 = v[14], v[15]
    st.heading_cmd_deg = v[16] / 100.0
    st.xte_m = v[17] / 100.0
    st.sog_mps = v[18] / 100.0
    st.rpm_cmd, st.rpm, st.leg, st.legs = v[19:23]
    st.to_wp_m = v[23] / 100.0
    st.compass_deg = v[24] / 100.0
    st.locked_deg = v[25] / 100.0
    st.keystrokes, st.hang_recoveries, st.cmd_counter = v[26:29]
    st.degraded = bool(flags & 1)
    st.recovering = bool(flags & 2)
    st.holding = bool(flags & 4)
    st.estop_input = bool(flags & 8)
    st.pos_valid = bool(flags & 16)
    st.heading_valid = bool(flags & 32)
    st.cmd_valid = bool(flags & 64)
    st.nav_valid = bool(flags & 128)
    st.pilot_ok = bool(flags2 & 1)
    st.wifi = (flags2 >> 1) & 3
    st.wifi_ap = bool(flags2 & 8)
    st.gnss_cfg_failed = bool(flags2 & 16)
    st.pilot_hunts = bool(flags2 & 32)
    st.wind_angle_deg = -1.0 if trailer[0] == 65535 else trailer[0] / 10.0
    st.wind_speed_mps = -1.0 if trailer[1] == 65535 else trailer[1] / 100.0
    st.battery_v = -1.0 if trailer[2] == 65535 else trailer[2] / 100.0
    try:
        st.alarm_reason = ra.decode()
        st.refusal = rf.decode()
    except UnicodeError:
        raise ValueError("status text is not UTF-8")
    return st


def alarm_names(bits):
    """List of short names of the set alarm bits."""
    out = []
    for bit, name in ALARM_BITS:
        if bits & bit:
            out.append(name)
    return out


def mode_text(st):
    """'AUTO', 'AUTO degr', 'AUTO recov', 'AUTO hold', 'STANDBY', 'ALARM', 'E-STOP'."""
    m = st.mode
    s = MODE_NAMES[m] if 0 <= m < len(MODE_NAMES) else "mode%d" % m
    if m == MODE_AUTO:
        if st.degraded:
            s = "AUTO degr"
        elif st.recovering:
            s = "AUTO recov"
        elif st.holding:
            s = "AUTO hold"
    return s


def _num(v, default):
    return default if v is None else v


def status_from_app(app, t_ms, st=None):
    """Fill `st` (or a new HmiStatus) from the running application (trackpilot.app.App).

    Reads only attributes, defensively (getattr), so the HMI keeps working while the app evolves:
    app.mm (mode machine), app.fix, app.progress, app.track, app.heading_cmd_deg, app.rpm_cmd,
    app.motor.rpm, app.pilot (ST2000+ driver), app.refusal, app.alarm_reason, app.w (wiring)."""
    if st is None:
        st = HmiStatus()
    mm = app.mm
    st.mode = mm.mode
    st.degraded = bool(getattr(mm, "degraded", False))
    st.recovering = bool(getattr(mm, "recovering", False))
    st.holding = bool(getattr(mm, "holding", False))
    st.alarms = mm.alarms
    st.sounding = mm.sounding() if hasattr(mm, "sounding") else mm.alarms
    st.alarm_reason = getattr(app, "alarm_reason", "") or ""
    st.refusal = getattr(app, "refusal", "") or ""
    w = getattr(app, "w", None)
    st.estop_input = bool(w.estop_active()) if w is not None and hasattr(w, "estop_active") else False
    fix = getattr(app, "fix", None)
    if fix is not None:
        st.pos_valid = bool(fix.pos_valid)
        st.rtk = fix.rtk
        st.lat_e7 = fix.lat_e7
        st.lon_e7 = fix.lon_e7
        st.num_sv = fix.num_sv
        st.h_acc_m = fix.h_acc_m
        st.heading_valid = bool(fix.heading_valid)
        st.heading_deg = fix.heading_deg
        st.heading_acc_deg = fix.heading_acc_deg
        st.sog_mps = fix.sog_mps if fix.vel_valid else 0.0
    link = getattr(w, "wifi", None) if w is not None else None
    st.wifi = link.state if link is not None else 0
    st.wifi_ap = bool(link.ap_active) if link is not None else False
    st.gnss_cfg_failed = bool(getattr(app, "gnss_cfg_failed", False))
    age = w.correction_age_s(t_ms) if w is not None and hasattr(w, "correction_age_s") else None
    st.corr_age_s = -1.0 if age is None else float(age)
    prog = getattr(app, "progress", None)
    st.nav_valid = prog is not None
    if prog is not None:
        st.xte_m = prog.xte_m
        st.leg = prog.leg
        st.to_wp_m = prog.to_wp_m
        tr = getattr(app, "track", None)
        st.legs = len(tr.waypoints) - 1 if tr is not None else 0
    cmd = getattr(app, "heading_cmd_deg", None)
    st.cmd_valid = cmd is not None and st.mode == MODE_AUTO
    st.heading_cmd_deg = _num(cmd, 0.0)
    st.rpm_cmd = int(getattr(app, "rpm_cmd", 0) or 0)
    motor = getattr(app, "motor", None)
    rpm = getattr(motor, "rpm", None) if motor is not None else None
    st.rpm = -1 if rpm is None else int(rpm)
    pilot = getattr(app, "pilot", None)
    if pilot is not None:
        st.pilot_ok = bool(pilot.status_fresh(t_ms)) if hasattr(pilot, "status_fresh") else False
        m = getattr(pilot, "mode", None)
        st.pilot_mode = PM_UNKNOWN if m is None else m
        st.compass_deg = float(_num(getattr(pilot, "heading_deg", None), 0.0))
        st.locked_deg = float(_num(getattr(pilot, "course_deg", None), 0.0))
        st.keystrokes = getattr(pilot, "keys_sent", 0)
        st.hang_recoveries = getattr(pilot, "recoveries", 0)
    watch = getattr(app, "pilot_watch", None)
    st.pilot_hunts = bool(getattr(watch, "hunting", False))
    bv = getattr(motor, "battery_v", None) if motor is not None else None
    st.battery_v = -1.0 if bv is None else float(bv)
    wind = getattr(app, "wind", None)
    if wind is not None and getattr(wind, "valid", False):
        st.wind_angle_deg = float(_num(getattr(wind, "angle_deg", None), -1.0))
        st.wind_speed_mps = float(_num(getattr(wind, "speed_mps", None), -1.0))
    else:
        st.wind_angle_deg = -1.0
        st.wind_speed_mps = -1.0
    return st
