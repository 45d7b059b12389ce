"""The output folder of a simulated run: summary.json, summary.md and PNG plots, from the truth
trace (truth.csv), the runner's result and the firmware's own log (decoded with logdecode)."""
import csv
import glob
import json
import math
import os
import re
from pathlib import Path

from .truth import settling_distance, stats


def _fw_log(out):
    files = sorted(glob.glob(os.path.join(out, "fw", "log", "*.tpl")))
    if not files:
        return None, None, []
    try:
        from ..logdecode import decode_files, session_key, summarize
    except ImportError:
        return None, None, files
    files.sort(key=session_key)
    d = decode_files(files)
    return d, summarize(d), files


def _peak_heap(out):
    p = Path(out) / "firmware_stderr.txt"
    if not p.exists():
        return None
    found = [int(x) for x in re.findall(r"peak heap (\d+) B", p.read_text(errors="replace"))]
    return max(found) if found else None


def _r(x, nd=3):
    return None if x is None else round(x, nd)


def summarize_run(res, meta):
    out = res["out"]
    tx = res["truth_xte"]
    xs = [x for _, x, _, _, _ in tx]
    straight = [x for _, x, _, _, s in tx if s]
    turns = [x for _, x, _, _, s in tx if not s]
    settle = settling_distance([(t, d, x) for t, x, _, d, _ in tx]) if tx else None
    modes = [(t, v) for t, n, v in res["outputs"] if n == "mode"]
    d, fw, files = _fw_log(out)
    geom = res["geom"]
    path_x = []
    if d is not None and d.controls and hasattr(d.controls[0], "path_xte_m"):
        path_x = [c.path_xte_m for c in d.controls if c.mode == 1 and c.pos_valid]
    summ = {
        **meta,
        "stop_reason": res["stop_reason"],
        "finished": res["finished_s"] is not None,
        "finished_at_s": res["finished_s"],
        "sim_time_s": _r(res["sim_s"], 1),
        "auto_time_s": _r(len(tx) * 0.2, 1),
        "wall_time_s": _r(res["wall_s"], 2),
        "sim_speed_x": _r(res["speedup"], 1),
        "lockstep_steps": res["steps"],
        "track_length_m": _r(geom.length_m, 1),
        "truth_xte_vs_track": {k: _r(v) for k, v in stats(xs).items()},
        "truth_xte_straights": {k: _r(v) for k, v in stats(straight).items()},
        "truth_xte_turns": {k: _r(v) for k, v in stats(turns).items()},
        "settling_distance_m": _r(settle, 1),
        "fw_xte_vs_planned_path": {k: _r(v) for k, v in stats(path_x).items()},
        "firmware_log": {k: v for k, v in (fw or {}).items()},
        "firmware_log_files": [os.path.relpath(f, out) for f in files],
        "keystrokes_received_by_pilot": res.get("pilot_keys_by_sender"),
        "pilot_keys_accepted": res["pilot_keys_accepted"],
        "pilot_keys_ignored": res["pilot_keys_ignored"],
        "pilot_bad_datagrams": res["pilot_bad_datagrams"],
        "mode_changes": [[round(t, 2), v] for t, v in modes],
        "alarms_output": sorted({v for t, n, v in res["outputs"] if n == "alarms"}),
        "events": [[round(t, 2), k, txt] for t, k, txt in sorted(res["events"], key=lambda e: e[0])],
        "seatalk_bus": res["bus"],
        "resets": res["resets"],
        "firmware_peak_heap_bytes": _peak_heap(out),
        "failure": res["failure"],
    }
    return summ


