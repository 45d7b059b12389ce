"""NMEA 0183 building blocks shared by the GNSS parser (gnss.py) and the wind parser (mwv.py).

Everything works on a preallocated bytearray and index ranges, so parsing a sentence allocates
nothing: numbers come out as ints (decimals as thousandths, `*_e3`), empty fields as None.

    from trackpilot.devices.nmea import LineFramer, parse_ddmm_e7
    fr = LineFramer()
    data = b"$GPHDT,274.07,T*03\\r\\n"
    i = 0
    while True:
        i = fr.feed(data, i, len(data))   # index after a checked sentence, or -1
        if i < 0:
            break
        f = fr.fields                     # Fields view: f.formatter() == FMT_HDT
        heading_e3 = f.e3(1)              # 274070
    parse_ddmm_e7(b"4807.038", 0, 8, ord("N"))   # 481173000 (48.1173000 deg), exact, no float
(the text API for the same conversion is trackpilot.nav.geo.ddmm_to_e7; both give the same ints)
"""
from trackpilot.compat import const

MAX_FIELDS = const(32)
_DOLLAR = const(0x24)
_BANG = const(0x21)
_STAR = const(0x2A)
_COMMA = const(0x2C)
_DOT = const(0x2E)
_MINUS = const(0x2D)
_PLUS = const(0x2B)
_CR = const(0x0D)
_LF = const(0x0A)


def fmt_code(name):
    """Three-letter sentence formatter (b"GGA") as the int the parser compares with."""
    return (name[0] << 16) | (name[1] << 8) | name[2]


FMT_GGA = const(0x474741)
FMT_RMC = const(0x524D43)
FMT_VTG = const(0x565447)
FMT_GST = const(0x475354)
FMT_HDT = const(0x484454)
FMT_THS = const(0x544853)
FMT_MWV = const(0x4D5756)

_HEX = b"0123456789ABCDEF"


def _hexval(c):
    if 0x30 <= c <= 0x39:
        return c - 0x30
    if 0x41 <= c <= 0x46:
        return c - 0x37
    if 0x61 <= c <= 0x66:
        return c - 0x57
    return -1


def checksum(buf, a, b):
    """XOR of buf[a:b] (the bytes between '$' and '*')."""
    x = 0
    for i in range(a, b):
        x ^= buf[i]
    return x


def sentence_ok(buf, start, end):
    """True if buf[start:end] is `$...*hh` (optionally followed by CR) with a correct checksum.

    `start` indexes the '$' (or '!'), `end` is one past the last byte before LF."""
    while end > start and buf[end - 1] == _CR:
        end -= 1
    star = end - 3
    if star <= start or buf[star] != _STAR:
        return False
    hi = _hexval(buf[star + 1])
    lo = _hexval(buf[star + 2])
    if hi < 0 or lo < 0:
        return False
    return checksum(buf, start + 1, star) == (hi << 4) | lo


