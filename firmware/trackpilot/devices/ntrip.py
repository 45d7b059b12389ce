"""NTRIP client: RTK corrections from a caster (over Wi-Fi to the boat's 4G router) to the receiver.

The core (`NtripSession`) builds the request, checks the caster's answer, frames RTCM3 (preamble 0xD3,
10-bit length, CRC-24Q) so only whole, valid frames are forwarded, and keeps the age of the last
correction. The shell (`run_client`) is an asyncio TCP client that reconnects with back-off and
forwards the frames to the GNSS UART; it sends the boat's GGA every `gga_interval_s` for network
(VRS) mountpoints.

Casters answer in three ways, all accepted: NTRIP 1.0 `ICY 200 OK` (often with no blank line after
it, as RTKLIB also accepts), HTTP/1.x 200 with a plain stream, and NTRIP 2.0 HTTP/1.1 200 with
`Transfer-Encoding: chunked` (the chunk framing is removed before the RTCM framer). Whatever a
caster sends (non-UTF-8 status text, odd chunk sizes) ends at most this connection with a logged
reason; run_client catches every error per connection and reconnects with back-off.

Usage:
    s = NtripSession("caster.example", 2101, "MOUNT", "user", "pass")
    sock.write(s.request())
    for frame in s.feed(data, t_ms): gnss_uart.write(frame)
    s.age_s(t_ms)    # seconds since the last good frame, None before the first
"""
import binascii

from trackpilot.compat import ticks_diff

try:
    import asyncio
except ImportError:  # pragma: no cover
    asyncio = None

_MAX_FRAME = 1029  # 3 header + 1023 payload + 3 CRC
_MAX_HEADER = 4096
_MAX_CHUNK_LINE = 80  # hex size plus chunk extensions


def printable(raw, n=80):
    """Caster text for the log: ASCII only (the caster may send any bytes; MicroPython's decode
    has no errors="replace")."""
    return "".join(chr(b) if 32 <= b < 127 else "?" for b in raw[:n])


def crc24q(data, start, end):
    crc = 0
    for i in range(start, end):
        crc ^= data[i] << 16
        for _ in range(8):
            crc <<= 1
            if crc & 0x1000000:
                crc ^= 0x1864CFB
    return crc & 0xFFFFFF


class NtripSession:
    """One connection's protocol state. Bytes in, whole RTCM3 frames out."""

    def __init__(self, host, port, mountpoint, user="", password="", agent="NTRIP trackpilot/0.1"):
        self.host = host
        self.port = port
        self.mountpoint = mountpoint
        self.user = user
        self.password = password
        self.agent = agent
        self.header_done = False
        self.error = ""
        self._hdr = bytearray()
        self._buf = bytearray()
        self.chunked = False
        self._chunk_left = -1  # bytes left in the current chunk; -1: reading a size line
        self._chunk_line = bytearray()
        self._chunk_crlf = False  # the CRLF after a chunk's data is still to come
        self.frames = 0
        self.bad_crc = 0
        self.skipped = 0
        self.last_frame_ms = None

    def request(self):
        lines = [
            "GET /%s HTTP/1.1" % self.mountpoint,
            "Host: %s:%d" % (self.host, self.port),
            "Ntrip-Version: Ntrip/2.0",
            "User-Agent: %s" % self.agent,
            "Connection: close",
        ]
        if self.user:
            token = binascii.b2a_base64(("%s:%s" % (self.user, self.password)).encode()).strip()
            lines.append("Authorization: Basic %s" % token.decode())
        return ("\r\n".join(lines) + "\r\n\r\n").encode()

    def _header(self, data):
        self._hdr.extend(data)
        hdr = self._hdr
        eol = hdr.find(b"\r\n")
        if eol >= 0 and hdr.startswith(b"ICY 200"):
            # NTRIP 1.0: the status line alone, a blank line after it or not
            rest = bytes(hdr[eol + 2 :])
            if rest.startswith(b"\r\n"):
                rest = rest[2:]
            self._hdr = bytearray()
            self.header_done = True
            return rest
        end = hdr.find(b"\r\n\r\n")
        if end < 0:
            if len(hdr) > _MAX_HEADER:
                self.error = "caster answer without end of header: %s" % printable(hdr)
            return b""
        head = bytes(hdr[:end])
        rest = bytes(hdr[end + 4 :])
        self._hdr = bytearray()
        lines = head.split(b"\r\n")
        first = lines[0]
        if first.startswith(b"HTTP/1.") and b" 200" in first[:13]:
            for line in lines[1:]:
                name, _, value = line.partition(b":")
                if name.strip().lower() == b"transfer-encoding" and b"chunked" in value.lower():
                    self.chunked = True
            self.header_done = True
            return rest
        if first.startswith(b"SOURCETABLE"):
            self.error = "mountpoint %r not found (caster sent its source table)" % self.mountpoint
        else:
            self.error = "caster refused: %s" % printable(first)
        return b""

    def _dechunk(self, data):
        """HTTP/1.1 chunked transfer: the payload bytes of `data` (sizes and CRLFs removed)."""
        out = bytearray()
        i = 0
        n = len(data)
        while i < n and not self.error:
            if self._chunk_left > 0:  # inside a chunk's data
                take = min(self._chunk_left, n - i)
                out.extend(data[i : i + take])
                i += take
                self._chunk_left -= take
                if self._chunk_left == 0:
                    self._chunk_crlf = True
                    self._chunk_left = -1
                continue
            b = data[i]
            i += 1
            if self._chunk_crlf:  # the CR LF that ends a chunk's data
                if b == 0x0A:
                    self._chunk_crlf = False
                elif b != 0x0D:
                    self.error = "bad chunked transfer: no CRLF after a chunk"
                continue
            if b != 0x0A:
                if len(self._chunk_line) >= _MAX_CHUNK_LINE:
                    self.error = "bad chunked transfer: chunk size line too long"
                else:
                    self._chunk_line.append(b)
                continue
            line = bytes(self._chunk_line).split(b";")[0].strip()
            self._chunk_line = bytearray()
            try:
                size = int(printable(line), 16)
            except ValueError:
                self.error = "bad chunked transfer: chunk size %r" % printable(line)
                break
            if size == 0:
                self.error = "caster ended the stream"
                break
            self._chunk_left = size
        return bytes(out)

    def feed(self, data, t_ms):
        """Bytes from the caster -> list of whole RTCM3 frames (bytes) to forward."""
        if self.error:
            return []
        if not self.header_done:
            data = self._header(data)
            if not data:
                return []
        if self.chunked:
            data = self._dechunk(data)
        buf = self._buf
        buf.extend(data)
        out = []
        while True:
            i = buf.find(b"\xd3")
            if i < 0:
                self.skipped += len(buf)
                buf[:] = b""
                break
            if i:
                self.skipped += i
                buf[:i] = b""
            if len(buf) < 3:
                break
            length = ((buf[1] & 0x03) << 8) | buf[2]
            if buf[1] & 0xFC:  # the 6 reserved bits are zero in RTCM 3
                self.skipped += 1
                buf[:1] = b""
                continue
            n = 3 + length + 3
            if len(buf) < n:
                break
            crc = (buf[n - 3] << 16) | (buf[n - 2] << 8) | buf[n - 1]
            if crc24q(buf, 0, n - 3) == crc:
                out.append(bytes(buf[:n]))
                self.frames += 1
                self.last_frame_ms = t_ms
                buf[:n] = b""
            else:
                self.bad_crc += 1
                buf[:1] = b""
        if len(buf) > _MAX_FRAME:  # cannot happen with the checks above; bound it anyway
            self.skipped += len(buf)
            buf[:] = b""
        return out

    def age_s(self, t_ms):
        if self.last_frame_ms is None:
            return None
        return ticks_diff(t_ms, self.last_frame_ms) / 1000.0


