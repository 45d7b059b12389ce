"""`trackpilot replay LOG...`: rerun a log's inputs through the firmware's navigation and guidance.

The firmware's own code runs under MICROPYTHON (firmware/tools/replay.py). With the configuration
the boat ran, every heading and speed command must come out identical; with `--law` or `--set`
it shows what another law or other parameters would have commanded for the same inputs.
"""
import sys
from pathlib import Path

from trackpilot_tools.mpy import ROOT, run_script

SCRIPT = ROOT / "firmware" / "tools" / "replay.py"


def run_replay(logs, config=None, law=None, sets=(), csv=False):
    args = [str(p) for p in logs]
    if config:
        args += ["--config", str(config)]
    if law:
        args += ["--law", law]
    for s in sets:
        args += ["--set", s]
    if csv:
        args.append("--csv")
    proc = run_script(SCRIPT, args, timeout=1800)
    rows, summary = [], {}
    for line in proc.stdout.decode().splitlines():
        if line.startswith("SUMMARY "):
            for item in line[8:].split():
                k, _, v = item.partition("=")
                summary[k] = v if k == "law" else float(v)
        elif line and line[0].isdigit():
            rows.append([float(x) for x in line.split(",")])
    return summary, rows


def cmd_replay(args):
    logs = [Path(p) for p in args.logs]
    for p in logs:
        if not p.is_file():
            print("replay: no such log: %s" % p, file=sys.stderr)
            return 2
    want_rows = bool(args.csv or args.plot)
    summary, rows = run_replay(logs, args.config, args.law, args.set or (), want_rows)
    g = int(summary.get("guided", 0))
    print("replayed %d control steps, %d guided, law %s" % (summary.get("control", 0), g, summary.get("law")))
    print("heading commands identical: %d of %d; speed commands identical: %d of %d" % (
        summary.get("heading_identical", 0), g, summary.get("speed_identical", 0), g))
    print("heading command difference: max %.2f deg, RMS %.3f deg" % (
        summary.get("max_heading_diff_deg", 0), summary.get("rms_heading_diff_deg", 0)))
    if summary.get("damage"):
        print("log damage reports: %d (records in damaged spans are skipped)" % summary["damage"])
    if args.csv:
        with open(args.csv, "w") as f:
            f.write("t_ms,leg,logged_heading_cmd_deg,replayed_heading_cmd_deg,logged_speed_cmd_mps,"
                    "replayed_speed_cmd_mps,xte_m\n")
            for r in rows:
                f.write("%d,%d,%.2f,%.2f,%.3f,%.3f,%.2f\n" % tuple(r))
        print("csv: %s" % args.csv)
    if args.plot and rows:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        t0 = rows[0][0]
        t = [(r[0] - t0) / 1000.0 for r in rows]
        fig, ax = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
        ax[0].plot(t, [r[2] for r in rows], label="logged command")
        ax[0].plot(t, [r[3] for r in rows], label="replayed command", linestyle="--")
        ax[0].set_ylabel("heading command (deg)")
        ax[0].legend()
        ax[1].plot(t, [r[6] for r in rows])
        ax[1].set_ylabel("xte (m, + stbd)")
        ax[1].set_xlabel("t (s, guided steps)")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=100)
        print("plot: %s" % args.plot)
    if args.expect_identical and (summary.get("heading_identical") != g or summary.get("speed_identical") != g):
        return 1
    return 0


def add_parser(p):
    p.add_argument("logs", nargs="+", help="log files (.tpl) of one session, in order")
    p.add_argument("--config", help="the configuration the boat ran (default: built-in defaults)")
    p.add_argument("--law", choices=("seed", "los"), help="replay with another guidance law")
    p.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                   help="override a setting, e.g. guidance.los_lookahead_gain=3")
    p.add_argument("--csv", help="write logged vs replayed commands to this CSV")
    p.add_argument("--plot", help="write a PNG of logged vs replayed commands")
    p.add_argument("--expect-identical", action="store_true",
                   help="exit 1 unless every command is reproduced exactly")
    p.set_defaults(func=cmd_replay)
