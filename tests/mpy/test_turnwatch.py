# nav/turnwatch.py and the los law's use of it under MicroPython: the radius the boat achieves
# while the path asks more, the ram's rate from the reported rudder, arcs planned no tighter than
# the boat turns, the preview lengthened by a slow ram, and U-turns narrower than the boat turns.
import math

import tpassert as t
from _navtracks import Boat, track_from_m
from trackpilot.nav import track
from trackpilot.nav.guidance import LosLaw
from trackpilot.nav.progress import Progress
from trackpilot.nav.turnwatch import TurnWatch


def test_radius_of_a_limited_stretch():
    w = TurnWatch()
    h = 10.0
    # 8 s at 2 m/s turning 5 deg/s to port (sign -1): R = 2 / (5 pi / 180) = 22.92 m
    for _ in range(40):
        t.eq(w.step(0.2, h, 2.0, -1.0, True), 0.0)
        h -= 1.0
    r = w.step(0.2, h, 2.0, -1.0, False)
    t.near(r, 2.0 / math.radians(5.0), 0.05)
    t.near(w.radius_m, r, 1e-6)
    t.eq(w.samples, 1)
    t.near(w.last_sog_mps, 2.0, 1e-6)
    # a short stretch (2 s, under min_s) gives no sample
    for _ in range(10):
        w.step(0.2, h, 2.0, -1.0, True)
        h -= 1.0
    t.eq(w.step(0.2, h, 2.0, -1.0, False), 0.0)
    t.eq(w.samples, 1)
    # a second stretch at 10 deg/s across north (wrap): 11.46 m; the estimate is the mean
    h = 350.0
    for _ in range(30):
        w.step(0.2, h % 360.0, 2.0, 1.0, True)
        h += 2.0
    r2 = w.step(0.2, h % 360.0, 2.0, 1.0, False)
    t.near(r2, 2.0 / math.radians(10.0), 0.05)
    t.near(w.radius_m, (r + r2) / 2.0, 0.05)
    # a stretch turning the wrong way (heading moving against the turn) is no sample
    for _ in range(30):
        w.step(0.2, h % 360.0, 2.0, 1.0, True)
        h -= 2.0
    t.eq(w.step(0.2, h % 360.0, 2.0, 1.0, False), 0.0)


def _feed_ram(w, t0_ms, rate_dps, seconds, period_ms=250, start_deg=0.0, sign=1):
    t_ms = t0_ms
    for k in range(int(seconds * 1000 / period_ms)):
        deg = start_deg + sign * rate_dps * k * period_ms / 1000.0
        deg = max(-30.0, min(30.0, deg))
        w.rudder(t_ms & 0x3FFFFFFF, int(math.floor(deg + 0.5)))
        t_ms += period_ms
    return t_ms


