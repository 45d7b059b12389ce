"""`trackpilot bench --robust N`: both guidance laws on N random boats (boat_params.json "spread",
drawn per boat from a seed) x a scenario set, through the full firmware, on Dask distributed.

Each run is one task: (case, law, boat seed) -> metrics. The task writes its track and run folder
in a temporary directory on the worker (workers need not share a disk) and returns only numbers,
so the same seeds give the same numbers whatever the number of workers or where they run.
Boat 0 is the nominal boat (no spread), the reference for keystrokes per km.
Definitions (settling, oscillation, goals): docs/BENCHMARK_ROBUST.md.
"""
import json
import math
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

STRAIGHT_SPEEDS = (0.5, 1.0, 2.0, 3.0)
GOAL_SPEEDS = (1.0, 2.0, 3.0)
GOAL_CURRENT_MPS = 0.3
TURN_CASES = ("zigzag_60", "uturn_20m", "lawnmower")


def _straight_len(v):
    """200 m as `trackpilot bench`'s straights, at least 100 s of sailing (settling, then a measure)."""
    return max(200.0, 100.0 * v)


# case name -> (track maker name, args, sim overrides, faults, kind)
def case_table():
    t = {}
    for v in STRAIGHT_SPEEDS:
        t["straight_%.1f" % v] = ("straight", (v, _straight_len(v)), {"sim": {"start_offset_m": 5.0}}, (), "line")
    t["zigzag_60"] = ("zigzag", (60,), {"leg_m": 40.0, "legs": 4}, (), "turns")
    t["uturn_20m"] = ("uturn", (20,), {"length_m": 60.0}, (), "turns")
    t["lawnmower"] = ("lawnmower", (), {"lines": 4, "length_m": 60.0, "spacing_m": 20.0}, (), "turns")
    t["mooring"] = ("mooring", (), {}, (), "turns")
    # a bridge: no GNSS at all for 6 s (about 12 m at 2 m/s), then single, float, fixed
    t["bridge"] = ("straight", (2.0, 200.0), {"sim": {"start_offset_m": 0.0}}, ("gnss_dropout@45:6",), "line")
    return t


def _write_track(case, path):
    from .sim import benchtracks as bt

    maker, args, extra, _, kind = case_table()[case]
    fn = getattr(bt, maker)
    if kind == "turns" and maker != "mooring":
        return fn(path, *args, **extra)
    return fn(path, *args)


def sim_params(case, boat_seed, base=None):
    """(parameter dict, flat drawn values) for a case on boat `boat_seed` (0 = nominal); `base`: a
    full parameter dict given by the caller instead (tune's sweep around a fitted boat)."""
    from .sim import params as P
    from .sim import scenarios

    p = P.load() if base is None else json.loads(json.dumps(base))  # a copy: the case adds to it
    flat = {}
    if base is not None:
        pass  # drawn by the caller
    elif boat_seed == 0:  # the nominal point as `trackpilot bench` sails it: calm, 0.2 m/s cross current
        P.merge(p, scenarios.PRESETS["calm"])
        P.merge(p, {"water": {"current_mps": 0.2, "current_dir_deg": 90.0}})
    else:
        over, flat = P.draw_spread(boat_seed, P.load_spread(), p)
        P.merge(p, over)
    _, _, extra, _, kind = case_table()[case]
    if kind == "line":
        P.merge(p, extra)
    return p, flat


NOMINAL_SEEDS = 3  # the nominal boat's noise seeds (its reference figures are their mean)


def job_name(job):
    extra = "_s%d" % job["seed"] if job.get("seed", 1) != 1 else ""
    if job.get("config"):  # tune's sweep: the same boat with two configurations
        extra += "_" + job["config"]
    return "%s_%s_b%d%s" % (job["case"], job["law"], job["boat"], extra)


def rerun_command(job):
    sets = []
    for sec, body in sorted((job.get("fw") or {}).items()):
        for k, v in sorted(body.items()):
            sets.append(" --fw-set %s.%s=%s" % (sec, k, json.dumps(v)))
    return "trackpilot bench --robust-one %d --case %s --laws %s%s --out robust_%s" % (
        job["boat"], job["case"], job["law"], "".join(sets), job_name(job))


