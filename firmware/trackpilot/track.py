"""Tracks: the waypoint CSV format, its parser and validation, and the precomputed legs.

A track is a list of waypoints (lat/lon as ints in 1e-7 deg, parsed from the decimal text
without a float, and a speed); leg i runs from waypoint i to waypoint i+1 and is sailed at
waypoint i's speed. The format is documented in tracks/README.md. A file that does not parse
raises TrackError(line_no, message) and never yields a Track, so the caller keeps the active
one (parse into a new object, swap only on success).

Usage:
    from trackpilot import track
    trk = track.parse_track_csv(open("tracks/middelburg_loop.csv").read())
    for w in track.validate(trk, {"turn_radius_m": 9.0}):
        print(w)
    leg = trk.legs[0]   # leg.length_m, leg.bearing_deg, leg.turn_deg, leg.speed_mps
"""
import math

from trackpilot import geo
from trackpilot.compat import wrap180

# Defaults (the parser's limits are arguments; the boat's come from config via `boat`).
MIN_LEG_M = 5.0  # shorter legs cannot be steered: the boat is 5 m long
MAX_SPEED_MPS = 8.0  # the boat does about 3 m/s; more is a typo (knots? km/h?)
MAX_RADIUS_M = 500.0
BOAT_DEFAULTS = {
    "turn_radius_m": 9.0,  # minimum turning radius (BOAT_AND_BENCHMARK.md: 8-10 m)
    "corner_tol_m": 1.5,  # warn when the best rounded corner passes further off the track
    "min_speed_mps": 0.3,  # below this the rudder has little authority
}
COLUMNS = ("lon", "lat", "speed_mps", "name", "radius_m")


class TrackError(ValueError):
    """A track file error; `line_no` is 1-based (0 when no line applies)."""

    def __init__(self, line_no, message):
        super().__init__("line %d: %s" % (line_no, message))
        self.line_no = line_no
        self.message = message


class Waypoint:
    def __init__(self, lat_e7, lon_e7, speed_mps, name=None, radius_m=None, line_no=0):
        self.lat_e7 = lat_e7
        self.lon_e7 = lon_e7
        self.speed_mps = speed_mps
        self.name = name
        self.radius_m = radius_m  # arrival radius, None: the default / end-perpendicular rule
        self.line_no = line_no

    def label(self, i):
        if self.name:
            return "wp %d '%s' (line %d)" % (i, self.name, self.line_no)
        return "wp %d (line %d)" % (i, self.line_no)


class Leg:
    """Leg i from waypoint i to i+1, geometry in the frame at waypoint i."""

    def __init__(self, i, length_m, bearing_deg, end_bearing_deg, speed_mps):
        self.i = i
        self.length_m = length_m
        self.bearing_deg = bearing_deg  # initial true bearing at waypoint i
        self.end_bearing_deg = end_bearing_deg  # true bearing of the leg as it reaches wp i+1
        self.turn_deg = 0.0  # turn at waypoint i+1 into the next leg (+ starboard); 0 on the last
        self.speed_mps = speed_mps
        self.start_m = 0.0  # track distance from waypoint 0 to waypoint i


class Track:
    def __init__(self, waypoints, name=None):
        self.waypoints = waypoints
        self.name = name
        self.legs = []
        start_m = 0.0
        for i in range(len(waypoints) - 1):
            a = waypoints[i]
            b = waypoints[i + 1]
            d, brg = geo.dist_bearing(a.lat_e7, a.lon_e7, b.lat_e7, b.lon_e7)
            end_brg = geo.final_bearing_deg(a.lat_e7, a.lon_e7, b.lat_e7, b.lon_e7)
            leg = Leg(i, d, brg, end_brg, a.speed_mps)
            leg.start_m = start_m
            start_m += d
            self.legs.append(leg)
        for i in range(len(self.legs) - 1):
            self.legs[i].turn_deg = wrap180(self.legs[i + 1].bearing_deg - self.legs[i].end_bearing_deg)
        self.length_m = start_m

    def duration_s(self):
        """Expected time to sail the legs at their speeds (no turns or accelerations)."""
        s = 0.0
        for leg in self.legs:
            s += leg.length_m / leg.speed_mps
        return s


