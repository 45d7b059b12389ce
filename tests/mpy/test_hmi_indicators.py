# LEDs and buzzer: pure patterns, GPS LED per RTK state, cues derived from the status.
import tpassert as T
from tphmi.indicators import ALARM, ENGAGE, PATTERNS, REFUSED, STANDBY, TAKEOVER, Indicators, gps_led_level
from tphmi.status import HmiStatus


def _trace(p, ms, step=10):
    return [p.level_at(t) for t in range(0, ms, step)]


def test_patterns_distinct_and_engage_shape():
    seen = []
    for p in PATTERNS:
        tr = _trace(p, 4000)
        T.true(tr not in seen, "pattern %s not distinct" % p.name)
        seen.append(tr)
    T.eq(ENGAGE.level_at(40), 1)
    T.eq(ENGAGE.level_at(120), 0)
    T.eq(ENGAGE.level_at(200), 1)
    T.eq(ENGAGE.level_at(1000), 0)
    T.eq(STANDBY.level_at(599), 1)
    T.eq(STANDBY.level_at(600), 0)
    T.eq(ALARM.level_at(50), ALARM.level_at(50 + ALARM.period_ms), "alarm repeats")
    T.eq(TAKEOVER.level_at(600), 1)


def test_gps_led():
    T.eq([gps_led_level(0, True, t) for t in (0, 500, 1500)], [0, 0, 0])
    T.eq([gps_led_level(1, True, t) for t in (0, 500, 1500)], [1, 1, 0])
    T.eq([gps_led_level(2, True, t) for t in (0, 100, 200)], [1, 1, 0])
    T.eq([gps_led_level(3, True, t) for t in (0, 500, 1500)], [1, 1, 1])
    T.eq(gps_led_level(3, False, 0), 0, "no position: off")


def _run(ind, st, t0, ms, step=10):
    out = []
    t = t0
    while t < t0 + ms:
        out.append(ind.update(st, t))
        t += step
    return out


def test_cues_from_status():
    ind = Indicators()
    st = HmiStatus()
    _run(ind, st, 0, 1000)
    T.eq(ind.playing(), "")
    st.mode = 1  # engaged
    ind.update(st, 1000)
    T.eq(ind.playing(), "engage")
    T.eq(ind.auto_led, 1)
    _run(ind, st, 1010, 1000)
    T.eq(ind.playing(), "")
    st.mode = 0  # standby by a person
    ind.update(st, 2010)
    T.eq(ind.playing(), "standby")
    T.eq(ind.auto_led, 0)
    _run(ind, st, 2020, 1000)
    st.refusal = "no track"
    ind.update(st, 3100)
    T.eq(ind.playing(), "refused")


def test_takeover_and_alarm_loops_until_ack():
    ind = Indicators()
    st = HmiStatus()
    st.mode = 1
    _run(ind, st, 0, 1000)
    st.mode = 0
    st.alarms = st.sounding = 1  # takeover by a person
    ind.update(st, 1000)
    T.eq(ind.playing(), "takeover", "no standby cue on top of the takeover pattern")
    lv = _run(ind, st, 1010, 5000)
    T.true(sum(b for _, _, _, b in lv) > 0)
    st.alarms |= 2
    st.sounding |= 2
    ind.update(st, 6100)
    T.eq(ind.playing(), "alarm", "other alarms outrank takeover")
    T.true(sum(a for _, _, a, _ in _run(ind, st, 6110, 1000)) > 0)
    st.sounding = 0  # acknowledged
    lv = _run(ind, st, 7200, 3000)
    T.eq(sum(b for _, _, _, b in lv), 0, "silent after ack")
    T.eq(ind.alarm_led, 1, "alarm LED steady while acknowledged alarms are active")