def test_ram_rate_from_the_reported_rudder():
    w = TurnWatch()
    _feed_ram(w, 1000, 6.0, 3.0)
    t.near(w.ram_dps, 6.0, 1.0)  # whole degrees over about 1 s
    t.eq(w.stop_deg, 17)
    # a faster move raises it; the same report twice is ignored
    t_ms = _feed_ram(w, 10000, 12.0, 4.0, start_deg=-5.0, sign=1)
    t.near(w.ram_dps, 12.0, 1.5)
    t.eq(w.rudder(t_ms - 250, 30), False)
    t.eq(w.stop_deg, 30)
    # slow wander (3 deg/s, under ram_min_deg per second) gives nothing
    w = TurnWatch()
    _feed_ram(w, 0, 3.0, 3.0)
    t.eq(w.ram_dps, 0.0)
    # a quick back-and-forth (+-3 deg) is no move: the reversal cuts it
    w = TurnWatch()
    for k in range(20):
        w.rudder(k * 250, 3 if (k // 2) % 2 else -3)
    t.eq(w.ram_dps, 0.0)
    # across the ticks wrap (2^30)
    w = TurnWatch()
    _feed_ram(w, (1 << 30) - 700, 8.0, 3.0)
    t.near(w.ram_dps, 8.0, 1.2)


def _lead(law):
    law.turns.set_lead(law.ram_lead, law.ram_ref_dps)
    return law.turns.lead_s


def test_preview_lengthened_by_a_slow_ram():
    law = LosLaw()
    t.eq(_lead(law), 0.0)  # nothing measured: preview_s as set
    law.turns.ram_dps = 7.5
    law.turns.stop_deg = 29.0
    t.near(_lead(law), 29.0 * (1.0 / 7.5 - 1.0 / 10.0), 1e-4)  # 0.97 s
    law.turns.ram_dps = 12.0
    t.eq(_lead(law), 0.0)  # faster than the reference: as set (never shorter)
    law.turns.ram_dps = 4.0
    t.near(_lead(law), 3.0, 1e-6)  # RAM_LEAD_MAX_S
    law.configure({"ram_lead": 0.0})
    t.eq(_lead(law), 0.0)
    # the rudder not yet driven to 20 deg: no move asked all of the ram, nothing added
    law.configure({"ram_lead": 1.0})
    law.turns.ram_dps = 6.0
    law.turns.stop_deg = 14.0
    t.eq(_lead(law), 0.0)
    # fed through rudder_report: a 6 deg/s ram, to 12 deg (not trusted), then on to 22 deg
    law = LosLaw()
    for k in range(8):
        note = law.rudder_report(1000 + k * 250, int(k * 1.5), True)
    t.near(law.turns.ram_dps, 6.0, 1.0)
    t.eq(law.turns.lead_s, 0.0)
    t.eq(note, "")
    notes = []
    for k in range(8, 16):
        notes.append(law.rudder_report(1000 + k * 250, int(k * 1.5), True))
    t.eq(law.turns.stop_deg, 22)
    t.near(law.turns.lead_s, 22.0 * (1.0 / law.turns.ram_dps - 0.1), 1e-4)
    t.true([n for n in notes if n.startswith("rudder moves at")], repr(notes))
    # the step's preview distance grows by U x lead: the same point sees more of the turn ahead
    trk = _zigzag()
    from _navtracks import make_fix

    b = math.radians(30.0)
    f = make_fix(45.0 * math.sin(b), 45.0 * math.cos(b), 30.0, sog_mps=2.0)
    p0 = Progress(trk)
    p0.update(f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp)
    plain = LosLaw().step(f, p0, 0.2).preview_deg
    t.eq(plain, 0.0)  # 7.2 m before the arc: beyond 3.5 s x 2 m/s
    p1 = Progress(trk)
    p1.update(f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp)
    t.true(law.step(f, p1, 0.2).preview_deg < -1.0)  # 3.5 + 1.5 s: the turn to port is seen
    # not steering: nothing is taken
    law = LosLaw()
    for k in range(12):
        law.rudder_report(1000 + k * 250, int(k * 1.5), False)
    t.eq(law.turns.ram_dps, 0.0)


def _zigzag():
    # zig-zag: 4 legs of 60 m, 60 deg turns, 2 m/s
    pts = [(0.0, 0.0, 2.0)]
    e, n = 0.0, 0.0
    for i in range(4):
        b = math.radians(30.0 if i % 2 == 0 else -30.0)
        e += 60.0 * math.sin(b)
        n += 60.0 * math.cos(b)
        pts.append((e, n, 2.0))
    return track_from_m(pts)


def _sail(law, trk, max_rate_dps, seconds=140.0, dt_s=0.2, heading0_deg=30.0):
    prog = Progress(trk)
    boat = Boat(0.0, 0.0, heading0_deg, 2.0, max_rate_dps=max_rate_dps)
    fix = boat.step(heading0_deg, 0.0)
    law.reset()
    notes = []
    for _ in range(int(seconds / dt_s)):
        prog.update(fix.lat_e7, fix.lon_e7, fix.lat_hp, fix.lon_hp)
        out = law.step(fix, prog, dt_s)
        if out.note:
            notes.append(out.note)
        if prog.finished:
            break
        fix = boat.step(out.heading_cmd_deg, dt_s)
    return notes


def test_arcs_follow_the_boat():
    # 13.5 m arcs planned (1.5 x 9 m); a boat turning at most 4 deg/s at 2 m/s achieves 28.6 m
    trk = _zigzag()
    law = LosLaw()
    law.plan(trk)
    t.near(law.corner_radius_m(1), 13.5, 0.01)
    notes = _sail(law, trk, 4.0)
    # the first the law says of the corners (the tenth round's tightening speaks of the legs)
    said = [n for n in notes if "lookahead x" not in n]
    t.true(said and said[0].startswith("turned at"), repr(notes))
    r = law.turns.radius_m
    t.near(r, 2.0 / math.radians(4.0), 3.0)  # the stretch includes the turn's start: a bit wider
    # the later corners are planned at turn_margin x the measured radius; legs of 60 m allow it
    t.near(law.corner_radius_m(3), 1.2 * r, 0.05)
    t.near(law._want, 1.2 * r, 1e-4)
    t.near(law.turns.want_m, 1.2 * r, 1e-4)
    # a boat that turns its arcs (10 deg/s: 11.5 m < 13.5 m) never asks for more
    law = LosLaw()
    notes = _sail(law, trk, 10.0)
    t.eq([n for n in notes if n.startswith("turned")], [], repr(notes))
    t.near(law.corner_radius_m(3), 13.5, 0.01)
    # off: the plan stays as configured
    law = LosLaw(turn_margin=0.0)
    _sail(law, trk, 4.0)
    t.near(law.corner_radius_m(3), 13.5, 0.01)
    t.eq(law.turns.samples, 0)


def test_new_radius_waits_for_a_straight():
    trk = _zigzag()
    law = LosLaw()
    law.plan(trk)
    law.turns.pending_m = 30.0
    # on the first arc (the corner at waypoint 1 starts 60 - 13.5 tan 30 = 52.2 m along leg 0)
    prog = Progress(trk)
    from _navtracks import make_fix

    b = math.radians(30.0)
    f = make_fix(56.0 * math.sin(b), 56.0 * math.cos(b), 40.0, sog_mps=2.0)
    prog.update(f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp)
    out = law.step(f, prog, 0.2)
    t.true(out.arc_radius_m > 0.0)
    t.near(law._want, 13.5, 1e-6)  # not applied on the arc
    t.eq(law.turns.pending_m, 30.0)
    # on the straight of leg 1, 30 m along: 30 m arcs need 17.3 m of tangent, the corner behind
    # grows past the boat? 30 > 17.3: no, so it applies
    e1, n1 = 60.0 * math.sin(b), 60.0 * math.cos(b)
    f = make_fix(e1 + 25.0 * math.sin(-b), n1 + 25.0 * math.cos(-b), -30.0, sog_mps=2.0)
    prog.update(f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp)
    out = law.step(f, prog, 0.2)
    t.eq(prog.leg, 1)
    t.near(law._want, 30.0, 1e-6)
    t.eq(law.turns.pending_m, 0.0)
    t.near(law.corner_radius_m(2), 30.0, 0.01)
    # 12 m into leg 1 with 40 m asked: the corner behind would start 40 tan 30 = 23.1 m into the
    # leg, the boat would be back on its arc: refused, still pending, the plan as it was
    law = LosLaw()
    law.plan(trk)
    law.turns.pending_m = 40.0
    prog = Progress(trk)
    prog.update(f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp)  # the point above first: leg 1
    f = make_fix(e1 + 12.0 * math.sin(-b), n1 + 12.0 * math.cos(-b), -30.0, sog_mps=2.0)
    prog.update(f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp)
    out = law.step(f, prog, 0.2)
    t.eq(prog.leg, 1)
    t.eq(out.arc_radius_m, 0.0)
    t.near(law._want, 13.5, 1e-6)
    t.eq(law.turns.pending_m, 40.0)
    t.near(law.corner_radius_m(1), 13.5, 0.01)
    # 18 m asked at the same point: the corner behind ends 10.4 m into the leg, before the boat
    law.turns.pending_m = 18.0
    law.step(f, prog, 0.2)
    t.near(law._want, 18.0, 1e-6)
    t.eq(law.turns.pending_m, 0.0)


def test_narrow_uturn_reported():
    trk = track_from_m([(0, 0, 2.0), (0, 200, 1.5), (20, 200, 1.5), (20, 0, 1.5)])
    k, w = track.narrow_uturn(trk, 0, 28.0)
    t.eq(k, 1)
    t.near(w, 20.0, 0.01)
    t.eq(track.narrow_uturn(trk, 2, 100.0), (0, 0.0))  # the last corner has no second one
    w = track.validate(trk, {"turn_radius_m": 12.0})
    u = [x for x in w if "U-turn" in x]
    t.eq(len(u), 1, repr(w))
    t.true("U-turn 20.0 m wide" in u[0] and "2 x 12.0 m" in u[0] and "4.0 m past" in u[0], u[0])
    t.eq([x for x in track.validate(trk, {"turn_radius_m": 9.0}) if "U-turn" in x], [])
    # a zig-zag (turns alternate) is no U-turn
    t.eq(track.narrow_uturn(_zigzag(), 0, 100.0), (0, 0.0))
    # the first one ahead of a leg, narrower than a width asked
    t.eq(track.narrow_uturn(trk, 0, 18.0), (0, 0.0))
    t.eq(track.narrow_uturn(trk, 2, 28.0), (0, 0.0))  # passed


def test_narrow_uturn_told_in_auto():
    # lawnmower: 4 lines of 60 m, 20 m apart; a boat turning at most 4 deg/s at 2 m/s (28.6 m)
    pts = [(0, 0, 2.0), (0, 60, 2.0), (20, 60, 2.0), (20, 0, 2.0), (40, 0, 2.0), (40, 60, 2.0)]
    trk = track_from_m(pts)
    law = LosLaw()
    notes = _sail(law, trk, 4.0, seconds=200.0, heading0_deg=0.0)
    told = [n for n in notes if "U-turn at" in n]
    # measured on the first U-turn, told for the next one (wp 3), once
    t.eq(len(told), 1, repr(notes))
    t.true("U-turn at wp 3" in told[0] and "20 m wide" in told[0], told[0])
    t.true(law.turns.radius_m > 10.0, law.turns.radius_m)
    # off (turn_margin 0): nothing measured, nothing told
    law = LosLaw(turn_margin=0.0)
    notes = _sail(law, trk, 4.0, seconds=200.0, heading0_deg=0.0)
    t.eq([n for n in notes if "U-turn at" in n], [])