def corner_deviation_m(turn_deg, radius_m):
    """Cross-track error at a corner sailed on a circle of radius_m tangent to both legs.

    The circle's centre lies on the bisector, R / cos(theta/2) from the corner; the arc's
    point nearest the corner is R (1/cos(theta/2) - 1) from the waypoint but only
    R (1 - cos(theta/2)) from each leg, which is what a cross-track error measures. So a
    90 deg corner costs 0.29 R, a 180 deg reversal on one waypoint R."""
    return radius_m * (1.0 - math.cos(math.radians(abs(turn_deg)) * 0.5))


def corner_tangent_m(turn_deg, radius_m):
    """Distance from the waypoint to where that circle touches each leg: R tan(theta/2)."""
    a = abs(turn_deg)
    if a >= 179.0:
        return 1e9
    return radius_m * math.tan(math.radians(a) * 0.5)


def _split_fields(line):
    return [f.strip() for f in line.split(",")]


def _num(text, what, line_no):
    try:
        v = float(text)
    except ValueError:
        raise TrackError(line_no, "%s '%s' is not a number" % (what, text))
    if v != v or v in (float("inf"), float("-inf")):
        raise TrackError(line_no, "%s '%s' is not a number" % (what, text))
    return v


def _coord(text, what, limit_e7, line_no):
    try:
        v = geo.decimal_to_e7(text)
    except ValueError:
        raise TrackError(line_no, "%s '%s' is not a decimal number of degrees" % (what, text))
    if v > limit_e7 or v < -limit_e7:
        raise TrackError(line_no, "%s %s is out of range (+-%d deg)" % (what, text, limit_e7 // 10000000))
    return v


def parse_track_csv(text, min_leg_m=MIN_LEG_M, max_speed_mps=MAX_SPEED_MPS, name=None):
    """Parse the CSV text of a track -> Track; raises TrackError(line_no, message)."""
    if isinstance(text, bytes):
        try:
            text = text.decode()
        except UnicodeError:
            raise TrackError(0, "the file is not UTF-8 text")
    cols = None
    wps = []
    line_no = 0
    for raw in text.split("\n"):
        line_no += 1
        hash_at = raw.find("#")
        line = (raw if hash_at < 0 else raw[:hash_at]).strip()
        if line.startswith("\ufeff"):  # a spreadsheet's byte-order mark
            line = line[1:].strip()
        if not line:
            continue
        fields = _split_fields(line)
        if cols is None:
            cols = [f.lower() for f in fields]
            header_line = line_no
            for c in cols:
                if c not in COLUMNS:
                    raise TrackError(line_no, "unknown column '%s' (known: %s)" % (c, ", ".join(COLUMNS)))
                if cols.count(c) > 1:
                    raise TrackError(line_no, "column '%s' appears twice" % c)
            for c in ("lon", "lat", "speed_mps"):
                if c not in cols:
                    raise TrackError(line_no, "header lacks the column '%s' (need lon, lat, speed_mps)" % c)
            continue
        if len(fields) > len(cols):
            raise TrackError(line_no, "%d fields, the header has %d columns" % (len(fields), len(cols)))
        while len(fields) < len(cols):  # trailing optional fields may be left out
            if cols[len(fields)] in ("lon", "lat", "speed_mps"):
                raise TrackError(line_no, "%d fields, the header has %d columns" % (len(fields), len(cols)))
            fields.append("")
        rec = {}
        for c, f in zip(cols, fields):
            rec[c] = f
        lat = _coord(rec["lat"], "lat", 900000000, line_no)
        lon = _coord(rec["lon"], "lon", 1800000000, line_no)
        if lon == -1800000000:
            lon = 1800000000
        spd = _num(rec["speed_mps"], "speed_mps", line_no)
        if spd < 0.0:
            raise TrackError(line_no, "speed_mps %s is negative" % rec["speed_mps"])
        if spd > max_speed_mps:
            raise TrackError(line_no, "speed_mps %s is above %.1f m/s (a unit mix-up? knots = 0.514 m/s)"
                             % (rec["speed_mps"], max_speed_mps))
        radius = None
        if rec.get("radius_m", ""):
            radius = _num(rec["radius_m"], "radius_m", line_no)
            if not (0.0 < radius <= MAX_RADIUS_M):
                raise TrackError(line_no, "radius_m %s must be in (0, %d] m" % (rec["radius_m"], MAX_RADIUS_M))
        wp_name = rec.get("name", "") or None
        if wps and wps[-1].lat_e7 == lat and wps[-1].lon_e7 == lon:
            raise TrackError(line_no, "repeats the previous point (line %d)" % wps[-1].line_no)
        wps.append(Waypoint(lat, lon, spd, wp_name, radius, line_no))
    if cols is None:
        raise TrackError(1, "no header line (lon, lat, speed_mps ...) and no waypoints")
    if len(wps) < 2:
        raise TrackError(wps[-1].line_no if wps else header_line,
                         "a track needs at least 2 waypoints, found %d" % len(wps))
    for i in range(len(wps) - 1):
        if wps[i].speed_mps <= 0.0:
            raise TrackError(wps[i].line_no, "speed_mps 0 on a waypoint that starts a leg (only the "
                             "last waypoint may have speed 0)")
    trk = Track(wps, name)
    for leg in trk.legs:
        if leg.length_m < min_leg_m:
            a = wps[leg.i]
            raise TrackError(wps[leg.i + 1].line_no, "leg from line %d is %.1f m long; legs shorter "
                             "than %.1f m cannot be steered" % (a.line_no, leg.length_m, min_leg_m))
    return trk


def validate(trk, boat=None):
    """Warnings (strings, with line numbers) for a parsed track on this boat.

    boat: dict with turn_radius_m (or config's min_turn_radius_m), corner_tol_m, min_speed_mps
    (BOAT_DEFAULTS for what it lacks); other keys are ignored."""
    b = dict(BOAT_DEFAULTS)
    if boat:
        for k in boat:
            b[k] = boat[k]
        if "min_turn_radius_m" in boat and "turn_radius_m" not in boat:  # the config's name
            b["turn_radius_m"] = boat["min_turn_radius_m"]
    r = b["turn_radius_m"]
    warnings = []
    wps = trk.waypoints
    legs = trk.legs
    for i in range(len(wps) - 1):
        if wps[i].speed_mps < b["min_speed_mps"]:
            warnings.append("%s: speed %.2f m/s is below %.2f m/s; the rudder may not hold the line"
                            % (wps[i].label(i), wps[i].speed_mps, b["min_speed_mps"]))
    for k in range(1, len(wps) - 1):
        th = legs[k - 1].turn_deg
        if abs(th) >= 179.0:
            warnings.append("%s: reversal (%.0f deg turn) on one waypoint; the boat must loop around "
                            "and will pass about %.1f m or more off the track" % (wps[k].label(k), th, r))
            continue
        dev = corner_deviation_m(th, r)
        tan_m = corner_tangent_m(th, r)
        # each leg lends at most half its length to a corner at either end (all of it at the
        # track's ends): beyond that the rounded corners of a short leg overlap
        room_in = legs[k - 1].length_m * (1.0 if k == 1 else 0.5)
        room_out = legs[k].length_m * (1.0 if k == len(legs) - 1 else 0.5)
        if tan_m > room_in or tan_m > room_out:
            warnings.append("%s: %.0f deg turn needs %.1f m of leg either side for a %.1f m turning "
                            "radius but a leg is shorter; expect more than %.1f m off the track"
                            % (wps[k].label(k), th, tan_m, r, dev))
        elif dev > b["corner_tol_m"]:
            warnings.append("%s: %.0f deg turn is sharper than the boat can follow; with a %.1f m "
                            "turning radius expect %.1f m off the track there (the turn passes %.1f m "
                            "inside the waypoint)" % (wps[k].label(k), th, r, dev,
                                                      r / math.cos(math.radians(abs(th)) * 0.5) - r))
    return warnings


def track_id(text):
    """Short id of a track file's content: its CRC-32 (as zlib.crc32) in 8 hex digits, to match
    saved state and logs with the file. binascii when the build has it, else a bitwise loop (a
    one-off per load)."""
    if isinstance(text, str):
        text = text.encode()
    try:
        import binascii

        crc = binascii.crc32(text) & 0xFFFFFFFF
    except (ImportError, AttributeError):
        crc = 0xFFFFFFFF
        for b in text:
            crc ^= b
            for _ in range(8):
                crc = (crc >> 1) ^ (0xEDB88320 if crc & 1 else 0)
        crc ^= 0xFFFFFFFF
    return "%08x" % crc


def leg_table(trk):
    """Rows (i, from_label, length_m, bearing_deg, turn_deg at its end, speed_mps) for printing."""
    rows = []
    for leg in trk.legs:
        rows.append((leg.i, trk.waypoints[leg.i].name or "", leg.length_m, leg.bearing_deg,
                     leg.turn_deg, leg.speed_mps))
    return rows
