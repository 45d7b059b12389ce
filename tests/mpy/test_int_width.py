# Integer code on hot paths must stay below 2**30: on the ESP32 (and the project's 32-bit build,
# tools/build_micropython_f32.sh) a larger int is a heap-allocated long int, so these run with
# the heap locked. The expected values were computed with the 64-bit unix port before the
# rewrite (results must be bit-identical on both word sizes).
import micropython
import tpassert as t

from trackpilot import gnss, logfmt, ntrip, stlink

DATA = bytes(range(256)) * 4
# an RTCM3 frame (1005) with its CRC: the CRC over header + payload + CRC is 0
RTCM = b"\xd3\x00\x13>\xd0\x00\x03\x8aX\xd9I<\x87/4\x10\x9d\x07\xd6\xafH Z\xd7\xf7"


def _locked3(fn, a, b, c):
    micropython.heap_lock()  # no *args here: building the argument tuple would allocate
    try:
        return fn(a, b, c)
    finally:
        micropython.heap_unlock()


def test_gnss_crc24q_values_and_no_alloc():
    t.eq(_locked3(gnss.crc24q, DATA, 0, len(DATA)), 0xF8E43B)
    t.eq(_locked3(gnss.crc24q, RTCM, 0, len(RTCM)), 0)
    t.eq(_locked3(gnss.crc24q, RTCM, 0, len(RTCM) - 3), 0x5AD7F7)


def test_ntrip_crc24q_same_and_no_alloc():
    t.eq(_locked3(ntrip.crc24q, DATA, 0, len(DATA)), 0xF8E43B)
    t.eq(_locked3(ntrip.crc24q, RTCM, 0, len(RTCM)), 0)


def test_logfmt_crc16_no_alloc():
    t.eq(_locked3(logfmt.crc16, DATA, 0, len(DATA)), 0x758F)


def _draws(rng, n, out):
    for i in range(n):
        out[i] = rng.randint(2, 50)
    return out


def test_stlink_prng_values_and_no_alloc():
    rng = stlink.Prng(0xDEADBEEF)
    t.eq(_locked3(_draws, rng, 8, [0] * 8), [4, 8, 25, 9, 3, 21, 33, 27])
    _locked3(_draws, rng, 1000, [0] * 1000)  # the whole state space stays small
