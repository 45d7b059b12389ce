"""`trackpilot seatalk ...`: look at SeaTalk1 traffic with the firmware's own framer and codec.

    trackpilot seatalk make-capture cap.bin              # the public vectors as 8-bit bus bytes
    trackpilot seatalk make-capture cap.txt --text       # the same in the 9-bit text form
    trackpilot seatalk make-capture cap.bin --noise 3    # with up to 3 random bytes between datagrams
    trackpilot seatalk decode cap.bin                    # one JSON object per datagram
    trackpilot seatalk decode cap.txt --odd-rule knauf

Decoding runs under MicroPython ($MICROPYTHON) in `firmware/tools/seatalk_decode.py`, so the output
is exactly what the boat's firmware makes of those bytes. Formats: docs/SEATALK.md.
"""
import random
import re
import os
import sys

from trackpilot_tools.errors import UserError, script_error_line
from trackpilot_tools.mpy import FIRMWARE_DIR, ROOT, run_script

DECODE_SCRIPT = FIRMWARE_DIR / "tools" / "seatalk_decode.py"
VECTORS = ROOT / "tests" / "data" / "seatalk" / "seatalk_vectors.txt"
_HEX2 = re.compile(r"^[0-9a-fA-F]{2}$")


def vector_datagrams(path=VECTORS):
    """Datagrams in the vectors file: runs of >= 3 two-digit hex tokens, ended by '|' or ';'
    (the file's column separators); '#' lines are comments."""
    out = []
    for line in open(path, encoding="utf-8"):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        cur = []
        for tok in line.replace("|", " | ").replace(";", " ; ").split() + ["|"]:
            if _HEX2.match(tok):
                cur.append(int(tok, 16))
                continue
            if len(cur) >= 3:
                out.append(bytes(cur))
            cur = []
    return out


def make_capture(out_path, text=False, noise=0, seed=1, vectors=VECTORS):
    """Write the vectors as a capture; returns the list of datagrams written (without noise)."""
    sys.path.insert(0, str(FIRMWARE_DIR))
    from trackpilot.devices import seatalk as st

    dgs = vector_datagrams(vectors)
    rng = random.Random(seed)
    if text:
        lines = ["# SeaTalk1 9-bit text capture made by `trackpilot seatalk make-capture` from",
                 "# tests/data/seatalk/seatalk_vectors.txt; c = byte sent with the command bit.",
                 "# @t_ms gives the time of the line's first byte (4800 Bd: 2.29 ms a byte)."]
        t = 0
        for dg in dgs:
            lines.append("@%d %s" % (t, st.to_9bit_text(dg)))
            t += int(len(dg) * 2.29) + 10
        lines.append(st.to_stalk(dgs[0]))
        with open(out_path, "w", encoding="ascii") as f:
            f.write("\n".join(lines) + "\n")
        return dgs + [dgs[0]]
    buf = bytearray()
    for dg in dgs:
        for _ in range(rng.randint(0, noise) if noise else 0):
            buf.append(rng.randint(0, 255))
        buf += dg
    with open(out_path, "wb") as f:
        f.write(bytes(buf))
    return dgs


def run_decode(path, fmt="auto", odd_rule="dotnet", gap_ms=0, byte_ms=0, timeout=600):
    args = [str(path), "--format", fmt, "--odd-rule", odd_rule, "--gap-ms", str(gap_ms),
            "--byte-ms", str(byte_ms)]
    proc = run_script(DECODE_SCRIPT, args, timeout=timeout)
    return proc.stdout.decode(), proc.stderr.decode()


def _decode(args):
    if not os.path.isfile(args.file):
        raise UserError("no such capture file: %s" % args.file)
    try:
        out, err = run_decode(args.file, args.format, args.odd_rule, args.gap_ms, args.byte_ms)
    except RuntimeError as e:
        raise UserError("decoding failed: %s" % script_error_line(e))
    sys.stdout.write(out)
    if not args.quiet:
        sys.stderr.write(err)
    return 0


def _make(args):
    dgs = make_capture(args.out, args.text, args.noise, args.seed)
    sys.stderr.write("wrote %d datagrams to %s\n" % (len(dgs), args.out))
    return 0


def add_parser(p):
    sub = p.add_subparsers(dest="seatalk_command", metavar="SUBCOMMAND")
    sub.required = True
    d = sub.add_parser("decode", help="decode a SeaTalk1 capture (8-bit binary or 9-bit text) to JSON lines")
    d.add_argument("file")
    d.add_argument("--format", choices=("auto", "bin", "text"), default="auto",
                   help="bin: raw 8-bit UART bytes; text: $STALK / per-byte 9-bit form (default: guess)")
    d.add_argument("--odd-rule", choices=("dotnet", "knauf"), default="dotnet",
                   help="odd-degree heading rule (docs/SEATALK.md)")
    d.add_argument("--gap-ms", type=int, default=0,
                   help="idle gap that ends a partial datagram (binary with --byte-ms; 0 = off)")
    d.add_argument("--byte-ms", type=int, default=0, help="time between bytes of a binary capture")
    d.add_argument("-q", "--quiet", action="store_true", help="do not print framer counters")
    d.set_defaults(func=_decode)
    m = sub.add_parser("make-capture", help="write the public test vectors as a capture file")
    m.add_argument("out")
    m.add_argument("--text", action="store_true", help="9-bit text form instead of 8-bit binary")
    m.add_argument("--noise", type=int, default=0, help="up to N random bytes before each datagram")
    m.add_argument("--seed", type=int, default=1)
    m.set_defaults(func=_make)
