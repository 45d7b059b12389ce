# nav/swing.py under MicroPython: the on-line swing watch fires on a sustained regular swing and not
# on noise, a decaying response, a steady offset or an irregular wander.
import math

import tpassert as t
from trackpilot.nav.swing import SwingWatch


def _run(w, f, seconds, dt_s=0.2):
    """Feed f(t) for `seconds`; the times (s) at which the watch fired."""
    fired = []
    n = int(seconds / dt_s)
    for k in range(n):
        ts = k * dt_s
        if w.step(dt_s, f(ts)):
            fired.append(ts)
    return fired


def _noise(k):  # deterministic pseudo-noise in -1..1 (no random module needed)
    return math.sin(k * 12.9898) * 0.5 + math.sin(k * 78.233) * 0.5


def test_sustained_swing_fires_after_need_half_cycles():
    w = SwingWatch(0.2, 0.5, 2, min_half_s=2.0, max_half_s=60.0)
    fired = _run(w, lambda ts: 3.0 * math.sin(2 * math.pi * ts / 20.0), 100.0)
    # first half cycle (from the start) not counted; then 2 qualifying halves: fires at ~30 s
    t.true(len(fired) >= 2, fired)
    t.near(fired[0], 30.0, 1.0)
    t.near(w.amp, 3.0, 0.05)
    t.near(2 * w.first_s, 20.0, 0.5)


def test_decaying_response_does_not_fire():
    w = SwingWatch(0.2, 0.5, 2, min_half_s=2.0, max_half_s=60.0)
    # keeps 40 % of its amplitude per half cycle (damping ratio about 0.28): not a swing
    fired = _run(w, lambda ts: 5.0 * math.exp(-ts * math.log(2.5) / 10.0) * math.cos(2 * math.pi * ts / 20.0), 120.0)
    t.eq(fired, [])


def test_noise_and_offset_do_not_fire():
    w = SwingWatch(0.2, 0.5, 2, min_half_s=2.0, max_half_s=60.0)
    t.eq(_run(w, lambda ts: 0.15 * _noise(int(ts * 5)), 300.0), [])  # inside the band: no crossings
    w.reset()
    t.eq(_run(w, lambda ts: 1.5 + 0.3 * _noise(int(ts * 5)), 300.0), [])  # a steady offset
    w.reset()
    # noise across zero: crossings every sample or two, far shorter than min_half_s
    t.eq(_run(w, lambda ts: 0.8 * _noise(int(ts * 5)), 300.0), [])


def test_small_swing_below_amplitude_does_not_fire():
    w = SwingWatch(0.2, 0.5, 2, min_half_s=2.0, max_half_s=60.0)
    t.eq(_run(w, lambda ts: 0.4 * math.sin(2 * math.pi * ts / 20.0), 200.0), [])


def test_irregular_period_does_not_fire():
    w = SwingWatch(0.2, 1.0, 3, min_half_s=1.0, max_half_s=60.0)
    # half cycles of 3 s, 12 s, 3 s, 12 s ...: durations differ by 4x, not a regular period
    seq = []
    s = 1.0
    tt = 0.0
    for k in range(20):
        d = 3.0 if k % 2 == 0 else 12.0
        seq.append((tt, tt + d, s))
        tt += d
        s = -s

    def f(ts):
        for a, b, sg in seq:
            if a <= ts < b:
                return sg * 2.0 * math.sin(math.pi * (ts - a) / (b - a))
        return 0.0

    t.eq(_run(w, f, tt, dt_s=0.1), [])


def _approach(ts, over_m, start_m=5.0):
    """An approach from start_m off: down to the path in 15 s, over it by over_m (a 20 s half
    cycle), back over by half of that, then on the path."""
    if ts < 15.0:
        return start_m * math.cos(0.5 * math.pi * ts / 15.0)
    if ts < 35.0:
        return -over_m * math.sin(math.pi * (ts - 15.0) / 20.0)
    if ts < 55.0:
        return 0.5 * over_m * math.sin(math.pi * (ts - 35.0) / 20.0)
    return 0.0


def test_overshoot_of_the_approach():
    # overshoots by 4 m of 5 m (0.8): true from where the overshoot reaches 0.7 x 5 m = 3.5 m
    w = SwingWatch(0.2, 1.0, 2, min_half_s=2.0, max_half_s=60.0)
    seen = []
    for k in range(400):
        ts = k * 0.2
        w.step(0.2, _approach(ts, 4.0))
        if w.overshoot(0.7):
            seen.append(ts)
    t.true(len(seen) > 0, seen)
    # 4 sin(pi (t - 15) / 20) = 3.5 at t = 15 + 20 asin(0.875) / pi = 21.8 s; false again once it closed
    t.near(seen[0], 21.8, 0.3)
    t.true(seen[-1] < 36.0, seen[-1])  # the next crossing (35 s, out of the +-0.2 m band) closes it
    t.eq(w.closed, 2)  # the approach and the overshoot closed; the third half cycle still open
    # the nominal boat's approach: over by 1.9 m of 5 m (0.38, measured at 3 m/s): never
    w.reset()
    for k in range(400):
        w.step(0.2, _approach(k * 0.2, 1.9))
        t.eq(w.overshoot(0.7), False)
    # off (ratio 0) and below amp_min (0.9 m of 1.2 m): never
    w.reset()
    for k in range(400):
        w.step(0.2, _approach(k * 0.2, 4.0))
        t.eq(w.overshoot(0.0), False)
    w.reset()
    for k in range(400):
        w.step(0.2, _approach(k * 0.2, 0.9, start_m=1.2))
        t.eq(w.overshoot(0.7), False)
