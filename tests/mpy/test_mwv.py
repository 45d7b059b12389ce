# Wind sensor MWV parser and the shared NMEA line framer (runs under MicroPython).
import tpassert as t

from trackpilot.devices.mwv import MwvParser
from trackpilot.devices.nmea import LineFramer, format_sentence


def _one(body, t_ms=100):
    w = MwvParser()
    s = format_sentence(body)
    return w, w.feed(s, len(s), t_ms)


def test_units_and_reference():
    for body, ang, mps, rel in ((b"WIMWV,45.0,R,10.0,N,A", 45.0, 10.0 * 1852 / 3600, True),
                                (b"IIMWV,270.5,T,5.2,M,A", 270.5, 5.2, False),
                                (b"WIMWV,359.9,R,36.0,K,A", 359.9, 10.0, True),
                                (b"WIMWV,360,R,0,M,A", 0.0, 0.0, True)):
        w, n = _one(body)
        t.eq(n, 1, body)
        t.near(w.angle_deg, ang, 1e-4, body)
        t.near(w.speed_mps, mps, 1e-5, body)
        t.eq(w.relative, rel)
        t.eq(w.t_ms, 100)


def test_invalid_readings_keep_the_last_one():
    w = MwvParser()
    good = format_sentence(b"WIMWV,90.0,R,4.0,M,A")
    w.feed(good, len(good), 10)
    for body in (b"WIMWV,90.0,R,4.0,M,V", b"WIMWV,,R,4.0,M,A", b"WIMWV,90.0,R,,M,A",
                 b"WIMWV,90.0,X,4.0,M,A", b"WIMWV,90.0,R,4.0,S,A", b"WIMWV,-1,R,4.0,M,A",
                 b"WIMWV,361,R,4.0,M,A", b"WIMWV,90.0,R,-4,M,A", b"WIMWV,90.0,R,999,M,A",
                 b"WIMWV,9x,R,4.0,M,A", b"WIMWV,90"):
        s = format_sentence(body)
        t.eq(w.feed(s, len(s), 20), 0, body)
    t.eq(w.invalid, 11)
    t.eq(w.t_ms, 10)
    t.near(w.speed_mps, 4.0, 1e-6)
    s = format_sentence(b"GPGGA,1,2,3")
    w.feed(s, len(s), 30)
    t.eq(w.other, 1)


def test_framer_checksum_and_resync():
    w = MwvParser()
    good = format_sentence(b"WIMWV,10.0,R,1.0,M,A")
    bad = bytearray(good)
    bad[8] = ord("9")
    data = b"\xff\x00noise" + good[:12] + good + bytes(bad) + b"$" + b"A" * 200 + b"\r\n" + good
    n = 0
    for i in range(len(data)):
        n += w.feed(data[i:i + 1], 1, i)
    t.eq(n, 2)
    fr = w.framer
    t.eq(fr.ok, 2)
    t.eq(fr.ck_err, 1)
    t.eq(fr.dropped, 2)  # the cut sentence and the overlong line
    t.true(fr.garbage >= 7)
    t.eq(len(fr.buf), 96)


def test_line_framer_stops_after_each_sentence():
    fr = LineFramer()
    a = format_sentence(b"GPHDT,1.5,T")
    b = format_sentence(b"GPHDT,2.5,T")
    data = a + b
    i = fr.feed(data, 0, len(data))
    t.eq(i, len(a))
    t.eq(fr.fields.e3(1), 1500)
    i = fr.feed(data, i, len(data))
    t.eq(fr.fields.e3(1), 2500)
    t.eq(fr.feed(data, i, len(data)), -1)