# ---------------------------------------------------------------------- metrics
def settle_index(rows, tol_m=0.5, hold_s=10.0):
    """Index of the first sample of the first span where |xte| < tol held for hold_s (None: never)."""
    start = None
    for k, (t, x) in enumerate(rows):
        if abs(x) < tol_m:
            if start is None:
                start = k
            elif t - rows[start][0] >= hold_s:
                return start
        else:
            start = None
    return None


def settled_late_rms(after):
    """RMS xte over the second half (by time) of a settled window [(t_s, xte_m)], rounded; None if
    empty."""
    if not after:
        return None
    mid = after[0][0] + 0.5 * (after[-1][0] - after[0][0])
    late = [x for t, x in after if t >= mid]
    return round(_rms(late), 3)


def oscillation(samples, amp_m=0.5, band_m=0.1, min_half_cycles=3, keep_ratio=0.5, period_ratio=2.0):
    """Does the cross-track error keep swinging? samples: [(t_s, xte_m)], one straight line.

    The signal is xte minus its median (a steady offset is not an oscillation). A half cycle runs
    from one crossing of the median to the next, crossings counted with a hysteresis of band_m
    (noise does not make crossings); its amplitude is its largest |deviation|. The first half cycle
    (from the start of the window) and the one still open at the end are not counted. The run
    oscillates if min_half_cycles consecutive half cycles each have an amplitude > amp_m, each
    keeps >= keep_ratio of the one before (decays by less than 1 - keep_ratio per half cycle), and
    their durations stay within a factor period_ratio of the first one's (a regular period).
    Returns {"oscillates", "half_cycles" (longest such sequence), "amp_m", "period_s"}."""
    none = {"oscillates": False, "half_cycles": 0, "amp_m": 0.0, "period_s": None}
    if len(samples) < 10:
        return none
    med = statistics.median(x for _, x in samples)
    halves = []  # (duration_s, amplitude_m)
    sign = 0
    t0 = None
    peak = 0.0
    for t, x in samples:
        d = x - med
        s = 1 if d > band_m else (-1 if d < -band_m else 0)
        if s == 0 or s == sign or sign == 0:
            peak = max(peak, abs(d))
            if sign == 0 and s != 0:
                sign, t0 = s, t
            continue
        halves.append((t - t0, peak))
        sign, t0, peak = s, t, abs(d)
    halves = halves[1:]
    best, best_amp, best_per = 0, 0.0, None
    i = 0
    while i < len(halves):
        j = i
        while j < len(halves):
            dur, amp = halves[j]
            if amp <= amp_m:
                break
            if j > i:
                if amp < keep_ratio * halves[j - 1][1]:
                    break
                r = dur / halves[i][0] if halves[i][0] > 0 else 0.0
                if not (1.0 / period_ratio <= r <= period_ratio):
                    break
            j += 1
        n = j - i
        if n > best:
            best = n
            best_amp = max(a for _, a in halves[i:j])
            best_per = 2.0 * statistics.mean(d for d, _ in halves[i:j])
        i = max(j, i + 1)
    if best == 0:
        return none
    return {"oscillates": best >= min_half_cycles, "half_cycles": best, "amp_m": round(best_amp, 3),
            "period_s": round(best_per, 1)}


def outside_by_phase(rows, corners_m, tol_m=1.5, near_m=15.0, after_m=30.0):
    """Where the time outside +-tol_m goes in a turn case (% of all AUTO samples): the approach
    (before |xte| first comes within tol_m), the corners (track distance within near_m of a
    corner), the settle after a corner (near_m..after_m past one) and the rest of the straights;
    of the last, out_start_pct: the first leg before its corner (the start from rest)."""
    n = len(rows)
    out = {"out_approach_pct": 0, "out_corner_pct": 0, "out_exit_pct": 0, "out_straight_pct": 0,
           "out_start_pct": 0}
    reached = False
    for _, x, s_m, _, _ in rows:
        inside = abs(x) <= tol_m
        reached = reached or inside
        if inside:
            continue
        if not reached:
            out["out_approach_pct"] += 1
        elif any(abs(s_m - c) <= near_m for c in corners_m):
            out["out_corner_pct"] += 1
        elif any(0.0 < s_m - c <= after_m for c in corners_m):
            out["out_exit_pct"] += 1
        else:
            out["out_straight_pct"] += 1
            if corners_m and s_m < corners_m[0]:
                out["out_start_pct"] += 1
    return {k: round(100.0 * v / n, 2) for k, v in out.items()}