class Fields:
    """Field view over one checked sentence in a buffer. Field 0 is the address (`GPGGA`)."""

    def __init__(self, buf):
        self.buf = buf
        self.starts = [0] * (MAX_FIELDS + 1)  # a list: offsets go beyond 255 in a 512 B buffer
        self.count = 0

    def split(self, start, end):
        """Split `$addr,f1,...,fn*hh` at buf[start:end] (end: one past the last byte before LF).

        Returns the number of fields (the extra ones beyond MAX_FIELDS are dropped)."""
        buf = self.buf
        while end > start and buf[end - 1] == _CR:
            end -= 1
        star = end - 3
        st = self.starts
        st[0] = start + 1
        k = 1
        for i in range(start + 1, star):
            if buf[i] == _COMMA:
                if k >= MAX_FIELDS:
                    break
                st[k] = i + 1
                k += 1
        st[k] = star + 1  # sentinel: field k-1 ends at st[k] - 1
        self.count = k
        return k

    def formatter(self):
        """The sentence formatter as an int (FMT_*), any talker ID; 0 if the address is odd."""
        a = self.starts[0]
        n = self.starts[1] - 1 - a
        if n != 5:
            return 0
        b = self.buf
        return (b[a + 2] << 16) | (b[a + 3] << 8) | b[a + 4]

    def talker(self):
        """Two-letter talker ID as an int (b[0] << 8 | b[1])."""
        a = self.starts[0]
        return (self.buf[a] << 8) | self.buf[a + 1]

    def span(self, i):
        """(start, end) of field i; (0, 0) if the sentence has no field i."""
        if i >= self.count:
            return 0, 0
        return self.starts[i], self.starts[i + 1] - 1

    def empty(self, i):
        return i >= self.count or self.starts[i + 1] - 1 == self.starts[i]

    def char(self, i):
        """First byte of field i as an int, 0 if empty or absent."""
        if self.empty(i):
            return 0
        return self.buf[self.starts[i]]

    def int_(self, i):
        """Field i as an int; None if empty, absent or malformed."""
        if i >= self.count:
            return None
        return parse_int(self.buf, self.starts[i], self.starts[i + 1] - 1)

    def e3(self, i):
        """Decimal field i in thousandths (rounded half away from zero); None if empty/bad."""
        if i >= self.count:
            return None
        return parse_e3(self.buf, self.starts[i], self.starts[i + 1] - 1)

    def ddmm_e7(self, i):
        """Fields i (ddmm.mmmm) and i+1 (N/S/E/W) as 1e-7 deg; None if empty or malformed."""
        if i + 1 >= self.count:
            return None
        a = self.starts[i]
        b = self.starts[i + 1] - 1
        h = self.starts[i + 1]
        if self.starts[i + 2] - 1 != h + 1:
            return None
        return parse_ddmm_e7(self.buf, a, b, self.buf[h])

    def time_ms(self, i):
        """hhmmss.ss field as ms of the UTC day; None if empty or malformed."""
        if i >= self.count:
            return None
        return parse_hms_ms(self.buf, self.starts[i], self.starts[i + 1] - 1)


def parse_int(buf, a, b):
    if a >= b:
        return None
    neg = False
    if buf[a] == _MINUS:
        neg = True
        a += 1
        if a >= b:
            return None
    v = 0
    for i in range(a, b):
        d = buf[i] - 0x30
        if d < 0 or d > 9:
            return None
        v = v * 10 + d
        if v > 99999999:  # keep small ints (31-bit on the ESP32); NMEA has no such fields
            return None
    return -v if neg else v


def parse_e3(buf, a, b):
    """`-12.3456` -> -12346 (thousandths, rounded half away from zero). None if empty/bad."""
    if a >= b:
        return None
    neg = False
    c = buf[a]
    if c == _MINUS or c == _PLUS:
        neg = c == _MINUS
        a += 1
    v = 0
    frac = -1  # digits after the point so far, -1 before the point
    digits = 0
    rnd = 0
    for i in range(a, b):
        c = buf[i]
        if c == _DOT:
            if frac >= 0:
                return None
            frac = 0
            continue
        d = c - 0x30
        if d < 0 or d > 9:
            return None
        digits += 1
        if frac < 0:
            v = v * 10 + d
            if v > 999999:  # 1e6 units * 1000 must stay a small int
                return None
        elif frac < 3:
            v = v * 10 + d
            frac += 1
        else:
            if frac == 3 and d >= 5:
                rnd = 1
            frac += 1
    if digits == 0:
        return None
    if frac < 0:
        frac = 0
    while frac < 3:
        v *= 10
        frac += 1
    v += rnd
    return -v if neg else v


def parse_hms_ms(buf, a, b):
    """`hhmmss.sss` -> ms of day. None if empty or out of range."""
    if b - a < 6:
        return None
    for i in range(a, a + 6):
        if not 0x30 <= buf[i] <= 0x39:
            return None
    hh = (buf[a] - 0x30) * 10 + buf[a + 1] - 0x30
    mm = (buf[a + 2] - 0x30) * 10 + buf[a + 3] - 0x30
    ss_e3 = parse_e3(buf, a + 4, b)
    if ss_e3 is None or ss_e3 < 0 or hh > 23 or mm > 59 or ss_e3 >= 61000:
        return None
    return (hh * 3600 + mm * 60) * 1000 + ss_e3


