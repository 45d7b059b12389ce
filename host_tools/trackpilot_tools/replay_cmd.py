"""`trackpilot replay LOG...`: rerun a log's inputs through the firmware's navigation and guidance.

With `--closed-loop` (replay_closed.py): re-sail the logged run in the simulator with law or
configuration B on the identified boat, and compare both runs' xte and keystrokes.

With `--journal` (a simulator run with `trackpilot sim --journal`): every input of the decision
core goes through a fresh core, and every control record, core event, SeaTalk bus action and
motor frame is checked (firmware/tools/replay_core.py).

The firmware's own code runs under MICROPYTHON (firmware/tools/replay.py). With the configuration
the boat ran, every heading and speed command must come out identical; with `--law` or `--set`
it shows what another law or other parameters would have commanded for the same inputs.
"""
import json
import sys
from pathlib import Path

from trackpilot_tools.errors import UserError, script_error_line
from trackpilot_tools.mpy import ROOT, run_script

SCRIPT = ROOT / "firmware" / "tools" / "replay.py"
CORE_SCRIPT = ROOT / "firmware" / "tools" / "replay_core.py"


def run_core_replay(logs, config, journal, seed=None):
    """The decision core replayed from a simulator journal (firmware/tools/replay_core.py):
    (exit status, {counter: value}, [mismatch lines])."""
    args = [str(journal), str(config)] + [str(p) for p in logs]
    if seed is not None:
        args += ["--seed", str(seed)]
    proc = run_script(CORE_SCRIPT, args, timeout=1800, check=False)
    summary, bad = {}, []
    for line in proc.stdout.decode().splitlines():
        if line.startswith("SUMMARY "):
            for item in line[8:].split():
                k, _, v = item.partition("=")
                summary[k] = int(v)
        elif line.startswith("MISMATCH "):
            bad.append(line[9:])
    if not summary:
        raise RuntimeError("MicroPython script %s failed (%d):\n%s" % (
            CORE_SCRIPT, proc.returncode, proc.stderr.decode(errors="replace")[-4000:]))
    return proc.returncode, summary, bad


def cmd_core_replay(args, logs):
    if not args.config:
        raise UserError("--journal needs --config: the configuration the simulated boat ran "
                        "(OUT/config.json of `trackpilot sim`)")
    if not Path(args.journal).is_file():
        raise UserError("no such journal: %s" % args.journal)
    _check_sets(args.config, ())
    try:
        rc, s, bad = run_core_replay(logs, args.config, args.journal)
    except RuntimeError as e:
        raise UserError("replay failed: %s" % script_error_line(e))
    print("replayed %d calls into the decision core" % s.get("journal_lines", 0))
    print("control records identical: %d of %d (keystrokes %d, RPM setpoints %d, modes %d)" % (
        s["records_identical"], s["records"], s["keys_identical"], s["rpm_identical"], s["mode_identical"]))
    print("core events identical: %d of %d (mode changes %d of %d)" % (
        s["events_identical"], s["events"], s["mode_changes_identical"], s["mode_changes"]))
    print("SeaTalk bus actions checked: %d; motor frames checked: %d" % (s["bus_actions"], s["motor_frames"]))
    for line in bad:
        print("  mismatch: " + line)
    if rc != 0:
        print("trackpilot replay: %d mismatches: the core decided differently" % s.get("mismatches", 0),
              file=sys.stderr)
        return 1
    print("everything the core decided was reproduced")
    return 0


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


def _check_sets(config_path, sets):
    """--config and --set checked on the host, so a typo is one line, not a MicroPython error."""
    import trackpilot_tools.logdecode  # noqa: F401 (puts firmware/ on sys.path)
    from trackpilot import config as fwconfig

    if config_path and not Path(config_path).is_file():
        raise UserError("no such configuration file: %s" % config_path)
    if config_path:
        # the firmware refuses such a file (and runs its last good one): replayed, its bad
        # entries would quietly be the defaults, and the replay not the run asked for
        try:
            _cfg, errors = fwconfig.parse(Path(config_path).read_bytes().decode("utf-8"))
        except (OSError, UnicodeError) as e:
            errors = ["not a UTF-8 text file (%s)" % e]
        if errors:
            raise UserError("--config %s: %s" % (config_path, "; ".join(errors)))
    cfg = {}
    for item in sets or ():
        key, eq, text = item.partition("=")
        sec, dot, name = key.partition(".")
        if not eq or not dot or not sec or not name:
            raise UserError("--set %r: expected SECTION.KEY=VALUE, e.g. guidance.los_lookahead_gain=3" % item)
        try:
            value = json.loads(text)
        except ValueError:
            value = text
        cfg.setdefault(sec, {})[name] = value
    errors = fwconfig.validate(cfg)
    if errors:
        raise UserError("--set: " + "; ".join(errors))


def _time_axis(rows, decoded):
    """Seconds since the log's first control record for each replayed row (ticks wrap at 2^30;
    a jump outside -1 s..1 h is a new session and continues the axis after a gap, as logdecode
    does)."""
    from trackpilot.compat import ticks_diff
    from trackpilot_tools.logdecode import SESSION_GAP_S

    if not rows:
        return []
    first = decoded.controls[0] if decoded.controls else None
    t = ticks_diff(int(rows[0][0]), first.t_ms) / 1000.0 if first is not None else 0.0
    out = [max(t, 0.0)]
    for prev, row in zip(rows, rows[1:]):
        dt = ticks_diff(int(row[0]), int(prev[0]))
        if not -1000 < dt < 3600000:
            dt = int(SESSION_GAP_S * 1000)
        out.append(out[-1] + dt / 1000.0)
    return out


