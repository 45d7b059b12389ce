# track.py under MicroPython: parsing, errors with line numbers, legs, corner warnings.
import tpassert as t
from _navtracks import csv_from_m, track_from_m
from trackpilot.nav import track
from trackpilot.nav.track import TrackError, parse_track_csv

GOOD = """# comment line
lon,lat,speed_mps,name,radius_m
3.6100000,51.4900000,1.5,start,
3.6100000,51.4909000,2.0,north   # inline comment
3.6114000,51.4909000,0.0,end,4.5
"""


def _err(text, **kw):
    e = t.raises(TrackError, parse_track_csv, text, **kw)
    return e.line_no, e.message


def test_parse_good():
    trk = parse_track_csv(GOOD)
    t.eq(len(trk.waypoints), 3)
    w = trk.waypoints[1]
    t.eq((w.lat_e7, w.lon_e7, w.name, w.radius_m, w.line_no), (514909000, 36100000, "north", None, 4))
    t.eq(trk.waypoints[2].radius_m, 4.5)
    t.eq(len(trk.legs), 2)
    t.near(trk.legs[0].length_m, 100.13, 0.02)
    t.near(trk.legs[0].bearing_deg, 0.0, 1e-3)
    t.near(trk.legs[0].turn_deg, 90.0, 0.02)  # north then east: starboard
    t.near(trk.legs[1].bearing_deg, 90.0, 0.02)
    t.eq(trk.legs[1].turn_deg, 0.0)
    t.near(trk.length_m, trk.legs[0].length_m + trk.legs[1].length_m, 1e-3)
    t.near(trk.duration_s(), 100.13 / 1.5 + trk.legs[1].length_m / 2.0, 0.05)
    t.eq(trk.legs[1].start_m, trk.legs[0].length_m)


def test_columns_any_order_and_bytes():
    trk = parse_track_csv(b"speed_mps,LAT,lon\n1,51.49,3.61\n1,51.4901,3.61\n")
    t.eq(trk.waypoints[0].lat_e7, 514900000)
    t.eq(trk.waypoints[1].lon_e7, 36100000)


def test_errors_have_line_numbers():
    t.eq(_err(""), (1, "no header line (lon, lat, speed_mps ...) and no waypoints"))
    t.eq(_err("lon,lat,speed_mps\n3.61,51.49,1\n")[0], 2)
    t.true("at least 2 waypoints" in _err("lon,lat,speed_mps\n3.61,51.49,1\n")[1])
    t.eq(_err("lon,lat,speed\n"), (1, "unknown column 'speed' (known: lon, lat, speed_mps, name, radius_m)"))
    t.eq(_err("lon,lat\n")[0], 1)
    t.eq(_err("lon,lat,lat,speed_mps\n")[0], 1)
    base = "lon,lat,speed_mps\n3.61,51.49,1\n"
    t.eq(_err(base + "3.61,51.49x,1\n"), (3, "lat '51.49x' is not a decimal number of degrees"))
    t.eq(_err(base + "3.61,91.0,1\n"), (3, "lat 91.0 is out of range (+-90 deg)"))
    t.eq(_err(base + "180.5,51.5,1\n")[0], 3)
    t.eq(_err(base + "\n\n3.61,51.491,-1\n"), (5, "speed_mps -1 is negative"))
    t.true("above 8.0 m/s" in _err(base + "3.61,51.491,12\n")[1])
    t.eq(_err(base + "3.61,51.491,abc\n"), (3, "speed_mps 'abc' is not a number"))
    t.eq(_err(base + "3.61,51.491,nan\n")[0], 3)
    t.eq(_err(base + "3.61,51.491,1,7\n")[0], 3)
    t.eq(_err(base + "3.61,51.49,1\n"), (3, "repeats the previous point (line 2)"))
    e = _err(base + "3.61,51.49002,1\n")
    t.eq(e[0], 3)
    t.true("2.2 m long" in e[1] and "shorter than 5.0 m" in e[1], e[1])
    parse_track_csv(base + "3.61,51.49002,1\n", min_leg_m=2.0)  # configurable
    e = _err("lon,lat,speed_mps\n3.61,51.49,0\n3.61,51.491,1\n")
    t.eq(e[0], 2)
    t.true("speed_mps 0" in e[1])
    e = _err("lon,lat,speed_mps,radius_m\n3.61,51.49,1,-2\n3.61,51.491,1\n")
    t.eq(e, (2, "radius_m -2 must be in (0, 500] m"))


def test_error_string():
    try:
        parse_track_csv("lon,lat,speed_mps\n3.61,51.49,1\n3.61,51.49,1\n")
    except TrackError as e:
        t.eq(str(e), "line 3: repeats the previous point (line 2)")
        return
    raise AssertionError("no error")


