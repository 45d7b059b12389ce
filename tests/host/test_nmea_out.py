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


# a 16-character name (the most a track takes) is still cut to 12 for NMEA
ROUTE_TRACK = """lon,lat,speed_mps,name,radius_m
3.6100000,51.4900000,1.0,quay start,
3.6104319,51.4907191,2.0,,
3.6135997,51.4937750,3.0,a_very_long_wp*x,
3.6186393,51.4938646,2.0,bridge,5
"""


def test_rmb_apb_name_the_active_leg_and_decode():
    """RMB/APB decoded by pynmeagps: names of the leg's waypoints (sanitised, shortened), range and
    bearing to the destination against geographiclib, the side to steer, arrival, status."""
    from geographiclib.geodesic import Geodesic

    wps = [(51.49, 3.61), (51.4907191, 3.6104319), (51.493775, 3.6135997), (51.4938646, 3.6186393)]
    # (leg, lat_e7, lon_e7, sog, cog, auto): east of leg 0, west of leg 1, inside bridge's 5 m circle
    cases = [(0, 514903000, 36102500, 1.5, 20.0, 1), (1, 514920000, 36115000, 2.0, 40.0, 0),
             (2, 514938700, 36185900, 1.0, 88.0, 1)]
    stdin = (ROUTE_TRACK + "--\n" + "".join("%d %d %d %s %s %d\n" % c for c in cases)).encode()
    out = run_script(ROOT / "tests/host/_nmea_route_mpy.py", stdin_bytes=stdin).stdout.decode()
    lines = out.strip().split("\n")
    assert len(lines) == len(cases)
    names = ["quay_start", "WP2", "a_very_long_", "bridge"]
    for line, (leg, la, lo, sog, cog, auto) in zip(lines, cases):
        leg_out, xte_m, rmb_s, apb_s = line.split()
        assert int(leg_out) == leg
        assert len(rmb_s) + 2 <= 82 and len(apb_s) + 2 <= 82
        rmb = NMEAReader.parse(rmb_s, validate=1)
        apb = NMEAReader.parse(apb_s, validate=1)
        assert rmb.msgID == "RMB" and apb.msgID == "APB"
        assert names[leg + 1].startswith(rmb.wptD) and len(rmb.wptD) >= 3
        assert names[leg].startswith(rmb.wptO)
        assert apb.wpt == names[leg + 1]
        dlat, dlon = wps[leg + 1]
        g = Geodesic.WGS84.Inverse(la / 1e7, lo / 1e7, dlat, dlon)
        assert abs(rmb.range * 1852 - g["s12"]) < 2.0, (rmb.range, g["s12"])
        assert abs((rmb.bearing - g["azi1"] + 180) % 360 - 180) < 0.2
        assert abs(apb.bearD - rmb.bearing) < 0.11
        assert abs(rmb.lat - dlat) < 2e-6 and abs(rmb.lon - dlon) < 2e-6
        assert abs(float(rmb.ctrkerr) * 1852 - abs(float(xte_m))) < 0.2
        assert abs(float(apb.ctrkerr) * 1852 - abs(float(xte_m))) < 0.02
        assert rmb.dirs == apb.dirs == ("L" if float(xte_m) > 0 else "R")
        assert rmb.status == ("A" if auto else "V")
        assert apb.bearS == (123.4 if auto else apb.bearD)
    assert float(lines[0].split()[1]) > 0 and float(lines[1].split()[1]) < 0  # both sides covered
    last = NMEAReader.parse(lines[2].split()[2], validate=1)
    assert last.arrstatus == "A" and last.range * 1852 < 5.0
    assert NMEAReader.parse(lines[0].split()[2]).arrstatus == "V"
