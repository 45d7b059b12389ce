"""`trackpilot bench` (`make bench`): issue 5's benchmark in one run, through the full firmware in the
simulator (bytes in, bytes out). Writes OUT/report.md (summary table and goals on top) and
OUT/report.json, plus the per-run folders.

- Tracking accuracy: the scenarios of BOAT_AND_BENCHMARK.md, the `seed` law and the project's best
  law (`los`) side by side over several seeds (this module).
- Compute and memory, unix-port figures (bench_perf.py).
- The fault matrix (bench_faults.py).

On Dask distributed (a LocalCluster of `--jobs` worker processes, default 2, or `--scheduler`); a run whose firmware stops answering is killed after
`--run-timeout` wall seconds and counted as a failure."""
import json
import math
import os
import statistics
import sys
import time
from collections import deque
from pathlib import Path

from . import bench_faults, bench_perf
from .errors import UserError

R_TURN_M = 5.0 / (1.1 * math.radians(30.0))  # the simulated boat's turning radius (8.7 m)


def cases(quick=False):
    from .sim import benchtracks as bt

    if quick:  # the test's subset: one of each kind
        return [c for c in cases(False) if c["name"] in (
            "straight_2.0mps_cur0.2", "zigzag_90", "uturn_20m", "robust_rtk_float_20s")]
    out = []
    speeds = (1.0, 2.0) if quick else (0.5, 1.0, 2.0, 3.0)
    currents = (0.0, 0.2) if quick else (0.0, 0.1, 0.2, 0.3)
    for v in speeds:
        for c in currents:
            out.append({"name": "straight_%.1fmps_cur%.1f" % (v, c), "track": (bt.straight, v),
                        "set": {"sim": {"start_offset_m": 5.0},
                                "water": {"current_mps": c, "current_dir_deg": 90.0}}})
    for a in ((60, 90) if quick else (30, 60, 90)):
        out.append({"name": "zigzag_%d" % a, "track": (bt.zigzag, a), "set": {}})
    for s in ((20,) if quick else (10, 20, 30)):
        out.append({"name": "uturn_%dm" % s, "track": (bt.uturn, s), "set": {}})
    if not quick:
        out.append({"name": "lawnmower", "track": (bt.lawnmower,),
                    "set": {"water": {"current_mps": 0.2, "current_dir_deg": 45.0}}})
    out.append({"name": "mooring_wind5", "track": (bt.mooring,),
                "set": {"wind": {"speed_mps": 5.0, "dir_deg": 0.0}}})
    rob = [("rtk_float_20s", {}, ["rtk_float@40:20"]),
           ("model_K_plus50", {"boat": {"k_prime": 1.65}}, []),
           ("model_K_minus50", {"boat": {"k_prime": 0.55}}, []),
           ("model_T_plus50", {"boat": {"t_prime": 0.72}}, []),
           ("rtk_single_8s", {}, ["rtk_single@40:8"]),
           ("deadband_3deg", {"pilot": {"deadband_deg": 3.0}}, []),
           ("latency_300ms", {"gnss": {"latency_ms": [300, 300]}}, []),
           ("seatalk_noise", {}, ["st_noise@20:60"]),
           ("pilot_hang_keys", {}, ["pilot_hang_keys@40"])]
    for name, st, faults in rob:
        base = {"sim": {"start_offset_m": 5.0}, "water": {"current_mps": 0.2, "current_dir_deg": 90.0}}
        for sec, body in st.items():
            base.setdefault(sec, {}).update(body)
        out.append({"name": "robust_" + name, "track": (bt.straight, 2.0), "set": base, "faults": faults})
    if not quick:
        out += gnss_cases()
    return out


def gnss_cases():
    """GNSS as it is on a canal (docs/MODES.md "GNSS gaps"): the issue's 300 m canal at 1.5 m/s in a
    0.2 m/s cross current, a bridge at 60 s (float 6 s, no GNSS for D s, single 5 s, float 9 s,
    compass bent 6 deg); then long float after it, and receivers that send in another order, without
    NAV-EOE, at 10 Hz. A 60 s gap is past the hold (40 s): its defined reaction is ALARM (the pilot
    keeps its course), so that case passes when it ends in ALARM, not when it finishes."""
    from .sim import benchtracks as bt
    from .sim import scenarios

    def case(name, faults, gnss=None):
        st = {"water": {"current_mps": 0.2, "current_dir_deg": 90.0},
              "gnss": dict(scenarios.BRIDGE_GNSS["gnss"], **(gnss or {}))}
        return {"name": "gnss_" + name, "track": (bt.straight, 1.5, 300.0), "set": st, "faults": faults}

    out = [case("bridge_%ds" % d, scenarios.bridge_faults(60.0, d)) for d in (5, 15, 30, 60)]
    out[-1]["expect_alarm"] = True
    for f in (10, 60, 120):  # float episodes after the 15 s gap and its reacquisition (95 s on)
        out.append(case("bridge_15s_float%ds" % f,
                        scenarios.bridge_faults(60.0, 15.0) + ["rtk_float@95:%d" % f]))
    out.append(case("bridge_15s_10hz_pvt_first_no_eoe", scenarios.bridge_faults(60.0, 15.0),
                    {"rate_hz": 10, "order": "pvt_first", "eoe": False}))
    out.append(case("no_eoe_valset_unanswered", [], {"eoe": False, "order": "pvt_first",
                                                      "answer_valset": False}))
    return out




def geo_min_m(geom, radius_m=R_TURN_M):
    """The cross-track error (against the track as given) that a boat turning no tighter than
    radius_m cannot avoid at the worst corner of the track: a circle tangent to both legs
    (track.corner_deviation_m: R (1 - cos(theta/2))); two corners nearer than the sum of their
    tangent lengths (a U-turn between lines closer than 2R) are taken as one reversal sailed on a
    circle of radius R centred between the lines, which overshoots each line by R - spacing/2.
    This is the tangent-circle figure: a path that first swings wide can trade some of it against
    the straight before, so it is an upper estimate of the true minimax."""
    from trackpilot.nav.track import corner_deviation_m, corner_tangent_m

    worst = 0.0
    turns = []
    for i in range(1, len(geom.legs)):
        a, b = geom.bearing_deg(i - 1), geom.bearing_deg(i)
        turns.append((b - a + 180.0) % 360.0 - 180.0)
    for i, t in enumerate(turns):
        if abs(t) <= 10.0:
            continue
        worst = max(worst, corner_deviation_m(t, radius_m))
        if i + 1 < len(turns) and abs(turns[i + 1]) > 10.0 and turns[i + 1] * t > 0:
            between = geom.legs[i + 1][4]  # the short leg joining the two corners
            if between < corner_tangent_m(t, radius_m) + corner_tangent_m(turns[i + 1], radius_m) \
                    and abs(t + turns[i + 1]) > 170.0:
                worst = max(worst, radius_m - between / 2.0)
    return worst


