"""Tracks: the waypoint CSV format, its parser and validation, and the legs derived on demand.

A track is a sequence of waypoints (lat/lon as ints in 1e-7 deg, parsed from the decimal text
without a float, and a speed); leg i runs from waypoint i to waypoint i+1 and is sailed at
waypoint i's speed. The format is documented in tracks/README.md. A file that does not parse
raises TrackError(line_no, message) and never yields a Track, so the caller keeps the active
one (parse into a new object, swap only on success).

Compact for the ESP32's ~110 KB heap: the file is read line by line twice (first to count the
waypoints, refusing more than MAX_WAYPOINTS, or more than TRACK_BUDGET_B of heap as
track_heap_bytes computes it, before anything is allocated for them, then into
integer arrays sized for them, in pages of 128 so no large block is needed): 11.0 B per waypoint
without names or radii, 22.1 B with both and a blank line after each (measured at 2000 on the
32-bit build; was ~550 B as Waypoint/Leg objects and boxed floats). A leg is computed from its two
waypoints when asked for, the last few cached; track distances and line numbers are recomputed
too (docs/MEMORY.md).

Usage:
    from trackpilot.nav import track
    trk, track_id = track.load_file("tracks/middelburg_loop.csv")    # or parse_track_csv(text)
    for w in track.validate(trk, {"turn_radius_m": 9.0}):
        print(w)
    leg = trk.leg(0)   # leg.length_m, leg.bearing_deg, leg.turn_deg, leg.speed_mps, leg.start_m
    trk.start_m(5), trk.line_no(5)    # track distance to waypoint 5 (m), its line in the file
    trk.waypoints[3].name, trk.legs[2].turn_deg, len(trk.waypoints)    # sequence views
"""
import math
from array import array

from trackpilot.nav import geo
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


MAX_WAYPOINTS = 2000  # the firmware's limit (tracks/README.md)
# The heap a track may take on the ESP32 (track_heap_bytes; tracks/README.md, docs/MEMORY.md):
# at the ESP32-equivalent heap the app kept a 16 KB largest free block in steady state up to
# tracks of about 31-33 KB (measured), so 28 KB leaves the run-to-run spread (2-3 KB) as margin.
# 2000 waypoints without names take 23.2 KB, with a radius on each 27.5 KB.
TRACK_BUDGET_B = 28 * 1024
MAX_NAME_CHARS = 16  # the display's width (hmi/tphmi/pages.py: 16 columns)
MAX_LINE_BYTES = 512  # a longer line is not a track line (and would cost a large string)
MAX_LINES = 65535  # line numbers are kept as 16-bit ints
# Floats as stored: single precision on a float32 build (the ESP32), else double, so a stored
# value reads back exactly as computed.
_FLOAT_CODE = "f" if 1.0 + 1e-9 == 1.0 else "d"


class Waypoint:
    """One waypoint, made on demand from the track's arrays (for printing, logging, tests)."""

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
    """Leg i from waypoint i to i+1, geometry in the frame at waypoint i (derived on demand)."""

    def __init__(self, i, length_m, bearing_deg, end_bearing_deg, speed_mps):
        self.i = i
        self.length_m = length_m
        self.bearing_deg = bearing_deg  # initial true bearing at waypoint i
        self.end_bearing_deg = end_bearing_deg  # true bearing of the leg as it reaches wp i+1
        self.turn_deg = 0.0  # turn at waypoint i+1 into the next leg (+ starboard); 0 on the last
        self.speed_mps = speed_mps
        self.start_m = 0.0  # track distance from waypoint 0 to waypoint i
        self.lat_e7 = 0  # waypoint i (set by Track.leg)
        self.lon_e7 = 0
        rad = math.radians(bearing_deg)
        self.ux = math.sin(rad)  # unit vector of the leg in its frame (east, north)
        self.uy = math.cos(rad)


