"""The simulated pilot's closed heading response, to match it with the measured one.

The trial measures the closed response of ST2000+ + boat to course steps (time to 63 %) at two
speeds, not the ST2000+'s own settings (gain, damping, deadband, ram speed: its control law is not
published). tune's sweep draws those from the robust bench's spreads and keeps only pilots whose
simulated steps on the drawn boat reach 63 % within a tolerance of the measured times (tune_sweep.py).
The same quiet-water pilot, with the fitted settings, is checked for a limit cycle after a large
course change at speeds the trial did not sail (tune_fit.pilot_limit_cycles).
"""


def _quiet(params, speed_mps, course_deg, heading_deg=0.0, steady_weather=False):
    """The simulator's pilot in Auto, its course course_deg, on the simulator's boat heading
    heading_deg at a held speed, in quiet water: no wind, waves or current, a compass without
    noise, drift, offset or deviation. steady_weather: the drawn wind (its mean, no gusts or
    wander) and current (no walk) kept, still no waves. Returns (pilot, boat, pilot parameters)."""
    from .bench_robust import _NoBus
    from .sim import stcodec
    from .sim.boat import Boat, Environment
    from .sim.randproc import component_rng
    from .sim.st2000_sim import ST2000Sim

    water = dict(params["water"], current_walk_sd_mps=0.0, wave_yaw_rms_deg=0.0)
    wind = dict(params["wind"], gust_sd_frac=0.0, dir_sd_deg=0.0)
    if not steady_weather:
        water["current_mps"] = 0.0
        wind["speed_mps"] = 0.0
    env = Environment(water, wind, component_rng(1, "environment"))
    pp = dict(params["pilot"], compass_noise_deg=0.0, compass_drift_sd_deg=0.0, compass_offset_deg=0.0,
              compass_dev_sin_deg=0.0, compass_dev_cos_deg=0.0)
    boat = Boat(params["boat"], env, 0.0, 0.0, heading_deg, u_mps=speed_mps, rpm=0.0)
    boat.p = dict(params["boat"], surge_tau_s=1e9)  # the speed held (the trial's steps run at a steady RPM)
    pil = ST2000Sim(pp, component_rng(1, "pilot"), None, _NoBus())
    pil.mode = stcodec.MODE_AUTO
    pil.course_deg = course_deg % 360.0
    return pil, boat, pp


def _sail(pil, boat, speed_mps, seconds, dt):
    """Step the pilot and the boat for `seconds`, the speed held; yields the true heading."""
    for _ in range(int(round(seconds / dt))):
        rud = pil.control_step(dt, boat.heading_deg())
        boat.step(dt, rud, 0.0)
        boat.u_mps = speed_mps
        yield boat.psi_deg


def _read_step(pil, boat, pp, speed_mps, step_deg, seconds, dt):
    """The heading's response to a course change of step_deg (signed; the pilot's course already
    changed), by tune_fit.fit_steps' definitions: times from the keystroke (the pilot's key delay
    in them), levels of |step_deg| the change's way."""
    delay = pp.get("key_delay_ms", 100) / 1000.0
    sign = 1.0 if step_deg > 0 else -1.0
    psi0 = boat.psi_deg
    t10 = t63 = float("nan")
    peak = 0.0
    tail = []
    for k, psi in enumerate(_sail(pil, boat, speed_mps, seconds, dt)):
        y = sign * (((psi - psi0 + 180.0) % 360.0) - 180.0) / abs(step_deg)
        t = (k + 1) * dt + delay
        peak = max(peak, y)
        if t10 != t10 and y >= 0.1:
            t10 = t
        if t63 != t63 and y >= 0.63:
            t63 = t
        if t >= seconds + delay - 3.0:
            tail.append(y)
    return {"delay_s": t10, "t63_s": t63, "overshoot": peak - 1.0,
            "gain": sum(tail) / len(tail) if tail else float("nan")}


