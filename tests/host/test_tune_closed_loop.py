"""tune's Nomoto fit on a synthetic trial sailed in closed loop with a known answer: a P-D pilot
(its own lagged compass, a deadband, a rate-limited ram) steering the zig-zag and the circles by
scripted course keys, in a gusty wind that yaws the boat and pushes it sideways (leeway), with a
current. No firmware, no simulator."""
import math

import numpy as np
import pytest

from trackpilot_tools import tune_fit as F

D2R = math.pi / 180.0
KP, TP, L = 0.9, 0.45, 5.0


def _closed_loop_trial(wind_mps=5.5, wind_from_deg=300.0, leeway_frac=0.06, yaw_coeff=0.008,
                       cur=(0.05, -0.15), seed=3):
    """The trial's zig-zags (1.6 and 2.5 m/s) and circles (2.5 m/s) sailed by a P-D pilot.
    Leeway: the hull drifts sideways at leeway_frac x the apparent crosswind (as a small open
    boat does); the wind's yaw rate is -yaw_coeff Va^2 sin(apparent angle)."""
    rng = np.random.default_rng(seed)
    dt = 0.02
    t_end = 240.0
    n = int(t_end / dt)
    t = np.arange(n) * dt
    # the script: zig-zag at the low speed, zig-zag at the high speed, circles to starboard and port
    plan = [("zigzag", 0.0, 60.0, 1.6), ("zigzag", 60.0, 120.0, 2.5),
            ("circle", 120.0, 180.0, 2.5), ("circle", 180.0, 240.0, 2.5)]
    psi = r = de = ram = 0.0
    comp = psi
    comp_rate = 0.0
    u = 1.6
    gust = 0.0
    course = 20.0
    side = 1
    out = {k: np.zeros(n) for k in ("psi", "ram", "u", "ve", "vn", "va", "wa", "course")}
    for k in range(n):
        kind, t0, t1, u_set = next(p for p in plan if p[1] <= t[k] < p[2] or p is plan[-1])
        u += (u_set * (1.0 - 0.1 * (ram / 30.0) ** 2) - u) * dt / 3.0
        gust += -gust * dt / 6.0 + 0.25 * math.sqrt(2 * dt / 6.0) * rng.normal()
        w = wind_mps * max(0.0, 1.0 + gust)
        # the pilot: P-D on its lagged compass, deadband 1 deg, ram 10 deg/s, limit 30 deg
        c_new = comp + (psi - comp) * dt / 0.5
        comp_rate += ((c_new - comp) / dt - comp_rate) * dt / 0.5
        comp = c_new
        if kind == "zigzag":
            if t[k] - t0 < dt:
                side, base = 1, psi
            if side * (psi - base) > 10.0:
                side = -side
            course = base + 20.0 * side
        else:
            direction = 1.0 if t0 < 180.0 else -1.0
            course = comp + 150.0 * direction
        err = course - comp
        e = 0.0 if abs(err) < 1.0 else err - math.copysign(1.0, err)
        cmd = max(-30.0, min(30.0, 1.5 * e - 1.2 * comp_rate))
        ram += max(-10.0 * dt, min(10.0 * dt, cmd - ram))
        de += (ram - de) * dt / 0.15  # the rudder's flow lag
        # the apparent wind (where the air goes, relative to the boat's ground velocity)
        h = psi * D2R
        wdir = wind_from_deg * D2R
        ve_w = u * math.sin(h)
        vn_w = u * math.cos(h)
        air_e = -w * math.sin(wdir) - (ve_w + cur[0])
        air_n = -w * math.cos(wdir) - (vn_w + cur[1])
        va = math.hypot(air_e, air_n)
        wa = (math.degrees(math.atan2(-air_e, -air_n)) - psi) % 360.0
        crosswind = va * math.sin(wa * D2R)  # from starboard
        v_lee = -leeway_frac * crosswind  # to starboard
        K, T = KP * u / L, TP * L / u
        r += (K * de - yaw_coeff * va * va * math.sin(wa * D2R) - r) * dt / T
        psi += r * dt
        out["psi"][k], out["ram"][k], out["u"][k] = psi, ram, u
        out["ve"][k] = ve_w + v_lee * math.cos(h) + cur[0]
        out["vn"][k] = vn_w - v_lee * math.sin(h) + cur[1]
        out["va"][k], out["wa"][k], out["course"][k] = va, wa, course
    ig = np.arange(0, n, 10)  # GNSS at 5 Hz
    tg = t[ig]
    read_t = np.floor(tg / 0.5) * 0.5  # the pilot's status (compass, rudder) at 2 Hz
    ir = np.clip(np.round(read_t / dt).astype(int), 0, n - 1)
    heading = out["psi"][ig] + rng.normal(0, 0.1, len(ig))
    a = {
        "t": tg, "heading": heading,
        "heading_ok": np.ones(len(ig), bool), "vel_ok": np.ones(len(ig), bool),
        "sog": np.hypot(out["ve"][ig], out["vn"][ig]),
        "cog": np.degrees(np.arctan2(out["ve"][ig], out["vn"][ig])) % 360.0,
        "compass": np.round(out["psi"][ir]) % 360.0,
        "compass_age_ms": np.round((tg - read_t) * 1000.0),
        "locked": out["course"][ig], "rudder": np.round(out["ram"][ir]),
        "rpm_set": np.where(tg < 60, 600, 1000), "rpm": np.where(tg < 60, 600, 1000),
        "wind_speed": out["va"][ig] + rng.normal(0, 0.2, len(ig)),
        "wind_angle": (out["wa"][ig] + rng.normal(0, 3.0, len(ig))) % 360.0,
    }
    turned = lambda t0, t1: float(abs(np.interp(t1, t, out["psi"]) - np.interp(t0, t, out["psi"])))
    segs = [("zigzag", 0.0, 60.0, {"deg": 10.0}), ("zigzag", 60.0, 120.0, {"deg": 10.0}),
            ("circle", 120.0, 180.0, {"dir": 1.0, "turned": turned(120.0, 180.0)}),
            ("circle", 180.0, 239.0, {"dir": -1.0, "turned": turned(180.0, 239.0)})]
    return {"t0": 0.0, "t1": 239.0, "segments": segs, "a": a}


