"""The trackpilot log format: compact, append-only, self-describing, every record CRC-checked.

Pure code (no I/O, no clock): the encoder turns records into bytes, the decoder turns bytes
(a whole file, a cut one, a damaged one) back into records plus reports of the damage.
The full byte layout is in docs/LOG_FORMAT.md.

Frame:  tag u8 (0xB0 | type) | length varint | payload | CRC-16/CCITT-FALSE u16 LE
        (the CRC covers tag, length and payload)
Types:  HEADER (field table, firmware, config hash, track id, reset cause, start time),
        KEY (control record, absolute values), DELTA (control record, changed fields only,
        coded against the previous control record), EVENT (t_ms, kind, text), TRACK (waypoints).

Usage:
    enc = LogEncoder(key_every=25)
    f.write(enc.header(fw_version="0.1", config_hash="a1b2", track_id="loop",
                       reset_cause="power_on", t0_ms=t_ms, session=1, part=0))
    f.write(enc.encode_track(track.waypoints))
    rec = ControlRecord(); rec.t_ms = t_ms; rec.lat_e7 = fix.lat_e7; ...
    f.write(enc.encode_control(rec))          # a memoryview into the encoder's buffer
    f.write(enc.encode_event("MODE", "STANDBY->AUTO: HMI", t_ms))
    for r in iter_records(data):               # r.type: header/control/event/track/damage
        ...
"""
from array import array

from trackpilot.compat import const, ticks_diff

FORMAT_VERSION = const(1)
MAGIC = b"TPL"

T_HEADER = const(0)
T_KEY = const(1)
T_DELTA = const(2)
T_EVENT = const(3)
T_TRACK = const(4)
_N_TYPES = const(5)
_TAG_BASE = const(0xB0)
MAX_PAYLOAD = const(2047)  # longer frames are refused: keeps a false sync on garbage cheap
_MAX_TEXT = const(200)  # event text bytes kept (longer text is cut)
_TRACK_CHUNK = const(700)  # payload bytes per TRACK record

# Coding of a control field in DELTA records: against the previous value (D1), against a linear
# prediction from the two previous values (D2: steady ramps such as time cost nothing), or the
# value itself (D0: noise-like small numbers such as the 1e-9 deg position parts).
D0 = "d0"
D1 = "d1"
D2 = "d2"

# The control record's fields: (attribute name, scale (stored int = value * scale), unit,
# coding, modulus (0: none; angles and ticks wrap)). "flags" packs pos_valid (bit 0),
# heading_valid (bit 1), vel_valid (bit 2) and rtk (bits 3-4).
# Adding a field: append it here (old logs still decode: the decoder reads each file's own table).
FIELDS = (
    ("t_ms", 1, "ms", D2, 1 << 30),  # ticks_ms domain of the control step (wraps at 2^30)
    ("itow_ms", 1, "ms", D2, 604800000),  # GPS time of week of the epoch, -1 unknown
    ("lat_e7", 1, "1e-7deg", D2, 0),
    ("lat_hp", 1, "1e-9deg", D0, 0),
    ("lon_e7", 1, "1e-7deg", D2, 0),
    ("lon_hp", 1, "1e-9deg", D0, 0),
    ("flags", 1, "bits", D1, 0),
    ("num_sv", 1, "", D1, 0),
    ("h_acc_m", 1000, "m", D1, 0),
    ("heading_deg", 100, "deg", D1, 36000),
    ("heading_acc_deg", 100, "deg", D1, 0),
    ("sog_mps", 1000, "m/s", D1, 0),
    ("cog_deg", 100, "deg", D1, 36000),
    ("corr_age_s", 10, "s", D2, 0),  # age of the RTK corrections
    ("leg", 1, "", D1, 0),
    ("xte_m", 100, "m", D1, 0),
    ("path_xte_m", 100, "m", D1, 0),  # against the path the guidance planned (rounded corners)
    ("heading_cmd_deg", 100, "deg", D1, 36000),
    ("speed_cmd_mps", 1000, "m/s", D1, 0),
    ("pilot_mode", 1, "", D1, 0),
    ("compass_deg", 10, "deg", D1, 3600),
    ("locked_deg", 10, "deg", D1, 3600),
    ("rudder_deg", 10, "deg", D1, 0),
    ("keys_sent", 1, "", D1, 0),  # cumulative count of keystrokes sent to the pilot
    ("keys_net_deg", 1, "deg", D1, 0),  # cumulative signed course change sent by keystrokes
    ("rpm_set", 1, "rpm", D1, 0),
    ("rpm", 1, "rpm", D1, 0),
    ("battery_v", 100, "V", D1, 0),
    ("wind_angle_deg", 10, "deg", D1, 3600),
    ("wind_speed_mps", 100, "m/s", D1, 0),
    ("alarms", 1, "bits", D1, 0),
    ("mode", 1, "", D1, 0),
    ("guided", 1, "", D1, 0),  # 1: the guidance law ran in this step (replay reruns exactly these)
    ("compass_age_ms", 1, "ms", D0, 0),  # since the pilot's compass/rudder were received, -1 never
)


