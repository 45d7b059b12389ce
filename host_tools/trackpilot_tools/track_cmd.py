"""`trackpilot track ...`: check track files with the firmware's own track module.

    trackpilot track check tracks/middelburg_loop.csv
    trackpilot track check my.csv --turn-radius 10 --strict

`check` prints the legs (length, bearing, turn at the leg's end, speed, time), the total length
and the expected duration, then the warnings (corners sharper than the boat can turn, with the
expected deviation; very slow legs). A file that does not parse prints `FILE: line N: message`
on stderr and exits 1; `--strict` also exits 1 (code 2) when there are warnings.

The parsing and validation are firmware/trackpilot/nav/track.py, imported here under CPython (the
same code the boat runs), so a file that passes here loads on the boat.
"""
import sys

from trackpilot_tools.mpy import FIRMWARE_DIR

if str(FIRMWARE_DIR) not in sys.path:
    sys.path.insert(0, str(FIRMWARE_DIR))

from trackpilot.nav import track as fw_track  # noqa: E402


def _duration_text(s):
    s = int(round(s))
    if s >= 3600:
        return "%d h %02d min %02d s" % (s // 3600, s % 3600 // 60, s % 60)
    return "%d min %02d s" % (s // 60, s % 60)


def check_text(text, boat, min_leg_m=fw_track.MIN_LEG_M, max_speed_mps=fw_track.MAX_SPEED_MPS):
    """(Track, warnings) or raises fw_track.TrackError."""
    trk = fw_track.parse_track_csv(text, min_leg_m=min_leg_m, max_speed_mps=max_speed_mps)
    return trk, fw_track.validate(trk, boat)


def format_report(path, trk, warnings, boat):
    wps = trk.waypoints
    lines = ["track %s: %d waypoints, %d legs" % (path, len(wps), len(trk.legs)), ""]
    lines.append("%4s  %-18s %-18s %9s %8s %9s %7s %7s"
                 % ("leg", "from", "to", "length_m", "bearing", "turn_end", "speed", "time_s"))
    for leg in trk.legs:
        a = wps[leg.i]
        b = wps[leg.i + 1]
        turn = "%+9.1f" % leg.turn_deg if leg.i + 1 < len(trk.legs) else "%9s" % "end"
        lines.append("%4d  %-18s %-18s %9.1f %8.1f %s %7.2f %7.0f" % (
            leg.i, (a.name or "wp %d" % leg.i)[:18], (b.name or "wp %d" % (leg.i + 1))[:18],
            leg.length_m, leg.bearing_deg, turn, leg.speed_mps, leg.length_m / leg.speed_mps))
    lines.append("")
    dur = trk.duration_s()
    lines.append("total length %.1f m, expected duration %s (%.0f s) at the legs' speeds"
                 % (trk.length_m, _duration_text(dur), dur))
    lines.append("bearings: true, deg at the leg's start; turn_end: + to starboard; speed: m/s")
    if warnings:
        lines.append("")
        lines.append("%d warning%s (turning radius %.1f m):" % (
            len(warnings), "" if len(warnings) == 1 else "s", boat["turn_radius_m"]))
        for w in warnings:
            lines.append("  " + w)
    else:
        lines.append("no warnings (turning radius %.1f m)" % boat["turn_radius_m"])
    return "\n".join(lines) + "\n"


def _check(args):
    boat = dict(fw_track.BOAT_DEFAULTS)
    boat["turn_radius_m"] = args.turn_radius
    boat["corner_tol_m"] = args.corner_tol
    try:
        with open(args.file, "rb") as f:
            data = f.read()
    except OSError as e:
        sys.stderr.write("%s: %s\n" % (args.file, e.strerror or e))
        return 1
    try:
        trk, warnings = check_text(data, boat, args.min_leg, args.max_speed)
    except fw_track.TrackError as e:
        sys.stderr.write("%s: %s\n" % (args.file, e))
        return 1
    sys.stdout.write(format_report(args.file, trk, warnings, boat))
    if warnings and args.strict:
        return 2
    return 0


def add_parser(p):
    sub = p.add_subparsers(dest="track_command", metavar="SUBCOMMAND")
    sub.required = True
    c = sub.add_parser("check", help="validate a track CSV and print its legs")
    c.add_argument("file", help="track CSV (format: tracks/README.md)")
    c.add_argument("--turn-radius", type=float, default=fw_track.BOAT_DEFAULTS["turn_radius_m"],
                   help="the boat's minimum turning radius, m (default %(default)s)")
    c.add_argument("--corner-tol", type=float, default=fw_track.BOAT_DEFAULTS["corner_tol_m"],
                   help="warn when a corner costs more cross-track error than this, m (default %(default)s)")
    c.add_argument("--min-leg", type=float, default=fw_track.MIN_LEG_M,
                   help="shortest leg that can be steered, m (default %(default)s)")
    c.add_argument("--max-speed", type=float, default=fw_track.MAX_SPEED_MPS,
                   help="highest plausible speed, m/s (default %(default)s)")
    c.add_argument("--strict", action="store_true", help="exit 2 when there are warnings")
    c.set_defaults(func=_check)
    from trackpilot_tools import track_import

    track_import.add_import_parser(sub)
