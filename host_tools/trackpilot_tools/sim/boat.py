"""The boat and its water: first-order Nomoto yaw with speed-dependent K and T, rudder authority
with the square of the water speed over the rudder, first-order surge lag from RPM, current
(constant + Gauss-Markov walk), wind with gusts (leeway drift and yaw moment), wave yaw.

Frame: east/north metres in the simulator's plane (geodesy.LocalFrame), heading in grid degrees,
+ = clockwise (to starboard). Equations in docs/SIMULATOR.md.
"""
import math

from .randproc import GaussMarkov

D2R = math.pi / 180.0


def wrap180(a):
    return (a + 180.0) % 360.0 - 180.0


def interp_map(pairs, x):
    """Piecewise-linear map [[x, y], ...] (x ascending), clamped at the ends."""
    if x <= pairs[0][0]:
        return pairs[0][1]
    for (x0, y0), (x1, y1) in zip(pairs, pairs[1:]):
        if x <= x1:
            return y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    return pairs[-1][1]


class Environment:
    """Current, wind and waves; `step(dt)` advances the random parts."""

    def __init__(self, water, wind, rng):
        self.water = water
        self.wind = wind
        c = water["current_mps"]
        a = water["current_dir_deg"] * D2R
        self.cur0_e = c * math.sin(a)
        self.cur0_n = c * math.cos(a)
        self.cur_walk_e = GaussMarkov(rng, water["current_walk_sd_mps"], water["current_walk_tau_s"])
        self.cur_walk_n = GaussMarkov(rng, water["current_walk_sd_mps"], water["current_walk_tau_s"])
        if c <= 0.0:  # calm water: no walk either
            self.cur_walk_e.sd = self.cur_walk_n.sd = 0.0
            self.cur_walk_e.x = self.cur_walk_n.x = 0.0
        self.gust = GaussMarkov(rng, wind["gust_sd_frac"], wind["gust_tau_s"])
        self.wdir = GaussMarkov(rng, wind["dir_sd_deg"], wind["dir_tau_s"])
        periods = water["wave_periods_s"]
        amp = water["wave_yaw_rms_deg"] * math.sqrt(2.0 / len(periods)) if periods else 0.0
        self.waves = [(amp, 2 * math.pi / p, rng.uniform(0, 2 * math.pi)) for p in periods]

    def step(self, dt_s):
        self.cur_walk_e.step(dt_s)
        self.cur_walk_n.step(dt_s)
        self.gust.step(dt_s)
        self.wdir.step(dt_s)

    def current_en(self):
        return self.cur0_e + self.cur_walk_e.x, self.cur0_n + self.cur_walk_n.x

    def wind_speed_dir(self):
        """(speed m/s, FROM direction deg) now, gusts included (never negative)."""
        w = self.wind["speed_mps"]
        if w <= 0.0:
            return 0.0, self.wind["dir_deg"]
        return max(0.0, w * (1.0 + self.gust.x)), (self.wind["dir_deg"] + self.wdir.x) % 360.0

    def wave_yaw_deg(self, t_s):
        return sum(a * math.sin(w * t_s + ph) for a, w, ph in self.waves)


