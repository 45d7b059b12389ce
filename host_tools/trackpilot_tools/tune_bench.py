"""How well `trackpilot tune` recovers a boat: simulated trials on boats drawn from the robust
bench's spreads (sim/boat_params.json "spread"), the true parameters hidden from the fit, then the
fit's values against them.

Usage: python -m trackpilot_tools.tune_bench N [--first SEED] [--out DIR] [--trial-set KEY=VALUE ...]
Writes DIR/tune_bench.json (one row per boat) and prints the error table.
"""
import argparse
import json
import math
import statistics
import sys
from pathlib import Path

from trackpilot_tools.mpy import ROOT

TRACK = ROOT / "tracks" / "middelburg_loop.csv"


def truth_of(p):
    """The true values the fit should find (the simulator's own parameters)."""
    b, pl = p["boat"], p["pilot"]
    return {"k_prime": b["k_prime"], "t_prime": b["t_prime"], "compass_lag_s": pl["compass_lag_s"],
            "rudder_limit_deg": pl["rudder_limit_deg"], "length_m": b["length_m"]}


def one_boat(seed, out_dir, trial_cfg=None, noise_offset=0):
    """Sail the trial on boat `seed`, fit it; a row of fitted vs true values. noise_offset: the
    simulator's noise seed is seed + noise_offset (0: the bench's own trial; another value: the
    same boat's trial on another day: its own waves, gusts, current walk and sensor noise)."""
    from trackpilot_tools.sim import params as pm
    from trackpilot_tools.sim.runner import SimRun

    spread = pm.load_spread()
    over, flat = pm.draw_spread(seed, spread, pm.load())
    out = Path(out_dir) / ("boat%03d" % seed)
    run = SimRun(TRACK, out, seed=seed + noise_offset, scenario="calm", overrides=over, duration_s=900, trial=True,
                 fw_config={"trial": trial_cfg} if trial_cfg else None)
    run.run()
    row = {"seed": seed, "drawn": flat, "sim_stop": run.stop_reason}
    return fit_boat(row, out, run.p)


def fit_boat(row, out, params, more=()):
    """Fit the trial log in `out` (fw/log) and compare with the simulator's parameters. more:
    folders of the same boat's other trials (tune_bench --noise-offset), pooled with it
    (tune_pool) in the order given, `out`'s last."""
    from trackpilot_tools import logdecode
    from trackpilot_tools import tune_fit as F
    from trackpilot_tools import tune_pool as TP

    truth = truth_of(params)
    row["truth"] = truth
    try:
        files = [f for o in list(more) + [out] for f in sorted((Path(o) / "fw" / "log").glob("*.tpl"))]
        d = logdecode.decode_files_in_order(files)
        fit = TP.fit_trials(d)
        # `out`'s own time axis (its truth.csv) against the pooled log's
        mine = str(sorted((Path(out) / "fw" / "log").glob("*.tpl"))[0])
        shift_s = min(r.t_s for r in d.controls + d.events if r.file == mine)
    except F.TuneError as e:
        row["refused"] = str(e)
        return row
    row["trial_s"] = fit["trial"]["duration_s"]
    n, c, ci = fit["nomoto"], fit["compass"], fit["circle"]
    row["fit"] = {"k_prime": n["k_prime"], "t_prime": n["t_prime"], "compass_lag_s": c["lag_s"],
                  "radius_m": ci["radius_m"], "rudder_deg": ci["rudder_deg"]}
    row["sd"] = {"k_prime": n["k_prime_sd"], "t_prime": n["t_prime_sd"], "compass_lag_s": c["lag_sd_s"],
                 "radius_m": ci["radius_sd_m"]}
    # the minimum radius the pilot really sails: the circle at the rudder it gave
    row["truth"]["rudder_lag_s"] = params["boat"]["rudder_lag_s"]
    row["fit"]["rudder_lag_s"] = n["rudder_lag_s"]
    row["truth"]["radius_m"] = truth["length_m"] / (truth["k_prime"] * ci["rudder_deg"] * math.pi / 180.0)
    row["truth"]["pilot_gain"] = params["pilot"]["kp_rudder_per_deg"]
    row["fit"]["pilot_gain"] = fit["pilot_gain"]["gain"]  # 0.0: not sure
    row["truth"]["pilot_damping_s"] = params["pilot"]["kd_rudder_s"]
    row["fit"]["pilot_damping_s"] = fit["pilot_gain"].get("damping_s", 0.0)
    row["truth"]["pilot_deadband_deg"] = params["pilot"]["deadband_deg"]
    row["fit"]["pilot_deadband_deg"] = fit["pilot_gain"].get("deadband_deg", 0.0)
    row["sd"]["pilot_deadband_deg"] = fit["pilot_gain"].get("deadband_sd_deg", float("inf"))
    row["sd"]["pilot_gain"] = fit["pilot_gain"].get("gain_sd", float("inf"))
    row["refusals"] = fit["problems"]
    row["doubts"] = fit.get("doubts", [])
    _more_truth(row, out, params, fit, shift_s)
    _closed_response_truth(row, params, fit)
    (Path(out) / "tune_config.json").write_text(json.dumps(fit["config"], indent=1))
    return row


