"""Streaming GNSS parser: mixed NMEA 0183 + UBX + RTCM3 bytes in, one `Fix` per epoch out.

    from trackpilot.nav.fix import Fix
    from trackpilot.devices.gnss import GnssParser
    fix = Fix()
    gp = GnssParser(fix, heading_offset_deg=0.0)
    n_epochs = gp.feed(chunk, len(chunk), t_ms)   # chunk: bytes/bytearray/memoryview
    if n_epochs:
        control_step(fix)                         # fix holds the latest completed epoch

Framing: bytes are copied into one preallocated buffer (BUF_SIZE) and frames are cut from its
front: `$...*hh\\r\\n` (NMEA, checksum XOR), `B5 62 cls id len` (UBX, Fletcher-8), `D3` (RTCM3,
CRC-24Q, skipped). A frame that fails its check is dropped and the search restarts one byte after
its sync byte, so a frame cut by another one is found again. UBX/RTCM frames longer than the
buffer (e.g. NAV-SAT) are skipped by their length while their checksum runs, and counted as
`oversize`. Bytes outside frames are `garbage`. Nothing is allocated per byte.

Decoded messages land in preallocated records (`pvt`, `relpos`, `hppos`, `ack`, `gga`, `rmc`,
`vtg`, `gst`, `hdt`, `ths`, `rtcm`, `other`) as ints in the protocol's own units; `on_msg(kind)`
(if set) is called after each one (the decode tool prints them from there).

Epochs (see docs/GNSS.md): messages are merged into a private working Fix; an epoch closes
 1. on NAV-EOE (the receiver's own end-of-epoch marker);
 2. once every message kind the stream sends per epoch has arrived (`close_on=None`, automatic):
    the set is learnt from the stream, so any message order works without extra latency. It
    starts as {NAV-PVT}; a kind arriving late (for an epoch already closed) for the first epoch,
    or later two epochs in a row, joins the set (that epoch lost it, the next ones wait for it;
    a kind that is late only now and then, such as 1 Hz NMEA among 5 Hz UBX, does not); two
    epochs in a row that closed without the whole set (by the rules below) replace the set by
    what the last one had. With `close_on` (message names) those messages close the epoch;
 3. on a message carrying another iTOW (UBX) or UTC time (NMEA) than the open epoch;
 4. when `epoch_timeout_ms` (or 3/4 of the measured epoch interval, if longer) passed since its
    first message (checked at each feed()).
Closing copies the working Fix into the public one; feed() returns how many epochs closed.
Messages of an epoch that already closed are not merged (`stats.late`). Within an epoch the best
source wins: position NAV-HPPOSLLH > NAV-PVT > GGA > RMC; status NAV-PVT > GGA > RMC; velocity
NAV-PVT > RMC/VTG; heading NAV-RELPOSNED > HDT/THS; accuracy NAV-HPPOSLLH > NAV-PVT > GST.
The epoch interval is measured from consecutive iTOWs (UTC times for NMEA): `interval_ms` once
two intervals in a row agree (0 until then), so the app knows the receiver's real rate.
"""
import array

from trackpilot.devices import nmea
from trackpilot.compat import const, ticks_diff
from trackpilot.nav.fix import RTK_FIXED, RTK_FLOAT, RTK_NONE, RTK_SINGLE, Fix

# Holds the longest RTCM3 frame (1029 B) and NAV-SAT up to 91 satellites, so those are checked
# before they are dropped and a cut one costs nothing; longer frames are skipped by length.
BUF_SIZE = const(1100)
EPOCH_MS = const(200)  # nominal navigation epoch: 5 Hz (CFG-RATE-MEAS in ubxcfg.rover_items)
NMEA_MAX = const(480)  # NMEA says 82; u-blox PUBX,03 lines run to 400+
UBX_MAX_SKIP = const(2048)  # longer "UBX" lengths are taken as garbage (NAV-SAT: 8+12*nSV)

# message kinds (on_msg argument, `sources` bit = 1 << kind)
K_NAV_PVT = const(1)
K_NAV_RELPOSNED = const(2)
K_NAV_HPPOSLLH = const(3)
K_NAV_EOE = const(4)
K_ACK_ACK = const(5)
K_ACK_NAK = const(6)
K_GGA = const(7)
K_RMC = const(8)
K_VTG = const(9)
K_GST = const(10)
K_HDT = const(11)
K_THS = const(12)
K_UBX_OTHER = const(13)
K_NMEA_OTHER = const(14)
K_RTCM3 = const(15)
KIND_NAMES = (
    "", "NAV-PVT", "NAV-RELPOSNED", "NAV-HPPOSLLH", "NAV-EOE", "ACK-ACK", "ACK-NAK", "GGA",
    "RMC", "VTG", "GST", "HDT", "THS", "UBX", "NMEA", "RTCM3",
)

_S_HUNT = const(0)
_SKIP_UBX = const(1)
_SKIP_RTCM = const(2)

# source priorities inside one epoch
_P_HP = const(3)
_P_PVT = const(2)
_P_GGA = const(1)
_P_RMC = const(0)
_P_NONE = const(-1)

_KN_TO_MPS = 1852.0 / 3600000.0  # knots*1000 -> m/s
_KMH_TO_MPS = 1.0 / 3600.0  # km/h*1000 -> m/s


def kind_code(name):
    """'NAV-PVT' -> K_NAV_PVT (for configuration); ValueError for an unknown name."""
    for k in range(1, len(KIND_NAMES)):
        if KIND_NAMES[k] == name:
            return k
    raise ValueError("unknown GNSS message name %r" % name)


