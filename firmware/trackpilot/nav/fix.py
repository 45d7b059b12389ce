# The per-epoch GNSS fix: the one object the parsers fill and navigation reads.
# Absolute positions are integers (1e-7 deg, plus 1e-9 deg high-precision parts) because the
# ESP32's single-precision floats would quantise 51.49 deg to about 0.4 m.
from trackpilot.compat import const

RTK_NONE = const(0)  # no position
RTK_SINGLE = const(1)  # autonomous or DGPS
RTK_FLOAT = const(2)
RTK_FIXED = const(3)
RTK_NAMES = ("none", "single", "float", "fixed")


class Fix:
    """Filled in place by the GNSS parser once per epoch (no allocation per epoch)."""


    def __init__(self):
        self.clear()

    def clear(self):
        self.t_ms = 0  # receive time (injected clock, ticks_ms domain)
        self.itow_ms = -1  # GPS time of week of the epoch, -1 unknown
        self.pos_valid = False
        self.lat_e7 = 0  # latitude, 1e-7 deg (int)
        self.lon_e7 = 0  # longitude, 1e-7 deg (int; a heap int above 107 deg on the ESP32)
        self.lat_hp = 0  # extra latitude, 1e-9 deg, -99..99 (NAV-HPPOSLLH), added to lat_e7*100
        self.lon_hp = 0
        self.height_mm = 0  # height above ellipsoid
        self.rtk = RTK_NONE  # RTK_* above
        self.num_sv = 0
        self.h_acc_m = 99.0  # horizontal accuracy estimate (1 sigma)
        self.heading_valid = False
        self.heading_deg = 0.0  # true heading of the bow (mount offset applied), 0..360
        self.heading_acc_deg = 180.0
        self.vel_valid = False
        self.sog_mps = 0.0  # speed over ground
        self.cog_deg = 0.0  # course over ground, 0..360
        self.utc_s = -1  # UTC seconds of day, -1 unknown
        self.utc_ms = -1  # UTC milliseconds of day (5 Hz epochs need the fraction), -1 unknown
        self.date = 0  # ddmmyy from RMC, 0 unknown
        self.sources = 0  # bit set of the messages that filled this epoch (parser-defined)
