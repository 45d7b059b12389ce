"""`trackpilot log`: decode firmware logs to text/CSV and plot them.

Usage:
    trackpilot log decode log/0003-*.tpl --csv run.csv --events
    trackpilot log plot log/0003-*.tpl --out plots/
"""
import json
import os
import sys

from trackpilot_tools.logdecode import LogError, decode_files, summarize, write_csv, write_events_csv


def add_parser(p):
    sub = p.add_subparsers(dest="log_command", metavar="SUBCOMMAND")
    sub.required = True
    d = sub.add_parser("decode", help="decode logs: headers, summary, damage; optional CSV")
    d.add_argument("files", nargs="+", metavar="FILE", help="log files (.tpl) of one run")
    d.add_argument("--csv", metavar="OUT", help="write the control records to this CSV file, and the "
                   "events to OUT_events.csv beside it")
    d.add_argument("--events", action="store_true", help="list every event")
    d.add_argument("--json", action="store_true", help="print the summary as JSON only")
    d.set_defaults(func=cmd_decode)
    pl = sub.add_parser("plot", help="plot logs to PNG files")
    pl.add_argument("files", nargs="+", metavar="FILE", help="log files (.tpl) of one run")
    pl.add_argument("--out", required=True, metavar="DIR", help="output directory")
    pl.set_defaults(func=cmd_plot)


def _load(files):
    try:
        return decode_files(files)
    except LogError as e:
        print("trackpilot log: %s" % e, file=sys.stderr)
        return None


def cmd_decode(args):
    d = _load(args.files)
    if d is None:
        return 2
    s = summarize(d)
    if args.json:
        print(json.dumps(s, indent=1))
    else:
        for h in d.headers:
            print("header %s: session %s part %s fw %s config %s track %s reset %s utc %s"
                  % (h.file, h.get("session"), h.get("part"), h.get("fw"), h.get("config"),
                     h.get("track"), h.get("reset"), h.get("utc") or "-"))
        for k, v in s.items():
            print("%-22s %s" % (k, v))
        for x in d.damage:
            extra = " (%d control records lost)" % x.records if x.records else ""
            print("damage %s @%d: %d bytes, %s%s" % (x.file, x.offset, x.length, x.reason, extra))
    if args.events:
        for e in d.events:
            print("%10.1f  %-12s %s" % (e.t_s, e.kind, e.text))
    if args.csv:
        n = write_csv(d, args.csv)
        print("wrote %d rows to %s" % (n, args.csv), file=sys.stderr)
        ev = events_csv_path(args.csv)
        n = write_events_csv(d, ev)
        print("wrote %d events to %s" % (n, ev), file=sys.stderr)
    if d.damage:
        lost = d.lost_control
        print("trackpilot log: the log is damaged: %d report(s), %d control records lost; the records "
              "around them are decoded (see the 'damage' lines)" % (len(d.damage), lost), file=sys.stderr)
    return 0


def events_csv_path(csv_path):
    """run.csv -> run_events.csv (beside it)."""
    root, ext = os.path.splitext(csv_path)
    return root + "_events" + (ext or ".csv")


def cmd_plot(args):
    d = _load(args.files)
    if d is None:
        return 2
    if not d.controls:
        print("trackpilot log: no control records to plot", file=sys.stderr)
        return 2
    from trackpilot_tools.logplot import plot_all

    for path in plot_all(d, args.out):
        print(path)
    return 0
