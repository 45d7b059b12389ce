"""RPM-setpoint link to the motor controller, and an analog/PWM throttle mapping.

The Sinus Leistungssteller SLS60-240's RS232 protocol is not public. The frames here are this
project's OWN placeholder format ("trackpilot motor frame", docs/MOTOR_LINK.md), NOT the SLS
protocol; what must be confirmed with the vendor is listed there. Pure logic: no I/O, no clock.

Frames (FMT_ASCII, the default; readable on a terminal):
    to the controller:   S<rpm>\\r          e.g. b"S1200\\r", b"S-300\\r", b"S0\\r"
    reply (if any):      R<rpm>,<mV>,<status>\\r   e.g. b"R1187,48120,0\\r"
FMT_BINARY:
    to the controller:   A5 01 rpm_lo rpm_hi ck           (rpm int16 LE; ck = XOR of the bytes before)
    reply:               5A 81 rpm_lo rpm_hi mv_lo mv_hi status ck

Usage:
    link = MotorLink(fmt=FMT_ASCII, keepalive_ms=200, reply_timeout_ms=1500, low_batt_mv=44000)
    link.set_rpm(800)
    frame = link.poll(t_ms)      # bytes to write now, or None (on change or every keepalive_ms)
    link.feed(uart_bytes, t_ms)  # replies: rpm, batt_mv, status, link_ok
    ev = link.pop_event()        # (EV_LINK_LOST|EV_LINK_OK|EV_LOW_BATT|EV_BATT_OK, t_ms, text)
    duty = rpm_to_duty_u16(800, rpm_full=1500)   # analog throttle via PWM + RC filter
"""
from trackpilot.compat import const, ticks_add, ticks_diff

FMT_ASCII = const(0)
FMT_BINARY = const(1)
_START_TX = const(0xA5)
_START_RX = const(0x5A)
_CMD_SET = const(0x01)
_CMD_REPLY = const(0x81)
RPM_LIMIT = const(32767)  # int16 in the binary frame

EV_LINK_LOST = "MOTOR_LINK_LOST"
EV_LINK_OK = "MOTOR_LINK_OK"
EV_LOW_BATT = "LOW_BATTERY"
EV_BATT_OK = "BATTERY_OK"

_LINE_MAX = const(32)


def _xor(buf, n):
    c = 0
    for i in range(n):
        c ^= buf[i]
    return c


def encode_set(rpm, fmt=FMT_ASCII):
    """The setpoint frame for `rpm` (int, -32767..32767)."""
    rpm = int(rpm)
    if rpm < -RPM_LIMIT or rpm > RPM_LIMIT:
        raise ValueError("rpm %d outside +-%d" % (rpm, RPM_LIMIT))
    if fmt == FMT_ASCII:
        return b"S%d\r" % rpm
    v = rpm & 0xFFFF
    b = bytearray((_START_TX, _CMD_SET, v & 0xFF, v >> 8, 0))
    b[4] = _xor(b, 4)
    return bytes(b)


def encode_reply(rpm, batt_mv, status=0, fmt=FMT_ASCII):
    """A controller reply (used by motor_sim and tests)."""
    rpm = max(-RPM_LIMIT, min(RPM_LIMIT, int(rpm)))
    batt_mv = max(0, min(65535, int(batt_mv)))
    if fmt == FMT_ASCII:
        return b"R%d,%d,%d\r" % (rpm, batt_mv, status & 0xFF)
    v = rpm & 0xFFFF
    b = bytearray((_START_RX, _CMD_REPLY, v & 0xFF, v >> 8, batt_mv & 0xFF, batt_mv >> 8, status & 0xFF, 0))
    b[7] = _xor(b, 7)
    return bytes(b)


def _s16(lo, hi):
    v = lo | (hi << 8)
    return v - 65536 if v > 32767 else v