def _overshoot(rows, geom):
    """Largest xte to the outside of each turn within 40 m after the corner."""
    worst = 0.0
    for i in range(1, len(geom.legs)):
        a = geom.bearing_deg(i - 1)
        b = geom.bearing_deg(i)
        turn = (b - a + 180.0) % 360.0 - 180.0
        if abs(turn) <= 10.0:
            continue
        s0 = geom.legs[i][5]
        outside = [-math.copysign(1.0, turn) * x for _, x, s, _, _ in rows if s0 < s < s0 + 40.0]
        if outside:
            worst = max(worst, max(outside))
    return worst


def _fw_path_metrics(out, r):
    """From the firmware's log: xte against the path it planned (path_xte_m), on straights and in
    turns (classified by the record's position along the track as given), and the number of
    course changes it made the pilot do (changes of the pilot's locked course, AUTO only)."""
    from .logdecode import decode_files, session_key
    from .sim.truth import TrackGeom, stats

    files = sorted(Path(out, "fw", "log").glob("*.tpl"), key=session_key)
    if not files:
        return {}
    d = decode_files([str(f) for f in files])
    wps = [(w.lat_e7 * 1e-7, w.lon_e7 * 1e-7) for w in r.track.waypoints]
    g = TrackGeom(r.frame, wps)
    st, tu = [], []
    changes = 0
    last = None
    for c in d.controls:
        if c.mode != 1 or not c.pos_valid:
            last = None
            continue
        lat = (c.lat_e7 * 100 + c.lat_hp) * 1e-9
        lon = (c.lon_e7 * 100 + c.lon_hp) * 1e-9
        e, n = r.frame.from_latlon(lat, lon)
        _, _, track_m = g.update(e, n)
        (st if g.is_straight(track_m) else tu).append(c.path_xte_m)
        if last is not None and c.locked_deg != last:
            changes += 1
        last = c.locked_deg
    rnd = lambda dd: {k: round(v, 3) for k, v in dd.items()}  # noqa: E731
    return {"path_straights": rnd(stats(st)), "path_turns": rnd(stats(tu)), "course_changes": changes}


def run_one(job):
    from .sim.runner import SimRun
    from .sim import report
    from .sim.truth import stats

    case, law, seed, track_path, out, timeout = job
    r = SimRun(track_path, out, seed=seed, law=law, scenario="calm", faults=case.get("faults", ()),
               overrides=case["set"], duration_s=case.get("duration_s"))
    dog = bench_perf.watchdog(r, timeout)
    res = r.run()
    dog.cancel()
    summ = report.summarize_run(res, {"case": case["name"], "law": law, "seed": seed})
    report.write_summary(summ, out)
    rows = res["truth_xte"]
    fw = summ["firmware_log"] or {}
    engaged = rows[0][0] if rows else None
    # after settling: from where |xte| < 0.5 m held for 10 s (BOAT_AND_BENCHMARK.md)
    k0 = None
    start = None
    for k, (t, x, _, _, _) in enumerate(rows):
        if abs(x) < 0.5:
            if start is None:
                start = k
            elif t - rows[start][0] >= 10.0:
                k0 = start
                break
        else:
            start = None
    settled = rows[k0:] if k0 is not None else []
    settled_straight = stats([x for _, x, _, _, st in settled if st])
    # the slow part (leg speed <= 0.5 m/s): the mooring goal
    geom = res["geom"]
    slow = []
    for t, x, s, _, _ in rows:
        leg = max(i for i, lg in enumerate(geom.legs) if lg[5] <= s + 1e-9) if geom.legs else 0
        if r.track.legs[min(leg, len(r.track.legs) - 1)].speed_mps <= 0.5:
            slow.append(x)
    # rudder travel in AUTO (truth)
    travel = 0.0
    prev = None
    for row in r.truth_rows:
        if row[22].startswith("AUTO"):
            rd = float(row[10])
            if prev is not None:
                travel += abs(rd - prev)
            prev = rd
        else:
            prev = None
    try:
        fwp = _fw_path_metrics(out, r)
    except Exception as e:  # noqa: BLE001 - a log the decoder cannot read is reported, not fatal
        fwp = {"error": str(e)}
    failure = (not summ["finished"]) or k0 is None or any(abs(x) > 5.0 for _, x, _, _, _ in settled)
    modes = [v for _, n, v in res["outputs"] if n == "mode"]
    if case.get("expect_alarm"):  # a gap past the hold: ALARM is the defined reaction, not a failure
        failure = "ALARM" not in modes or summ["finished"]
    return {
        "case": case["name"], "law": law, "seed": seed,
        "finished": summ["finished"],
        "completion_s": (summ["finished_at_s"] - engaged) if summ["finished"] and engaged is not None else None,
        "xte": summ["truth_xte_vs_track"], "straights": summ["truth_xte_straights"],
        "turns": summ["truth_xte_turns"], "settling_m": summ["settling_distance_m"],
        "overshoot_m": round(_overshoot(rows, geom), 3),
        "settled_straights": {k: round(v, 3) for k, v in settled_straight.items()},
        "slow_max_m": round(max(abs(x) for x in slow), 3) if slow else None,
        "path_straights": fwp.get("path_straights"), "path_turns": fwp.get("path_turns"),
        "course_changes": fwp.get("course_changes"), "rudder_travel_deg": round(travel, 1),
        "keystrokes": fw.get("keystrokes"),
        "geo_min_m": round(geo_min_m(geom), 2),
        "failure": failure,
        "failure_why": None if not failure else (
            "firmware stopped answering (killed: %s)" % dog.fired if dog.fired else
            "expected ALARM, modes %s" % modes if case.get("expect_alarm") else
            "not finished (%s)" % summ["stop_reason"] if not summ["finished"] else
            "never settled" if k0 is None else "|xte| > 5 m after settling"),
        "sim_speed_x": summ["sim_speed_x"], "stop": summ["stop_reason"], "timed_out": dog.fired,
    }


def _agg(runs, path):
    vals = []
    for r in runs:
        d = r
        for k in path:
            d = d.get(k) if isinstance(d, dict) else None
        if d is not None:
            vals.append(d)
    return vals


def _mean(v, nd=3):
    return round(statistics.mean(v), nd) if v else None


def _max(v, nd=3):
    return round(max(v), nd) if v else None


def aggregate(results):
    table = {}
    for r in results:
        table.setdefault((r["case"], r["law"]), []).append(r)
    out = []
    for (case, law), runs in sorted(table.items()):
        a = lambda *p: _agg(runs, p)  # noqa: E731
        out.append({
            "case": case, "law": law, "seeds": len(runs),
            "straight_rms_m": _mean(a("settled_straights", "rms_m")),
            "straight_p95_m": _mean(a("settled_straights", "p95_m")),
            "straight_max_m": _max(a("settled_straights", "max_m")),
            "straight_all_rms_m": _mean(a("straights", "rms_m")),
            "turn_rms_m": _mean(a("turns", "rms_m")),
            "turn_p95_m": _mean(a("turns", "p95_m")),
            "turn_max_m": _max(a("turns", "max_m")),
            "geo_min_m": _max(a("geo_min_m"), 2),
            "path_straight_rms_m": _mean(a("path_straights", "rms_m")),
            "path_straight_max_m": _max(a("path_straights", "max_m")),
            "path_turn_rms_m": _mean(a("path_turns", "rms_m")),
            "path_turn_p95_m": _mean(a("path_turns", "p95_m")),
            "path_turn_max_m": _max(a("path_turns", "max_m")),
            "p95_m": _mean(a("xte", "p95_m")),
            "max_m": _max(a("xte", "max_m")),
            "within_1p5_pct": _mean(a("xte", "within_1p5_pct"), 1),
            "settling_m": _mean(a("settling_m"), 1),
            "overshoot_m": _max(a("overshoot_m")),
            "slow_max_m": _max(a("slow_max_m")),
            "keystrokes": _mean(a("keystrokes"), 1),
            "course_changes": _mean(a("course_changes"), 1),
            "rudder_travel_deg": _mean(a("rudder_travel_deg"), 0),
            "completion_s": _mean(a("completion_s"), 1),
            "failures": sum(1 for r in runs if r["failure"]),
            "failure_why": sorted({r["failure_why"] for r in runs if r["failure_why"]}),
        })
    return out


