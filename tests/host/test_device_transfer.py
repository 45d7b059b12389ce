"""upload, pull and the maintenance state end to end: the real `mpremote` (as a subprocess, through
the trackpilot host tools) against the real unix-port `micropython` on a pseudo-terminal, running
the real maintenance loop (trackpilot.board.maint.supervise) around a stand-in app (_device_main.py).
The temp folder plays the board's flash root (device root '')."""
import hashlib
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))

from devpty import PtyBoard  # noqa: E402
from trackpilot_tools.device_cmd import Device, DeviceError  # noqa: E402
from trackpilot_tools.pull_cmd import pull  # noqa: E402
from trackpilot_tools.upload_cmd import upload  # noqa: E402

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)

TRACK = ROOT / "tracks" / "middelburg_loop.csv"
OLD_TRACK = "lon,lat,speed_mps\n3.6100000,51.4900000,1.0\n3.6110000,51.4910000,1.0\n"


def _sha(p):
    return hashlib.sha256(Path(p).read_bytes()).hexdigest()


def _wait_for(fn, timeout_s=5.0):
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        if fn():
            return True
        time.sleep(0.05)
    return False


@pytest.fixture
def board(tmp_path):
    made = []

    def make(mode="STANDBY", idle_s=120, limit_s=900, logs=None):
        root = tmp_path / ("flash%d" % len(made))
        (root / "tracks").mkdir(parents=True)
        (root / "log").mkdir()
        (root / "tracks" / "active.csv").write_text(OLD_TRACK)
        for name, data in (logs or {}).items():
            (root / "log" / name).write_bytes(data)
        b = PtyBoard(root, args=[mode, idle_s, limit_s])
        assert _wait_for(lambda: "RUN app run 1" in b.events()), b.close()
        made.append(b)
        return b

    yield make
    for b in made:
        err = b.close()
        assert "Traceback" not in err, err


def _dev(b):
    return Device(b.port, root="", out=open(os.devnull, "w"))


def test_upload_valid_track_lands_verified_previous_kept(board):
    b = board()
    old_sha = _sha(b.root / "tracks" / "active.csv")
    t0 = time.monotonic()
    ans = upload(_dev(b), str(TRACK), say=lambda *a: None)
    dt = time.monotonic() - t0
    assert ans["ok"] and ans["digest"] == _sha(TRACK)
    assert _sha(b.root / "tracks" / "active.csv") == _sha(TRACK)
    assert _sha(b.root / "tracks" / "previous.csv") == old_sha
    assert not (b.root / "tracks" / "upload.tmp").exists()
    # the app came back without a reset (same process, next run) and loaded the new track
    assert _wait_for(lambda: "RUN app run 2" in b.events())
    assert _wait_for(lambda: "TRACK loaded tracks/active.csv: 13 waypoints" in b.events())
    ev = b.events()
    assert "MAINT entered" in ev and "MAINT ended: resumed by the host" in ev
    assert b.alive()
    print("upload of %d bytes: %.2f s" % (TRACK.stat().st_size, dt))


def test_invalid_track_refused_before_touching_the_board(board, tmp_path):
    b = board()
    bad = tmp_path / "bad.csv"
    bad.write_text("lon,lat,speed_mps\n3.61,51.49,1.0\n3.61,91.5,1.0\n")
    before = _sha(b.root / "tracks" / "active.csv")
    dev = _dev(b)
    with pytest.raises(DeviceError) as e:
        upload(dev, str(bad), say=lambda *a: None)
    assert "line 3" in str(e.value) and "lat" in str(e.value)
    assert dev.mpremote_runs == 0 and dev.state is None  # never connected
    assert _sha(b.root / "tracks" / "active.csv") == before
    assert "MAINT" not in b.events()


