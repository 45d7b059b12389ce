"""The robustness sweep around a fitted boat (`trackpilot tune --sweep N`): N boats drawn around the
fit within its 1-sigma uncertainty, each sailed with the tuned and with the default guidance, on the
robust bench's engine (bench_robust.run_job on Dask), and which of the two to recommend.

What is drawn (per boat, from its seed):
- identified, around the fit (normal, 1 sigma): K', T', the rudder dead time (as the flow lag),
  the compass lag; the pilot's rudder gain when the trial identified it (1 sigma taken as 10 %:
  its error over simulated trials, docs/COMMISSIONING.md), with its ram speed as measured, and
  its damping (log-normal, KD_LOG_SD: identified only roughly) and its deadband (normal, its
  stated 1 sigma); the compass offset/deviation, the RPM -> speed map and the current as fitted;
- not identified by the trial (the ST2000+'s ram speed unless measured,
  key delay, the compass's noise, wind, waves, GNSS latency): drawn from the robust bench's spreads
  (sim/boat_params.json),
  so the sweep also covers what the trial cannot see; but the pilot only where its simulated
  course steps on the drawn boat reach 63 % within T63_TOLERANCE of the times measured in the
  trial (rejection: up to MAX_TRIES draws, else the closest), so every boat responds like the
  measured one.
Each boat sails one straight of the robust bench (1, 2, 3 m/s over the boats, 5 m start offset).
"""
import json
import math
import random

from . import bench_robust as BR

SPEEDS = BR.GOAL_SPEEDS
T63_TOLERANCE = 0.2
MAX_TRIES = 60
KD_LOG_SD = 0.35  # the pilot's damping drawn around the fitted one: x0.70..1.42 at 1 sigma


def measured_t63(fit):
    """[(water speed m/s, time to 63 % s)] of the trial's course steps, per RPM."""
    sm = fit["speed_map"]
    speed = {int(r): u for r, u in zip(sm["rpm"], sm["speed_mps"])}
    out = []
    for rpm, s in fit["steps"]["by_rpm"].items():
        if int(rpm) in speed and s.get("t63_s") is not None and math.isfinite(s["t63_s"]):
            out.append((speed[int(rpm)], s["t63_s"]))
    return out


def draw_boats(fit, n, seed0=1):
    """[(seed, full simulator parameters, flat drawn values)] for n boats around the fit."""
    from .tune_pilot import step_metrics

    want = measured_t63(fit)
    out = []
    for seed in range(seed0, seed0 + n):
        best = None
        for attempt in range(MAX_TRIES):
            p, flat = _draw_one(fit, seed, attempt)
            err = max([abs(step_metrics(p, u)[0] / t63 - 1.0) for u, t63 in want] or [0.0])
            if best is None or err < best[0]:
                best = (err, p, flat)
            if err <= T63_TOLERANCE:
                break
        err, p, flat = best
        flat["t63_mismatch"] = round(err, 3)
        out.append((seed, p, flat))
    return out


def _draw_one(fit, seed, attempt):
    """One candidate boat: the fit's values within their uncertainty (the same for every attempt of
    a seed), the rest from the spreads (new for every attempt)."""
    from .sim import params as P
    from .sim import scenarios

    nom, comp, cur = fit["nomoto"], fit["compass"], fit["current"]
    sp = fit["sim_params"]
    p = P.load()
    P.merge(p, scenarios.PRESETS["calm"])
    over, flat = P.draw_spread(seed * 1000 + attempt, P.load_spread(), p)
    P.merge(p, over)
    P.merge(p, json.loads(json.dumps(sp)))
    rng = random.Random(1000003 * seed + 17)

    def around(v, sd, lo):
        sd = sd if (sd is not None and math.isfinite(sd)) else 0.0
        return max(lo, rng.gauss(v, sd))

    p["boat"]["k_prime"] = around(nom["k_prime"], nom["k_prime_sd"], 0.05)
    p["boat"]["t_prime"] = around(nom["t_prime"], nom["t_prime_sd"], 0.05)
    p["boat"]["rudder_lag_s"] = around(nom["rudder_lag_s"], nom["rudder_lag_sd_s"], 0.0)
    p["boat"]["speed_map_scale"] = 1.0
    p["pilot"]["compass_lag_s"] = around(comp["lag_s"], comp["lag_sd_s"], 0.05)
    kp = sp.get("pilot", {}).get("kp_rudder_per_deg")
    if kp:
        p["pilot"]["kp_rudder_per_deg"] = around(kp, 0.1 * kp, 0.2)
        flat["pilot.kp_rudder_per_deg"] = p["pilot"]["kp_rudder_per_deg"]
    kd = sp.get("pilot", {}).get("kd_rudder_s")
    if kd:
        # identified only roughly (|error| median 12 %, p90 56 % on 40 simulated trials): wide
        p["pilot"]["kd_rudder_s"] = min(5.0, max(0.1, kd * math.exp(rng.gauss(0.0, KD_LOG_SD))))
        flat["pilot.kd_rudder_s"] = p["pilot"]["kd_rudder_s"]
    db = sp.get("pilot", {}).get("deadband_deg")
    if db is not None:
        # identified roughly too: its stated 1 sigma is at least the method's spread (0.45 deg)
        p["pilot"]["deadband_deg"] = min(3.5, max(0.25, rng.gauss(db, fit["pilot_gain"]["deadband_sd_deg"])))
        flat["pilot.deadband_deg"] = p["pilot"]["deadband_deg"]
    p["water"]["current_mps"] = cur["speed_mps"]
    p["water"]["current_dir_deg"] = cur["to_deg"]
    for key, val in (("boat.k_prime", p["boat"]["k_prime"]), ("boat.t_prime", p["boat"]["t_prime"]),
                     ("boat.rudder_lag_s", p["boat"]["rudder_lag_s"]),
                     ("pilot.compass_lag_s", p["pilot"]["compass_lag_s"])):
        flat[key] = val
    for key in ("boat.speed_map_scale", "water.current_mps", "water.current_dir_deg",
                "pilot.compass_offset_deg", "pilot.compass_dev_sin_deg", "pilot.compass_dev_cos_deg"):
        flat.pop(key, None)
    return p, flat