RATIO_KEYS = ("straight_rms_m", "straight_max_m", "straight_all_rms_m", "turn_max_m", "path_turn_max_m", "p95_m",
              "within_1p5_pct", "keystrokes")


def ratios(rows, best="los"):
    """best/seed per scenario for the main figures (below 1: the best law is better)."""
    by = {(r["case"], r["law"]): r for r in rows}
    out = {}
    for (case, law), r in by.items():
        s = by.get((case, "seed"))
        if law != best or s is None:
            continue
        out[case] = {k: (round(r[k] / s[k], 2) if r[k] is not None and s[k] else None) for k in RATIO_KEYS}
    return out


# ---------------------------------------------------------------------- the report
STRAIGHT_GOAL_CASES = lambda c: c.startswith("straight_") and any(  # noqa: E731
    c.startswith("straight_%.1fmps" % v) for v in (1.0, 2.0, 3.0)) and float(c.split("cur")[1]) <= 0.2 + 1e-9
TURN_CASES = lambda c: c.startswith("zigzag_") or c.startswith("uturn_")  # noqa: E731


def _f(x, fmt="%.2f"):
    return "-" if x is None else (fmt % x if isinstance(x, (int, float)) else str(x))


def _status(ok):
    return "n/a" if ok is None else ("met" if ok else "**not met**")


