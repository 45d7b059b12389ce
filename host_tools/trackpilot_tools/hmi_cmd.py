"""`trackpilot hmi ...`: preview the HMI pages as PNG, regenerate the reference images.

    trackpilot hmi preview --out DIR [--status FILE.json | --sample NAME | --log FILE... [--at S]]
    trackpilot hmi refs [--out tests/data/hmi]      # rewrite the main-page reference images

The pages are rendered by the real HMI code under MicroPython ($MICROPYTHON); the framebuffers come
back as hex and are turned into PNG here (Pillow), scaled so they are readable.
"""
import json
import sys
import tempfile
from pathlib import Path

from trackpilot_tools.errors import script_error_line
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


MODE_AUTO = 1
REFUSAL_SHOW_S = 5.0  # an engage refusal stays on the page this long (as the app does)


def status_from_log(paths, at_s=None):
    """HmiStatus fields (dict) at `at_s` seconds into a log (default: its last control record).

    From the control record at or before that time, the track record and the events before it.
    Not in the log: acknowledgements (sounding = all active alarms) and the AUTO sub-states."""
    from trackpilot_tools.logdecode import decode_files

    from trackpilot import geo

    d = decode_files(paths)
    if not d.controls:
        raise ValueError("no control records in the log")
    rec = d.controls[-1]
    if at_s is not None:
        for r in d.controls:
            if r.t_s > at_s:
                break
            rec = r
    t = rec.t_s
    st = {
        "mode": rec.mode, "rtk": rec.rtk, "pos_valid": rec.pos_valid, "lat_e7": rec.lat_e7,
        "lon_e7": rec.lon_e7, "num_sv": rec.num_sv, "h_acc_m": rec.h_acc_m,
        "heading_valid": rec.heading_valid, "heading_deg": rec.heading_deg,
        "heading_acc_deg": rec.heading_acc_deg, "corr_age_s": rec.corr_age_s, "sog_mps": rec.sog_mps,
        "xte_m": rec.xte_m, "leg": rec.leg, "cmd_valid": rec.mode == MODE_AUTO,
        "heading_cmd_deg": rec.heading_cmd_deg, "rpm_cmd": rec.rpm_set, "rpm": rec.rpm,
        "pilot_ok": rec.pilot_mode != 5, "pilot_mode": rec.pilot_mode,
        "compass_deg": rec.compass_deg, "locked_deg": rec.locked_deg, "keystrokes": rec.keys_sent,
        "alarms": rec.alarms, "sounding": rec.alarms, "estop_input": bool(rec.alarms & 256),
    }
    wps = d.track.waypoints if d.track is not None else []
    if len(wps) >= 2:
        st["nav_valid"] = True
        st["legs"] = len(wps) - 1
        nxt = wps[min(rec.leg + 1, len(wps) - 1)]
        st["to_wp_m"] = geo.dist_bearing(rec.lat_e7, rec.lon_e7, nxt.lat_e7, nxt.lon_e7)[0]
    hangs = 0
    for e in d.events:
        if e.t_s > t:
            break
        if e.kind == "ALARM":
            st["alarm_reason"] = e.text
        elif e.kind == "REFUSED" and t - e.t_s <= REFUSAL_SHOW_S:
            st["refusal"] = e.text.split(": ", 1)[-1]
        elif e.kind == "MODE" and "recovering" in e.text:
            hangs += 1
    st["hang_recoveries"] = hangs
    return st


def cmd_preview(args):
    status = None
    if args.sample:
        sys.path.insert(0, str(HMI_DIR))
        from tphmi.samples import SAMPLES

        if args.sample not in SAMPLES:
            print("trackpilot hmi preview: no sample %r; samples: %s" % (args.sample, ", ".join(SAMPLES)),
                  file=sys.stderr)
            return 2
    try:
        if args.status:
            status = json.loads(Path(args.status).read_text())
        elif args.log:
            status = status_from_log(args.log, args.at)
        pages = render(status=status, sample=args.sample, t_ms=args.t_ms, progress=args.progress)
    except (ValueError, RuntimeError, OSError) as e:
        # one line: a failed MicroPython renderer's own last line, not its whole output
        print("trackpilot hmi preview: %s" % script_error_line(e), file=sys.stderr)
        return 2
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
    g.add_argument("--log", nargs="+", help="log file(s) of one session: the state at --at")
    pv.add_argument("--at", type=float, help="seconds into the log (default: its end)")
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