class ControlRecord:
    """One control step (one GNSS epoch). The application fills it; the decoder gives it back.

    Attributes (stored resolution in brackets; see FIELDS):
      t_ms (1 ms ticks), itow_ms (1 ms), pos_valid, lat_e7, lat_hp, lon_e7, lon_hp (exact ints),
      rtk (fix.RTK_*), num_sv, h_acc_m (1 mm), heading_valid, heading_deg (0.01),
      heading_acc_deg (0.01), vel_valid, sog_mps (1 mm/s), cog_deg (0.01), corr_age_s (0.1),
      leg, xte_m (1 cm), path_xte_m (1 cm), heading_cmd_deg (0.01), speed_cmd_mps (1 mm/s), pilot_mode,
      compass_deg (0.1), locked_deg (0.1), rudder_deg (0.1), keys_sent, keys_net_deg (cumulative),
      rpm_set, rpm, battery_v (0.01), wind_angle_deg (0.1), wind_speed_mps (0.01), alarms, mode,
      guided (1 when the guidance law ran in this step).
    Decoded records also carry `key` (True for an absolute record) and `offset` (byte offset).
    """

    type = "control"

    def __init__(self):
        self.t_ms = 0
        self.itow_ms = -1
        self.pos_valid = False
        self.lat_e7 = 0
        self.lat_hp = 0
        self.lon_e7 = 0
        self.lon_hp = 0
        self.rtk = 0
        self.num_sv = 0
        self.h_acc_m = 0.0
        self.heading_valid = False
        self.heading_deg = 0.0
        self.heading_acc_deg = 0.0
        self.vel_valid = False
        self.sog_mps = 0.0
        self.cog_deg = 0.0
        self.corr_age_s = 0.0
        self.leg = 0
        self.xte_m = 0.0
        self.path_xte_m = 0.0
        self.heading_cmd_deg = 0.0
        self.speed_cmd_mps = 0.0
        self.pilot_mode = 0
        self.compass_deg = 0.0
        self.locked_deg = 0.0
        self.rudder_deg = 0.0
        self.keys_sent = 0
        self.keys_net_deg = 0
        self.rpm_set = 0
        self.rpm = 0
        self.battery_v = 0.0
        self.wind_angle_deg = 0.0
        self.wind_speed_mps = 0.0
        self.alarms = 0
        self.mode = 0
        self.guided = 0
        self.compass_age_ms = -1
        self.key = False
        self.offset = -1

    def fill_fix(self, fix):
        """Copy the GNSS epoch's fields from a fix.Fix (t_ms, itow_ms, position, rtk, num_sv,
        h_acc_m, heading, heading_acc_deg, velocity)."""
        self.t_ms = fix.t_ms
        self.itow_ms = fix.itow_ms
        self.pos_valid = fix.pos_valid
        self.lat_e7 = fix.lat_e7
        self.lat_hp = fix.lat_hp
        self.lon_e7 = fix.lon_e7
        self.lon_hp = fix.lon_hp
        self.rtk = fix.rtk
        self.num_sv = fix.num_sv
        self.h_acc_m = fix.h_acc_m
        self.heading_valid = fix.heading_valid
        self.heading_deg = fix.heading_deg
        self.heading_acc_deg = fix.heading_acc_deg
        self.vel_valid = fix.vel_valid
        self.sog_mps = fix.sog_mps
        self.cog_deg = fix.cog_deg


