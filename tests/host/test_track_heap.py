"""A 2000-waypoint track in a 110 KB heap: the firmware's modules as bytecode (.mpy, as deployed;
a frozen build needs even less), the track parsed from its file by the firmware's own loader
under MicroPython at `-X heapsize=110k`. Live heap per waypoint <= 40 B (it was ~550 B, and the
old parser could not load 500 waypoints in this heap)."""
import pytest
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
from trackpilot_tools.device_cmd import mpy_cross_cmd  # noqa: E402
from trackpilot_tools.mpy import micropython_cmd  # noqa: E402

RUN = """import sys
import track_heap
n = int(sys.argv[1])
size, live, trk = track_heap.measure(n, sys.argv[2])
print("LIVE %d %d" % (n, live))
"""


def _interpreter():
    cmd = []
    for a in micropython_cmd():  # as chosen, without a heapsize it may carry
        if a.startswith("heapsize="):
            if cmd and cmd[-1] == "-X":
                cmd.pop()
            continue
        cmd.append(a)
    return cmd


def test_2000_waypoints_load_in_110k(tmp_path):
    lib = tmp_path / "lib"
    (lib / "trackpilot").mkdir(parents=True)
    srcs = [(p, lib / "trackpilot" / (p.stem + ".mpy"), "trackpilot/" + p.name)
            for p in sorted((ROOT / "firmware" / "trackpilot").glob("*.py"))]
    srcs.append((ROOT / "firmware" / "tools" / "track_heap.py", lib / "track_heap.mpy", "track_heap.py"))
    for src, dest, name in srcs:
        subprocess.run(mpy_cross_cmd() + ["-o", str(dest), "-s", name, str(src)], check=True, capture_output=True)
    (tmp_path / "run.py").write_text(RUN)
    env = dict(os.environ, MICROPYPATH=str(lib))
    for n in (500, 2000):
        proc = subprocess.run(_interpreter() + ["-X", "heapsize=110k", str(tmp_path / "run.py"), str(n),
                                                str(tmp_path / "t.csv")],
                              env=env, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        live = int(proc.stdout.split("LIVE %d " % n)[1].split()[0])
        assert live / n <= 40.0, (n, live)


pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)