def _more_truth(row, out, params, fit, shift_s=0.0):
    """The fitted compass offset and deviation, RPM -> water speed map and current beside what the
    simulator sailed: the offset as the compass showed it over the trial (its drawn offset plus its
    slow drift, against the true heading put through the compass's own lag), the speed from the
    boat's map at each trial RPM, the current averaged over the circles that measure it (it walks)."""
    import csv

    from trackpilot_tools.sim.boat import interp_map

    b, pl = params["boat"], params["pilot"]
    c, sm, cur = fit["compass"], fit["speed_map"], fit["current"]
    f, t = row["fit"], row["truth"]
    f["dev_sin_deg"], f["dev_cos_deg"] = c["dev_sin_deg"], c["dev_cos_deg"]
    t["dev_sin_deg"], t["dev_cos_deg"] = pl.get("compass_dev_sin_deg", 0.0), pl.get("compass_dev_cos_deg", 0.0)
    scale = b.get("speed_map_scale", 1.0)
    f["speed_mps"] = list(sm["speed_mps"])
    t["speed_mps"] = [interp_map(b["rpm_speed_map"], rpm) * scale for rpm in sm["rpm"]]
    f["current_e_mps"], f["current_n_mps"] = cur["east_mps"], cur["north_mps"]
    path = Path(out) / "truth.csv"
    if not path.is_file():
        return
    t0 = fit["trial"]["start_s"] - shift_s
    circles = [(t0 + a, t0 + z) for kind, a, z in fit["trial"]["manoeuvres"] if kind == "circle"]
    off, ce, cn = [], [], []
    lag_s = pl["compass_lag_s"]
    h_lag = None  # the true heading through the compass's own lag: the offset in turns too
    t_prev = None
    for r in csv.DictReader(path.open()):
        ts, h = float(r["t_s"]), float(r["heading_deg"])
        if any(a <= ts <= z for a, z in circles):
            ce.append(float(r["current_e_mps"]))
            cn.append(float(r["current_n_mps"]))
        if h_lag is None:
            h_lag = h
        else:
            a = 1.0 - math.exp(-(ts - t_prev) / lag_s) if lag_s > 0.0 else 1.0
            h_lag = (h_lag + a * ((h - h_lag + 180.0) % 360.0 - 180.0)) % 360.0
        t_prev = ts
        if r["compass_deg"] and t0 <= ts <= t0 + fit["trial"]["duration_s"]:
            hr = math.radians(h_lag)
            dev = t["dev_sin_deg"] * math.sin(hr) + t["dev_cos_deg"] * math.cos(hr)
            off.append((float(r["compass_deg"]) - h_lag - dev + 180.0) % 360.0 - 180.0)
    if off:
        f["offset_deg"], t["offset_deg"] = c["offset_deg"], sum(off) / len(off)
    if ce:
        t["current_e_mps"], t["current_n_mps"] = sum(ce) / len(ce), sum(cn) / len(cn)