class Header:
    type = "header"

    def __init__(self):
        self.version = 0
        self.info = {}  # every key=value line of the header (strings)
        self.fields = ()  # ((name, scale, unit, coding, modulus), ...)
        self.offset = -1

    def get(self, key, default=""):
        return self.info.get(key, default)


class Event:
    type = "event"

    def __init__(self, t_ms, kind, text, offset=-1):
        self.t_ms = t_ms
        self.kind = kind
        self.text = text
        self.offset = offset


class LogWaypoint:
    def __init__(self, lat_e7, lon_e7, speed_mps, name, radius_m):
        self.lat_e7 = lat_e7
        self.lon_e7 = lon_e7
        self.speed_mps = speed_mps
        self.name = name
        self.radius_m = radius_m  # None: the track's default arrival radius


class TrackRecord:
    type = "track"

    def __init__(self, track_id, waypoints, offset=-1):
        self.track_id = track_id
        self.waypoints = waypoints
        self.offset = offset


class Damage:
    """Bytes the decoder could not use. reason: "bad frame" (CRC/length wrong: skipped to the
    next valid frame), "truncated" (the data ends inside a frame), "no keyframe" (intact DELTA
    records whose chain back to a keyframe is broken; `records` counts them), "bad header",
    "incomplete track"."""

    type = "damage"

    def __init__(self, offset, length, reason, records=0):
        self.offset = offset
        self.length = length
        self.reason = reason
        self.records = records


# ---------------------------------------------------------------- CRC-16/CCITT-FALSE
def _crc_table():
    """CRC-16 of each 4-bit value: the CRC runs a nibble at a time, with a 16-entry table of 32 B
    (a byte table took 0.5 KB of heap)."""
    tab = array("H", range(16))
    for i in range(16):
        c = i << 12
        for _ in range(4):
            c = ((c << 1) ^ 0x1021) if c & 0x8000 else (c << 1)
        tab[i] = c & 0xFFFF
    return tab


_CRC_TAB = _crc_table()


