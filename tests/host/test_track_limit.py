"""The waypoint limit (tracks/README.md): a 2000-waypoint track sails in the simulator through the
real firmware; 2001 waypoints are refused by `track check` and `upload` with a clear message."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
from trackpilot_tools import cli  # noqa: E402
from trackpilot_tools.device_cmd import DeviceError  # noqa: E402
from trackpilot_tools.sim import benchtracks  # noqa: E402
from trackpilot_tools.sim.runner import SimRun  # noqa: E402
from trackpilot_tools.upload_cmd import check_track  # noqa: E402


def zigzag(path, n_waypoints):
    """n waypoints: 12 m legs turning 20 deg left and right (a gentle slalom), without the names
    (2000 named waypoints pass the track memory budget: tests/host/test_track_budget.py)."""
    benchtracks.zigzag(str(path), 20.0, leg_m=12.0, legs=n_waypoints - 1, speed_mps=1.5)
    lines = Path(path).read_text().splitlines()
    head = [x for x in lines if x and not x.startswith("#")][0].split(",")
    k = head.index("name")
    out = []
    for x in lines:
        if x and not x.startswith("#"):
            f = x.split(",")
            x = ",".join(f[:k] + f[k + 1:])
        out.append(x)
    Path(path).write_text("\n".join(out) + "\n")
    return str(path)


def test_2001_waypoints_refused_by_check_and_upload(tmp_path, capsys):
    big = zigzag(tmp_path / "big.csv", 2001)
    rc = cli.main(["track", "check", big])
    err = capsys.readouterr().err
    assert rc == 1
    assert "line 2003: more than 2000 waypoints: the most a track may have" in err, err  # comment, header
    with pytest.raises(DeviceError, match="more than 2000 waypoints.*not uploaded"):
        check_track(big)
    ok = zigzag(tmp_path / "ok.csv", 2000)
    assert cli.main(["track", "check", ok]) == 0
    assert "2000 waypoints, 1999 legs" in capsys.readouterr().out
    trk, _ = check_track(ok)
    assert len(trk.waypoints) == 2000


def test_2000_waypoints_sail_in_the_simulator(tmp_path):
    from trackpilot_tools.logdecode import decode_files

    path = zigzag(tmp_path / "t2000.csv", 2000)
    r = SimRun(path, tmp_path / "run", seed=1, duration_s=60)
    res = r.run()
    assert res["failure"] is None, res["failure"]
    stderr = (tmp_path / "run" / "firmware_stderr.txt").read_text()
    assert "MemoryError" not in stderr
    d = decode_files(sorted((tmp_path / "run" / "fw" / "log").glob("*.tpl")))
    loaded = [e.text for e in d.events if e.kind == "TRACK" and e.text.startswith("loaded")]
    assert loaded and "2000 waypoints" in loaded[0], [e.text for e in d.events if e.kind == "TRACK"]
    assert len(d.track.waypoints) == 2000
    modes = [v for _, n, v in res["outputs"] if n == "mode"]
    assert any(m.startswith("AUTO") for m in modes), modes
    # sailing along: past several 12 m legs in the minute, close to the track
    later = [x for _, x, s, _, _ in res["truth_xte"] if s > 30.0]
    assert later and max(abs(x) for x in later) < 3.0, max(abs(x) for x in later)
    assert max(s for _, _, s, _, _ in res["truth_xte"]) > 40.0


pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)