def _crc24q_table():
    """CRC-24Q of each 4-bit value: the CRC runs a nibble at a time, with a 16-entry table of
    64 B where a byte table took 1 KB of heap for a check that only RTCM3 frames need."""
    t = array.array("I", [0] * 16)
    for i in range(16):
        c = i << 20
        for _ in range(4):
            c <<= 1
            if c & 0x1000000:
                c ^= 0x1864CFB
        t[i] = c & 0xFFFFFF
    return t


_CRC24Q = _crc24q_table()


def crc24q(buf, a, b):
    """CRC-24Q (RTCM3) of buf[a:b]."""
    t = _CRC24Q
    c = 0
    for i in range(a, b):
        x = buf[i]
        # the low 20 bits move up a nibble; the top nibble with the input's indexes the table
        c = ((c & 0xFFFFF) << 4) ^ t[(c >> 20) ^ (x >> 4)]
        c = ((c & 0xFFFFF) << 4) ^ t[(c >> 20) ^ (x & 15)]
    return c


# payload lengths of the decoded messages (fixed), and the messages allowed to be longer than the
# buffer (skipped by length): NAV-SAT, NAV-SIG, RXM-RAWX, RXM-SFRBX, MON-SPAN. Any other length is
# taken as a false or corrupted header and searched past, so one bad byte cannot make the parser
# throw away up to UBX_MAX_SKIP good bytes.
_UBX_FIXED = ((0x01, 0x07, 92), (0x01, 0x3C, 64), (0x01, 0x14, 36), (0x01, 0x61, 4),
              (0x05, 0x00, 2), (0x05, 0x01, 2))
_UBX_LONG = ((0x01, 0x35), (0x01, 0x43), (0x02, 0x15), (0x02, 0x13), (0x0A, 0x31))


def _ubx_len_ok(cls, mid, ln):
    for c, m, n in _UBX_FIXED:
        if c == cls and m == mid:
            return ln == n
    if ln + 8 <= BUF_SIZE:
        return True
    if ln > UBX_MAX_SKIP:
        return False
    for c, m in _UBX_LONG:
        if c == cls and m == mid:
            return True
    return False


def _u2(b, o):
    return b[o] | (b[o + 1] << 8)


def _u4(b, o):
    # iTOW and accuracies stay below 2**30: small ints on the ESP32
    return b[o] | (b[o + 1] << 8) | (b[o + 2] << 16) | (b[o + 3] << 24)


def _i4(b, o):
    hi = b[o + 3]
    if hi > 127:
        hi -= 256
    return (hi << 24) + (b[o + 2] << 16) + (b[o + 1] << 8) + b[o]


def _i2(b, o):
    v = b[o] | (b[o + 1] << 8)
    return v - 65536 if v > 32767 else v


def _i1(b, o):
    v = b[o]
    return v - 256 if v > 127 else v


class Record:
    """Plain attribute holder for one decoded message (reused, filled in place)."""

    def __init__(self, **fields):
        for k in fields:
            setattr(self, k, fields[k])


class GnssStats:
    def __init__(self):
        self.bytes = 0
        self.ubx_ok = 0
        self.nmea_ok = 0
        self.rtcm_ok = 0
        self.ck_err = 0  # frames with a bad checksum/CRC
        self.broken = 0  # NMEA lines cut by a non-text byte
        self.oversize = 0  # frames longer than the buffer: skipped by length
        self.dropped = 0  # overlong NMEA lines
        self.unknown = 0  # good frames of a type not decoded
        self.bad_field = 0  # good checksum, unusable content
        self.garbage = 0  # bytes outside frames
        self.comments = 0  # '#' lines skipped (decode tool option)
        self.epochs = 0
        self.late = 0  # messages of an already closed epoch