class Boat:
    """State: east_m, north_m, psi_deg (low-frequency heading), r_degps, u_mps (water speed)."""

    def __init__(self, params, env, east_m=0.0, north_m=0.0, heading_deg=0.0, u_mps=0.0, rpm=0.0):
        self.p = params
        self.env = env
        self.t_s = 0.0
        self.east_m = east_m
        self.north_m = north_m
        self.psi_deg = heading_deg % 360.0
        self.r_degps = 0.0
        self.u_mps = u_mps
        self.v_lee_mps = 0.0
        self.rudder_deg = 0.0
        self.rudder_eff_deg = 0.0  # the rudder angle the flow has caught up with (rudder_lag_s)
        self.rpm = rpm
        self.vel_e = self.vel_n = 0.0
        self._update_outputs()

    # ---------------------------------------------------------------- derived quantities
    def heading_deg(self):
        """Hull heading (grid): low-frequency heading + wave yaw."""
        return (self.psi_deg + self.env.wave_yaw_deg(self.t_s)) % 360.0

    def apparent_wind(self):
        """(speed m/s, angle deg relative to the bow, + = from starboard, 0..360)."""
        w, wdir = self.env.wind_speed_dir()
        a = wdir * D2R
        air_e = -w * math.sin(a) - self.vel_e  # air velocity relative to the boat (where it goes)
        air_n = -w * math.cos(a) - self.vel_n
        spd = math.hypot(air_e, air_n)
        if spd < 1e-9:
            return 0.0, 0.0
        from_dir = math.degrees(math.atan2(-air_e, -air_n))
        return spd, (from_dir - self.heading_deg()) % 360.0

    def _update_outputs(self):
        h = self.heading_deg() * D2R
        ce, cn = self.env.current_en()
        se, sn = math.sin(h), math.cos(h)
        self.vel_e = self.u_mps * se + self.v_lee_mps * sn + ce
        self.vel_n = self.u_mps * sn - self.v_lee_mps * se + cn

    # ---------------------------------------------------------------- integration
    def step(self, dt_s, rudder_deg, rpm):
        p = self.p
        self.rudder_deg = rudder_deg
        self.rpm = rpm
        self.env.step(dt_s)
        L = p["length_m"]
        U = max(self.u_mps, 0.0)
        u_t = max(U, p["u_floor_mps"])
        T = p["t_prime"] * L / u_t
        wash = p["wash_coeff"] * (p["wash_speed_mps_at_max_rpm"] * min(abs(rpm), p["rpm_max"]) / p["rpm_max"]) ** 2
        K = p["k_prime"] * (U * U + wash) / (u_t * L)  # = K' U / L above the floor, no wash

        wa_spd, wa_ang = self.apparent_wind()
        r_wind = -self.env.wind["yaw_coeff_degps_per_mps2"] * wa_spd * wa_spd * math.sin(wa_ang * D2R)
        lag = p.get("rudder_lag_s", 0.0)
        if lag > 0.0:
            self.rudder_eff_deg = rudder_deg + (self.rudder_eff_deg - rudder_deg) * math.exp(-dt_s / lag)
        else:
            self.rudder_eff_deg = rudder_deg
        r_ss = K * self.rudder_eff_deg + r_wind
        a = math.exp(-dt_s / T)
        r0 = self.r_degps
        self.r_degps = r_ss + (r0 - r_ss) * a
        # exact integral of the first-order response over the step
        dpsi = r_ss * dt_s + (r0 - r_ss) * T * (1.0 - a)
        self.psi_deg = (self.psi_deg + dpsi) % 360.0

        frac = min(1.0, abs(rudder_deg) / 30.0)
        u_tgt = interp_map(p["rpm_speed_map"], rpm) * (1.0 - p["yaw_speed_loss"] * frac * frac)
        u_tgt *= p.get("speed_map_scale", 1.0)
        self.u_mps = u_tgt + (self.u_mps - u_tgt) * math.exp(-dt_s / p["surge_tau_s"])
        # leeway: the hull drifts sideways through the water with the apparent crosswind
        air_stbd = wa_spd * math.sin(wa_ang * D2R)  # component of the wind coming from starboard
        self.v_lee_mps = -self.env.wind["leeway_frac"] * air_stbd

        ve0, vn0 = self.vel_e, self.vel_n
        self.t_s += dt_s
        self._update_outputs()
        self.east_m += 0.5 * (ve0 + self.vel_e) * dt_s
        self.north_m += 0.5 * (vn0 + self.vel_n) * dt_s

    def sog_cog(self):
        sog = math.hypot(self.vel_e, self.vel_n)
        cog = math.degrees(math.atan2(self.vel_e, self.vel_n)) % 360.0
        return sog, cog