def goals(rows, ratio, perf, faults, best="los"):
    """Issue 5's goals with where we stand: [(goal, figure, met?)]."""
    def sel(law, pred):
        return [r for r in rows if r["law"] == law and pred(r["case"])]

    out = []
    def worst(rs, key):
        v = [(r[key], r["case"]) for r in rs if r[key] is not None]
        return max(v) if v else (None, "-")

    st = sel(best, STRAIGHT_GOAL_CASES)
    rms = [r["straight_rms_m"] for r in st if r["straight_rms_m"] is not None]
    fails = sum(r["failures"] for r in st)
    w_rms, w_rms_case = worst(st, "straight_rms_m")
    w_mx, w_mx_case = worst(st, "straight_max_m")
    out.append(("Straights 1-3 m/s, current <= 0.2 m/s, best law: RMS |XTE| <= 0.15 m (after settling)",
                "worst case %s m (%s), mean %s m over %d cases%s" % (
                    _f(w_rms, "%.3f"), w_rms_case, _f(_mean(rms), "%.3f"), len(st), ", %d failed runs" % fails if fails else ""),
                (w_rms <= 0.15 and not fails) if rms else None))
    out.append(("... max |XTE| <= 1.0 m after settling", "worst %s m (%s)" % (_f(w_mx), w_mx_case),
                (w_mx <= 1.0 and not fails) if w_mx is not None else None))
    tu = sel(best, TURN_CASES)
    pm = [r["path_turn_max_m"] for r in tu if r["path_turn_max_m"] is not None]
    w_pm, w_pm_case = worst(tu, "path_turn_max_m")
    per = ", ".join("%s %s" % (r["case"], _f(r["path_turn_max_m"])) for r in tu)
    out.append(("Turns (zig-zag 30/60/90, U-turns incl. 20 m): max <= 1.0 m against the planned path",
                "worst %s m (%s); per case: %s (the firmware's own path_xte, from its log)" % (_f(w_pm), w_pm_case, per),
                w_pm <= 1.0 if pm else None))
    gaps = [(r["case"], r["turn_max_m"], r["geo_min_m"]) for r in tu if r["turn_max_m"] is not None and r["geo_min_m"] is not None]
    worst = max(gaps, key=lambda g: g[1] - g[2]) if gaps else None
    u20 = next((r for r in tu if r["case"] == "uturn_20m"), None)
    out.append(("... against the track as given: within 0.5 m of the geometric minimum (R = %.1f m)" % R_TURN_M,
                ("U-turn 20 m: %s m vs minimum %s m; worst excess %s m (%s)" % (
                    _f(u20 and u20["turn_max_m"]), _f(u20 and u20["geo_min_m"]), _f(worst[1] - worst[2]), worst[0]))
                if worst else "-", (worst[1] - worst[2] <= 0.5) if worst else None))
    mo = next((r for r in rows if r["law"] == best and r["case"] == "mooring_wind5"), None)
    out.append(("Mooring at <= 0.5 m/s (5 m/s cross wind): max <= 1.5 m",
                "max %s m on the legs at <= 0.5 m/s%s" % (_f(mo and mo["slow_max_m"], "%.3f"),
                                                         ", %d failed runs" % mo["failures"] if mo and mo["failures"] else ""),
                (mo["slow_max_m"] is not None and mo["slow_max_m"] <= 1.5 and not mo["failures"]) if mo else None))
    rr = [v["straight_all_rms_m"] for v in ratio.values() if v.get("straight_all_rms_m")]
    out.append(("The seed law reproduced as the baseline; ratio best/seed per scenario",
                "stated per scenario below; median ratio of the straight RMS (whole run) %s" % _f(statistics.median(rr) if rr else None),
                True if rr else None))
    esp = perf.get("esp32_equiv", {})
    est = ("ESP32-equivalent of the .mpy build: minimum heap %s KB, peak live %s KB (%s); code frozen into flash: "
           "about %s KB (estimate)" % (
               _f(esp.get("min_heap_B") and esp["min_heap_B"] / 1024, "%.0f"),
               _f(esp.get("peak_B") and esp["peak_B"] / 1024, "%.0f"), esp.get("method_short", "-"),
               _f(esp.get("min_heap_code_frozen_B") and esp["min_heap_code_frozen_B"] / 1024, "%.0f")))
    met = (esp["min_heap_B"] <= 110 * 1024) if esp.get("min_heap_B") else None
    fz = [r for r in (perf.get("frozen_heap") or {}).get("runs", []) if r["track"] == "mission" and r.get("esp32_heap_B")]
    if fz:
        # the frozen 32-bit build with the frozen code's records in flash, as on the board: a
        # measurement, where the line after it is an estimate from the .mpy build
        r = fz[0]
        est = "frozen 32-bit build at 110 KB (the frozen code's %d B of records in flash, as on a board): %s%s; %s" % (
            r["records_B"], "completes" if r["ok"] else "fails (%s)" % r.get("stop"),
            ", peak live %d KB without the records" % ((r["peak_heap_B"] - r["records_B"]) // 1024)
            if r.get("peak_heap_B") else "", est)
        met = bool(r["ok"])
    out.append(("One-hour mission, code included, fits an ESP32 heap without PSRAM (~110 KB)", est, met))
    pr = perf.get("profile") or {}
    gcp = perf.get("mission", {}).get("gc_max_pause_us")
    tot = (pr.get("cpu_us_max") or 0) + (gcp or 0)
    out.append(("Bytes allocated per epoch small enough that GC does not stall the 5 Hz loop",
                "%s B/epoch mean (max %s); GC pause max %s ms, worst epoch %s ms (unix port)" % (
                    _f(pr.get("alloc_B_mean"), "%.0f"), _f(pr.get("alloc_B_max"), "%d"), _f(gcp and gcp / 1000.0, "%.1f"),
                    _f(pr.get("cpu_us_max") and pr["cpu_us_max"] / 1000.0, "%.1f")),
                (tot < 100000) if pr and gcp is not None else None))
    sp = (perf.get("sim_speed_alone") or {}).get("sim_speed_x")
    sp2 = perf.get("mission", {}).get("sim_speed_x")
    out.append((">= 100x real time", "%sx for one run alone (example track); %sx for the profiled mission with "
                "another run beside it on the 2 cores" % (_f(sp, "%.0f"), _f(sp2, "%.0f")),
                sp >= 100 if sp else None))
    return out


def summary_table(rows, ratio, perf, faults, best="los"):
    def sel(law, pred):
        return [r for r in rows if r["law"] == law and pred(r["case"])]

    def worst(law, pred, key, agg=max):
        v = [r[key] for r in sel(law, pred) if r[key] is not None]
        return agg(v) if v else None

    allc = lambda c: True  # noqa: E731
    rob = lambda c: c.startswith("robust_")  # noqa: E731
    lines = ["| figure | `%s` (best) | `seed` (baseline) |" % best, "|---|---|---|"]
    for label, pred, key, agg in (
            ("straights 1-3 m/s, cur <= 0.2: RMS after settling, worst case (m)", STRAIGHT_GOAL_CASES, "straight_rms_m", max),
            ("straights 1-3 m/s, cur <= 0.2: max after settling (m)", STRAIGHT_GOAL_CASES, "straight_max_m", max),
            ("all straight cases incl. 0.5 m/s and 0.3 m/s current: worst RMS after settling (m)", lambda c: c.startswith("straight_"), "straight_rms_m", max),
            ("straights 1-3 m/s, cur <= 0.2: RMS over the whole straight incl. settling, worst (m)", STRAIGHT_GOAL_CASES, "straight_all_rms_m", max),
            ("turns: max vs planned path, worst (m)", TURN_CASES, "path_turn_max_m", max),
            ("turns: max vs track as given, worst (m)", TURN_CASES, "turn_max_m", max),
            ("U-turn 20 m: max vs track as given (m; minimum %.2f)" % geo_min_uturn(rows), lambda c: c == "uturn_20m", "turn_max_m", max),
            ("mooring, legs <= 0.5 m/s: max (m)", lambda c: c == "mooring_wind5", "slow_max_m", max),
            ("robustness cases: worst p95 (m)", rob, "p95_m", max),
            ("time within 1.5 m, mean over cases (%)", allc, "within_1p5_pct", _mean),
            ("keystrokes per run, mean", allc, "keystrokes", _mean)):
        lines.append("| %s | %s | %s |" % (label, _f(worst(best, pred, key, agg)), _f(worst("seed", pred, key, agg))))
    nb = sum(r["failures"] for r in rows if r["law"] == best)
    ns = sum(r["failures"] for r in rows if r["law"] == "seed")
    nr = sum(r["seeds"] for r in rows if r["law"] == best)
    lines.append("| failed runs (of %d per law) | %d | %d |" % (nr, nb, ns))
    lines += ["", "| compute and memory (MicroPython unix port, 64-bit, unless marked) | value |", "|---|---|"]
    pr = perf.get("profile") or {}
    mi = perf.get("mission") or {}
    esp = perf.get("esp32_equiv") or {}
    ps = perf.get("parser") or {}
    lines += [
        "| CPU per 5 Hz control epoch (parse + navigate + guide + SeaTalk + log), median / p99 / max | %s / %s / %s us |" % (
            _f(pr.get("cpu_us_median"), "%d"), _f(pr.get("cpu_us_p99"), "%d"), _f(pr.get("cpu_us_max"), "%d")),
        "| bytes allocated per epoch, median / mean / max | %s / %s / %s B |" % (
            _f(pr.get("alloc_B_median"), "%d"), _f(pr.get("alloc_B_mean"), "%.0f"), _f(pr.get("alloc_B_max"), "%d")),
        "| smallest -X heapsize for the %s mission (.mpy) | %s B (%s KB) |" % (
            _f(mi.get("sim_s") and mi["sim_s"] / 60.0, "%.0f min"), _f(perf.get("min_heap_B"), "%d"),
            _f(perf.get("min_heap_B") and perf["min_heap_B"] / 1024.0, "%.0f")),
        "| peak live heap in that run | %s B |" % _f(perf.get("min_heap_run", {}).get("peak_heap_B"), "%d"),
        "| **ESP32-equivalent** minimum heap / peak live heap | %s / %s KB (%s) |" % (
            _f(esp.get("min_heap_B") and esp["min_heap_B"] / 1024.0, "%.0f"), _f(esp.get("peak_B") and esp["peak_B"] / 1024.0, "%.0f"),
            esp.get("method_short", "-")),
        "| GC: collections / max pause (mission, default heap) | %s / %s us |" % (_f(mi.get("gc_runs"), "%d"), _f(mi.get("gc_max_pause_us"), "%d")),
        "| log bytes per hour | %s B |" % _f(perf.get("log_bytes_per_hour"), "%d"),
        "| simulation speed, one run alone / the mission beside another run | %sx / %sx real time |" % (
            _f((perf.get("sim_speed_alone") or {}).get("sim_speed_x"), "%.0f"), _f(mi.get("sim_speed_x"), "%.0f")),
        "| GNSS parser throughput, MicroPython unix vs pyubx2 (CPython) | %s vs %s B/s: ratio %s |" % (
            _f(ps.get("micropython_unix_bytes_per_s"), "%d"), _f(ps.get("pyubx2_cpython_bytes_per_s"), "%d"),
            _f(ps.get("ratio_micropython_over_pyubx2"))),
        "| ... NMEA part vs pynmeagps (CPython) | ratio %s |" % _f(ps.get("ratio_micropython_over_pynmeagps")),
    ]
    ok = sum(1 for f in faults if f["reaction_ok"])
    done = sum(1 for f in faults if f["finished"])
    bad = [f["name"] for f in faults if not f["reaction_ok"]]
    lines += ["", "| fault matrix | value |", "|---|---|",
              "| defined reaction happened | %d of %d%s |" % (ok, len(faults), (": not for " + ", ".join(bad)) if bad else ""),
              "| track completed | %d of %d |" % (done, len(faults))]
    return lines


def geo_min_uturn(rows):
    r = next((r for r in rows if r["case"] == "uturn_20m"), None)
    return r["geo_min_m"] if r and r["geo_min_m"] is not None else float("nan")


COLS = ("case", "law", "seeds", "straight_rms_m", "straight_p95_m", "straight_max_m", "straight_all_rms_m", "turn_rms_m", "turn_p95_m",
        "turn_max_m", "geo_min_m", "path_straight_rms_m", "path_turn_rms_m", "path_turn_max_m", "p95_m",
        "within_1p5_pct", "settling_m", "overshoot_m", "keystrokes", "course_changes", "rudder_travel_deg",
        "completion_s", "failures")


def write_report(out, rows, results, ratio, perf, faults, meta):
    data = {"meta": meta, "goals": [{"goal": g, "where_we_stand": w, "met": m} for g, w, m in goals(rows, ratio, perf, faults)],
            "accuracy": {"summary": rows, "ratio_best_over_seed": ratio, "runs": results},
            "compute_memory": perf, "fault_matrix": faults}
    Path(out, "report.json").write_text(json.dumps(data, indent=2))
    L = ["# trackpilot bench%s" % (" (--quick)" if meta["quick"] else ""), "",
         "%s; seeds %d; %d accuracy runs, %d fault runs, %d mission runs; wall %.0f s with %d workers on %d cores." % (
             meta["date"], meta["seeds"], len(results), len(faults), meta["mission_runs"], meta["wall_s"], meta["jobs"],
             os.cpu_count() or 0),
         "", "## Summary", ""]
    L += summary_table(rows, ratio, perf, faults)
    L += ["", "## Goals (issue 5) and where we stand", "", "| goal | where we stand | |", "|---|---|---|"]
    for g, w, m in goals(rows, ratio, perf, faults):
        L.append("| %s | %s | %s |" % (g, w, _status(m)))
    L += ["", "## Tracking accuracy", "",
          "Every case with both laws (`seed` = the baseline of BOAT_AND_BENCHMARK.md, `los` = the project's best), "
          "%d seed(s) each, through the full firmware (sim_main under the unix port, bytes in and out). " % meta["seeds"],
          "Truth |XTE| of the boat's reference point, AUTO only. `straight_*`: on straights (more than 15 m from a "
          "corner turning > 10 deg) after settling (|xte| < 0.5 m held for 10 s), mean over seeds of RMS/p95, max of "
          "max. `straight_all_rms_m`: on straights over the whole run in AUTO (settling included; defined also when "
          "a run never settles). `turn_*`: in turns, against the track as given; `geo_min_m`: the smallest max |XTE| at the worst "
          "corner that a boat turning no tighter than R = %.1f m can reach (tangent circle, R (1 - cos(theta/2)); "
          "a U-turn tighter than 2R: R - spacing/2), an upper estimate of the true minimax. `path_*`: the firmware's "
          "own xte against the path it planned (rounded corners), from its log. `p95_m`, `within_1p5_pct`: the whole run in AUTO. "
          "Settling distance: sailed from engaging until |xte| < 0.5 m for 10 s. Overshoot: largest xte to the outside "
          "within 40 m after a corner. Course changes: changes of the pilot's locked course (firmware log). Rudder "
          "travel: sum of |rudder change| in AUTO (truth). Failure: not finished, never settled, or |xte| > 5 m after "
          "settling." % R_TURN_M, ""]
    L.append("| " + " | ".join(COLS) + " |")
    L.append("|" + "---|" * len(COLS))
    for r in rows:
        L.append("| " + " | ".join(_f(r[c], "%g") for c in COLS) + " |")
    why = [(r["case"], r["law"], r["failure_why"]) for r in rows if r["failure_why"]]
    if why:
        L += ["", "Failures: " + "; ".join("%s/%s: %s" % (c, l, ", ".join(w)) for c, l, w in why)]
    L += ["", "### Ratio best/seed per scenario (below 1: `los` better)", "",
          "| case | " + " | ".join(RATIO_KEYS) + " |", "|" + "---|" * (len(RATIO_KEYS) + 1)]
    for case, v in sorted(ratio.items()):
        L.append("| %s | %s |" % (case, " | ".join(_f(v[k]) for k in RATIO_KEYS)))
    L += ["", "## Compute and memory (MicroPython unix port)", ""] + perf_section(perf)
    L += ["", "## Fault matrix", "", bench_faults.__doc__.split("\n\n", 1)[1].strip(), "",
          "| fault | defined reaction | happened | detect (s) | recover (s) | max XTE (m) | completed | modes after | note |",
          "|---|---|---|---|---|---|---|---|---|"]
    for f in faults:
        L.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            f["fault"], f["expected"], "yes" if f["reaction_ok"] else "**no**", _f(f["detect_s"]), _f(f["recover_s"]),
            _f(f["max_xte_m"]), "yes" if f["finished"] else "**no**", " > ".join(f["modes"]), f["note"]))
    L += ["", "## Left out", ""] + ["- " + x for x in meta["left_out"]]
    Path(out, "report.md").write_text("\n".join(L) + "\n")


