# progress.py under MicroPython: signs, leg advance, loops, joining, skip/back, the end.
import tpassert as t
from _navtracks import pos, track_from_m
from trackpilot.nav.progress import RULE_SEED, Progress


def _at(prog, e, n):
    la, lo, lah, loh = pos(e, n)
    return prog.update(la, lo, lah, loh)


def _square():
    return track_from_m([(0, 0, 2.0), (0, 100, 2.0), (100, 100, 1.5), (100, 0, 1.0)])


def test_signs_and_distances():
    prog = Progress(_square())
    _at(prog, 3.0, 40.0)  # 3 m east of a northbound leg: starboard
    t.eq(prog.leg, 0)
    t.near(prog.xte_m, 3.0, 0.01)
    t.near(prog.along_m, 40.0, 0.01)
    t.near(prog.to_wp_m, (60.0 ** 2 + 9.0) ** 0.5, 0.01)
    t.near(prog.remain_m, 60.0, 0.01)
    t.near(prog.leg_bearing_deg, 0.0, 0.01)
    t.near(prog.track_m, 40.0, 0.01)
    _at(prog, -2.5, 10.0)
    t.near(prog.xte_m, -2.5, 0.01)
    t.eq(prog.speed_mps(), 2.0)


def test_advance_at_corner_and_end():
    prog = Progress(_square())
    _at(prog, 0.0, 50.0)
    _at(prog, 1.0, 97.0)  # inside the corner, nearer to leg 0 still
    t.eq(prog.leg, 0)
    _at(prog, 4.0, 98.0)  # nearer to the eastbound leg now
    t.eq(prog.leg, 1)
    t.near(prog.xte_m, 2.0, 0.01)  # south of an eastbound leg: starboard
    t.near(prog.leg_bearing_deg, 90.0, 0.02)
    t.near(prog.track_m, 100.0 + 4.0, 0.05)
    _at(prog, 60.0, 100.0)
    t.eq(prog.speed_mps(), 2.0)  # leg i is sailed at waypoint i's speed
    _at(prog, 100.0, 60.0)
    t.eq(prog.leg, 2)
    t.eq(prog.speed_mps(), 1.5)
    t.eq(prog.finished, False)
    _at(prog, 101.0, 3.5)  # inside the 3 m default arrival radius? 3.6 m: not yet
    t.eq(prog.finished, False)
    _at(prog, 101.0, 2.0)
    t.eq((prog.finished, prog.finish_reason), (True, "arrived"))


def test_end_passed_perpendicular():
    prog = Progress(_square())
    prog.join_nearest(*pos(100.0, 60.0))
    t.eq(prog.leg, 2)
    _at(prog, 108.0, 1.0)
    t.eq(prog.finished, False)
    _at(prog, 108.0, -0.5)  # 8 m off but past the end: finished, reason recorded
    t.eq((prog.finished, prog.finish_reason), (True, "passed_end"))


def test_outside_corner_advances():
    # boat swings wide outside the corner: equally far from both legs until the end
    # perpendicular (a tie that the plain seed rule leaves to rounding); passing it advances
    prog = Progress(_square())
    _at(prog, -3.0, 50.0)
    _at(prog, -3.0, 99.9)
    t.eq(prog.leg, 0)
    _at(prog, -3.0, 100.1)
    t.eq(prog.leg, 1)
    t.near(prog.xte_m, -0.1, 0.01)  # north of an eastbound leg: port


def test_self_crossing_loop_does_not_jump():
    # a figure of eight: leg 3 crosses leg 0 at (0, 50)
    trk = track_from_m([(0, 0, 2.0), (0, 100, 2.0), (50, 100, 2.0), (-50, 0, 2.0), (-50, 150, 1.0)])
    prog = Progress(trk)
    for n in range(0, 100, 5):
        _at(prog, 0.3, float(n))
        t.eq(prog.leg, 0, "at n=%d" % n)
    # and a loop closing on its start: the last leg ends where the first begins
    trk = track_from_m([(0, 0, 2.0), (0, 100, 2.0), (60, 100, 2.0), (60, 0, 2.0), (1, 0, 1.0)])
    prog = Progress(trk)
    _at(prog, 0.5, 1.0)  # start at the quay, which is also the end of the last leg
    t.eq(prog.leg, 0)
    t.eq(prog.finished, False)
    for n in range(1, 95, 3):
        _at(prog, 0.0, float(n))
        t.eq(prog.leg, 0)