def make_jobs(boats, configs, timeout=300.0):
    """One job per boat and configuration: bench_robust.run_job's format with the boat's parameters."""
    jobs = []
    for seed, p, flat in boats:
        case = "straight_%.1f" % SPEEDS[seed % len(SPEEDS)]
        for name, cfg in configs.items():
            jobs.append({"case": case, "law": "los", "boat": seed, "params": p, "flat": flat,
                         "fw": cfg, "timeout": timeout, "config": name})
    return jobs


def run(fit, configs, n, seed0=1, workers=1, scheduler=None, progress=None):
    """Sail the sweep; {config name: [result]} (bench_robust.run_job's results)."""
    jobs = make_jobs(draw_boats(fit, n, seed0), configs)
    out = {name: [] for name in configs}
    for job, res in BR.run_on_dask(jobs, BR.run_job, scheduler, workers):
        out[job["config"]].append(res)
        if progress:
            progress(job, res)
    return out


def summarise(results):
    """Per configuration: median / p90 / worst of the settled RMS and the max |xte| (truth), the
    runs that oscillate and the failures."""
    summ = {}
    for name, rs in results.items():
        s = {"runs": len(rs)}
        for metric in ("settled_rms_m", "max_m"):
            d = BR.distribution(rs, metric)
            s[metric] = {k: d[k] for k in ("median", "p90", "worst", "worst_boat")} if d else None
        s["oscillating"] = sum(1 for r in rs if (r["metrics"].get("osc") or {}).get("oscillates"))
        s["failures"] = sum(1 for r in rs if r["metrics"].get("failure"))
        summ[name] = s
    return summ


def recommend(summ, tuned="tuned", default="default"):
    """(name, why): the tuned configuration only where it is not worse than the default on the
    sweep: no more failures or oscillating runs, and median and p90 settled RMS no larger."""
    t, d = summ[tuned], summ[default]
    worse = []
    if t["failures"] > d["failures"]:
        worse.append("more failures (%d vs %d)" % (t["failures"], d["failures"]))
    if t["oscillating"] > d["oscillating"]:
        worse.append("more oscillating runs (%d vs %d)" % (t["oscillating"], d["oscillating"]))
    for q in ("median", "p90"):
        a, b = (t["settled_rms_m"] or {}).get(q), (d["settled_rms_m"] or {}).get(q)
        if a is None or b is None:
            worse.append("no settled RMS to compare")
            break
        if a > b:
            worse.append("%s settled RMS %.2f m vs %.2f m" % (q, a, b))
    if worse:
        return default, "the tuned guidance is worse on the sweep: " + "; ".join(worse)
    return tuned, "the tuned guidance is no worse on the sweep in failures, oscillations, median and p90"


def table_md(summ):
    lines = ["| configuration | runs | settled RMS median / p90 / worst m | max xte median / p90 / worst m "
             "| oscillating | failures |", "|---|---|---|---|---|---|"]
    for name, s in summ.items():
        def trio(d):
            return "%.2f / %.2f / %.2f" % (d["median"], d["p90"], d["worst"]) if d else "-"
        lines.append("| %s | %d | %s | %s | %d | %d |" % (name, s["runs"], trio(s["settled_rms_m"]),
                                                          trio(s["max_m"]), s["oscillating"], s["failures"]))
    return "\n".join(lines)