def perf_section(perf):
    pr = perf.get("profile") or {}
    mi = perf.get("mission") or {}
    esp = perf.get("esp32_equiv") or {}
    fp = perf.get("footprint") or {}
    L = ["Mission: %s, `current` scenario, law `los`, %s s simulated, firmware loaded from the .mpy files "
         "`trackpilot deploy --dry-run` builds (plus simio, wiring_sim and sim_main compiled the same way; "
         "`%s`)." % (perf.get("mission_track"), _f(mi.get("sim_s"), "%.0f"), perf.get("mpy_dir")), "",
         "- **CPU per control epoch** (`sim_main --profile`: `ticks_us` around the GNSS feed + `control_step`, "
         "summed over the feeds of one epoch; %s epochs): median %s us, p99 %s us, max %s us, mean %s us. "
         "Wall time inside the process: the max includes preemption by the other benchmark worker." % (
             _f(pr.get("epochs"), "%d"), _f(pr.get("cpu_us_median"), "%d"), _f(pr.get("cpu_us_p99"), "%d"),
             _f(pr.get("cpu_us_max"), "%d"), _f(pr.get("cpu_us_mean"), "%.0f")),
         "- **Bytes allocated per epoch** (`gc.mem_alloc()` delta with the collector disabled over the same "
         "window): median %s B, p99 %s B, max %s B, mean %s B (unix port: a float is a 32 B block here, 16 B "
         "on the ESP32)." % (_f(pr.get("alloc_B_median"), "%d"), _f(pr.get("alloc_B_p99"), "%d"),
                             _f(pr.get("alloc_B_max"), "%d"), _f(pr.get("alloc_B_mean"), "%.0f")),
         "- **GC** (the app collects once a second between epochs): %s collections, max pause %s us; peak live "
         "heap after a collection %s B (default heap)." % (_f(mi.get("gc_runs"), "%d"), _f(mi.get("gc_max_pause_us"), "%d"),
                                                        _f(mi.get("peak_heap_B"), "%d")),
         "- **Smallest -X heapsize** with which the mission completes: %s B, bisection to %s B (%d probes: %s). "
         "Peak live heap in that run: %s B." % (
             _f(perf.get("min_heap_B"), "%d"), _f(perf.get("bisect_resolution_B"), "%d"), len(perf.get("bisect_probes", [])),
             ", ".join("%d %s" % (p["heap"], "ok" if p["ok"] else "fails") for p in perf.get("bisect_probes", [])),
             _f(perf.get("min_heap_run", {}).get("peak_heap_B"), "%d")),
         "- **ESP32-equivalent**: %s" % esp.get("method", "-"),
         "  - of the ESP32-equivalent minimum heap, %s B is the firmware's code loaded from .mpy (bytecode, "
         "constants, function objects: measured under the 32-bit port). Frozen into the firmware image "
         "(firmware/manifest.py) the code stays in flash: the heap would then need about %s B (an estimate: "
         "the same minimum less the code, not measured)." % (_f(esp.get("code_B"), "%d"),
                                                            _f(esp.get("min_heap_code_frozen_B"), "%d")),
         "  - footprint (code + App + track + %s GNSS epochs through the control step), unix port 64-bit: code %s B, "
         "built %s B, peak %s B; WebAssembly port (32-bit): %s" % (
             _f((fp.get("unix64") or {}).get("epochs"), "%d"), _f((fp.get("unix64") or {}).get("code_B"), "%d"),
             _f((fp.get("unix64") or {}).get("app_built_B"), "%d"), _f((fp.get("unix64") or {}).get("peak_B"), "%d"),
             ("code %s B, built %s B, peak %s B" % tuple(_f(fp["wasm32"].get(k), "%d") for k in ("code_B", "app_built_B", "peak_B")))
             if (fp.get("wasm32") or {}).get("peak_B") else (fp.get("wasm32") or {}).get("error", "-")),
         "- **Log bytes per hour**: %s B (%s B in %s file(s) over %s s simulated)." % (
             _f(perf.get("log_bytes_per_hour"), "%d"), _f(mi.get("log_bytes"), "%d"), _f(mi.get("log_files"), "%d"),
             _f(mi.get("sim_s"), "%.0f")),
         "- **Simulation speed** (simulated s per wall s, the whole loop: simulator + firmware + pipe): one run alone "
         "%sx (%s, %s s simulated in %s s); the profiled mission %sx (%s s wall, %s lockstep steps, the other worker "
         "busy beside it); accuracy runs (two at a time): mean %sx." % (
             _f((perf.get("sim_speed_alone") or {}).get("sim_speed_x"), "%.0f"), (perf.get("sim_speed_alone") or {}).get("track"),
             _f((perf.get("sim_speed_alone") or {}).get("sim_s"), "%.0f"), _f((perf.get("sim_speed_alone") or {}).get("wall_s"), "%.1f"),
             _f(mi.get("sim_speed_x"), "%.0f"), _f(mi.get("wall_s"), "%.1f"),
             _f(mi.get("steps"), "%d"), _f(perf.get("accuracy_sim_speed_mean"), "%.0f"))]
    L += bench_perf.frozen_heap_lines(perf.get("frozen_heap"))
    ps = perf.get("parser") or {}
    L.append("- **GNSS parser throughput** on one recorded stream (the simulator's F9P, %s epochs of UBX "
             "NAV-RELPOSNED/HPPOSLLH/PVT + NMEA GGA/RMC, %s B; best of 3): trackpilot.devices.gnss under the unix port "
             "(.mpy) %s B/s (%s epochs/s); pyubx2 %s on CPython %s B/s (NMEA via pynmeagps): ratio %s. NMEA "
             "sentences alone (%s B): trackpilot.devices.gnss %s B/s, pynmeagps %s B/s: ratio %s." % (
                 _f(ps.get("epochs"), "%d"), _f(ps.get("stream_bytes"), "%d"), _f(ps.get("micropython_unix_bytes_per_s"), "%d"),
                 _f(ps.get("micropython_unix_epochs_per_s"), "%.0f"), perf.get("pyubx2_version", ""),
                 _f(ps.get("pyubx2_cpython_bytes_per_s"), "%d"), _f(ps.get("ratio_micropython_over_pyubx2")),
                 _f(ps.get("nmea_bytes"), "%d"), _f(ps.get("micropython_unix_nmea_bytes_per_s"), "%d"),
                 _f(ps.get("pynmeagps_cpython_bytes_per_s"), "%d"), _f(ps.get("ratio_micropython_over_pynmeagps"))))
    return L