def test_corrupted_transfer_is_refused_and_nothing_saved_is_lost(board):
    b = board()
    (b.root / "tracks" / "previous.csv").write_text("the previous track\n")
    active_before = _sha(b.root / "tracks" / "active.csv")
    prev_before = _sha(b.root / "tracks" / "previous.csv")

    def tamper(dev):  # one byte flipped on the "flash" between copy and verify
        p = b.root / "tracks" / "upload.tmp"
        data = bytearray(p.read_bytes())
        data[100] ^= 0x01
        p.write_bytes(bytes(data))

    with pytest.raises(DeviceError) as e:
        upload(_dev(b), str(TRACK), before_install=tamper, say=lambda *a: None)
    assert "checksum mismatch" in str(e.value)
    assert _sha(b.root / "tracks" / "active.csv") == active_before
    assert _sha(b.root / "tracks" / "previous.csv") == prev_before
    assert not (b.root / "tracks" / "upload.tmp").exists()
    assert _wait_for(lambda: "RUN app run 2" in b.events())  # maintenance ended anyway


def test_maintenance_refused_in_auto_then_granted_in_standby(board):
    b = board(mode="AUTO")
    dev = _dev(b)
    with pytest.raises(DeviceError) as e:
        upload(dev, str(TRACK), say=lambda *a: None)
    # the real app on a bench board: engaged with no pilot answering it drops to ALARM at once
    # (its defined reaction); either way it is not STANDBY, so maintenance is refused
    assert "refused" in str(e.value) and ("AUTO" in str(e.value) or "ALARM" in str(e.value))
    assert dev.mpremote_runs == 0
    assert "MAINT refused: mode AUTO" in b.events() or "MAINT refused: mode ALARM" in b.events()
    assert "STOP" not in b.events()  # the app never stopped
    assert _sha(b.root / "tracks" / "active.csv") != _sha(TRACK)
    b.set_mode("STANDBY")
    assert _wait_for(lambda: "STANDBY by a person" in b.events() or "->STANDBY" in b.events())
    upload(_dev(b), str(TRACK), say=lambda *a: None)
    assert _sha(b.root / "tracks" / "active.csv") == _sha(TRACK)


def test_maintenance_ends_by_itself_when_the_host_goes_away(board):
    b = board(idle_s=1.0)
    dev = _dev(b)
    dev.enter()
    dev.exec("print(1)")  # the host vanishes here without resume()
    assert _wait_for(lambda: "MAINT ended: no host activity for 1 s" in b.events(), 5.0)
    assert _wait_for(lambda: "RUN app run 2" in b.events())
    assert b.alive()


def test_pull_twice_then_resume_a_partial_pull(board, tmp_path):
    logs = {"0001-00.tpl": os.urandom(70000), "0002-00.tpl": os.urandom(30001), "crash.txt": b""}
    b = board(logs=logs)
    out = tmp_path / "pulled"
    t0 = time.monotonic()
    st = pull(_dev(b), out, say=lambda *a: None)
    dt = time.monotonic() - t0
    assert (st.fetched, st.skipped, st.bytes) == (3, 0, 100001)
    for name, data in logs.items():
        assert (out / name).read_bytes() == data
    print("pull of %d bytes: %.2f s (%.0f kB/s)" % (st.bytes, dt, st.bytes / dt / 1000))
    st2 = pull(_dev(b), out, say=lambda *a: None)
    assert (st2.fetched, st2.skipped, st2.bytes) == (0, 3, 0)
    # the board's session grows and a new one appears; a link that breaks after 20000 bytes
    more = os.urandom(50000)
    with open(b.root / "log" / "0002-00.tpl", "ab") as f:
        f.write(more)
    (b.root / "log" / "0003-00.tpl").write_bytes(os.urandom(40000))
    st3 = pull(_dev(b), out, max_bytes=20000, say=lambda *a: None)
    assert st3.bytes == 20000 and st3.incomplete == 2 and st3.resumed == 1
    assert (out / "0002-00.tpl.part").stat().st_size == 30001 + 20000
    st4 = pull(_dev(b), out, say=lambda *a: None)
    assert st4.bytes == 30000 + 40000 and st4.resumed == 1 and st4.fetched == 2
    assert (out / "0002-00.tpl").read_bytes() == logs["0002-00.tpl"] + more
    assert not list(out.glob("*.part"))
    assert sorted(os.listdir(b.root / "log")) == ["0001-00.tpl", "0002-00.tpl", "0003-00.tpl", "crash.txt"]


