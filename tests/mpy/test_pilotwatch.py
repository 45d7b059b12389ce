# core/pilotwatch.py under MicroPython: the pilot-hunting watch fires on a heading swinging about a
# steady locked course, not on a steady course with noise, and not when the locked course swings
# with the heading (the track loop, not the pilot); it reports the end of the hunting too.
import math

import tpassert as t
from trackpilot.core.pilotwatch import HUNT_TEXT, PilotWatch


def _noise(k):
    return math.sin(k * 12.9898) * 0.5 + math.sin(k * 78.233) * 0.5


def _feed(w, seconds, heading, course, t0_ms=0, dt_ms=500):
    texts = []
    for k in range(int(seconds * 1000 / dt_ms)):
        ts = k * dt_ms / 1000.0
        txt = w.step(t0_ms + k * dt_ms, dt_ms / 1000.0, heading(ts) % 360.0, course(ts) % 360.0)
        if txt:
            texts.append((ts, txt))
    return texts


def test_hunting_pilot_is_reported_once():
    w = PilotWatch()
    # +-6 deg about a locked course of 90, period 8 s (a pilot with too much gain)
    texts = _feed(w, 120.0, lambda ts: 90.0 + 6.0 * math.sin(2 * math.pi * ts / 8.0), lambda ts: 90.0)
    t.eq(len(texts), 1, texts)
    t.true(texts[0][1].startswith(HUNT_TEXT), texts)
    t.true(texts[0][0] < 30.0, texts)  # within a few periods
    t.true(w.hunting)
    t.near(w.hunt_period_s, 8.0, 1.0)


def test_steady_course_with_noise_is_not_hunting():
    w = PilotWatch()
    # wave yaw and compass noise: +-1.5 deg, no regular swing
    texts = _feed(w, 300.0, lambda ts: 180.0 + 1.5 * _noise(int(ts * 2)), lambda ts: 180.0)
    t.eq(texts, [])
    t.true(not w.hunting)


def test_course_swinging_with_heading_is_the_track_loop():
    w = PilotWatch()
    # the locked course itself swings +-10 deg (period 20 s) and the heading follows 2 s late
    c = lambda ts: 10.0 + 10.0 * math.sin(2 * math.pi * ts / 20.0)  # noqa: E731
    texts = _feed(w, 300.0, lambda ts: c(ts - 2.0), c)
    t.eq(texts, [])


def test_hunting_ends_is_reported():
    w = PilotWatch()
    texts = _feed(w, 80.0, lambda ts: 350.0 + 5.0 * math.sin(2 * math.pi * ts / 6.0), lambda ts: 350.0)
    t.true(w.hunting)
    texts = _feed(w, 120.0, lambda ts: 350.0 + 0.3 * _noise(int(ts * 2)), lambda ts: 350.0, t0_ms=80000)
    t.eq(len(texts), 1, texts)
    t.eq(texts[0][1], "pilot steady again")
    t.true(not w.hunting)


def test_repeated_status_is_ignored():
    w = PilotWatch()
    for _ in range(200):  # the same status many times (epochs faster than the pilot's 2 Hz)
        t.eq(w.step(1000, 0.5, 100.0, 90.0), "")
    t.true(not w.hunting)