# ---------------------------------------------------------------------- the run
def add_parser(p):
    p.add_argument("--out", default="bench_out")
    p.add_argument("--seeds", type=int, default=None, help="seeds per case and law (default 3, --quick 1)")
    p.add_argument("--quick", action="store_true",
                   help="a small subset: 4 cases, 2 faults, a 2.5-minute mission, coarse heap bisection (for tests)")
    p.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 2), help="worker processes (default 2)")
    p.add_argument("--laws", default="seed,los")
    p.add_argument("--only", help="accuracy: run only cases whose name contains this")
    p.add_argument("--no-perf", action="store_true", help="skip compute and memory")
    p.add_argument("--no-faults", action="store_true", help="skip the fault matrix")
    p.add_argument("--run-timeout", type=float, default=240.0,
                   help="wall seconds after which a run's firmware is killed (counted as a failure); "
                        "a run without lockstep progress for 20 s is killed at once")
    g = p.add_argument_group("robustness over random boats (docs/BENCHMARK_ROBUST.md)")
    g.add_argument("--robust", type=int, metavar="N",
                   help="run the robustness benchmark on N random boats instead (Dask distributed)")
    g.add_argument("--robust-seed", type=int, default=1, metavar="S", help="first boat seed (default 1)")
    g.add_argument("--robust-cases", metavar="A,B", help="cases (default all; with --quick the 1-3 m/s straights, "
                   "one per boat)")
    g.add_argument("--robust-one", type=int, metavar="BOAT", help="rerun one sample alone: boat seed (with --case, --laws)")
    g.add_argument("--case", default="straight_2.0", help="the case for --robust-one")
    g.add_argument("--fw-set", action="append", metavar="SEC.KEY=V",
                   help="firmware configuration override for every run (e.g. guidance.los_lookahead_gain=3)")
    g.add_argument("--scheduler", metavar="tcp://HOST:8786",
                   help="a running Dask scheduler (default: a LocalCluster of --jobs workers)")
    p.set_defaults(func=run)


def _misc_perf(job):
    """Parser throughput and the unix/wasm32 footprint (one worker)."""
    out, lib, mission, stream, allow_install = job
    res = {"parser": bench_perf.parser_throughput(out, lib, stream)}
    res["footprint"] = bench_perf.footprint(out, lib, mission, stream, log=lambda *a: None, install=allow_install)
    return res


