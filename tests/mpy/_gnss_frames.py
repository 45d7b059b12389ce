# Frame builders for the GNSS tests (MicroPython and CPython): UBX from the field layout in
# PROTOCOLS.md, NMEA via trackpilot.devices.nmea.format_sentence, RTCM3 with CRC-24Q; and a small
# deterministic PRNG (the float32 interpreter has no `random`).
import struct

from trackpilot.devices.gnss import crc24q
from trackpilot.devices.nmea import format_sentence
from trackpilot.devices.ubxcfg import ubx_frame


def pvt(itow, lat_e7=514900000, lon_e7=36100000, carr=2, fix_type=3, fix_ok=1, g_speed=1500,
        head_mot_e5=9000000, h_acc=14, num_sv=20, hms=None, nano=0, height=50000,
        flags3=0, valid=0x07):
    # UTC defaults to 10:00:00.000 at iTOW 1000 ms, advancing with the iTOW
    if hms is None:
        utc_ms = 36000000 + itow - 1000
        hms = (utc_ms // 3600000 % 24, utc_ms // 60000 % 60, utc_ms // 1000 % 60)
        nano = (utc_ms % 1000) * 1000000
    p = bytearray(92)
    flags = (fix_ok & 1) | 2 | (carr << 6)
    struct.pack_into("<IHBBBBBBIiBBBBiiii", p, 0, itow, 2026, 11, 22, hms[0], hms[1], hms[2],
                     valid, 20, nano, fix_type, flags, 0, num_sv, lon_e7, lat_e7, height,
                     height - 45000)
    struct.pack_into("<IIiiiiiIIHH", p, 40, h_acc, 20, 100, -200, 3, g_speed, head_mot_e5, 50,
                     250000, 120, flags3)
    struct.pack_into("<ihH", p, 84, 0, 0, 0)
    return ubx_frame(0x01, 0x07, p)


def relpos(itow, heading_e5=4500000, valid=True, acc_heading_e5=30000, length_cm=150,
           carr=2):
    p = bytearray(64)
    p[0] = 1
    struct.pack_into("<HIiiiii", p, 2, 0, itow, 106, 106, -2, length_cm, heading_e5)
    struct.pack_into("<bbbb", p, 32, 3, -4, 5, -6)
    struct.pack_into("<IIIII", p, 36, 40, 41, 42, 43, acc_heading_e5)
    flags = 0x1 | 0x2 | 0x4 | (carr << 3) | 0x20 | (0x100 if valid else 0)
    struct.pack_into("<I", p, 60, flags)
    return ubx_frame(0x01, 0x3C, p)


def hppos(itow, lat_e7=514900001, lon_e7=36100002, lat_hp=-42, lon_hp=37, h_acc=123,
          invalid=0):
    p = bytearray(36)
    p[3] = invalid
    struct.pack_into("<IiiiibbbbII", p, 4, itow, lon_e7, lat_e7, 50000, 5000, lon_hp, lat_hp,
                     5, -5, h_acc, 200)
    return ubx_frame(0x01, 0x14, p)


def eoe(itow):
    return ubx_frame(0x01, 0x61, struct.pack("<I", itow))


def nmea(body):
    return format_sentence(body)


def rtcm3(payload):
    n = len(payload)
    f = bytearray(3 + n + 3)
    f[0] = 0xD3
    f[1] = (n >> 8) & 3
    f[2] = n & 0xFF
    f[3:3 + n] = payload
    c = crc24q(f, 0, 3 + n)
    f[3 + n] = c >> 16
    f[4 + n] = (c >> 8) & 0xFF
    f[5 + n] = c & 0xFF
    return bytes(f)


class Rng:
    """xorshift32: same sequence on every interpreter."""

    def __init__(self, seed=2463534242):
        self.x = seed & 0xFFFFFFFF or 1

    def u32(self):
        x = self.x
        x ^= (x << 13) & 0xFFFFFFFF
        x ^= x >> 17
        x ^= (x << 5) & 0xFFFFFFFF
        self.x = x
        return x

    def below(self, n):
        return self.u32() % n

    def fill(self, buf, n):
        i = 0
        while i < n:
            v = self.u32()
            for _ in range(4):
                if i < n:
                    buf[i] = v & 0xFF
                    v >>= 8
                    i += 1
