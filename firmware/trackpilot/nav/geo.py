"""WGS84 geodesy for short distances from integer positions, safe in single precision.

Positions are ints in 1e-7 deg (`lat_e7`, `lon_e7`), optionally refined by the u-blox
high-precision parts (`lat_hp`, `lon_hp`, 1e-9 deg, value = e7 * 100 + hp). Only integer
*differences* are ever turned into floats, so a float32 build (ESP32) keeps RTK precision.

Method (for two points up to a few km apart):
- integer differences dlat, dlon (the longitude wrapped across the antimeridian);
- meridional radius M and prime-vertical radius N at the pair's mid-latitude phi_m:
  north = M * dlat, east = N * cos(phi_m) * dlon gives the distance and the azimuth at the
  midpoint (Gauss mid-latitude formulas; the neglected terms are O((s/R)^2) ~ 1e-8 relative);
- meridian convergence gamma = dlon * sin(phi_m): the azimuth at point 0 is the mid azimuth
  minus gamma/2 (up to 0.008 deg at 1 km east-west at 60 deg, so it is needed for 0.01 deg).

Measured against geographiclib (tests/host/test_geo_oracle.py: 16000 random pairs up to 1 km
apart, 15043 of them > 10 m, within 10 km of starts at lat 0, 51.5, 60, -45 and lon 3.6, 120,
+-179.95 across the antimeridian), run under MicroPython:
- double build: distance error max 4.0e-6 m, bearing error max 1.9e-7 deg;
- float32 build: distance error max 3.4e-4 m, bearing error max 3.7e-5 deg;
- move_hp (inverse, up to 1 km): position error max 7.5e-5 m (double), 2.3e-4 m (float32).
The seed report's spherical formulas (`seed_dist_bearing`) err by up to 0.67 % of the distance
(double) and 0.75 % (float32) on the same pairs.

Usage:
    from trackpilot.nav import geo
    e7 = geo.ddmm_to_e7("5129.4000000", "N")          # 514900000
    d_m, brg_deg = geo.dist_bearing(514900000, 36100000, 514909000, 36110000)
    east_m, north_m = geo.offset_m(514900000, 36100000, 514909000, 36110000)
    lat_e7, lon_e7 = geo.move_e7(514900000, 36100000, 10.0, -5.0)
    ref_lat, ref_lon = geo.apply_lever_arm(lat_e7, lon_e7, heading_deg, 1.2, 0.0)
"""
import math

from trackpilot.compat import const, wrap360

# WGS84
_A_M = 6378137.0
_E2 = 0.0066943799901413165  # f * (2 - f), f = 1 / 298.257223563
_ONE_MINUS_E2 = 1.0 - _E2
_DEG = math.pi / 180.0
_E9_RAD = math.pi / 180.0 * 1e-9  # radians per 1e-9 deg
# Longitudes as ints: 360 deg in 1e-9 deg is a big int; only used to wrap a difference.
_HALF_TURN_E7 = 1800000000
_TURN_E7 = 3600000000
_MAX_LAT_E7 = const(900000000)

# The seed report's sphere (Appendix B); comparison only.
SEED_R_M = 6377918.0


def radii_m(lat_deg):
    """(M, N*cos(lat)): metres per radian of latitude and of longitude at lat_deg."""
    s = math.sin(lat_deg * _DEG)
    w2 = 1.0 - _E2 * s * s
    n = _A_M / math.sqrt(w2)
    return n * _ONE_MINUS_E2 / w2, n * math.cos(lat_deg * _DEG)


def _diff_e9(lat0_e7, lon0_e7, lat1_e7, lon1_e7, lat0_hp, lon0_hp, lat1_hp, lon1_hp):
    """Integer differences (dlat, dlon) in 1e-9 deg, dlon wrapped to (-180, 180] deg."""
    dlon = lon1_e7 - lon0_e7
    if dlon > _HALF_TURN_E7:
        dlon -= _TURN_E7
    elif dlon <= -_HALF_TURN_E7:
        dlon += _TURN_E7
    return (lat1_e7 - lat0_e7) * 100 + (lat1_hp - lat0_hp), dlon * 100 + (lon1_hp - lon0_hp)