class _Seq:
    """A read-only sequence view (len, index, negative index, slice, iteration) over item(i)."""

    def __init__(self, n, item):
        self._n = n
        self._item = item

    def __len__(self):
        return self._n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._item(k) for k in range(self._n)][i]
        if i < 0:
            i += self._n
        if not 0 <= i < self._n:
            raise IndexError("index out of range")
        return self._item(i)

    def __iter__(self):
        for k in range(self._n):
            yield self._item(k)


_LEG_CACHE = 8  # legs kept (direct-mapped by index): the current one and its neighbours


_PAGE_SHIFT = 7
_PAGE = 1 << _PAGE_SHIFT  # waypoints per page: no block larger than 1 KB is ever needed
_START_SHIFT = 5  # a track distance kept every 32 waypoints: at most 31 legs to add (0.13 B each)


class _Paged:
    """An int/float array in pages of _PAGE items: loads in a fragmented heap."""

    def __init__(self, code, item_bytes, n, zeros):
        """zeros: a bytearray of at least item_bytes * _PAGE zero bytes (one for all pages: no
        temporary per page to leave holes in the heap)."""
        self.pages = []
        for k in range(0, n, _PAGE):
            m = item_bytes * min(_PAGE, n - k)
            self.pages.append(array(code, zeros if m == len(zeros) else bytearray(m)))

    def __getitem__(self, i):
        return self.pages[i >> _PAGE_SHIFT][i & (_PAGE - 1)]

    def __setitem__(self, i, v):
        self.pages[i >> _PAGE_SHIFT][i & (_PAGE - 1)] = v


