# nav/tighten.py under MicroPython, and the los law's use of it: the lookahead is tightened only
# after the boat has held the path on a straight, a turn suspends it, and a growing xte or an act
# of the swing watch sets it back until the next engage (docs/NAVIGATION.md "Tenth round").
import math
from array import array

import tpassert as t
from _navtracks import Boat, track_from_m
from trackpilot.nav.guidance import LosLaw
from trackpilot.nav.progress import Progress
from trackpilot.nav.tighten import Tighten

_ARGS = (0.67, 20.0, 0.5, 0.8)  # scale, wait_s, band_m, exit_m


def _feed(w, seconds, y_m, straight=True, calm=True, dt_s=0.2):
    """Feed a constant xte; the factors returned and the notes said."""
    factors, notes = [], []
    for _ in range(int(seconds / dt_s + 0.5)):
        factors.append(w.step(dt_s, y_m, straight, calm, *_ARGS))
        if w.note:
            notes.append(w.note)
    return factors, notes


def test_tightens_only_after_the_wait_within_the_band():
    w = Tighten()
    f, notes = _feed(w, 19.6, 0.4)
    t.eq(set(f), {1.0})
    t.eq(notes, [])
    f, notes = _feed(w, 0.4, -0.4)  # either side of the path counts
    t.eq(f[-1], 0.67)
    t.eq(len(notes), 1)
    t.true("lookahead x0.67" in notes[0], notes)
    f, notes = _feed(w, 60.0, 0.7)  # within exit_m: stays tight, says nothing more
    t.eq(set(f), {0.67})
    t.eq(notes, [])


def test_the_wait_starts_again_outside_the_band_or_off_a_straight():
    for kw in ({"y_m": 0.6}, {"y_m": 0.1, "straight": False}, {"y_m": 0.1, "calm": False}):
        w = Tighten()
        _feed(w, 15.0, 0.1)
        _feed(w, 0.2, **kw)
        f, _ = _feed(w, 15.0, 0.1)
        t.eq(set(f), {1.0}, kw)  # 15 s again are not 20 s
        f, _ = _feed(w, 5.2, 0.1)
        t.eq(f[-1], 0.67, kw)


def test_a_growing_xte_sets_it_back_until_the_next_engage():
    w = Tighten()
    _feed(w, 20.0, 0.0)
    t.true(w.on)
    f, notes = _feed(w, 0.2, 0.81)
    t.eq(f, [1.0])
    t.eq(len(notes), 1)
    t.true("0.81 m" in notes[0] and "next engage" in notes[0], notes)
    f, notes = _feed(w, 120.0, 0.0)  # held again for minutes: not again
    t.eq(set(f), {1.0})
    t.eq(notes, [])
    w.reset()  # a new engage
    f, _ = _feed(w, 20.0, 0.0)
    t.eq(f[-1], 0.67)


def test_an_act_of_the_watches_sets_it_back_a_turn_only_suspends_it():
    w = Tighten()
    _feed(w, 20.0, 0.0)
    f, notes = _feed(w, 0.2, 0.0, calm=False)
    t.eq(f, [1.0])
    t.eq(len(notes), 1)
    t.true("swing watch" in notes[0], notes)
    f, _ = _feed(w, 60.0, 0.0)
    t.eq(set(f), {1.0})
    w = Tighten()
    _feed(w, 20.0, 0.0)
    f, notes = _feed(w, 10.0, 0.0, straight=False)  # an arc: the plain lookahead, nothing said
    t.eq(set(f), {1.0})
    t.eq(notes, [])
    f, _ = _feed(w, 19.8, 0.0)
    t.eq(f[-1], 1.0)
    f, _ = _feed(w, 0.2, 0.0)
    t.eq(f[-1], 0.67)  # the next straight, after its own wait


def test_scale_one_is_off():
    w = Tighten()
    for _ in range(500):
        t.eq(w.step(0.2, 0.0, True, True, 1.0, 20.0, 0.5, 0.8), 1.0)
    t.eq(w.note, "")


def _step(law, prog, fix, dt_s):
    prog.update(fix.lat_e7, fix.lon_e7, fix.lat_hp, fix.lon_hp)
    return law.step(fix, prog, dt_s)


def _sail(law, seconds, u_mps=3.0, dt_s=0.2):
    """The kinematic boat (1.5 s heading lag) on a 3 m/s straight in a 0.2 m/s cross current,
    from 3 m off: (lookahead m per step, xte m per step, the law's notes)."""
    trk = track_from_m([(0, 0, u_mps), (0, 3000, u_mps)])
    prog = Progress(trk)
    boat = Boat(3.0, 0.0, 0.0, u_mps, 0.2)
    fix = boat.step(0.0, 0.0)
    law.reset()
    n = int(seconds / dt_s)
    las = array("f", bytes(4 * n))
    xs = array("f", bytes(4 * n))
    notes = []
    for i in range(n):
        out = _step(law, prog, fix, dt_s)
        las[i] = out.lookahead_m
        xs[i] = out.xte_m
        if out.note:
            notes.append(out.note)
        fix = boat.step(out.heading_cmd_deg, dt_s)
    return las, xs, notes


def test_the_law_tightens_a_boat_that_holds_the_line():
    scale = LosLaw.PARAMS["tight_scale"][0]
    t.true(scale < 1.0)  # on by default
    las, xs, notes = _sail(LosLaw(), 120.0)
    plain, _, plain_notes = _sail(LosLaw(tight_scale=1.0), 120.0)
    t.near(plain[25], 18.0, 0.3)  # 2 x 3 m/s x 3 s (the SOG in the current)
    t.near(las[25], plain[25], 0.01)  # the approach: not yet
    t.near(las[-1], scale * plain[-1], 0.05)
    said = [n for n in notes if "lookahead x%.2f" % scale in n]
    t.eq(len(said), 1, notes)
    t.eq([n for n in plain_notes if "lookahead x" in n], [])
    t.true(max(abs(x) for x in xs[-100:]) < 0.2, max(abs(x) for x in xs[-100:]))
