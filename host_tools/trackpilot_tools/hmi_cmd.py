"""`trackpilot hmi ...`: preview the HMI pages as PNG, regenerate the reference images.

    trackpilot hmi preview --out DIR [--status FILE.json | --sample NAME] [--scale 4]
    trackpilot hmi refs [--out tests/data/hmi]      # rewrite the main-page reference images

The pages are rendered by the real HMI code under MicroPython ($MICROPYTHON); the framebuffers come
back as hex and are turned into PNG here (Pillow), scaled so they are readable.
"""
import json
import sys
import tempfile
from pathlib import Path

from trackpilot_tools.mpy import HMI_DIR, ROOT, run_script

RENDER_SCRIPT = HMI_DIR / "tphmi" / "render_cli.py"
REF_DIR = ROOT / "tests" / "data" / "hmi"
# Samples whose main page is kept as a reference image (tests/mpy/test_hmi_pages.py compares).
REF_SAMPLES = ("auto_right", "auto_left_far", "standby_refused", "estop")


def render(status=None, sample=None, t_ms=300, progress=0.0):
    """Render every page; returns {page name: (width, height, MONO_VLSB bytes)}."""
    args = ["--t-ms", str(t_ms), "--progress", str(progress)]
    tmp = None
    if status is not None:
        tmp = tempfile.NamedTemporaryFile("w", suffix=".json", delete=False)
        json.dump(status, tmp)
        tmp.close()
        args += ["--status", tmp.name]
    elif sample:
        args += ["--sample", sample]
    try:
        proc = run_script(RENDER_SCRIPT, args, timeout=60)
    finally:
        if tmp:
            Path(tmp.name).unlink()
    pages = {}
    for line in proc.stdout.decode().splitlines():
        parts = line.split()
        if len(parts) == 5 and parts[0] == "PAGE":
            pages[parts[1]] = (int(parts[2]), int(parts[3]), bytes.fromhex(parts[4]))
    if not pages:
        raise RuntimeError("renderer printed no pages:\n" + proc.stdout.decode()[-2000:])
    return pages


def vlsb_pixels(w, h, buf):
    """MONO_VLSB buffer -> list of rows of 0/1."""
    return [[(buf[(y >> 3) * w + x] >> (y & 7)) & 1 for x in range(w)] for y in range(h)]


def to_png(w, h, buf, path, scale=4):
    from PIL import Image

    img = Image.new("L", (w, h))
    px = vlsb_pixels(w, h, buf)
    # OLED look: light blue-white pixels on black, as grey levels
    img.putdata([255 if v else 0 for row in px for v in row])
    img = img.resize((w * scale, h * scale), Image.NEAREST)
    img.save(path)


def to_pbm(w, h, buf):
    """MONO_VLSB buffer -> binary PBM (P4) bytes (1 = lit pixel)."""
    px = vlsb_pixels(w, h, buf)
    out = bytearray(b"P4\n%d %d\n" % (w, h))
    for row in px:
        for x0 in range(0, w, 8):
            b = 0
            for k in range(8):
                if x0 + k < w and row[x0 + k]:
                    b |= 0x80 >> k
            out.append(b)
    return bytes(out)


def cmd_preview(args):
    status = None
    if args.status:
        status = json.loads(Path(args.status).read_text())
    pages = render(status=status, sample=args.sample, t_ms=args.t_ms, progress=args.progress)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, (w, h, buf) in pages.items():
        path = out / ("hmi_%s.png" % name)
        to_png(w, h, buf, path, scale=args.scale)
        print(path)
    return 0


def cmd_refs(args):
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for s in REF_SAMPLES:
        w, h, buf = render(sample=s)["main"]
        path = out / ("main_%s.pbm" % s)
        path.write_bytes(to_pbm(w, h, buf))
        print(path)
    return 0


def add_parser(p):
    sub = p.add_subparsers(dest="hmi_command", metavar="SUBCOMMAND")
    sub.required = True
    pv = sub.add_parser("preview", help="write every HMI page as PNG")
    pv.add_argument("--out", required=True, help="output directory")
    g = pv.add_mutually_exclusive_group()
    g.add_argument("--status", help="JSON file with HmiStatus fields (default: a built-in state)")
    g.add_argument("--sample", help="a built-in state from tphmi/samples.py (default auto_right)")
    pv.add_argument("--t-ms", type=int, default=300, help="time for blinking elements (ms)")
    pv.add_argument("--progress", type=float, default=0.0, help="AUTO hold progress 0..1 to draw")
    pv.add_argument("--scale", type=int, default=4, help="pixel scale of the PNG (default 4)")
    pv.set_defaults(func=cmd_preview)
    rf = sub.add_parser("refs", help="regenerate the main-page reference images (PBM)")
    rf.add_argument("--out", default=str(REF_DIR))
    rf.set_defaults(func=cmd_refs)


if __name__ == "__main__":
    from trackpilot_tools.cli import main

    sys.exit(main(["hmi"] + sys.argv[1:]))
