# Remote HMI box: status in, link-lost after the timeout, signed commands out to the boat's
# verifier; and the asyncio shells over real UDP on localhost when this build has sockets.
import tpassert as T

try:
    import framebuf
except ImportError:
    framebuf = None
    print("skipped: no framebuf")
try:
    import hashlib
except ImportError:
    hashlib = None
    print("skipped: no hashlib")

KEY = b"k" * 32


def _remote(timeout_ms=3000):
    from tphmi.auth import CommandSigner, CommandVerifier, MemStore, init_state
    from tphmi.pages import Pages
    from tphmi.remote import RemoteHmi

    buf = bytearray(1024)
    fb = framebuf.FrameBuffer(buf, 128, 64, framebuf.MONO_VLSB)
    tx, rx = MemStore(), MemStore()
    init_state(tx, KEY)
    init_state(rx, KEY)
    r = RemoteHmi(Pages(fb), CommandSigner(KEY, 7, tx), 7, timeout_ms)
    return r, buf, CommandVerifier(KEY, 7, rx)


def _text_at(buf, s, x, y, inverted=False):
    ref = bytearray(len(s) * 8)
    framebuf.FrameBuffer(ref, len(s) * 8, 8, framebuf.MONO_VLSB).text(s, 0, 0, 1)
    for cx in range(len(s) * 8):
        for cy in range(8):
            want = ((ref[cx] >> cy) & 1) ^ (1 if inverted else 0)
            if ((buf[((y + cy) >> 3) * 128 + x + cx] >> ((y + cy) & 7)) & 1) != want:
                return False
    return True


def test_status_link_lost_and_pages():
    if framebuf is None or hashlib is None:
        return
    from tphmi.preview.samples import sample
    from tphmi.status import encode_status

    r, buf, _ = _remote()
    r.render(0)
    T.true(_text_at(buf, "no status yet", 0, 34), "no status at boot")
    T.true(r.on_datagram(encode_status(sample("auto_right")), 1000))
    r.render(2000)
    T.true(_text_at(buf, "AUTO", 1, 1, inverted=True), "boat's main page shown")
    T.true(_text_at(buf, "LEG 3/11", 0, 56))
    r.on_events(["PAGE"], 2100)
    r.render(2200)
    T.true(_text_at(buf, "GNSS", 1, 1, inverted=True), "PAGE is local")
    r.render(4100)
    T.true(_text_at(buf, "no status    3s", 0, 34), "link lost after 3 s")
    T.true(_text_at(buf, "last: AUTO", 0, 44))
    T.eq(r.on_datagram(b"garbage", 4200), False)
    other = sample("auto_right")
    other.boat_id = 9
    T.eq(r.on_datagram(encode_status(other), 4300), False, "other boat's status ignored")
    T.eq(r.bad_datagrams, 2)
    T.eq(r.link_ok(4300), False)
    T.true(r.on_datagram(encode_status(sample("standby_refused")), 5000))
    T.eq(r.link_ok(5100), True)
    r.render(5100)
    T.true(_text_at(buf, "AUTO REFUSED:", 1, 37, inverted=True), "boat's refusal shown remotely")


def test_commands_reach_verifier():
    if framebuf is None or hashlib is None:
        return
    r, buf, v = _remote()
    pkts = r.on_events(["ENGAGE", "PAGE", "HOLD_LONGER", "STANDBY", "NEXT_WP", "PREV_WP", "ACK"], 0)
    T.eq(len(pkts), 5)
    T.eq([v.verify(p)[0] for p in pkts], ["ENGAGE", "STANDBY", "NEXT_WP", "PREV_WP", "ACK"])
    T.eq(v.verify(pkts[1])[0], None, "replay refused")


def test_udp_shells_loopback():
    if framebuf is None or hashlib is None:
        return
    try:
        import asyncio
        import socket
    except ImportError:
        print("skipped: no socket/asyncio (UDP loopback part)")
        return
    from tphmi.buttons import B_STBY, N_BUTTONS, Buttons
    from tphmi.remote import command_listener, run_remote, udp_socket
    from tphmi.preview.samples import sample
    from tphmi.status import encode_status

    import time

    r, buf, v = _remote()
    boat_port = 40000 + (time.ticks_us() % 20000) * 2  # the unix port has no getsockname()
    remote_port = boat_port + 1
    boat_sock = udp_socket(boat_port)
    remote_sock = udp_socket(remote_port)
    boat_addr = socket.getaddrinfo("127.0.0.1", boat_port)[0][-1]
    got, refused = [], []

    class Pins:
        def __init__(self):
            self.levels = [0] * N_BUTTONS
            self.n = 0

        def read(self):
            self.n += 1
            self.levels[B_STBY] = 1 if 3 <= self.n < 8 else 0
            return self.levels

    clock = [0]

    def ticks():
        clock[0] += 20
        return clock[0]

    async def main():
        remote_addr = socket.getaddrinfo("127.0.0.1", remote_port)[0][-1]
        boat_sock.sendto(encode_status(sample("auto_right")), remote_addr)
        boat_sock.sendto(b"\x00garbage", boat_addr)  # to itself: refused
        t1 = asyncio.create_task(command_listener(boat_sock, v, lambda n, a: got.append(n),
                                                  lambda w, a: refused.append(w), poll_ms=5))
        t2 = asyncio.create_task(run_remote(r, remote_sock, boat_addr, Buttons(), Pins(), lambda: None,
                                            ticks_ms=ticks, poll_ms=5))
        for _ in range(100):
            await asyncio.sleep_ms(10)
            if got and refused:
                break
        t1.cancel()
        t2.cancel()

    asyncio.run(main())
    boat_sock.close()
    remote_sock.close()
    T.eq(got, ["STANDBY"])
    T.eq(len(refused), 1)
    T.true("truncated" in refused[0], refused[0])
    T.true(r.have_status, "status arrived over UDP")