@pytest.fixture(scope="module")
def windy():
    return _closed_loop_trial()


def test_leeway_is_not_taken_for_current(windy):
    """In a circle the leeway's sideways drift turns with the wind's angle; its mean (half the
    drift, downwind) is not current."""
    cur = F.fit_current(windy)
    assert cur["leeway_model"] == "sensor"
    assert math.hypot(cur["east_mps"] - 0.05, cur["north_mps"] + 0.15) < 0.03
    assert cur["leeway_per_crosswind"] == pytest.approx(-0.06, abs=0.01)
    old = F.fit_current(windy, leeway=False)  # the fit before: a constant sideways velocity
    assert math.hypot(old["east_mps"] - 0.05, old["north_mps"] + 0.15) > 0.08


def test_t_prime_within_15_percent_in_closed_loop_in_wind(windy):
    cur = F.fit_current(windy)
    n = F.fit_nomoto(windy, F.water_speed(windy, cur), L, gnss_latency_s=0.0)
    assert n["t_prime"] == pytest.approx(TP, rel=0.15)
    assert n["k_prime"] == pytest.approx(KP, rel=0.05)
    # the water speed from the current fit without the leeway biased T' beyond the goal
    old = F.fit_current(windy, leeway=False)
    nb = F.fit_nomoto(windy, F.water_speed(windy, old), L, gnss_latency_s=0.0)
    assert abs(nb["t_prime"] / TP - 1.0) > 0.15
    assert abs(nb["t_prime"] / TP - 1.0) > 2.0 * abs(n["t_prime"] / TP - 1.0)


def test_no_wind_sensor_falls_back_to_a_constant_winds_leeway(windy):
    blind = dict(windy, a={k: v for k, v in windy["a"].items() if k not in ("wind_speed", "wind_angle")})
    cur = F.fit_current(blind)
    assert cur["leeway_model"] == "heading"
    assert "leeway_per_crosswind" not in cur
    # the gusts are not followed, the mean drift is
    assert math.hypot(cur["east_mps"] - 0.05, cur["north_mps"] + 0.15) < 0.04