def write_summary(summ, out):
    Path(out, "summary.json").write_text(json.dumps(summ, indent=2))
    t = summ["truth_xte_vs_track"]
    s = summ["truth_xte_straights"]
    tu = summ["truth_xte_turns"]
    fw = summ["firmware_log"] or {}
    pp = summ["fw_xte_vs_planned_path"]
    lines = [
        "# Simulated run: %s" % summ.get("track"),
        "",
        "law `%s`, scenario `%s`, seed %s, faults %s" % (summ.get("law"), summ.get("scenario"),
                                                          summ.get("seed"), summ.get("faults") or "none"),
        "",
        "| | value |", "|---|---|",
        "| stop | %s |" % summ["stop_reason"],
        "| finished | %s |" % ("yes, at %.1f s" % summ["finished_at_s"] if summ["finished"] else "no"),
        "| simulated time | %.1f s (AUTO %.1f s) |" % (summ["sim_time_s"], summ["auto_time_s"]),
        "| sim speed | %sx real time (%s s wall, %d steps) |" % (summ["sim_speed_x"], summ["wall_time_s"], summ["lockstep_steps"]),
        "| truth xte vs track, RMS / p95 / max | %s / %s / %s m |" % (t.get("rms_m"), t.get("p95_m"), t.get("max_m")),
        "| ... on straights | %s / %s / %s m |" % (s.get("rms_m"), s.get("p95_m"), s.get("max_m")),
        "| ... in turns | %s / %s / %s m |" % (tu.get("rms_m"), tu.get("p95_m"), tu.get("max_m")),
        "| time within 1.5 m | %s %% |" % t.get("within_1p5_pct"),
        "| settling distance | %s m |" % summ["settling_distance_m"],
        "| firmware's own xte vs track, RMS / max | %s / %s m |" % (fw.get("xte_rms_m"), fw.get("xte_max_abs_m")),
        "| firmware's xte vs its planned path, RMS / p95 / max | %s / %s / %s m |" % (
            pp.get("rms_m"), pp.get("p95_m"), pp.get("max_m")),
        "| keystrokes (firmware log / pilot accepted) | %s / %s |" % (fw.get("keystrokes"), summ["pilot_keys_accepted"]),
        "| alarms (firmware log) | %s |" % (fw.get("alarms"),),
        "| mode changes | %s |" % " -> ".join("%s@%.0fs" % (v, t_) for t_, v in summ["mode_changes"]),
        "| firmware peak heap | %s B |" % summ["firmware_peak_heap_bytes"],
        "| resets | %d |" % summ["resets"],
        "",
        "Truth xte: the true reference point against the track as given (no corner rounding), AUTO only.",
    ]
    if summ["events"]:
        lines += ["", "## Events", ""] + ["- %.2f s %s: %s" % (t_, k, txt) for t_, k, txt in summ["events"]]
    Path(out, "summary.md").write_text("\n".join(lines) + "\n")


def read_truth(out):
    with open(os.path.join(out, "truth.csv")) as f:
        return list(csv.DictReader(f))


def plot_truth(out, geom):
    """Plots from the truth: the track as given vs the sailed path; xte; heading/course; speed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = read_truth(out)
    if not rows:
        return []
    col = lambda k: [float(r[k]) for r in rows]  # noqa: E731
    t = col("t_s")
    paths = []
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.plot([p[0] for p in geom.pts], [p[1] for p in geom.pts], "k--o", ms=3, lw=1, label="track as given")
    auto = [r["fw_mode"].startswith("AUTO") for r in rows]
    e, n = col("east_m"), col("north_m")
    ax.plot(e, n, color="0.7", lw=1, label="sailed (all)")
    ax.plot([x if a else math.nan for x, a in zip(e, auto)], [y if a else math.nan for y, a in zip(n, auto)],
            "b", lw=1.2, label="sailed in AUTO")
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.legend()
    ax.set_title("Truth: track and sailed path")
    p = os.path.join(out, "truth_track.png")
    fig.savefig(p, dpi=110)
    plt.close(fig)
    paths.append(p)

    fig, axs = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    xte = col("xte_m")
    axs[0].plot(t, [x if a else math.nan for x, a in zip(xte, auto)], "b", lw=0.8)
    axs[0].axhline(1.5, color="r", lw=0.5)
    axs[0].axhline(-1.5, color="r", lw=0.5)
    axs[0].set_ylabel("truth xte (m, + stbd)")
    import numpy as np

    def unwrapped(k):
        return np.degrees(np.unwrap(np.radians(col(k))))

    axs[1].plot(t, unwrapped("heading_deg"), lw=0.8, label="true heading")
    axs[1].plot(t, unwrapped("compass_deg"), lw=0.8, label="pilot compass")
    axs[1].plot(t, unwrapped("pilot_course_deg"), lw=0.8, label="pilot locked course")
    axs[1].set_ylabel("deg (unwrapped)")
    axs[2].plot(t, col("sog_mps"), lw=0.8, label="SOG")
    axs[2].plot(t, col("water_speed_mps"), lw=0.8, label="through water")
    ax2 = axs[2].twinx()
    ax2.plot(t, col("rpm"), "g", lw=0.6, label="RPM")
    ax2.set_ylabel("RPM")
    axs[2].set_ylabel("m/s")
    axs[2].set_xlabel("simulated time (s)")
    h1, l1 = axs[2].get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    axs[2].legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left", bbox_to_anchor=(1.08, 1.0),
                  borderaxespad=0.0)
    axs[0].set_title("cross-track error (AUTO only; red: +-1.5 m)", fontsize=9)
    axs[1].set_title("heading, compass and the pilot's locked course", fontsize=9)
    axs[1].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    axs[2].set_title("speed and propeller RPM", fontsize=9)
    fig.suptitle("Truth over time (simulator)")
    fig.tight_layout()
    p = os.path.join(out, "truth_timeseries.png")
    fig.savefig(p, dpi=110)
    plt.close(fig)
    paths.append(p)
    return paths


def plot_firmware_log(out):
    d, _, _ = _fw_log(out)
    if d is None or not d.controls:
        return []
    try:
        from ..logplot import plot_all
    except ImportError:
        return []
    return plot_all(d, os.path.join(out, "plots"))