def _esp32_equiv(perf):
    fp = perf.get("footprint") or {}
    u, w = fp.get("unix64") or {}, fp.get("wasm32") or {}
    mh = perf.get("min_heap_B")
    pk = (perf.get("min_heap_run") or {}).get("peak_heap_B")
    if u.get("peak_B") and w.get("peak_B"):
        k = w["peak_B"] / u["peak_B"]
        return {"factor": round(k, 3), "min_heap_B": int(mh * k) if mh else None, "peak_B": int(pk * k) if pk else None,
                "code_B": w.get("code_B"),
                "min_heap_code_frozen_B": int(mh * k - w["code_B"]) if mh and w.get("code_B") else None,
                "method_short": "x%.2f, measured: wasm32 / unix64 footprint" % k,
                "method": ("the unix-port figures x %.3f, the ratio of the same footprint measured with the same .mpy "
                           "files under MicroPython's WebAssembly port (%s %s, 32-bit: 4-byte words and 16-byte GC "
                           "blocks as on the ESP32, floats boxed in one block on both) and under the 64-bit unix port. "
                           "Not an ESP32 measurement: the ESP32 port's own modules, its float32 and the network stack "
                           "(Wi-Fi, NTRIP sockets, which the simulation does not allocate) differ; the ratio "
                           "covers code, the App's objects and buffers, and the control step's steady state."
                           % (k, bench_perf.WASM_PKG, bench_perf.WASM_VERSION))}
    lo = {"factor_range": [0.5, 1.0], "min_heap_B": int(mh * 0.5) if mh else None, "peak_B": int(pk * 0.5) if pk else None,
          "method_short": "lower bound x0.5 (no 32-bit port to measure)",
          "method": "no 32-bit MicroPython available (node/npm for the WebAssembly port): between x0.5 (every "
                    "object made of words) and x1.0 (all raw bytes) of the unix-port figures; the lower bound is shown."}
    lo["min_heap_upper_B"] = mh
    return lo


class _Submitter:
    """submit(fn, job) on a Dask client: one task per job, never cached (pure=False), retried once
    if it raises (a worker that dies has its task rescheduled by the scheduler)."""

    def __init__(self, client):
        self.client = client

    def submit(self, fn, job):
        return self.client.submit(fn, job, pure=False, retries=1)


def run(args):
    """The benchmark into a fresh temporary folder, renamed to --out when it has finished (an
    interrupted run leaves OUT.partial/ and the older OUT untouched; outdir.py)."""
    import math

    from .outdir import fresh_output

    if args.seeds is not None and args.seeds < 1:
        raise UserError("--seeds must be at least 1")
    if args.jobs < 1:
        raise UserError("--jobs must be at least 1 worker")
    if not (math.isfinite(args.run_timeout) and args.run_timeout > 0):
        raise UserError("--run-timeout must be seconds > 0")
    if args.robust_seed < 1:
        raise UserError("--robust-seed S: the first boat, 1.. (boat 0 is the nominal boat, always sailed)")
    if args.robust is not None or args.robust_one is not None:
        from . import bench_robust

        if args.robust is not None and args.robust < 1:
            raise UserError("--robust N: N must be at least 1 boat")
        if args.robust_one is not None and args.robust_one < 0:
            raise UserError("--robust-one B: B is a boat of the sweep, 1.. (0: the nominal boat)")
        return bench_robust.run(args)

    final = Path(args.out).resolve()
    try:
        with fresh_output(final) as tmp:
            head, wall = _run(args, tmp)
            _repoint(tmp, final)
    except KeyboardInterrupt:
        print("\ninterrupted: the partial output is in %s.partial/ (see PARTIAL.txt there); "
              "%s/ is unchanged" % (final, final), file=sys.stderr)
        raise
    print(head)
    print("report: %s, %s (wall %.0f s)" % (final / "report.md", final / "report.json", wall))
    return 0


def _repoint(tmp, final):
    """The report names its files by absolute path: point them at the final folder."""
    for p in list(tmp.rglob("*.md")) + list(tmp.rglob("*.json")) + list(tmp.rglob("*.csv")):
        text = p.read_text()
        if str(tmp) in text:
            p.write_text(text.replace(str(tmp), str(final)))