class Track:
    """The waypoints in preallocated integer arrays (pages of 128 waypoints): 10 B per waypoint
    (lat, lon, speed), + 2 B when the file gives radii, + 2 B and the name's bytes when it gives
    names. Derived on demand instead of stored: the track distances (from one float per 32),
    the line numbers (from the few lines where the file does not go on line by line), the legs
    (a few cached). `waypoints` and `legs` are sequence views."""

    def __init__(self, n_max, name=None, name_bytes=(), line_breaks=-1, radii=True):
        """name_bytes: the names' bytes per page (as _survey counts them); line_breaks: how many
        waypoints do not follow the previous one's line (-1: keep every line number, 0: none);
        radii: whether any waypoint has an arrival radius."""
        self.name = name
        self.n = 0
        # everything allocated here, before the parse, so its garbage cannot split the heap
        z = bytearray(4 * _PAGE)
        self.lat_e7 = _Paged("i", 4, n_max, z)
        self.lon_e7 = _Paged("i", 4, n_max, z)
        z = bytearray(2 * _PAGE)
        self.speed_mmps = _Paged("H", 2, n_max, z)  # mm/s (at most 8000)
        self.radius_cm = _Paged("H", 2, n_max, z) if radii else None  # 0: none
        named = False
        for k in name_bytes:
            named = named or k > 0
        self.name_end = _Paged("H", 2, n_max, z) if named else None  # end of wp i's name in its page's
        self._names = [bytearray(k) for k in name_bytes] if named else None
        self._names_len = 0
        # line numbers: every one (more breaks than half the waypoints), else (waypoint, line)
        # pairs where a waypoint's line is not the previous one's + 1 (1 pair for most files)
        if line_breaks < 0 or 2 * line_breaks > n_max:
            self._lines = _Paged("H", 2, n_max, z)
            self._breaks = None
        else:
            self._lines = None
            self._breaks = array("H", bytearray(4 * line_breaks))
        self._n_breaks = 0
        self._last_line = -1
        z = None
        n_starts = (n_max + (1 << _START_SHIFT) - 1) >> _START_SHIFT
        self._starts_m = array(_FLOAT_CODE, bytearray((8 if _FLOAT_CODE == "d" else 4) * n_starts))
        self.length_m = 0.0
        self._cache_i = [-1] * _LEG_CACHE
        self._cache_leg = [None] * _LEG_CACHE
        self.waypoints = _Seq(0, self.waypoint)
        self.legs = _Seq(0, self.leg)

    def append(self, lat_e7, lon_e7, speed_mmps, name_b, radius_cm, line_no):
        i = self.n
        self.lat_e7[i] = lat_e7
        self.lon_e7[i] = lon_e7
        self.speed_mmps[i] = speed_mmps
        if radius_cm:
            if self.radius_cm is None:  # only if the file changed between the passes
                raise TrackError(line_no, "the file changed while it was read")
            self.radius_cm[i] = radius_cm
        if self._lines is not None:
            self._lines[i] = line_no
        elif line_no != self._last_line + 1 or i == 0:
            k = 2 * self._n_breaks
            if k < len(self._breaks):
                self._breaks[k] = i
                self._breaks[k + 1] = line_no
                self._n_breaks += 1
            elif line_no:  # only if the file changed between the passes (the parser checks)
                raise TrackError(line_no, "the file changed while it was read")
        self._last_line = line_no
        if self.name_end is not None:
            k = 0 if i & (_PAGE - 1) == 0 else self._names_len
            if name_b:
                self._names[i >> _PAGE_SHIFT][k : k + len(name_b)] = name_b
                k += len(name_b)
            self._names_len = k
            self.name_end[i] = k
        elif name_b:
            raise TrackError(line_no, "the file changed while it was read")
        self.n = i + 1

    def finish(self):
        """Track distances of every 32nd waypoint; the sequence views."""
        n = self.n
        s = 0.0
        for i in range(n):
            if i & ((1 << _START_SHIFT) - 1) == 0:
                self._starts_m[i >> _START_SHIFT] = s
            if i + 1 < n:
                s += self.leg_length_m(i)
        self.length_m = s
        self.waypoints = _Seq(n, self.waypoint)
        self.legs = _Seq(n - 1 if n > 1 else 0, self.leg)

    def start_m(self, i):
        """Track distance from waypoint 0 to waypoint i (m): the same sum, in the same order, as
        the whole track's, from the previous leg if cached, else from the last kept distance."""
        slot = (i - 1) % _LEG_CACHE
        if i > 0 and self._cache_i[slot] == i - 1:
            prev = self._cache_leg[slot]
            return prev.start_m + prev.length_m
        s = self._starts_m[i >> _START_SHIFT]
        for j in range(i & ~((1 << _START_SHIFT) - 1), i):
            s += self.leg_length_m(j)
        return s

    def line_no(self, i):
        """Waypoint i's line in the file (0: not known, e.g. a track from a log)."""
        if self._lines is not None:
            return self._lines[i]
        b = self._breaks
        lo = 0
        hi = self._n_breaks
        while hi > lo:  # the last break at or before i
            mid = (lo + hi) >> 1
            if b[2 * mid] <= i:
                lo = mid + 1
            else:
                hi = mid
        if lo == 0:
            return 0
        return b[2 * lo - 1] + i - b[2 * lo - 2]

    # ---- waypoint fields
    def speed_mps(self, i):
        return self.speed_mmps[i] / 1000

    def radius_m(self, i):
        """Waypoint i's arrival radius (m) or None."""
        if self.radius_cm is None:
            return None
        r = self.radius_cm[i]
        return r / 100 if r else None

    def name_of(self, i):
        if self.name_end is None:
            return None
        a = self.name_end[i - 1] if i & (_PAGE - 1) else 0
        b = self.name_end[i]
        return self._names[i >> _PAGE_SHIFT][a:b].decode() if b > a else None

    def waypoint(self, i):
        return Waypoint(self.lat_e7[i], self.lon_e7[i], self.speed_mps(i), self.name_of(i),
                        self.radius_m(i), self.line_no(i))

    # ---- legs
    def leg_length_m(self, i):
        return geo.dist_bearing(self.lat_e7[i], self.lon_e7[i], self.lat_e7[i + 1], self.lon_e7[i + 1])[0]

    def leg(self, i):
        """Leg i (0 .. n-2), from the cache or computed."""
        slot = i % _LEG_CACHE
        if self._cache_i[slot] == i:
            return self._cache_leg[slot]
        lat = self.lat_e7
        lon = self.lon_e7
        d, brg = geo.dist_bearing(lat[i], lon[i], lat[i + 1], lon[i + 1])
        end_brg = geo.final_bearing_deg(lat[i], lon[i], lat[i + 1], lon[i + 1])
        leg = Leg(i, d, brg, end_brg, self.speed_mps(i))
        leg.start_m = self.start_m(i)
        leg.lat_e7 = lat[i]  # the start waypoint: the origin of the leg's frame
        leg.lon_e7 = lon[i]
        if i + 2 < self.n:
            brg_next = geo.dist_bearing(lat[i + 1], lon[i + 1], lat[i + 2], lon[i + 2])[1]
            leg.turn_deg = wrap180(brg_next - end_brg)
        self._cache_i[slot] = i
        self._cache_leg[slot] = leg
        return leg

    def duration_s(self):
        """Expected time to sail the legs at their speeds (no turns or accelerations)."""
        s = 0.0
        for i in range(self.n - 1):
            s += self.leg_length_m(i) / self.speed_mps(i)
        return s


