"""Outgoing NMEA (for chart plotters), made under MicroPython, checked with pynmeagps."""
import random

from pynmeagps import NMEAReader

from trackpilot_tools.mpy import ROOT, run_script
import pytest

# runs firmware code under $MICROPYTHON: also part of the float32 pass of `make test`
pytestmark = pytest.mark.mpy


def test_sentences_parse_and_keep_full_precision():
    rng = random.Random(7)
    cases = [(514960123, 36123456, 3, 87.25, 1.2), (-450000001, -1799999999, 2, 359.99, -0.4),
             (0, 1200000000, 1, 0.0, 0.0), (599999999, 1799999999, 3, 180.0, 12.0)]
    for _ in range(200):
        cases.append((rng.randint(-800000000, 800000000), rng.randint(-1800000000, 1800000000),
                      rng.choice([1, 2, 3]), round(rng.uniform(0, 359.99), 2), round(rng.uniform(-30, 30), 2)))
    stdin = "".join("%d %d %d %s %s\n" % c for c in cases).encode()
    out = run_script(ROOT / "tests/host/_nmea_out_mpy.py", stdin_bytes=stdin).stdout.decode()
    lines = out.strip().split("\r\n")
    assert len(lines) == 4 * len(cases)
    quality = {1: 1, 2: 5, 3: 4}
    for i, case in enumerate(cases):
        gga, rmc, hdt, xte = (NMEAReader.parse(lines[4 * i + k], validate=1) for k in range(4))
        lat_e7, lon_e7, rtk, heading, xte_m = case
        assert abs(gga.lat - lat_e7 / 1e7) < 2e-9, (lines[4 * i], case)
        assert abs(gga.lon - lon_e7 / 1e7) < 2e-9, (lines[4 * i], case)
        assert gga.quality == quality[rtk]
        assert abs(rmc.lat - lat_e7 / 1e7) < 2e-9 and abs(rmc.lon - lon_e7 / 1e7) < 2e-9
        assert abs(hdt.headingT - heading) < 0.006
        assert abs(float(xte.ctrkerr) * 1852 - abs(xte_m)) < 0.2
        assert xte.dirs == ("L" if xte_m > 0 else "R")