def parse_ddmm_e7(buf, a, b, hemi):
    """NMEA `[d]ddmm.mmmm` in buf[a:b] plus hemisphere byte -> 1e-7 deg int, or None.

    Exact: degrees*1e7 + round(minutes*1e7/60), minutes kept as an integer of 1e-7 min, so
    no float ever holds the value and a float32 build gives the same int."""
    if hemi == 0x4E or hemi == 0x53:  # N S
        max_deg = 90
    elif hemi == 0x45 or hemi == 0x57:  # E W
        max_deg = 180
    else:
        return None
    dot = b
    for i in range(a, b):
        if buf[i] == _DOT:
            dot = i
            break
    nint = dot - a
    if nint < 3 or nint > 5:
        return None
    deg = 0
    for i in range(a, dot - 2):
        d = buf[i] - 0x30
        if d < 0 or d > 9:
            return None
        deg = deg * 10 + d
    m10 = buf[dot - 2] - 0x30
    m1 = buf[dot - 1] - 0x30
    if m10 < 0 or m10 > 5 or m1 < 0 or m1 > 9:
        return None
    # minutes in units of 1e-7 min, truncated: at most 599999999 < 2**30. Digits beyond the
    # 7th cannot change round(minutes_e7 / 60): floor((m + 30 + r) / 60) == floor((m + 30) / 60)
    # for an int m and 0 <= r < 1, so this is the exactly rounded value for any length.
    mins = m10 * 10 + m1
    k = 0
    for i in range(dot + 1, b):
        d = buf[i] - 0x30
        if d < 0 or d > 9:
            return None
        if k < 7:
            mins = mins * 10 + d
        k += 1
    while k < 7:
        mins *= 10
        k += 1
    # 1e-7 min -> 1e-7 deg: divide by 60, round half up (on the magnitude)
    v = (mins + 30) // 60
    if deg > max_deg or (deg == max_deg and v > 0):
        return None
    v += deg * 10000000
    if hemi == 0x53 or hemi == 0x57:
        v = -v
    return v


def format_sentence(body):
    """`GPGGA,...` (bytes, no $ and checksum) -> full sentence bytes with CRLF (tools, tests)."""
    x = checksum(body, 0, len(body))
    return b"$" + body + b"*" + bytes((_HEX[x >> 4], _HEX[x & 15])) + b"\r\n"


class LineFramer:
    """Frames `$...*hh<CR><LF>` sentences from a byte stream (one UART carrying NMEA only).

    Bounded buffer (maxlen bytes); overlong lines and bytes outside sentences are dropped and
    counted; no allocation per byte. feed() stops after each checked sentence so the caller can
    read `fields` before the buffer is reused."""

    def __init__(self, maxlen=96):
        self.buf = bytearray(maxlen)
        self.maxlen = maxlen
        self.n = 0  # bytes of the current sentence in buf, 0 = hunting for '$'
        self.fields = Fields(self.buf)
        self.ok = 0
        self.ck_err = 0
        self.dropped = 0  # overlong or broken sentences
        self.garbage = 0  # bytes outside any sentence (CR/LF not counted)

    def feed(self, data, i, n):
        """Consume data[i:n]; return the index after a checked sentence (then `fields` is
        valid), or -1 once everything was consumed without completing one."""
        buf = self.buf
        k = self.n
        cap = self.maxlen
        while i < n:
            c = data[i]
            i += 1
            if c == _DOLLAR or c == _BANG:
                if k:
                    self.dropped += 1  # a new sentence cut the old one
                buf[0] = c
                k = 1
                continue
            if k == 0:
                if c != _CR and c != _LF:
                    self.garbage += 1
                continue
            if c == _LF:
                self.n = 0
                if sentence_ok(buf, 0, k):
                    self.ok += 1
                    self.fields.split(0, k)
                    return i
                self.ck_err += 1
                k = 0
                continue
            if (c < 0x20 and c != _CR) or c > 0x7E or k >= cap:
                self.dropped += 1
                k = 0
                continue
            buf[k] = c
            k += 1
        self.n = k
        return -1
