# App.load_track never raises: a bad, too large or unreadable file, or one that does not fit in
# memory, gives a TRACK event and a refusal, and the active track stays.
import sys

import tpassert as t
from _appwiring import HAVE_ASYNCIO, Wiring
from trackpilot import config
from trackpilot.nav import track

sys.path.append("firmware/tools")
import track_heap  # noqa: E402

DIR = "/tmp/trackpilot_test_app_track"


def _app():
    from trackpilot.app import App

    w = Wiring(DIR)
    return App(w, config.defaults(), ()), w


def _app_with_a_track():
    """An app that has loaded a good 40-waypoint track: (app, wiring, that track)."""
    app, w = _app()
    good = DIR + "/good.csv"
    track_heap.write_track(good, 40)
    app.load_track(good)
    return app, w, app.track


def _write(path, data):
    with open(path, "wb") as f:
        f.write(data)


def test_good_then_bad_files_keep_the_track():
    if not HAVE_ASYNCIO:
        print("skipped: no asyncio")
        return
    app, w = _app()
    good = DIR + "/good.csv"
    track_heap.write_track(good, 40)
    t.eq(app.load_track(good), (True, "ok"))
    first = app.track
    t.eq(len(first.waypoints), 40)
    cases = [
        (b"lon,lat,speed_mps\n3.61,51.49,1\n3.61,51.4901,x\n", "line 3: speed_mps 'x' is not a number"),
        (b"lon,lat,speed_mps\n3.61,51.49,1\n3.61,51.4901,1\n\xff\xfe\n", "line 4: the file is not UTF-8 text"),
        (b"\x00" * 3000, "line 1: line longer than 512 characters"),
    ]
    for data, want in cases:
        _write(DIR + "/bad.csv", data)
        ok, msg = app.load_track(DIR + "/bad.csv")
        t.true(not ok and want in msg, msg)
        t.true(app.track is first, "the active track stays")
        t.true(("TRACK track %s/bad.csv rejected: %s" % (DIR, want)) in w.lines[-1], w.lines[-1])
    ok, msg = app.load_track(DIR + "/missing.csv")
    t.true(not ok and "rejected" in msg and app.track is first, msg)


def test_too_many_waypoints_refused():
    if not HAVE_ASYNCIO:
        print("skipped: no asyncio")
        return
    app, w = _app()
    path = DIR + "/big.csv"
    track_heap.write_named_track(path, track.MAX_WAYPOINTS + 1)  # no names: only the count is wrong
    ok, msg = app.load_track(path)
    t.true(not ok, msg)
    t.true("line 2002: more than 2000 waypoints" in msg, msg)
    t.eq(app.track, None)


def test_over_the_budget_refused():
    if not HAVE_ASYNCIO:
        print("skipped: no asyncio")
        return
    app, w, first = _app_with_a_track()
    path = DIR + "/heavy.csv"
    track_heap.write_budget_track(path, track.MAX_WAYPOINTS, over=True)
    ok, msg = app.load_track(path)
    t.true(not ok and "shorten the names or split the track" in msg, msg)
    t.true(("TRACK track %s rejected: line " % path) in w.lines[-1], w.lines[-1])
    t.true(app.track is first, "the active track stays")


def test_memory_error_is_a_refusal():
    if not HAVE_ASYNCIO:
        print("skipped: no asyncio")
        return
    app, w, first = _app_with_a_track()
    real = track.load_file

    def no_memory(path, min_leg_m=track.MIN_LEG_M):
        raise MemoryError("memory allocation failed")

    track.load_file = no_memory
    try:
        ok, msg = app.load_track(DIR + "/good.csv")
    finally:
        track.load_file = real
    t.true(not ok and "not enough memory" in msg and "previous track stays" in msg, msg)
    t.true(app.track is first)
