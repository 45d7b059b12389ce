"""The simulator's true frame: an azimuthal-equidistant plane about the start point (east, north in
metres, double precision), converted to and from WGS84 with geographiclib's geodesics.

Along a geodesic from the origin the plane is exact; the sideways scale error is about
(d/R)^2/6 (4e-9 at 1 km). Grid north at a point differs from true north there by the meridian
convergence `conv_deg` (grid direction + conv_deg = true direction), which `to_latlon` returns so
headings and velocities can be given against true north where the boat is.
"""
import math

from geographiclib.geodesic import Geodesic

_G = Geodesic.WGS84


class LocalFrame:
    def __init__(self, lat0_deg, lon0_deg):
        self.lat0_deg = lat0_deg
        self.lon0_deg = lon0_deg

    def to_latlon(self, east_m, north_m):
        """-> (lat_deg, lon_deg, conv_deg)."""
        d = math.hypot(east_m, north_m)
        if d < 1e-9:
            return self.lat0_deg, self.lon0_deg, 0.0
        azi1 = math.degrees(math.atan2(east_m, north_m))
        g = _G.Direct(self.lat0_deg, self.lon0_deg, azi1, d)
        conv = g["azi2"] - azi1
        conv = (conv + 180.0) % 360.0 - 180.0
        return g["lat2"], g["lon2"], conv

    def from_latlon(self, lat_deg, lon_deg):
        """-> (east_m, north_m)."""
        g = _G.Inverse(self.lat0_deg, self.lon0_deg, lat_deg, lon_deg)
        a = math.radians(g["azi1"])
        return g["s12"] * math.sin(a), g["s12"] * math.cos(a)


def deg_to_e7_hp(deg):
    """Degrees -> (e7 int, hp int in -50..50) with deg = e7*1e-7 + hp*1e-9 (UBX HPPOSLLH)."""
    total = int(round(deg * 1e9))
    e7 = (total + 50) // 100 if total >= 0 else -((-total + 50) // 100)
    return e7, total - e7 * 100


def e7_hp_to_deg(e7, hp=0):
    return e7 * 1e-7 + hp * 1e-9