def _with_gaps(t, ys, gap_s):
    """Copies of t and ys with a NaN point wherever consecutive samples are more than gap_s apart,
    so the plot shows the gap instead of a straight line across it."""
    tt, yy = [], []
    for i, (a, y) in enumerate(zip(t, ys)):
        if i and a - t[i - 1] > gap_s:
            tt.append((a + t[i - 1]) / 2)
            yy.append(float("nan"))
        tt.append(a)
        yy.append(y)
    return tt, yy


def cmd_replay(args):
    from trackpilot_tools.logdecode import LogError, decode_files

    logs = [Path(p) for p in args.logs]
    for p in logs:
        if not p.is_file():
            raise UserError("no such log: %s" % p)
    if args.closed_loop:
        from trackpilot_tools import replay_closed

        _check_sets(args.config, args.set)
        return replay_closed.cmd(args, logs)
    if args.boat or args.out:
        raise UserError("--boat and --out belong to --closed-loop")
    if args.journal:
        return cmd_core_replay(args, logs)
    _check_sets(args.config, args.set)
    try:
        decoded = decode_files(logs)
    except LogError as e:
        raise UserError(str(e))
    want_rows = bool(args.csv or args.plot)
    try:
        summary, rows = run_replay(logs, args.config, args.law, args.set or (), want_rows)
    except RuntimeError as e:
        raise UserError("replay failed: %s" % script_error_line(e))
    g = int(summary.get("guided", 0))
    print("replayed %d control steps, %d guided, law %s" % (summary.get("control", 0), g, summary.get("law")))
    print("heading commands identical: %d of %d; speed commands identical: %d of %d" % (
        summary.get("heading_identical", 0), g, summary.get("speed_identical", 0), g))
    print("heading command difference: max %.2f deg, RMS %.3f deg" % (
        summary.get("max_heading_diff_deg", 0), summary.get("rms_heading_diff_deg", 0)))
    if summary.get("damage"):
        print("log damage reports: %d (records in damaged spans are skipped; "
              "`trackpilot log decode` lists them)" % summary["damage"])
    if not summary.get("control"):
        why = ("no track record before the control records" if decoded.controls and decoded.track is None
               else "no control records could be read" if not decoded.controls
               else "no control records after the track record")
        print("trackpilot replay: nothing to replay: %s (%d control records, %d damage reports)"
              % (why, len(decoded.controls), len(decoded.damage)), file=sys.stderr)
        return 1
    t_s = _time_axis(rows, decoded)
    if args.csv:
        with open(args.csv, "w") as f:
            f.write("t_s,t_ms,leg,logged_heading_cmd_deg,replayed_heading_cmd_deg,logged_speed_cmd_mps,"
                    "replayed_speed_cmd_mps,xte_m\n")
            for ts, r in zip(t_s, rows):
                f.write("%.3f,%d,%d,%.2f,%.2f,%.3f,%.3f,%.2f\n" % ((ts,) + tuple(r)))
        print("csv: %s" % args.csv)
    if args.plot and rows:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        utc = next((h.get("utc") for h in decoded.headers if h.get("utc")), None)
        gap_s = 2.0  # guided steps come at the GNSS rate (5-10 Hz); a longer pause is a gap
        fig, ax = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
        ax[0].plot(*_with_gaps(t_s, [r[2] for r in rows], gap_s), label="logged command")
        ax[0].plot(*_with_gaps(t_s, [r[3] for r in rows], gap_s), label="replayed command", linestyle="--")
        ax[0].set_ylabel("heading command (deg)")
        ax[0].set_title("Replay (law %s): logged vs replayed heading command" % summary.get("law"))
        ax[0].legend(loc="best", fontsize=8)
        ax[1].plot(*_with_gaps(t_s, [r[6] for r in rows], gap_s))
        ax[1].set_ylabel("xte (m, + stbd)")
        ax[1].set_xlabel("time since log start (s)" + (", start %s UTC" % utc if utc else "")
                         + "; guided steps only, gaps left open")
        for a in ax:
            a.grid(True, alpha=0.3)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=100)
        plt.close(fig)
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
    p.add_argument("--journal", help="a simulator journal (trackpilot sim --journal): replay the whole decision "
                   "core and check every record, event, keystroke and RPM setpoint (exit 1 on a difference)")
    p.add_argument("--closed-loop", action="store_true",
                   help="re-sail the log's track in the simulator from the logged AUTO start state and current "
                        "with --law/--config/--set, and compare with the logged run (xte, keystrokes, plot)")
    p.add_argument("--boat", metavar="FIT.json", help="--closed-loop: the boat `trackpilot tune` identified "
                   "(default: the simulator's nominal boat)")
    p.add_argument("--out", help="--closed-loop: output folder (default replay_closed_out)")
    p.add_argument("--no-plot", action="store_true", help="--closed-loop: no PNG")
    p.set_defaults(func=cmd_replay)
