"""NMEA 0183 sentences the boat sends out for chart plotters (OpenCPN listens on UDP 10110).

GGA and RMC (position), HDT (dual-antenna heading), XTE (cross-track error), and RMB and APB for
the active leg (origin and destination waypoint names, range and bearing to the destination,
arrival), built from the Fix and the track progress. Latitude and longitude are formatted from the
integer 1e-7 deg with integer arithmetic, so a single-precision ESP32 sends the same digits as the
host.

Usage:
    s = gga(fix)          # b"$GPGGA,...*hh\\r\\n"
    s = xte(progress.xte_m, valid=True)
    s = route(fix, progress, valid=True, heading_cmd_deg=cmd)   # RMB + APB, b"" without a leg
"""
import math

from trackpilot.fix import RTK_FIXED, RTK_FLOAT, RTK_SINGLE

M_PER_NM = 1852.0
KN_PER_MPS = 1.943844
MAX_SENTENCE = 82  # NMEA 0183 limit, "$" to "\\n"; longer ones are dropped by some listeners


def _checksum(body):
    c = 0
    for ch in body:
        c ^= ord(ch)
    return c


def sentence(body):
    """`body` without `$` and `*hh` -> the complete sentence as bytes."""
    return ("$%s*%02X\r\n" % (body, _checksum(body))).encode()


def _ddmm(value_e7, deg_digits):
    """1e-7 deg -> (ddmm.mmmmmmm text, negative). Minutes with 7 decimals, from integers only."""
    neg = value_e7 < 0
    v = -value_e7 if neg else value_e7
    deg = v // 10000000
    frac = v - deg * 10000000  # 1e-7 deg
    # minutes * 1e7 = frac * 60, exactly: 7 decimals of a minute (1.9 mm) hold the full precision
    min_e7 = frac * 60
    mins = min_e7 // 10000000
    mfrac = min_e7 - mins * 10000000
    fmt = "%02d%02d.%07d" if deg_digits == 2 else "%03d%02d.%07d"
    return fmt % (deg, mins, mfrac), neg


def lat_text(lat_e7):
    t, neg = _ddmm(lat_e7, 2)
    return t, "S" if neg else "N"


def lon_text(lon_e7):
    t, neg = _ddmm(lon_e7, 3)
    return t, "W" if neg else "E"


