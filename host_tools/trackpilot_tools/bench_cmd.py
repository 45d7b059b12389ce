"""`trackpilot bench`: tracking accuracy of both guidance laws, through the full firmware in the
simulator, over the benchmark scenarios of BOAT_AND_BENCHMARK.md and several seeds. Writes
bench.md and bench.json. (Compute/memory figures and the fault matrix are not part of this yet.)"""
import json
import math
import os
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

R_TURN_M = 5.0 / (1.1 * math.radians(30.0))  # the simulated boat's turning radius (8.7 m)


def cases(quick=False):
    from .sim import benchtracks as bt

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
    rob = [("rtk_float_episode", {}, ["rtk_float@40:20"]),
           ("model_K_plus50", {"boat": {"k_prime": 1.65}}, []),
           ("model_K_minus50", {"boat": {"k_prime": 0.55}}, []),
           ("deadband_3deg", {"pilot": {"deadband_deg": 3.0}}, []),
           ("latency_300ms", {"gnss": {"latency_ms": [300, 300]}}, []),
           ("seatalk_noise", {}, ["st_noise@20:60"])]
    for name, st, faults in (rob[:2] if quick else rob):
        base = {"sim": {"start_offset_m": 5.0}, "water": {"current_mps": 0.2, "current_dir_deg": 90.0}}
        for sec, body in st.items():
            base.setdefault(sec, {}).update(body)
        out.append({"name": "robust_" + name, "track": (bt.straight, 2.0), "set": base, "faults": faults})
    return out


def _overshoot(rows, geom):
    """Largest xte to the outside of each turn within 40 m after the corner."""
    from trackpilot.track import corner_deviation_m  # noqa: F401 (firmware importable here)

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


