"""Log outputs a person can read: CSV with names for the codes and UTC where known, an events
CSV, time in seconds since the log start across the 2^30 tick wrap, gaps drawn as gaps."""
import csv
import math
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "firmware"))

from trackpilot_tools import cli  # noqa: E402
from trackpilot_tools.logdecode import decode_files  # noqa: E402

from logseq import sailing_records, track_waypoints  # noqa: E402

GAP_AT, GAP_MS = 300, 30000


def _log_with_gap(root):
    """A session starting 60 s before the tick wrap, UTC known, with a 30 s hole after record 300."""
    from trackpilot.logger import Logger

    lg = Logger(str(root), fw_version="test")
    t0 = (1 << 30) - 60000
    lg.start(t0, reset_cause="power_on", config_hash="0123abcd", track_id="logseq",
             utc="2026-05-01T10:00:00Z")
    lg.track(track_waypoints(), "logseq")
    for i, (r, events) in enumerate(sailing_records(900, t0_ms=t0)):
        if i >= GAP_AT:
            r.t_ms = (r.t_ms + GAP_MS) & ((1 << 30) - 1)
        lg.control(r)
        for kind, text in events:
            lg.event(kind, text, r.t_ms)
        lg.tick(r.t_ms)
    lg.close()
    return sorted(str(p) for p in Path(root).rglob("*.tpl"))


def test_csv_names_utc_and_events(tmp_path, capsys):
    files = _log_with_gap(tmp_path / "log")
    out = tmp_path / "run.csv"
    assert cli.main(["log", "decode"] + files + ["--csv", str(out)]) == 0
    rows = list(csv.DictReader(open(out)))
    assert len(rows) == 900
    t = [float(r["t_s"]) for r in rows]
    assert t[0] < 1.0 and all(b >= a for a, b in zip(t, t[1:]))  # across the wrap at 60 s
    assert 29.0 < t[GAP_AT] - t[GAP_AT - 1] < 31.0
    assert rows[0]["utc"].startswith("2026-05-01T10:00:")
    assert rows[-1]["utc"] > rows[0]["utc"]
    assert {r["mode_name"] for r in rows} <= {"STANDBY", "AUTO", "ALARM", "ESTOP"}
    assert "AUTO" in {r["mode_name"] for r in rows}
    assert {r["rtk_name"] for r in rows} <= {"none", "single", "float", "fixed"}
    assert {r["pilot_mode_name"] for r in rows} - {"standby", "auto", "wind", "track", "calibration", "unknown"} == set()
    ev = list(csv.DictReader(open(tmp_path / "run_events.csv")))
    assert ev and any(e["kind"] == "MODE" for e in ev)
    assert all(e["utc"].startswith("2026-05-01T10:") for e in ev if e["kind"] != "DAMAGE")


def test_plots_leave_gaps_open(tmp_path):
    from trackpilot_tools.logplot import _gapped, plot_all

    d = decode_files(_log_with_gap(tmp_path / "log"))
    tt, xs = _gapped([c.t_s for c in d.controls], [c.xte_m for c in d.controls])
    nan_at = [i for i, x in enumerate(xs) if math.isnan(x)]
    assert len(nan_at) == 1 and tt[nan_at[0] - 1] < tt[nan_at[0]] < tt[nan_at[0] + 1]
    paths = plot_all(d, str(tmp_path / "plots"))
    assert all(Path(p).stat().st_size > 10000 for p in paths)


def test_replay_time_axis_crosses_the_wrap():
    from trackpilot_tools.replay_cmd import _time_axis

    class C:
        t_ms = (1 << 30) - 500

    class D:
        controls = [C()]

    rows = [[(1 << 30) - 300], [(1 << 30) - 100], [100], [300], [300 + 30000]]
    assert _time_axis(rows, D()) == pytest.approx([0.2, 0.4, 0.6, 0.8, 30.8])


def test_replay_of_a_log_without_control_records_explains_and_fails(tmp_path):
    import subprocess

    from trackpilot.logger import Logger

    from logseq import track_waypoints as wps

    lg = Logger(str(tmp_path / "log"), fw_version="test")
    lg.start(1000, reset_cause="power_on", config_hash="0", track_id="t")
    lg.track(wps(), "t")
    lg.event("BOOT", "booted", 1000)
    lg.close()
    files = sorted(str(p) for p in (tmp_path / "log").rglob("*.tpl"))
    r = subprocess.run([sys.executable, "-m", "trackpilot_tools.cli", "replay"] + files,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "nothing to replay: no control records could be read" in r.stderr
    assert "Traceback" not in r.stderr
