"""Dead reckoning through GNSS gaps (bridges, trees): a predicted antenna position from the last
good fix, the pilot's compass corrected by the learnt offset, and a velocity.

Pure logic, no I/O: the app feeds it good fixes and, in a gap, asks for a prediction at a time.

    dr = DeadReckoner()
    dr.good_fix(t_ms, fix, water_mps)                # every steerable epoch (RTK fixed/float)
    ok = dr.predict(t_ms, heading_deg, water_mps, gnss_vel)   # in a gap; fills dr.fix
    dr.sigma_m                                       # 1-sigma position uncertainty, grows
    gap_step_due(t_ms, last_epoch_ms, interval_ms, last_step_ms)   # the app's gap timer rule

Velocity in a gap, best first:
 1. the receiver's own velocity (Doppler; good to a few cm/s even without RTK, e.g. in a single
    fix after a bridge) when the epoch has one: `gnss_vel` = (sog_mps, cog_deg);
 2. else water speed along the compass heading plus the water current learnt while fixes were
    good (current = ground velocity - water speed along the heading, low-pass filtered).
With the receiver's velocity the error grows about a quarter as fast (its Doppler velocity is good
to ~0.03 m/s; water speed, current and a compass bent by steel give ~0.1 m/s): such seconds count
DOPPLER_WEIGHT toward the uncertainty and toward the hold time (`hold_s`, docs/MODES.md).
Water speed comes from the motor RPM (the app's rpm map) through a first-order lag, the hull's
surge response. The absolute position stays integer (1e-7 deg + 1e-9 parts); only the offset
from the last fix (metres) is a float.
"""
import math

from trackpilot.compat import ticks_diff
from trackpilot.fix import RTK_NONE, Fix
from trackpilot.geo import move_hp

_DEG = math.pi / 180.0

GAP_MARGIN_MS = 80  # above the receiver's latency jitter; with a 100 ms timer the loss is
# acted on within 0.5 s at 5 Hz (epoch 200 ms + latency <= 100 ms + 80 ms + timer 100 ms)


def gap_step_due(t_ms, last_epoch_ms, interval_ms, last_step_ms):
    """The gap timer's rule: True when no epoch came for one epoch interval (200 ms until it is
    measured) + GAP_MARGIN_MS, and the last dead-reckoned step is one interval old (or none)."""
    iv = interval_ms if interval_ms > 0 else 200
    if last_epoch_ms is None or ticks_diff(t_ms, last_epoch_ms) < iv + GAP_MARGIN_MS:
        return False
    return last_step_ms is None or ticks_diff(t_ms, last_step_ms) >= iv