def _rms(v):
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else None


def analyse(res, kind, sender_id=1):
    """A finished SimRun's result -> the robust bench's metrics (docs/BENCHMARK_ROBUST.md)."""
    rows = res["truth_xte"]  # (t_s, xte_m, track_m, dist_m, straight) in AUTO
    allx = [x for _, x, _, _, _ in rows]
    m = {"finished": res["finished_s"] is not None, "stop": res["stop_reason"],
         "sim_s": round(res["sim_s"], 1), "wall_s": round(res["wall_s"], 2)}
    if not rows:
        m.update({"failure": True, "why": "never in AUTO (%s)" % res["stop_reason"]})
        return m
    km = max(rows[-1][3] - rows[0][3], 1.0) / 1000.0
    keys = res["pilot_keys_by_sender"].get(sender_id, 0)
    m["keys"] = keys
    m["keys_per_km"] = round(keys / km, 1)
    m["max_m"] = round(max(abs(x) for x in allx), 3)
    m["within_1p5_pct"] = round(100.0 * sum(1 for x in allx if abs(x) <= 1.5) / len(allx), 2)
    m["rms_all_m"] = round(_rms(allx), 3)
    if kind == "turns":
        m.update(outside_by_phase(rows, res["geom"].corners_m))
    if kind == "line":
        st = [(t, x) for t, x, _, _, s in rows if s]
        k0 = settle_index(st)
        m["settled"] = k0 is not None
        # never settled: the RMS over everything after the first 30 s counts (no free pass)
        after = st[k0:] if k0 is not None else [(t, x) for t, x in st if t - st[0][0] >= 30.0]
        m["settled_rms_m"] = round(_rms([x for _, x in after]), 3) if after else None
        # a diagnostic beside the goal's metric, not a goal: the RMS over the settled window's
        # second half, the steady state (its first half carries the end of the approach)
        m["settled_late_rms_m"] = settled_late_rms(after) if k0 is not None else None
        m["settled_max_m"] = round(max(abs(x) for _, x in after), 3) if after else None
        # the oscillation window: from the first time the boat reaches |xte| <= 0.5 m
        w0 = next((k for k, (_, x) in enumerate(st) if abs(x) <= 0.5), None)
        win = st[w0:] if w0 is not None else [(t, x) for t, x in st if t - st[0][0] >= 30.0]
        m["osc"] = oscillation(win)
    m["failure"] = not m["finished"] or (kind == "line" and not m["settled"])
    m["why"] = None if not m["failure"] else ("not finished (%s)" % m["stop"] if not m["finished"] else "never settled")
    return m


# ---------------------------------------------------------------------- one task
def run_job(job):
    """One run on a worker: job = {"case", "law", "boat", "out" (None: a temporary folder, removed),
    "timeout"} -> {"job", "params", "metrics"} (or "error")."""
    from . import bench_perf
    from .sim.runner import SimRun

    case = job["case"]
    _, _, _, faults, kind = case_table()[case]
    keep = job.get("out")
    base = Path(keep) if keep else Path(tempfile.mkdtemp(prefix="tp_robust_"))
    try:
        base.mkdir(parents=True, exist_ok=True)
        track = _write_track(case, str(base / "track.csv"))
        p, flat = sim_params(case, job["boat"], job.get("params"))
        flat = job.get("flat", flat)
        r = SimRun(track, base / "run", seed=job["boat"] if job["boat"] else job.get("seed", 1), law=job["law"], params=p,
                   faults=faults, fw_config=job.get("fw"))
        dog = bench_perf.watchdog(r, job.get("timeout", 300.0))
        res = r.run()
        dog.cancel()
        m = analyse(res, kind)
        if kind == "line":  # can this boat's pilot hold a course by itself at this speed?
            v = case_table()[case][1][0]
            m["pilot_alone_pp_deg"] = pilot_alone(p, v, step_deg=10.0)
            m["pilot_alone_40_pp_deg"] = pilot_alone(p, v, step_deg=40.0)
        if dog.fired:
            m["failure"], m["why"] = True, "firmware stopped answering (killed: %s)" % dog.fired
        return {"job": job, "params": flat, "metrics": m}
    finally:
        if not keep:
            shutil.rmtree(base, ignore_errors=True)


