"""Debounced HMI buttons with a long-press guard: pin levels and t_ms in, events out.

Buttons (index in the `levels` sequence, see BUTTONS):
    AUTO   long press (engage_hold_ms, 1 s) -> "ENGAGE"; released early -> "HOLD_LONGER"
           (cancelled if any other button is pressed during the hold: a knee on the panel
           or a person pressing STANDBY never engages)
    STBY   -> "STANDBY" on the very first pressed sample (no debounce delay: a spurious
           STANDBY is safe, a late one is not)
    NEXT   long press (wp_hold_ms) -> "NEXT_WP"; short -> "HOLD_LONGER"
    PREV   long press (wp_hold_ms) -> "PREV_WP"; short -> "HOLD_LONGER"
    PAGE   debounced press -> "PAGE"; held alone for trial_hold_ms (3 s) -> "TRIAL" as well (the
           commissioning trial, docs/COMMISSIONING.md; the mode machine takes it only in STANDBY)
    ACK    debounced press -> "ACK" (acknowledge / mute alarms)
Each press gives at most one event; holding a button never repeats. The app decides what an event
does (ENGAGE goes through the mode machine's preconditions); this module never engages anything.

Usage:
    b = Buttons()                      # or Buttons(debounce_ms=30, engage_hold_ms=1000)
    levels = [0] * N_BUTTONS           # 1 = pressed (ButtonPins.read() fills it from the pins)
    for ev in b.update(levels, t_ms): app.on_hmi_event(ev, t_ms)   # list reused per call
    b.engage_progress(t_ms)            # 0.0 .. 1.0 while AUTO is held (for the display)
"""
from trackpilot.compat import const, ticks_diff

B_AUTO = const(0)
B_STBY = const(1)
B_NEXT = const(2)
B_PREV = const(3)
B_PAGE = const(4)
B_ACK = const(5)
N_BUTTONS = const(6)
BUTTONS = ("AUTO", "STBY", "NEXT", "PREV", "PAGE", "ACK")

_LONG_EVENT = {B_AUTO: "ENGAGE", B_NEXT: "NEXT_WP", B_PREV: "PREV_WP"}
_PRESS_EVENT = {B_PAGE: "PAGE", B_ACK: "ACK"}


class Buttons:
    """Debounce and press logic for N_BUTTONS buttons (pure: no pins, no clock)."""

    def __init__(self, debounce_ms=30, engage_hold_ms=1000, wp_hold_ms=800, trial_hold_ms=3000):
        self.debounce_ms = debounce_ms  # a level must be stable this long to count
        self.engage_hold_ms = engage_hold_ms  # AUTO must be held this long to engage
        self.wp_hold_ms = wp_hold_ms  # NEXT/PREV must be held this long
        self.trial_hold_ms = trial_hold_ms  # PAGE held alone this long starts a trial (from STANDBY)
        self._trial_done = False  # this PAGE press already gave TRIAL (or another button spoiled it)
        self._raw = [0] * N_BUTTONS  # last sampled level
        self._raw_since = [0] * N_BUTTONS  # t_ms the raw level last changed
        self._state = [0] * N_BUTTONS  # debounced level
        self._down_t = [0] * N_BUTTONS  # t_ms of the debounced press
        self._fired = [False] * N_BUTTONS  # this press already gave its event
        self._spoiled = [False] * N_BUTTONS  # long press cancelled (another button pressed)
        self._stby_armed = True  # STANDBY fires on the first pressed sample, re-arms on release
        self._events = []

    def update(self, levels, t_ms):
        """Feed one sample of all levels (1/True = pressed). Returns the list of new events."""
        ev = self._events  # reused: consume it before the next update
        del ev[:]
        # STANDBY first, and without waiting for debounce.
        if levels[B_STBY] and self._stby_armed:
            self._stby_armed = False
            ev.append("STANDBY")
        for i in range(N_BUTTONS):
            lv = 1 if levels[i] else 0
            if lv != self._raw[i]:
                self._raw[i] = lv
                self._raw_since[i] = t_ms
            if lv != self._state[i] and ticks_diff(t_ms, self._raw_since[i]) >= self.debounce_ms:
                self._state[i] = lv
                if lv:
                    self._press(i, t_ms, ev)
                else:
                    self._release(i, ev)
        # STANDBY re-arms once the pin has been released for debounce_ms (also after a glitch).
        if not self._stby_armed and not self._raw[B_STBY]:
            if ticks_diff(t_ms, self._raw_since[B_STBY]) >= self.debounce_ms:
                self._stby_armed = True
        # Long presses fire while still held (the person gets feedback at once).
        for i in (B_AUTO, B_NEXT, B_PREV):
            if self._state[i] and not self._fired[i] and not self._spoiled[i]:
                hold = self.engage_hold_ms if i == B_AUTO else self.wp_hold_ms
                if ticks_diff(t_ms, self._down_t[i]) >= hold:
                    self._fired[i] = True
                    if self._others_down(i):
                        self._spoiled[i] = True
                    else:
                        ev.append(_LONG_EVENT[i])
        # PAGE held alone: TRIAL once per press (a second, rarer gesture on the same button)
        if self._state[B_PAGE] and not self._trial_done:
            if self._others_down(B_PAGE):
                self._trial_done = True
            elif ticks_diff(t_ms, self._down_t[B_PAGE]) >= self.trial_hold_ms:
                self._trial_done = True
                ev.append("TRIAL")
        return ev

    def _others_down(self, i):
        for j in range(N_BUTTONS):
            if j != i and (self._state[j] or self._raw[j]):
                return True
        return False

    def _press(self, i, t_ms, ev):
        self._down_t[i] = t_ms
        self._fired[i] = False
        self._spoiled[i] = self._others_down(i)
        if i == B_PAGE:
            self._trial_done = self._spoiled[i]
        elif self._state[B_PAGE]:
            self._trial_done = True  # another button during the PAGE hold: no trial
        # A new press anywhere spoils a long press in progress.
        for j in (B_AUTO, B_NEXT, B_PREV):
            if j != i and self._state[j]:
                self._spoiled[j] = True
        if i in _PRESS_EVENT and not self._spoiled[i]:
            self._fired[i] = True
            ev.append(_PRESS_EVENT[i])

    def _release(self, i, ev):
        if i in _LONG_EVENT and not self._fired[i] and not self._spoiled[i]:
            ev.append("HOLD_LONGER")
        self._fired[i] = False
        self._spoiled[i] = False

    def pressed(self, i):
        """Debounced state of button i."""
        return bool(self._state[i])

    def engage_progress(self, t_ms):
        """0.0 .. 1.0 while AUTO is being held towards engage, else 0.0."""
        if not self._state[B_AUTO] or self._fired[B_AUTO] or self._spoiled[B_AUTO]:
            return 0.0
        p = ticks_diff(t_ms, self._down_t[B_AUTO]) / self.engage_hold_ms
        return 1.0 if p > 1.0 else p


class ButtonPins:
    """Shell part: reads machine.Pin objects (from the wiring) into a levels list.

    pins: sequence of N_BUTTONS Pin objects (None for a button not fitted), in BUTTONS order.
    active_low: buttons to ground with pull-ups (the usual wiring).
    """

    def __init__(self, pins, active_low=True):
        self.pins = pins
        self.active_low = active_low
        self.levels = [0] * N_BUTTONS

    def read(self):
        inv = 1 if self.active_low else 0
        for i in range(N_BUTTONS):
            p = self.pins[i]
            self.levels[i] = 0 if p is None else p.value() ^ inv
        return self.levels
