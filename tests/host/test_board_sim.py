"""`trackpilot board-sim`: a unix-port board on a pty that upload and pull work against."""
import re
import subprocess
import sys
import time

from trackpilot_tools.mpy import ROOT


def test_upload_and_pull_against_board_sim(tmp_path):
    log = tmp_path / "0007-00.tpl"
    log.write_bytes(bytes(range(256)) * 40)
    sim = subprocess.Popen([sys.executable, "-m", "trackpilot_tools.cli", "board-sim", "--root", str(tmp_path / "flash"),
                            "--stand-in", "--logs", str(log), "--duration", "60"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(tmp_path))
    try:
        first = sim.stdout.readline()
        m = re.search(r"on (/dev/pts/\d+)", first)
        assert m, first + sim.stderr.read()
        port = m.group(1)
        cli = [sys.executable, "-m", "trackpilot_tools.cli"]
        up = subprocess.run(cli + ["upload", str(ROOT / "tracks/middelburg_loop.csv"), "--port", port,
                                   "--device-root", ""], capture_output=True, text=True, timeout=60)
        assert up.returncode == 0, up.stdout + up.stderr
        assert (tmp_path / "flash" / "tracks" / "active.csv").read_bytes() == (ROOT / "tracks/middelburg_loop.csv").read_bytes()
        pull = subprocess.run(cli + ["pull", "--port", port, "--device-root", "", "--out", str(tmp_path / "got")],
                              capture_output=True, text=True, timeout=60)
        assert pull.returncode == 0, pull.stdout + pull.stderr
        assert (tmp_path / "got" / "0007-00.tpl").read_bytes() == log.read_bytes()
    finally:
        sim.terminate()
        sim.wait(timeout=10)
