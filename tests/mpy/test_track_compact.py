# The compact track: live heap per waypoint, the waypoint limit, parsing from a file line by line.
import gc
import sys

import tpassert as t
from trackpilot.nav import track

sys.path.append("firmware/tools")
import track_heap  # noqa: E402

PATH = "/tmp/trackpilot_test_compact.csv"


def test_live_heap_per_waypoint():
    # the old Waypoint/Leg objects cost ~550 B per waypoint; the arrays 23 B with stored track
    # distances and line numbers, now 14.6-18.0 B for this file (issue 13's goal: 40 B)
    for n in (500, 2000):
        size, live, trk = track_heap.measure(n, PATH)
        t.true(live / n <= 20.0, "%d waypoints: %d B live, %.1f B each" % (n, live, live / n))
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
    # without names: 2000 of them fit the heap budget (with a name each they do not)
    track_heap.write_named_track(PATH, track.MAX_WAYPOINTS)
    with open(PATH, "rb") as f:
        t.eq(len(track.parse_track_csv(f).waypoints), 2000)
    track_heap.write_named_track(PATH, track.MAX_WAYPOINTS + 1)
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


def _irregular(n, every_blank):
    """A track text with comments and blank lines between some waypoints; (text, line of each)."""
    out = ["# a comment first", "", "lon,lat,speed_mps"]
    lines = []
    for i in range(n):
        if every_blank and i % every_blank == 0:
            out.append("# waypoint %d next" % i)
            out.append("")
        out.append("%d.%07d,51.49,1.5" % (3 + (6100000 + 900 * i) // 10000000, (6100000 + 900 * i) % 10000000))
        lines.append(len(out))
    return "\n".join(out) + "\n", lines


def test_line_numbers_recomputed():
    # one (waypoint, line) pair per run of consecutive lines; every number when most break the run
    for n, every in ((300, 0), (300, 7), (300, 1), (2, 0)):
        text, lines = _irregular(n, every)
        trk = track.parse_track_csv(text)
        t.eq([trk.line_no(i) for i in range(n)], lines)
        t.eq([w.line_no for w in trk.waypoints], lines)
    text, lines = _irregular(300, 1)
    e = t.raises(track.TrackError, track.parse_track_csv, text.replace("1.5\n", "0\n", 1))
    t.eq((e.line_no, e.message[:12]), (lines[0], "speed_mps 0 "))


def test_track_distances_as_summed():
    # start_m(i) is bit for bit the running sum of the leg lengths, in any order of asking (from
    # the page's float, or from the cached previous leg)
    text, lines = _irregular(300, 0)
    trk = track.parse_track_csv(text)
    sums = [0.0]
    for i in range(trk.n - 1):
        sums.append(sums[-1] + trk.leg_length_m(i))
    t.eq(trk.length_m, sums[-1])
    for i in (299, 128, 127, 0, 255, 1, 200):  # uncached, across pages
        t.eq(trk.start_m(i), sums[i])
    t.eq([trk.leg(i).start_m for i in range(trk.n - 1)], sums[:-1])  # cached neighbours
    t.eq([trk.leg(i).start_m for i in range(trk.n - 2, -1, -1)], sums[-2::-1])


def test_optional_arrays():
    # no radius or name array when the file has none; both when it has one
    plain = track.parse_track_csv("lon,lat,speed_mps,name,radius_m\n3.61,51.49,1,,\n3.611,51.49,1,,\n")
    t.eq((plain.radius_cm, plain.name_end), (None, None))
    t.eq((plain.waypoints[1].radius_m, plain.waypoints[1].name), (None, None))
    full = track.parse_track_csv("lon,lat,speed_mps,name,radius_m\n3.61,51.49,1,a,\n3.611,51.49,1,,2.5\n")
    t.true(full.radius_cm is not None and full.name_end is not None)
    t.eq([(w.name, w.radius_m) for w in full.waypoints], [("a", None), (None, 2.5)])
    again = track.from_waypoints(full.waypoints)
    t.eq([(w.name, w.radius_m, w.line_no) for w in again.waypoints], [("a", None, 2), (None, 2.5, 3)])


def test_heap_estimate_matches_measured():
    # track_heap_bytes at this interpreter's word and float size against the heap the parsed and
    # validated track holds: never below it, above by at most 1 % or 600 B (the leg cache is
    # counted full; validate fills it only on a track with turns)
    cases = ((2, 0, 0, 0), (9, 4, 1, 0), (130, 3, 0, 0), (129, 16, 0, 2), (1000, 10, 1, 1), (2000, 0, 0, 0),
             (2000, 1, 0, 0), (2000, 5, 1, 0), (2000, 0, 1, 1))
    for n, name_chars, radii, blank_every in cases:
        track_heap.write_named_track(PATH, n, name_chars, radii != 0, blank_every)
        est, live = track_heap.measure_budget(PATH)
        t.true(0 <= est - live <= max(live // 100, 600), "%r: estimated %d B, measured %d B" % (
            (n, name_chars, radii, blank_every), est, live))
        gc.collect()


def test_budget_refused_at_the_crossing_line():
    est = track_heap.write_budget_track(PATH, 2000)
    t.true(est <= track.TRACK_BUDGET_B, est)
    with open(PATH, "rb") as f:
        t.eq(len(track.parse_track_csv(f).waypoints), 2000)
    gc.collect()
    track_heap.write_budget_track(PATH, 2000, over=True)
    with open(PATH, "rb") as f:
        e = t.raises(track.TrackError, track.parse_track_csv, f)
    t.true(e.line_no > 1000, e.line_no)
    t.true(e.message.endswith("B a track may take (tracks/README.md): shorten the names or split the track"),
           e.message)
