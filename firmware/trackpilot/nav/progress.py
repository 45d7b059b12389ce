"""Progress along a track: current leg, signed cross-track error, along-track distance, leg advance.

Each leg is measured in its own frame at its start waypoint (geo.offset_m, an azimuthal
equidistant frame: the leg is a straight line in it), so floats stay small and float32 is fine.

Leg advance (seed report section 4.6.1: go to the next leg when the boat is nearer to the next
leg than to the current one), made robust (rule RULE_ROBUST, the default):
- only the current and the next leg are ever compared, so a looping or self-crossing track never
  jumps ahead because a later leg passes close by;
- "nearer to the next leg" counts only within `advance_window_m` of the current leg's end (a
  hairpin's next leg lies right beside the start of the current one);
- passing the perpendicular at the end of the leg advances too (otherwise a boat outside a
  corner is equally far from both legs and would stay on the old leg);
- a waypoint's own arrival radius (CSV radius_m), when given, advances when the boat is inside it;
- after back(), advancing waits until the boat is nearer to the current leg again.
RULE_SEED is the plain seed rule (strictly nearer to the next segment, nothing else), for the
baseline comparison. Both end the track at the last waypoint: inside its arrival radius
("arrived") or past the perpendicular at its end ("passed_end"); skip() on the last leg ends it
with "skipped".

join_nearest() (on start and on re-engaging after a person steered) picks the nearest leg that
the boat has not passed, searching from the current leg ahead up to `join_window_m` of track.

Usage:
    from trackpilot.nav.progress import Progress
    prog = Progress(trk)
    prog.update(fix.lat_e7, fix.lon_e7)   # the first update joins the nearest leg ahead
    prog.leg, prog.xte_m, prog.along_m, prog.to_wp_m, prog.finished, prog.finish_reason
"""
import math

from trackpilot.nav import geo
from trackpilot.compat import const, wrap180, wrap360

RULE_ROBUST = const(0)
RULE_SEED = const(1)

REASON_ARRIVED = "arrived"
REASON_PASSED_END = "passed_end"
REASON_SKIPPED = "skipped"


