"""Guidance laws: from the boat's place on the track to a heading command and a speed command.

Both laws share one output (GuidanceOut) and one call, made once per GNSS epoch after
progress.update() has placed the boat's reference point on the track with the same fix:

    law = make_law("los")                 # or "seed"; config key guidance.law
    law.reset()                           # on engage
    prog.update(ref_lat_e7, ref_lon_e7)
    out = law.step(fix, prog, dt_s)       # out.heading_cmd_deg (true), out.speed_cmd_mps

The application turns heading_cmd_deg into a course relative to the pilot's compass
(ARCHITECTURE.md). Conventions (docs/CONTRACTS.md): + angle = to starboard, xte + = boat to
starboard of the leg. Parameters live in each law's PARAMS table (default, unit, min, max,
meaning); `law.configure({...})` overrides them with range checks.

SeedLaw ("seed"): the seed report's controller as pinned in BOAT_AND_BENCHMARK.md "The seed law"
(seed sections 4.6.1, 4.6.2 and Appendix A, with 4.6.1's blend sign).
LosLaw ("los"): line-of-sight path following with measured crab-angle compensation, an adaptive
(ALOS, Fossen 2023) crab term with anti-windup, a speed-scheduled lookahead, corners rounded to
>= 1.5 x the turning radius with preview (curvature feed-forward), and speed planning.
"""
import math

from trackpilot.compat import wrap180, wrap360
from trackpilot.nav.swing import SwingWatch
from trackpilot.nav.tighten import Tighten
from trackpilot.nav.turnwatch import TurnWatch

_RAD = math.pi / 180.0
_HALF_PI = math.pi * 0.5
_CORNER_CACHE = 16  # planned corners kept (direct-mapped by waypoint index)
_TRAIL_DEG = 10.0  # on an arc, the course made good trailing the path by more: the boat turns its widest
_STOP_SEEN_DEG = 15.0  # the largest rudder reported counts as the stop from this angle on


class GuidanceOut:
    """One step's result (preallocated, filled in place)."""

    def __init__(self, law=""):
        self.law = law
        self.valid = False  # False: no heading (or no position); hold the last command
        self.heading_cmd_deg = 0.0  # true heading to steer, 0..360
        self.speed_cmd_mps = 0.0
        self.rel_cmd_deg = 0.0  # heading_cmd - heading after the clip, -180..180
        self.clipped = False  # the relative command hit its clip
        self.ref_course_deg = 0.0  # the course the law aims the boat at before the xte term
        self.xte_m = 0.0  # against the leg (the track as given)
        self.path_xte_m = 0.0  # against the planned path (rounded corners); = xte_m for seed
        self.crab_deg = 0.0  # compensation applied (course over ground - heading), filtered
        self.integral_deg = 0.0  # adaptive crab estimate (ALOS)
        self.lookahead_m = 0.0
        self.preview_deg = 0.0  # turn of the path within the preview distance (feed-forward)
        self.blend = 0.0  # seed: heading blend factor c
        self.arc_radius_m = 0.0  # radius of the rounded corner the boat is on, 0 on a straight
        self.finished = False
        self.note = ""  # los: what the swing watch changed this step (the app logs it), else ""


def _configure(obj, params):
    for k in params:
        spec = obj.PARAMS.get(k)
        if spec is None:
            raise ValueError("%s: unknown parameter %r" % (obj.name, k))
        v = float(params[k])
        if not (spec[2] <= v <= spec[3]):
            raise ValueError("%s: %s = %r outside %r..%r %s" % (obj.name, k, v, spec[2], spec[3], spec[1]))
        setattr(obj, k, v)


def _defaults(obj):
    for k in obj.PARAMS:
        setattr(obj, k, obj.PARAMS[k][0])


def _soft(v, knee, gain):
    """v beyond +-knee grows at gain (a soft clip): the large course errors of a swing reach the
    pilot at gain, the small ones of a settled straight as they are."""
    if v > knee:
        return knee + gain * (v - knee)
    if v < -knee:
        return -knee + gain * (v + knee)
    return v


def _clip(v, lo, hi):
    return lo if v < lo else (hi if v > hi else v)


class SeedLaw:
    """The seed law, exactly as pinned in BOAT_AND_BENCHMARK.md (the baseline).

    - leg advance: the Progress given (seed 4.6.1; Progress(trk, RULE_SEED) for the plain rule);
    - reference heading H = H_i + c * wrap(H_(i+1) - H_i), c = clip(1 - d / B, 0, 1), d the
      distance to the next waypoint, B = 30 m (4.6.1; Appendix A's sign would turn away);
    - relative setpoint clip(-k_y * y + k_psi * wrap(H - heading), -30, +30) deg (4.6.2);
    - heading_cmd = heading + relative setpoint; speed = the current leg's (4.6.2)."""

    name = "seed"
    PARAMS = {
        # name: (default, unit, min, max, meaning)
        "blend_m": (30.0, "m", 1.0, 500.0, "B: heading blend distance before the next waypoint"),
        "k_y_deg_per_m": (3.0, "deg/m", 0.0, 50.0, "cross-track gain"),
        "k_psi": (1.0, "1", 0.0, 5.0, "heading-error gain"),
        "clip_deg": (30.0, "deg", 1.0, 90.0, "clip of the relative setpoint"),
    }

    def __init__(self, **params):
        _defaults(self)
        _configure(self, params)
        self.out = GuidanceOut(self.name)

    def configure(self, params):
        _configure(self, params)

    def reset(self):
        self.out.valid = False

    def step(self, fix, prog, dt_s):
        out = self.out
        out.finished = prog.finished
        out.speed_cmd_mps = 0.0 if prog.finished else prog.speed_mps()
        if not prog.valid or not fix.heading_valid:
            out.valid = False  # keep the last heading command
            return out
        h_i = prog.leg_bearing_deg
        nxt = prog.next_leg()
        c = 0.0
        ref = h_i
        if nxt is not None and not prog.finished:
            c = _clip(1.0 - prog.to_wp_m / self.blend_m, 0.0, 1.0)
            ref = wrap360(h_i + c * wrap180(nxt.bearing_deg - h_i))
        y = prog.xte_m
        rel = -self.k_y_deg_per_m * y + self.k_psi * wrap180(ref - fix.heading_deg)
        out.clipped = rel > self.clip_deg or rel < -self.clip_deg
        rel = _clip(rel, -self.clip_deg, self.clip_deg)
        out.rel_cmd_deg = rel
        out.heading_cmd_deg = wrap360(fix.heading_deg + rel)
        out.ref_course_deg = ref
        out.blend = c
        out.xte_m = y
        out.path_xte_m = y
        out.valid = True
        return out