def test_optional_fields_may_be_left_out():
    trk = parse_track_csv("lon,lat,speed_mps,name,radius_m\n3.61,51.49,1\n3.61,51.491,1,x\n")
    t.eq(trk.waypoints[0].name, None)
    t.eq(trk.waypoints[1].name, "x")
    t.eq(_err("lon,lat,speed_mps,name\n3.61,51.49\n")[0], 2)


def test_corner_figures():
    t.near(track.corner_deviation_m(90.0, 10.0), 2.929, 0.001)  # 0.29 R (BOAT_AND_BENCHMARK)
    t.near(track.corner_deviation_m(-60.0, 9.0), 9.0 * (1 - 0.8660254), 1e-4)
    t.near(track.corner_deviation_m(180.0, 9.0), 9.0, 1e-4)
    t.near(track.corner_tangent_m(90.0, 9.0), 9.0, 1e-4)


def test_corner_warnings():
    # 30 deg corner: 0.31 m deviation, no warning; 120 deg corner: warning with the figure
    trk = track_from_m([(0, 0, 2.0), (0, 100, 2.0), (50, 186.6, 2.0), (-50, 186.6, 1.0)])
    t.near(trk.legs[0].turn_deg, 30.0, 0.05)
    t.near(trk.legs[1].turn_deg, -120.0, 0.05)
    w = track.validate(trk, {"turn_radius_m": 9.0})
    t.eq(len(w), 1, repr(w))
    t.true(w[0].startswith("wp 2 (line 4): -120 deg turn") and "expect 4.5 m off the track" in w[0], w[0])
    t.eq(track.validate(trk, {"turn_radius_m": 9.0, "corner_tol_m": 5.0}), [])


def test_u_turn_is_legitimate_with_warnings():
    # the 180-degree bend: two parallel legs 20 m apart joined by a 20 m leg
    trk = track_from_m([(0, 0, 2.0), (0, 200, 1.5), (20, 200, 1.5), (20, 0, 1.5)])
    t.near(trk.legs[0].turn_deg, 90.0, 0.05)
    t.near(trk.legs[1].turn_deg, 90.0, 0.05)
    w = track.validate(trk, {"turn_radius_m": 9.0})
    t.eq(len(w), 2, repr(w))
    t.true("expect 2.6 m off the track" in w[0], w[0])
    # R = 12: each corner needs 12 m of the 20 m leg: the corners overlap
    w = track.validate(trk, {"turn_radius_m": 12.0})
    t.true("a leg is shorter" in w[0], w[0])
    # a reversal on one waypoint parses, with a warning
    trk = track_from_m([(0, 0, 2.0), (0, 100, 1.0), (0, 0, 1.0)])
    t.near(abs(trk.legs[0].turn_deg), 180.0, 0.01)
    w = track.validate(trk)
    t.true("reversal" in w[0], repr(w))


def test_slow_speed_warning():
    trk = track_from_m([(0, 0, 0.2), (0, 50, 1.0)])
    w = track.validate(trk)
    t.true("below 0.30 m/s" in w[0], repr(w))


def test_example_track_parses():
    with open("tracks/middelburg_loop.csv") as f:
        trk = parse_track_csv(f.read())
    t.true(1000.0 < trk.length_m < 2000.0, "length %r" % trk.length_m)
    speeds = [w.speed_mps for w in trk.waypoints[:-1]]
    t.true(min(speeds) >= 0.3 and max(speeds) <= 3.0)
    t.eq(trk.waypoints[-1].radius_m, 2.0)
    turns = [abs(leg.turn_deg) for leg in trk.legs]
    t.true(sum(1 for a in turns if a > 85.0) == 2)  # the 180-degree bend: two 90s


def test_crlf_bom_and_comments():
    text = "\ufeff# exported\r\nlon,lat,speed_mps\r\n3.61,51.49,1 # first\r\n\r\n3.61,51.491,1\r\n"
    trk = parse_track_csv(text)
    t.eq(len(trk.waypoints), 2)
    t.eq(trk.waypoints[1].line_no, 5)
    t.eq(trk.waypoints[0].lat_e7, 514900000)


def test_antimeridian_track():
    trk = parse_track_csv("lon,lat,speed_mps\n179.9995,0,1\n-179.9995,0,1\n")
    t.near(trk.legs[0].length_m, 111.3, 0.1)
    t.near(trk.legs[0].bearing_deg, 90.0, 1e-3)


def test_track_id_and_config_boat():
    a = track.track_id(GOOD)
    t.eq(len(a), 8)
    t.eq(track.track_id("123456789"), "cbf43926")  # the CRC-32 check value
    t.eq(a, track.track_id(GOOD.encode()))
    t.true(a != track.track_id(GOOD + "# changed\n"))
    trk = track_from_m([(0, 0, 2.0), (0, 100, 2.0), (100, 100, 2.0)])
    t.eq(len(track.validate(trk, {"min_turn_radius_m": 4.0, "name": "boat"})), 0)  # 1.2 m
    t.eq(len(track.validate(trk, {"min_turn_radius_m": 9.0})), 1)