async def run_client(cfg, forward, clock, gga=None, events=None, stop=None):
    """Connect, forward frames, reconnect with back-off (2 s doubling to 60 s). `forward(frame)`
    writes to the GNSS UART; `gga()` returns the current GGA sentence (bytes) or None; `events`
    is a callable(kind, text) for the log. Returns when `stop` (an asyncio.Event) is set; never
    because of what a caster sent (any error ends only that connection, logged)."""
    delay_s = 2
    session = None
    while stop is None or not stop.is_set():
        session = NtripSession(cfg["host"], cfg["port"], cfg["mountpoint"], cfg["user"], cfg["password"])
        _state[0] = session
        writer = None
        try:
            reader, writer = await asyncio.open_connection(cfg["host"], cfg["port"])
            writer.write(session.request())
            await writer.drain()
            if events:
                events("NTRIP", "connected to %s:%d/%s" % (cfg["host"], cfg["port"], cfg["mountpoint"]))
            last_gga = clock()
            while stop is None or not stop.is_set():
                try:
                    data = await asyncio.wait_for_ms(reader.read(512), 5000)
                except asyncio.TimeoutError:
                    data = None
                    if events:
                        events("NTRIP", "no data for 5 s")
                    break
                if not data:
                    break
                t = clock()
                for frame in session.feed(data, t):
                    forward(frame)
                if session.error:
                    if events:
                        events("NTRIP", session.error)
                    break
                if session.header_done and delay_s > 2:
                    delay_s = 2
                if gga is not None and cfg.get("gga_interval_s", 0) and ticks_diff(t, last_gga) > cfg["gga_interval_s"] * 1000:
                    sentence = gga()
                    if sentence:
                        writer.write(sentence)
                        await writer.drain()
                    last_gga = t
        except OSError as e:
            if events:
                events("NTRIP", "connection failed: %s" % e)
        except Exception as e:  # noqa: BLE001 -- a bug or an odd caster: log it, reconnect
            if events:
                events("NTRIP", "connection ended by an error: %s: %s" % (type(e).__name__, e))
        if writer is not None:
            try:
                writer.close()
            except Exception:  # noqa: BLE001 -- closing a broken socket
                pass
        if stop is not None and stop.is_set():
            break
        await asyncio.sleep(delay_s)
        delay_s = min(60, delay_s * 2)
    return session


_state = [None]  # the current session, for status display and tests


def current_session():
    return _state[0]