class LosLaw:
    """Line-of-sight guidance on the planned path (legs with rounded corners).

    course_d = path tangent + preview turn - atan(y_lead / lookahead), the approach angle clamped
    y_lead = path_xte + xte_lead_s * U * sin(heading + crab - path tangent): the xte predicted
    xte_lead_s ahead, the damping that keeps the loop stable over unknown pilots (docs/NAVIGATION.md
    "Robust over boats we have not modelled")
    heading_cmd = course_d - crab (measured COG - heading, low-pass) - beta_hat (ALOS)
    beta_hat' = gamma * lookahead / sqrt(lookahead^2 + y^2) * y_a,
    y_a = y + alos_lead_s * U * sin(course made good - path tangent) (the xte predicted alos_lead_s
    ahead; "Seventh round"), frozen while the command is clipped, while far off the path or slow
    (anti-windup), on arcs and in a corner's preview (alos_turn_hold), and clamped.
    lookahead = clamp(lookahead_gain * U * heading_tc_s, min, max) = 6 s x U by default, from
    the closed heading response's spread with a stability margin (docs/NAVIGATION.md); with accel_la
    (off by default) from that share of the planned speed while the boat speeds up after an engage.
    On a slow leg (planned speed U < slow_ref_mps) the heading response slows as 1 / U: lookahead
    time and lead x slow = slow_ref / max(U, slow_min_mps), the ALOS gain / slow^slow_alos (3: its
    integral feeds a slow pilot's swings there; "Ninth round"), and the ALOS learns only while the
    course made good runs along the path (slow_chi_deg; "Fifth round"); on the other legs too
    (alos_chi_deg; "Sixth round").
    Once the boat has held the path on a straight (tight_wait_s within tight_band_m), lookahead
    and lead x tight_scale; back at once and until the next engage beyond tight_exit_m or on an
    act of the swing watch (nav/tighten.py; "Tenth round").
    A pilot whose own rudder gain is high (learnt from its reports, nav/pilotgain.py; or set as
    pilot_gain, off by default) gets the straight's clip gain_clip_deg / gain about its compass,
    so its rudder stays off the stop ("Twelfth round").
    Defaults: docs/NAVIGATION.md "Tuning".
    Corners are arcs of radius round_factor * turn_radius_m, shrunk where legs are too short
    (never below turn_radius_m / 2; sharper corners and reversals >= 170 deg are not rounded).
    The planned path is what path_xte_m measures against."""

    name = "los"
    PARAMS = {
        "turn_radius_m": (9.0, "m", 2.0, 100.0, "the boat's minimum turning radius"),
        "round_factor": (1.5, "1", 1.0, 5.0, "corner radius / turning radius"),
        "lookahead_gain": (2.0, "1", 0.5, 10.0, "lookahead = gain * speed * heading_tc_s"),
        "heading_tc_s": (3.0, "s", 0.2, 10.0, "time constant of heading response (boat + pilot)"),
        "lookahead_min_m": (6.0, "m", 1.0, 50.0, "lookahead clamp, low (gain x T' L: slow boat)"),
        "lookahead_max_m": (30.0, "m", 2.0, 200.0, "lookahead clamp, high"),
        "xte_lead_s": (3.0, "s", 0.0, 20.0, "damping: steer on the xte predicted this far ahead (0 = off)"),
        "accel_la": (0.0, "1", 0.0, 1.0, "from an engage until the boat is at its planned speed, the lookahead from this share of it (0 = off: measured, not earned)"),
        "accel_done": (0.9, "1", 0.1, 1.0, "... the acceleration is over at this share of the planned speed"),
        "intercept_max_deg": (90.0, "deg", 5.0, 90.0, "clamp of the approach angle to the path (90 = off)"),
        "preview_s": (3.5, "s", 0.0, 10.0, "preview time: path turn this far ahead is fed forward"),
        "crab_use": (1.0, "1", 0.0, 1.0, "weight of the measured crab angle (0 = off)"),
        "crab_tc_s": (2.0, "s", 0.2, 120.0, "low-pass time constant of the measured crab"),
        "crab_min_speed_mps": (0.3, "m/s", 0.0, 5.0, "below this COG is noise: crab is held"),
        "crab_max_deg": (35.0, "deg", 0.0, 60.0, "clamp of the measured crab"),
        "alos_gain": (0.004, "rad/(m s)", 0.0, 0.1, "adaptive crab gain gamma (0 = off)"),
        "alos_max_deg": (20.0, "deg", 0.0, 45.0, "clamp of the adaptive crab estimate"),
        "alos_zone_m": (5.0, "m", 0.1, 100.0, "adapt only within this distance of the path"),
        "slow_ref_mps": (2.0, "m/s", 0.0, 5.0, "slow leg: below this planned speed lookahead time and lead grow as slow_ref / U, the ALOS gain falls (slow_alos) (0 = off)"),
        "slow_min_mps": (1.0, "m/s", 0.1, 5.0, "slow leg: below this planned speed the schedule grows no more"),
        "slow_alos": (3.0, "1", 0.0, 4.0, "slow leg: the ALOS gain divided by (slow_ref / U) to this power (0 = full gain, 1 = its integral time grows with the lookahead time)"),
        "slow_chi_deg": (5.0, "deg", 0.0, 90.0, "slow leg: the ALOS learns with weight 1 - |course made good - path| / this (0 = always)"),
        "alos_chi_deg": (5.0, "deg", 0.0, 90.0, "legs at or above slow_ref_mps: the ALOS learns with weight 1 - |course made good - path| / this (0 = always)"),
        "alos_lead_s": (15.0, "s", 0.0, 60.0, "the ALOS learns on the xte predicted this far ahead from the course made good: damps its slow loop (0 = off)"),
        "alos_turn_hold": (1.0, "1", 0.0, 1.0, "ALOS held on arcs and in a corner's preview (1 = on; 0 = learns there too)"),
        "clip_deg": (45.0, "deg", 5.0, 120.0, "clip of the relative command (heading_cmd - heading)"),
        "max_turn_rate_dps": (10.0, "deg/s", 0.0, 60.0, "slow down so U / r stays below this (0 = off)"),
        "speed_tc_s": (5.0, "s", 0.0, 60.0, "surge lag: speed changes start this many seconds early"),
        "min_speed_mps": (0.3, "m/s", 0.0, 3.0, "floor of the turn slow-down"),
        "adapt_max_scale": (4.0, "1", 1.0, 10.0, "swing watch: largest lookahead scale it may set (1 = off)"),
        "hunt_gentle": (0.0, "1", 0.0, 1.0, "when the pilot hunts: lookahead x2 and no lead (1 = on)"),
        "adapt_clip_min_deg": (10.0, "deg", 1.0, 120.0, "swing watch: the straight's command clip not below this"),
        "adapt_swing_m": (1.0, "m", 0.2, 10.0, "swing watch: a half cycle counts from this amplitude of the path xte"),
        "adapt_keep": (0.6, "1", 0.1, 1.0, "swing watch: each half cycle keeps at least this share of the one before"),
        "adapt_overshoot": (0.7, "1", 0.0, 5.0, "swing watch: the approach's overshoot / its start offset that acts ... (0 = off)"),
        "adapt_stop_s": (3.0, "s", 0.0, 60.0, "... with the rudder at its stop this long since the crossing"),
        "adapt_stop_deg": (27.0, "deg", 1.0, 90.0, "the pilot's reported rudder at or beyond this is at its stop"),
        "adapt_clip_back": (1.0, "1", 0.0, 1.0, "a straight's clip cut by the watches still lets the boat turn parallel to the path while it moves away (1 = on)"),
        "adapt_overshoot_clip_deg": (12.0, "deg", 5.0, 120.0, "the straight's clip set then (and lookahead x2)"),
        "adapt_split": (3.5, "1", 1.0, 20.0, "swing watch: period / (lookahead / U) below which the lead is cut"),
        "tau_sched": (0.0, "1", 0.0, 1.0, "lookahead and lead from the measured heading response (1 = on; measured no gain)"),
        "tau_zeta": (0.7, "1", 0.3, 1.5, "damping ratio kept at the measured heading response"),
        "tau_max_s": (20.0, "s", 2.0, 60.0, "bound of the measured heading response"),
        "tau_window_s": (10.0, "s", 5.0, 120.0, "heading response: length of one fitting window"),
        "turn_margin": (1.2, "1", 0.0, 3.0, "arcs planned at least this x the radius the boat achieved (0 = off)"),
        "ram_lead": (1.0, "1", 0.0, 3.0, "preview lengthened by this x the ram's extra delay (0 = off)"),
        "ram_ref_dps": (10.0, "deg/s", 1.0, 60.0, "the ram rate preview_s was set for"),
        "soft_knee_deg": (8.0, "deg", 1.0, 120.0, "on a straight crossed twice since it began, at the law's own clip: the relative command beyond this grows at soft_gain"),
        "soft_gain": (0.5, "1", 0.0, 1.0, "... by this share of the law's (1 = off)"),
        "tight_scale": (0.5, "1", 0.3, 1.0, "once the boat has held the path: lookahead and lead x this (1 = off)"),
        "tight_wait_s": (10.0, "s", 1.0, 600.0, "... held within tight_band_m on a straight this long"),
        "tight_band_m": (0.5, "m", 0.05, 5.0, "... within this distance of the path"),
        "tight_exit_m": (0.6, "m", 0.1, 10.0, "tightened, |xte| beyond this sets it back until the next engage"),
        "clip_pilot_frame": (1.0, "1", 0.0, 2.0, "clip about the pilot's own compass, not the GNSS heading: 1 = once the watches cut the clip, 2 = always, 0 = never"),
        "gain_clip_deg": (20.0, "deg", 0.0, 90.0, "once the pilot's rudder gain is learnt at or above gain_clip_min: the straight's clip this / gain, about the pilot's compass (0 = off)"),
        "gain_clip_min": (1.6, "deg/deg", 0.3, 5.0, "... the gain (rudder deg per deg of its course error) from which that clip applies"),
        "pilot_gain": (0.0, "deg/deg", 0.0, 5.0, "the pilot's rudder gain as known (tune reports it, does not write it): its clip from the first engage, until the law learns its own (0 = not known; measured worse, docs/COMMISSIONING.md)"),
    }

    def __init__(self, **params):
        _defaults(self)
        _configure(self, params)
        self.out = GuidanceOut(self.name)
        self._track = None
        # the swing watch on the path xte (docs/NAVIGATION.md "Adapting to the boat"): its
        # scales belong to the boat, so they outlive reset() (a new engage, the same boat)
        self.swing = SwingWatch(0.2, self.adapt_swing_m, 2, min_half_s=2.0, max_half_s=60.0,
                                keep_ratio=self.adapt_keep)
        self.la_scale = 1.0
        self.lead_scale = 1.0
        self.clip_scale = 1.0
        self._approach = True  # the first approach since the engage: its overshoot is watched
        self._stop_s = 0.0
        # the closed heading response fitted to the locked course (nav/tauest.py): made only when
        # tau_sched is on (off by default: no measured gain, and it costs the ESP32's heap)
        self.tau = None
        self.tau_scale = 1.0
        self._tau_logged_s = 0.0
        self.on_straight = False
        # the pilot's compass in the true frame (compass - learnt offset), set by the autopilot each
        # epoch while fresh, else None: the heading the clip bounds the pilot's error about
        self.pilot_heading_deg = None
        # what the boat achieves in turns (nav/turnwatch.py; its state lives there: the ESP32 heap
        # keeps this object's attribute table small): the boat's, so it outlives reset()
        self.turns = TurnWatch()
        self.tight = Tighten()
        # the pilot's own rudder gain, learnt from its reports (nav/pilotgain.py): the boat's, so
        # it outlives reset(); made on the first report (its model bank costs heap)
        self.gain = None
        self.reset()

    def configure(self, params):
        _configure(self, params)
        self._track = None  # re-plan the corners
        self.swing.amp_min = self.adapt_swing_m
        self.swing.keep_ratio = self.adapt_keep
        if self.tau is not None:
            self.tau.prior_s = self.heading_tc_s
            self.tau.hi_s = self.tau_max_s
            self.tau.window_s = self.tau_window_s
            self.tau.restart()
        self.tau_scale = 1.0
        self.turns.set_lead(self.ram_lead, self.ram_ref_dps)

    def reset(self):
        self.crab_f_deg = 0.0
        self.crab_ok = False
        self.beta_hat_rad = 0.0
        self._intercept_clamped = False
        self._accel = True  # engaged, not yet at the planned speed (the lookahead from the plan)
        self.swing.reset()
        self._approach = True
        self._stop_s = 0.0  # the pilot's rudder at its stop in the approach's overshoot
        self.turns.end()
        self.tight.reset()
        if self.tau is not None:
            self.tau.reset()
        self.out.valid = False
        self.out.clipped = False

    # ---- corner planning (per corner, on demand, a few cached) ----
    def plan(self, trk):
        """Start planning the corners of a track: each corner's radius and tangent length is
        derived when first needed from the legs beside it (no per-waypoint lists)."""
        self._track = trk
        self._n = len(trk.waypoints)
        self._want = self.round_factor * self.turn_radius_m
        if self.turn_margin > 0.0 and self.turns.want_m > self._want:
            self._want = self.turns.want_m  # what the boat showed it turns at (a new track, a new plan)
        self.turns.uturn_told = -1
        self._cache_k = [-1] * _CORNER_CACHE
        self._cache_c = [None] * _CORNER_CACHE

    def _raw(self, k):
        """(sign, |turn| rad, unshrunk tangent m) of the corner at waypoint k."""
        if k < 1 or k >= self._n - 1:
            return 0.0, 0.0, 0.0
        th = self._track.leg(k - 1).turn_deg
        if abs(th) < 1.0 or abs(th) >= 170.0:
            return 0.0, 0.0, 0.0
        th_rad = abs(th) * _RAD
        return (1.0 if th > 0 else -1.0), th_rad, self._want * math.tan(th_rad * 0.5)

    def _corner(self, k):
        """(sign, |turn| rad, tangent m, radius m) planned at waypoint k; corners whose tangents
        overlap on a leg are shrunk (both ends share the leg in proportion)."""
        slot = k % _CORNER_CACHE
        if self._cache_k[slot] == k:
            return self._cache_c[slot]
        s, th, t = self._raw(k)
        c = (0.0, 0.0, 0.0, 0.0)
        if th != 0.0:
            scale = 1.0
            for i in (k - 1, k):  # the legs ending and starting at waypoint k
                need = self._raw(i)[2] + self._raw(i + 1)[2]
                length = self._track.leg(i).length_m
                if need > length:
                    scale = min(scale, length / need)
            t = t * scale
            r = t / math.tan(th * 0.5)
            if r >= 0.5 * self.turn_radius_m:  # else too tight to plan: follow the legs
                c = (s, th, t, r)
        self._cache_k[slot] = k
        self._cache_c[slot] = c
        return c

    def _t(self, k):
        return self._corner(k)[2]

    def _r(self, k):
        return self._corner(k)[3]

    def _straight(self, i):
        """Straight part of leg i between its corners' tangent points."""
        return self._track.leg(i).length_m - self._t(i) - self._t(i + 1)

    def corner_radius_m(self, k):
        """Planned radius at waypoint k (0: not rounded)."""
        return self._r(k)

    def _preview_rad(self, kind, idx, rem, p):
        """Signed turn (rad) of the path over the next p metres from a point on an arc (kind 0,
        corner idx, rem rad left) or on a straight (kind 1, leg idx, rem m left)."""
        total = 0.0
        n_legs = self._n - 1
        for _ in range(6):
            if p <= 0.0:
                break
            if kind == 0:
                c = self._corner(idx)
                r = c[3]
                if r > 0.0:
                    take = min(p, rem * r)
                    total += c[0] * take / r
                    p -= take
                if idx >= n_legs:
                    break
                kind = 1
                rem = self._straight(idx)
            else:
                p -= min(p, rem)
                idx += 1
                if idx >= n_legs:
                    break
                kind = 0
                rem = self._corner(idx)[1]
        return total

    @staticmethod
    def _line_xte(a, x, pa, px, phi):
        """Signed xte from a line through (pa, px) with direction phi (rad, + starboard)."""
        return -(a - pa) * math.sin(phi) + (x - px) * math.cos(phi)

    def _path(self, prog, p):
        """(tangent_rad relative to the leg, path_xte_m, preview_rad, arc_radius_m)."""
        i = prog.leg
        a = prog.along_m
        x = prog.xte_m
        length = prog.leg_length_m
        k_end = i + 1
        t_end = self._t(k_end) if k_end < self._n - 1 else 0.0
        t_start = self._t(i) if i > 0 else 0.0
        if t_end > 0.0 and a >= length - t_end:
            k = k_end
            s, th_k, _, r = self._corner(k)
            th = s * th_k
            dx = a - (length - t_end)
            dy = x - s * r
            tan = wrap180((math.atan2(dy, dx) + s * _HALF_PI) / _RAD) * _RAD
            if s * tan < 0.0:  # before the arc (cannot be, but keep it defined)
                return 0.0, x, self._preview_rad(0, k, th_k, p), 0.0
            if s * tan > s * th:  # past the arc, progress still on this leg: next leg's line
                return th, self._line_xte(a, x, length, 0.0, th), self._preview_rad(1, k, self._straight(k), p), 0.0
            rem = th_k - s * tan
            self.turns.sign = s
            return tan, s * (r - math.sqrt(dx * dx + dy * dy)), self._preview_rad(0, k, rem, p), r
        if t_start > 0.0 and a <= t_start:
            k = i
            s, th_k, _, r = self._corner(k)
            th = s * th_k
            dx = a - t_start
            dy = x - s * r
            tan = wrap180((math.atan2(dy, dx) + s * _HALF_PI) / _RAD) * _RAD
            if s * tan > 0.0:  # past the arc's end: the straight of this leg
                return 0.0, x, self._preview_rad(1, i, t_start + self._straight(i) - a, p), 0.0
            if s * tan < -s * th:  # before the arc: the previous leg's line
                return -th, self._line_xte(a, x, 0.0, 0.0, -th), self._preview_rad(0, k, th_k, p), 0.0
            self.turns.sign = s
            return tan, s * (r - math.sqrt(dx * dx + dy * dy)), self._preview_rad(0, k, -s * tan, p), r
        rem = length - t_end - a
        if rem < 0.0:
            rem = 0.0
        return 0.0, x, self._preview_rad(1, i, rem, p), 0.0

    def step(self, fix, prog, dt_s):
        out = self.out
        if self._track is not prog.track:
            self.plan(prog.track)
        out.finished = prog.finished
        leg = prog.track.leg(prog.leg)
        if fix.vel_valid:
            u = fix.sog_mps
        else:
            u = leg.speed_mps
        u_eff = u if u > 0.3 else 0.3
        out.speed_cmd_mps = 0.0 if prog.finished else self._speed(prog, leg)
        if not prog.valid or not fix.heading_valid:
            out.valid = False
            return out
        # measured crab: course over ground - heading, only when COG means something
        if fix.vel_valid and fix.sog_mps >= self.crab_min_speed_mps and self.crab_use > 0.0:
            c = _clip(wrap180(fix.cog_deg - fix.heading_deg), -self.crab_max_deg, self.crab_max_deg)
            if not self.crab_ok:
                self.crab_f_deg = c
                self.crab_ok = True
            else:
                self.crab_f_deg += (c - self.crab_f_deg) * (dt_s / (self.crab_tc_s + dt_s))
        # a slow leg (docs/NAVIGATION.md "Fifth round"): the heading response slows as 1 / U below
        # slow_ref_mps (rudder force ~ U^2), so the lookahead time and the lead grow with it:
        # scheduled on the leg's planned speed, not on the SOG every start from rest passes through
        u_leg = leg.speed_mps if leg.speed_mps > self.slow_min_mps else self.slow_min_mps
        slow = self.slow_ref_mps / u_leg if self.slow_ref_mps > u_leg else 1.0
        p_m = u_eff * (self.preview_s + self.turns.lead_s)  # the ram's own delay on top
        tan_rad, y, prev_rad, arc_r = self._path(prog, p_m)
        out.note = ""
        self.on_straight = arc_r == 0.0 and -0.035 < prev_rad < 0.035 and not prog.finished
        if self.turns.pending_m > 0.0 and self.on_straight:
            r = self._replan(prog, p_m)
            if r is not None:
                tan_rad, y, prev_rad, arc_r = r
        if self.turn_margin > 0.0:
            self._turn_watch(fix, prog, dt_s, arc_r, tan_rad)
        # engaged from rest: the lookahead of the speed the boat is being driven to, so the first
        # course step is the one for that speed, not a 40 deg one for 6 m (docs/NAVIGATION.md
        # "Fifth round"); over once it has (nearly) reached that speed, or at a turn
        u_la = u_eff
        if self._accel:
            v_plan = out.speed_cmd_mps
            if not self.on_straight or u >= self.accel_done * v_plan:
                self._accel = False
            elif self.accel_la * v_plan > u_la:
                u_la = self.accel_la * v_plan
        la = _clip(self.lookahead_gain * u_la * self.heading_tc_s * slow, self.lookahead_min_m,
                   self.lookahead_max_m) * self.tau_scale * self.la_scale
        if self.adapt_max_scale > 1.0:
            self._watch(dt_s, y, la / self.la_scale / u_la, self.on_straight)
        # tightened once the boat has held the path ("Tenth round"); the watches' acts undo it
        calm = (not out.clipped and self.la_scale == 1.0 and self.lead_scale == 1.0
                and self.clip_scale == 1.0)
        # on a slow leg less (scale^(1 / slow)): its sluggish pilots swing on the full scale
        t_scale = self.tight_scale if slow == 1.0 else math.pow(self.tight_scale, 1.0 / slow)
        tight = self.tight.step(dt_s, y, self.on_straight, calm, t_scale, self.tight_wait_s,
                                self.tight_band_m, self.tight_exit_m)
        if self.tight.note:
            self._add_note(self.tight.note)
        la *= tight
        # adaptive crab (ALOS), anti-windup: frozen while clipped (the command or the approach
        # angle), far off or slow
        # held through corners: a turn's lag is not a steady crab, and what it learnt there
        # pushed the boat off after the corner (docs/NAVIGATION.md "Turns over the random boats")
        turning = self.alos_turn_hold > 0.0 and (arc_r > 0.0 or prev_rad != 0.0)
        # the course made good against the path: the lead's prediction and the slow leg's ALOS gate
        chi_rad = 0.0
        if self.crab_ok:
            chi_rad = wrap180(fix.heading_deg + self.crab_f_deg - prog.leg_bearing_deg) * _RAD - tan_rad
        w = 1.0
        if slow > 1.0:
            # a slow leg: the ALOS's integral time grows faster than the lookahead time (its
            # integral fed a slow pilot's swings), and it learns a steady offset (the course made
            # good along the path), not the long approach or a swing
            if self.slow_alos > 0.0:
                w = 1.0 / math.pow(slow, self.slow_alos)
            if self.slow_chi_deg > 0.0 and self.crab_ok:
                w *= 1.0 - abs(chi_rad) / (self.slow_chi_deg * _RAD)
        elif self.alos_chi_deg > 0.0 and self.crab_ok:
            # at speed too: a sluggish pilot's deadband swing (periods 45-90 s) winds the ALOS
            # up on each side ("Sixth round: the ALOS and the deadband")
            w *= 1.0 - abs(chi_rad) / (self.alos_chi_deg * _RAD)
        if (self.alos_gain > 0.0 and w > 0.0 and not out.clipped and not self._intercept_clamped and not turning
                and abs(y) < self.alos_zone_m and u >= self.crab_min_speed_mps and not prog.finished):
            # on the xte predicted alos_lead_s ahead ("Seventh round"): its integral is the xte's
            # integral plus alos_lead_s x the xte itself, a phase lead in its ~70 s loop that a
            # slow heading response (deadband, low gain) otherwise turns into a limit cycle
            y_a = y + self.alos_lead_s * u * math.sin(chi_rad) if self.alos_lead_s > 0.0 else y
            self.beta_hat_rad += dt_s * self.alos_gain * w * la / math.sqrt(la * la + y * y) * y_a
            lim = self.alos_max_deg * _RAD
            self.beta_hat_rad = _clip(self.beta_hat_rad, -lim, lim)
        crab = self.crab_f_deg * self.crab_use if self.crab_ok else 0.0
        # damping: the xte predicted xte_lead_s ahead from the course made good (heading + the
        # filtered crab: quieter than the raw COG), so the heading loop's lag cannot ring
        y_lead = y
        t_lead_s = self.xte_lead_s * self.lead_scale * self.la_scale * self.tau_scale * slow * tight  # T_d / T_la kept
        if t_lead_s > 0.0 and self.crab_ok:
            y_lead = y + t_lead_s * u * math.sin(chi_rad)
        corr = -math.atan2(y_lead, la) / _RAD
        self._intercept_clamped = corr > self.intercept_max_deg or corr < -self.intercept_max_deg
        corr = _clip(corr, -self.intercept_max_deg, self.intercept_max_deg)
        course = prog.leg_bearing_deg + (tan_rad + prev_rad) / _RAD + corr
        cmd = course - crab - self.beta_hat_rad / _RAD
        # the clip bounds the error the pilot steers on: its locked course minus its own compass.
        # About the GNSS heading instead, a clipped command follows the true heading, and the
        # pilot's lagging compass turns that into rate feedback of the wrong sign (kp x lag
        # beyond its own kd: a swing that grows; docs/NAVIGATION.md "Eleventh round")
        # a pilot whose gain is high gets the clip its gain allows (gain_clip_deg / gain, on
        # straights), in its own frame (docs/NAVIGATION.md "Twelfth round")
        g_clip = self.gain_clip()
        h_ref = fix.heading_deg
        if (self.pilot_heading_deg is not None and self.clip_pilot_frame > 0.0
                and (self.clip_pilot_frame >= 2.0 or self.clip_scale < 1.0 or g_clip > 0.0)):
            h_ref = self.pilot_heading_deg
        rel = wrap180(cmd - h_ref)
        lim = self.clip_deg * self.clip_scale if arc_r == 0.0 else self.clip_deg  # turns: as set
        if g_clip > 0.0 and arc_r == 0.0 and g_clip < lim:
            lim = g_clip
        if self.adapt_clip_back > 0.0 and arc_r == 0.0 and self.clip_scale < 1.0 and y * chi_rad > 0.0:
            # moving away from the path under a clip the watches cut: the pilot may still be asked
            # for the course parallel to the path, so a slow turn cannot carry the boat 20 m off
            # ("Seventh round: the clip lets the boat turn back")
            par = wrap180(prog.leg_bearing_deg + tan_rad / _RAD - crab - h_ref)
            if par * rel > 0.0:
                lim = max(lim, min(abs(par), self.clip_deg))
        out.clipped = rel > lim or rel < -lim
        rel = _clip(rel, -lim, lim)
        # the soft clip (docs/NAVIGATION.md "Sixth round"): on a straight the boat has crossed
        # twice since it began (after the approach or a corner's exit: a swing), while the law
        # steers at its own clip: a swing's large errors reach the pilot at soft_gain, so a hot
        # pilot keeps its rudder off the stop; not on top of a clip the watches already cut
        # (that starves the boat)
        if (self.soft_gain < 1.0 and self.on_straight and not self._approach and self.swing.closed >= 2
                and self.clip_scale == 1.0):
            rel = _soft(rel, self.soft_knee_deg, self.soft_gain)
        out.rel_cmd_deg = rel
        out.heading_cmd_deg = wrap360(h_ref + rel)
        out.ref_course_deg = wrap360(prog.leg_bearing_deg + (tan_rad + prev_rad) / _RAD)
        out.xte_m = prog.xte_m
        out.path_xte_m = y
        out.crab_deg = crab
        out.integral_deg = self.beta_hat_rad / _RAD
        out.lookahead_m = la
        out.preview_deg = prev_rad / _RAD
        out.arc_radius_m = arc_r
        out.valid = True
        return out

    def heading_response(self, t_ms, locked_deg, heading_deg, ok):
        """Feed the heading response estimate (the pilot's locked course as it reports it, the true
        heading; ok: steering, GNSS good) and schedule the lookahead from it: T_la at least what
        keeps zeta = 0.5 (1 + T_d / T_la) sqrt(T_la / tau) >= tau_zeta at the estimate, with
        T_d / T_la as set (0.5), never below the configured one (docs/NAVIGATION.md "Timing from
        the measured heading response"). Only on a straight, only with tau_sched on. Returns a note
        or ""."""
        if self.tau_sched <= 0.0:
            return ""
        if self.tau is None:
            from trackpilot.nav.tauest import TauEstimate

            self.tau = TauEstimate(self.heading_tc_s, hi_s=self.tau_max_s, window_s=self.tau_window_s)
        if not self.tau.step(t_ms, locked_deg, heading_deg, ok and self.on_straight):
            return ""
        tau_s = self.tau.tau_s
        la_s = self.lookahead_gain * self.heading_tc_s  # the configured T_la (clamps aside)
        r = self.xte_lead_s / la_s
        need = 2.0 * self.tau_zeta / (1.0 + r)
        need_la_s = need * need * tau_s
        old = self.tau_scale
        self.tau_scale = need_la_s / la_s if need_la_s > la_s else 1.0
        d = tau_s - self._tau_logged_s
        if self.tau_scale == old and -0.1 * tau_s < d < 0.1 * tau_s:
            return ""  # logged when the scale or the estimate (by 10 %) changes
        self._tau_logged_s = tau_s
        t = self.tau
        return "heading response %.1f s (fits %.1f %.1f %.1f s, %d): lookahead x%.2f" % (
            tau_s, t.s0, t.s1, t.s2, t.samples, self.tau_scale)

    def pilot_hunts(self):
        """The pilot's own loop hunts (core/pilotwatch.py): steer it gently. Returns a note or ""."""
        if self.hunt_gentle <= 0.0 or (self.lead_scale == 0.0 and self.la_scale >= 2.0):
            return ""
        self.lead_scale = 0.0
        self.la_scale = max(self.la_scale, min(2.0, self.adapt_max_scale))
        return "pilot hunts: lead off, lookahead x%.2f" % self.la_scale

    def _watch(self, dt_s, y, t_la_s, straight):
        """The swing watch: the path xte keeps swinging (>= adapt_swing_m, two half cycles in a row
        that each keep adapt_keep of the one before, regular period) on a straight; t_la_s: the
        unscaled lookahead / U.
        A short period (< adapt_split x t_la_s) is the lead's heading feedback ringing with the
        pilot's own resonance: the lead goes off. A long one (or a short one with the lead off) is
        the outer loop too fast for this pilot, or its ram saturating on large course steps:
        lookahead x2 (the lead with it) up to adapt_max_scale and the straight's command clip
        halved (not below adapt_clip_min_deg). Turns do not count and keep the clip as set."""
        if not straight:
            self.swing.reset()
            self._approach = False  # a turn's exit is not the approach
            return
        fired = self.swing.step(dt_s, y)
        if self._approach and self.swing.closed >= 2:
            self._approach = False  # the overshoot's half cycle closed: the approach is over
        if (not fired and self._approach and self._stop_s >= self.adapt_stop_s
                and self.swing.overshoot(self.adapt_overshoot)):
            self._approach = False  # once
            self._on_overshoot()
            return
        if not fired:
            return
        period_s = 2.0 * self.swing.first_s
        clip_min = self.adapt_clip_min_deg / self.clip_deg
        if period_s < self.adapt_split * t_la_s and self.lead_scale > 0.0:
            self.lead_scale = 0.0
            what = "lead off"
        elif self.la_scale < self.adapt_max_scale or self.clip_scale > clip_min:
            self.la_scale = min(self.adapt_max_scale, self.la_scale * 2.0)
            self.clip_scale = max(clip_min, self.clip_scale * 0.5)
            what = "lookahead x%.2f, clip %.0f deg" % (self.la_scale, self.clip_deg * self.clip_scale)
        else:
            what = "at its limits"
        text = "xte swings +-%.1f m, period %.0f s: %s" % (self.swing.amp, period_s, what)
        self._add_note(text)

    # ---- what the boat achieves in turns (docs/NAVIGATION.md "Fourth round") ----
    def _turn_watch(self, fix, prog, dt_s, arc_r, tan_rad):
        """Measure the radius the boat turns at while an arc asks more than it gives (the course
        made good trailing the path by > _TRAIL_DEG, or the rudder at its stop; from the arc until
        the boat has caught up with the path), and ask for later arcs no tighter than turn_margin x
        that; tell a U-turn ahead narrower than twice that."""
        tw = self.turns
        limited = False
        s = tw.sign
        # from an arc on, and past its end while the boat still trails the path (a short arc ends
        # before a slow boat has turned its turn)
        if (arc_r > 0.0 or tw.in_stretch) and fix.vel_valid and not prog.finished:
            cmg = fix.heading_deg + (self.crab_f_deg if self.crab_ok else 0.0)
            trail = s * wrap180(prog.leg_bearing_deg + tan_rad / _RAD - cmg)
            at_stop = tw.rudder_ok and tw.stop_deg >= _STOP_SEEN_DEG and s * tw.rudder_now() >= tw.stop_deg - 1.0
            limited = trail > _TRAIL_DEG or at_stop
        if not tw.step(dt_s, fix.heading_deg, fix.sog_mps if fix.vel_valid else 0.0, s, limited):
            return
        want = self.turn_margin * tw.radius_m
        have = self._want if tw.pending_m <= 0.0 else tw.pending_m
        if want > have * 1.05 or (tw.want_m > 0.0 and want < have * 0.95):
            tw.pending_m = want
        text = "turned at %.1f m at %.1f m/s (mean %.1f m of %d): arcs %.1f m" % (
            tw.last_m, tw.last_sog_mps, tw.radius_m, tw.samples,
            max(self.round_factor * self.turn_radius_m, want))
        from trackpilot.nav.track import narrow_uturn

        k, w = narrow_uturn(self._track, prog.leg, 2.0 * tw.radius_m, 200)
        if k > 0 and k != tw.uturn_told:  # once per U-turn
            tw.uturn_told = k
            text += "; U-turn at %s %.0f m wide, the boat turns 2 x %.1f m: expect %.1f m past it" % (
                self._track.waypoints[k].label(k), w, tw.radius_m, 2.0 * tw.radius_m - w)
        self._add_note(text)

    def _replan(self, prog, p_m):
        """Apply the asked arc radius on a straight; kept only if the boat stays on the straight
        of the new plan (the corner behind grows too). Returns the new _path or None."""
        tw = self.turns
        old_want, old_meas = self._want, tw.want_m
        tw.want_m = tw.pending_m
        self._want = max(self.round_factor * self.turn_radius_m, tw.want_m)
        self._cache_k = [-1] * _CORNER_CACHE
        r = self._path(prog, p_m)
        if r[3] == 0.0 and -0.035 < r[2] < 0.035:
            tw.pending_m = 0.0
            return r
        self._want, tw.want_m = old_want, old_meas  # not here: the next straight
        self._cache_k = [-1] * _CORNER_CACHE
        return None

    def rudder_report(self, t_ms, rudder_deg, ok):
        """The pilot's reported rudder (0x84 / 0x9C; t_ms: when it came), while steering (ok). The
        fastest move sets the ram's delay the preview adds (TurnWatch.set_lead). Returns a note or
        ""."""
        tw = self.turns
        tw.rudder_ok = ok and t_ms is not None and rudder_deg is not None
        if not tw.rudder_ok or self.ram_lead <= 0.0:
            return ""
        if not tw.rudder(t_ms, rudder_deg):
            return ""
        old = tw.lead_s
        tw.set_lead(self.ram_lead, self.ram_ref_dps)
        if -0.1 < tw.lead_s - old < 0.1:
            return ""  # logged when the lead moves by 0.1 s
        return "rudder moves at %.1f deg/s (stop %.0f deg): preview %.1f s" % (
            tw.ram_dps, tw.stop_deg, self.preview_s + tw.lead_s)

    def gain_clip(self):
        """The straight's clip from the pilot's gain (deg; 0.0: none): the learnt gain's once it
        set one, else the measured gain's (pilot_gain, from the commissioning trial)."""
        pg = self.gain
        if pg is not None and pg.clip_deg > 0.0:
            return pg.clip_deg
        if self.gain_clip_deg > 0.0 and self.pilot_gain >= self.gain_clip_min:
            return self.gain_clip_deg / self.pilot_gain
        return 0.0

    def pilot_status(self, t_ms, compass_deg, course_deg, rudder_deg, deadband_deg):
        """Each new pilot status while the pilot steers for us in AUTO: its compass, locked
        course and rudder (deg), its deadband as configured. Feeds the gain estimate
        (nav/pilotgain.py); once it is sure of a gain at or above gain_clip_min the straight's clip
        becomes gain_clip_deg / gain (kept for the boat; updated when the estimate moves by 10 %).
        Returns a note or ""."""
        if self.gain_clip_deg <= 0.0 or compass_deg is None or course_deg is None or rudder_deg is None:
            return ""
        pg = self.gain
        if pg is None:
            from trackpilot.nav.pilotgain import PilotGain

            pg = self.gain = PilotGain()
        tw = self.turns
        trusted = tw.ram_trusted()
        ram = tw.ram_dps if trusted else self.ram_ref_dps
        stop = tw.stop_deg if trusted else self.adapt_stop_deg + 3.0
        if not pg.step(t_ms, compass_deg, course_deg, rudder_deg, deadband_deg, ram, stop):
            return ""
        g = pg.gain  # 0.0 while not sure
        if g <= 0.0 or (g < self.gain_clip_min and pg.clip_deg == 0.0):
            return ""
        if g < self.gain_clip_min:
            g = self.gain_clip_min  # kept for the boat: a high gain once seen stays clipped
        if pg.clip_deg > 0.0 and 0.9 * pg.told < g < 1.1 * pg.told:
            return ""  # said when the gain moves by 10 %
        pg.told = g
        pg.clip_deg = self.gain_clip_deg / g
        return "the pilot's gain %.2f deg/deg (damping ~%.1f s; %d reports, %.1f deg RMS): clip %.1f deg about its compass" % (
            pg.gain, pg.damping_s, pg.scored, pg.rms_deg, pg.clip_deg)

    def _add_note(self, text):
        """Add text to this step's note (the swing watch, the overshoot and the turn watch may
        each have something to say in one step)."""
        self.out.note = text if not self.out.note else self.out.note + "; " + text

    def pilot_rudder(self, dt_s, rudder_deg):
        """Each new pilot status in AUTO: its reported rudder, dt_s since the last status. Counts
        the seconds the rudder stands at its stop (adapt_stop_deg) while the approach's overshoot
        is open (the half cycle after the first crossing of the path since the engage)."""
        if (self._approach and self.swing.closed == 1 and rudder_deg is not None
                and (rudder_deg >= self.adapt_stop_deg or rudder_deg <= -self.adapt_stop_deg)):
            self._stop_s += dt_s

    def _on_overshoot(self):
        """The approach overshoots the path by adapt_overshoot of where it started while the
        pilot's rudder stands at its stop: its ram saturates on the law's course steps (a high
        gain on a slow ram, docs/NAVIGATION.md "Fourth round"): lookahead x2 and the straight's
        clip cut to adapt_overshoot_clip_deg now, not after two more half cycles. (A sluggish pilot
        overshoots with its rudder well off the stop: left alone, a longer lookahead and a tight
        clip starve it.)"""
        self.la_scale = min(self.adapt_max_scale, self.la_scale * 2.0)
        scale = max(self.adapt_clip_min_deg, self.adapt_overshoot_clip_deg) / self.clip_deg
        if scale < self.clip_scale:
            self.clip_scale = scale
        text = ("approach overshoots %.1f m of %.1f m, rudder at its stop %.0f s: "
                "lookahead x%.2f, clip %.0f deg") % (
            self.swing.peak, self.swing.prev_amp, self._stop_s, self.la_scale,
            self.clip_deg * self.clip_scale)
        self._add_note(text)

    def _speed(self, prog, leg):
        """The leg's speed, eased towards the next leg's before the waypoint (surge lag), and
        capped so the planned corner's turn rate U / r stays below max_turn_rate_dps."""
        v = leg.speed_mps
        nxt = prog.next_leg()
        if nxt is None:
            if prog.along_m < self._t(prog.leg):
                v = self._turn_cap(v, self._r(prog.leg))
            return v
        k = prog.leg + 1
        t_end = self._t(k)
        to_turn = prog.remain_m - t_end  # distance to where the corner begins
        ramp_m = self.speed_tc_s * v
        v_next = nxt.speed_mps
        if ramp_m > 0.0 and v_next < v and to_turn < ramp_m:
            f = to_turn / ramp_m if to_turn > 0.0 else 0.0
            v = v_next + (v - v_next) * f
        if to_turn < ramp_m:
            v = self._turn_cap(v, self._r(k))
        if prog.along_m < self._t(prog.leg):  # still on the corner behind (exit half of its arc)
            v = self._turn_cap(v, self._r(prog.leg))
        return v

    def _turn_cap(self, v, r):
        if r > 0.0 and self.max_turn_rate_dps > 0.0:
            v_turn = self.max_turn_rate_dps * _RAD * r
            if v_turn < self.min_speed_mps:
                v_turn = self.min_speed_mps
            if v > v_turn:
                v = v_turn
        return v


LAWS = {"seed": SeedLaw, "los": LosLaw}


def make_law(cfg, params=None):
    """The guidance law chosen by configuration, with its parameters.

    make_law("los", {"clip_deg": 30.0})             # a name and the law's own parameter names
    make_law(cfg["guidance"], cfg["boat"])           # the config sections: guidance.law names the
        # law; keys "<law>_<param>" (seed_k_psi, los_lookahead_gain ...) set its parameters, other
        # laws' keys are ignored; the boat's min_turn_radius_m sets LosLaw.turn_radius_m.
    Unknown parameters or values out of range raise ValueError (never silently ignored)."""
    if isinstance(cfg, dict):
        name = cfg.get("law", "los")
        prefix = name + "_"
        own = {}
        for k in cfg:
            if k.startswith(prefix):
                own[k[len(prefix):]] = cfg[k]
        boat = params or {}
        if name == "los" and "min_turn_radius_m" in boat and "turn_radius_m" not in own:
            own["turn_radius_m"] = boat["min_turn_radius_m"]
        params = own
    else:
        name = cfg
    cls = LAWS.get(name)
    if cls is None:
        raise ValueError("unknown guidance law %r (known: seed, los)" % (name,))
    law = cls()
    if params:
        law.configure(params)
    return law