class FrameParser:
    """Byte-stream parser for either direction of either format (bounded buffer, resyncs).
    feed_byte(b) returns a tuple when a frame completes: ("S", rpm) or ("R", rpm, mv, status)."""

    def __init__(self, fmt=FMT_ASCII):
        self.fmt = fmt
        self._buf = bytearray(_LINE_MAX)
        self._n = 0
        self.errors = 0

    def feed_byte(self, b):
        if self.fmt == FMT_ASCII:
            return self._ascii(b)
        return self._binary(b)

    def _ascii(self, b):
        if b == 0x0D or b == 0x0A:
            n = self._n
            self._n = 0
            if n == 0:
                return None
            try:
                return self._parse_line(bytes(self._buf[:n]))
            except (ValueError, IndexError):
                self.errors += 1
                return None
        if b == 0x53 or b == 0x52:  # 'S' / 'R' always start a frame (resync after junk)
            if self._n:
                self.errors += 1
            self._buf[0] = b
            self._n = 1
            return None
        if self._n == 0:
            self.errors += 1  # junk between frames
            return None
        if self._n >= _LINE_MAX:
            self._n = 0
            self.errors += 1
            return None
        self._buf[self._n] = b
        self._n += 1
        return None

    @staticmethod
    def _parse_line(line):
        kind = line[0]
        body = line[1:].decode()
        if kind == 0x53:
            return ("S", int(body))
        parts = body.split(",")
        if len(parts) != 3:
            raise ValueError("reply needs rpm,mV,status")
        return ("R", int(parts[0]), int(parts[1]), int(parts[2]))

    def _binary(self, b):
        buf = self._buf
        n = self._n
        if n == 0:
            if b == _START_TX or b == _START_RX:
                buf[0] = b
                self._n = 1
            else:
                self.errors += 1
            return None
        buf[n] = b
        n += 1
        want = 5 if buf[0] == _START_TX else 8
        if n == 2 and b != (_CMD_SET if buf[0] == _START_TX else _CMD_REPLY):
            self.errors += 1
            self._n = 0
            return self._binary(b)  # this byte may be a start
        if n < want:
            self._n = n
            return None
        self._n = 0
        if _xor(buf, want - 1) != buf[want - 1]:
            self.errors += 1
            return None
        if want == 5:
            return ("S", _s16(buf[2], buf[3]))
        return ("R", _s16(buf[2], buf[3]), buf[4] | (buf[5] << 8), buf[6])


