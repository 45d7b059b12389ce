"""Configure the ZED-F9P over its UART: UBX-CFG-VALSET frames and the ACK/NAK exchange.

    from trackpilot.devices import ubxcfg
    items = ubxcfg.rover_items(rate_ms=200, nmea=("GGA", "RMC"))
    sess = ubxcfg.ConfigSession(ubxcfg.valset_frames(items), timeout_ms=500, retries=3)
    out = sess.start(t_ms)                   # bytes to write to the GNSS UART
    ...on each UBX ACK seen by the GNSS parser (gp.ack):
    out = sess.on_ack(ack.cls, ack.id, ack.ack, t_ms)
    ...periodically:   out = sess.poll(t_ms)   # a retry after a timeout, or None
    sess.state in (ubxcfg.BUSY, ubxcfg.DONE, ubxcfg.FAILED); sess.log lists every step

Pure logic: no UART, no clock; the app writes the returned bytes and injects t_ms.
The configuration enables, on UART1 and once per navigation epoch: NAV-PVT, NAV-RELPOSNED,
NAV-HPPOSLLH and NAV-EOE (the epoch's last message: the GNSS parser closes epochs on it), the
NMEA sentences asked for, and switches the other default NMEA sentences off. Measurement rate:
CFG-RATE-MEAS = 200 ms (5 Hz). Keys are from the u-blox F9 HPG interface description.
"""
from trackpilot.compat import ticks_diff

LAYER_RAM = 1
LAYER_BBR = 2
LAYER_FLASH = 4

# name: key id (bits 28-30 give the value size: 1 bit, 1, 2, 4 or 8 bytes)
KEYS = {
    "CFG-RATE-MEAS": 0x30210001,
    "CFG-RATE-NAV": 0x30210002,
    "CFG-UART1-BAUDRATE": 0x40520001,
    "CFG-UART1OUTPROT-UBX": 0x10740001,
    "CFG-UART1OUTPROT-NMEA": 0x10740002,
    "CFG-UART1INPROT-RTCM3X": 0x10730004,
    "CFG-MSGOUT-UBX_NAV_PVT_UART1": 0x20910007,
    "CFG-MSGOUT-UBX_NAV_RELPOSNED_UART1": 0x2091008E,
    "CFG-MSGOUT-UBX_NAV_HPPOSLLH_UART1": 0x20910034,
    "CFG-MSGOUT-UBX_NAV_EOE_UART1": 0x20910160,
    "CFG-MSGOUT-NMEA_ID_GGA_UART1": 0x209100BB,
    "CFG-MSGOUT-NMEA_ID_RMC_UART1": 0x209100AC,
    "CFG-MSGOUT-NMEA_ID_VTG_UART1": 0x209100B1,
    "CFG-MSGOUT-NMEA_ID_GSA_UART1": 0x209100C0,
    "CFG-MSGOUT-NMEA_ID_GSV_UART1": 0x209100C5,
    "CFG-MSGOUT-NMEA_ID_GLL_UART1": 0x209100CA,
    "CFG-MSGOUT-NMEA_ID_GST_UART1": 0x209100D4,
    "CFG-MSGOUT-NMEA_ID_THS_UART1": 0x209100E3,
}
NMEA_CHOICES = ("GGA", "RMC", "VTG", "GSA", "GSV", "GLL", "GST", "THS")
MAX_KEYS_PER_MSG = 64  # VALSET limit

BUSY = 0
DONE = 1
FAILED = 2
STATE_NAMES = ("busy", "done", "failed")

_CLS_CFG = 0x06
_ID_VALSET = 0x8A


def ubx_frame(cls, msg_id, payload):
    """Complete UBX frame: B5 62 cls id len16 payload ck_a ck_b."""
    n = len(payload)
    out = bytearray(8 + n)
    out[0] = 0xB5
    out[1] = 0x62
    out[2] = cls
    out[3] = msg_id
    out[4] = n & 0xFF
    out[5] = n >> 8
    out[6:6 + n] = payload
    a = b = 0
    for i in range(2, 6 + n):
        a = (a + out[i]) & 0xFF
        b = (b + a) & 0xFF
    out[6 + n] = a
    out[7 + n] = b
    return bytes(out)


def value_size(key):
    """Bytes a key's value takes in VALSET (a 1-bit value takes one byte)."""
    s = (key >> 28) & 7
    if s == 1 or s == 2:
        return 1
    if s == 3:
        return 2
    if s == 4:
        return 4
    if s == 5:
        return 8
    raise ValueError("key 0x%08x has no valid size" % key)


def key_id(name_or_id):
    if isinstance(name_or_id, int):
        return name_or_id
    k = KEYS.get(name_or_id)
    if k is None:
        raise ValueError("unknown configuration key %r" % name_or_id)
    return k


