"""NMEA 0183 sentences the boat sends out for chart plotters (OpenCPN listens on UDP 10110).

GGA and RMC (position), HDT (dual-antenna heading) and XTE (cross-track error), built from the Fix
and the track progress. Latitude and longitude are formatted from the integer 1e-7 deg with integer
arithmetic, so a single-precision ESP32 sends the same digits as the host.

Usage:
    s = gga(fix)          # b"$GPGGA,...*hh\\r\\n"
    s = xte(progress.xte_m, valid=True)
"""
from trackpilot.nav.fix import RTK_FIXED, RTK_FLOAT, RTK_SINGLE


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
    return sentence("%sXTE,%s,%s,%.4f,%s,N,%s" % (talker, status, status, abs(xte_m) / 1852.0, steer,
                                                   "A" if valid else "N"))
