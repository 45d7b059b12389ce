"""TurnWatch: what the boat achieves in a turn, measured while it steers.

Two figures, both from what the boat shows (docs/NAVIGATION.md "Fourth round: arcs the boat can
follow"):

- radius_m: the radius it turns at while the path asks more than it gives (the caller says when:
  on an arc with the heading trailing the path, or the rudder at its stop). Over such a stretch the
  distance sailed over the heading turned (SOG / yaw rate, integrated, so GNSS heading noise
  averages out); a stretch counts from 4 s and 20 deg. The estimate is the mean of the stretches
  (the last four weigh most).
- ram_dps: the fastest move of the rudder the pilot reports (0x84 / 0x9C, whole degrees, about
  2-5 Hz): a change of at least 5 deg in one direction over 0.8 .. 2.5 s. The fastest such
  move is the ram's rate, or the pilot's own limit when its gain never asks more. stop_deg: the
  largest rudder reported.

A dozen floats, nothing allocated per step (MicroPython, small heap); times only through the
caller's dt_s and ticks differences (ticks wrap)."""

from trackpilot.compat import ticks_diff, wrap180

_RAD = 3.141592653589793 / 180.0
_MIN_S = 4.0  # a stretch counts from this long ...
_MIN_TURN_RAD = 20.0 * _RAD  # ... and this much turned
_KEEP = 4  # the radius: the mean of the stretches, the last _KEEP weighing most
_RAM_MIN_DEG = 5  # a rudder move counts from this many degrees
_RING = 8  # rudder reports kept (about 2 s at 4 Hz)
RAM_TRUST_DEG = 20.0  # the ram's rate is trusted once the rudder was driven this far
RAM_LEAD_MAX_S = 3.0  # the largest lengthening of the preview by the ram's delay


class TurnWatch:
    def __init__(self):
        self.radius_m = 0.0  # 0: not measured
        self.samples = 0
        self.last_m = 0.0  # the last stretch's radius
        self.last_sog_mps = 0.0  # its mean speed over ground
        self.ram_dps = 0.0  # 0: no move seen yet
        self.stop_deg = 0.0
        self._seg_m = 0.0
        self._seg_rad = 0.0
        self._seg_s = 0.0
        self._hdg = 0.0  # heading at the last limited step
        self.in_stretch = False  # a limited stretch is being measured
        # what the los law keeps here (LosLaw's own attribute table stays small on the ESP32 heap)
        self.sign = 0.0  # the turn's direction on the arc last found (+1 starboard)
        self.want_m = 0.0  # arc radius the measurement asks (margin x radius), applied
        self.pending_m = 0.0  # asked, waiting for a straight
        self.lead_s = 0.0  # the preview added for the ram's delay
        self.rudder_ok = False  # the rudder reports are fresh and the pilot steers
        self.uturn_told = -1  # the last corner a narrow U-turn was told at
        # the rudder reports of the last second or two since the last reversal of the rudder's
        # direction: ring of (ticks ms, whole degrees) pairs, one list
        self._r = [0] * (2 * _RING)
        self._ri = 0  # next slot
        self._rn = 0  # reports held
        self._dir = 0

    def end(self):
        """Drop the stretch in progress (a gap, a disengage)."""
        self._seg_m = 0.0
        self._seg_rad = 0.0
        self._seg_s = 0.0
        self.in_stretch = False

    def step(self, dt_s, heading_deg, sog_mps, sign, limited):
        """One epoch. sign: +1 / -1, the turn's direction; limited: the path asks more than the boat
        gives. Returns the radius of a stretch that just closed (a new sample), else 0.0."""
        if limited:
            if self.in_stretch:
                d = wrap180(heading_deg - self._hdg) * sign
                self._seg_rad += d * _RAD
                self._seg_m += sog_mps * dt_s
                self._seg_s += dt_s
            self._hdg = heading_deg
            self.in_stretch = True
            return 0.0
        if not self.in_stretch:
            return 0.0
        r = 0.0
        if self._seg_s >= _MIN_S and self._seg_rad >= _MIN_TURN_RAD:
            r = self._seg_m / self._seg_rad
            self.last_m = r
            self.last_sog_mps = self._seg_m / self._seg_s
            n = self.samples + 1 if self.samples < _KEEP else _KEEP
            self.radius_m = r if self.samples == 0 else self.radius_m + (r - self.radius_m) / n
            self.samples += 1
        self.end()
        return r

    def rudder(self, t_ms, rudder_deg):
        """A rudder report (each new one; repeats of the same report are ignored). Returns True when
        the ram rate estimate or the largest rudder rose."""
        n = _RING
        last = self._ri - 1 if self._ri > 0 else n - 1
        if self._rn and t_ms == self._r[2 * last]:
            return False
        r = int(rudder_deg)
        a = r if r >= 0 else -r
        rose = a > self.stop_deg
        if rose:
            self.stop_deg = a
        if self._rn:  # a reversal: the move before it does not count
            d = r - self._r[2 * last + 1]
            if d * self._dir < 0:
                self._rn = 0
            if d != 0:
                self._dir = 1 if d > 0 else -1
        self._r[2 * self._ri] = t_ms
        self._r[2 * self._ri + 1] = r
        self._ri = (self._ri + 1) % n
        if self._rn < n:
            self._rn += 1
        # the newest report at least 0.8 s older, within the move (no reversal since)
        best = 0.0
        k = self._ri - 1
        for _ in range(self._rn - 1):
            k = k - 1 if k > 0 else n - 1
            span_ms = ticks_diff(t_ms, self._r[2 * k])
            if span_ms >= 800:
                mv = r - self._r[2 * k + 1]
                if mv < 0:
                    mv = -mv
                if span_ms <= 2500 and mv >= _RAM_MIN_DEG:
                    best = mv * 1000.0 / span_ms
                break
        if best > self.ram_dps:
            self.ram_dps = best
            return True
        return rose

    def rudder_now(self):
        """The last rudder reported (whole degrees; 0 before any)."""
        if not self._rn:
            return 0
        return self._r[2 * (self._ri - 1 if self._ri > 0 else _RING - 1) + 1]

    def ram_trusted(self):
        """The ram's rate is known: a move was seen and the rudder has been driven RAM_TRUST_DEG."""
        return self.ram_dps > 0.0 and self.stop_deg >= RAM_TRUST_DEG

    def set_lead(self, gain, ref_dps):
        """lead_s: the ram's delay beyond the one the preview was set for: gain x rudder needed (the
        largest rudder seen) x (1 / ram rate - 1 / ref_dps), 0 .. RAM_LEAD_MAX_S. Only once the
        rudder has been driven to RAM_TRUST_DEG: before that no move asked the ram for all it has
        (the nominal boat's gentle first minutes on the example loop read 6-7 deg/s of its 10)."""
        if gain <= 0.0 or not self.ram_trusted():
            self.lead_s = 0.0
            return
        ram = self.ram_dps
        need = self.stop_deg
        v = gain * need * (1.0 / ram - 1.0 / ref_dps)
        self.lead_s = 0.0 if v < 0.0 else (RAM_LEAD_MAX_S if v > RAM_LEAD_MAX_S else v)
