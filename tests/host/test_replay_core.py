"""Replay of the whole decision core (firmware/tools/replay_core.py, `trackpilot replay --journal`):
a simulator run with faults, takeovers and re-engagements, its journal fed to a fresh core, and
100 % of the control records (keystrokes, RPM setpoints, modes), core events (mode changes with
their reasons) and SeaTalk bus actions reproduced. A changed setting is caught."""
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
from trackpilot_tools.logdecode import decode_files  # noqa: E402
from trackpilot_tools.replay_cmd import run_core_replay  # noqa: E402
from trackpilot_tools.sim.runner import SimRun  # noqa: E402

LOOP = ROOT / "tracks" / "middelburg_loop.csv"
FAULTS = ["pilot_key_standby@60", "gnss_dropout@90:4", "motor_link_loss@120:6", "heading_loss@150:3",
          "estop@180:2", "button_ack@186", "button_engage@190", "pilot_hang_steer@205:8"]


def _run(out, **kw):
    r = SimRun(LOOP, out, journal=True, **kw)
    res = r.run()
    assert res["failure"] is None, res["failure"]
    logs = sorted((Path(out) / "fw" / "log").glob("*.tpl"))
    return logs, Path(out) / "config.json", Path(out) / "fw" / "journal.txt"


@pytest.fixture(scope="module")
def faulted(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("core") / "run", seed=3, faults=FAULTS, duration_s=240, reengage_s=5)


def test_every_decision_of_a_faulted_run_is_reproduced(faulted):
    logs, cfg, journal = faulted
    rc, s, bad = run_core_replay(logs, cfg, journal)
    assert rc == 0 and bad == [], bad
    n = s["records"]
    assert n == len(decode_files(logs).controls) > 1000
    assert s["records_identical"] == s["keys_identical"] == s["rpm_identical"] == s["mode_identical"] == n
    assert s["events_identical"] == s["events"]
    assert s["mode_changes_identical"] == s["mode_changes"] >= 10  # takeover, re-engage, DR, ALARM, ESTOP ...
    assert s["bus_actions"] > 1000 and s["motor_frames"] > 1000
    d = decode_files(logs)
    assert d.controls[-1].keys_sent > 100  # keystrokes were sent, and each one was reproduced
    kinds = {e.text.split(":")[0] for e in d.events if e.kind == "PILOT"}
    assert {"TAKEOVER", "HANG", "RECOVERED"} <= kinds, kinds


def test_a_changed_setting_is_caught(faulted, tmp_path):
    logs, cfg, journal = faulted
    changed = json.loads(cfg.read_text())
    motor = changed.setdefault("motor", {})
    motor["rpm_per_mps"] = motor.get("rpm_per_mps", 500) + 10
    path = tmp_path / "changed.json"
    path.write_text(json.dumps(changed))
    rc, s, bad = run_core_replay(logs, path, journal)
    assert rc == 1 and bad
    assert s["rpm_identical"] < s["records"] and s["mismatches"] > 0


def test_a_reset_and_the_restored_leg_are_reproduced(tmp_path):
    logs, cfg, journal = _run(tmp_path / "reset", seed=6, faults=["reset@50", "pilot_key_standby@80"],
                              duration_s=120, reengage_s=4)
    assert len(logs) == 2 and sum(1 for ln in journal.read_text().splitlines() if ln.startswith("B ")) == 2
    rc, s, bad = run_core_replay(logs, cfg, journal)
    assert rc == 0 and bad == [], bad
    assert s["records_identical"] == s["records"] > 500 and s["events_identical"] == s["events"]