def _blocks_b(n_bytes, block_b):
    """A heap allocation of n_bytes, rounded up to the GC's blocks (0 bytes: none)."""
    return (n_bytes + block_b - 1) // block_b * block_b


def _list_b(n_items, word_b, block_b):
    """A list grown by append to n_items: the object and its items (4, 8, 16 ... slots)."""
    cap = 4
    while cap < n_items:
        cap *= 2
    return block_b + _blocks_b(cap * word_b, block_b)


def _map_b(n_attrs, word_b, block_b):
    """An instance's attribute table: the smallest of MicroPython's hash sizes that holds them."""
    for size in (2, 4, 6, 8, 10, 12, 17, 23, 29, 37):
        if size >= n_attrs:
            return _blocks_b(size * 2 * word_b, block_b)
    return _blocks_b(n_attrs * 4 * word_b, block_b)


def _paged_b(item_b, n, word_b, block_b):
    """A _Paged array of n items: the instance, its table and list, a page array per 128."""
    full = n >> _PAGE_SHIFT
    rest = n & (_PAGE - 1)
    b = 2 * block_b + _map_b(1, word_b, block_b) + _list_b(full + (1 if rest else 0), word_b, block_b)
    b += full * (block_b + _blocks_b(item_b * _PAGE, block_b))
    if rest:
        b += block_b + _blocks_b(item_b * rest, block_b)
    return b


def track_heap_bytes(n, name_bytes=(), line_breaks=0, radii=False, word_b=4, float_b=4):
    """The heap (bytes) a Track of n waypoints takes once loaded and validated (with its leg
    cache full), by MicroPython's layout: objects of 4 words, allocations in blocks of 4 words,
    an array = an object + its items, lists grown by doubling, attribute tables in the hash
    sizes. name_bytes: the names' bytes per page of 128; line_breaks, radii: as _survey counts
    them. The defaults describe the ESP32 (32-bit words, single-precision floats): that is the
    figure TRACK_BUDGET_B limits, on every interpreter. Within 2 % of the measured allocation
    on the unix port and the 32-bit build (tests/host/test_track_budget.py)."""
    blk = 4 * word_b  # one GC block; an instance, an array object, a list object, a boxed float
    b = _paged_b(4, n, word_b, blk) * 2 + _paged_b(2, n, word_b, blk)  # lat, lon, speed
    if radii:
        b += _paged_b(2, n, word_b, blk)
    named = 0
    for k in name_bytes:
        named += k
    if named:
        b += _paged_b(2, n, word_b, blk) + _list_b(len(name_bytes), word_b, blk)
        for k in name_bytes:
            b += blk + _blocks_b(k, blk)
    if line_breaks < 0 or 2 * line_breaks > n:
        b += _paged_b(2, n, word_b, blk)
    else:
        b += blk + _blocks_b(4 * line_breaks, blk)
    b += blk + _blocks_b(float_b * ((n + (1 << _START_SHIFT) - 1) >> _START_SHIFT), blk)  # _starts_m
    b += 2 * blk + _map_b(19, word_b, blk)  # the Track, its 19 attributes, length_m
    b += 2 * (2 * blk + _map_b(2, word_b, blk))  # waypoints and legs: _Seq and bound method
    b += 2 * (blk + _blocks_b(_LEG_CACHE * word_b, blk))  # the cache's two lists
    legs = min(_LEG_CACHE, n - 1) if n > 1 else 0
    b += legs * (9 * blk + _map_b(11, word_b, blk))  # the cached legs: 11 attributes, 8 floats
    return b