def _run(args, out):
    from .sim import benchtracks as bt
    from .sim import scenarios

    t_start = time.perf_counter()
    quick = args.quick
    seeds = args.seeds or (1 if quick else 3)
    (out / "tracks").mkdir(parents=True, exist_ok=True)

    def log(msg):
        print("[%4.0f s] %s" % (time.perf_counter() - t_start, msg), flush=True)

    # --- accuracy jobs
    acc = []
    for case in cases(quick):
        if args.only and args.only not in case["name"]:
            continue
        fn, *fa = case["track"]
        tp = str(out / "tracks" / (case["name"] + ".csv"))
        fn(tp, *fa)
        for law in args.laws.split(","):
            for seed in range(1, seeds + 1):
                acc.append((case, law, seed, tp, str(out / "runs" / ("%s_%s_s%d" % (case["name"], law, seed))),
                            args.run_timeout))
    # the long ones first (slow straights), so the two workers finish together
    acc.sort(key=lambda j: (0 if "0.5mps" in j[0]["name"] or "mooring" in j[0]["name"] else 1))
    # --- fault jobs
    names, missing = bench_faults.fault_list()
    if quick:
        names = ["pilot_key_minus10", "rtk_single"]
    ftrack = str(out / "tracks" / "faults_uturn20.csv")
    bt.uturn(ftrack, 20, length_m=200.0)
    fjobs = [] if args.no_faults else [
        {"fault": n, "track": ftrack, "out": str(out / "faults" / n), "timeout": args.run_timeout} for n in names]
    # --- compute and memory
    perf = {}
    pdir = out / "perf"
    queue = deque()
    if not args.no_perf:
        pdir.mkdir(parents=True, exist_ok=True)
        lib = bench_perf.build_mpy(pdir / "mpy")
        if quick:
            mission = bt.straight(str(pdir / "mission.csv"), 2.0, 300.0)
            perf["mission_track"] = "straight 300 m at 2 m/s (--quick)"
        else:
            mission = bench_perf.mission_track(str(pdir / "mission.csv"))
            perf["mission_track"] = "tracks/middelburg_loop.csv sailed 3 times, speeds x0.88 (a little over one hour)"
        perf["mpy_dir"] = str(lib)
        wrap = bench_perf.write_wrapper(pdir / "sim_main_mpy.py", lib)
        wrap_prof = bench_perf.write_wrapper(pdir / "sim_main_mpy_profile.py", lib, profile=True)
        stream, _, _ = bench_perf.gnss_stream(pdir, 60 if quick else 600)
        queue.append(("mission", bench_perf.run_mission,
                      {"track": mission, "out": str(pdir / "mission"), "wrapper": wrap_prof, "heap": None,
                       "timeout": 900}))
        queue.append(("misc", _misc_perf, (str(pdir), str(lib), mission, str(stream), not quick)))
        if quick:
            perf["frozen_heap"] = {"skipped": "not with --quick (it builds the frozen interpreter)"}
        else:
            queue.append(("frozen", bench_perf.frozen_heap,
                          {"out": str(pdir / "frozen"), "heaps": [256 * 1024], "esp32_heap_B": 110 * 1024,
                           "timeout": 900,
                           "tracks": [("tracks/middelburg_loop.csv", str(bench_perf.ROOT / "tracks" / "middelburg_loop.csv")),
                                      ("mission", mission)]}))
    for j in fjobs:
        queue.append(("fault", bench_faults.run_fault, j))
    for j in acc:
        queue.append(("acc", run_one, j))
    log("%d accuracy runs, %d fault runs, compute/memory %s; %d workers" % (
        len(acc), len(fjobs), "off" if args.no_perf else "on", args.jobs))

    bis = None
    resolution = 32768 if quick else 8192
    results, faults, mission_runs = [], [], 0
    inflight = {}
    from dask.distributed import wait

    from .bench_robust import dask_client

    client, cluster = dask_client(args.scheduler, args.jobs)
    ex = _Submitter(client)
    try:
        while queue or inflight or (bis is not None and not bis.done):
            while len(inflight) < args.jobs:
                h = bis.next() if bis is not None else None
                if h is not None:
                    job = {"track": mission, "out": str(pdir / ("heap_%d" % h)), "wrapper": wrap, "heap": h,
                           "timeout": 900}
                    inflight[ex.submit(bench_perf.run_mission, job)] = ("heap", h)
                    continue
                if queue:
                    tag, fn, job = queue.popleft()
                    inflight[ex.submit(fn, job)] = (tag, job)
                    continue
                break
            if not inflight:
                break
            done, _ = wait(list(inflight), return_when="FIRST_COMPLETED")
            for fut in done:
                tag, job = inflight.pop(fut)
                try:
                    res = fut.result()
                except Exception as e:  # noqa: BLE001 - a crashed run is a finding, not the end
                    res = {"error": "%s: %s" % (type(e).__name__, e)}
                    log("%s run failed: %s" % (tag, res["error"]))
                if tag == "acc":
                    if "error" in res:
                        case, law, seed = job[0], job[1], job[2]
                        res = {"case": case["name"], "law": law, "seed": seed, "finished": False, "failure": True,
                               "failure_why": res["error"], "xte": {}, "straights": {}, "turns": {},
                               "settled_straights": {}, "overshoot_m": None, "geo_min_m": None}
                    results.append(res)
                    if len(results) % 20 == 0:
                        log("accuracy %d/%d" % (len(results), len(acc)))
                elif tag == "fault":
                    if "error" in res:
                        res = {"name": job["fault"], "fault": job["fault"], "expected": bench_faults.expected_text(job["fault"]),
                               "reaction_ok": False, "detect_s": None, "recover_s": None, "max_xte_m": None,
                               "finished": False, "modes": [], "note": res["error"]}
                    faults.append(res)
                elif tag == "mission":
                    mission_runs += 1
                    perf["mission"] = {k: v for k, v in res.items() if k != "profile"}
                    perf["profile"] = res.get("profile")
                    if res.get("log_bytes") and res.get("sim_s"):
                        perf["log_bytes_per_hour"] = int(res["log_bytes"] * 3600.0 / res["sim_s"])
                    pk = res.get("peak_heap_B") or 300000
                    bis = bench_perf.HeapBisect(int(pk * 0.9) // 1024 * 1024, int(pk * 1.5) // 1024 * 1024, resolution)
                    log("mission: %s, %.0f s simulated in %.0f s; bisecting the heap from %d..%d B" % (
                        "ok" if res.get("ok") else "FAILED", res.get("sim_s", 0), res.get("wall_s", 0), bis.lo, bis.hi))
                elif tag == "heap":
                    mission_runs += 1
                    if "error" in res:
                        res = {"heap": job, "ok": False, "stop": res["error"]}
                    bis.report(res)
                    log("heap %d B: %s" % (job, "ok" if res.get("ok") else "fails (%s)" % res.get("stop")))
                elif tag == "misc":
                    perf.update(res)
                elif tag == "frozen":
                    perf["frozen_heap"] = res
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    if not args.no_perf:  # simulation speed of one run alone (nothing else running): the example track
        from .mpy import ROOT
        from .sim.runner import SimRun

        r = SimRun(ROOT / "tracks" / "middelburg_loop.csv", pdir / "speed_alone", seed=1, law="los", scenario="calm",
                   duration_s=120.0 if quick else None)
        res = r.run()
        perf["sim_speed_alone"] = {"track": "tracks/middelburg_loop.csv (calm, los, firmware from source as `make sim`)",
                                   "sim_s": round(res["sim_s"], 1), "wall_s": round(res["wall_s"], 2),
                                   "sim_speed_x": round(res["speedup"], 1) if res["speedup"] else None,
                                   "steps": res["steps"]}
        log("sim speed alone: %.0fx" % (res["speedup"] or 0))
    if bis is not None:
        perf["min_heap_B"] = bis.best["heap"] if bis.best else None
        perf["min_heap_run"] = {k: v for k, v in (bis.best or {}).items() if k != "profile"}
        perf["bisect_probes"] = bis.probes
        perf["bisect_resolution_B"] = resolution
    if perf:
        perf["esp32_equiv"] = _esp32_equiv(perf)
        try:
            import pyubx2

            perf["pyubx2_version"] = pyubx2.version if isinstance(getattr(pyubx2, "version", None), str) else ""
        except ImportError:
            pass
    sp = [r["sim_speed_x"] for r in results if r.get("sim_speed_x")]
    perf["accuracy_sim_speed_mean"] = _mean(sp, 1)
    results.sort(key=lambda r: (r["case"], r["law"], r["seed"]))
    faults.sort(key=lambda f: list(scenarios.FAULTS).index(f["name"]) if f["name"] in scenarios.FAULTS else 99)
    rows = aggregate(results)
    ratio = ratios(rows)
    wall = time.perf_counter() - t_start
    left_out = [
        "ESP32 timing: every CPU figure is the unix port on this machine; an ESP32-S3 at 240 MHz is expected to be "
        "one to two orders of magnitude slower per bytecode, not measured here.",
        "The ESP32-equivalent heap is scaled from a 32-bit WebAssembly port measurement, not measured on an ESP32 "
        "(no board here); Wi-Fi/NTRIP buffers are not in the simulation.",
        "Against the planned path, only the firmware's own logged path_xte (from its GNSS fix) is available; the "
        "truth is compared with the track as given.",
        "The geometric minimum is the tangent-circle figure (an upper estimate of the true minimax path).",
        "Optional laws (L1, pure pursuit) are not implemented in the firmware, so not compared.",
    ]
    if missing:
        left_out.append("faults without a defined check: " + ", ".join(missing))
    if quick:
        left_out.insert(0, "--quick: a subset of cases and faults, a short mission and a coarse heap bisection")
    meta = {"seeds": seeds, "wall_s": round(wall, 1), "quick": quick, "jobs": args.jobs, "mission_runs": mission_runs,
            "date": time.strftime("%Y-%m-%d %H:%M"), "laws": args.laws, "left_out": left_out}
    write_report(out, rows, results, ratio, perf, faults, meta)
    text = (out / "report.md").read_text()
    return text.split("\n## Goals")[0], wall