def crc16(data, start=0, end=-1, crc=0xFFFF):
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) of data[start:end]; b"123456789" -> 0x29B1."""
    tab = _CRC_TAB
    if end < 0:
        end = len(data)
    for i in range(start, end):
        x = data[i]
        # the low 12 bits move up a nibble; the top nibble with the input's indexes the table
        crc = ((crc & 0xFFF) << 4) ^ tab[(crc >> 12) ^ (x >> 4)]
        crc = ((crc & 0xFFF) << 4) ^ tab[(crc >> 12) ^ (x & 15)]
    return crc


# ---------------------------------------------------------------- varints
def _put_uv(buf, i, v):
    while v >= 0x80:
        buf[i] = (v & 0x7F) | 0x80
        v >>= 7
        i += 1
    buf[i] = v
    return i + 1


def _text_bytes(text):
    """Text as written into a record: str with \r as a space, encoded; bytes as they are."""
    return text.replace("\r", " ").encode() if isinstance(text, str) else text


def _put_sv(buf, i, v):
    return _put_uv(buf, i, (v << 1) if v >= 0 else ((-v) << 1) - 1)


def _get_uv(data, i, end):
    """(value, next index); raises IndexError past end."""
    v = 0
    shift = 0
    while True:
        if i >= end:
            raise IndexError("varint past end")
        b = data[i]
        i += 1
        v |= (b & 0x7F) << shift
        if not b & 0x80:
            return v, i
        shift += 7
        if shift > 63:
            raise IndexError("varint too long")


def _get_sv(data, i, end):
    v, i = _get_uv(data, i, end)
    return ((v >> 1) if not v & 1 else -((v + 1) >> 1)), i


def _quant(x, scale):
    """Value in units -> stored int (nearest, ties to even on MicroPython and CPython alike)."""
    if x is None:
        return 0
    if scale == 1:
        try:
            return int(x)
        except (ValueError, OverflowError):
            return 0
    try:
        return round(x * scale)  # half to even, as CPython; one float temporary
    except (ValueError, OverflowError):  # nan, inf: logged as 0 rather than stopping the log
        return 0


# the fields' names in FIELDS' order, for quantized(): a tuple of 0.2 KB where a dict of
# (scale, modulus) pairs took 1.3 KB of heap (docs/MEMORY.md)
_NAMES = tuple(f[0] for f in FIELDS)


def quantized(name, x):
    """`x` exactly as the log stores it and a decoder gives it back (int / scale, wrapped).
    The app feeds its control step with these values, so a replay of the log sees exactly the
    inputs the boat saw and reproduces its commands bit for bit."""
    f = FIELDS[_NAMES.index(name)]
    scale = f[1]
    mod = f[4]
    q = _quant(x, scale)
    if mod:
        q %= mod
    return q if scale == 1 else q / scale


def _wrap(d, mod):
    if mod:
        h = mod >> 1
        d = (d + h) % mod - h
    return d


def _frame(buf, typ, plen):
    """Write tag + length in front of a payload that sits at buf[3:3+plen]; return (start, end).
    The payload is written first at offset 3 (room for a 2-byte length), then the head is placed
    just before it so no copy is needed."""
    start = 0 if plen >= 0x80 else 1  # 2-byte or 1-byte length ends at buf[2]
    buf[start] = _TAG_BASE | typ
    _put_uv(buf, start + 1, plen)
    end = 3 + plen
    c = crc16(buf, start, end)
    buf[end] = c & 0xFF
    buf[end + 1] = c >> 8
    return start, end + 2


class LogEncoder:
    """Encodes one file's records. Call header() at the start of every file (it also makes the next
    control record a keyframe). Not thread-safe; one encoder per log file stream."""

    def __init__(self, key_every=25, fields=FIELDS):
        self.fields = fields
        self.key_every = key_every  # a KEY record at least every this many control records
        n = len(fields)
        self._n = n
        self._mask_len = (n + 7) // 8
        self._prev = [0] * n
        self._prev2 = [0] * n
        self._cur = [0] * n
        self._since_key = key_every  # first control record is a keyframe
        self._buf = bytearray(4 + self._mask_len + 10 * n + 2)
        self._mv = memoryview(self._buf)
        self._ebuf = bytearray(3 + 5 + 1 + 32 + _MAX_TEXT + 2)
        self._emv = memoryview(self._ebuf)
        # no buffer for the HEADER frame (about 900 B): write_header() hands it out line by line
        # (a 2 KB buffer kept for it took heap all the time; allocating it late, in a fragmented
        # heap, was the first thing to fail: docs/MEMORY.md)
        self.records = 0
        self.keyframes = 0
        self._seq = 0  # control record counter (mod 256): a lost whole record is detected
        self._flags_i = -1
        for i in range(n):
            if fields[i][0] == "flags":
                self._flags_i = i

    def force_keyframe(self):
        """The next control record is absolute (after a dropped record, a new file, a gap)."""
        self._since_key = self.key_every

    def header(self, fw_version="", config_hash="", track_id="", reset_cause="", t0_ms=0,
               utc="", session=0, part=0, **extra):
        """The HEADER record (bytes). Every file starts with one; keys are free text values."""
        out = bytearray()

        def put(b):
            out.extend(b)
            return True

        self.write_header(put, fw_version, config_hash, track_id, reset_cause, t0_ms, utc, session, part, **extra)
        return bytes(out)

    def _header_lines(self, fw_version, config_hash, track_id, reset_cause, t0_ms, utc, session, part, extra):
        """The HEADER payload after MAGIC and the format byte, a line at a time (bytes)."""
        yield _text_bytes("fw=%s" % fw_version)
        yield _text_bytes("\nconfig=%s" % config_hash)
        yield _text_bytes("\ntrack=%s" % track_id)
        yield _text_bytes("\nreset=%s" % reset_cause)
        yield _text_bytes("\nt0_ms=%d" % t0_ms)
        yield _text_bytes("\nutc=%s" % utc)
        yield _text_bytes("\nsession=%d" % session)
        yield _text_bytes("\npart=%d" % part)
        yield _text_bytes("\nkey_every=%d" % self.key_every)
        for k in sorted(extra):
            yield _text_bytes("\n%s=%s" % (k, extra[k]))
        for name, scale, unit, coding, mod in self.fields:
            yield _text_bytes("\nf %s %d %s %s %d" % (name, scale, unit or "-", coding, mod))

    def write_header(self, write, fw_version="", config_hash="", track_id="", reset_cause="", t0_ms=0,
                     utc="", session=0, part=0, **extra):
        """The HEADER frame given to write(bytes) -> bool in pieces of a line each, with no buffer
        for the whole frame: the length first (a pass over the lines), then the lines with the CRC
        summed on. Returns False as soon as a write does (the frame is then incomplete); raises
        ValueError, before writing anything, when the header would be longer than MAX_PAYLOAD."""
        args = (fw_version, config_hash, track_id, reset_cause, t0_ms, utc, session, part, extra)
        n = len(MAGIC) + 1
        for b in self._header_lines(*args):
            n += len(b)
        if n > MAX_PAYLOAD:
            raise ValueError("log header too long (%d bytes)" % n)
        self.force_keyframe()
        head = bytearray(3 + len(MAGIC) + 1)
        head[0] = _TAG_BASE | T_HEADER
        j = _put_uv(head, 1, n)
        head[j : j + len(MAGIC)] = MAGIC
        j += len(MAGIC)
        head[j] = FORMAT_VERSION
        j += 1
        c = crc16(head, 0, j)
        if not write(memoryview(head)[:j]):
            return False
        for b in self._header_lines(*args):
            c = crc16(b, 0, len(b), c)
            if not write(b):
                return False
        return write(bytes((c & 0xFF, c >> 8)))

    def _values(self, rec):
        cur = self._cur
        fields = self.fields
        for i in range(self._n):
            name, scale, _unit, _coding, mod = fields[i]
            if i == self._flags_i:
                v = (1 if rec.pos_valid else 0) | (2 if rec.heading_valid else 0)
                v |= (4 if rec.vel_valid else 0) | ((rec.rtk & 3) << 3)
            else:
                v = _quant(getattr(rec, name, 0), scale)
                if mod:
                    v %= mod
            cur[i] = v

    def encode_control(self, rec):
        """The record as a KEY or DELTA frame: a memoryview into the encoder's buffer, valid
        until the next encode_control call (copy it or write it out before then)."""
        self._values(rec)
        buf = self._buf
        cur = self._cur
        prev = self._prev
        prev2 = self._prev2
        fields = self.fields
        n = self._n
        self._seq = (self._seq + 1) & 0xFF
        buf[3] = self._seq
        i = 4
        if self._since_key >= self.key_every:
            typ = T_KEY
            for k in range(n):
                i = _put_sv(buf, i, cur[k])
                prev2[k] = cur[k]  # D2 prediction restarts flat after a keyframe
                prev[k] = cur[k]
            self._since_key = 1
            self.keyframes += 1
        else:
            typ = T_DELTA
            mlen = self._mask_len
            for k in range(mlen):
                buf[4 + k] = 0
            i = 4 + mlen
            for k in range(n):
                coding = fields[k][3]
                mod = fields[k][4]
                v = cur[k]
                if coding == D1:
                    d = v - prev[k]
                elif coding == D2:
                    d = v - prev[k] - _wrap(prev[k] - prev2[k], mod)
                else:
                    d = v
                d = _wrap(d, mod)
                if d:
                    buf[4 + (k >> 3)] |= 1 << (k & 7)
                    i = _put_sv(buf, i, d)
                prev2[k] = prev[k]
                prev[k] = v
            self._since_key += 1
        self.records += 1
        start, end = _frame(buf, typ, i - 3)
        return self._mv[start:end]

    def encode_event(self, kind, text, t_ms):
        """An EVENT frame (memoryview into a separate buffer, valid until the next event).
        kind: short ASCII word ("MODE", "ALARM", "FAULT", "KEY", ...); text is cut to 200 bytes."""
        buf = self._ebuf
        kb = kind.encode() if isinstance(kind, str) else bytes(kind)
        kb = kb[:32]
        tb = text.encode() if isinstance(text, str) else bytes(text)
        tb = tb[:_MAX_TEXT]
        i = _put_uv(buf, 3, t_ms & 0x3FFFFFFF)
        buf[i] = len(kb)
        i += 1
        buf[i : i + len(kb)] = kb
        i += len(kb)
        buf[i : i + len(tb)] = tb
        i += len(tb)
        start, end = _frame(buf, T_EVENT, i - 3)
        return self._emv[start:end]

    def encode_track(self, waypoints, track_id=""):
        """TRACK record(s) (bytes): waypoints with attributes lat_e7, lon_e7, speed_mps, name,
        radius_m (None allowed). Long tracks are split into several records."""
        return b"".join(list(self.iter_track(waypoints, track_id)))

    def iter_track(self, waypoints, track_id=""):
        """The TRACK records of encode_track one at a time (each under 1 KB): a long track is
        never encoded into one large buffer."""
        idb = track_id.encode()[:64]
        total = len(waypoints)
        first = 0
        while True:
            body = bytearray()
            tmp = bytearray(10)
            plat = plon = 0
            k = first
            while k < total and len(body) < _TRACK_CHUNK:
                w = waypoints[k]
                lat = int(w.lat_e7)
                lon = int(w.lon_e7)
                n = _put_sv(tmp, 0, lat - plat)
                body += tmp[:n]
                n = _put_sv(tmp, 0, lon - plon)
                body += tmp[:n]
                plat = lat
                plon = lon
                n = _put_sv(tmp, 0, _quant(w.speed_mps, 1000))
                body += tmp[:n]
                r = getattr(w, "radius_m", None)
                n = _put_uv(tmp, 0, 0 if r is None else _quant(r, 100) + 1)
                body += tmp[:n]
                nb = (getattr(w, "name", "") or "").encode()[:40]
                body.append(len(nb))
                body += nb
                k += 1
            head = bytearray(12 + len(idb))
            j = _put_uv(head, 0, total)
            j = _put_uv(head, j, first)
            head[j] = len(idb)
            j += 1
            head[j : j + len(idb)] = idb
            j += len(idb)
            yield _whole_frame(T_TRACK, bytes(head[:j]) + bytes(body))
            first = k
            if first >= total:
                break


def _whole_frame(typ, payload):
    """A frame around a payload (bytes; for the rare, allocating record types)."""
    head = bytearray(3)
    n = _put_uv(head, 1, len(payload))
    head[0] = _TAG_BASE | typ
    out = bytearray(head[:n]) + payload + b"\0\0"
    c = crc16(out, 0, len(out) - 2)
    out[-2] = c & 0xFF
    out[-1] = c >> 8
    return bytes(out)


# ---------------------------------------------------------------- decoding
def _parse_header(data, s, e, offset):
    if e - s < 4 or bytes(data[s : s + 3]) != MAGIC:
        return None
    h = Header()
    h.version = data[s + 3]
    h.offset = offset
    fields = []
    for line in bytes(data[s + 4 : e]).decode().split("\n"):
        if line.startswith("f "):
            p = line.split(" ")
            if len(p) != 6 or p[4] not in (D0, D1, D2):
                return None
            fields.append((p[1], int(p[2]), "" if p[3] == "-" else p[3], p[4], int(p[5])))
        elif "=" in line:
            k, v = line.split("=", 1)
            h.info[k] = v
    h.fields = tuple(fields)
    return h


def _parse_event(data, s, e, offset):
    t, i = _get_uv(data, s, e)
    kl = data[i]
    i += 1
    if i + kl > e:
        raise IndexError("event kind past end")
    kind = bytes(data[i : i + kl]).decode()
    text = bytes(data[i + kl : e]).decode()
    return Event(t, kind, text, offset)


def _parse_track(data, s, e):
    total, i = _get_uv(data, s, e)
    first, i = _get_uv(data, i, e)
    il = data[i]
    i += 1
    tid = bytes(data[i : i + il]).decode()
    i += il
    wps = []
    lat = lon = 0
    while i < e:
        d, i = _get_sv(data, i, e)
        lat += d
        d, i = _get_sv(data, i, e)
        lon += d
        sp, i = _get_sv(data, i, e)
        r, i = _get_uv(data, i, e)
        nl = data[i]
        i += 1
        if i + nl > e:
            raise IndexError("name past end")
        name = bytes(data[i : i + nl]).decode()
        i += nl
        wps.append(LogWaypoint(lat, lon, sp / 1000, name, None if r == 0 else (r - 1) / 100))
    return total, first, tid, wps


class _Chain:
    """Decoder state for control records of one file part (the header's field table)."""

    def __init__(self, fields):
        self.fields = fields
        n = len(fields)
        self.n = n
        self.mask_len = (n + 7) // 8
        self.prev = [0] * n
        self.prev2 = [0] * n
        self.seq = -1
        self.valid = False
        self.gap = 0  # control records missing before the last keyframe (sequence gap, mod 256)

    def decode(self, typ, data, s, e, offset):
        n = self.n
        fields = self.fields
        prev = self.prev
        prev2 = self.prev2
        vals = [0] * n
        if s >= e:
            raise IndexError("empty control record")
        seq = data[s]
        s += 1
        if typ == T_KEY:
            # a gap is news only if nothing before it was reported damaged (chain still valid)
            self.gap = (seq - self.seq - 1) & 0xFF if (self.valid and self.seq >= 0) else 0
            i = s
            for k in range(n):
                vals[k], i = _get_sv(data, i, e)
            for k in range(n):
                prev2[k] = vals[k]
                prev[k] = vals[k]
        else:
            if not self.valid or seq != (self.seq + 1) & 0xFF:
                self.valid = False  # a record is missing: wait for the next keyframe
                return None
            i = s + self.mask_len
            if i > e:
                raise IndexError("mask past end")
            for k in range(n):
                coding = fields[k][3]
                mod = fields[k][4]
                d = 0
                if data[s + (k >> 3)] & (1 << (k & 7)):
                    d, i = _get_sv(data, i, e)
                if coding == D1:
                    v = prev[k] + d
                elif coding == D2:
                    v = prev[k] + _wrap(prev[k] - prev2[k], mod) + d
                else:
                    v = d
                if mod:
                    v %= mod
                vals[k] = v
            for k in range(n):
                prev2[k] = prev[k]
                prev[k] = vals[k]
        if i != e:
            raise IndexError("control payload length mismatch")
        self.valid = True
        self.seq = seq
        rec = ControlRecord()
        rec.key = typ == T_KEY
        rec.offset = offset
        for k in range(n):
            name, scale = fields[k][0], fields[k][1]
            v = vals[k]
            if name == "flags":
                rec.pos_valid = bool(v & 1)
                rec.heading_valid = bool(v & 2)
                rec.vel_valid = bool(v & 4)
                rec.rtk = (v >> 3) & 3
            elif scale == 1:
                setattr(rec, name, v)
            else:
                setattr(rec, name, v / scale)
        return rec


def _frame_at(data, i, n):
    """(type, payload start, payload end, frame end) of a valid frame at i, or an int reason:
    1 not a frame / bad CRC, 2 runs past the end of data."""
    tag = data[i]
    typ = tag - _TAG_BASE
    if typ < 0 or typ >= _N_TYPES:
        return 1
    try:
        plen, s = _get_uv(data, i + 1, min(n, i + 3))
    except IndexError:
        return 2 if i + 3 > n else 1
    if plen > MAX_PAYLOAD:
        return 1
    e = s + plen
    if e + 2 > n:
        return 2
    c = crc16(data, i, e)
    if data[e] != c & 0xFF or data[e + 1] != c >> 8:
        return 1
    return typ, s, e, e + 2


def iter_records(data, fields=FIELDS):
    """Decode a log (bytes, bytearray or memoryview; one file or several concatenated).
    Yields Header, ControlRecord, Event, TrackRecord and Damage objects in file order (`.type` is
    "header", "control", "event", "track", "damage"). Never raises on bad data.
    `fields` is the table used before any header was seen (a file cut at its start)."""
    n = len(data)
    chain = _Chain(fields)
    i = 0
    orphans = 0
    orphan_off = 0
    orphan_end = 0
    track_parts = None  # (total, track_id, waypoints, offset) while a multi-record track arrives
    while i < n:
        f = _frame_at(data, i, n)
        if isinstance(f, int):
            # Scan for the next valid frame; everything in between is damage.
            j = i + 1
            while j < n:
                g = _frame_at(data, j, n)
                if not isinstance(g, int):
                    break
                j += 1
            chain.valid = False
            if orphans:
                yield Damage(orphan_off, orphan_end - orphan_off, "no keyframe", orphans)
                orphans = 0
            reason = "truncated" if (f == 2 and j >= n) else "bad frame"
            yield Damage(i, j - i, reason)
            i = j
            continue
        typ, s, e, nxt = f
        rec = None
        try:
            if typ == T_HEADER:
                rec = _parse_header(data, s, e, i)
                if rec is None:
                    chain.valid = False
                    yield Damage(i, nxt - i, "bad header")
                else:
                    chain = _Chain(rec.fields)
            elif typ == T_KEY or typ == T_DELTA:
                rec = chain.decode(typ, data, s, e, i)
                if rec is not None and typ == T_KEY and chain.gap:
                    # whole records vanished right before a keyframe: nothing else shows it
                    yield Damage(i, 0, "%d control records missing (sequence gap)" % chain.gap)
                    chain.gap = 0
                if rec is None:
                    if not orphans:
                        orphan_off = i
                    orphans += 1
                    orphan_end = nxt
            elif typ == T_EVENT:
                rec = _parse_event(data, s, e, i)
            else:
                total, first, tid, wps = _parse_track(data, s, e)
                if first == 0:
                    track_parts = (total, tid, wps, i)
                elif track_parts and track_parts[0] == total and len(track_parts[2]) == first:
                    track_parts[2].extend(wps)
                else:
                    track_parts = None
                    yield Damage(i, nxt - i, "incomplete track")
                if track_parts and len(track_parts[2]) >= track_parts[0]:
                    rec = TrackRecord(track_parts[1], track_parts[2], track_parts[3])
                    track_parts = None
        except (IndexError, ValueError, UnicodeError):
            # CRC was right but the content is not: a writer bug or a CRC collision.
            chain.valid = False
            rec = None
            yield Damage(i, nxt - i, "bad content")
        if orphans and (rec is not None and rec.type == "control" or typ == T_HEADER):
            yield Damage(orphan_off, orphan_end - orphan_off, "no keyframe", orphans)
            orphans = 0
        if rec is not None:
            yield rec
        i = nxt
    if orphans:
        yield Damage(orphan_off, orphan_end - orphan_off, "no keyframe", orphans)
    if track_parts:
        yield Damage(track_parts[3], n - track_parts[3], "incomplete track")


def t_span_ms(t_first_ms, t_last_ms):
    """Duration between two logged ticks (handles the 2^30 wrap)."""
    return ticks_diff(t_last_ms, t_first_ms)
