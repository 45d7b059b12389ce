# Shared helpers for the navigation tests: tracks drawn in metres about a start point, a fix
# placed in metres, and a few-line kinematic boat.
import math

from trackpilot.nav import geo
from trackpilot.nav.fix import Fix
from trackpilot.nav.track import parse_track_csv

LAT0 = 514900000
LON0 = 36100000


def e7_text(v):
    s = "-" if v < 0 else ""
    v = abs(v)
    return "%s%d.%07d" % (s, v // 10000000, v % 10000000)


def csv_from_m(points, header="lon,lat,speed_mps", lat0=LAT0, lon0=LON0):
    """points: (east_m, north_m, speed_mps[, extra fields text]) about (lat0, lon0)."""
    lines = [header]
    for p in points:
        la, lo = geo.move_e7(lat0, lon0, float(p[0]), float(p[1]))
        extra = ("," + p[3]) if len(p) > 3 else ""
        lines.append("%s,%s,%s%s" % (e7_text(lo), e7_text(la), repr(p[2]), extra))
    return "\n".join(lines) + "\n"


def track_from_m(points, lat0=LAT0, lon0=LON0):
    header = "lon,lat,speed_mps"
    if any(len(p) > 3 for p in points):
        header += ",name,radius_m"
    return parse_track_csv(csv_from_m(points, header, lat0, lon0))


def pos(east_m, north_m, lat0=LAT0, lon0=LON0):
    """(lat_e7, lon_e7, lat_hp, lon_hp) of a point in metres about the start."""
    return geo.move_hp(lat0, lon0, east_m, north_m)


def make_fix(east_m, north_m, heading_deg, sog_mps=1.0, cog_deg=None):
    f = Fix()
    la, lo, lah, loh = pos(east_m, north_m)
    f.pos_valid = True
    f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp = la, lo, lah, loh
    f.heading_valid = True
    f.heading_deg = heading_deg % 360.0
    f.vel_valid = True
    f.sog_mps = sog_mps
    f.cog_deg = (heading_deg if cog_deg is None else cog_deg) % 360.0
    return f


class Boat:
    """Kinematic boat: heading follows the command with a first-order lag and a rate limit;
    water speed u along the heading plus a constant current (east, north)."""

    def __init__(self, east_m, north_m, heading_deg, u_mps, cur_e_mps=0.0, cur_n_mps=0.0, tc_s=1.5,
                 max_rate_dps=10.0):
        self.max_rate_dps = max_rate_dps  # the turn it achieves: radius u / rate at most
        self.e = east_m
        self.n = north_m
        self.h = heading_deg
        self.u = u_mps
        self.ce = cur_e_mps
        self.cn = cur_n_mps
        self.tc_s = tc_s
        self.fix = Fix()

    def step(self, heading_cmd_deg, dt_s):
        err = (heading_cmd_deg - self.h + 180.0) % 360.0 - 180.0
        rate = err / self.tc_s
        rate = max(-self.max_rate_dps, min(self.max_rate_dps, rate))
        self.h = (self.h + rate * dt_s) % 360.0
        ve = self.u * math.sin(math.radians(self.h)) + self.ce
        vn = self.u * math.cos(math.radians(self.h)) + self.cn
        self.e += ve * dt_s
        self.n += vn * dt_s
        f = self.fix
        la, lo, lah, loh = pos(self.e, self.n)
        f.pos_valid = True
        f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp = la, lo, lah, loh
        f.heading_valid = True
        f.heading_deg = self.h
        f.vel_valid = True
        f.sog_mps = math.sqrt(ve * ve + vn * vn)
        f.cog_deg = math.degrees(math.atan2(ve, vn)) % 360.0
        return f
