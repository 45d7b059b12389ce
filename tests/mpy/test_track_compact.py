# The compact track: live heap per waypoint, the waypoint limit, parsing from a file line by line.
import gc
import sys

import tpassert as t
from trackpilot.nav import track

sys.path.append("firmware/tools")
import track_heap  # noqa: E402

PATH = "/tmp/trackpilot_test_compact.csv"


def test_live_heap_per_waypoint():
    # the old Waypoint/Leg objects cost ~550 B per waypoint; the arrays about 25-31 B
    for n in (500, 2000):
        size, live, trk = track_heap.measure(n, PATH)
        t.true(live / n <= 40.0, "%d waypoints: %d B live, %.1f B each" % (n, live, live / n))
        trk = None
        gc.collect()


def test_file_and_text_parse_alike():
    track_heap.write_track(PATH, 300)
    with open(PATH, "rb") as f:
        a = track.parse_track_csv(f)
    with open(PATH) as f:
        b = track.parse_track_csv(f.read())
    t.eq(len(a.waypoints), 300)
    t.eq(a.length_m, b.length_m)
    for i in (0, 1, 127, 128, 129, 255, 256, 299):  # across the pages
        wa = a.waypoints[i]
        wb = b.waypoints[i]
        t.eq((wa.lat_e7, wa.lon_e7, wa.speed_mps, wa.name, wa.radius_m, wa.line_no),
             (wb.lat_e7, wb.lon_e7, wb.speed_mps, wb.name, wb.radius_m, wb.line_no))
        t.eq(a.legs[min(i, 298)].start_m, b.legs[min(i, 298)].start_m)
    t.eq(a.waypoints[128].name, "wp128")
    t.eq(a.waypoints[129].name, None)
    t.eq(a.waypoints[-1].line_no, 301)


def test_waypoint_limit():
    track_heap.write_track(PATH, track.MAX_WAYPOINTS)
    with open(PATH, "rb") as f:
        t.eq(len(track.parse_track_csv(f).waypoints), 2000)
    track_heap.write_track(PATH, track.MAX_WAYPOINTS + 1)
    with open(PATH, "rb") as f:
        e = t.raises(track.TrackError, track.parse_track_csv, f)
    t.eq(e.line_no, 2002)  # the header, then the 2001st waypoint
    t.true("more than 2000 waypoints" in e.message, e.message)


def test_long_line_refused():
    e = t.raises(track.TrackError, track.parse_track_csv, "lon,lat,speed_mps\n" + "1" * 600 + "\n")
    t.eq(e.line_no, 2)
    with open(PATH, "wb") as f:
        f.write(b"lon,lat,speed_mps\n3.61,51.49,1\n" + b"x" * 5000)
    with open(PATH, "rb") as f:
        e = t.raises(track.TrackError, track.parse_track_csv, f)
    t.eq((e.line_no, e.message), (3, "line longer than 512 characters"))


def test_legs_cached_and_derived_alike():
    track_heap.write_track(PATH, 40)
    with open(PATH, "rb") as f:
        trk = track.parse_track_csv(f)
    first = [(g.length_m, g.bearing_deg, g.turn_deg, g.start_m) for g in trk.legs]
    again = [(trk.leg(i).length_m, trk.leg(i).bearing_deg, trk.leg(i).turn_deg, trk.leg(i).start_m)
             for i in range(38, -1, -1)]
    again.reverse()
    t.eq(first, again)
    t.eq(trk.legs[-1].turn_deg, 0.0)
