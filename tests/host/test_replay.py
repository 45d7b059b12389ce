"""Replay: a simulated run's log, rerun through the firmware core, reproduces every command."""
import glob
import subprocess
import sys

import pytest

from trackpilot_tools.mpy import ROOT
from trackpilot_tools.replay_cmd import run_replay

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)

sys.path.insert(0, str(ROOT / "firmware"))


@pytest.fixture(scope="module")
def sim_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("replay_sim")
    subprocess.run([sys.executable, "-m", "trackpilot_tools.cli", "sim", str(ROOT / "tracks/middelburg_loop.csv"),
                    "--out", str(out), "--duration-s", "150", "--no-plots", "--scenario", "current",
                    "--fault", "pilot_key_minus10@60", "--reengage-s", "70"],
                   check=True, capture_output=True, cwd=str(ROOT))
    logs = sorted(glob.glob(str(out / "fw" / "log" / "*.tpl")))
    assert logs
    return out, logs


def test_replay_reproduces_every_command(sim_run):
    out, logs = sim_run
    summary, rows = run_replay(logs, config=out / "config.json", csv=True)
    assert summary["guided"] > 300, summary
    assert summary["heading_identical"] == summary["guided"], summary
    assert summary["speed_identical"] == summary["guided"], summary
    assert len(rows) == summary["guided"]


def test_replay_with_another_law_differs(sim_run):
    out, logs = sim_run
    summary, _ = run_replay(logs, config=out / "config.json", law="seed")
    assert summary["law"] == "seed"
    assert summary["heading_identical"] < summary["guided"]
    assert summary["max_heading_diff_deg"] > 0.5


def test_replay_of_a_cut_log_reports_damage(sim_run, tmp_path):
    out, logs = sim_run
    from trackpilot.record import logfmt

    data = open(logs[0], "rb").read()
    offsets = [r.offset for r in logfmt.iter_records(data) if r.type == "control"]
    cut = tmp_path / "cut.tpl"
    cut.write_bytes(data[: offsets[len(offsets) * 2 // 3] + 3])  # 3 bytes into a control record
    summary, _ = run_replay([cut], config=out / "config.json")
    assert summary["damage"] >= 1
    assert summary["heading_identical"] == summary["guided"] > 0


def test_sim_log_decodes_and_plots(sim_run, tmp_path):
    out, logs = sim_run
    csv = tmp_path / "log.csv"
    r = subprocess.run([sys.executable, "-m", "trackpilot_tools.cli", "log", "decode", *logs, "--csv", str(csv)],
                       capture_output=True, text=True, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr
    rows = csv.read_text().splitlines()
    assert len(rows) > 700 and "lat_e7" in rows[0]
    r = subprocess.run([sys.executable, "-m", "trackpilot_tools.cli", "log", "plot", *logs, "--out", str(tmp_path / "p")],
                       capture_output=True, text=True, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr
    pngs = sorted((tmp_path / "p").glob("*.png"))
    assert len(pngs) >= 4 and all(p.stat().st_size > 10000 for p in pngs)
