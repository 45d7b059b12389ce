"""SeaTalk1 datagram codec, the 9th-bit parity rule, and a receive framer for 8-bit data.

Pure functions and one small framer object: bytes and t_ms in, datagrams and dicts out; no I/O.

Facts and sources: docs/SEATALK.md (Knauf's SeaTalk reference, dotnet/iot's Seatalk1 binding,
AK-Homberger's remote). A datagram is `CMD ATTR data...`, 3 + (ATTR & 0x0F) bytes long.

Usage:
    from trackpilot.devices import seatalk as st
    st.parity_for(0x86, True)            # -> "E": write the command byte with even parity
    dg = st.encode_86(st.KEY_PLUS_1, sender=1)           # b'\\x86\\x11\\x07\\xf8'
    d = st.decode(b'\\x84\\x86\\x26\\x97\\x02\\x00\\x00\\x00\\x08')
    d["heading_deg"], d["course_deg"], d["mode"]           # 76, 75.5, "auto"
    fr = st.Framer()                       # 8-bit receive: length nibble, known table, idle gaps
    for b in data: 
        if fr.feed(b, t_ms): dg = fr.pop()

Odd-degree rule (the sources disagree, so it is a setting, `odd_rule`):
    ODD_DOTNET (default; dotnet/iot, tested on a real ST2000+): U & 4 adds 1 degree, U & 8 means
        turning to starboard and adds nothing.
    ODD_KNAUF (Knauf's text): add the number of bits set in U & 0xC (0, 1 or 2).
"""
from trackpilot.compat import const, ticks_diff

# datagram types handled by the codec
ST_WIND_ANGLE = const(0x10)
ST_WIND_SPEED = const(0x11)
ST_AP_STATUS = const(0x84)  # compass heading, locked course, mode, rudder
ST_NAV_WP = const(0x85)
ST_KEY = const(0x86)
ST_ST40_HEADING = const(0x89)
ST_AP_STATUS_SET = const(0x95)  # same layout as 0x84, sent while the pilot is in a setting mode
ST_VARIATION = const(0x99)
ST_HEADING_RUDDER = const(0x9C)

ODD_DOTNET = const(0)
ODD_KNAUF = const(1)

MAX_LEN = const(18)  # 3 + 15

# keystroke codes (0x86 YY), PROTOCOLS.md / Knauf
KEY_AUTO = const(0x01)
KEY_STANDBY = const(0x02)
KEY_TRACK = const(0x03)
KEY_DISP = const(0x04)
KEY_MINUS_1 = const(0x05)
KEY_MINUS_10 = const(0x06)
KEY_PLUS_1 = const(0x07)
KEY_PLUS_10 = const(0x08)
KEY_STANDBY_AUTO = const(0x23)  # wind (vane) mode
KEY_NAMES = {
    0x01: "auto", 0x02: "standby", 0x03: "track", 0x04: "disp", 0x05: "-1", 0x06: "-10",
    0x07: "+1", 0x08: "+10", 0x23: "standby+auto",
    0x41: "auto_held", 0x42: "standby_held", 0x43: "track_held", 0x44: "disp_held",
    0x45: "-1_held", 0x46: "-10_held", 0x47: "+1_held", 0x48: "+10_held",
    0x63: "standby+auto_held", 0x80: "repeat", 0x81: "repeat", 0x82: "repeat", 0x83: "repeat",
    0x84: "released",
}
KEY_DELTA_DEG = {KEY_MINUS_1: -1, KEY_MINUS_10: -10, KEY_PLUS_1: 1, KEY_PLUS_10: 10}

# pilot modes (0x84 byte 4, "Z"); dotnet/iot's table: 0 standby, 2 auto, 4/6 wind, 8/0A track,
# 0x10 calibration
MODE_STANDBY = const(0)
MODE_AUTO = const(1)
MODE_WIND = const(2)
MODE_TRACK = const(3)
MODE_CAL = const(4)
MODE_UNKNOWN = const(5)
MODE_NAMES = ("standby", "auto", "wind", "track", "calibration", "unknown")
_MODE_OF_Z = {0x00: MODE_STANDBY, 0x02: MODE_AUTO, 0x04: MODE_WIND, 0x06: MODE_WIND,
              0x08: MODE_TRACK, 0x0A: MODE_TRACK, 0x10: MODE_CAL}