# ---------------------------------------------------------------------- the engine: Dask distributed
def dask_client(scheduler=None, workers=2):
    """(client, cluster or None): a running scheduler's address, or a LocalCluster of `workers`
    single-threaded worker processes (each run is a firmware process: one per core)."""
    import logging

    from dask.distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout="20s"), None
        except (OSError, TimeoutError, ValueError) as e:  # an ordinary mistake: no traceback
            raise SystemExit("cannot reach the Dask scheduler at %s: %s (start it with `dask scheduler`, "
                             "workers with `dask worker %s`)" % (scheduler, e, scheduler))
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.ERROR)
    return Client(cluster), cluster


def run_on_dask(jobs, fn, scheduler=None, workers=2, progress=None, retries=2):
    """Submit every job; yield (job, result) as they finish. A task that raises is retried
    `retries` times; a task whose worker dies is rescheduled by the scheduler (up to its
    allowed-failures). scheduler: "tcp://HOST:8786" or None for a LocalCluster of `workers`
    single-threaded worker processes."""
    from dask.distributed import as_completed

    client, cluster = dask_client(scheduler, workers)
    try:
        byfut = {}
        for j in jobs:
            f = client.submit(fn, j, key="tp-" + job_name(j), pure=False, retries=retries)
            byfut[f] = j
        for f in as_completed(list(byfut)):
            j = byfut[f]
            try:
                res = f.result()
            except Exception as e:  # noqa: BLE001 - a failed task is a finding, reported with its job
                res = {"job": j, "params": {}, "error": "%s: %s" % (type(e).__name__, e),
                       "metrics": {"failure": True, "why": "%s: %s" % (type(e).__name__, e)}}
            yield j, res
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# ---------------------------------------------------------------------- aggregation
def _q(v, q):
    """The q-quantile (0..1) of v, nearest rank."""
    a = sorted(v)
    return a[min(len(a) - 1, max(0, int(math.ceil(q * len(a))) - 1))]


def distribution(results, metric, worst="max"):
    """median, p90 (towards the bad side), worst and the worst sample's job over results with the metric."""
    vals = [(r["metrics"].get(metric), r) for r in results if r["metrics"].get(metric) is not None]
    if not vals:
        return None
    v = [x for x, _ in vals]
    if worst == "max":
        w = max(vals, key=lambda p: p[0])
        p90 = _q(v, 0.9)
    else:
        w = min(vals, key=lambda p: p[0])
        p90 = _q(v, 0.1)
    return {"n": len(v), "median": round(statistics.median(v), 3), "p90": round(p90, 3), "worst": round(w[0], 3),
            "worst_boat": w[1]["job"]["boat"], "worst_params": w[1]["params"], "rerun": rerun_command(w[1]["job"])}


def goal_straight(r):
    j = r["job"]
    if j["boat"] == 0:
        return False
    if not j["case"].startswith("straight_") or float(j["case"].split("_")[1]) not in GOAL_SPEEDS:
        return False
    return r["params"].get("water.current_mps", 0.0) <= GOAL_CURRENT_MPS + 1e-9


def summarise(results):
    """{(case, law): {metric: distribution}} plus goal lines."""
    table = {}
    for r in results:
        if r["job"]["boat"] == 0:
            continue
        table.setdefault((r["job"]["case"], r["job"]["law"]), []).append(r)
    out = {}
    for (case, law), rs in sorted(table.items()):
        d = {"runs": len(rs), "failures": sum(1 for r in rs if r["metrics"].get("failure")),
             "pilot_cannot_hold": sum(1 for r in rs if not pilot_holds(r)),
             "oscillating": sum(1 for r in rs if (r["metrics"].get("osc") or {}).get("oscillates"))}
        for metric, w in (("settled_rms_m", "max"), ("settled_late_rms_m", "max"), ("settled_max_m", "max"),
                          ("max_m", "max"), ("within_1p5_pct", "min"), ("keys_per_km", "max")):
            d[metric] = distribution(rs, metric, w)
        out["%s/%s" % (case, law)] = d
    return out