def run_one(job):
    from .sim.runner import SimRun
    from .sim import report

    case, law, seed, track_path, out = job
    r = SimRun(track_path, out, seed=seed, law=law, scenario="calm", faults=case.get("faults", ()),
               overrides=case["set"], duration_s=case.get("duration_s"))
    res = r.run()
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
    from .sim.truth import stats

    settled_straight = stats([x for _, x, _, _, st in settled if st])
    return {
        "case": case["name"], "law": law, "seed": seed,
        "finished": summ["finished"],
        "completion_s": (summ["finished_at_s"] - engaged) if summ["finished"] and engaged is not None else None,
        "xte": summ["truth_xte_vs_track"], "straights": summ["truth_xte_straights"],
        "turns": summ["truth_xte_turns"], "settling_m": summ["settling_distance_m"],
        "overshoot_m": round(_overshoot(rows, res["geom"]), 3),
        "settled_straights": {k: round(v, 3) for k, v in settled_straight.items()},
        "keystrokes": fw.get("keystrokes"),
        "failure": (not summ["finished"]) or k0 is None or any(abs(x) > 5.0 for _, x, _, _, _ in settled),
        "sim_speed_x": summ["sim_speed_x"], "stop": summ["stop_reason"],
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


def aggregate(results):
    table = {}
    for r in results:
        table.setdefault((r["case"], r["law"]), []).append(r)
    out = []
    for (case, law), runs in sorted(table.items()):
        rms_s = _agg(runs, ("settled_straights", "rms_m"))
        max_s = _agg(runs, ("settled_straights", "max_m"))
        rms_t = _agg(runs, ("turns", "rms_m"))
        max_t = _agg(runs, ("turns", "max_m"))
        p95 = _agg(runs, ("xte", "p95_m"))
        within = _agg(runs, ("xte", "within_1p5_pct"))
        out.append({
            "case": case, "law": law, "seeds": len(runs),
            "straight_rms_m": round(statistics.mean(rms_s), 3) if rms_s else None,
            "straight_max_m": round(max(max_s), 3) if max_s else None,
            "turn_rms_m": round(statistics.mean(rms_t), 3) if rms_t else None,
            "turn_max_m": round(max(max_t), 3) if max_t else None,
            "p95_m": round(statistics.mean(p95), 3) if p95 else None,
            "within_1p5_pct": round(statistics.mean(within), 1) if within else None,
            "settling_m": round(statistics.mean(_agg(runs, ("settling_m",))), 1) if _agg(runs, ("settling_m",)) else None,
            "overshoot_m": round(max(_agg(runs, ("overshoot_m",))), 3),
            "keystrokes": round(statistics.mean(_agg(runs, ("keystrokes",))), 1) if _agg(runs, ("keystrokes",)) else None,
            "completion_s": round(statistics.mean(_agg(runs, ("completion_s",))), 1) if _agg(runs, ("completion_s",)) else None,
            "failures": sum(1 for r in runs if r["failure"]),
        })
    return out


def write_report(out, rows, results, meta):
    Path(out, "bench.json").write_text(json.dumps({"meta": meta, "summary": rows, "runs": results}, indent=2))
    cols = ("case", "law", "seeds", "straight_rms_m", "straight_max_m", "turn_rms_m", "turn_max_m",
            "p95_m", "within_1p5_pct", "settling_m", "overshoot_m", "keystrokes", "completion_s", "failures")
    lines = ["# trackpilot bench", "",
             "Truth cross-track error against the track as given (AUTO only), through the full firmware "
             "in the simulator. straight_* columns: on straights after settling (|xte| < 0.5 m for 10 s); "
             "turn_*, p95 and within-1.5 m: the whole run in AUTO. Failure: not finished, never settled, "
             "or |xte| > 5 m after settling. Boat turning radius %.1f m: a 90 deg corner cannot be sailed closer than "
             "%.2f m to the legs, a 180 deg reversal %.1f m (track.corner_deviation_m)." % (
                 R_TURN_M, R_TURN_M * (1 - math.cos(math.radians(45))), R_TURN_M),
             "", "seeds %s, wall %.0f s, %d runs" % (meta["seeds"], meta["wall_s"], len(results)), "",
             "| " + " | ".join(cols) + " | los/seed straight RMS |",
             "|" + "---|" * (len(cols) + 1)]
    by = {(r["case"], r["law"]): r for r in rows}
    for r in rows:
        ratio = ""
        s = by.get((r["case"], "seed"))
        if r["law"] == "los" and s and s["straight_rms_m"] and r["straight_rms_m"] is not None:
            ratio = "%.2f" % (r["straight_rms_m"] / s["straight_rms_m"])
        lines.append("| " + " | ".join("" if r[c] is None else str(r[c]) for c in cols) + " | %s |" % ratio)
    Path(out, "bench.md").write_text("\n".join(lines) + "\n")


def add_parser(p):
    p.add_argument("--out", default="bench_out")
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--quick", action="store_true", help="a small subset (for tests)")
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    p.add_argument("--laws", default="seed,los")
    p.add_argument("--only", help="run only cases whose name contains this")
    p.set_defaults(func=run)


def run(args):
    out = Path(args.out)
    (out / "tracks").mkdir(parents=True, exist_ok=True)
    jobs = []
    for case in cases(args.quick):
        if args.only and args.only not in case["name"]:
            continue
        fn, *fa = case["track"]
        tp = str(out / "tracks" / (case["name"] + ".csv"))
        fn(tp, *fa)
        for law in args.laws.split(","):
            for seed in range(1, args.seeds + 1):
                jobs.append((case, law, seed, tp, str(out / "runs" / ("%s_%s_s%d" % (case["name"], law, seed)))))
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.jobs) as ex:
        results = list(ex.map(run_one, jobs))
    wall = time.perf_counter() - t0
    rows = aggregate(results)
    write_report(out, rows, results, {"seeds": args.seeds, "wall_s": wall, "quick": args.quick})
    print((out / "bench.md").read_text())
    print("report: %s, %s" % (out / "bench.md", out / "bench.json"))
    return 0
