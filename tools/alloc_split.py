"""Where the firmware's allocations go, per simulated second (docs/MEMORY.md, "GC pause").

Runs the simulator twice (D and 2D simulated seconds, so start-up cancels out) on the f32 build
(`make f32`: gcinfo.allocated() counts every allocation, freed or not, as gc.threshold does)
with tools/alloc_split_fw.py as the firmware entry, and prints bytes per simulated second for
each part and for the whole process.

Usage: .venv/bin/python tools/alloc_split.py [TRACK] [--duration-s D]   (default: the loop, 200)
"""
import argparse
import os
import re
import sys
from pathlib import Path
from tempfile import TemporaryDirectory

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "host_tools"))

from trackpilot_tools import bench_perf  # noqa: E402

F32 = ROOT / "build" / "micropython-f32" / "micropython"
LINE = re.compile(r"alloc_split: (.+?) = (\d+)$|alloc_split: total (\d+)$")


def run(track, duration_s, out):
    out.mkdir(parents=True, exist_ok=True)
    wrapper = out / "fw_entry.py"
    wrapper.write_text("import sys\nsys.path.insert(0, %r)\nsys.path.insert(0, %r)\n%s" % (
        str(ROOT / "firmware"), str(ROOT / "tools"), "import alloc_split_fw\n"))
    fig = bench_perf.run_mission({"track": str(track), "out": str(out / "run"), "wrapper": str(wrapper),
                                  "heap": None, "duration_s": duration_s})
    err = (out / "run" / "firmware_stderr.txt").read_text(errors="replace")
    parts = {}
    total = None
    for line in err.splitlines():
        m = LINE.search(line)
        if m and m.group(3):
            total = int(m.group(3))
        elif m:
            parts[m.group(1)] = parts.get(m.group(1), 0) + int(m.group(2))
    if total is None:
        sys.exit("alloc_split: the run gave no figures (%s):\n%s" % (fig.get("stop"), err[-800:]))
    return total, parts


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("track", nargs="?", default=str(ROOT / "tracks" / "middelburg_loop.csv"))
    ap.add_argument("--duration-s", type=float, default=200.0)
    a = ap.parse_args()
    if not F32.exists():
        sys.exit("alloc_split: %s missing: run `make f32` first" % F32)
    os.environ["MICROPYTHON"] = str(F32)
    d = a.duration_s
    with TemporaryDirectory() as tmp:
        t1, p1 = run(a.track, d, Path(tmp) / "short")
        t2, p2 = run(a.track, 2 * d, Path(tmp) / "long")
    print("bytes allocated per simulated second (freed or not), steady state (%g s .. %g s):" % (d, 2 * d))
    total = (t2 - t1) / d
    listed = 0.0
    for key in sorted(p2, key=lambda k: -(p2[k] - p1.get(k, 0))):
        v = (p2[key] - p1.get(key, 0)) / d
        listed += v
        print("  %8.0f B/s  %4.1f %%  %s" % (v, 100 * v / total, key))
    print("  %8.0f B/s  %4.1f %%  the rest: asyncio's scheduler, the tasks' own code, the wrappers" % (
        total - listed, 100 * (total - listed) / total))
    print("  %8.0f B/s  100 %%    the whole process" % total)


if __name__ == "__main__":
    main()