class MotorLink:
    def __init__(self, fmt=FMT_ASCII, keepalive_ms=200, reply_timeout_ms=1500, expect_replies=True,
                 rpm_min=-1500, rpm_max=1500, low_batt_mv=44000, low_batt_hyst_mv=500,
                 low_batt_hold_ms=5000, events_len=8):
        if isinstance(fmt, str):
            fmt = FMT_BINARY if fmt == "binary" else FMT_ASCII
        self.fmt = fmt
        self.keepalive_ms = keepalive_ms
        self.reply_timeout_ms = reply_timeout_ms
        self.expect_replies = expect_replies
        self.rpm_min = rpm_min
        self.rpm_max = rpm_max
        self.low_batt_mv = low_batt_mv
        self.low_batt_hyst_mv = low_batt_hyst_mv
        self.low_batt_hold_ms = low_batt_hold_ms
        self._parser = FrameParser(fmt)
        self._evmax = events_len
        self._ev = []
        self.rpm_set = 0  # setpoint after clamping
        self._sent_rpm = None
        self._next_ms = None
        self._first_tx = None
        self._last_reply = None
        # read back (None until a reply)
        self.rpm = None
        self.batt_mv = None
        self.status = None
        self.link_ok = None  # None = unknown (no replies expected, or none yet)
        self.low_batt = False
        self._low_since = None
        # counters
        self.frames_sent = 0
        self.replies = 0

    @classmethod
    def from_config(cls, motor_cfg):
        """Build from the config's "motor" section (frame, keepalive_ms, reply_timeout_ms,
        expect_replies, rpm_max, low_battery_v); reverse is allowed down to -rpm_max."""
        rpm_max = motor_cfg.get("rpm_max", 1500)
        return cls(fmt=motor_cfg.get("frame", "ascii"), keepalive_ms=motor_cfg.get("keepalive_ms", 200),
                   reply_timeout_ms=motor_cfg.get("reply_timeout_ms", 1500),
                   expect_replies=motor_cfg.get("expect_replies", True), rpm_min=-rpm_max,
                   rpm_max=rpm_max, low_batt_mv=int(motor_cfg.get("low_battery_v", 44.0) * 1000))

    @property
    def battery_v(self):
        """Battery voltage from the last reply, or None."""
        return None if self.batt_mv is None else self.batt_mv / 1000.0

    def duty_u16(self, duty_idle_u16=0, duty_full_u16=65535):
        """The current setpoint as a PWM duty for an analog throttle (see rpm_to_duty_u16)."""
        return rpm_to_duty_u16(self.rpm_set, self.rpm_max, duty_idle_u16, duty_full_u16)

    @property
    def parse_errors(self):
        return self._parser.errors

    def pop_event(self):
        return self._ev.pop(0) if self._ev else None

    def _event(self, name, t_ms, text):
        if len(self._ev) >= self._evmax:
            self._ev.pop(0)
        self._ev.append((name, t_ms, text))

    def set_rpm(self, rpm):
        """New setpoint, clamped to rpm_min..rpm_max; the next poll sends it."""
        r = float(rpm)
        if not (r == r) or r in (float("inf"), float("-inf")):
            raise ValueError("rpm must be a finite number, got %r" % (rpm,))
        r = int(r + 0.5) if r >= 0 else -int(-r + 0.5)
        self.rpm_set = max(self.rpm_min, min(self.rpm_max, r))

    def poll(self, t_ms):
        """A frame to write now (bytes) or None. Also runs the link-loss and battery timers."""
        if self.expect_replies and self._first_tx is not None:
            ref = self._last_reply if self._last_reply is not None else self._first_tx
            if ticks_diff(t_ms, ref) > self.reply_timeout_ms and self.link_ok is not False:
                self.link_ok = False
                self._event(EV_LINK_LOST, t_ms, "no reply for %d ms" % ticks_diff(t_ms, ref))
        if self._low_since is not None and not self.low_batt:
            if ticks_diff(t_ms, self._low_since) >= self.low_batt_hold_ms:
                self.low_batt = True
                self._event(EV_LOW_BATT, t_ms, "battery %d mV below %d mV" % (self.batt_mv, self.low_batt_mv))
        due = (self._sent_rpm != self.rpm_set or self._next_ms is None
               or ticks_diff(t_ms, self._next_ms) >= 0)
        if not due:
            return None
        self._sent_rpm = self.rpm_set
        self._next_ms = ticks_add(t_ms, self.keepalive_ms)
        if self._first_tx is None:
            self._first_tx = t_ms
        self.frames_sent += 1
        return encode_set(self.rpm_set, self.fmt)

    def feed(self, data, t_ms):
        """Bytes from the controller. Returns the number of replies parsed."""
        got = 0
        for b in data:
            r = self._parser.feed_byte(b)
            if r is None or r[0] != "R":
                continue
            got += 1
            self.replies += 1
            self.rpm, self.batt_mv, self.status = r[1], r[2], r[3]
            self._last_reply = t_ms
            if self.link_ok is not True:
                self.link_ok = True
                self._event(EV_LINK_OK, t_ms, "replies from the controller")
            self._battery(t_ms)
        return got

    def _battery(self, t_ms):
        mv = self.batt_mv
        if mv < self.low_batt_mv:
            if self._low_since is None:
                self._low_since = t_ms  # must stay low for low_batt_hold_ms (sag under load)
        else:
            self._low_since = None
            if self.low_batt and mv >= self.low_batt_mv + self.low_batt_hyst_mv:
                self.low_batt = False
                self._event(EV_BATT_OK, t_ms, "battery %d mV" % mv)


def rpm_to_duty_u16(rpm, rpm_full, duty_idle_u16=0, duty_full_u16=65535):
    """Analog throttle: PWM duty (0..65535, for machine.PWM.duty_u16) for `rpm`; linear from
    duty_idle at 0 rpm to duty_full at rpm_full; negative rpm and rpm above rpm_full clamp (an
    analog throttle has no reverse here; a controller that needs a centred input uses
    duty_idle_u16 = 32768)."""
    if rpm_full <= 0:
        raise ValueError("rpm_full must be > 0")
    f = float(rpm) / rpm_full
    if not (f > 0.0):  # also NaN
        f = 0.0
    elif f > 1.0:
        f = 1.0
    d = int(duty_idle_u16 + (duty_full_u16 - duty_idle_u16) * f + 0.5)
    return max(0, min(65535, d))
