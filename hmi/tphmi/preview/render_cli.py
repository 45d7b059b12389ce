"""Render HMI pages under MicroPython and print the framebuffers (for `trackpilot hmi preview`).

Run with the unix port (MICROPYPATH has firmware/ and hmi/):
    micropython hmi/tphmi/preview/render_cli.py --sample auto_right
    micropython hmi/tphmi/preview/render_cli.py --status state.json [--t-ms 300] [--progress 0.5]
Output, one line per page: "PAGE <name> <width> <height> <hex of the MONO_VLSB buffer>".
The status JSON holds HmiStatus fields (docs/HMI.md); unknown fields are an error.
"""
import sys

import framebuf

from tphmi.pages import PAGE_NAMES, Pages
from tphmi.preview.samples import sample
from tphmi.status import HmiStatus

W = 128
H = 64


def hexlify(buf):
    return "".join("%02x" % b for b in buf)


def main(argv):
    st = None
    t_ms = 300
    progress = 0.0
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == "--sample":
            st = sample(argv[i + 1])
            i += 1
        elif a == "--status":
            import json

            with open(argv[i + 1]) as f:
                st = HmiStatus().update(json.load(f))
            i += 1
        elif a == "--t-ms":
            t_ms = int(argv[i + 1])
            i += 1
        elif a == "--progress":
            progress = float(argv[i + 1])
            i += 1
        else:
            raise ValueError("unknown argument %r" % a)
        i += 1
    if st is None:
        st = sample("auto_right")
    buf = bytearray(W * H // 8)
    fb = framebuf.FrameBuffer(buf, W, H, framebuf.MONO_VLSB)
    pages = Pages(fb, W, H)
    for p in range(len(PAGE_NAMES)):
        pages.render(st, p, t_ms, progress)
        print("PAGE %s %d %d %s" % (PAGE_NAMES[p], W, H, hexlify(buf)))
    pages.link_lost(12, st)
    print("PAGE %s %d %d %s" % ("link_lost", W, H, hexlify(buf)))


main(sys.argv[1:])