def valset_payload(items, layers=LAYER_RAM):
    """items: sequence of (key name or id, int value) -> CFG-VALSET payload (version 0)."""
    if not 0 < len(items) <= MAX_KEYS_PER_MSG:
        raise ValueError("VALSET takes 1..64 keys, got %d" % len(items))
    if layers & ~7 or not layers:
        raise ValueError("layers must be a non-empty RAM|BBR|FLASH mask")
    out = bytearray((0, layers, 0, 0))
    for name, value in items:
        k = key_id(name)
        n = value_size(k)
        if value < 0 or value >= (1 << (8 * n)) or ((k >> 28) & 7 == 1 and value > 1):
            raise ValueError("value %r does not fit key 0x%08x" % (value, k))
        for i in range(4):
            out.append((k >> (8 * i)) & 0xFF)
        for i in range(n):
            out.append((value >> (8 * i)) & 0xFF)
    return bytes(out)


def valset_frames(items, layers=LAYER_RAM):
    """One or more complete CFG-VALSET frames (64 keys each at most)."""
    frames = []
    for i in range(0, len(items), MAX_KEYS_PER_MSG):
        frames.append(ubx_frame(_CLS_CFG, _ID_VALSET,
                                valset_payload(items[i:i + MAX_KEYS_PER_MSG], layers)))
    return frames


def rover_items(rate_ms=200, nmea=("GGA", "RMC"), eoe=True, hppos=True, baudrate=None,
                rtcm_in=True):
    """The key/value list for the boat's moving-base rover on UART1 (see module doc)."""
    if not 25 <= rate_ms <= 10000:
        raise ValueError("rate_ms out of range 25..10000")
    for s in nmea:
        if s not in NMEA_CHOICES:
            raise ValueError("NMEA sentence %r not configurable here (%s)"
                             % (s, ",".join(NMEA_CHOICES)))
    items = [
        ("CFG-RATE-MEAS", rate_ms),
        ("CFG-RATE-NAV", 1),
        ("CFG-UART1OUTPROT-UBX", 1),
        ("CFG-UART1OUTPROT-NMEA", 1 if nmea else 0),
        ("CFG-MSGOUT-UBX_NAV_PVT_UART1", 1),
        ("CFG-MSGOUT-UBX_NAV_RELPOSNED_UART1", 1),
        ("CFG-MSGOUT-UBX_NAV_HPPOSLLH_UART1", 1 if hppos else 0),
        ("CFG-MSGOUT-UBX_NAV_EOE_UART1", 1 if eoe else 0),
    ]
    if rtcm_in:
        items.append(("CFG-UART1INPROT-RTCM3X", 1))
    for s in NMEA_CHOICES:
        items.append(("CFG-MSGOUT-NMEA_ID_%s_UART1" % s, 1 if s in nmea else 0))
    if baudrate is not None:
        items.append(("CFG-UART1-BAUDRATE", baudrate))
    return items


class ConfigSession:
    """Send frames one by one; each must be acknowledged (ACK-ACK for CFG-VALSET) before the
    next. A NAK or `timeout_ms` without an answer resends it, up to `retries` resends; then the
    session FAILED (the app reports it and runs with what the receiver sends)."""

    def __init__(self, frames, timeout_ms=500, retries=3):
        if not frames:
            raise ValueError("nothing to send")
        self.frames = list(frames)
        self.timeout_ms = timeout_ms
        self.retries = retries
        self.state = BUSY
        self.index = 0  # frame being sent
        self.attempts = 0  # sends of the current frame
        self.naks = 0
        self.timeouts = 0
        self.sent_ms = 0
        self.started = False
        self.log = []  # (t_ms, text) for every step

    def _send(self, t_ms):
        self.attempts += 1
        self.sent_ms = t_ms
        self.log.append((t_ms, "send frame %d try %d" % (self.index, self.attempts)))
        return self.frames[self.index]

    def _retry(self, t_ms, why):
        if self.attempts > self.retries:
            self.state = FAILED
            self.log.append((t_ms, "frame %d failed after %d tries (%s)"
                             % (self.index, self.attempts, why)))
            return None
        return self._send(t_ms)

    def start(self, t_ms):
        """Bytes to write now (the first frame)."""
        self.started = True
        return self._send(t_ms)

    def on_ack(self, cls, msg_id, ack, t_ms):
        """Feed a received ACK-ACK (ack=True) / ACK-NAK for (cls, msg_id); returns bytes to send
        next or None. ACKs for other messages are ignored."""
        if self.state != BUSY or not self.started:
            return None
        f = self.frames[self.index]
        if cls != f[2] or msg_id != f[3]:
            return None
        if ack:
            self.log.append((t_ms, "frame %d acknowledged" % self.index))
            self.index += 1
            self.attempts = 0
            if self.index >= len(self.frames):
                self.state = DONE
                self.log.append((t_ms, "configuration done"))
                return None
            return self._send(t_ms)
        self.naks += 1
        self.log.append((t_ms, "frame %d refused (NAK)" % self.index))
        return self._retry(t_ms, "NAK")

    def poll(self, t_ms):
        """Call periodically; returns bytes to resend after a timeout, else None."""
        if self.state != BUSY or not self.started:
            return None
        if ticks_diff(t_ms, self.sent_ms) >= self.timeout_ms:
            self.timeouts += 1
            self.log.append((t_ms, "frame %d: no answer in %d ms" % (self.index,
                                                                     self.timeout_ms)))
            return self._retry(t_ms, "timeout")
        return None