def _utc(fix):
    if fix.utc_s is None or fix.utc_s < 0:
        return ""
    s = fix.utc_s
    ms = fix.utc_ms if getattr(fix, "utc_ms", -1) >= 0 else s * 1000
    return "%02d%02d%02d.%02d" % (s // 3600, (s // 60) % 60, s % 60, (ms % 1000) // 10)


_QUALITY = {RTK_SINGLE: 1, RTK_FLOAT: 5, RTK_FIXED: 4}


def gga(fix, talker="GP"):
    if not fix.pos_valid:
        return sentence("%sGGA,%s,,,,,0,%02d,,,M,,M,," % (talker, _utc(fix), fix.num_sv))
    la, ns = lat_text(fix.lat_e7)
    lo, ew = lon_text(fix.lon_e7)
    q = _QUALITY.get(fix.rtk, 0)
    h_m = fix.height_mm / 1000.0
    return sentence("%sGGA,%s,%s,%s,%s,%s,%d,%02d,%.1f,%.3f,M,,M,," % (
        talker, _utc(fix), la, ns, lo, ew, q, fix.num_sv, min(99.9, fix.h_acc_m), h_m))


def rmc(fix, talker="GP"):
    la, ns = lat_text(fix.lat_e7)
    lo, ew = lon_text(fix.lon_e7)
    status = "A" if fix.pos_valid else "V"
    mode = {RTK_FIXED: "R", RTK_FLOAT: "F", RTK_SINGLE: "A"}.get(fix.rtk, "N")
    sog_kn = fix.sog_mps * 1.943844
    date = "%06d" % fix.date if fix.date else ""
    return sentence("%sRMC,%s,%s,%s,%s,%s,%s,%.2f,%.1f,%s,,,%s" % (
        talker, _utc(fix), status, la, ns, lo, ew, sog_kn, fix.cog_deg, date, mode))


def hdt(fix, talker="GP"):
    if not fix.heading_valid:
        return sentence("%sHDT,,T" % talker)
    return sentence("%sHDT,%.2f,T" % (talker, fix.heading_deg))


def xte(xte_m, valid=True, talker="II"):
    """XTE: magnitude in nautical miles and the direction to steer (L when we are to starboard)."""
    status = "A" if valid else "V"
    steer = "L" if xte_m > 0 else "R"
    return sentence("%sXTE,%s,%s,%s,%s,N,%s" % (talker, status, status, _xte_nm(xte_m), steer,
                                                 "A" if valid else "N"))


def _xte_nm(xte_m):
    # 5 decimals of a nautical mile (1.9 cm): a plotter set to metres shows the real deviation
    return "%.5f" % min(abs(xte_m) / M_PER_NM, 9.99)


def wp_id(wp, i, max_len=12):
    """A waypoint's name as an NMEA field: no field or sentence delimiters, at most max_len
    characters; WPn (1-based) when the track gives no name."""
    name = wp.name or ""
    out = ""
    for ch in name:
        o = ord(ch)
        out += ch if 32 < o < 127 and ch not in ",*$!\\^~" else "_"
    return (out or "WP%d" % (i + 1))[:max_len]


def _lat2(lat_e7):
    # 4 decimals of a minute (0.19 m) keep RMB within the 82-character limit
    t, h = lat_text(lat_e7)
    return t[:-3], h


def _lon2(lon_e7):
    t, h = lon_text(lon_e7)
    return t[:-3], h


def route(fix, prog, valid=True, heading_cmd_deg=None, talker="II"):
    """RMB and APB (bytes) for the progress' active leg; b"" without a position or a placed leg.

    valid: the pilot steers this leg (AUTO); otherwise both carry status V (a plotter shows the
    leg but no steering). heading_cmd_deg: the guidance command, sent as APB's heading to steer
    (default: the bearing to the destination)."""
    from trackpilot import geo

    if prog is None or not prog.valid or not fix.pos_valid:
        return b""
    wps = prog.track.waypoints
    i = prog.leg
    if i + 1 >= len(wps):
        return b""
    orig, dest = wps[i], wps[i + 1]
    rng_m, brg_deg = geo.dist_bearing(fix.lat_e7, fix.lon_e7, dest.lat_e7, dest.lon_e7,
                                      fix.lat_hp, fix.lon_hp)
    leg = prog.track.legs[i]
    radius = dest.radius_m if dest.radius_m is not None else getattr(prog, "arrival_radius_m", 0.0)
    arrived = rng_m <= radius or (prog.finished and prog.finish_reason == "arrived")
    passed = prog.along_m >= prog.leg_length_m
    closing_kn = 0.0
    if fix.vel_valid:
        closing_kn = fix.sog_mps * KN_PER_MPS * math.cos(math.radians(fix.cog_deg - brg_deg))
    status = "A" if valid else "V"
    steer = "L" if prog.xte_m > 0 else "R"
    la, ns = _lat2(dest.lat_e7)
    lo, ew = _lon2(dest.lon_e7)
    tail = ",%s,%s,%s,%s,%.3f,%.1f,%.1f,%s,%s" % (la, ns, lo, ew, min(rng_m / M_PER_NM, 999.999),
                                                   brg_deg, closing_kn, "A" if arrived else "V",
                                                   "A" if valid else "N")
    head = "%sRMB,%s,%s,%s," % (talker, status, _xte_nm(prog.xte_m)[:-1], steer)
    o_id, d_id = wp_id(orig, i), wp_id(dest, i + 1)
    while len(head) + len(o_id) + 1 + len(d_id) + len(tail) + 6 > MAX_SENTENCE and len(o_id) > 1:
        o_id = o_id[:-1]  # keep the destination's name whole as long as possible
    while len(head) + len(o_id) + 1 + len(d_id) + len(tail) + 6 > MAX_SENTENCE and len(d_id) > 1:
        d_id = d_id[:-1]
    rmb = sentence(head + o_id + "," + d_id + tail)
    hts = heading_cmd_deg if heading_cmd_deg is not None else brg_deg
    apb = sentence("%sAPB,%s,%s,%s,%s,N,%s,%s,%.1f,T,%s,%.1f,T,%.1f,T,%s" % (
        talker, status, status, _xte_nm(prog.xte_m), steer, "A" if arrived else "V",
        "A" if passed else "V", leg.bearing_deg % 360.0, wp_id(dest, i + 1), brg_deg, hts % 360.0,
        "A" if valid else "N"))
    return rmb + apb