PILOT_HOLDS_PP_DEG = 5.0


def pilot_holds(r):
    """The boat's pilot alone holds a fixed course at the case's speed: after a 10 deg and after a
    40 deg course step its heading swings less than PILOT_HOLDS_PP_DEG peak to peak over the last
    60 s (pilot_alone). A pilot that limit-cycles by itself needs its own gain turned down; no
    keystroke law can steer it straight."""
    m = r["metrics"]
    a, b = m.get("pilot_alone_pp_deg"), m.get("pilot_alone_40_pp_deg")
    return a is None or (a < PILOT_HOLDS_PP_DEG and b < PILOT_HOLDS_PP_DEG)


def goals(results, law="los", only_holding=False):
    """The issue's goals for one law: [(goal, figure, met)]. only_holding: over the boats whose
    pilot holds a course by itself (pilot_holds)."""
    res = [r for r in results if r["job"]["law"] == law and r["job"]["boat"] != 0
           and (not only_holding or pilot_holds(r))]
    nom = [r for r in results if r["job"]["law"] == law and r["job"]["boat"] == 0]
    out = []
    st = [r for r in res if goal_straight(r)]
    boats = len({r["job"]["boat"] for r in st})
    d = distribution(st, "settled_rms_m")
    if d:
        fails = sum(1 for r in st if r["metrics"].get("failure"))
        out.append(("straights 1-3 m/s, current <= 0.3 m/s: median RMS XTE after settling <= 0.15 m",
                    "%.3f m over %d runs (%d boats), %d failed" % (d["median"], d["n"], boats, fails),
                    d["median"] <= 0.15 and not fails))
        out.append(("... p90 <= 0.25 m", "%.3f m" % d["p90"], d["p90"] <= 0.25))
        out.append(("... worst <= 0.5 m", "%.3f m (boat %d: `%s`)" % (d["worst"], d["worst_boat"], d["rerun"]),
                    d["worst"] <= 0.5))
        osc = [r for r in st if (r["metrics"].get("osc") or {}).get("oscillates")]
        out.append(("... no run oscillates", "%d of %d%s" % (len(osc), len(st), (" (e.g. boat %d, %s)" % (
            osc[0]["job"]["boat"], osc[0]["job"]["case"])) if osc else ""), not osc))
        kn = [r["metrics"]["keys_per_km"] for r in nom if goal_straight_case(r["job"]["case"])
              and r["metrics"].get("keys_per_km") is not None]
        kk = [r["metrics"]["keys_per_km"] for r in st if r["metrics"].get("keys_per_km") is not None]
        if kn and kk:
            ref = statistics.mean(kn)
            med = statistics.median(kk)
            out.append(("... keystrokes per km <= 1.5 x the nominal boat's (median over boats)",
                        "%.0f /km against %.0f /km nominal (x%.2f)" % (med, ref, med / ref if ref else 0.0),
                        med <= 1.5 * ref))
    for case in TURN_CASES:
        t = [r for r in res if r["job"]["case"] == case]
        d = distribution(t, "within_1p5_pct", "min")
        if d:
            out.append(("%s: p90 of time within +-1.5 m >= 95 %%" % case,
                        "%.1f %% (median %.1f %%, worst %.1f %% boat %d) over %d boats" % (
                            d["p90"], d["median"], d["worst"], d["worst_boat"], d["n"]), d["p90"] >= 95.0))
    return out


def nominal_table(results):
    """The nominal boat per case and law: mean over its noise seeds of the settled RMS, max |xte|,
    within 1.5 m and keystrokes per km."""
    t = {}
    for r in results:
        if r["job"]["boat"] == 0:
            t.setdefault("%s/%s" % (r["job"]["case"], r["job"]["law"]), []).append(r["metrics"])
    out = {}
    for k, ms in sorted(t.items()):
        row = {"seeds": len(ms)}
        for key in ("settled_rms_m", "settled_max_m", "max_m", "within_1p5_pct", "keys_per_km"):
            v = [m[key] for m in ms if m.get(key) is not None]
            row[key] = round(statistics.mean(v), 3) if v else None
        row["oscillating"] = sum(1 for m in ms if (m.get("osc") or {}).get("oscillates"))
        out[k] = row
    return out


