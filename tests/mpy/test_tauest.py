# nav/tauest.py under MicroPython: the heading response's tau (and dead time) recovered from key
# steps of a simulated first order plus dead time with noise; no update on a turn or a gap, none
# from a step too small or one the next command cuts short; ticks across the 2^30 wrap.
import math

import tpassert as t
from trackpilot.compat import ticks_add
from trackpilot.nav.tauest import TauEstimate


def _noise(k):
    return math.sin(k * 12.9898) * 0.5 + math.sin(k * 78.233) * 0.5


def _sail(est, tau_s, dead_s, steps, t0_ms=0, dt_ms=100, noise_deg=0.3, ok=None, bias_deg=1.5):
    """steps: [(t_s, locked_deg)], the locked course from t_s on. The heading: first order of
    tau_s behind the locked course delayed dead_s, plus a steady bias (deadband, offset) and noise.
    Returns the times (s) at which the estimate changed."""
    h = steps[0][1] + bias_deg
    changes = []
    n = int((steps[-1][0] + 40.0) * 1000 / dt_ms)
    for k in range(n):
        ts = k * dt_ms / 1000.0
        c_now = c_late = steps[0][1]
        for st_s, c in steps:
            if ts >= st_s:
                c_now = c
            if ts - dead_s >= st_s:
                c_late = c
        h += (c_late + bias_deg - h) * (dt_ms / 1000.0) / tau_s
        good = ok(ts) if ok else True
        if est.step(ticks_add(t0_ms, k * dt_ms), c_now % 360.0, (h + noise_deg * _noise(k)) % 360.0, good):
            changes.append(ts)
    return changes


def _steps(n, first_s=10.0, every_s=40.0, size_deg=8.0, base=350.0):
    out = [(0.0, base)]
    for i in range(n):
        out.append((first_s + i * every_s, base + (size_deg if i % 2 == 0 else 0.0)))
    return out


def test_tau_recovered_within_15_percent():
    for tau_s, dead_s in ((2.0, 0.5), (5.0, 1.0), (10.0, 0.8)):
        est = TauEstimate(3.0)
        _sail(est, tau_s, dead_s, _steps(4))
        want = tau_s + dead_s  # the time to 63 %
        t.true(est.samples >= 3, (tau_s, est.samples))
        t.true(abs(est.tau_s - want) <= 0.15 * want, (tau_s, dead_s, est.tau_s))
        t.true(abs(est.dead_s - dead_s) <= 0.5 + 0.15 * dead_s, (tau_s, dead_s, est.dead_s))


def test_ticks_wrap():
    est = TauEstimate(3.0)
    _sail(est, 5.0, 1.0, _steps(4), t0_ms=(1 << 30) - 30000)
    t.true(abs(est.tau_s - 6.0) <= 0.9, est.tau_s)


def test_one_odd_sample_does_not_move_it():
    est = TauEstimate(3.0)
    _sail(est, 8.0, 0.5, _steps(1))
    t.eq(est.samples, 1)
    t.eq(est.tau_s, 3.0)  # the median of (prior, prior, 8.5)


def test_no_update_in_a_turn_or_gap():
    est = TauEstimate(3.0)
    # ok goes false 3 s after each step (a turn, a GNSS gap): no step is completed
    changes = _sail(est, 6.0, 0.5, _steps(4), ok=lambda ts: ((ts - 10.0) % 40.0) < 3.0)
    t.eq(est.samples, 0)
    t.eq(changes, [])
    t.eq(est.tau_s, 3.0)


def test_small_steps_and_cut_steps_are_ignored():
    est = TauEstimate(3.0)
    _sail(est, 6.0, 0.5, _steps(4, size_deg=2.0))  # under step_min_deg
    t.eq(est.samples, 0)
    # the next command comes 2 s after each step (before 63 %): no sample
    steps = [(0.0, 10.0)]
    for i in range(4):
        steps.append((10.0 + 40.0 * i, 20.0))
        steps.append((12.0 + 40.0 * i, 10.0))
    est = TauEstimate(3.0)
    _sail(est, 6.0, 0.5, steps)
    t.eq(est.samples, 0)


def test_bounded():
    est = TauEstimate(3.0, hi_s=8.0)
    _sail(est, 12.0, 0.5, _steps(4))  # 63 % at 12.5 s: above the bound
    t.eq(est.tau_s, 8.0)


def test_overshoot_of_an_underdamped_pilot():
    # a second-order heading response (zeta 0.3): overshoot about 37 %
    est = TauEstimate(3.0)
    wn = 1.0
    z = 0.3
    h = 0.0
    r = 0.0
    dt = 0.1
    for k in range(600):
        ts = k * dt
        c = 10.0 if ts >= 10.0 else 0.0
        a = wn * wn * (c - h) - 2 * z * wn * r
        r += a * dt
        h += r * dt
        est.step(k * 100, c % 360.0, h % 360.0, True)
    t.true(0.25 < est.overshoot < 0.5, est.overshoot)
