# The dead reckoner (issue 12): prediction from the last good fix, compass heading, water speed
# and the learnt current, or the receiver's own velocity; growing uncertainty.
import math

from tpassert import eq, near, true

from trackpilot import geo
from trackpilot.deadreckon import DeadReckoner, gap_step_due
from trackpilot.fix import RTK_FIXED, RTK_NONE, Fix

LAT0 = 514950000
LON0 = 36100000


def _fix(east_m, north_m, heading_deg, sog, cog):
    f = Fix()
    la, lo, lah, loh = geo.move_hp(LAT0, LON0, east_m, north_m)
    f.lat_e7, f.lon_e7, f.lat_hp, f.lon_hp = la, lo, lah, loh
    f.pos_valid = True
    f.rtk = RTK_FIXED
    f.h_acc_m = 0.02
    f.heading_valid = True
    f.heading_deg = heading_deg
    f.vel_valid = True
    f.sog_mps = sog
    f.cog_deg = cog
    return f


def _en(f):
    return geo.offset_m(LAT0, LON0, f.lat_e7, f.lon_e7, 0, 0, f.lat_hp, f.lon_hp)


def test_current_learnt_and_used_in_a_gap():
    # heading north at 1.5 m/s through water, a current of 0.2 m/s to the east
    dr = DeadReckoner()
    t = 1000
    for k in range(100):  # 20 s of good fixes
        vg_e, vg_n = 0.2, 1.5
        f = _fix(0.2 * k * 0.2, 1.5 * k * 0.2, 0.0, math.sqrt(vg_e ** 2 + vg_n ** 2),
                 math.degrees(math.atan2(vg_e, vg_n)))
        dr.good_fix(t + 200 * k, f, 1.5, 0.2)
    near(dr.cur_e_mps, 0.2, 0.01)
    near(dr.cur_n_mps, 0.0, 0.01)
    t_last = t + 200 * 99
    e0, n0 = 0.2 * 99 * 0.2, 1.5 * 99 * 0.2
    for k in range(1, 51):  # 10 s of gap, same water speed (no lag to settle)
        true(dr.predict(t_last + 200 * k, 0.0, 1.5))
    e, n = _en(dr.fix)
    near(e - e0, 2.0, 0.1)
    near(n - n0, 15.0, 0.1)
    eq(dr.fix.rtk, RTK_NONE)
    true(dr.fix.heading_valid and dr.fix.pos_valid and not dr.fix.vel_valid)
    near(dr.sigma_m, 1.0, 0.05)  # 0.1 m/s for 10 s
    near(dr.hold_s, 10.0, 0.01)


def test_receivers_velocity_beats_water_speed_and_weighs_less():
    dr = DeadReckoner()
    dr.good_fix(0, _fix(0.0, 0.0, 90.0, 1.0, 90.0), 1.0, 0.2)
    for k in range(1, 26):  # 5 s with a single fix's Doppler velocity: 0.5 m/s to the north
        dr.predict(200 * k, 90.0, 1.0, (0.5, 0.0))
    e, n = _en(dr.fix)
    near(e, 0.0, 0.01)
    near(n, 2.5, 0.01)
    near(dr.hold_s, 5.0 * DeadReckoner.DOPPLER_WEIGHT, 0.01)


def test_no_prediction_without_a_fix_and_water_speed_lag():
    dr = DeadReckoner()
    true(not dr.predict(0, 0.0, 1.0))
    dr.good_fix(0, _fix(0.0, 0.0, 0.0, 1.5, 0.0), 1.5, 0.2)
    dr.predict(3500, 0.0, 0.5)  # slowed: water speed follows with the hull's lag
    true(0.5 < dr.water_mps < 1.5)


def test_ticks_wrap():
    dr = DeadReckoner()
    t0 = (1 << 30) - 100
    dr.good_fix(t0, _fix(0.0, 0.0, 0.0, 1.0, 0.0), 1.0, 0.2)
    dr.predict(900, 0.0, 1.0)  # 1 s later, across the wrap
    e, n = _en(dr.fix)
    near(n, 1.0, 0.01)
    near(dr.gap_s(900), 1.0, 1e-6)


def test_gap_timer_rule():
    eq(gap_step_due(1000, None, 200, None), False)  # no epoch yet
    eq(gap_step_due(1279, 1000, 200, None), False)
    eq(gap_step_due(1280, 1000, 200, None), True)  # one interval + 80 ms
    eq(gap_step_due(1400, 1000, 200, 1280), False)
    eq(gap_step_due(1480, 1000, 200, 1280), True)  # then once per interval
    eq(gap_step_due(1179, 1000, 100, None), False)  # 10 Hz measured
    eq(gap_step_due(1180, 1000, 100, None), True)
    eq(gap_step_due(1280, 1000, 0, None), True)  # not measured yet: 200 ms
    t0 = (1 << 30) - 100
    eq(gap_step_due(180, t0, 200, None), True)  # across the ticks wrap
    eq(gap_step_due(170, t0, 200, None), False)
