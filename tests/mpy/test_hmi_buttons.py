# Buttons: debounce, STANDBY immediate, long-press guards; and through the real mode machine.
import tpassert as T
from tphmi.buttons import B_ACK, B_AUTO, B_NEXT, B_PAGE, B_PREV, B_STBY, N_BUTTONS, Buttons, ButtonPins
from trackpilot.compat import TICKS_PERIOD, ticks_add
from trackpilot.core import modes


class Run:
    """Samples the buttons every step_ms and collects (t_ms, event)."""

    def __init__(self, t0=0, step_ms=10, **kw):
        self.b = Buttons(**kw)
        self.t = t0
        self.step = step_ms
        self.levels = [0] * N_BUTTONS
        self.events = []

    def hold(self, ms, **pressed):
        for i in range(N_BUTTONS):
            self.levels[i] = 0
        for name, v in pressed.items():
            self.levels[{"auto": B_AUTO, "stby": B_STBY, "next": B_NEXT, "prev": B_PREV,
                         "page": B_PAGE, "ack": B_ACK}[name]] = v
        end = self.t + ms
        while self.t < end:
            for e in self.b.update(self.levels, self.t % TICKS_PERIOD):
                self.events.append((self.t, e))
            self.t += self.step
        return self

    def names(self):
        return [e for _, e in self.events]


def test_standby_immediate_on_first_sample():
    r = Run().hold(100).hold(10, stby=1)
    T.eq(r.events, [(100, "STANDBY")])


def test_standby_once_per_press_and_rearms():
    r = Run().hold(50).hold(500, stby=1).hold(100).hold(30, stby=1)
    T.eq(r.names(), ["STANDBY", "STANDBY"])


def test_standby_rearms_after_glitch():
    # a 10 ms glitch gives a (safe) STANDBY; the next real press must work again
    r = Run().hold(50).hold(10, stby=1).hold(100).hold(50, stby=1)
    T.eq(r.names(), ["STANDBY", "STANDBY"])


def test_page_debounced():
    r = Run().hold(50)
    for _ in range(5):  # contact bounce: 10 ms on, 10 ms off
        r.hold(10, page=1).hold(10)
    T.eq(r.names(), [], "bounce shorter than debounce gives nothing")
    r.hold(60, page=1).hold(100)
    T.eq(r.names(), ["PAGE"])


def test_ack_on_press():
    r = Run().hold(20).hold(50, ack=1)
    T.eq(r.names(), ["ACK"])


def test_engage_needs_long_press():
    r = Run().hold(20).hold(500, auto=1).hold(100)
    T.eq(r.names(), ["HOLD_LONGER"], "short press never engages")
    r = Run().hold(20).hold(900, auto=1)
    T.eq(r.names(), [], "not yet at 0.9 s")
    r.hold(200, auto=1)
    T.eq(r.names(), ["ENGAGE"])
    t_engage = r.events[0][0]
    T.true(1030 <= t_engage <= 1060, "engage at press + debounce + 1 s, got %d" % t_engage)
    r.hold(5000, auto=1).hold(100)
    T.eq(r.names(), ["ENGAGE"], "holding does not repeat, release gives nothing more")


def test_engage_progress():
    r = Run().hold(20).hold(530, auto=1)
    p = r.b.engage_progress(r.t)
    T.true(0.4 < p < 0.6, "progress %r" % p)
    r.hold(600, auto=1)
    T.eq(r.b.engage_progress(r.t), 0.0)


def test_engage_spoiled_by_standby_or_other_button():
    r = Run().hold(20).hold(300, auto=1).hold(1500, auto=1, stby=1).hold(100)
    T.eq(r.names(), ["STANDBY"], "STANDBY during the hold wins, no engage")
    r = Run().hold(20).hold(300, auto=1).hold(1500, auto=1, page=1).hold(100)
    T.eq(r.names(), [], "two buttons at once (knee on the panel) never engage")
    r = Run().hold(20).hold(300, page=1).hold(1500, page=1, auto=1)
    T.true("ENGAGE" not in r.names())


def test_next_prev_long_press():
    r = Run().hold(20).hold(300, next=1).hold(50)
    T.eq(r.names(), ["HOLD_LONGER"])
    r = Run().hold(20).hold(1000, next=1).hold(50).hold(1000, prev=1).hold(50)
    T.eq(r.names(), ["NEXT_WP", "PREV_WP"])


def test_page_held_alone_starts_a_trial_once():
    # issue 11: the crew starts the commissioning trial from the panel (only STANDBY takes it)
    r = Run().hold(20).hold(2900, page=1).hold(100)
    T.eq(r.names(), ["PAGE"], "2.9 s is not enough")
    r = Run().hold(20).hold(10000, page=1).hold(100)
    T.eq(r.names(), ["PAGE", "TRIAL"], "once per press, however long")
    r = Run().hold(20).hold(1000, page=1).hold(3000, page=1, ack=1).hold(100)
    T.true("TRIAL" not in r.names(), "another button during the hold: no trial")
    r = Run().hold(20).hold(500, stby=1, page=1).hold(3500, page=1).hold(100)
    T.true("TRIAL" not in r.names(), "pressed together with another button: no trial")


def test_across_tick_wrap():
    r = Run(t0=TICKS_PERIOD - 500).hold(20).hold(1200, auto=1)
    T.eq(r.names(), ["ENGAGE"])


def test_button_pins_active_low():
    class P:
        def __init__(self, v):
            self.v = v

        def value(self):
            return self.v

    bp = ButtonPins([P(1), P(0), None, P(1), P(1), P(1)])
    T.eq(bp.read(), [0, 1, 0, 0, 0, 0])


def _apply(mm, ev, t, refusal):
    if ev == "ENGAGE":
        return mm.engage(t, refusal=refusal, source="HMI")
    if ev == "STANDBY":
        mm.standby(t, source="HMI")
    if ev == "ACK":
        mm.ack(t)


def test_through_mode_machine():
    mm = modes.ModeMachine()
    r = Run().hold(20)
    # engage refused without RTK: the reason comes back for the page
    r.hold(1100, auto=1).hold(50)
    T.eq(_apply(mm, "ENGAGE", r.t, "no RTK fixed solution"), (False, "no RTK fixed solution"))
    T.eq(mm.mode, modes.STANDBY)
    T.eq(_apply(mm, "ENGAGE", r.t, "no track loaded"), (False, "no track loaded"))
    # preconditions hold: engage; then STANDBY is honoured at once from AUTO and ALARM
    T.eq(_apply(mm, "ENGAGE", r.t, None), (True, ""))
    T.eq(mm.mode, modes.AUTO)
    r2 = Run(t0=r.t).hold(10, stby=1)
    T.eq(r2.names(), ["STANDBY"])
    _apply(mm, "STANDBY", r2.t, None)
    T.eq(mm.mode, modes.STANDBY)
    mm.engage(r2.t, None)
    mm.pilot_lost(r2.t, "no answer")
    T.eq(mm.mode, modes.ALARM)
    _apply(mm, "STANDBY", r2.t, None)
    T.eq(mm.mode, modes.STANDBY)
