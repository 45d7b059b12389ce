# Fuzz the SeaTalk framer, decoder and pilot driver with random and mutated bytes.
# TRACKPILOT_FUZZ_N sets the number of inputs (default 100000; `make fuzz-long` runs more).
import os
import time

import tpassert as T
from trackpilot.devices import seatalk as st
from trackpilot.devices import st2000 as sp
from trackpilot.devices.stlink import Prng

try:
    N = int(os.getenv("TRACKPILOT_FUZZ_N") or 100000)
except AttributeError:  # a port without os.getenv
    N = 100000

SEEDS = [
    bytes.fromhex(x)
    for x in (
        "84862697020000000008", "9c011200", "8611 08f7".replace(" ", ""), "95860e0010000004 08".replace(" ", ""),
        "1001 0166".replace(" ", ""), "11011203", "9900e4", "850600 00c00d1700e8".replace(" ", ""),
        "82 05 00 ff 70 8f 05 fa".replace(" ", ""), "a8538000 00d3".replace(" ", ""), "9000a3",
        "a1031122 3344".replace(" ", ""),
    )
]


def _input(rng, buf):
    """Fill buf (bytearray) with one input; returns its length."""
    kind = rng.randint(0, 3)
    n = 0
    if kind == 0:  # random bytes
        n = rng.randint(1, 24)
        for i in range(n):
            buf[i] = rng.randint(0, 255)
        return n
    # a few real datagrams back to back, then mutated
    for _ in range(rng.randint(1, 3)):
        s = SEEDS[rng.randint(0, len(SEEDS) - 1)]
        for b in s:
            buf[n] = b
            n += 1
    for _ in range(rng.randint(1, 3)):
        m = rng.randint(0, 3)
        i = rng.randint(0, n - 1)
        if m == 0:  # flip a bit
            buf[i] ^= 1 << rng.randint(0, 7)
        elif m == 1 and n > 1:  # drop a byte
            for j in range(i, n - 1):
                buf[j] = buf[j + 1]
            n -= 1
        elif m == 2 and n < len(buf) - 1:  # insert a byte
            for j in range(n, i, -1):
                buf[j] = buf[j - 1]
            buf[i] = rng.randint(0, 255)
            n += 1
        else:  # cut here
            n = i + 1
    return n


def test_fuzz_framer_decoder_driver():
    rng = Prng(20240611)
    fr = st.Framer(gap_ms=5, depth=4)
    drv = sp.St2000(send=lambda dg: True)
    buf = bytearray(96)
    t = (1 << 30) - 100000  # crosses the tick wrap on the way
    nbytes = 0
    ndg = 0
    nresync = 0
    t0 = time.ticks_ms() if hasattr(time, "ticks_ms") else int(time.time() * 1000)
    for k in range(N):
        n = _input(rng, buf)
        nbytes += n
        # inputs arrive back to back (2 ms a byte) or after an idle gap
        t = (t + (rng.randint(6, 40) if k & 1 else 2)) & ((1 << 30) - 1)
        for i in range(n):
            fr.feed(buf[i], t)
            t = (t + 2) & ((1 << 30) - 1)
            while fr.pending():
                dg = fr.pop()
                ndg += 1
                T.true(3 <= len(dg) <= 18 and len(dg) == 3 + (dg[1] & 15))
                st.decode(dg)  # never raises on what the framer lets through
                drv.on_datagram(dg, t)
        if k % 8 == 7:
            # after any garbage, an idle gap and a clean datagram: it must come out intact
            good = SEEDS[k % len(SEEDS)]
            t = (t + 10) & ((1 << 30) - 1)
            last = None
            for b in good:
                fr.feed(b, t)
                t = (t + 2) & ((1 << 30) - 1)
                while fr.pending():
                    last = fr.pop()
                    ndg += 1
                    drv.on_datagram(last, t)
            T.eq(last, good, "resync after input %d" % k)
            nresync += 1
        if k % 64 == 0:
            drv.poll(t)
            while drv.pop_event():
                pass
        T.true(fr._n < st.MAX_LEN and fr.pending() <= 4)
    T.true(len(drv._ev) <= drv._evmax)
    t1 = time.ticks_ms() if hasattr(time, "ticks_ms") else int(time.time() * 1000)
    print("fuzz: %d inputs, %d bytes, %d datagrams framed, %d dropped bytes, %d resyncs, %d ms" % (
        N, nbytes, ndg, fr.dropped_bytes, nresync, t1 - t0))
    T.true(ndg > N // 10, "datagrams framed %d" % ndg)


def test_fuzz_decoder_direct():
    # every length-consistent byte string decodes or raises ValueError, nothing else
    rng = Prng(7)
    bad = 0
    for k in range(N // 10):
        n = rng.randint(3, 18)
        b = bytearray(n)
        for i in range(n):
            b[i] = rng.randint(0, 255)
        b[0] = (0x84, 0x95, 0x9C, 0x86, 0x85, 0x89, 0x99, 0x10, 0x11, b[0])[k % 10]
        b[1] = (b[1] & 0xF0) | ((n - 3) if k % 3 else rng.randint(0, 15))
        try:
            st.decode(bytes(b))
        except ValueError:
            bad += 1
    T.true(bad > 0)


def test_fuzz_link_and_driver_state_machines():
    # random bus bytes, random polls, random valid-but-hostile pilot datagrams; the driver is
    # re-engaged whenever it stops commanding. Nothing may raise, queues stay bounded.
    from trackpilot.devices import stlink as sl

    rng = Prng(99)
    sent = []
    link = sl.StLink(framer=st.Framer(), rand=Prng(5), queue_len=4)
    drv = sp.St2000(send=link.send, status_timeout_ms=800, confirm_timeout_ms=300,
                    converge_window_ms=2000, mode_confirm_ms=300)
    link.on_datagram = drv.on_datagram
    t = (1 << 30) - 5000
    steps = N // 5
    for k in range(steps):
        t = (t + rng.randint(0, 7)) & ((1 << 30) - 1)
        r = rng.randint(0, 9)
        if r == 0:
            dg = st.encode_84(rng.randint(0, 359), rng.randint(0, 719) / 2, rng.randint(0, 4),
                              rng.randint(-30, 30), rng.randint(0, 1) == 1)
            for b in dg:
                link.on_rx(b, t)
        elif r == 1:
            for b in st.encode_86(rng.randint(0, 255), rng.randint(0, 3)):
                link.on_rx(b, t)
        elif r == 2:
            link.on_rx(rng.randint(0, 255), t)
        elif r == 3 and drv.state in (sp.IDLE, sp.TAKEN_OVER, sp.FAILED):
            drv.engage(t)
        elif r == 4:
            drv.steer_to(rng.randint(-180, 180), t)
        elif r == 5 and rng.randint(0, 50) == 0:
            drv.standby(t)
        act = link.poll(t)
        if act[0] == sl.WRITE and rng.randint(0, 3):
            link.on_rx(link.byte, t)  # the echo, mostly
        drv.poll(t)
        while link.pop_event():
            pass
        while drv.pop_event():
            pass
        T.true(len(link._q) <= 4 and len(link._ev) <= 16 and len(drv._ev) <= 32)
    print("link/driver fuzz: %d steps, %d sent, %d failed, %d collisions, %d keys, %d hangs, %d takeovers" % (
        steps, link.sent, link.failed, link.collisions, drv.keys_sent, drv.hangs, drv.takeovers))
    T.true(drv.takeovers > 0 and link.sent > 0)
