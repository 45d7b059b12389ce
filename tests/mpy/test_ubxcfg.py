# UBX-CFG-VALSET frames and the ACK/NAK session (runs under MicroPython). The bytes are checked
# against pyubx2 in tests/host/test_ubxcfg_pyubx2.py.
import tpassert as t

from trackpilot.devices import gnss, ubxcfg
from trackpilot.nav.fix import Fix


def _ack(frame, ok=True):
    cls_id = bytes((frame[2], frame[3]))
    return ubxcfg.ubx_frame(0x05, 0x01 if ok else 0x00, cls_id)


def test_valset_layout():
    p = ubxcfg.valset_payload([("CFG-RATE-MEAS", 200), ("CFG-UART1OUTPROT-UBX", 1),
                               ("CFG-UART1-BAUDRATE", 115200)], ubxcfg.LAYER_RAM)
    t.eq(p, bytes((0, 1, 0, 0, 0x01, 0x00, 0x21, 0x30, 200, 0, 0x01, 0x00, 0x74, 0x10, 1,
                   0x01, 0x00, 0x52, 0x40, 0x00, 0xC2, 0x01, 0x00)))
    t.raises(ValueError, ubxcfg.valset_payload, [("CFG-RATE-MEAS", 70000)])
    t.raises(ValueError, ubxcfg.valset_payload, [("CFG-UART1OUTPROT-UBX", 2)])
    t.raises(ValueError, ubxcfg.valset_payload, [("CFG-NOPE", 1)])
    t.raises(ValueError, ubxcfg.valset_payload, [])
    t.raises(ValueError, ubxcfg.rover_items, 10)
    t.raises(ValueError, ubxcfg.rover_items, 200, ("GGA", "XYZ"))


def test_frames_parse_back_and_acks_decode():
    frames = ubxcfg.valset_frames(ubxcfg.rover_items())
    t.eq(len(frames), 1)
    gp = gnss.GnssParser(Fix())
    seen = []
    gp.on_msg = lambda k: seen.append((k, gp.other.cls, gp.other.id, gp.ack.cls, gp.ack.id))
    data = frames[0] + _ack(frames[0]) + _ack(frames[0], False)
    gp.feed(data, len(data), 0)
    t.eq(seen[0][:3], (gnss.K_UBX_OTHER, 0x06, 0x8A))
    t.eq(seen[1][0], gnss.K_ACK_ACK)
    t.eq(seen[1][3:], (0x06, 0x8A))
    t.eq(seen[2][0], gnss.K_ACK_NAK)
    many = [("CFG-RATE-MEAS", 200)] * 65
    t.eq(len(ubxcfg.valset_frames(many)), 2)


def test_session_ack_nak_timeout_and_failure():
    frames = ubxcfg.valset_frames([("CFG-RATE-MEAS", 200)] * 65)
    s = ubxcfg.ConfigSession(frames, timeout_ms=500, retries=2)
    t.eq(s.start(0), frames[0])
    t.eq(s.poll(499), None)
    t.eq(s.on_ack(0x06, 0x8B, True, 10), None)  # an ACK for another message
    t.eq(s.on_ack(0x06, 0x8A, True, 20), frames[1])
    t.eq(s.on_ack(0x06, 0x8A, False, 30), frames[1])  # NAK: resend
    t.eq(s.poll(529), None)
    t.eq(s.poll(530), frames[1])  # timeout: resend
    t.eq(s.attempts, 3)
    t.eq(s.poll(1030), None)  # third resend would exceed retries=2
    t.eq(s.state, ubxcfg.FAILED)
    t.eq(s.on_ack(0x06, 0x8A, True, 1040), None)
    t.eq((s.naks, s.timeouts), (1, 2))
    t.true(len(s.log) >= 6)
    s = ubxcfg.ConfigSession(frames[:1], timeout_ms=100, retries=0)
    s.start((1 << 30) - 50)  # ticks wrap
    t.eq(s.poll(49), None)
    t.eq(s.on_ack(0x06, 0x8A, True, 60), None)
    t.eq(s.state, ubxcfg.DONE)
