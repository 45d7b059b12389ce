"""`trackpilot sim` output folders are whole or marked: Ctrl-C leaves the older complete output as it
was and puts the interrupted run's files in OUT.partial/ with a note."""
import json
import signal
import subprocess
import sys
import time

from trackpilot_tools.mpy import ROOT

TRACK = str(ROOT / "tracks" / "middelburg_loop.csv")


def _sim(out, *extra, **kw):
    return subprocess.Popen([sys.executable, "-m", "trackpilot_tools.cli", "sim", TRACK, "--out", str(out),
                             "--no-plots"] + list(extra), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=str(out.parent),
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL), **kw)


def test_interrupted_run_keeps_the_complete_one(tmp_path):
    out = tmp_path / "sim_out"
    done = _sim(out, "--duration-s", "15")
    assert done.wait(timeout=120) == 0, done.stderr.read()
    before = (out / "summary.json").read_bytes()
    assert json.loads(before)["firmware_log_files"], "the firmware log lies inside the output folder"

    run = _sim(out, "--realtime", "--realtime-speed", "2", "--udp-port", "9", "--nmea-port", "9")
    time.sleep(4.0)  # the firmware is running and writing its log by now
    run.send_signal(signal.SIGINT)
    _, err = run.communicate(timeout=60)
    assert run.returncode != 0
    assert "partial output is in" in err and "Traceback" not in err, err
    assert (out / "summary.json").read_bytes() == before  # the complete output untouched
    partial = tmp_path / "sim_out.partial"
    assert "PARTIAL" in (partial / "PARTIAL.txt").read_text()
    assert not (partial / "summary.json").exists()
    assert list((partial / "fw").rglob("*.tpl")), "the interrupted run's own log is kept, apart"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim_out", "sim_out.partial"]  # no temp left

    again = _sim(out, "--duration-s", "15")  # a later complete run supersedes the partial one
    assert again.wait(timeout=120) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim_out"]