def _mid(lat0_e7, lat0_hp, dlat_e9):
    # The absolute latitude only feeds the radii and sin/cos: its float32 rounding (~3e-6 deg)
    # changes them by < 1e-7 relative.
    return lat0_e7 * 1e-7 + (lat0_hp + dlat_e9 * 0.5) * 1e-9


def _mid_frame(lat0_e7, lon0_e7, lat1_e7, lon1_e7, lat0_hp, lon0_hp, lat1_hp, lon1_hp):
    """(east_m, north_m) in the midpoint's frame and half the meridian convergence (rad)."""
    dlat, dlon = _diff_e9(lat0_e7, lon0_e7, lat1_e7, lon1_e7, lat0_hp, lon0_hp, lat1_hp, lon1_hp)
    phim_deg = _mid(lat0_e7, lat0_hp, dlat)
    m, nc = radii_m(phim_deg)
    dlon_rad = dlon * _E9_RAD
    return nc * dlon_rad, m * (dlat * _E9_RAD), 0.5 * dlon_rad * math.sin(phim_deg * _DEG)


def offset_m(lat0_e7, lon0_e7, lat1_e7, lon1_e7, lat0_hp=0, lon0_hp=0, lat1_hp=0, lon1_hp=0):
    """(east_m, north_m) of point 1 from point 0 in the frame at point 0 (true north there).

    Distance and initial azimuth are those of the geodesic, so this is an azimuthal
    equidistant projection about point 0: straight lines through point 0 are geodesics."""
    e, n, g = _mid_frame(lat0_e7, lon0_e7, lat1_e7, lon1_e7, lat0_hp, lon0_hp, lat1_hp, lon1_hp)
    # Rotate the mid-point azimuth back by gamma/2 to the azimuth at point 0.
    cg = math.cos(g)
    sg = math.sin(g)
    return e * cg - n * sg, n * cg + e * sg


def dist_bearing(lat0_e7, lon0_e7, lat1_e7, lon1_e7, lat0_hp=0, lon0_hp=0, lat1_hp=0, lon1_hp=0):
    """(dist_m, bearing_deg): geodesic distance and initial true bearing 0..360 from 0 to 1."""
    e, n, g = _mid_frame(lat0_e7, lon0_e7, lat1_e7, lon1_e7, lat0_hp, lon0_hp, lat1_hp, lon1_hp)
    d = math.sqrt(e * e + n * n)
    if d == 0.0:
        return 0.0, 0.0
    return d, wrap360((math.atan2(e, n) - g) / _DEG)


def final_bearing_deg(lat0_e7, lon0_e7, lat1_e7, lon1_e7):
    """True bearing of the geodesic from 0 to 1 as it arrives at point 1."""
    e, n, g = _mid_frame(lat0_e7, lon0_e7, lat1_e7, lon1_e7, 0, 0, 0, 0)
    if e == 0.0 and n == 0.0:
        return 0.0
    return wrap360((math.atan2(e, n) + g) / _DEG)


def split_e9(value_e9):
    """Int in 1e-9 deg -> (e7, hp) with hp in -50..49 (value = e7 * 100 + hp)."""
    e7 = (value_e9 + 50) // 100
    return e7, value_e9 - e7 * 100


def move_hp(lat_e7, lon_e7, east_m, north_m, lat_hp=0, lon_hp=0):
    """Point at (east_m, north_m) from the given one (frame there) -> (lat_e7, lon_e7, lat_hp, lon_hp).

    Inverse of offset_m to < 0.3 mm within 1 km (fixed-point passes for the mid-latitude)."""
    lat0 = lat_e7 * 1e-7 + lat_hp * 1e-9
    dlat = 0.0
    dlon = 0.0
    # one pass is good to ~1e-6 m within 5 m (a lever arm); longer moves need the mid-latitude and
    # convergence from the first pass's result
    passes = 1 if -5.0 < east_m < 5.0 and -5.0 < north_m < 5.0 else 3
    for _ in range(passes):
        phim = lat0 + dlat * 0.5e-9
        m, nc = radii_m(phim)
        g = 0.5 * dlon * _E9_RAD * math.sin(phim * _DEG)
        cg = math.cos(g)
        sg = math.sin(g)
        # offset_m rotates the mid frame by -g; undo it.
        e = east_m * cg + north_m * sg
        n = north_m * cg - east_m * sg
        dlat = n / m / _E9_RAD
        dlon = e / nc / _E9_RAD
    # add in the small domain (hp + offset), so no big int is formed on the ESP32
    q, lah = split_e9(lat_hp + int(round(dlat)))
    la = lat_e7 + q
    q, loh = split_e9(lon_hp + int(round(dlon)))
    lo = lon_e7 + q
    if lo > _HALF_TURN_E7 or (lo == _HALF_TURN_E7 and loh > 0):
        lo -= _TURN_E7
    elif lo < -_HALF_TURN_E7 or (lo == -_HALF_TURN_E7 and loh <= 0):
        lo += _TURN_E7
    if la > _MAX_LAT_E7 or la < -_MAX_LAT_E7:
        raise ValueError("move_e7 crosses a pole")
    return la, lo, lah, loh


