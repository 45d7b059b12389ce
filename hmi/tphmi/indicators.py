"""LEDs and buzzer: pure pattern logic from the status and t_ms, plus a thin pin shell.

LEDs:
    GPS/RTK  off: no position; slow blink (1 s on / 1 s off): single; fast blink (125/125 ms):
             RTK float; steady on: RTK fixed
    AUTO     on in AUTO; slow blink in AUTO degraded/recovering/hold; off otherwise
    ALARM    fast blink while an alarm sounds (not acknowledged); on while alarms are active
             but acknowledged; off without alarms
Buzzer (an active buzzer on one pin; patterns are on/off durations in ms, first one on):
    engage    two short beeps            (ENGAGE)
    standby   one long beep              (STANDBY)
    refused   four very short beeps      (REFUSED: engage refused, the page says why)
    alarm     three beeps, pause, repeat (ALARM) while an alarm sounds
    takeover  long-short, pause, repeat  (TAKEOVER) while the takeover alarm sounds
Cues are derived from status changes (mode, sounding bits, refusal), so the app only fills the
status; `cue()` plays one explicitly (for example after a remote command).

Usage:
    ind = Indicators()
    gps, auto, alarm, buzz = ind.update(status, t_ms)      # 0/1 levels, every 10..50 ms
    IndicatorPins(gps_pin, auto_pin, alarm_pin, buzzer_pin).apply(ind)
    ENGAGE.level_at(40)                                     # pure pattern generator -> 1
"""
from trackpilot.compat import ticks_diff

from tphmi.status import AL_TAKEOVER, MODE_AUTO, MODE_STANDBY


class Pattern:
    """On/off durations in ms (first is on). repeat=True loops; otherwise silent afterwards."""

    def __init__(self, name, durations_ms, repeat=False):
        self.name = name
        self.durations_ms = durations_ms
        self.repeat = repeat
        total = 0
        for d in durations_ms:
            total += d
        self.period_ms = total

    def level_at(self, t_ms):
        """Level (0/1) at t_ms after the pattern started (t_ms >= 0)."""
        if t_ms < 0:
            return 0
        if t_ms >= self.period_ms:
            if not self.repeat:
                return 0
            t_ms %= self.period_ms
        on = 1
        for d in self.durations_ms:
            if t_ms < d:
                return on
            t_ms -= d
            on ^= 1
        return 0

    def done_at(self, t_ms):
        return not self.repeat and t_ms >= self.period_ms


ENGAGE = Pattern("engage", (80, 80, 80))
STANDBY = Pattern("standby", (600,))
REFUSED = Pattern("refused", (40, 60, 40, 60, 40, 60, 40))
ALARM = Pattern("alarm", (200, 100, 200, 100, 200, 1200), repeat=True)
TAKEOVER = Pattern("takeover", (700, 150, 150, 1500), repeat=True)
PATTERNS = (ENGAGE, STANDBY, REFUSED, ALARM, TAKEOVER)

SLOW_BLINK = Pattern("slow", (1000, 1000), repeat=True)
FAST_BLINK = Pattern("fast", (125, 125), repeat=True)
AUTO_BLINK = Pattern("auto", (500, 500), repeat=True)
ALARM_BLINK = Pattern("alarmled", (150, 150), repeat=True)


def gps_led_level(rtk, pos_valid, t_ms):
    """GPS/RTK LED from the RTK state (0 none, 1 single, 2 float, 3 fixed); blink phase from t_ms."""
    if not pos_valid or rtk <= 0:
        return 0
    if rtk == 1:
        return SLOW_BLINK.level_at(t_ms % SLOW_BLINK.period_ms)
    if rtk == 2:
        return FAST_BLINK.level_at(t_ms % FAST_BLINK.period_ms)
    return 1


class Indicators:
    """Derives LED and buzzer levels from successive HmiStatus snapshots."""

    def __init__(self):
        self._prev_mode = MODE_STANDBY
        self._prev_sounding = 0
        self._prev_refusal = ""
        self._cue = None  # one-shot Pattern playing
        self._cue_t0 = 0
        self._loop = None  # repeating alarm/takeover Pattern
        self._loop_t0 = 0
        self.gps_led = 0
        self.auto_led = 0
        self.alarm_led = 0
        self.buzzer = 0

    def cue(self, pattern, t_ms):
        """Play a one-shot pattern now (over any repeating alarm pattern)."""
        self._cue = pattern
        self._cue_t0 = t_ms

    def playing(self):
        """Name of what the buzzer plays ("" when silent)."""
        if self._cue is not None:
            return self._cue.name
        return self._loop.name if self._loop is not None else ""

    def update(self, st, t_ms):
        """Returns (gps_led, auto_led, alarm_led, buzzer) levels (0/1) for time t_ms."""
        mode = st.mode
        sounding = st.sounding
        new_bits = sounding & ~self._prev_sounding
        if new_bits & AL_TAKEOVER:
            pass  # the takeover loop below announces it; no standby cue on top
        elif mode == MODE_AUTO and self._prev_mode != MODE_AUTO:
            self.cue(ENGAGE, t_ms)
        elif mode == MODE_STANDBY and self._prev_mode != MODE_STANDBY:
            self.cue(STANDBY, t_ms)
        if st.refusal and st.refusal != self._prev_refusal:
            self.cue(REFUSED, t_ms)
        self._prev_mode = mode
        self._prev_sounding = sounding
        self._prev_refusal = st.refusal

        # Repeating pattern: any other alarm outranks the takeover pattern.
        want = None
        if sounding & ~AL_TAKEOVER:
            want = ALARM
        elif sounding & AL_TAKEOVER:
            want = TAKEOVER
        if want is not self._loop:
            self._loop = want
            self._loop_t0 = t_ms

        buzz = 0
        if self._cue is not None:
            dt = ticks_diff(t_ms, self._cue_t0)
            if self._cue.done_at(dt):
                self._cue = None
            else:
                buzz = self._cue.level_at(dt)
        if self._cue is None and self._loop is not None:
            buzz = self._loop.level_at(ticks_diff(t_ms, self._loop_t0))

        self.gps_led = gps_led_level(st.rtk, st.pos_valid, t_ms)
        if mode == MODE_AUTO:
            if st.degraded or st.recovering or st.holding:
                self.auto_led = AUTO_BLINK.level_at(t_ms % AUTO_BLINK.period_ms)
            else:
                self.auto_led = 1
        else:
            self.auto_led = 0
        if sounding:
            self.alarm_led = ALARM_BLINK.level_at(t_ms % ALARM_BLINK.period_ms)
        else:
            self.alarm_led = 1 if st.alarms else 0
        self.buzzer = buzz
        return self.gps_led, self.auto_led, self.alarm_led, self.buzzer


class IndicatorPins:
    """Shell part: drives machine.Pin outputs (from the wiring); None for what is not fitted."""

    def __init__(self, gps_pin, auto_pin, alarm_pin, buzzer_pin):
        self.pins = (gps_pin, auto_pin, alarm_pin, buzzer_pin)

    def apply(self, ind):
        levels = (ind.gps_led, ind.auto_led, ind.alarm_led, ind.buzzer)
        for i in range(4):
            p = self.pins[i]
            if p is not None:
                p.value(levels[i])