def step_response(params, speed_mps, step_deg=10.0, seconds=25.0, dt=0.05):
    """The simulator's pilot on the simulator's boat, calm, no noise, after a course step of
    step_deg at t = 0: what tune_fit.fit_steps measures on the water, by the same definitions
    (times from the keystroke, the pilot's key delay in them): delay_s (10 %), t63_s, overshoot
    (peak / step - 1) and gain (the mean change over the last 3 s / step). NaN for a level never
    reached."""
    pil, boat, pp = _quiet(params, speed_mps, step_deg)
    return _read_step(pil, boat, pp, speed_mps, step_deg, seconds, dt)


def step_response_in_weather(params, speed_mps, delta_deg, heading_deg, seconds=25.0, settle_s=120.0, dt=0.05):
    """As step_response, but in the drawn boat's steady weather (_quiet's steady_weather), the
    pilot first holding heading_deg for settle_s (its trim takes the wind's moment, its deadband
    leaves what it leaves), then the course changed by delta_deg (signed). The levels are of the
    step the pilot was asked to make, the change plus its standing error then, as
    tune_fit.fit_steps reads them on the water."""
    pil, boat, pp = _quiet(params, speed_mps, heading_deg, heading_deg, steady_weather=True)
    for _ in _sail(pil, boat, speed_mps, settle_s, dt):
        pass
    standing = ((pil.course_deg - pil.compass_deg + 180.0) % 360.0) - 180.0
    eff = delta_deg + standing
    if eff * delta_deg <= 0.0 or abs(eff) < 1.0:
        eff = delta_deg
    pil.course_deg = (pil.course_deg + delta_deg) % 360.0
    out = _read_step(pil, boat, pp, speed_mps, eff, seconds, dt)
    out["standing_deg"] = standing
    return out


def step_metrics(params, speed_mps, step_deg=10.0, seconds=25.0, dt=0.05):
    """The simulator's pilot on the simulator's boat, calm, no noise: (t63 s, overshoot fraction)
    after a course step of step_deg at t = 0 (plus the pilot's key delay); inf when it never
    reaches 63 %."""
    r = step_response(params, speed_mps, step_deg, seconds, dt)
    return (r["t63_s"] if r["t63_s"] == r["t63_s"] else float("inf")), r["overshoot"]


# a heading swing of this many degrees peak to peak, late after a course change, is a limit cycle
# (in quiet water the fitted pilots that hold stayed under 8 deg; those that cycled swung 44-112)
LIMIT_CYCLE_PP_DEG = 15.0


def swing_after_step(params, speed_mps, step_deg=40.0, seconds=150.0, dt=0.05):
    """The simulator's pilot holding a course step_deg off its heading on the simulator's boat,
    quiet water (no wind, waves, current, compass noise or drift): the heading's peak-to-peak
    swing over the last 60 s (deg). A large course change saturates the ram of a pilot whose gain
    is high for its compass lag, and some never come out of it (docs/COMMISSIONING.md)."""
    pil, boat, _ = _quiet(params, speed_mps, step_deg)
    lo, hi = float("inf"), float("-inf")
    for k, psi in enumerate(_sail(pil, boat, speed_mps, seconds, dt)):
        if (k + 1) * dt >= seconds - 60.0:
            h = ((psi - step_deg + 180.0) % 360.0) - 180.0
            lo, hi = min(lo, h), max(hi, h)
    return round(hi - lo, 2)


def limit_cycles(params, speeds_mps=(1.0, 2.0, 3.0), step_deg=40.0):
    """[(speed m/s, swing deg)] where the pilot, as fitted, does not come out of a step_deg course
    change (swing_after_step >= LIMIT_CYCLE_PP_DEG)."""
    out = []
    for u in speeds_mps:
        pp = swing_after_step(params, u, step_deg)
        if pp >= LIMIT_CYCLE_PP_DEG:
            out.append((u, pp))
    return out