STEP_KEYS = ("delay_s", "t63_s", "overshoot", "gain")


def _closed_response_truth(row, params, fit):
    """The closed heading response per RPM as tune fitted it (tune_fit.fit_steps: median over the
    steps it used at that RPM) beside the true pilot on the true boat, stepped by the same course
    changes (the change asked plus the pilot's standing error), held as long, at the boat's true
    water speed for that RPM, read by the same definitions: in quiet water
    (tune_pilot.step_response, truth "steps") and in the boat's steady wind and current from the
    step's start heading (step_response_in_weather, truth "steps_weather"). Neither has the
    trial's waves, gusts or current walk: the comparison says how much of the fitted response is
    the pilot and the boat (docs/COMMISSIONING.md "The closed heading response against the pilot
    alone")."""
    from trackpilot_tools.sim.boat import interp_map
    from trackpilot_tools.tune_pilot import step_response, step_response_in_weather

    b = params["boat"]
    scale = b.get("speed_map_scale", 1.0)
    fit_by, true_by, weather_by = {}, {}, {}
    records = fit["steps"].get("records")
    if records is None:  # a pooled fit: the last trial's steps as asked
        records = [{"rpm": int(c[0]), "step_deg": float(c[1]), "hold_s": float(c[2][-1])}
                   for c in fit["steps"]["_plot"] if len(c[2])]
    for rpm, s in fit["steps"]["by_rpm"].items():
        mine = [r for r in records if int(r["rpm"]) == int(rpm)]
        mine = [r for r in mine if r.get("clean", True)] or mine  # the steps the fit used
        if not mine:
            continue
        u = interp_map(b["rpm_speed_map"], int(rpm)) * scale
        resp = [step_response(params, u, abs(r["step_deg"]), seconds=max(5.0, r["hold_s"])) for r in mine]
        key = str(int(rpm))
        fit_by[key] = {k: s[k] for k in STEP_KEYS}
        true_by[key] = {k: _median_finite([r[k] for r in resp]) for k in STEP_KEYS}
        true_by[key]["speed_mps"] = u
        if all("heading0_deg" in r for r in mine):
            resp = [step_response_in_weather(params, u, r["delta_deg"], r["heading0_deg"],
                                             seconds=max(5.0, r["hold_s"])) for r in mine]
            weather_by[key] = {k: _median_finite([r[k] for r in resp]) for k in STEP_KEYS}
    row["fit"]["steps"], row["truth"]["steps"] = fit_by, true_by
    if weather_by:
        row["truth"]["steps_weather"] = weather_by


def _median_finite(v):
    """The median of the finite values (fit_steps' own aggregate over the steps), NaN if none."""
    v = [x for x in v if math.isfinite(x)]
    return statistics.median(v) if v else float("nan")


def _step_errors(ok, key, truth="steps"):
    """|fitted - true| of one closed-response quantity over every (boat, RPM): relative for the
    times, absolute (a fraction of the step) for the overshoot and the gain. truth: "steps" (the
    pilot alone in quiet water) or "steps_weather" (in the boat's steady wind and current)."""
    e = []
    for r in ok:
        fs, ts = r["fit"].get("steps") or {}, r["truth"].get(truth) or {}
        for rpm in fs:
            f, t = fs[rpm][key], ts.get(rpm, {}).get(key, float("nan"))
            if not (math.isfinite(f) and math.isfinite(t)):
                continue
            e.append(abs(f / t - 1.0) if key.endswith("_s") else abs(f - t))
    return sorted(e)


