"""`trackpilot gnss ...`: see what a GNSS receiver really sends, with the firmware's own parser.

    trackpilot gnss decode capture.ubx            # one JSON object per message
    trackpilot gnss decode capture.ubx --fixes    # one JSON object per completed epoch (Fix)

The decoding runs under MicroPython ($MICROPYTHON) in `firmware/tools/gnss_decode.py`, so what
you see is exactly what the boat's firmware decodes. Parser counters go to stderr.
"""
import os
import sys

from trackpilot_tools.errors import UserError, script_error_line
from trackpilot_tools.mpy import FIRMWARE_DIR, run_script

DECODE_SCRIPT = FIRMWARE_DIR / "tools" / "gnss_decode.py"


def decode_args(path, fixes=False, offset_deg=0.0, chunk=64):
    args = [str(path), "--chunk", str(chunk)]
    if fixes:
        args.append("--fixes")
    if offset_deg:
        args += ["--offset", repr(float(offset_deg))]
    return args


def run_decode(path, fixes=False, offset_deg=0.0, chunk=64, timeout=600):
    """Run the firmware decoder; returns (stdout text, stderr text)."""
    proc = run_script(DECODE_SCRIPT, decode_args(path, fixes, offset_deg, chunk), timeout=timeout)
    return proc.stdout.decode(), proc.stderr.decode()


def _decode(args):
    if not os.path.isfile(args.file):
        raise UserError("no such capture file: %s" % args.file)
    try:
        out, err = run_decode(args.file, args.fixes, args.offset, args.chunk)
    except RuntimeError as e:
        raise UserError("decoding failed: %s" % script_error_line(e))
    sys.stdout.write(out)
    if not args.quiet:
        sys.stderr.write(err)
    return 0


def add_parser(p):
    sub = p.add_subparsers(dest="gnss_command", metavar="SUBCOMMAND")
    sub.required = True
    d = sub.add_parser("decode", help="decode a raw NMEA/UBX/RTCM3 capture to JSON lines")
    d.add_argument("file", help="raw capture (gpsd-style '#' comment lines are skipped)")
    d.add_argument("--fixes", action="store_true", help="print per-epoch Fix objects instead")
    d.add_argument("--offset", type=float, default=0.0,
                   help="antenna baseline mounting offset, deg (added to the heading)")
    d.add_argument("--chunk", type=int, default=64, help="bytes per feed() call (default 64)")
    d.add_argument("-q", "--quiet", action="store_true", help="do not print parser counters")
    d.set_defaults(func=_decode)
