"""The simulator's own NMEA 0183 encoders (GGA, RMC, MWV); verified against pynmeagps in tests."""


def sentence(body):
    cs = 0
    for ch in body.encode("ascii"):
        cs ^= ch
    return ("$%s*%02X\r\n" % (body, cs)).encode("ascii")


def ddmm(e7, hp, lat):
    """Integer 1e-7 deg (+ 1e-9 hp) -> ('ddmm.mmmmmmm', 'N'|'S') exactly, without floats."""
    total = e7 * 100 + hp  # 1e-9 deg
    hemi = ("N" if total >= 0 else "S") if lat else ("E" if total >= 0 else "W")
    total = abs(total)
    deg, rem = divmod(total, 10 ** 9)
    min_e7 = (rem * 60 + 50) // 100  # minutes in 1e-7
    if min_e7 >= 60 * 10 ** 7:
        deg += 1
        min_e7 -= 60 * 10 ** 7
    mins, frac = divmod(min_e7, 10 ** 7)
    return ("%02d%02d.%07d" if lat else "%03d%02d.%07d") % (deg, mins, frac), hemi


def hhmmss(utc):
    return "%02d%02d%02d.%02d" % (utc[3], utc[4], utc[5], utc[6] // 10_000_000)


GGA_QUALITY = {"none": 0, "single": 1, "float": 5, "fixed": 4}
RMC_MODE = {"none": "N", "single": "A", "float": "F", "fixed": "R"}


def gga(utc, lat_e7, lat_hp, lon_e7, lon_hp, quality, num_sv, hdop, alt_m, sep_m, age_s=None,
        talker="GN"):
    la, ns = ddmm(lat_e7, lat_hp, True)
    lo, ew = ddmm(lon_e7, lon_hp, False)
    age = "" if age_s is None else "%.1f" % age_s
    station = "" if age_s is None else "0000"
    q = GGA_QUALITY[quality]
    if q == 0:
        la = ns = lo = ew = ""
    body = "%sGGA,%s,%s,%s,%s,%s,%d,%02d,%.2f,%.3f,M,%.3f,M,%s,%s" % (
        talker, hhmmss(utc), la, ns, lo, ew, q, num_sv, hdop, alt_m, sep_m, age, station)
    return sentence(body)


def rmc(utc, lat_e7, lat_hp, lon_e7, lon_hp, quality, sog_mps, cog_deg, talker="GN"):
    la, ns = ddmm(lat_e7, lat_hp, True)
    lo, ew = ddmm(lon_e7, lon_hp, False)
    ok = quality != "none"
    if not ok:
        la = ns = lo = ew = ""
    date = "%02d%02d%02d" % (utc[2], utc[1], utc[0] % 100)
    body = "%sRMC,%s,%s,%s,%s,%s,%s,%.3f,%.2f,%s,,,%s,V" % (
        talker, hhmmss(utc), "A" if ok else "V", la, ns, lo, ew, sog_mps / 0.514444,
        cog_deg, date, RMC_MODE[quality])
    return sentence(body)


def mwv(angle_deg, speed_mps, talker="WI", valid=True):
    body = "%sMWV,%.1f,R,%.1f,M,%s" % (talker, angle_deg % 360.0, speed_mps, "A" if valid else "V")
    return sentence(body)