_Z_OF_MODE = (0x00, 0x02, 0x06, 0x0A, 0x10)

# Known datagram types for framing 8-bit data: cmd -> (attr mask, attr value). Any other type is
# framed by its length nibble alone and reported as unknown. From Knauf's table.
KNOWN = {
    0x00: (0xFF, 0x02), 0x10: (0xFF, 0x01), 0x11: (0xFF, 0x01), 0x20: (0xFF, 0x01),
    0x26: (0xFF, 0x04), 0x27: (0xFF, 0x01), 0x30: (0xFF, 0x00), 0x50: (0x0F, 0x02),
    0x51: (0x0F, 0x02), 0x52: (0xFF, 0x01), 0x53: (0x0F, 0x00), 0x54: (0x0F, 0x01),
    0x56: (0x0F, 0x01), 0x58: (0x0F, 0x05), 0x82: (0xFF, 0x05), 0x84: (0x0F, 0x06),
    0x85: (0x0F, 0x06), 0x86: (0x0F, 0x01), 0x87: (0xFF, 0x00), 0x89: (0x0F, 0x02),
    0x90: (0xFF, 0x00), 0x95: (0x0F, 0x06), 0x99: (0xFF, 0x00), 0x9C: (0x0F, 0x01),
    0xA8: (0x0F, 0x03),
}


def length_of(attr):
    """Datagram length in bytes from its attribute byte."""
    return 3 + (attr & 0x0F)


def _ones(b):
    n = 0
    while b:
        b &= b - 1
        n += 1
    return n


def parity_for(byte, is_command):
    """UART parity ("E" or "O") that transmits `is_command` as the 9th bit after `byte`."""
    odd_ones = _ones(byte & 0xFF) & 1
    if is_command:
        return "E" if odd_ones else "O"
    return "O" if odd_ones else "E"


def command_bit(byte, parity):
    """The 9th bit a byte carried when written with UART parity "E"/"O" (for the simulator)."""
    odd_ones = _ones(byte & 0xFF) & 1
    if parity == "E" or parity == 0x45:
        return odd_ones
    if parity == "O" or parity == 0x4F:
        return 1 - odd_ones
    raise ValueError("parity must be E or O, got %r" % (parity,))


def plausible(dg, n=None):
    """True if a complete datagram passes the checks its type allows (length, attr, complements,
    status fields). Used by the framer to reject mis-framed 8-bit data."""
    if n is None:
        n = len(dg)
    if n < 3 or n != length_of(dg[1]):
        return False
    cmd = dg[0]
    k = KNOWN.get(cmd)
    if k is not None and (dg[1] & k[0]) != k[1]:
        return False
    if cmd == 0x86:
        return (dg[2] ^ dg[3]) == 0xFF
    if cmd == 0x84 or cmd == 0x95:
        return dg[4] in _MODE_OF_Z and (dg[5] & 0xF0) == 0 and (dg[8] & 0xF0) == 0
    if cmd == 0x85:
        return (dg[6] ^ dg[8]) == 0xFF
    if cmd == 0x82:
        return (dg[2] ^ dg[3]) == 0xFF and (dg[4] ^ dg[5]) == 0xFF and (dg[6] ^ dg[7]) == 0xFF
    return True


# ---- headings -----------------------------------------------------------------------------------


def heading_of(u, vw, odd_rule=ODD_DOTNET):
    """Compass heading (int degrees 0..359) from the U nibble and the VW byte of 0x84/0x9C."""
    h = (u & 3) * 90 + (vw & 0x3F) * 2
    if odd_rule == ODD_KNAUF:
        h += ((u >> 2) & 1) + ((u >> 3) & 1)
    else:
        h += (u >> 2) & 1
    return h % 360