def from_waypoints(waypoints, name=None):
    """A Track from waypoint objects (lat_e7, lon_e7, speed_mps, optional name, radius_m,
    line_no), e.g. a log's TRACK record; not validated."""
    names = [((getattr(w, "name", None) or "").encode()) for w in waypoints]
    per_page = [0] * ((len(names) + _PAGE - 1) // _PAGE)
    for i in range(len(names)):
        per_page[i >> _PAGE_SHIFT] += len(names[i])
    lines = 0
    radii = False
    for w in waypoints:
        lines = lines or getattr(w, "line_no", 0)
        radii = radii or getattr(w, "radius_m", None) is not None
    trk = Track(len(waypoints), name, per_page, -1 if lines else 0, radii)
    for w, nb in zip(waypoints, names):
        r = getattr(w, "radius_m", None)
        trk.append(w.lat_e7, w.lon_e7, _mm(w.speed_mps), nb, 0 if r is None else max(1, _cm(r)),
                   getattr(w, "line_no", 0))
    trk.finish()
    return trk


def _mm(v):
    return int(v * 1000 + 0.5)


def _cm(v):
    return int(v * 100 + 0.5)


def corner_deviation_m(turn_deg, radius_m):
    """Cross-track error at a corner sailed on a circle of radius_m tangent to both legs.

    The circle's centre lies on the bisector, R / cos(theta/2) from the corner; the arc's
    point nearest the corner is R (1/cos(theta/2) - 1) from the waypoint but only
    R (1 - cos(theta/2)) from each leg, which is what a cross-track error measures. So a
    90 deg corner costs 0.29 R, a 180 deg reversal on one waypoint R."""
    return radius_m * (1.0 - math.cos(math.radians(abs(turn_deg)) * 0.5))


def narrow_uturn(trk, leg, min_width_m, ahead=2000):
    """(k, width_m) of the first U-turn narrower than min_width_m with its first corner at waypoint
    k >= leg (at most `ahead` corners looked at); (0, 0.0) if none. A U-turn: the corners at k and
    k + 1 turn the same way, 150 deg or more together; its width is how far waypoint k + 1 lies
    from the line of the leg into k."""
    legs = trk.legs
    for k in range(max(1, leg), min(len(legs) - 1, leg + ahead)):
        a = legs[k - 1].turn_deg
        b = legs[k].turn_deg
        if a * b <= 0.0 or abs(a + b) < 150.0 or abs(a) >= 179.0 or abs(b) >= 179.0:
            continue
        w = legs[k].length_m * abs(math.sin(math.radians(a)))
        if w < min_width_m:
            return k, w
    return 0, 0.0


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


def _lines(src):
    """(line_no, raw line) of a str, bytes or a file opened in binary or text mode, one line at
    a time (never a list of all lines). A file is read with a line limit."""
    line_no = 0
    if isinstance(src, (str, bytes, bytearray)):
        nl = "\n" if isinstance(src, str) else b"\n"
        i = 0
        n = len(src)
        while i <= n:
            j = src.find(nl, i)
            if j < 0:
                j = n
            line_no += 1
            if j - i > MAX_LINE_BYTES:
                raise TrackError(line_no, "line longer than %d characters" % MAX_LINE_BYTES)
            yield line_no, src[i:j]
            i = j + 1
        return
    while True:
        raw = src.readline(MAX_LINE_BYTES + 1)
        if not raw:
            return
        line_no += 1
        if len(raw) > MAX_LINE_BYTES:
            raise TrackError(line_no, "line longer than %d characters" % MAX_LINE_BYTES)
        yield line_no, raw


def _clean(raw, line_no):
    """The line's text without comment, blanks and byte-order mark ('' for none)."""
    if not isinstance(raw, str):
        try:
            raw = bytes(raw).decode()
        except UnicodeError:
            raise TrackError(line_no, "the file is not UTF-8 text")
    hash_at = raw.find("#")
    line = (raw if hash_at < 0 else raw[:hash_at]).strip()
    if line.startswith("\ufeff"):  # a spreadsheet's byte-order mark
        line = line[1:].strip()
    return line


def _header(line, line_no):
    cols = [f.lower() for f in _split_fields(line)]
    for c in cols:
        if c not in COLUMNS:
            raise TrackError(line_no, "unknown column '%s' (known: %s)" % (c, ", ".join(COLUMNS)))
        if cols.count(c) > 1:
            raise TrackError(line_no, "column '%s' appears twice" % c)
    for c in ("lon", "lat", "speed_mps"):
        if c not in cols:
            raise TrackError(line_no, "header lacks the column '%s' (need lon, lat, speed_mps)" % c)
    return cols


def _rewind(src):
    if not isinstance(src, (str, bytes, bytearray)):
        src.seek(0)


def _survey(src, budget_b=TRACK_BUDGET_B):
    """First pass: (waypoint lines, bytes of their names per page, waypoints whose line is not the
    previous one's + 1, whether any has a radius), refusing more than MAX_WAYPOINTS, a name longer
    than MAX_NAME_CHARS, or a track whose heap on the ESP32 (track_heap_bytes) would pass
    budget_b, at the line where it does, before anything is allocated for them."""
    name_col = -1
    radius_col = -1
    n = 0
    name_bytes = []  # per page of _PAGE waypoints
    breaks = 0
    radii = False
    last_line = -1
    seen_header = False
    for line_no, raw in _lines(src):
        if line_no > MAX_LINES:
            raise TrackError(line_no, "more than %d lines" % MAX_LINES)
        line = _clean(raw, line_no)
        if not line:
            continue
        if not seen_header:
            cols = _header(line, line_no)
            name_col = cols.index("name") if "name" in cols else -1
            radius_col = cols.index("radius_m") if "radius_m" in cols else -1
            seen_header = True
            continue
        if n & (_PAGE - 1) == 0:
            name_bytes.append(0)
        n += 1
        if n > MAX_WAYPOINTS:
            raise TrackError(line_no, "more than %d waypoints: the most a track may have "
                             "(tracks/README.md)" % MAX_WAYPOINTS)
        if line_no != last_line + 1 or n == 1:
            breaks += 1
        last_line = line_no
        if name_col >= 0 or radius_col >= 0:
            fields = line.split(",")
            if 0 <= name_col < len(fields):
                wp_name = fields[name_col].strip()
                if len(wp_name) > MAX_NAME_CHARS:
                    raise TrackError(line_no, "name '%s' has %d characters: the most is %d (the "
                                     "display's width)" % (wp_name, len(wp_name), MAX_NAME_CHARS))
                name_bytes[-1] += len(wp_name.encode())
            if 0 <= radius_col < len(fields) and fields[radius_col].strip():
                radii = True
        heap_b = track_heap_bytes(n, name_bytes, breaks, radii)
        if heap_b > budget_b:
            raise TrackError(line_no, "the track up to here needs %d B of the board's memory, more "
                             "than the %d B a track may take (tracks/README.md): shorten the names "
                             "or split the track" % (heap_b, budget_b))
    return n, name_bytes, breaks, radii


def parse_track_csv(src, min_leg_m=MIN_LEG_M, max_speed_mps=MAX_SPEED_MPS, name=None, budget_b=TRACK_BUDGET_B):
    """Parse a track -> Track; raises TrackError(line_no, message).

    src: the CSV as str or bytes, or a file opened in binary mode (read twice, line by line:
    first to count the waypoints and refuse more than MAX_WAYPOINTS or a track whose heap would
    pass budget_b, then into arrays sized for them)."""
    n_max, name_bytes, breaks, radii = _survey(src, budget_b)
    _rewind(src)
    trk = Track(n_max, name, name_bytes, breaks, radii)
    cols = None
    header_line = 0
    prev_line = 0
    for line_no, raw in _lines(src):
        line = _clean(raw, line_no)
        if not line:
            continue
        if cols is None:
            cols = _header(line, line_no)
            header_line = line_no
            continue
        fields = _split_fields(line)
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
        radius_cm = 0
        if rec.get("radius_m", ""):
            radius = _num(rec["radius_m"], "radius_m", line_no)
            if not (0.0 < radius <= MAX_RADIUS_M):
                raise TrackError(line_no, "radius_m %s must be in (0, %d] m" % (rec["radius_m"], MAX_RADIUS_M))
            radius_cm = max(1, _cm(radius))
        k = trk.n
        if k and trk.lat_e7[k - 1] == lat and trk.lon_e7[k - 1] == lon:
            raise TrackError(line_no, "repeats the previous point (line %d)" % prev_line)
        if k >= n_max:  # the file changed under us between the passes
            raise TrackError(line_no, "the file changed while it was read")
        trk.append(lat, lon, _mm(spd), rec.get("name", "").encode(), radius_cm, line_no)
        prev_line = line_no
    if cols is None:
        raise TrackError(1, "no header line (lon, lat, speed_mps ...) and no waypoints")
    n = trk.n
    if n < 2:
        raise TrackError(trk.line_no(n - 1) if n else header_line,
                         "a track needs at least 2 waypoints, found %d" % n)
    for i in range(n - 1):
        if trk.speed_mmps[i] == 0:
            raise TrackError(trk.line_no(i), "speed_mps 0 on a waypoint that starts a leg (only the "
                             "last waypoint may have speed 0)")
    for i in range(n - 1):
        d = trk.leg_length_m(i)
        if d < min_leg_m:
            raise TrackError(trk.line_no(i + 1), "leg from line %d is %.1f m long; legs shorter "
                             "than %.1f m cannot be steered" % (trk.line_no(i), d, min_leg_m))
    trk.finish()
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
    k = 1
    while True:
        k, w = narrow_uturn(trk, k, 2.0 * r)
        if not k:
            break
        warnings.append("%s: U-turn %.1f m wide, narrower than the boat turns (2 x %.1f m); expect "
                        "it to swing about %.1f m past the leg back" % (wps[k].label(k), w, r, 2.0 * r - w))
        k += 1
    return warnings


def track_id(src):
    """Short id of a track file's content: its CRC-32 (as zlib.crc32) in 8 hex digits, to match
    saved state and logs with the file. src: str, bytes or a binary file (read in 256 B chunks
    from where it is). binascii when the build has it, else a bitwise loop (a one-off per load)."""
    if isinstance(src, str):
        src = src.encode()
    if isinstance(src, (bytes, bytearray)):
        return "%08x" % _crc32(src, 0)
    crc = 0
    while True:
        chunk = src.read(256)
        if not chunk:
            return "%08x" % crc
        crc = _crc32(chunk, crc)


def _crc32(data, crc):
    try:
        import binascii

        return binascii.crc32(data, crc) & 0xFFFFFFFF
    except (ImportError, AttributeError):
        crc ^= 0xFFFFFFFF
        for b in data:
            crc ^= b
            for _ in range(8):
                crc = (crc >> 1) ^ (0xEDB88320 if crc & 1 else 0)
        return crc ^ 0xFFFFFFFF


def load_file(path, min_leg_m=MIN_LEG_M):
    """(Track, track id) of a track file, parsed line by line; raises TrackError, OSError (and
    MemoryError when even a valid track does not fit)."""
    with open(path, "rb") as f:
        trk = parse_track_csv(f, min_leg_m=min_leg_m)
        f.seek(0)
        return trk, track_id(f)


def leg_table(trk):
    """Rows (i, from_label, length_m, bearing_deg, turn_deg at its end, speed_mps) for printing."""
    rows = []
    for leg in trk.legs:
        rows.append((leg.i, trk.waypoints[leg.i].name or "", leg.length_m, leg.bearing_deg,
                     leg.turn_deg, leg.speed_mps))
    return rows