class DeadReckoner:
    """sigma_rate_mps: how fast the 1-sigma position error grows in a gap (heading offset error
    ~2 deg at 1.5 m/s plus an unknown current change ~0.05 m/s: ~0.1 m/s).
    current_tc_s: time constant of the current estimate (waves and yaw average out).
    surge_tc_s: RPM -> water speed lag of the hull (3.5 s; the app feeds the RPM the motor
    controller reports, which already has the controller's own lag)."""

    DOPPLER_WEIGHT = 0.25  # a second with the receiver's velocity counts this much of the hold

    def __init__(self, sigma_rate_mps=0.1, current_tc_s=20.0, surge_tc_s=3.5):
        self.sigma_rate_mps = sigma_rate_mps
        self.current_tc_s = current_tc_s
        self.surge_tc_s = surge_tc_s
        self.fix = Fix()  # the predicted epoch (antenna position, compass heading)
        self.reset()

    def reset(self):
        self.valid = False  # a good fix seen since the last reset
        self.t_fix_ms = 0
        self.t_ms = 0
        self.lat_e7 = self.lon_e7 = self.lat_hp = self.lon_hp = 0
        self.east_m = 0.0  # offset of the prediction from the last good fix
        self.north_m = 0.0
        self.sigma0_m = 0.0
        self.sigma_m = 0.0
        self.drift_m = 0.0  # accumulated 1-sigma growth since the fix
        self.hold_s = 0.0  # gap time as the hold counts it (Doppler seconds weigh less)
        self.cur_e_mps = 0.0
        self.cur_n_mps = 0.0
        self.cur_n = 0  # samples in the current estimate
        self.water_mps = None  # lagged water speed

    def _water(self, dt_s, water_cmd_mps):
        if self.water_mps is None:
            self.water_mps = water_cmd_mps
        elif dt_s > 0:
            self.water_mps += (water_cmd_mps - self.water_mps) * (dt_s / (self.surge_tc_s + dt_s))
        return self.water_mps

    def good_fix(self, t_ms, fix, water_cmd_mps, dt_s):
        """A steerable epoch: anchor the prediction here, learn the current."""
        w = self._water(dt_s, water_cmd_mps)
        if fix.vel_valid and fix.heading_valid:
            h = fix.heading_deg * _DEG
            c = fix.cog_deg * _DEG
            ce = fix.sog_mps * math.sin(c) - w * math.sin(h)
            cn = fix.sog_mps * math.cos(c) - w * math.cos(h)
            self.cur_n += 1
            a = max(1.0 / self.cur_n, dt_s / (self.current_tc_s + dt_s))
            self.cur_e_mps += a * (ce - self.cur_e_mps)
            self.cur_n_mps += a * (cn - self.cur_n_mps)
        self.lat_e7 = fix.lat_e7
        self.lon_e7 = fix.lon_e7
        self.lat_hp = fix.lat_hp
        self.lon_hp = fix.lon_hp
        self.east_m = self.north_m = 0.0
        self.sigma0_m = fix.h_acc_m
        self.sigma_m = fix.h_acc_m
        self.drift_m = 0.0
        self.hold_s = 0.0
        self.t_fix_ms = self.t_ms = t_ms
        self.valid = True

    def gap_s(self, t_ms):
        return ticks_diff(t_ms, self.t_fix_ms) / 1000.0 if self.valid else 0.0

    def predict(self, t_ms, heading_deg, water_cmd_mps, gnss_vel=None):
        """Advance the prediction to t_ms (an injected-clock time; differences only). Returns
        False without a good fix to start from. Fills self.fix (RTK_NONE, pos and heading valid,
        sog/cog = the velocity used, vel_valid False)."""
        if not self.valid:
            return False
        dt_s = ticks_diff(t_ms, self.t_ms) / 1000.0
        if dt_s < 0:
            dt_s = 0.0
        w = self._water(dt_s, water_cmd_mps)
        if gnss_vel is not None:
            c = gnss_vel[1] * _DEG
            ve = gnss_vel[0] * math.sin(c)
            vn = gnss_vel[0] * math.cos(c)
        else:
            h = heading_deg * _DEG
            ve = w * math.sin(h) + self.cur_e_mps
            vn = w * math.cos(h) + self.cur_n_mps
        self.east_m += ve * dt_s
        self.north_m += vn * dt_s
        self.t_ms = t_ms
        k = self.DOPPLER_WEIGHT if gnss_vel is not None else 1.0
        self.hold_s += k * dt_s
        self.drift_m += k * self.sigma_rate_mps * dt_s
        g = self.drift_m
        self.sigma_m = math.sqrt(self.sigma0_m * self.sigma0_m + g * g)
        f = self.fix
        p = move_hp(self.lat_e7, self.lon_e7, self.east_m, self.north_m, self.lat_hp, self.lon_hp)
        f.t_ms = t_ms
        f.pos_valid = True
        f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp = p[0], p[1], p[2], p[3]
        f.rtk = RTK_NONE
        f.h_acc_m = self.sigma_m
        f.heading_valid = True
        f.heading_deg = heading_deg % 360.0
        f.heading_acc_deg = 2.0
        # the velocity is logged but not offered as measured: a law would learn a false crab
        # from it (COG against a compass heading that steel near a bridge bends)
        f.vel_valid = False
        f.sog_mps = math.sqrt(ve * ve + vn * vn)
        f.cog_deg = (math.atan2(ve, vn) / _DEG) % 360.0
        return True