def goal_straight_case(case):
    return case.startswith("straight_") and float(case.split("_")[1]) in GOAL_SPEEDS


# ---------------------------------------------------------------------- plots
def _spearman(a, b):
    def ranks(v):
        order = sorted(range(len(v)), key=lambda i: v[i])
        r = [0.0] * len(v)
        for k, i in enumerate(order):
            r[i] = float(k)
        return r

    ra, rb = ranks(a), ranks(b)
    ma, mb = statistics.mean(ra), statistics.mean(rb)
    num = sum((x - ma) * (y - mb) for x, y in zip(ra, rb))
    den = math.sqrt(sum((x - ma) ** 2 for x in ra) * sum((y - mb) ** 2 for y in rb))
    return num / den if den else 0.0


def plots(results, out):
    """Histogram of straight RMS per law; straight RMS (los) against the parameters that matter most
    (largest |Spearman rank correlation|). Returns the ranking [(param, rho)]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    st = [r for r in results if goal_straight(r) and r["metrics"].get("settled_rms_m") is not None]
    laws = sorted({r["job"]["law"] for r in st})
    if not st:
        return []
    fig, ax = plt.subplots(figsize=(7, 4))
    top = max(r["metrics"]["settled_rms_m"] for r in st)
    bins = [top * k / 30.0 for k in range(31)] if top > 0 else 10
    for law in laws:
        ax.hist([r["metrics"]["settled_rms_m"] for r in st if r["job"]["law"] == law], bins=bins, alpha=0.6, label=law)
    ax.axvline(0.15, color="k", ls="--", lw=0.8)
    ax.set_xlabel("RMS |XTE| after settling, straights 1-3 m/s (m)")
    ax.set_ylabel("runs")
    ax.set_title("%d runs" % len(st), fontsize=9)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "robust_straight_rms_hist.png", dpi=90)
    plt.close(fig)
    los = [r for r in st if r["job"]["law"] == (laws[0] if "los" not in laws else "los")]
    names = sorted(los[0]["params"]) if los and los[0]["params"] else []
    y = [r["metrics"]["settled_rms_m"] for r in los]
    rank = sorted(((n, _spearman([r["params"][n] for r in los], y)) for n in names), key=lambda p: -abs(p[1]))
    if rank and len(los) > 3:
        fig, axs = plt.subplots(2, 3, figsize=(11, 6))
        for ax, (n, rho) in zip(axs.flat, rank[:6]):
            ax.scatter([r["params"][n] for r in los], y, s=8)
            ax.set_xlabel(n)
            ax.set_title("rho %.2f" % rho, fontsize=9)
        axs.flat[0].set_ylabel("RMS |XTE| (m)")
        fig.tight_layout()
        fig.savefig(out / "robust_straight_rms_vs_params.png", dpi=90)
        plt.close(fig)
    return [(n, round(rho, 3)) for n, rho in rank]


# ---------------------------------------------------------------------- the command
def make_jobs(n, cases, laws, seed0=1, quick=False, timeout=300.0, fw=None):
    """Boats seed0 .. seed0+n-1 (plus boat 0, the nominal one, for every case and law). --quick:
    each boat sails one straight, the speed cycling 1, 2, 3 m/s over the boats."""
    jobs = []
    for law in laws:
        for case in cases:
            for seed in range(1, NOMINAL_SEEDS + 1):
                jobs.append({"case": case, "law": law, "boat": 0, "seed": seed, "timeout": timeout, "fw": fw})
        for b in range(seed0, seed0 + n):
            bc = ["straight_%.1f" % GOAL_SPEEDS[b % 3]] if quick else cases
            for case in bc:
                jobs.append({"case": case, "law": law, "boat": b, "timeout": timeout, "fw": fw})
    # the long runs first, so workers finish together
    jobs.sort(key=lambda j: 0 if j["case"] in ("straight_0.5", "lawnmower", "mooring") else 1)
    return jobs


def fw_overrides(items):
    """["guidance.los_lookahead_gain=3", ...] -> firmware config sections (None if empty)."""
    from .sim.params import parse_set

    return parse_set(items) or None


def run(args):
    t0 = time.perf_counter()
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    if args.robust_one is not None:
        job = {"case": args.case, "law": args.laws.split(",")[0], "boat": args.robust_one,
               "out": str(out), "timeout": args.run_timeout, "fw": fw_overrides(args.fw_set)}
        if args.case not in case_table():
            print("unknown case %r (one of %s)" % (args.case, ", ".join(case_table())))
            return 2
        res = run_job(job)
        (out / "robust_one.json").write_text(json.dumps(res, indent=1))
        print(json.dumps(res, indent=1))
        print("run folder: %s (truth.csv, firmware log)" % (out / "run"))
        return 0
    quick = args.quick
    cases = list(case_table()) if not args.robust_cases else args.robust_cases.split(",")
    bad = [c for c in cases if c not in case_table()]
    if bad:
        print("unknown case(s) %s (known: %s)" % (", ".join(bad), ", ".join(case_table())))
        return 2
    if quick and not args.robust_cases:
        cases = ["straight_%.1f" % v for v in GOAL_SPEEDS]
    laws = args.laws.split(",")
    fw = fw_overrides(args.fw_set)
    jobs = make_jobs(args.robust, cases, laws, args.robust_seed, quick, args.run_timeout, fw)
    where = args.scheduler or "LocalCluster, %d workers" % args.jobs
    print("robust bench: %d boats x %s x %s + the nominal boat: %d runs on %s" % (
        args.robust, "1 straight (quick)" if quick else "%d cases" % len(cases), "/".join(laws), len(jobs), where),
        flush=True)
    results = []
    stream = open(out / "robust_results.jsonl", "w")
    last = 0.0
    for _, res in run_on_dask(jobs, run_job, args.scheduler, args.jobs):
        results.append(res)
        stream.write(json.dumps(res) + "\n")
        stream.flush()
        now = time.perf_counter() - t0
        if now - last >= 5.0 or len(results) == len(jobs):
            last = now
            fails = sum(1 for r in results if r["metrics"].get("failure"))
            print("[%4.0f s] %d/%d runs, %.2f runs/s, %d failed" % (now, len(results), len(jobs),
                                                                    len(results) / now, fails), flush=True)
    stream.close()
    wall = time.perf_counter() - t0
    results.sort(key=lambda r: (r["job"]["case"], r["job"]["law"], r["job"]["boat"]))
    summ = summarise(results)
    goal = {law: goals(results, law) for law in laws}
    for law in laws:
        goal[law + ", boats whose pilot holds a course alone"] = goals(results, law, only_holding=True)
    rank = plots(results, out)
    summ["nominal"] = nominal_table(results)
    cores = os.cpu_count() or 1
    meta = {"boats": args.robust, "fw_set": args.fw_set or [], "seed0": args.robust_seed, "cases": cases, "laws": laws, "quick": quick,
            "runs": len(results), "wall_s": round(wall, 1), "engine": where, "cores": cores,
            "runs_per_s": round(len(results) / wall, 3), "runs_per_s_per_core": round(len(results) / wall / min(
                cores, args.jobs if not args.scheduler else cores), 3),
            "sim_s": round(sum(r["metrics"].get("sim_s", 0) for r in results), 0),
            "date": time.strftime("%Y-%m-%d %H:%M")}
    (out / "robust.json").write_text(json.dumps({"meta": meta, "summary": summ, "goals": goal,
                                                  "param_ranking": rank}, indent=1))
    text = report_md(meta, summ, goal, rank)
    (out / "robust_report.md").write_text(text)
    print(text)
    print("report: %s" % (out / "robust_report.md"))
    return 0


def _f(x, fmt="%.3f"):
    return "-" if x is None else fmt % x


def report_md(meta, summ, goal, rank):
    L = ["# Robustness benchmark", "",
         "%(boats)d random boats (seeds %(seed0)d..), cases %(cases)s, laws %(laws)s; %(runs)d runs in %(wall_s).0f s "
         "on %(engine)s (%(runs_per_s).2f runs/s, %(runs_per_s_per_core).2f runs/s per core, %(sim_s).0f s "
         "simulated); %(date)s. Firmware overrides: %(fw)s. Definitions: docs/BENCHMARK_ROBUST.md." % dict(meta, cases=",".join(meta["cases"]), fw=" ".join(meta["fw_set"]) or "none",
                                                                               laws=",".join(meta["laws"])), ""]
    for law, g in goal.items():
        L += ["## Goals, `%s`" % law, "", "| goal | measured | status |", "|---|---|---|"]
        L += ["| %s | %s | %s |" % (a, b, "met" if ok else "**not met**") for a, b, ok in g]
        L.append("")
    L += ["## Distributions", "",
          "| case / law | runs | failed | oscillating | pilot alone cannot hold | settled RMS median / p90 / worst | "
          "its window's second half: median / p90 | max abs XTE median / p90 / "
          "worst | within 1.5 m % median / p10 / worst | keys/km median / p90 | worst RMS: rerun |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]
    for k, d in summ.items():
        if k == "nominal":
            continue
        s, m, w, kk = d["settled_rms_m"], d["max_m"], d["within_1p5_pct"], d["keys_per_km"]
        tri = lambda x, f="%.3f": "-" if not x else "%s / %s / %s" % (f % x["median"], f % x["p90"], f % x["worst"])  # noqa: E731
        late = d.get("settled_late_rms_m")
        L.append("| %s | %d | %d | %d | %d | %s | %s | %s | %s | %s | %s |" % (
            k, d["runs"], d["failures"], d["oscillating"], d["pilot_cannot_hold"], tri(s),
            "-" if not late else "%.3f / %.3f" % (late["median"], late["p90"]), tri(m), tri(w, "%.1f"),
            "-" if not kk else "%.0f / %.0f" % (kk["median"], kk["p90"]),
            "-" if not s else "`%s`" % s["rerun"]))
    L.append("")
    L += ["## The nominal boat (no spread; mean over %d noise seeds)" % NOMINAL_SEEDS, "",
          "| case / law | settled RMS | settled max | max abs XTE | within 1.5 m % | keys/km | oscillating |",
          "|---|---|---|---|---|---|---|"]
    for k, r in summ.get("nominal", {}).items():
        L.append("| %s | %s | %s | %s | %s | %s | %d |" % (k, _f(r["settled_rms_m"]), _f(r["settled_max_m"]), _f(r["max_m"]),
                                                        _f(r["within_1p5_pct"], "%.1f"), _f(r["keys_per_km"], "%.0f"),
                                                        r["oscillating"]))
    L.append("")
    if rank:
        L += ["## What matters most (straights, Spearman rank correlation with the RMS)", "",
              ", ".join("%s %+.2f" % (n, r) for n, r in rank[:8]), "",
              "![hist](robust_straight_rms_hist.png) ![params](robust_straight_rms_vs_params.png)", ""]
    return "\n".join(L) + "\n"


# ---------------------------------------------------------------------- the pilot alone
class _NoBus:
    retry_limit = 0

    def add_receiver(self, *a):
        pass


def pilot_alone(p, speed_mps, seconds=150.0, step_deg=10.0):
    """The drawn ST2000+ holding a fixed course on the drawn boat, without the firmware: after a
    step_deg course change at t = 0, the heading's peak-to-peak swing over the last 60 s (deg).
    A pilot that cannot hold a course by itself (a swing of several degrees) limits any outer law:
    the report counts such boats."""
    from .sim import stcodec
    from .sim.boat import Boat, Environment
    from .sim.randproc import component_rng
    from .sim.st2000_sim import ST2000Sim

    env = Environment(p["water"], p["wind"], component_rng(1, "environment"))
    scale = p["boat"].get("speed_map_scale", 1.0)
    rpm = speed_mps / scale * 400.0
    boat = Boat(p["boat"], env, 0.0, 0.0, 0.0, u_mps=speed_mps / 1.0, rpm=rpm)
    pil = ST2000Sim(p["pilot"], component_rng(1, "pilot"), None, _NoBus())
    pil.mode = stcodec.MODE_AUTO
    pil.course_deg = step_deg + p["pilot"]["compass_offset_deg"]
    dt = 0.05
    hs = []
    n = int(seconds / dt)
    for k in range(n):
        rud = pil.control_step(dt, boat.heading_deg())
        boat.step(dt, rud, rpm)
        if k * dt >= seconds - 60.0:
            hs.append(((boat.psi_deg + 180.0) % 360.0) - 180.0)
    return round(max(hs) - min(hs), 2)