def table(rows):
    ok = [r for r in rows if "fit" in r]
    lines = ["boats: %d, fitted: %d, refused: %d" % (len(rows), len(ok), len(rows) - len(ok))]
    if not ok:
        return "\n".join(lines)
    def errs(key, rel):
        out = []
        for r in ok:
            f, t = r["fit"][key], r["truth"][key]
            out.append(abs(f - t) / abs(t) if rel else abs(f - t))
        out.sort()
        return out
    for key, rel, goal in (("k_prime", True, 0.15), ("t_prime", True, 0.15), ("radius_m", False, 1.0),
                           ("compass_lag_s", False, 0.15)):
        e = errs(key, rel)
        med = e[len(e) // 2]
        p90 = e[min(len(e) - 1, int(0.9 * len(e)))]
        within = sum(1 for x in e if x <= goal)
        unit = "%" if rel else ""
        k = 100.0 if rel else 1.0
        lines.append("%-14s |error| median %.3g%s, p90 %.3g%s, worst %.3g%s; within %g%s: %d/%d" % (
            key, med * k, unit, p90 * k, unit, e[-1] * k, unit, goal * k, unit, within, len(e)))
    # the rest of what the trial identifies (absolute errors where a share of a small value means
    # nothing: an offset of 0.5 deg, a current of 0.01 m/s)
    for key, goal, unit, fn in (
            ("offset_deg", 1.0, " deg", lambda f, t: abs(f - t)),
            ("dev_sin_deg", 1.0, " deg", lambda f, t: abs(f - t)),
            ("dev_cos_deg", 1.0, " deg", lambda f, t: abs(f - t)),
            ("speed_mps", 0.15, "%", lambda f, t: max(abs(a / b - 1.0) for a, b in zip(f, t))),
            ("current", 0.03, " m/s", None)):
        e = []
        for r in ok:
            f, t = r["fit"], r["truth"]
            if key == "current":
                if "current_e_mps" in t:
                    e.append(math.hypot(f["current_e_mps"] - t["current_e_mps"], f["current_n_mps"] - t["current_n_mps"]))
            elif key in f and key in t:
                e.append(fn(f[key], t[key]))
        if not e:
            continue
        e.sort()
        k = 100.0 if unit == "%" else 1.0
        lines.append("%-14s |error| median %.3g%s, p90 %.3g%s, worst %.3g%s; within %g%s: %d/%d" % (
            key, e[len(e) // 2] * k, unit, e[min(len(e) - 1, int(0.9 * len(e)))] * k, unit, e[-1] * k, unit,
            goal * k, unit, sum(1 for x in e if x <= goal), len(e)))
    sure = [r for r in ok if r["fit"].get("pilot_gain", 0.0) > 0.0]
    if sure:
        e = sorted(abs(r["fit"]["pilot_gain"] / r["truth"]["pilot_gain"] - 1.0) for r in sure)
        lines.append("pilot_gain     |error| median %.3g%%, p90 %.3g%%, worst %.3g%%; within 15%%: %d/%d (sure on %d of %d)" % (
            100 * e[len(e) // 2], 100 * e[min(len(e) - 1, int(0.9 * len(e)))], 100 * e[-1],
            sum(1 for x in e if x <= 0.15), len(e), len(sure), len(ok)))
        cov = sum(1 for r in sure if abs(r["fit"]["pilot_gain"] - r["truth"]["pilot_gain"]) <= 2 * r["sd"]["pilot_gain"])
        lines.append("pilot_gain     within 2 sigma of its stated uncertainty: %d/%d" % (cov, len(sure)))
        e = sorted(abs(r["fit"]["pilot_damping_s"] / r["truth"]["pilot_damping_s"] - 1.0) for r in sure
                   if "pilot_damping_s" in r["truth"])
        if e:
            lines.append("pilot_damping  |error| median %.3g%%, p90 %.3g%%, worst %.3g%%; within 15%%: %d/%d "
                         "(the simulator's default 1.5 s would be within 15%% on %d)" % (
                             100 * e[len(e) // 2], 100 * e[min(len(e) - 1, int(0.9 * len(e)))], 100 * e[-1],
                             sum(1 for x in e if x <= 0.15), len(e),
                             sum(1 for r in sure if abs(1.5 / r["truth"]["pilot_damping_s"] - 1.0) <= 0.15)))
        db = [r for r in sure if "pilot_deadband_deg" in r["truth"]]
        if db:
            e = sorted(abs(r["fit"]["pilot_deadband_deg"] - r["truth"]["pilot_deadband_deg"]) for r in db)
            cov = sum(1 for r in db if abs(r["fit"]["pilot_deadband_deg"] - r["truth"]["pilot_deadband_deg"])
                      <= 2 * r["sd"]["pilot_deadband_deg"])
            lines.append("pilot_deadband |error| median %.2f, p90 %.2f, worst %.2f deg; within 0.5 deg: %d/%d "
                         "(the configured default 1 deg would be on %d); within 2 sigma: %d/%d" % (
                             e[len(e) // 2], e[min(len(e) - 1, int(0.9 * len(e)))], e[-1],
                             sum(1 for x in e if x <= 0.5), len(e),
                             sum(1 for r in db if abs(1.0 - r["truth"]["pilot_deadband_deg"]) <= 0.5), cov, len(db)))
    for truth, label in (("steps", "quiet water"), ("steps_weather", "steady weather")):
        for key, goal in (("t63_s", 0.15), ("delay_s", 0.15), ("overshoot", 0.05), ("gain", 0.05)):
            e = _step_errors(ok, key, truth)
            if not e:
                continue
            rel = key.endswith("_s")
            k, unit = (100.0, "%") if rel else (1.0, " of the step")
            lines.append("step %-9s |error| median %.3g%s, p90 %.3g%s, worst %.3g%s; within %g%s: %d/%d "
                         "(boat x RPM; against the pilot alone in %s)" % (
                             key, e[len(e) // 2] * k, unit, e[min(len(e) - 1, int(0.9 * len(e)))] * k, unit,
                             e[-1] * k, unit, goal * k, unit, sum(1 for x in e if x <= goal), len(e), label))
    cov = []
    for key in ("k_prime", "t_prime", "radius_m", "compass_lag_s"):
        n_in = sum(1 for r in ok if abs(r["fit"][key] - r["truth"][key]) <= 2 * r["sd"][key])
        cov.append("%s %d/%d" % (key, n_in, len(ok)))
    lines.append("within 2 sigma of the stated uncertainty: " + ", ".join(cov))
    dur = [r["trial_s"] for r in ok]
    lines.append("trial duration: %.0f-%.0f s" % (min(dur), max(dur)))
    # is the stated uncertainty honest: |error| <= 2 sigma; and what tune accepts
    cov = sum(1 for r in ok if abs(r["fit"]["t_prime"] - r["truth"]["t_prime"]) <= 2 * r["sd"]["t_prime"])
    acc = [r for r in ok if not r.get("refusals")]
    good = sum(1 for r in acc if abs(r["fit"]["t_prime"] / r["truth"]["t_prime"] - 1) <= 0.15)
    doubt = [r for r in acc if r.get("doubts")]
    good_d = sum(1 for r in doubt if abs(r["fit"]["t_prime"] / r["truth"]["t_prime"] - 1) <= 0.15)
    lines.append("T' within 2 sigma of its stated uncertainty: %d/%d; tune accepted %d, T' within 15 %% "
                 "on %d of them; %d of those with a doubt on the simulated boat (T' within 15 %% on %d)"
                 % (cov, len(ok), len(acc), good, len(doubt), good_d))
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="tune_bench")
    ap.add_argument("n", type=int)
    ap.add_argument("--first", type=int, default=1)
    ap.add_argument("--out", default="tune_bench_out")
    ap.add_argument("--refit", action="store_true",
                    help="fit the trials already sailed in --out again (after a change of the fit)")
    ap.add_argument("--pool", action="append", default=[], metavar="DIR",
                    help="with --refit: pool each boat's trial with its trial in DIR (sailed with --noise-offset)")
    ap.add_argument("--compare", action="store_true",
                    help="sail the accepted boats (tune_refit.json) with the tuned and the default configuration")
    ap.add_argument("--noise-offset", type=int, default=0, metavar="K",
                    help="sail with the noise seed boat + K: the same boats' trials on another day (for pooling)")
    ap.add_argument("--trial-set", action="append", default=[], metavar="KEY=VALUE",
                    help="a key of the firmware's trial section for the sail (e.g. circle_low_turns=1)")
    args = ap.parse_args(argv)
    trial_cfg = {}
    for kv in args.trial_set:
        k, eq, v = kv.partition("=")
        if not eq:
            ap.error("--trial-set wants KEY=VALUE, got %r" % kv)
        trial_cfg[k] = float(v) if "." in v else int(v)
    rows = []
    if args.compare:
        fits = json.loads((Path(args.out) / "tune_refit.json").read_text())
        seeds = [r["seed"] for r in fits if "fit" in r and not r.get("refusals")]
        res = compare_configs(args.out, seeds)
        for name in ("default", "tuned"):
            for k in ("rms_m", "p95_m", "max_m"):
                v = sorted(r[name][k] for r in res if r[name][k] is not None)
                if v:
                    print("%-8s %-6s median %.2f  p90 %.2f  worst %.2f m" % (
                        name, k, v[len(v) // 2], v[min(len(v) - 1, int(0.9 * len(v)))], v[-1]))
        return 0
    if args.refit:
        for d in sorted(Path(args.out).glob("boat[0-9][0-9][0-9]")):
            if not (d / "sim_params.json").is_file() or not list((d / "fw" / "log").glob("*.tpl")):
                continue
            more = [Path(p) / d.name for p in args.pool]
            if not all((m / "fw" / "log").is_dir() for m in more):
                continue
            row = fit_boat({"seed": int(d.name[4:])}, d, json.loads((d / "sim_params.json").read_text()), more)
            rows.append(row)
            print(json.dumps({k: row.get(k) for k in ("seed", "fit", "truth", "refused", "refusals")}), flush=True)
        (Path(args.out) / ("tune_refit_pooled.json" if args.pool else "tune_refit.json")).write_text(json.dumps(rows, indent=1))
        print(table(rows))
        return 0
    Path(args.out).mkdir(parents=True, exist_ok=True)
    for seed in range(args.first, args.first + args.n):
        row = one_boat(seed, args.out, trial_cfg, args.noise_offset)
        rows.append(row)
        print(json.dumps({k: row.get(k) for k in ("seed", "fit", "truth", "refused")}), flush=True)
        (Path(args.out) / "tune_bench.json").write_text(json.dumps(rows, indent=1))
    print(table(rows))
    return 0



def compare_configs(out_dir, seeds):
    """Sail the TRUE boat of each bench boat with tune's configuration and with the defaults
    (los): truth xte RMS / p95 / max of each. python -m trackpilot_tools.tune_bench 0 --compare
    --out DIR (uses DIR/tune_refit.json: the boats tune accepted)."""
    from trackpilot_tools.sim import report
    from trackpilot_tools.sim.runner import SimRun

    rows = []
    for seed in seeds:
        d = Path(out_dir) / ("boat%03d" % seed)
        params = json.loads((d / "sim_params.json").read_text())
        cfg = json.loads((d / "tune_config.json").read_text())
        row = {"seed": seed}
        for name, fw in (("default", {}), ("tuned", cfg)):
            run = SimRun(TRACK, d / ("sail_" + name), seed=seed, params=json.loads(json.dumps(params)),
                         fw_config=fw)
            res = run.run()
            summ = report.summarize_run(res, {"track": str(TRACK), "law": "los", "scenario": "bench", "seed": seed})
            t = summ.get("truth_xte_vs_track") or {}
            row[name] = {k: t.get(k) for k in ("rms_m", "p95_m", "max_m")}
        rows.append(row)
        print(json.dumps(row), flush=True)
    (Path(out_dir) / "tune_compare.json").write_text(json.dumps(rows, indent=1))
    return rows


if __name__ == "__main__":
    sys.exit(main())
