# Fuzz the GNSS parser with random bytes, mutated real/spec frames and checksum-correct frames
# with mutated contents (these reach the field decoders). No exception may escape, the buffers
# stay bounded, the Fix stays in range, and a good sentence after the noise is still decoded.
# TRACKPILOT_FUZZ_N (default 100000) sets the inputs per category (`make fuzz-long`).
import gc
import os
import time

import tpassert as t
from _gnss_frames import Rng, eoe, hppos, nmea, pvt, relpos, rtcm3

from trackpilot.devices import gnss
from trackpilot.nav.fix import Fix
from trackpilot.devices.nmea import format_sentence
from trackpilot.devices.ubxcfg import ubx_frame

N = int(os.getenv("TRACKPILOT_FUZZ_N") or "100000")
_SYNC = b"$\xb5\x62\xd3*,\r\n.0N5"
_NMEA_CHARS = b"0123456789.,-NSEWAVRTMKF*"
_SENTINEL = b"\r\n" + format_sentence(b"GPHDT,123.456,T")


def _seeds():
    s = [pvt(1000), relpos(1000), hppos(1000), eoe(1000), rtcm3(b"\x3e\xd0" + bytes(20)),
         ubx_frame(0x05, 0x01, b"\x06\x8a"), ubx_frame(0x01, 0x35, bytes(600)),
         ubx_frame(0x01, 0x35, bytes(1200))]
    for body in (b"GNGGA,120000.20,5129.4000000,N,00336.7407000,E,4,24,0.6,1.234,M,45.678,M,"
                 b"1.0,0000",
                 b"GNRMC,120000.20,A,5129.4000000,N,00336.7407000,E,3.000,271.5,221126,,,R,V",
                 b"GPVTG,271.5,T,,M,3.000,N,5.556,K,D",
                 b"GPGST,120000.20,0.1,0.02,0.01,45,0.011,0.012,0.03",
                 b"GPHDT,274.07,T", b"GNTHS,77.52,A", b"GPGSV,1,1,01,01,03,161,40"):
        s.append(nmea(body))
    try:
        with open("tests/data/gnss/ublox-zed-f9p-rtk.log", "rb") as f:
            real = f.read()
        for i in range(0, len(real) - 200, 97):
            s.append(real[i:i + 200])  # windows of a real capture, frames cut anywhere
    except OSError:
        pass
    return s


def _mutate(rng, src, out):
    """Copy src into out with 1-4 mutations; returns the length."""
    n = len(src)
    if n > len(out) - 8:
        n = len(out) - 8
    for i in range(n):
        out[i] = src[i]
    for _ in range(1 + rng.below(4)):
        op = rng.below(6)
        if n == 0:
            break
        p = rng.below(n)
        if op == 0:
            out[p] ^= 1 << rng.below(8)
        elif op == 1:
            out[p] = rng.below(256)
        elif op == 2:
            out[p] = _SYNC[rng.below(len(_SYNC))]
        elif op == 3 and n < len(out) - 1:  # insert
            for j in range(n, p, -1):
                out[j] = out[j - 1]
            out[p] = rng.below(256)
            n += 1
        elif op == 4:  # delete
            for j in range(p, n - 1):
                out[j] = out[j + 1]
            n -= 1
        else:  # truncate
            n = p
    return n


def _refit_ubx(rng, src, out):
    """A UBX frame with random payload bytes but a correct length and checksum."""
    n = len(src)
    for i in range(n):
        out[i] = src[i]
    for _ in range(1 + rng.below(8)):
        out[6 + rng.below(n - 8)] = rng.below(256)
    a = b = 0
    for i in range(2, n - 2):
        a = (a + out[i]) & 0xFF
        b = (b + a) & 0xFF
    out[n - 2] = a
    out[n - 1] = b
    return n


def _refit_nmea(rng, body):
    """An NMEA sentence with mutated field characters and a correct checksum."""
    b = bytearray(body)
    for _ in range(1 + rng.below(6)):
        p = 6 + rng.below(len(b) - 6)
        op = rng.below(3)
        if op == 0:
            b[p] = _NMEA_CHARS[rng.below(len(_NMEA_CHARS))]
        elif op == 1:
            b[p] = 0x2C
        else:
            b = b[:p]
            break
    return format_sentence(bytes(b))