def move_e7(lat_e7, lon_e7, east_m, north_m):
    """Point at (east_m, north_m) from the given one -> (lat_e7, lon_e7), rounded to 1e-7 deg."""
    la, lo, _, _ = move_hp(lat_e7, lon_e7, east_m, north_m)
    return la, lo


def _lever_en(heading_deg, fwd_m, stbd_m):
    h = heading_deg * _DEG
    sh = math.sin(h)
    ch = math.cos(h)
    # antenna offset from the reference point, east and north
    return fwd_m * sh + stbd_m * ch, fwd_m * ch - stbd_m * sh


def apply_lever_arm_hp(lat_e7, lon_e7, lat_hp, lon_hp, heading_deg, fwd_m, stbd_m):
    """Reference point from the antenna position -> (lat_e7, lon_e7, lat_hp, lon_hp).

    The antenna sits fwd_m ahead of and stbd_m to starboard of the reference point."""
    e, n = _lever_en(heading_deg, fwd_m, stbd_m)
    return move_hp(lat_e7, lon_e7, -e, -n, lat_hp, lon_hp)


def apply_lever_arm(lat_e7, lon_e7, heading_deg, fwd_m, stbd_m):
    """Reference point from the antenna position -> (lat_e7, lon_e7) (see apply_lever_arm_hp)."""
    if fwd_m == 0.0 and stbd_m == 0.0:
        return lat_e7, lon_e7
    e, n = _lever_en(heading_deg, fwd_m, stbd_m)
    return move_e7(lat_e7, lon_e7, -e, -n)


def seed_dist_bearing(lat0_e7, lon0_e7, lat1_e7, lon1_e7):
    """The seed report's spherical formulas (Appendix B, R = 6377918 m), for comparison only.

    X = R cos(lat1) sin(dlon), Y = R (cos(lat0) sin(lat1) - sin(lat0) cos(lat1) cos(dlon)),
    bearing = atan2(X, Y), dist = sqrt(X^2 + Y^2). Uses absolute angles in floats, so on a
    float32 build it is off by metres; its distance error is up to 0.7 % (measured)."""
    la0 = lat0_e7 * 1e-7 * _DEG
    la1 = lat1_e7 * 1e-7 * _DEG
    dl = (lon1_e7 - lon0_e7) * 1e-7 * _DEG
    x = SEED_R_M * math.cos(la1) * math.sin(dl)
    y = SEED_R_M * (math.cos(la0) * math.sin(la1) - math.sin(la0) * math.cos(la1) * math.cos(dl))
    return math.sqrt(x * x + y * y), wrap360(math.atan2(x, y) / _DEG)


# ---- NMEA ddmm.mmmm text -> integers, no float ----

_POW10 = (1, 10, 100, 1000, 10000, 100000, 1000000, 10000000, 100000000, 1000000000,
          10000000000, 100000000000, 1000000000000)
_MAX_DECIMALS = const(12)


def _hemi_sign(hemi):
    if isinstance(hemi, int):
        c = hemi
    else:
        if len(hemi) != 1:
            raise ValueError("bad hemisphere %r" % (hemi,))
        c = ord(hemi) if isinstance(hemi, str) else hemi[0]
    if c == 78:  # N
        return 1, 90
    if c == 83:  # S
        return -1, 90
    if c == 69:  # E
        return 1, 180
    if c == 87:  # W
        return -1, 180
    raise ValueError("bad hemisphere %r" % (hemi,))