class Progress:
    arrival_radius_m = 3.0  # default arrival radius at the last waypoint
    advance_window_m = 30.0  # the seed's blend distance B: "nearer to the next leg" counts within it
    join_window_m = 500.0  # how far along the track join_nearest() looks ahead

    def __init__(self, track, rule=RULE_ROBUST, **params):
        for k in params:
            if not hasattr(self, k):
                raise ValueError("unknown progress parameter %r" % k)
            setattr(self, k, params[k])
        self.track = track
        self.rule = rule
        self.n_legs = len(track.legs)  # legs come from track.leg(i), derived and cached there
        self.restart()

    def restart(self):
        """Back to leg 0; the next update() joins the nearest leg from there."""
        self.leg = 0
        self.xte_m = 0.0  # + = boat to starboard of the leg
        self.along_m = 0.0  # along the leg from its start waypoint (negative before it)
        self.to_wp_m = 0.0  # straight-line distance to the leg's end waypoint
        self.remain_m = 0.0  # leg length - along
        self.track_m = 0.0  # distance along the whole track (leg start + along)
        leg0 = self.track.leg(0)
        self.leg_length_m = leg0.length_m
        self.leg_bearing_deg = leg0.bearing_deg
        self.finished = False
        self.finish_reason = None
        self.valid = False  # True once update() has placed the boat
        self.updates = 0
        self._need_join = True
        self._join_window = None
        self._hold = False

    def _pos(self, i, lat_e7, lon_e7, lat_hp, lon_hp):
        """(along_m, xte_m, distance to the leg's segment) of the boat on leg i."""
        leg = self.track.leg(i)
        e, n = geo.offset_m(leg.lat_e7, leg.lon_e7, lat_e7, lon_e7, 0, 0, lat_hp, lon_hp)
        ux = leg.ux
        uy = leg.uy
        a = e * ux + n * uy
        x = e * uy - n * ux  # starboard normal of (ux, uy) is (uy, -ux)
        length = leg.length_m
        if a < 0.0:
            d = math.sqrt(a * a + x * x)
        elif a > length:
            d = math.sqrt((a - length) * (a - length) + x * x)
        else:
            d = abs(x)
        return a, x, d

    def join_nearest(self, lat_e7=None, lon_e7=None, lat_hp=0, lon_hp=0, window_m=None):
        """Rejoin the nearest leg ahead (not yet passed), now if a position is given, else at the
        next update(). Clears `finished` unless the boat is past the last leg."""
        self._need_join = True
        self._join_window = window_m
        if lat_e7 is not None:
            self.update(lat_e7, lon_e7, lat_hp, lon_hp)

    def _join(self, lat_e7, lon_e7, lat_hp, lon_hp):
        window = self.join_window_m if self._join_window is None else self._join_window
        i0 = self.leg
        start_m = self.track.start_m(i0)  # leg j's track distance, summed on as j goes
        limit_m = start_m + window
        best = -1
        best_d = 0.0
        j = i0
        while j < self.n_legs and start_m <= limit_m:
            a, x, d = self._pos(j, lat_e7, lon_e7, lat_hp, lon_hp)
            length_m = self.track.leg(j).length_m
            if a < length_m and (best < 0 or d < best_d):
                best = j
                best_d = d
            start_m += length_m
            j += 1
        if best < 0:  # past every leg in the window: take the last one looked at
            best = j - 1
        self.leg = best
        self.finished = False
        self.finish_reason = None
        self._hold = False

    def update(self, lat_e7, lon_e7, lat_hp=0, lon_hp=0):
        """Place the boat (reference point) on the track; returns self."""
        if self._need_join:
            self._join(lat_e7, lon_e7, lat_hp, lon_hp)
            self._need_join = False
        i = self.leg
        trk = self.track
        a, x, d = self._pos(i, lat_e7, lon_e7, lat_hp, lon_hp)
        length = trk.leg(i).length_m
        if i + 1 < self.n_legs and not self.finished:
            an, xn, dn = self._pos(i + 1, lat_e7, lon_e7, lat_hp, lon_hp)
            advance = False
            if self.rule == RULE_SEED:
                advance = dn < d
            elif self._hold:
                if d <= dn and a < length:
                    self._hold = False  # back on the leg: normal rules again
            elif a >= length:
                advance = True
            elif dn < d and length - a <= self.advance_window_m:
                advance = True
            else:
                r = trk.radius_m(i + 1)
                if r is not None and (length - a) * (length - a) + x * x <= r * r:
                    advance = True
            if advance:
                i += 1
                self.leg = i
                a = an
                x = xn
                length = trk.leg(i).length_m
        self.along_m = a
        self.xte_m = x
        self.remain_m = length - a
        self.to_wp_m = math.sqrt(self.remain_m * self.remain_m + x * x)
        self.leg_length_m = length
        leg = trk.leg(i)
        self.track_m = leg.start_m + a
        # bearing of the leg at the boat's abeam point (geodesic bearing drifts by convergence)
        f = a / length
        if f < 0.0:
            f = 0.0
        elif f > 1.0:
            f = 1.0
        self.leg_bearing_deg = wrap360(leg.bearing_deg + f * wrap180(leg.end_bearing_deg - leg.bearing_deg))
        if i == self.n_legs - 1 and not self.finished:
            r = trk.radius_m(i + 1)
            if r is None:
                r = self.arrival_radius_m
            if self.to_wp_m <= r:
                self.finished = True
                self.finish_reason = REASON_ARRIVED
            elif a >= length:
                self.finished = True
                self.finish_reason = REASON_PASSED_END
        self.valid = True
        self.updates += 1
        return self

    def next_leg(self):
        """The next Leg or None on the last leg."""
        if self.leg + 1 < self.n_legs:
            return self.track.leg(self.leg + 1)
        return None

    def speed_mps(self):
        """The current leg's speed (its start waypoint's)."""
        return self.track.leg(self.leg).speed_mps

    def set_leg(self, i):
        """Put the boat on leg i (restoring saved state, or an explicit choice); the advance
        rules go on from there at the next update()."""
        if not 0 <= i < self.n_legs:
            raise ValueError("leg %d out of range 0..%d" % (i, self.n_legs - 1))
        self.leg = i
        self.finished = False
        self.finish_reason = None
        self._need_join = False
        self._hold = False

    def skip(self):
        """Give up the current leg's end waypoint: go to the next leg (on the last: finish)."""
        if self.leg + 1 < self.n_legs:
            self.leg += 1
            self.finished = False
            self.finish_reason = None
        else:
            self.finished = True
            self.finish_reason = REASON_SKIPPED
        self._hold = False
        self._need_join = False

    def back(self):
        """Go back one leg; advancing waits until the boat is nearer to that leg again."""
        if self.leg > 0:
            self.leg -= 1
        self.finished = False
        self.finish_reason = None
        self._hold = True
        self._need_join = False
