"""The simulator side of docs/SIM_PROTOCOL.md: STEP frames out, REPORT frames in."""
import struct

MAGIC = 0xA5
KIND_STEP = 0x53
KIND_REPORT = 0x52
NO_WAKE = 0xFFFFFFFF
_HDR = struct.Struct("<BBIIB")
_CH = struct.Struct("<BH")

DEV_GNSS, DEV_SEATALK, DEV_MOTOR, DEV_WIND, DEV_IO, DEV_TELEMETRY = 1, 2, 3, 4, 5, 6


class ProtocolError(Exception):
    pass


def encode_step(t_ms, chunks):
    """chunks: {dev: bytes}."""
    out = [_HDR.pack(MAGIC, KIND_STEP, t_ms, 0, len(chunks))]
    for dev, data in chunks.items():
        out.append(_CH.pack(dev, len(data)))
        out.append(data)
    return b"".join(out)


def _read_exact(f, n):
    buf = f.read(n)
    if buf is None or len(buf) < n:
        # pipes may return short reads
        parts = [buf or b""]
        got = len(parts[0])
        while got < n:
            more = f.read(n - got)
            if not more:
                return None
            parts.append(more)
            got += len(more)
        buf = b"".join(parts)
    return buf


def read_report(f):
    """-> (t_ms, wake_ms, {dev: bytes}) or None at EOF."""
    hdr = _read_exact(f, _HDR.size)
    if hdr is None:
        return None
    magic, kind, t_ms, wake_ms, n = _HDR.unpack(hdr)
    if magic != MAGIC or kind != KIND_REPORT:
        raise ProtocolError("bad REPORT header %r" % hdr)
    chunks = {}
    for _ in range(n):
        ch = _read_exact(f, _CH.size)
        if ch is None:
            return None
        dev, length = _CH.unpack(ch)
        data = _read_exact(f, length) if length else b""
        if data is None:
            return None
        chunks[dev] = chunks.get(dev, b"") + data
    return t_ms, wake_ms, chunks