class GnssParser:
    """Feed bytes, get epochs. Parameters:

    heading_offset_deg: added to the antenna-baseline heading (NAV-RELPOSNED, HDT, THS) to give
        the bow's heading. Base antenna aft, rover antenna forward on the keel: 0. Rover antenna
        to starboard of the base: -90.
    close_on: message names that close an epoch (tuple), or None for automatic (the set of
        message kinds of an epoch, learnt from the stream; NAV-EOE always closes).
    epoch_timeout_ms: close an open epoch this long after its first message (0: never); at slow
        rates 3/4 of the measured epoch interval if that is longer.
    skip_comments: skip gpsd-style '#' lines that start at a line start between frames (captures).
    """

    def __init__(self, fix=None, heading_offset_deg=0.0, close_on=None, epoch_timeout_ms=150,
                 skip_comments=False):
        self.fix = fix if fix is not None else Fix()
        self._w = Fix()  # epoch being assembled
        self.heading_offset_e5 = int(round(heading_offset_deg * 100000))
        if close_on is None:
            self._close_mask = 1 << K_NAV_PVT  # learnt from the stream (docstring rule 2)
            self._auto_close = True
        else:
            m = 0
            for name in close_on:
                m |= 1 << kind_code(name)
            self._close_mask = m
            self._auto_close = False
        self.epoch_timeout_ms = epoch_timeout_ms
        self.skip_comments = skip_comments
        self.stats = GnssStats()
        self.on_msg = None  # on_msg(kind) after each decoded message
        self.on_epoch = None  # on_epoch() after each completed epoch (self.fix filled)
        self._buf = bytearray(BUF_SIZE)
        self.buf = self._buf  # frame_start/frame_len index it inside on_msg
        self.frame_start = 0
        self.frame_len = 0
        self._fields = nmea.Fields(self._buf)
        self.fields = self._fields
        self._start = 0
        self._end = 0
        self._scan = 0
        self._skip = 0  # bytes left of an oversize frame
        self._skip_kind = _S_HUNT
        self._skip_pos = 0
        self._ck_a = 0
        self._ck_b = 0
        self._crc = 0
        self._ck_rx = 0
        self._line_start = True
        self._in_comment = False
        self._t_ms = 0
        self._done = 0
        self._open = False
        self._open_t = 0
        self._w_utc = -1
        self._last_itow = -1
        self._last_utc = -1
        self._utc_off = -1
        self._late_cur = 0  # kinds that came late for the last closed epoch
        self._late_prev = 0  # ... and for the one before
        self._short_closes = 0  # epochs in a row closed without the learnt set of kinds
        self._prev_itow = -1  # the closed epochs' times, for the interval measurement
        self._prev_utc = -1
        self._cand_ms = 0
        self.interval_ms = 0  # measured epoch interval (0: not known yet)
        self._p_pos = _P_NONE
        self._p_stat = _P_NONE
        self._p_vel = _P_NONE
        self._p_hdg = _P_NONE
        self._p_acc = _P_NONE
        self._hacc_01mm = 0
        self._bad_pos = False
        self._sog_e3 = 0
        self._sog_k = 0.001
        self._cog_e3 = 0
        self._hdg_e5 = 0
        self._hdg_acc_e5 = 0
        self.pvt = Record(itow_ms=0, year=0, month=0, day=0, hour=0, min=0, sec=0, valid=0,
                          t_acc_ns=0, nano_ns=0, fix_type=0, flags=0, flags2=0, num_sv=0,
                          lon_e7=0, lat_e7=0, height_mm=0, hmsl_mm=0, h_acc_mm=0, v_acc_mm=0,
                          vel_n_mms=0, vel_e_mms=0, vel_d_mms=0, g_speed_mms=0, head_mot_e5=0,
                          s_acc_mms=0, head_acc_e5=0, pdop_e2=0, flags3=0, head_veh_e5=0,
                          mag_dec_e2=0, mag_acc_e2=0)
        self.relpos = Record(version=0, ref_station_id=0, itow_ms=0, n_cm=0, e_cm=0, d_cm=0,
                             length_cm=0, heading_e5=0, hp_n_01mm=0, hp_e_01mm=0, hp_d_01mm=0,
                             hp_length_01mm=0, acc_n_01mm=0, acc_e_01mm=0, acc_d_01mm=0,
                             acc_length_01mm=0, acc_heading_e5=0, flags=0)
        self.hppos = Record(version=0, flags=0, itow_ms=0, lon_e7=0, lat_e7=0, height_mm=0,
                            hmsl_mm=0, lon_hp=0, lat_hp=0, height_hp_01mm=0, hmsl_hp_01mm=0,
                            h_acc_01mm=0, v_acc_01mm=0)
        self.eoe = Record(itow_ms=0)
        self.ack = Record(ack=False, cls=0, id=0, count=0)
        self.gga = Record(talker=0, utc_ms=None, lat_e7=None, lon_e7=None, quality=None,
                          num_sv=None, hdop_e3=None, alt_mm=None, sep_mm=None,
                          diff_age_e3=None, diff_station=None)
        self.rmc = Record(talker=0, utc_ms=None, status=0, lat_e7=None, lon_e7=None,
                          sog_kn_e3=None, cog_e3=None, date=None, magvar_e3=None,
                          magvar_dir=0, pos_mode=0)
        self.vtg = Record(talker=0, cog_t_e3=None, cog_m_e3=None, sog_kn_e3=None,
                          sog_kmh_e3=None, pos_mode=0)
        self.gst = Record(talker=0, utc_ms=None, rms_e3=None, major_e3=None, minor_e3=None,
                          orient_e3=None, sd_lat_e3=None, sd_lon_e3=None, sd_alt_e3=None)
        self.hdt = Record(talker=0, heading_e3=None)
        self.ths = Record(talker=0, heading_e3=None, mode=0)
        self.rtcm = Record(msg_type=0, length=0)
        self.other = Record(cls=0, id=0, length=0, formatter=0)

    # ---- bytes in -------------------------------------------------------------------------
    def feed(self, data, n, t_ms):
        """Parse data[0:n] received at t_ms; return the number of epochs completed."""
        self._t_ms = t_ms
        self._done = 0
        if self._open and self.epoch_timeout_ms and \
                ticks_diff(t_ms, self._open_t) >= self._timeout_ms():
            self._close(2)
        self.stats.bytes += n
        buf = self._buf
        i = 0
        while i < n:
            if self._skip:
                i = self._skip_bytes(data, i, n)
                continue
            end = self._end
            k = BUF_SIZE - end
            if k > n - i:
                k = n - i
            for j in range(k):
                buf[end + j] = data[i + j]
            i += k
            self._end = end + k
            self._parse()
            if self._end == BUF_SIZE and self._start == 0 and not self._skip:
                self._start = 1  # cannot happen by design; never stall on a full buffer
                self.stats.garbage += 1
                self._compact()
        return self._done

    def _compact(self):
        s = self._start
        end = self._end
        if s >= end:
            self._start = self._end = self._scan = 0
            return
        if s == 0:
            return
        buf = self._buf
        for j in range(end - s):
            buf[j] = buf[s + j]
        self._start = 0
        self._end = end - s
        if self._scan:
            self._scan -= s

    def _parse(self):
        buf = self._buf
        st = self.stats
        s = self._start
        end = self._end
        while s < end:
            c = buf[s]
            if self._in_comment:
                s += 1
                if c == 0x0A:
                    self._in_comment = False
                    self._line_start = True
                continue
            if c == 0x24:  # '$' NMEA
                j = self._scan if self._scan > s else s + 1
                bad = False
                while j < end:
                    b = buf[j]
                    if b == 0x0A:
                        break
                    if b > 0x7E or (b < 0x20 and b != 0x0D):
                        bad = True
                        break
                    j += 1
                if bad:
                    st.broken += 1
                    self._scan = 0
                    s += 1
                    continue
                if j - s > NMEA_MAX:
                    st.dropped += 1
                    self._scan = 0
                    s += 1
                    continue
                if j >= end:
                    self._scan = j
                    break
                self._scan = 0
                if nmea.sentence_ok(buf, s, j):
                    st.nmea_ok += 1
                    self.frame_start = s
                    self.frame_len = j + 1 - s
                    self._line_start = True
                    self._nmea(s, j)
                    s = j + 1
                else:
                    st.ck_err += 1
                    s += 1
                continue
            if c == 0xB5:  # UBX
                if end - s < 2:
                    break
                if buf[s + 1] != 0x62:
                    st.garbage += 1
                    s += 1
                    continue
                if end - s < 6:
                    break
                ln = buf[s + 4] | (buf[s + 5] << 8)
                total = ln + 8
                if not _ubx_len_ok(buf[s + 2], buf[s + 3], ln):
                    st.garbage += 1  # a length this message never has: a false or cut header
                    s += 1
                    continue
                if total > BUF_SIZE:
                    self._begin_skip(_SKIP_UBX, total, s, end)
                    s = end
                    break
                if end - s < total:
                    break
                ck_a = 0
                ck_b = 0
                for i in range(s + 2, s + 6 + ln):
                    ck_a = (ck_a + buf[i]) & 0xFF
                    ck_b = (ck_b + ck_a) & 0xFF
                if ck_a == buf[s + 6 + ln] and ck_b == buf[s + 7 + ln]:
                    st.ubx_ok += 1
                    self.frame_start = s
                    self.frame_len = total
                    self._line_start = False
                    self._ubx(buf[s + 2], buf[s + 3], s + 6, ln)
                    s += total
                else:
                    st.ck_err += 1
                    s += 1
                continue
            if c == 0xD3:  # RTCM3: skipped after its CRC
                if end - s < 3:
                    break
                if buf[s + 1] & 0xFC:
                    st.garbage += 1
                    s += 1
                    continue
                ln = ((buf[s + 1] & 3) << 8) | buf[s + 2]
                total = ln + 6
                if total > BUF_SIZE:
                    self._begin_skip(_SKIP_RTCM, total, s, end)
                    s = end
                    break
                if end - s < total:
                    break
                crc = crc24q(buf, s, s + 3 + ln)
                o = s + 3 + ln
                if crc == (buf[o] << 16) | (buf[o + 1] << 8) | buf[o + 2]:
                    st.rtcm_ok += 1
                    self.frame_start = s
                    self.frame_len = total
                    self._line_start = False
                    r = self.rtcm
                    r.length = ln
                    r.msg_type = (buf[s + 3] << 4) | (buf[s + 4] >> 4) if ln >= 2 else 0
                    self._emit(K_RTCM3)
                    s += total
                else:
                    st.ck_err += 1
                    s += 1
                continue
            # outside any frame
            s += 1
            if c == 0x0A:
                self._line_start = True
                continue
            if c == 0x23 and self._line_start and self.skip_comments:
                self._in_comment = True
                st.comments += 1
                continue
            self._line_start = False
            if c != 0x0D:
                st.garbage += 1
        self._start = s
        self._compact()

    def _begin_skip(self, kind, total, s, end):
        """Start skipping an oversize frame at buf[s]; run its check over what is buffered."""
        self.stats.oversize += 1
        self._skip_kind = kind
        self._skip = total
        self._skip_pos = 0
        self._ck_a = self._ck_b = self._crc = self._ck_rx = 0
        b = self._buf
        o = self.other
        if kind == _SKIP_UBX:
            o.cls = b[s + 2]
            o.id = b[s + 3]
            o.length = total - 8
        else:
            self.rtcm.length = total - 6
            self.rtcm.msg_type = (b[s + 3] << 4) | (b[s + 4] >> 4) if end - s >= 5 else 0
        self._skip_bytes(b, s, end)
        self._start = self._end = self._scan = 0

    def _skip_bytes(self, data, i, n):
        """Consume bytes of an oversize frame from data[i:n]; return the new index."""
        left = self._skip
        pos = self._skip_pos
        total = pos + left
        if self._skip_kind == _SKIP_UBX:
            a = self._ck_a
            b = self._ck_b
            rx = self._ck_rx
            while i < n and left:
                c = data[i]
                if 2 <= pos < total - 2:
                    a = (a + c) & 0xFF
                    b = (b + a) & 0xFF
                elif pos >= total - 2:
                    rx = (rx << 8) | c
                pos += 1
                left -= 1
                i += 1
            self._ck_a = a
            self._ck_b = b
            self._ck_rx = rx
            ok = rx == (a << 8) | b
        else:
            t = _CRC24Q
            crc = self._crc
            rx = self._ck_rx
            while i < n and left:
                c = data[i]
                if pos < total - 3:  # see crc24q
                    crc = ((crc & 0xFFFFF) << 4) ^ t[(crc >> 20) ^ (c >> 4)]
                    crc = ((crc & 0xFFFFF) << 4) ^ t[(crc >> 20) ^ (c & 15)]
                else:
                    rx = (rx << 8) | c
                pos += 1
                left -= 1
                i += 1
            self._crc = crc
            self._ck_rx = rx
            ok = rx == crc
        self._skip = left
        self._skip_pos = pos
        if not left:
            self._line_start = False
            if ok:
                if self._skip_kind == _SKIP_UBX:
                    self.stats.ubx_ok += 1
                    self.stats.unknown += 1
                    self._skip_kind = _S_HUNT
                    self._emit(K_UBX_OTHER)
                else:
                    self.stats.rtcm_ok += 1
                    self._skip_kind = _S_HUNT
                    self._emit(K_RTCM3)
            else:
                self.stats.ck_err += 1
            self._skip_kind = _S_HUNT
        return i

    def _emit(self, kind):
        if self.on_msg is not None:
            self.on_msg(kind)

    # ---- UBX --------------------------------------------------------------------------------
    def _ubx(self, cls, mid, o, ln):
        b = self._buf
        if cls == 0x01:
            if mid == 0x07 and ln == 92:
                r = self.pvt
                r.itow_ms = _u4(b, o)
                r.year = _u2(b, o + 4)
                r.month = b[o + 6]
                r.day = b[o + 7]
                r.hour = b[o + 8]
                r.min = b[o + 9]
                r.sec = b[o + 10]
                r.valid = b[o + 11]
                r.t_acc_ns = _u4(b, o + 12)
                r.nano_ns = _i4(b, o + 16)
                r.fix_type = b[o + 20]
                r.flags = b[o + 21]
                r.flags2 = b[o + 22]
                r.num_sv = b[o + 23]
                r.lon_e7 = _i4(b, o + 24)
                r.lat_e7 = _i4(b, o + 28)
                r.height_mm = _i4(b, o + 32)
                r.hmsl_mm = _i4(b, o + 36)
                r.h_acc_mm = _u4(b, o + 40)
                r.v_acc_mm = _u4(b, o + 44)
                r.vel_n_mms = _i4(b, o + 48)
                r.vel_e_mms = _i4(b, o + 52)
                r.vel_d_mms = _i4(b, o + 56)
                r.g_speed_mms = _i4(b, o + 60)
                r.head_mot_e5 = _i4(b, o + 64)
                r.s_acc_mms = _u4(b, o + 68)
                r.head_acc_e5 = _u4(b, o + 72)
                r.pdop_e2 = _u2(b, o + 76)
                r.flags3 = _u2(b, o + 78)
                r.head_veh_e5 = _i4(b, o + 84)
                r.mag_dec_e2 = _i2(b, o + 88)
                r.mag_acc_e2 = _u2(b, o + 90)
                self._emit(K_NAV_PVT)
                self._apply_pvt(r)
                return
            if mid == 0x3C and ln == 64 and b[o] == 1:
                r = self.relpos
                r.version = 1
                r.ref_station_id = _u2(b, o + 2)
                r.itow_ms = _u4(b, o + 4)
                r.n_cm = _i4(b, o + 8)
                r.e_cm = _i4(b, o + 12)
                r.d_cm = _i4(b, o + 16)
                r.length_cm = _i4(b, o + 20)
                r.heading_e5 = _i4(b, o + 24)
                r.hp_n_01mm = _i1(b, o + 32)
                r.hp_e_01mm = _i1(b, o + 33)
                r.hp_d_01mm = _i1(b, o + 34)
                r.hp_length_01mm = _i1(b, o + 35)
                r.acc_n_01mm = _u4(b, o + 36)
                r.acc_e_01mm = _u4(b, o + 40)
                r.acc_d_01mm = _u4(b, o + 44)
                r.acc_length_01mm = _u4(b, o + 48)
                r.acc_heading_e5 = _u4(b, o + 52)
                r.flags = _u4(b, o + 60)
                self._emit(K_NAV_RELPOSNED)
                self._apply_relpos(r)
                return
            if mid == 0x14 and ln == 36:
                r = self.hppos
                r.version = b[o]
                r.flags = b[o + 3]
                r.itow_ms = _u4(b, o + 4)
                r.lon_e7 = _i4(b, o + 8)
                r.lat_e7 = _i4(b, o + 12)
                r.height_mm = _i4(b, o + 16)
                r.hmsl_mm = _i4(b, o + 20)
                r.lon_hp = _i1(b, o + 24)
                r.lat_hp = _i1(b, o + 25)
                r.height_hp_01mm = _i1(b, o + 26)
                r.hmsl_hp_01mm = _i1(b, o + 27)
                r.h_acc_01mm = _u4(b, o + 28)
                r.v_acc_01mm = _u4(b, o + 32)
                self._emit(K_NAV_HPPOSLLH)
                self._apply_hppos(r)
                return
            if mid == 0x61 and ln == 4:
                self.eoe.itow_ms = _u4(b, o)
                self._emit(K_NAV_EOE)
                if self._join(self.eoe.itow_ms, -1, K_NAV_EOE):
                    self._w.sources |= 1 << K_NAV_EOE
                    self._close(0)
                return
        elif cls == 0x05 and ln == 2 and mid <= 1:
            r = self.ack
            r.ack = mid == 1
            r.cls = b[o]
            r.id = b[o + 1]
            r.count += 1
            self._emit(K_ACK_ACK if mid == 1 else K_ACK_NAK)
            return
        self.stats.unknown += 1
        r = self.other
        r.cls = cls
        r.id = mid
        r.length = ln
        self._emit(K_UBX_OTHER)

    # ---- NMEA -------------------------------------------------------------------------------
    def _nmea(self, s, j):
        f = self._fields
        f.split(s, j)
        fmt = f.formatter()
        if fmt == nmea.FMT_GGA:
            r = self.gga
            r.talker = f.talker()
            r.utc_ms = f.time_ms(1)
            r.lat_e7 = f.ddmm_e7(2)
            r.lon_e7 = f.ddmm_e7(4)
            r.quality = f.int_(6)
            r.num_sv = f.int_(7)
            r.hdop_e3 = f.e3(8)
            r.alt_mm = f.e3(9)
            r.sep_mm = f.e3(11)
            r.diff_age_e3 = f.e3(13)
            r.diff_station = f.int_(14)
            self._emit(K_GGA)
            self._apply_gga(r)
        elif fmt == nmea.FMT_RMC:
            r = self.rmc
            r.talker = f.talker()
            r.utc_ms = f.time_ms(1)
            r.status = f.char(2)
            r.lat_e7 = f.ddmm_e7(3)
            r.lon_e7 = f.ddmm_e7(5)
            r.sog_kn_e3 = f.e3(7)
            r.cog_e3 = f.e3(8)
            r.date = f.int_(9)
            r.magvar_e3 = f.e3(10)
            r.magvar_dir = f.char(11)
            r.pos_mode = f.char(12)
            self._emit(K_RMC)
            self._apply_rmc(r)
        elif fmt == nmea.FMT_VTG:
            r = self.vtg
            r.talker = f.talker()
            r.cog_t_e3 = f.e3(1)
            r.cog_m_e3 = f.e3(3)
            r.sog_kn_e3 = f.e3(5)
            r.sog_kmh_e3 = f.e3(7)
            r.pos_mode = f.char(9)
            self._emit(K_VTG)
            self._apply_vtg(r)
        elif fmt == nmea.FMT_GST:
            r = self.gst
            r.talker = f.talker()
            r.utc_ms = f.time_ms(1)
            r.rms_e3 = f.e3(2)
            r.major_e3 = f.e3(3)
            r.minor_e3 = f.e3(4)
            r.orient_e3 = f.e3(5)
            r.sd_lat_e3 = f.e3(6)
            r.sd_lon_e3 = f.e3(7)
            r.sd_alt_e3 = f.e3(8)
            self._emit(K_GST)
            self._apply_gst(r)
        elif fmt == nmea.FMT_HDT:
            r = self.hdt
            r.talker = f.talker()
            r.heading_e3 = f.e3(1)
            self._emit(K_HDT)
            if r.heading_e3 is not None and f.char(2) == 0x54:
                self._apply_heading(r.heading_e3, True, K_HDT)
        elif fmt == nmea.FMT_THS:
            r = self.ths
            r.talker = f.talker()
            r.heading_e3 = f.e3(1)
            r.mode = f.char(2)
            self._emit(K_THS)
            if r.heading_e3 is not None:
                self._apply_heading(r.heading_e3, r.mode == 0x41, K_THS)  # 'A' autonomous
        else:
            self.stats.unknown += 1
            self.other.formatter = fmt
            self._emit(K_NMEA_OTHER)

    # ---- epoch assembly ---------------------------------------------------------------------
    def _timeout_ms(self):
        t = self.interval_ms * 3 // 4
        return t if t > self.epoch_timeout_ms else self.epoch_timeout_ms

    def _join(self, itow, utc, kind):
        """Place a message of (itow or -1, utc_ms or -1) into the open epoch, opening or closing
        epochs as needed; False if it belongs to an epoch already closed."""
        # the iTOW decides where a message has one (NAV-PVT carries both), else the UTC time
        if itow >= 0:
            late = itow == self._last_itow
        else:
            late = utc >= 0 and utc == self._last_utc
        if late:
            self.stats.late += 1
            bit = 1 << kind
            if self._auto_close and (self._late_prev & bit or self.stats.epochs < 2):
                # late for the first epoch, or twice in a row: the stream sends it last
                self._close_mask |= bit
            self._late_cur |= bit
            return False
        w = self._w
        if self._open:
            if itow >= 0 and w.itow_ms >= 0:
                other = itow != w.itow_ms
            else:
                other = utc >= 0 and self._w_utc >= 0 and utc != self._w_utc
            if other:
                self._close(1)
        if not self._open:
            w.clear()
            w.t_ms = self._t_ms
            self._open = True
            self._open_t = self._t_ms
            self._w_utc = -1
            self._p_pos = self._p_stat = self._p_vel = self._p_hdg = self._p_acc = _P_NONE
            self._bad_pos = False
        if itow >= 0:
            w.itow_ms = itow
            if utc < 0 and self._utc_off >= 0:
                utc = (itow - self._utc_off) % 86400000  # as learnt from NAV-PVT
        if utc >= 0 and self._w_utc < 0:
            self._w_utc = utc
            w.utc_s = utc // 1000
            w.utc_ms = utc
        return True

    def _closing(self, kind):
        src = self._w.sources | (1 << kind)
        self._w.sources = src
        if self._auto_close:
            m = self._close_mask
            if src & m == m:
                self._close(0)
        elif self._close_mask & (1 << kind):
            self._close(0)

    def _learn(self, by):
        """After an epoch closed by a new time, timeout or flush: did it have the whole set?"""
        src = self._w.sources & ~(1 << K_NAV_EOE)
        m = self._close_mask
        if by == 0 or src & m == m or not src:
            self._short_closes = 0
            return
        self._short_closes += 1
        if self._short_closes >= 2:  # the stream changed: learn what it sends now
            self._close_mask = src
            self._short_closes = 0

    def _measure(self, itow, utc):
        d = 0
        if itow >= 0 and self._prev_itow >= 0:
            d = (itow - self._prev_itow) % 604800000
        elif itow < 0 and utc >= 0 and self._prev_utc >= 0:
            d = (utc - self._prev_utc) % 86400000
        if itow >= 0:
            self._prev_itow = itow
        if utc >= 0:
            self._prev_utc = utc
        if 0 < d <= 10000:
            c = self._cand_ms
            if -5 <= d - c <= 5:  # two intervals in a row agree: that is the rate
                self.interval_ms = d
            self._cand_ms = d

    def _close(self, by=0):
        """by: 0 its last message (EOE, the learnt set, close_on), 1 a new time, 2 timeout,
        3 flush."""
        if not self._open:
            return
        w = self._w
        self._late_prev = self._late_cur
        self._late_cur = 0
        if self._auto_close and by:
            self._learn(by)
        self._measure(w.itow_ms, self._w_utc)
        # the epoch's floats, made once here (5 heap objects at most)
        if self._bad_pos:
            w.pos_valid = False
            w.rtk = RTK_NONE
        if self._p_acc != _P_NONE:
            w.h_acc_m = self._hacc_01mm * 0.0001
        if self._p_vel != _P_NONE:
            w.sog_mps = self._sog_e3 * self._sog_k
            w.cog_deg = self._cog_e3 * 0.001
        if self._p_hdg != _P_NONE:
            w.heading_deg = self._hdg_e5 * 0.00001
            w.heading_acc_deg = self._hdg_acc_e5 * 0.00001
        f = self.fix
        f.t_ms = w.t_ms
        f.itow_ms = w.itow_ms
        f.pos_valid = w.pos_valid
        f.lat_e7 = w.lat_e7
        f.lon_e7 = w.lon_e7
        f.lat_hp = w.lat_hp
        f.lon_hp = w.lon_hp
        f.height_mm = w.height_mm
        f.rtk = w.rtk
        f.num_sv = w.num_sv
        f.h_acc_m = w.h_acc_m
        f.heading_valid = w.heading_valid
        f.heading_deg = w.heading_deg
        f.heading_acc_deg = w.heading_acc_deg
        f.vel_valid = w.vel_valid
        f.sog_mps = w.sog_mps
        f.cog_deg = w.cog_deg
        f.utc_s = w.utc_s
        f.utc_ms = w.utc_ms
        f.date = w.date
        f.sources = w.sources
        self._last_itow = w.itow_ms
        self._last_utc = self._w_utc
        self._open = False
        self._done += 1
        self.stats.epochs += 1
        if self.on_epoch is not None:
            self.on_epoch()

    def flush(self, t_ms):
        """Close the open epoch now (end of a capture, or the app's own timeout); returns 0/1."""
        self._t_ms = t_ms
        self._done = 0
        self._close(3)
        return self._done

    def _set_pos(self, prio, lat_e7, lon_e7, lat_hp, lon_hp, height_mm):
        if lat_e7 is None or lon_e7 is None:
            return
        if not (-900000000 <= lat_e7 <= 900000000 and -1800000000 <= lon_e7 <= 1800000000):
            # a checked frame with an impossible position: this epoch has no position
            self.stats.bad_field += 1
            self._bad_pos = True
            return
        if prio < self._p_pos:
            return
        self._p_pos = prio
        w = self._w
        w.lat_e7 = lat_e7
        w.lon_e7 = lon_e7
        w.lat_hp = lat_hp
        w.lon_hp = lon_hp
        if height_mm is not None:
            w.height_mm = height_mm

    def _set_status(self, prio, valid, rtk):
        if prio < self._p_stat:
            return
        self._p_stat = prio
        self._w.pos_valid = valid
        self._w.rtk = rtk if valid else RTK_NONE

    def _set_vel(self, prio, valid, sog_e3, to_mps, cog_e3):
        # kept as ints until the epoch closes: a float is a heap object on MicroPython
        if prio < self._p_vel:
            return
        self._p_vel = prio
        self._w.vel_valid = valid and sog_e3 >= 0
        self._sog_e3 = sog_e3
        self._sog_k = to_mps
        self._cog_e3 = cog_e3 % 360000

    def _pvt_utc(self, r):
        if not r.valid & 0x02:  # validTime
            return -1
        ms = ((r.hour * 60 + r.min) * 60 + r.sec) * 1000
        ms += (r.nano_ns + 5000000) // 10000000 * 10  # nearest 10 ms, as NMEA prints it
        return ms % 86400000

    def _apply_pvt(self, r):
        utc = self._pvt_utc(r)
        if utc >= 0:  # iTOW - UTC (mod one day): lets iTOW-only messages meet NMEA times
            self._utc_off = (r.itow_ms - utc) % 86400000
        if not self._join(r.itow_ms, utc, K_NAV_PVT):
            return
        w = self._w
        ok = (r.flags & 1) and 2 <= r.fix_type <= 4 and not (r.flags3 & 1)
        ok = bool(ok)
        carr = (r.flags >> 6) & 3
        self._set_status(_P_PVT, ok, RTK_FIXED if carr == 2 else RTK_FLOAT if carr == 1
                         else RTK_SINGLE)
        self._set_pos(_P_PVT, r.lat_e7, r.lon_e7, 0, 0, r.height_mm)
        w.num_sv = r.num_sv
        if _P_PVT >= self._p_acc:
            self._p_acc = _P_PVT
            self._hacc_01mm = r.h_acc_mm * 10
        # headMot in 1e-5 deg -> e3 keeps 0.001 deg (int division, no float)
        self._set_vel(_P_PVT, ok, r.g_speed_mms, 0.001, r.head_mot_e5 // 100)
        if r.valid & 0x01:
            w.date = (r.day * 100 + r.month) * 100 + r.year % 100
        self._closing(K_NAV_PVT)

    def _apply_relpos(self, r):
        if not self._join(r.itow_ms, -1, K_NAV_RELPOSNED):
            return
        fl = r.flags
        valid = (fl & 0x105) == 0x105  # gnssFixOK, relPosValid, relPosHeadingValid
        if _P_PVT >= self._p_hdg:
            self._p_hdg = _P_PVT
            self._w.heading_valid = valid
            self._hdg_e5 = (r.heading_e5 + self.heading_offset_e5) % 36000000
            self._hdg_acc_e5 = r.acc_heading_e5
        self._closing(K_NAV_RELPOSNED)

    def _apply_hppos(self, r):
        if not self._join(r.itow_ms, -1, K_NAV_HPPOSLLH):
            return
        # invalidLlh clear, and the high-precision parts in their range (-99..99, 1e-9 deg):
        # anything else is a corrupt frame that would move the position by up to 1.3 e-7 deg
        if not r.flags & 1 and -99 <= r.lat_hp <= 99 and -99 <= r.lon_hp <= 99:
            self._set_pos(_P_HP, r.lat_e7, r.lon_e7, r.lat_hp, r.lon_hp, r.height_mm)
            if _P_HP >= self._p_acc:
                self._p_acc = _P_HP
                self._hacc_01mm = r.h_acc_01mm
        self._closing(K_NAV_HPPOSLLH)

    def _utc_join(self, utc, kind):
        return self._join(-1, utc if utc is not None else -1, kind)

    def _apply_gga(self, r):
        if not self._utc_join(r.utc_ms, K_GGA):
            return
        q = r.quality
        if q is None:
            q = 0
        if q and (r.lat_e7 is None or r.lon_e7 is None):
            self.stats.bad_field += 1  # a fix without a (readable) position
            q = 0
        ok = q in (1, 2, 3, 4, 5)
        rtk = RTK_FIXED if q == 4 else RTK_FLOAT if q == 5 else RTK_SINGLE
        self._set_status(_P_GGA, ok, rtk)
        if ok:
            h = None
            if r.alt_mm is not None and r.sep_mm is not None:
                h = r.alt_mm + r.sep_mm  # ellipsoid height, as NAV-PVT `height`
            self._set_pos(_P_GGA, r.lat_e7, r.lon_e7, 0, 0, h)
            if r.num_sv is not None and self._p_stat == _P_GGA:
                self._w.num_sv = r.num_sv
        self._closing(K_GGA)

    def _apply_rmc(self, r):
        if not self._utc_join(r.utc_ms, K_RMC):
            return
        ok = r.status == 0x41 and r.lat_e7 is not None and r.lon_e7 is not None
        m = r.pos_mode
        rtk = RTK_FIXED if m == 0x52 else RTK_FLOAT if m == 0x46 else RTK_SINGLE
        if m == 0x4E or m == 0x45:  # N none, E estimated (dead reckoning)
            ok = False
        self._set_status(_P_RMC, ok, rtk)
        if ok:
            self._set_pos(_P_RMC, r.lat_e7, r.lon_e7, 0, 0, None)
        if r.date is not None:
            self._w.date = r.date
        if r.sog_kn_e3 is not None:
            self._set_vel(_P_RMC, ok and r.cog_e3 is not None, r.sog_kn_e3, _KN_TO_MPS,
                          r.cog_e3 if r.cog_e3 is not None else 0)
        self._closing(K_RMC)

    def _apply_vtg(self, r):
        # VTG carries no time: it joins the open epoch (or opens one)
        if not self._join(-1, -1, K_VTG):
            return
        ok = r.cog_t_e3 is not None and r.pos_mode != 0x4E
        cog = r.cog_t_e3 if r.cog_t_e3 is not None else 0
        if r.sog_kmh_e3 is not None:
            self._set_vel(_P_RMC, ok, r.sog_kmh_e3, _KMH_TO_MPS, cog)
        elif r.sog_kn_e3 is not None:
            self._set_vel(_P_RMC, ok, r.sog_kn_e3, _KN_TO_MPS, cog)
        self._closing(K_VTG)

    def _apply_gst(self, r):
        if not self._utc_join(r.utc_ms, K_GST):
            return
        if r.sd_lat_e3 is not None and r.sd_lon_e3 is not None and _P_GGA >= self._p_acc:
            self._p_acc = _P_GGA
            a = r.sd_lat_e3
            b = r.sd_lon_e3
            self._hacc_01mm = int(((a * a + b * b) ** 0.5) * 10 + 0.5)
        self._closing(K_GST)

    def _apply_heading(self, heading_e3, valid, kind):
        if not self._join(-1, -1, kind):
            return
        if _P_GGA >= self._p_hdg:
            self._p_hdg = _P_GGA
            self._w.heading_valid = valid
            self._hdg_e5 = (heading_e3 * 100 + self.heading_offset_e5) % 36000000
            self._hdg_acc_e5 = 18000000  # HDT/THS carry no accuracy
        self._closing(kind)
