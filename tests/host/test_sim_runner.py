"""The lockstep driver against a minimal MicroPython firmware that uses the real simio adapter:
stepping, inputs, SeaTalk writes reaching the simulated pilot, motor frames driving the boat,
determinism of the truth trace, faults and the reset."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
from trackpilot_tools.sim.runner import SimRun  # noqa: E402

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)

FAKE = ROOT / "tests" / "host" / "_fake_fw_mpy.py"
TRACK = ROOT / "tracks" / "middelburg_loop.csv"


def run(tmp_path, name, seed=1, **kw):
    kw.setdefault("duration_s", 30)
    r = SimRun(TRACK, tmp_path / name, seed=seed, fw_script=FAKE, **kw)
    return r, r.run()


def test_engage_keys_motor_and_speed(tmp_path):
    r, res = run(tmp_path, "a")
    assert res["failure"] is None and res["stop_reason"] == "time limit"
    assert res["sim_s"] == pytest.approx(30.0, abs=0.3)
    # ENGAGE pressed once the fix is fixed and the pilot talks; the Auto key reached the pilot
    assert [e for e in res["events"] if e[1] == "input"][0][2] == "button=ENGAGE"
    assert res["pilot_keys_accepted"] == 2 and r.pilot.mode == 2
    assert r.pilot.keys_by_sender == {1: 2}
    assert res["bus"]["fw_chars"] == 8 and res["bus"]["collisions"] == 0
    # 400 RPM -> about 1 m/s through the motor controller and the surge lag
    assert r.boat.u_mps == pytest.approx(1.0, abs=0.05)
    assert res["gnss_epochs"] == pytest.approx(150, abs=2)
    lines = (tmp_path / "a" / "truth.csv").read_text().splitlines()
    assert len(lines) == 1 + 150 and "auto" in lines[-1]
    assert res["speedup"] > 20


def test_same_seed_same_truth_other_seed_differs(tmp_path):
    run(tmp_path, "s1", seed=7, scenario="gusts")
    run(tmp_path, "s2", seed=7, scenario="gusts")
    run(tmp_path, "s3", seed=8, scenario="gusts")
    a, b, c = ((tmp_path / n / "truth.csv").read_text() for n in ("s1", "s2", "s3"))
    assert a == b
    assert a != c


def test_faults_reach_the_devices(tmp_path):
    r, res = run(tmp_path, "f", faults=["gnss_dropout@10:3", "pilot_key_standby@20", "motor_link_loss@22:8"])
    rows = (tmp_path / "f" / "truth.csv").read_text().splitlines()
    assert any(",none," in row for row in rows)  # the dropout
    assert r.pilot.mode == 0 and r.pilot.keys_by_sender.get(0) is None  # own key not heard by itself
    # the controller's failsafe stops the motor when setpoints stop arriving
    assert r.motor.rpm < 100
    assert ("fault" in {e[1] for e in res["events"]})


def test_reset_restarts_the_firmware(tmp_path):
    r, res = run(tmp_path, "r", faults=["reset@12"])
    assert res["resets"] == 1 and res["failure"] is None
    assert [o for o in res["outputs"] if o[1] == "mode"][-1][2] == "STANDBY"
    assert r.pilot.mode == 2  # the pilot is left as it was


def test_esp_idf_style_rx_timeout_batches_bus_bytes(tmp_path):
    r, res = run(tmp_path, "b", duration_s=8, overrides={"seatalk": {"rx_timeout_chars": 10}})
    assert res["failure"] is None and r.pilot.mode == 2  # the Auto key still got through
    r1, res1 = run(tmp_path, "b1", duration_s=8)
    # 8 status datagrams of 4 + 9 bytes: one step per byte, or one per datagram
    assert res1["steps"] - res["steps"] >= 8 * 11


def test_realtime_mode_paces_to_the_wall_clock(tmp_path):
    r, res = run(tmp_path, "rt", duration_s=2.0, realtime=True, realtime_speed=4.0)
    assert res["wall_s"] >= 0.45 and res["speedup"] < 4.5


def test_relative_out_dir_reaches_the_firmware(tmp_path, monkeypatch):
    """The firmware runs with the repository as its working directory: a relative output folder
    must still give it its config.json and data folder (it silently ran on the defaults)."""
    monkeypatch.chdir(tmp_path)
    r = SimRun(TRACK, "rel", seed=1, duration_s=20, fw_config={"guidance": {"los_lookahead_gain": 4.0}})
    r.run()
    assert list((tmp_path / "rel" / "fw" / "log").glob("*.tpl"))
    err = (tmp_path / "rel" / "firmware_stderr.txt").read_text()
    assert "defaults" not in err
