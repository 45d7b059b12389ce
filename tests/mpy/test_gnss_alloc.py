# Heap bytes allocated per 5 Hz epoch (NAV-PVT + NAV-RELPOSNED + GGA + RMC), measured with
# gc.mem_alloc() deltas under the unix port. The parser keeps everything as ints while an epoch
# is assembled; the only allocation is the Fix's five float fields, made once when the epoch
# closes (a float is a heap object on MicroPython: one GC block, 32 B on the 64-bit unix port,
# 16 B on the ESP32): h_acc_m, sog_mps, cog_deg, heading_deg, heading_acc_deg.
import gc

import micropython
import tpassert as t
from _gnss_frames import nmea, pvt, relpos

from trackpilot.devices import gnss
from trackpilot.nav.fix import Fix

EPOCHS = 100


def _epochs(n, start_itow):
    out = []
    for k in range(n):
        itow = start_itow + 200 * k
        utc = 36000000 + itow - 1000
        hms = b"%02d%02d%02d.%02d" % (utc // 3600000, utc // 60000 % 60, utc // 1000 % 60,
                                      utc % 1000 // 10)
        out.append(relpos(itow) +
                   nmea(b"GNGGA," + hms + b",5129.4000000,N,00336.7407000,E,4,24,0.6,1.234,M,"
                        b"45.678,M,1.0,0000") +
                   nmea(b"GNRMC," + hms + b",A,5129.4000000,N,00336.7407000,E,3.000,271.5,"
                        b"221126,,,R,V") +
                   pvt(itow))
    return out


def _measure(gp, data, t0):
    gc.collect()
    gc.disable()
    a0 = gc.mem_alloc()
    done = 0
    for i in range(len(data)):
        d = data[i]
        done += gp.feed(d, len(d), t0 + 200 * i)
    a1 = gc.mem_alloc()
    gc.enable()
    return a1 - a0, done


def _float_block():
    x = 3
    gc.collect()
    gc.disable()
    a0 = gc.mem_alloc()
    y = x * 0.5
    a1 = gc.mem_alloc()
    gc.enable()
    return a1 - a0, y


def test_bytes_per_epoch():
    fix = Fix()
    gp = gnss.GnssParser(fix)
    warm = _epochs(20, 1000)
    _measure(gp, warm, 0)
    data = _epochs(EPOCHS, 1000 + 200 * 20)
    nbytes = sum(len(d) for d in data) // EPOCHS
    used, done = _measure(gp, data, 4000)
    t.eq(done, EPOCHS)
    per = used // EPOCHS
    fb = _float_block()[0]
    print("GNSS alloc: %d bytes per epoch = %d floats of %d B (%d B of input per epoch, %d "
          "epochs)" % (per, per // fb, fb, nbytes, EPOCHS))
    t.true(fix.heading_valid and fix.pos_valid and fix.sources & (1 << gnss.K_GGA))
    t.true(fb > 0)
    t.true(used <= 5 * fb * EPOCHS, "allocated %d B per epoch" % per)


def test_parse_time_per_epoch():
    import time
    gp = gnss.GnssParser(Fix())
    data = _epochs(EPOCHS, 1000)
    t0 = time.ticks_us()
    done = 0
    for i in range(len(data)):
        done += gp.feed(data[i], len(data[i]), 200 * i)
    dt_us = time.ticks_diff(time.ticks_us(), t0)
    print("GNSS parse time: %d us per epoch on this host (%d epochs)" % (dt_us // EPOCHS, done))
    t.eq(done, EPOCHS)


def test_framing_allocates_nothing():
    # frames that fill no float field: NMEA the parser skips, an oversize UBX, RTCM3, garbage
    from _gnss_frames import rtcm3
    from trackpilot.devices.ubxcfg import ubx_frame
    gp = gnss.GnssParser(Fix())
    data = (nmea(b"GPGSV,3,1,11,01,03,161,40,03,35,107,32,04,67,055,23,06,51,291,30") +
            ubx_frame(0x01, 0x35, bytes(1300)) + ubx_frame(0x01, 0x35, bytes(700)) +
            rtcm3(bytes(200)) + b"\x00\x13garbage\xb5\x62" +
            nmea(b"GPGSA,A,3,01,03,,,,,,,,,,,1.5,0.8,1.2") + nmea(b"GPHDT,bad,T"))
    gp.feed(data, len(data), 0)
    micropython.heap_lock()
    try:
        for i in range(20):
            gp.feed(data, len(data), 0)
    finally:
        micropython.heap_unlock()
    t.eq(gp.stats.oversize, 21)
    t.eq(gp.stats.rtcm_ok, 21)
