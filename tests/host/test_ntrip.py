"""The firmware's NTRIP client (under MicroPython) against a small caster stand-in on loopback."""
import base64
import io
import socket
import threading

import pytest
from pyrtcm import RTCMReader

from trackpilot_tools.mpy import ROOT, run_script

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)


def _crc24q(data):
    crc = 0
    for b in data:
        crc ^= b << 16
        for _ in range(8):
            crc <<= 1
            if crc & 0x1000000:
                crc ^= 0x1864CFB
    return crc & 0xFFFFFF


def rtcm_frame(msg_type, body_len):
    payload = bytearray(body_len)
    payload[0] = msg_type >> 4
    payload[1] = (msg_type & 0xF) << 4
    for i in range(2, body_len):
        payload[i] = (i * 37) & 0xFF
    head = bytes([0xD3, (body_len >> 8) & 3, body_len & 0xFF]) + bytes(payload)
    return head + _crc24q(head).to_bytes(3, "big")


class Caster:
    """Answers one NTRIP request per connection: the stream for MOUNT, a source table otherwise.
    `answers`: the status/header sent on each connection in turn (the last one repeats); an answer
    without " 200" closes the connection. `chunk`: NTRIP 2.0 chunked transfer with chunks of this
    many bytes."""

    def __init__(self, frames, garbage=b"", answers=(b"ICY 200 OK\r\n\r\n",), chunk=0):
        self.frames = frames
        self.garbage = garbage
        self.answers = list(answers)
        self.chunk = chunk
        self.sock = socket.socket()
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(2)
        self.port = self.sock.getsockname()[1]
        self.requests = []
        self.thread = threading.Thread(target=self.serve, daemon=True)
        self.thread.start()

    def serve(self):
        self.sock.settimeout(15)
        for n in range(len(self.answers)):
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.serve_one(conn, self.answers[n])

    def serve_one(self, conn, answer):
        with conn:
            req = b""
            while b"\r\n\r\n" not in req:
                chunk = conn.recv(1024)
                if not chunk:
                    return
                req += chunk
            self.requests.append(req)
            if not req.startswith(b"GET /MOUNT "):
                conn.sendall(b"SOURCETABLE 200 OK\r\nContent-Type: text/plain\r\n\r\nSTR;MOUNT;\r\nENDSOURCETABLE\r\n")
                return
            conn.sendall(answer)
            if b" 200" not in answer:
                return
            body = self.garbage + b"".join(self.frames)
            if self.chunk:
                for i in range(0, len(body), self.chunk):
                    part = body[i : i + self.chunk]
                    conn.sendall(b"%x\r\n" % len(part) + part + b"\r\n")
            else:
                conn.sendall(body)
            try:
                conn.recv(1)
            except OSError:
                pass


def test_frames_are_valid_rtcm():
    frame = rtcm_frame(1005, 19)
    msg = RTCMReader(io.BytesIO(frame)).read()[1]
    assert msg.identity == "1005"


def test_client_forwards_whole_frames_and_skips_corrupt():
    good = [rtcm_frame(1077, 120), rtcm_frame(1087, 90), rtcm_frame(1005, 19), rtcm_frame(1230, 8)]
    corrupt = bytearray(rtcm_frame(1097, 60))
    corrupt[20] ^= 0xFF
    caster = Caster(good[:2] + [bytes(corrupt)] + good[2:], garbage=b"\x00junk\xd3\xff")
    out = run_script(ROOT / "tests/host/_ntrip_client_mpy.py", [caster.port, "MOUNT", len(good)], timeout=60).stdout.decode()
    lines = dict(line.split(" ", 1) for line in out.strip().splitlines() if not line.startswith("event"))
    assert lines["frames"] == str(len(good)), out
    assert lines["bytes"] == str(sum(len(f) for f in good)), out
    assert int(lines["bad_crc"]) >= 1, out
    assert lines["age_ok"] == "True", out
    req = caster.requests[0]
    assert b"Ntrip-Version: Ntrip/2.0" in req
    assert b"Authorization: Basic " + base64.b64encode(b"boat:secret") in req


def test_unknown_mountpoint_is_reported():
    caster = Caster([])
    out = run_script(ROOT / "tests/host/_ntrip_client_mpy.py", [caster.port, "NOPE", 1], timeout=60).stdout.decode()
    assert "frames 0" in out
    assert "not found" in out, out


def _run(caster, want, *extra):
    out = run_script(ROOT / "tests/host/_ntrip_client_mpy.py", [caster.port, "MOUNT", want, *extra],
                     timeout=60).stdout.decode()
    lines = dict(line.split(" ", 1) for line in out.strip().splitlines() if not line.startswith("event"))
    return out, lines


CHUNKED_OK = b"HTTP/1.1 200 OK\r\nContent-Type: gnss/data\r\nTransfer-Encoding: chunked\r\n\r\n"


@pytest.mark.parametrize("chunk", [64, 256, 512, 1024])
def test_ntrip2_chunked_transfer_all_frames_arrive(chunk):
    """Issue 14.8: chunk-size lines landed inside RTCM frames: 3/15/27/34 of 40 arrived."""
    frames = [rtcm_frame(1077 + 10 * (i % 4), 40 + (i * 29) % 200) for i in range(40)]
    out, lines = _run(Caster(frames, answers=[CHUNKED_OK], chunk=chunk), len(frames))
    assert lines["frames"] == "40", out
    assert lines["bytes"] == str(sum(len(f) for f in frames)), out
    assert lines["bad_crc"] == "0", out


def test_icy_status_line_without_blank_line_is_accepted():
    """Issue 14.9: many NTRIP 1.0 casters send only "ICY 200 OK\\r\\n"."""
    frames = [rtcm_frame(1005, 19), rtcm_frame(1077, 120)]
    out, lines = _run(Caster(frames, answers=[b"ICY 200 OK\r\n"]), len(frames))
    assert lines["frames"] == "2", out
    assert "without end of header" not in out


def test_non_utf8_refusal_is_logged_and_the_client_reconnects():
    """Issue 14.6: a status line with a Latin-1 byte killed the NTRIP task for good."""
    frames = [rtcm_frame(1005, 19)]
    caster = Caster(frames, answers=[b"HTTP/1.0 403 Zugriff f\xfcr MP\r\n\r\n", b"ICY 200 OK\r\n\r\n"])
    out, lines = _run(caster, 1, "keep")
    assert "event caster refused: HTTP/1.0 403 Zugriff f?r MP" in out, out
    assert lines["frames"] == "1", out
    assert len(caster.requests) == 2
