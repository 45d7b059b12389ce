# Fuzz the MWV wind parser and its line framer: random bytes, mutated sentences and mutated
# sentences with a correct checksum. No exception escapes, the buffer stays bounded, readings
# stay in range, and a good sentence after the noise is read. TRACKPILOT_FUZZ_N sets the inputs.
import gc
import os
import time

import tpassert as t
from _gnss_frames import Rng

from trackpilot.devices.mwv import MwvParser
from trackpilot.devices.nmea import format_sentence

N = int(os.getenv("TRACKPILOT_FUZZ_N") or "100000")
_CHARS = b"0123456789.,-RTKMNAV*$\r\n"
_BODIES = (b"WIMWV,45.0,R,10.0,N,A", b"IIMWV,270.5,T,5.2,M,A", b"WIMWV,359.9,R,36.0,K,V",
           b"WIMWV,,R,,M,V", b"GPHDT,274.07,T")
_SENTINEL = b"\r\n" + format_sentence(b"WIMWV,123.4,R,5.6,M,A")


def test_fuzz_mwv():
    w = MwvParser()
    rng = Rng(4242)
    seeds = [format_sentence(b) for b in _BODIES]
    out = bytearray(128)
    sentinels = found = readings = 0
    gc.collect()
    mem0 = gc.mem_alloc()
    t0 = time.ticks_ms()
    nbytes = 0
    for i in range(N):
        kind = i % 3
        if kind == 0:  # random bytes, biased to framing characters
            n = 1 + rng.below(40)
            for j in range(n):
                v = rng.u32()
                out[j] = _CHARS[(v >> 8) % len(_CHARS)] if v & 1 else (v >> 16) & 0xFF
            data = out
        elif kind == 1:  # mutated sentence
            src = seeds[rng.below(len(seeds))]
            n = len(src)
            for j in range(n):
                out[j] = src[j]
            for _ in range(1 + rng.below(3)):
                p = rng.below(n)
                if rng.below(2):
                    out[p] = rng.below(256)
                else:
                    n = p + 1
            data = out
        else:  # mutated fields, correct checksum
            b = bytearray(_BODIES[rng.below(len(_BODIES))])
            for _ in range(1 + rng.below(4)):
                b[6 + rng.below(len(b) - 6)] = _CHARS[rng.below(14)]
            data = format_sentence(bytes(b))
            n = len(data)
        nbytes += n
        readings += w.feed(data, n, i)
        if w.valid:
            t.true(0.0 <= w.angle_deg < 360.0 and 0.0 <= w.speed_mps <= 200.0)
        t.true(w.framer.n <= w.framer.maxlen)
        if i % 16 == 15:
            sentinels += 1
            if w.feed(_SENTINEL, len(_SENTINEL), i) and abs(w.speed_mps - 5.6) < 1e-5 and \
                    abs(w.angle_deg - 123.4) < 1e-4:
                found += 1
        if i % 20000 == 0:
            gc.collect()
            t.true(gc.mem_alloc() - mem0 < 16000)
    dt = time.ticks_diff(time.ticks_ms(), t0)
    fr = w.framer
    print("MWV fuzz: %d inputs, %d bytes, %d ms; sentinels %d/%d; readings %d, invalid %d; "
          "framer ok %d ck_err %d dropped %d" % (N, nbytes, dt, found, sentinels, readings,
                                                  w.invalid, fr.ok, fr.ck_err, fr.dropped))
    t.eq(len(fr.buf), 96)
    t.true(found >= sentinels * 99 // 100, "resync %d/%d" % (found, sentinels))
    t.true(readings > N // 100 and w.invalid > N // 20)