def test_hairpin_does_not_advance_early():
    # out and back on a 177 deg hairpin: near the start the return leg is nearer than the
    # current one; the plain seed rule jumps there, the robust rule waits for the end window
    trk = track_from_m([(0, 0, 2.0), (0, 150, 2.0), (8, 0, 2.0)])
    prog = Progress(trk)
    seed = Progress(trk, RULE_SEED)
    for p in (prog, seed):
        _at(p, 3.0, 5.0)
        t.eq(p.leg, 0)
        _at(p, 5.0, 20.0)  # 5 m starboard of leg 0, 1.9 m from the return leg
    t.eq(prog.leg, 0)
    t.eq(seed.leg, 1)
    _at(prog, 0.5, 125.0)
    t.eq(prog.leg, 0)
    _at(prog, 1.5, 149.0)
    t.eq(prog.leg, 1)


def test_join_nearest_ahead():
    trk = track_from_m([(0, 0, 2.0), (0, 100, 2.0), (100, 100, 2.0), (100, 0, 2.0), (200, 0, 1.0)])
    prog = Progress(trk)
    _at(prog, 40.0, 110.0)  # start off the track, beside leg 1
    t.eq(prog.leg, 1)
    t.near(prog.xte_m, -10.0, 0.01)
    # a person steered to near leg 3; re-engage joins it
    prog.join_nearest(*pos(150.0, 3.0))
    t.eq(prog.leg, 3)
    # re-engage never goes back to an earlier leg
    prog.join_nearest(*pos(0.0, 50.0))
    t.eq(prog.leg, 3)
    # the window limits how far ahead it looks
    prog = Progress(trk, join_window_m=150.0)
    _at(prog, 150.0, 3.0)
    t.true(prog.leg <= 2, "leg %d" % prog.leg)


def test_join_skips_passed_legs():
    prog = Progress(_square())
    _at(prog, 2.0, 104.0)  # beyond the end of leg 0, at the start of leg 1
    t.eq(prog.leg, 1)


def test_skip_and_back():
    prog = Progress(_square())
    _at(prog, 0.0, 30.0)
    prog.skip()
    t.eq(prog.leg, 1)
    _at(prog, 0.0, 35.0)
    t.eq(prog.leg, 1)  # stays on the skipped-to leg (boat behind its start)
    t.near(prog.along_m, 0.0, 0.05)
    prog.back()
    t.eq(prog.leg, 0)
    _at(prog, 0.0, 40.0)
    t.eq(prog.leg, 0)
    # back from leg 1 while at its middle: held on leg 0 until nearer to it again
    _at(prog, 3.0, 99.0)
    _at(prog, 10.0, 99.0)
    t.eq(prog.leg, 1)
    _at(prog, 50.0, 100.0)
    prog.back()
    _at(prog, 50.0, 100.0)
    t.eq(prog.leg, 0)
    _at(prog, 40.0, 101.0)
    t.eq(prog.leg, 0)
    _at(prog, 1.0, 80.0)  # came back to leg 0
    _at(prog, 1.0, 99.5)
    _at(prog, 6.0, 100.0)
    t.eq(prog.leg, 1)
    prog.skip()
    prog.skip()
    t.eq((prog.leg, prog.finished, prog.finish_reason), (2, True, "skipped"))
    prog.back()
    t.eq((prog.leg, prog.finished), (1, False))


def test_waypoint_radius_advances():
    trk = track_from_m([(0, 0, 2.0), (0, 100, 2.0, "a,12"), (100, 100, 1.0)])
    t.eq(trk.waypoints[1].radius_m, 12.0)
    prog = Progress(trk)
    _at(prog, 0.0, 50.0)
    _at(prog, -7.0, 91.0)  # 11.4 m from the waypoint, outside the corner
    t.eq(prog.leg, 1)


def test_set_leg():
    prog = Progress(_square())
    prog.set_leg(2)
    _at(prog, 100.0, 50.0)
    t.eq(prog.leg, 2)
    t.raises(ValueError, prog.set_leg, 3)
    t.raises(ValueError, prog.set_leg, -1)