def _heading_bits(heading_deg, turning_stbd, odd_rule):
    """(U nibble, VW low 6 bits) for an integer heading, the inverse of heading_of."""
    h = int(heading_deg) % 360
    turn = 8 if turning_stbd else 0
    if odd_rule == ODD_KNAUF:
        if turning_stbd:
            # bit 8 adds one degree under this rule: an even heading needs both bits on h - 2
            if h & 1:
                h -= 1
                extra = 8
            else:
                h = (h - 2) % 360
                extra = 0xC
        else:
            extra = 4 if h & 1 else 0
            h -= h & 1
    else:
        extra = turn | (4 if h & 1 else 0)
        h -= h & 1
    q = h // 90
    return (q | extra), ((h - q * 90) >> 1)


def _course_bits(course_deg):
    """(VW high 2 bits, XY) for a course in 0.5 degree steps."""
    x2 = int(course_deg * 2.0 + 0.5) % 720
    q = x2 // 180
    return q << 6, x2 - q * 180


def _s8(b):
    return b - 256 if b > 127 else b


def _u8(v, what):
    v = int(v)
    if v < -128 or v > 127:
        raise ValueError("%s %d outside -128..127" % (what, v))
    return v & 0xFF


# ---- encoders (bytes out) ------------------------------------------------------------------------


def encode_84(heading_deg, course_deg, mode=MODE_STANDBY, rudder_deg=0, turning_stbd=False,
              alarms=0, display=0, pilot_type=8, odd_rule=ODD_DOTNET, cmd=0x84):
    """Autopilot status 0x84 (or 0x95 with cmd=0x95). mode: MODE_* ; alarms: M nibble (4 off
    course, 8 wind shift); rudder in whole degrees, + = steer right."""
    if mode < 0 or mode >= MODE_UNKNOWN:
        raise ValueError("bad mode %r" % (mode,))
    u, vw = _heading_bits(heading_deg, turning_stbd, odd_rule)
    hi, xy = _course_bits(course_deg)
    return bytes((cmd, (u << 4) | 6, vw | hi, xy, _Z_OF_MODE[mode], alarms & 0x0F,
                  _u8(rudder_deg, "rudder"), display & 0xFF, pilot_type & 0x0F))


def encode_9c(heading_deg, rudder_deg=0, turning_stbd=False, odd_rule=ODD_DOTNET):
    """Compass heading and rudder 0x9C."""
    u, vw = _heading_bits(heading_deg, turning_stbd, odd_rule)
    return bytes((0x9C, (u << 4) | 1, vw, _u8(rudder_deg, "rudder")))


def encode_86(key, sender=1):
    """Keystroke 0x86 from `sender` (0 the pilot itself, 1 remote, 2 ST4000+/ST600R)."""
    if key < 0 or key > 255 or sender < 0 or sender > 15:
        raise ValueError("bad key %r or sender %r" % (key, sender))
    return bytes((0x86, (sender << 4) | 1, key, key ^ 0xFF))


def encode_89(heading_deg):
    """ST40 compass heading 0x89 (Knauf: (U & 0xC) / 8 is the odd degree, so U = 8 when odd)."""
    h = int(heading_deg) % 360
    odd = h & 1
    h -= odd
    q = h // 90
    return bytes((0x89, ((q | (8 if odd else 0)) << 4) | 2, (h - q * 90) >> 1, 0x00, 0x20))


def encode_99(variation_deg):
    """Compass variation 0x99, signed degrees (Knauf: + West, - East)."""
    return bytes((0x99, 0x00, _u8(variation_deg, "variation")))


def encode_10(angle_deg):
    """Apparent wind angle 0x10 in 0.5 degree steps (0..359.5, relative to the bow)."""
    x2 = int(angle_deg * 2.0 + 0.5) % 720
    return bytes((0x10, 0x01, x2 >> 8, x2 & 0xFF))