class _Checker:
    def __init__(self):
        self.fix = Fix()
        self.gp = gnss.GnssParser(self.fix)
        self.sentinels = 0
        self.found = 0
        self.epochs = 0
        self.gp.on_msg = self.on_msg
        self.gp.on_epoch = self.on_epoch

    def on_msg(self, kind):
        if kind == gnss.K_HDT and self.gp.hdt.heading_e3 == 123456:
            self.found += 1

    def on_epoch(self):
        f = self.fix
        self.epochs += 1
        t.true(0 <= f.rtk <= 3)
        if f.pos_valid:
            t.true(-900000000 <= f.lat_e7 <= 900000000, "lat %d" % f.lat_e7)
            t.true(-1800000000 <= f.lon_e7 <= 1800000000)
        t.true(0.0 <= f.heading_deg < 360.0 and 0.0 <= f.cog_deg < 360.0)

    def feed(self, data, n, t_ms):
        gp = self.gp
        gp.feed(data, n, t_ms)
        t.true(0 <= gp._start <= gp._end <= gnss.BUF_SIZE)
        t.true(gp._skip <= gnss.UBX_MAX_SKIP + 8)

    def sentinel(self, t_ms):
        s = _SENTINEL
        self.sentinels += 1
        self.feed(s, len(s), t_ms)


def _run(category, make):
    c = _Checker()
    rng = Rng(12345 + category)
    out = bytearray(1024)
    gc.collect()
    mem0 = gc.mem_alloc()
    t0 = time.ticks_ms()
    nbytes = 0
    for i in range(N):
        data, n = make(rng, out)
        c.feed(data, n, i * 7)
        nbytes += n
        if i % 16 == 15:
            c.sentinel(i * 7 + 3)
        if i % 20000 == 0:
            gc.collect()
            t.true(gc.mem_alloc() - mem0 < 16000, "heap grew by %d" % (gc.mem_alloc() - mem0))
    c.gp.flush(0)
    dt = time.ticks_diff(time.ticks_ms(), t0)
    st = c.gp.stats
    print("GNSS fuzz %s: %d inputs, %d bytes, %d ms; sentinels %d/%d; epochs %d; ok ubx %d "
          "nmea %d rtcm %d; ck_err %d broken %d oversize %d garbage %d"
          % (("random", "mutated", "refitted")[category], N, nbytes, dt, c.found, c.sentinels,
             c.epochs, st.ubx_ok, st.nmea_ok, st.rtcm_ok, st.ck_err, st.broken, st.oversize,
             st.garbage))
    return c


def test_fuzz_random_bytes():
    pool = bytearray(65536)
    Rng(99).fill(pool, len(pool))
    for i in range(0, len(pool), 13):  # plenty of sync bytes
        pool[i] = _SYNC[i % len(_SYNC)]
    mv = memoryview(pool)

    def make(rng, out):
        n = 1 + rng.below(64)
        o = rng.below(len(pool) - n)
        return mv[o:o + n], n

    c = _run(0, make)
    t.true(c.found >= c.sentinels * 99 // 100, "resync %d/%d" % (c.found, c.sentinels))


def test_fuzz_mutated_frames():
    seeds = _seeds()

    def make(rng, out):
        return out, _mutate(rng, seeds[rng.below(len(seeds))], out)

    c = _run(1, make)
    # a sentinel is lost only when a cut or corrupted frame longer than the buffer makes the
    # parser skip by its length (the cut 1200 B NAV-SAT seed); the rate is deterministic
    # (fixed PRNG seeds): 96.9 % measured at N = 100000
    t.true(c.found >= c.sentinels * 95 // 100, "resync %d/%d" % (c.found, c.sentinels))
    t.true(c.gp.stats.nmea_ok > N // 20)


def test_fuzz_refitted_frames():
    ubx = [pvt(1000), relpos(1000), hppos(1000), eoe(1000), ubx_frame(0x05, 0x00, b"\x06\x8a")]
    bodies = [b"GNGGA,120000.20,5129.4000000,N,00336.7407000,E,4,24,0.6,1.234,M,45.678,M,1.0,0000",
              b"GNRMC,120000.20,A,5129.4000000,N,00336.7407000,E,3.000,271.5,221126,,,R,V",
              b"GPVTG,271.5,T,,M,3.000,N,5.556,K,D",
              b"GPGST,120000.20,0.1,0.02,0.01,45,0.011,0.012,0.03", b"GPHDT,274.07,T",
              b"GNTHS,77.52,A"]

    def make(rng, out):
        k = rng.below(len(ubx) + len(bodies))
        if k < len(ubx):
            return out, _refit_ubx(rng, ubx[k], out)
        s = _refit_nmea(rng, bodies[k - len(ubx)])
        return s, len(s)

    c = _run(2, make)
    t.true(c.epochs > N // 10)
    st = c.gp.stats
    t.eq(st.ck_err, 0)
