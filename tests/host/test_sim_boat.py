"""Boat model sanity: turning radius, speed-dependent K and T, surge lag, current, wind, waves."""
import math
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host_tools"))
from trackpilot_tools.sim import boat, params, randproc  # noqa: E402


def make(water=None, wind=None, u=0.0, seed=1, **boat_over):
    p = params.load()
    p["water"]["wave_yaw_rms_deg"] = 0.0
    p["water"].update(water or {})
    p["wind"].update(wind or {})
    p["boat"].update(boat_over)
    env = boat.Environment(p["water"], p["wind"], randproc.component_rng(seed, "environment"))
    return boat.Boat(p["boat"], env, u_mps=u), p


def rpm_for(p, speed):
    return speed * 400.0  # the default map is 400 RPM per m/s up to 3 m/s


def test_turning_radius_at_full_rudder_is_8_to_10_m():
    b, p = make(u=2.0)
    pts = []
    for i in range(int(60 / 0.05)):
        b.step(0.05, 30.0, rpm_for(p, 2.0) / (1 - p["boat"]["yaw_speed_loss"]))
        if i > 600:
            pts.append((b.east_m, b.north_m))
    # radius from the circle the boat sails (diameter = max extent)
    ex = max(e for e, _ in pts) - min(e for e, _ in pts)
    nx = max(n for _, n in pts) - min(n for _, n in pts)
    radius = (ex + nx) / 4
    assert 8.0 <= radius <= 10.0
    assert b.u_mps == pytest.approx(2.0, rel=0.02)
    assert b.r_degps > 0  # + rudder turns to starboard


def test_nomoto_k_and_t_scale_with_speed():
    for u, k_lo, k_hi in ((2.0, 0.4, 0.5), (0.5, 0.09, 0.13)):
        b, p = make(u=u)
        rpm = rpm_for(p, u)
        b.step(0.05, 5.0, rpm)
        r1 = b.r_degps
        for _ in range(int(40 / 0.05)):
            b.step(0.05, 5.0, rpm)
        k = b.r_degps / 5.0
        assert k_lo <= k <= k_hi, (u, k)
        # T from the first step of the response: r(dt) = K d (1 - exp(-dt/T))
        T = -0.05 / math.log(1 - r1 / b.r_degps)
        T_expected = p["boat"]["t_prime"] * p["boat"]["length_m"] / u
        assert T == pytest.approx(T_expected, rel=0.05)


def test_rudder_authority_collapses_at_low_speed():
    b, p = make(u=0.1)
    for _ in range(200):
        b.step(0.05, 30.0, 40)
    slow = b.r_degps
    b2, _ = make(u=2.0)
    for _ in range(200):
        b2.step(0.05, 30.0, 800 / 0.85)
    assert slow < b2.r_degps / 50


def test_surge_lag_about_5_s_with_motor():
    b, p = make(u=0.0)
    # the hull's own lag (the motor controller adds its ~1.5 s in the full loop)
    tau = p["boat"]["surge_tau_s"]
    for _ in range(int(tau / 0.05)):
        b.step(0.05, 0.0, 800)
    assert b.u_mps == pytest.approx(2.0 * (1 - math.exp(-1)), rel=0.03)


def test_current_carries_the_boat():
    # (no air drag: drifting with the current through still air would slow it slightly)
    b, p = make(water={"current_mps": 0.2, "current_dir_deg": 90.0, "current_walk_sd_mps": 0.0},
                wind={"leeway_frac": 0.0}, u=0.0)
    for _ in range(200):
        b.step(0.05, 0.0, 0)
    assert b.east_m == pytest.approx(2.0, abs=0.01) and abs(b.north_m) < 0.01
    sog, cog = b.sog_cog()
    assert cog == pytest.approx(90.0, abs=0.1)


def test_wind_from_starboard_pushes_to_port_and_turns_the_bow_away():
    b, p = make(wind={"speed_mps": 6.0, "dir_deg": 90.0, "gust_sd_frac": 0.0, "dir_sd_deg": 0.0}, u=1.0)
    for _ in range(40):  # heading north, wind from the east (starboard)
        b.step(0.05, 0.0, 400)
    assert b.v_lee_mps < -0.1  # drifting to port (west)
    assert b.r_degps < 0  # bow falls off to port, away from the wind
    assert b.east_m < 0


def test_wave_yaw_rms():
    b, p = make(water={"wave_yaw_rms_deg": 2.0})
    xs = [b.env.wave_yaw_deg(t * 0.1) for t in range(20000)]
    rms = math.sqrt(sum(x * x for x in xs) / len(xs))
    assert rms == pytest.approx(2.0, rel=0.1)