def encode_11(speed_kn):
    """Apparent wind speed 0x11, 0..127.9 kn in 0.1 kn."""
    t = int(speed_kn * 10.0 + 0.5)
    if t < 0 or t > 1279:
        raise ValueError("wind speed %r kn outside 0..127.9" % (speed_kn,))
    return bytes((0x11, 0x01, t // 10, t % 10))


def encode_85(xte_nm=None, bearing_deg=None, bearing_true=True, dist_nm=None):
    """Navigation to waypoint 0x85 (dotnet/iot layout). xte_nm + = right of track (steer left);
    any field None = not present."""
    b = bytearray(9)
    b[0] = 0x85
    b[1] = 0x06
    flags = 0
    if xte_nm is not None:
        v = int(abs(xte_nm) * 100.0 + 0.5)
        if v > 0xFFF:
            v = 0xFFF
        b[1] = ((v & 0xF) << 4) | 6
        b[2] = v >> 4
        if xte_nm < 0:
            b[6] |= 0x40  # steer right to correct
        flags |= 1
        if abs(xte_nm) >= 0.3:
            flags |= 8
    if bearing_deg is not None:
        x2 = int(bearing_deg * 2.0 + 0.5) % 720
        q = x2 // 180
        r = x2 - q * 180
        b[3] = q | (8 if bearing_true else 0) | ((r & 0xF) << 4)
        b[4] = r >> 4
        flags |= 2
    if dist_nm is not None:
        if dist_nm <= 9.9:
            d = int(dist_nm * 100.0 + 0.5)
            b[6] |= 0x10
        else:
            d = int(dist_nm * 10.0 + 0.5)
        if d > 0xFFF:
            d = 0xFFF
        b[4] |= (d & 0xF) << 4
        b[5] = d >> 4
        flags |= 4
    b[6] |= flags
    b[8] = b[6] ^ 0xFF
    return bytes(b)


# ---- decoder (dict out) --------------------------------------------------------------------------


def decode(dg, odd_rule=ODD_DOTNET):
    """Decode one complete datagram into a dict with "cmd" (int), "name" and its fields.
    Types the codec does not decode give name "not_decoded"; a malformed one raises ValueError."""
    n = len(dg)
    if n < 3 or n != length_of(dg[1]):
        raise ValueError("datagram length %d does not match its attribute byte" % n)
    cmd = dg[0]
    k = KNOWN.get(cmd)
    if k is not None and (dg[1] & k[0]) != k[1]:
        raise ValueError("attribute %02x is wrong for type %02x" % (dg[1], cmd))
    if cmd == 0x84 or cmd == 0x95:
        u = dg[1] >> 4
        vw = dg[2]
        z = dg[4]
        return {
            "cmd": cmd, "name": "ap_status" if cmd == 0x84 else "ap_status_setting",
            "heading_deg": heading_of(u, vw, odd_rule), "turning_stbd": bool(u & 8),
            "course_deg": (vw >> 6) * 90 + dg[3] / 2,
            "mode": _MODE_OF_Z.get(z, MODE_UNKNOWN), "mode_raw": z,
            "off_course": bool(dg[5] & 4), "wind_shift": bool(dg[5] & 8),
            "rudder_deg": _s8(dg[6]), "display": dg[7], "pilot_type": dg[8],
        }
    if cmd == 0x9C:
        u = dg[1] >> 4
        return {"cmd": cmd, "name": "heading_rudder", "heading_deg": heading_of(u, dg[2], odd_rule),
                "turning_stbd": bool(u & 8), "rudder_deg": _s8(dg[3])}
    if cmd == 0x86:
        if (dg[2] ^ dg[3]) != 0xFF:
            raise ValueError("keystroke check byte %02x is not ~%02x" % (dg[3], dg[2]))
        return {"cmd": cmd, "name": "keystroke", "sender": dg[1] >> 4, "key": dg[2],
                "key_name": KEY_NAMES.get(dg[2], "key_%02x" % dg[2])}
    if cmd == 0x89:
        u = dg[1] >> 4
        return {"cmd": cmd, "name": "st40_heading",
                "heading_deg": ((u & 3) * 90 + (dg[2] & 0x3F) * 2 + ((u & 0xC) >> 3)) % 360}
    if cmd == 0x99:
        return {"cmd": cmd, "name": "variation", "variation_deg": _s8(dg[2])}
    if cmd == 0x10:
        return {"cmd": cmd, "name": "wind_angle", "angle_deg": ((dg[2] << 8) | dg[3]) / 2}
    if cmd == 0x11:
        return {"cmd": cmd, "name": "wind_speed", "speed_kn_x10": (dg[2] & 0x7F) * 10 + (dg[3] & 0x0F),
                "speed_kn": (dg[2] & 0x7F) + (dg[3] & 0x0F) / 10}
    if cmd == 0x85:
        if (dg[6] ^ dg[8]) != 0xFF:
            raise ValueError("0x85 check byte %02x is not ~%02x" % (dg[8], dg[6]))
        f = dg[6]
        out = {"cmd": cmd, "name": "nav_to_waypoint", "xte_nm": None, "bearing_deg": None,
               "bearing_true": bool(dg[3] & 8), "dist_nm": None, "xte_large": bool(f & 8)}
        if f & 1:
            v = (dg[1] >> 4) | (dg[2] << 4)
            out["xte_nm"] = (-v if f & 0x40 else v) / 100
        if f & 2:
            out["bearing_deg"] = (dg[3] & 3) * 90 + (((dg[4] & 0xF) << 4) | (dg[3] >> 4)) / 2
        if f & 4:
            d = (dg[5] << 4) | (dg[4] >> 4)
            out["dist_nm"] = d / 100 if f & 0x10 else d / 10
        return out
    return {"cmd": cmd, "name": "not_decoded"}


# ---- receive framer for 8-bit data ----------------------------------------------------------------

_WORK = const(40)


class Framer:
    """Frames datagrams out of 8-bit bus data (no 9th bit), one byte at a time.

    Rules, in order: an idle gap longer than `gap_ms` between two bytes ends any partial datagram
    (it is dropped; gap_ms=0 turns this off for untimed captures); a partial datagram whose first
    byte is a known type with the wrong attribute, or a complete one that fails `plausible`, loses
    its first byte and the rest is scanned again, so the framer finds the next real start; unknown
    types are framed by their length nibble, but only while the framer is in sync (after an idle
    gap, a reset or a datagram that passed): after a rejected byte only a known type can start a
    datagram, so garbage cannot be taken for a long unknown datagram that swallows good ones, and
    an unknown-type datagram that contains a known type's command and attribute bytes is dropped in
    favour of the known one (accept_unknown=False never accepts unknown types).
    Completed datagrams wait in a bounded queue (`depth`); when it is full the oldest is dropped
    and counted. Nothing grows: the buffers are allocated here once.
    """

    def __init__(self, gap_ms=5, accept_unknown=True, depth=4):
        self.gap_ms = gap_ms
        self.accept_unknown = accept_unknown
        self._buf = bytearray(MAX_LEN)
        self._n = 0
        self._work = bytearray(_WORK)
        self._last_t = None
        self._q = [bytearray(MAX_LEN) for _ in range(depth)]
        self._ql = [0] * depth
        self._qt = [0] * depth
        self._qhead = 0
        self._qn = 0
        self._t = 0
        self._synced = True
        # counters (for the log and the HMI)
        self.datagrams = 0
        self.unknown = 0
        self.dropped_bytes = 0  # bytes skipped while searching for a start
        self.dropped_gap = 0  # partial datagrams ended by an idle gap
        self.queue_overflow = 0

    def reset(self):
        """Forget any partial datagram (the link calls this around its own transmissions)."""
        self.dropped_bytes += self._n
        self._n = 0
        self._synced = True

    def pending(self):
        return self._qn

    def pop(self):
        """The oldest framed datagram as bytes, or None."""
        if not self._qn:
            return None
        i = self._qhead
        self._qhead = (i + 1) % len(self._q)
        self._qn -= 1
        return bytes(self._q[i][: self._ql[i]])

    def pop_t(self):
        """Arrival time (t_ms of the last byte) of the datagram pop() will return next."""
        return self._qt[self._qhead] if self._qn else None

    def feed(self, b, t_ms):
        """One received byte. Returns the number of datagrams waiting in the queue."""
        if self._n and self.gap_ms and ticks_diff(t_ms, self._last_t) > self.gap_ms:
            self.dropped_gap += 1
            self.dropped_bytes += self._n
            self._n = 0
        if self.gap_ms and self._last_t is not None and ticks_diff(t_ms, self._last_t) > self.gap_ms:
            self._synced = True
        self._last_t = t_ms
        self._t = t_ms
        work = self._work
        work[0] = b
        wn = 1
        wi = 0
        while wi < wn:
            r = self._step(work[wi])
            wi += 1
            if r:
                # drop the first byte of the partial datagram, rescan the rest before the
                # remaining work (never more than MAX_LEN + MAX_LEN bytes)
                buf = self._buf
                k = self._n - 1
                rest = wn - wi
                if k > wi:  # move the remaining work, in the direction that keeps the source
                    for j in range(rest - 1, -1, -1):
                        work[k + j] = work[wi + j]
                elif k < wi:
                    for j in range(rest):
                        work[k + j] = work[wi + j]
                for j in range(k):
                    work[j] = buf[1 + j]
                wi = 0
                wn = k + rest
                self._n = 0
                self._synced = False
                self.dropped_bytes += 1
        return self._qn

    def _step(self, b):
        # returns True when the partial datagram must be rescanned without its first byte
        buf = self._buf
        n = self._n
        if n == 0:
            if b not in KNOWN and not (self.accept_unknown and self._synced):
                self.dropped_bytes += 1
                return False
            buf[0] = b
            self._n = 1
            return False
        if n == 1:
            k = KNOWN.get(buf[0])
            if k is not None and (b & k[0]) != k[1]:
                buf[1] = b
                self._n = 2
                return True
        buf[n] = b
        n += 1
        self._n = n
        if n >= 3 and n == 3 + (buf[1] & 0x0F):
            if not plausible(buf, n):
                return True
            if buf[0] not in KNOWN:
                # an unknown type that hides the start of a known one: prefer the known one
                for p in range(1, n - 1):
                    k = KNOWN.get(buf[p])
                    if k is not None and (buf[p + 1] & k[0]) == k[1]:
                        return True
            self._emit(n)
            self._n = 0
            self._synced = True
        return False

    def _emit(self, n):
        depth = len(self._q)
        if self._qn == depth:
            self._qhead = (self._qhead + 1) % depth
            self._qn -= 1
            self.queue_overflow += 1
        i = (self._qhead + self._qn) % depth
        q = self._q[i]
        buf = self._buf
        for j in range(n):  # a loop, not a slice: no allocation on the receive path
            q[j] = buf[j]
        self._ql[i] = n
        self._qt[i] = self._t
        self._qn += 1
        self.datagrams += 1
        if self._buf[0] not in KNOWN:
            self.unknown += 1


# ---- text forms that keep the 9th bit -----------------------------------------------------------


def stalk_checksum(body):
    """XOR of the characters of `body` (the text between '$' and '*')."""
    c = 0
    for ch in body:
        c ^= ord(ch)
    return c


def to_stalk(dg):
    """`$STALK,84,86,...*hh` (the NMEA 0183 wrapper SeaTalk-NMEA bridges use)."""
    body = "STALK," + ",".join("%02X" % x for x in dg)
    return "$%s*%02X" % (body, stalk_checksum(body))


def parse_stalk(line):
    """Datagram bytes from a `$STALK,...` line; raises ValueError on a bad checksum or hex."""
    line = line.strip()
    if not line.startswith("$STALK,"):
        raise ValueError("not a $STALK line")
    star = line.find("*")
    body = line[1:star] if star >= 0 else line[1:]
    if star >= 0:
        want = int(line[star + 1 : star + 3], 16)
        if stalk_checksum(body) != want:
            raise ValueError("$STALK checksum %02X, expected %02X" % (want, stalk_checksum(body)))
    return bytes(int(x, 16) for x in body.split(",")[1:])


def to_9bit_text(dg):
    """Per-byte form: `c84 86 26 ...`; a leading `c` marks the byte sent with the command bit."""
    return " ".join(("c%02x" if i == 0 else "%02x") % x for i, x in enumerate(dg))