def test_pull_delete_after_only_verified(board, tmp_path):
    b = board(logs={"0001-00.tpl": os.urandom(5000)})
    out = tmp_path / "pulled"
    st = pull(_dev(b), out, delete_after=True, say=lambda *a: None)
    assert st.deleted == 1 and (out / "0001-00.tpl").stat().st_size == 5000
    assert os.listdir(b.root / "log") == []


def test_cli_errors_for_missing_device_and_bad_file(tmp_path):
    env = dict(os.environ, TRACKPILOT_PORT="/dev/nonexistent-tty")
    exe = [sys.executable, "-m", "trackpilot_tools.cli"]
    env["PYTHONPATH"] = str(ROOT / "host_tools")
    p = subprocess.run(exe + ["pull", "--out", str(tmp_path)], env=env, capture_output=True, text=True)
    assert p.returncode == 1 and "no such port /dev/nonexistent-tty" in p.stderr
    p = subprocess.run(exe + ["upload", str(tmp_path / "missing.csv")], env=env, capture_output=True, text=True)
    assert p.returncode == 1 and "cannot read" in p.stderr


def test_plain_mpremote_soft_reset_is_answered_not_performed(board):
    # mpremote without `resume` asks for a soft reset; the board must stay up, in maintenance
    b = board()
    dev = _dev(b)
    dev.enter()
    p = subprocess.run([sys.executable, "-m", "mpremote", "connect", b.port, "exec",
                        "import trackpilot.board.xfer as x; x.info()"], capture_output=True, text=True, timeout=30)
    assert p.returncode == 0 and "'maint': 'ACTIVE" in p.stdout, p.stdout + p.stderr
    dev.leave()
    assert _wait_for(lambda: "RUN app run 2" in b.events())
    assert b.events().count("RUN app run") == 2 and b.alive()


def test_upload_config_merges_validates_and_keeps_previous(board, tmp_path):
    import json

    from trackpilot_tools.upload_cmd import upload_config

    b = board()
    (b.root / "config.json").write_text(json.dumps({"ntrip": {"enabled": False}, "boat": {"name": "blik"}}))
    tuned = tmp_path / "config.json"
    tuned.write_text(json.dumps({"boat": {"min_turn_radius_m": 8.5}, "guidance": {"los_lookahead_gain": 1.4}}))
    ans, merged = upload_config(_dev(b), str(tuned), say=lambda *a: None)
    assert ans["ok"]
    on_board = json.loads((b.root / "config.json").read_text())
    assert on_board["boat"] == {"name": "blik", "min_turn_radius_m": 8.5}  # merged, nothing lost
    assert on_board["ntrip"] == {"enabled": False}
    assert on_board["guidance"]["los_lookahead_gain"] == 1.4
    assert json.loads((b.root / "config.previous.json").read_text())["boat"] == {"name": "blik"}
    assert not (b.root / "config.upload.tmp").exists()


def test_upload_config_refuses_bad_settings_and_outside_standby(board, tmp_path):
    import json

    from trackpilot_tools.upload_cmd import upload_config

    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"boat": {"min_turn_radius_m": 0.1}}))
    b = board()
    with pytest.raises(DeviceError, match="min_turn_radius_m"):
        upload_config(_dev(b), str(bad), say=lambda *a: None)
    assert not (b.root / "config.json").exists()  # the board was not touched
    good = tmp_path / "good.json"
    good.write_text(json.dumps({"boat": {"min_turn_radius_m": 8.5}}))
    b2 = board(mode="AUTO")  # the maintenance gate: STANDBY only (TRIAL too: tests/mpy/test_trial.py)
    with pytest.raises(DeviceError):
        upload_config(_dev(b2), str(good), say=lambda *a: None)
    assert not (b2.root / "config.json").exists()