def _ddmm_scaled(text, hemi, digits):
    """Magnitude-rounded value of ddmm.mmm text in 10^-digits deg, signed by hemisphere."""
    if isinstance(text, str):
        text = text.encode()
    sign, max_deg = _hemi_sign(hemi)
    n = len(text)
    dot = n
    ip = 0  # integer part (ddmm)
    frac = 0
    k = 0  # decimals of minutes
    i = 0
    while i < n:
        c = text[i]
        if c == 46:  # '.'
            if dot != n:
                raise ValueError("bad ddmm %r" % (text,))
            dot = i
        elif 48 <= c <= 57:
            if dot == n:
                ip = ip * 10 + (c - 48)
            else:
                if k >= _MAX_DECIMALS:
                    raise ValueError("more than %d decimals in %r" % (_MAX_DECIMALS, text))
                frac = frac * 10 + (c - 48)
                k += 1
        else:
            raise ValueError("bad ddmm %r" % (text,))
        i += 1
    if dot < 3:
        raise ValueError("bad ddmm %r (needs ddmm)" % (text,))
    deg = ip // 100
    mins = ip % 100
    if mins >= 60:
        raise ValueError("minutes >= 60 in %r" % (text,))
    # minutes = (mins * 10^k + frac) / 10^k; value = deg + minutes / 60, in 10^-digits deg.
    mnum = mins * _POW10[k] + frac
    if k <= digits:
        num = mnum * _POW10[digits - k]
        den = 60
    else:
        num = mnum
        den = 60 * _POW10[k - digits]
    # round half away from zero: applied to the magnitude, the sign comes after
    v = deg * _POW10[digits] + (2 * num + den) // (2 * den)
    if v > max_deg * _POW10[digits]:
        raise ValueError("%r out of range" % (text,))
    return sign * v


def ddmm_to_e7(text, hemi):
    """NMEA `ddmm.mmmm` / `dddmm.mmmm` (str or bytes) and N/S/E/W -> int in 1e-7 deg.

    Exact integer arithmetic: the minutes' decimal value / 60 is rounded to the nearest 1e-7 deg,
    a tie rounded away from zero (i.e. the magnitude is rounded half up, then signed). Accepts
    0..12 decimals. Raises ValueError on malformed text, minutes >= 60 or |value| > 90/180 deg."""
    return _ddmm_scaled(text, hemi, 7)


def ddmm_to_e9(text, hemi):
    """As ddmm_to_e7 but in 1e-9 deg (for NMEA with 7 decimals of minutes); split_e9 gives hp."""
    return _ddmm_scaled(text, hemi, 9)


def decimal_to_e7(text):
    """Decimal degrees text ('-3.6123456', '51.49') -> int in 1e-7 deg without a float.

    More than 7 decimals are rounded half away from zero. Raises ValueError if malformed."""
    if isinstance(text, str):
        text = text.encode()
    n = len(text)
    i = 0
    sign = 1
    if n and (text[0] == 45 or text[0] == 43):  # '-' '+'
        sign = -1 if text[0] == 45 else 1
        i = 1
    ip = 0
    frac = 0
    k = 0
    nd = 0
    seen_dot = False
    round_up = False
    while i < n:
        c = text[i]
        if c == 46 and not seen_dot:
            seen_dot = True
        elif 48 <= c <= 57:
            nd += 1
            if not seen_dot:
                ip = ip * 10 + (c - 48)
                if ip > 1000:
                    raise ValueError("number too large: %r" % (text,))
            elif k < 7:
                frac = frac * 10 + (c - 48)
                k += 1
            elif k == 7:
                round_up = c >= 53  # first excess digit decides (half away from zero)
                k += 1
        else:
            raise ValueError("not a decimal number: %r" % (text,))
        i += 1
    if nd == 0:
        raise ValueError("not a decimal number: %r" % (text,))
    if k > 7:
        k = 7
    v = ip * 10000000 + frac * _POW10[7 - k] + (1 if round_up else 0)
    return sign * v
