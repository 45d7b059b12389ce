# Maintenance gate: entered only from STANDBY, ends by itself (idle and hard limit), tick wrap.
from tpassert import eq, true
from trackpilot.board import maint
from trackpilot.compat import TICKS_PERIOD, ticks_add


def test_refused_unless_standby_with_reason():
    for mode in ("AUTO", "ALARM", "ESTOP"):
        g = maint.Gate(idle_s=60, limit_s=600)
        ok, why = g.request(mode, 0)
        true(not ok, mode)
        true(mode in why and "STANDBY" in why, why)
        eq(g.state, maint.IDLE)
        true(not g.may_feed(0))


def test_refused_when_estop_latched_even_in_standby():
    g = maint.Gate()
    ok, why = g.request("STANDBY", 0, estop_latched=True)
    true(not ok)
    true("E-stop" in why, why)


def test_standby_enters_and_idle_timeout_ends_it():
    g = maint.Gate(idle_s=60, limit_s=600)
    ok, why = g.request("STANDBY", 1000)
    true(ok, why)
    eq(g.state, maint.ACTIVE)
    eq(g.expired(60999), None)
    eq(g.remaining_ms(1000), 60000)
    true("no host activity" in g.expired(61000))
    g.activity(50000)  # host traffic pushes the idle deadline
    eq(g.expired(61000), None)
    eq(g.remaining_ms(61000), 49000)


def test_hard_limit_wins_over_activity():
    g = maint.Gate(idle_s=60, limit_s=300)
    g.request("STANDBY", 0)
    t = 0
    while t < 299000:
        g.activity(t)
        eq(g.expired(t), None)
        t += 10000
    g.activity(299500)
    true("time limit" in g.expired(300000))
    eq(g.remaining_ms(299000), 1000)


def test_watchdog_feeding_stops_after_limit_plus_grace():
    g = maint.Gate(idle_s=60, limit_s=300)
    g.request("STANDBY", 0)
    true(g.may_feed(300000 + maint.GRACE_MS - 1))
    true(not g.may_feed(300000 + maint.GRACE_MS))
    g.end("resumed by the host")
    true(not g.may_feed(1000))
    eq(g.end_reason, "resumed by the host")


def test_deadline_across_tick_wrap():
    start = TICKS_PERIOD - 5000  # 5 s before the 2**30 ms wrap
    g = maint.Gate(idle_s=10, limit_s=100)
    g.request("STANDBY", start)
    eq(g.expired(ticks_add(start, 9999)), None)
    true(g.expired(ticks_add(start, 10000)) is not None)
    eq(g.remaining_ms(ticks_add(start, 4000)), 6000)


def test_second_request_while_active_is_harmless():
    g = maint.Gate()
    g.request("STANDBY", 0)
    ok, why = g.request("AUTO", 10)  # cannot happen (app paused), but must not end the state
    true(ok)
    eq(g.state, maint.ACTIVE)
    eq(g.entries, 1)
